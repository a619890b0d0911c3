//! Sums of absolute differences (SAD) of byte images with run-time CPU
//! dispatch, in safe code.
//!
//! The kernels compare a template with frame windows one template row at a
//! time: each row is split into vector-wide chunks (16 bytes with SSE2, 32
//! with AVX2, 64 with AVX-512BW) and one `psadbw` per chunk sums the
//! absolute differences of the chunk's bytes into 64-bit lanes. The
//! template rows are copied once, zero-padded to whole chunks, and the frame
//! bytes past the row's end are masked off, so every path gives exactly the
//! integer SAD of the scalar reference ([`SimdLevel::Scalar`]).
//!
//! The instruction sets are chosen at run time through
//! [`crate::simd`] (the `pulp` crate's tokens, which check the CPU once and
//! make the intrinsics safe to call; this crate keeps
//! `unsafe_code = "forbid"`). Each kernel is written once, generic over the
//! vector width ([`x86::Lanes`]), and instantiated per level.

use crate::ImageView;
use crate::simd::{Kernel, SimdLevel, Token};

/// Bytes per vector chunk of a template row at `level`.
fn chunk_width(level: SimdLevel, row_len: usize) -> usize {
    match level {
        SimdLevel::Scalar => 1,
        SimdLevel::Sse2 => 16,
        SimdLevel::Avx2 => 32,
        SimdLevel::Avx512 if row_len <= 32 => 32,
        SimdLevel::Avx512 => 64,
    }
}

/// A `u8` template prepared for the SAD kernels: rows zero-padded to whole
/// vector chunks, and the mask of each chunk's valid bytes. Reusable:
/// [`SadTemplate::set`] keeps the buffers, so a warm template does not
/// allocate.
#[derive(Clone, Debug)]
pub struct SadTemplate {
    level: SimdLevel,
    /// Bytes per template row (width times channels).
    row_len: usize,
    rows: usize,
    /// Vector chunks per row and their width in bytes.
    chunks: usize,
    width: usize,
    padded: Vec<u8>,
    masks: Vec<u8>,
    /// Under AVX-512 with one 32-byte chunk per row: each padded row twice
    /// (64 bytes), for the kernel that runs two windows per `vpsadbw`.
    doubled: Vec<u8>,
    /// Under AVX2, gray rows of 1 to [`QUAD_MAX`] bytes but those
    /// [`narrow_takes`]: each row cut into groups of four 4-byte blocks
    /// (zero-padded), each group's 16 bytes stored twice (32 bytes, one copy
    /// per 128-bit lane), for the `vmpsadbw` kernel ([`x86::quads`]).
    quads: Vec<u8>,
}

/// The longest gray row (bytes) the AVX2 `vmpsadbw` kernel takes.
const QUAD_MAX: usize = 128;

/// Whether the AVX2 `vpsadbw` batches of gray windows ([`x86::narrow`])
/// take a template of `rows` rows of `n` bytes: rows of 11 to 32 bytes (the
/// column sums of the bytes past the row need at most 32 columns), at most
/// 257 of them (those 16-bit column sums cannot wrap). They run in about
/// 0.9 the time of the `vmpsadbw` kernel on Zen 3 (which then is not
/// used): there `vmpsadbw` issues on one pipe only, one every two cycles
/// (64 absolute differences), and bounds that kernel, where `vpsadbw`
/// (32) issues on two pipes, two a cycle, and the batches are bound by
/// the accumulating adds, the `vpalignr` or the loads beside it (about 8
/// cycles a row of ten windows, against 10 for the `vmpsadbw` kernel).
fn narrow_takes(n: usize, rows: usize) -> bool {
    (11..=32).contains(&n) && (1..=257).contains(&rows)
}

impl Default for SadTemplate {
    fn default() -> Self {
        Self::new(SimdLevel::detect())
    }
}

impl SadTemplate {
    /// An empty template that will run at `level`, or at the best level
    /// this CPU has if `level` is not available here.
    pub fn new(level: SimdLevel) -> Self {
        let level = level.or_best();
        Self {
            level,
            row_len: 0,
            rows: 0,
            chunks: 0,
            width: 1,
            padded: Vec::new(),
            masks: Vec::new(),
            doubled: Vec::new(),
            quads: Vec::new(),
        }
    }

    /// The level the kernels run at.
    pub fn level(&self) -> SimdLevel {
        self.level
    }

    /// Bytes per template row (width times channels).
    pub fn row_len(&self) -> usize {
        self.row_len
    }

    /// Template rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Copies `template` in (its rows padded to whole vector chunks).
    pub fn set(&mut self, template: ImageView<'_, u8>) {
        let n = template.width() * template.channels();
        let w = chunk_width(self.level, n);
        let chunks = n.div_ceil(w);
        self.row_len = n;
        self.rows = template.height();
        self.chunks = chunks;
        self.width = w;
        self.padded.clear();
        self.padded.resize(self.rows * chunks * w, 0);
        for r in 0..self.rows {
            let start = r * chunks * w;
            self.padded[start..start + n].copy_from_slice(template.row(r));
        }
        self.masks.clear();
        self.masks.resize(chunks * w, 0);
        self.masks[..n].fill(0xff);
        self.doubled.clear();
        if self.level == SimdLevel::Avx512 && chunks == 1 && w == 32 {
            for r in 0..self.rows {
                let row = &self.padded[r * 32..(r + 1) * 32];
                self.doubled.extend_from_slice(row);
                self.doubled.extend_from_slice(row);
            }
            self.masks.extend_from_within(..32);
        }
        self.quads.clear();
        if self.level == SimdLevel::Avx2
            && template.channels() == 1
            && (1..=QUAD_MAX).contains(&n)
            && !narrow_takes(n, self.rows)
        {
            let groups = n.div_ceil(16);
            self.quads.resize(self.rows * groups * 32, 0);
            for r in 0..self.rows {
                for (g, part) in template.row(r).chunks(16).enumerate() {
                    let o = (r * groups + g) * 32;
                    self.quads[o..o + part.len()].copy_from_slice(part);
                    self.quads[o + 16..o + 16 + part.len()].copy_from_slice(part);
                }
            }
        }
    }

    /// The integer SAD between the template and the frame window whose
    /// first byte is `frame[start]` (rows `stride` apart), stopping after
    /// the first group of rows whose partial sum exceeds `limit` (the
    /// partial sum is returned then, still above `limit`).
    ///
    /// # Panics
    /// If the window's rows leave `frame`.
    pub fn sad_at(&self, frame: &[u8], stride: usize, start: usize, limit: u32) -> u32 {
        if !self.fits(frame, stride, start) {
            return self.sad_scalar(frame, stride, start, limit);
        }
        // Rows of one 32-byte chunk under AVX-512 take the AVX2 kernel.
        let level = match (self.level, self.width) {
            (SimdLevel::Avx512, 64) => SimdLevel::Avx512,
            (SimdLevel::Avx512, _) => SimdLevel::Avx2,
            (level, _) => level,
        };
        level.run(&Window {
            t: self,
            f: frame,
            stride,
            start,
            limit,
        })
    }

    /// SADs between the template and the windows of `frame` with top-left
    /// corners `(x0 + k, y)` for `k < out.len()`, into `out`.
    ///
    /// # Panics
    /// If a window leaves the frame or the channel counts make the template
    /// rows longer than the frame's.
    pub fn sad_windows(&self, frame: ImageView<'_, u8>, x0: usize, y: usize, out: &mut [u32]) {
        let ch = frame.channels();
        assert!(
            (x0 + out.len()) * ch + self.row_len <= frame.width() * ch + ch
                && y + self.rows <= frame.height(),
            "sad_windows: a window leaves the frame"
        );
        let data = frame.as_slice();
        let stride = frame.stride();
        let start = y * stride + x0 * ch;
        let mut windows = Windows {
            t: self,
            f: data,
            stride,
            start,
            step: ch,
            out,
        };
        if self.level == SimdLevel::Avx2 && ch == 1 && (self.chunks == 1 || !self.quads.is_empty())
        {
            // its own dispatched function, so that the other paths' code
            // stays as it was (the colour surface took 2% more
            // instructions with both in one)
            self.level.run(&mut Narrow(windows));
        } else {
            self.level.run(&mut windows);
        }
    }

    /// SADs between the template and the windows of `frame` with top-left
    /// corners `(x0 + k, y + r)` for `k < width` and `r < out.len() /
    /// width`, into `out[r * width + k]`: [`SadTemplate::sad_windows`] for
    /// several rows at once (the same sums). Under AVX2, gray templates of
    /// rows of 11 to 32 bytes (at most 257 of them) share each frame row's
    /// loads between two rows of windows, which takes about 0.9 the time of
    /// row by row on Zen 3.
    ///
    /// # Panics
    /// If `width` is 0 or does not divide `out.len()`, or as
    /// [`SadTemplate::sad_windows`] for any of the rows.
    pub fn sad_window_rows(
        &self,
        frame: ImageView<'_, u8>,
        x0: usize,
        y: usize,
        width: usize,
        out: &mut [u32],
    ) {
        assert!(
            width > 0 && out.len().is_multiple_of(width),
            "sad_window_rows: out is not whole rows of width {width}"
        );
        let rows = out.len() / width;
        if rows == 0 {
            return;
        }
        let ch = frame.channels();
        assert!(
            (x0 + width) * ch + self.row_len <= frame.width() * ch + ch
                && y + rows - 1 + self.rows <= frame.height(),
            "sad_window_rows: a window leaves the frame"
        );
        if self.level == SimdLevel::Avx2 && ch == 1 && narrow_takes(self.row_len, self.rows) {
            let stride = frame.stride();
            self.level.run(&mut Rows {
                t: self,
                f: frame.as_slice(),
                stride,
                start: y * stride + x0,
                width,
                out,
            });
        } else {
            for (r, o) in out.chunks_exact_mut(width).enumerate() {
                self.sad_windows(frame, x0, y + r, o);
            }
        }
    }

    /// Whether the padded rows of the window at `start` stay inside `frame`
    /// (the bytes past each row's end are read, then masked off).
    #[inline(always)]
    fn fits(&self, frame: &[u8], stride: usize, start: usize) -> bool {
        self.rows == 0 || start + (self.rows - 1) * stride + self.chunks * self.width <= frame.len()
    }

    /// The scalar reference (also used where padded reads would leave the
    /// buffer). Stops after the first row whose partial sum exceeds `limit`.
    fn sad_scalar(&self, frame: &[u8], stride: usize, start: usize, limit: u32) -> u32 {
        let n = self.row_len;
        let mut s = 0u32;
        for r in 0..self.rows {
            let t = &self.padded[r * self.chunks * self.width..][..n];
            let f = &frame[start + r * stride..][..n];
            s += t
                .iter()
                .zip(f)
                .map(|(&a, &b)| u32::from(a.abs_diff(b)))
                .sum::<u32>();
            if s > limit {
                break;
            }
        }
        s
    }
}

/// `sum |a_k - b_k|` over two byte slices of equal length (the shorter
/// length if they differ), at the best level this CPU has.
pub fn sad_u8(a: &[u8], b: &[u8]) -> u32 {
    sad_u8_at(SimdLevel::detect(), a, b)
}

/// [`sad_u8`] at a given level (the best available one if `level` is not).
pub fn sad_u8_at(level: SimdLevel, a: &[u8], b: &[u8]) -> u32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    level.run(Slices { a, b })
}

/// One window's SAD, stopping past a limit ([`SadTemplate::sad_at`]).
/// Run by reference, as [`Windows`].
struct Window<'a> {
    t: &'a SadTemplate,
    f: &'a [u8],
    stride: usize,
    start: usize,
    limit: u32,
}

impl Kernel for &Window<'_> {
    type Output = u32;
    #[inline(always)]
    fn run<T: Token>(self, token: T) -> u32 {
        let (t, f, stride, start, limit) = (self.t, self.f, self.stride, self.start, self.limit);
        #[cfg(target_arch = "x86_64")]
        {
            use x86::{Avx2, Avx512, Sse2, window};
            if let Some(s) = token.avx512() {
                return window(Avx512(s), t, f, stride, start, limit);
            }
            if let Some(s) = token.avx2() {
                return window(Avx2(s), t, f, stride, start, limit);
            }
            if let Some(s) = token.sse2() {
                return window(Sse2(s), t, f, stride, start, limit);
            }
        }
        let _ = token;
        t.sad_scalar(f, stride, start, limit)
    }
}

/// Consecutive windows `step` bytes apart, no limit
/// ([`SadTemplate::sad_windows`]). Run by reference: passed by value, its
/// eight words go to the dispatched function in registers, and the loops
/// then took 1% more instructions (callgrind) than through a pointer.
struct Windows<'a> {
    t: &'a SadTemplate,
    f: &'a [u8],
    stride: usize,
    start: usize,
    step: usize,
    out: &'a mut [u32],
}

impl Kernel for &mut Windows<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        let (t, f, stride, start, step) = (self.t, self.f, self.stride, self.start, self.step);
        let out = &mut *self.out;
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = token.avx512() {
                return x86::windows_avx512(s, t, f, stride, start, step, out);
            }
            if let Some(s) = token.avx2() {
                return x86::windows_avx2(s, t, f, stride, start, step, out);
            }
            if let Some(s) = token.sse2() {
                return x86::windows_sse2(s, t, f, stride, start, step, out);
            }
        }
        let _ = token;
        for (k, o) in out.iter_mut().enumerate() {
            *o = t.sad_scalar(f, stride, start + k * step, u32::MAX);
        }
    }
}

/// Gray [`Windows`] under AVX2 with rows of at most [`QUAD_MAX`] bytes:
/// the unmasked `vpsadbw` batches of [`x86::narrow`] for the templates it
/// takes ([`narrow_takes`]), the `vmpsadbw` batches of [`x86::quads`] for
/// the others.
struct Narrow<'a>(Windows<'a>);

impl Kernel for &mut Narrow<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        #[cfg(target_arch = "x86_64")]
        if let (None, Some(s)) = (token.avx512(), token.avx2()) {
            let w = &mut self.0;
            return x86::windows_avx2_narrow(s, w.t, w.f, w.stride, w.start, w.out);
        }
        (&mut self.0).run(token)
    }
}

/// Rows of windows of width `width` for [`SadTemplate::sad_window_rows`]
/// (gray, under AVX2, templates [`narrow_takes`]).
struct Rows<'a> {
    t: &'a SadTemplate,
    f: &'a [u8],
    stride: usize,
    start: usize,
    width: usize,
    out: &'a mut [u32],
}

impl Kernel for &mut Rows<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        let (t, f, stride, start, width) = (self.t, self.f, self.stride, self.start, self.width);
        #[cfg(target_arch = "x86_64")]
        if let (None, Some(s)) = (token.avx512(), token.avx2()) {
            return x86::windows_avx2_rows(s, t, f, stride, start, width, self.out);
        }
        let _ = token;
        for (r, o) in self.out.chunks_exact_mut(width).enumerate() {
            for (k, o) in o.iter_mut().enumerate() {
                *o = t.sad_scalar(f, stride, start + r * stride + k, u32::MAX);
            }
        }
    }
}

/// Rows of windows [`x86::multi`] runs at once.
const MULTI_ROWS: usize = 2;

/// The SAD of two equal-length slices ([`sad_u8_at`]).
struct Slices<'a> {
    a: &'a [u8],
    b: &'a [u8],
}

impl Kernel for Slices<'_> {
    type Output = u32;
    #[inline(always)]
    fn run<T: Token>(self, token: T) -> u32 {
        let Slices { a, b } = self;
        #[cfg(target_arch = "x86_64")]
        {
            use x86::{Avx2, Avx512, Sse2, slices};
            if let Some(s) = token.avx512() {
                return slices(Avx512(s), a, b);
            }
            if let Some(s) = token.avx2() {
                return slices(Avx2(s), a, b);
            }
            if let Some(s) = token.sse2() {
                return slices(Sse2(s), a, b);
            }
        }
        let _ = token;
        abs_diff_sum(a, b)
    }
}

/// `sum |a_k - b_k|`, one byte at a time.
#[inline(always)]
fn abs_diff_sum(a: &[u8], b: &[u8]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| u32::from(x.abs_diff(y)))
        .sum()
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The x86-64 kernels: one `psadbw` per chunk, 64-bit lane sums.
    use core::arch::x86_64::{__m128i, __m256i, __m512i};

    use pulp::bytemuck::cast;
    use pulp::x86::{V1, V3, V4};

    use super::SadTemplate;

    /// `psadbw` and the few operations around it at one vector width.
    pub(super) trait Lanes: Copy {
        /// The vector.
        type V: Copy;
        /// Bytes per vector.
        const W: usize;
        /// All lanes zero.
        fn zero(self) -> Self::V;
        /// The `W` bytes of `s` from `o`.
        fn ld(self, s: &[u8], o: usize) -> Self::V;
        /// Bitwise and.
        fn and(self, a: Self::V, b: Self::V) -> Self::V;
        /// `psadbw`: sums of absolute byte differences, per 8 bytes, into
        /// 64-bit lanes.
        fn sad(self, a: Self::V, b: Self::V) -> Self::V;
        /// 64-bit lane addition.
        fn add(self, a: Self::V, b: Self::V) -> Self::V;
        /// The sum of the 64-bit lanes (in lane order).
        fn hsum(self, v: Self::V) -> u32;
    }

    /// A [`Lanes`] type over a `pulp` token: the struct and its impl.
    macro_rules! lanes {
        ($(#[$doc:meta])* $name:ident($token:ty), $v:ty, $w:literal, $words:literal,
         $zf:ident.$zero:ident, $af:ident.$and:ident, $sf:ident.$sad:ident, $df:ident.$add:ident) => {
            $(#[$doc])*
            #[derive(Clone, Copy)]
            pub(super) struct $name(pub $token);

            impl Lanes for $name {
                type V = $v;
                const W: usize = $w;
                #[inline(always)]
                fn zero(self) -> $v {
                    self.0.$zf.$zero()
                }
                #[inline(always)]
                fn ld(self, s: &[u8], o: usize) -> $v {
                    let a: [u8; $w] = s[o..o + $w].try_into().unwrap();
                    cast(a)
                }
                #[inline(always)]
                fn and(self, a: $v, b: $v) -> $v {
                    self.0.$af.$and(a, b)
                }
                #[inline(always)]
                fn sad(self, a: $v, b: $v) -> $v {
                    self.0.$sf.$sad(a, b)
                }
                #[inline(always)]
                fn add(self, a: $v, b: $v) -> $v {
                    self.0.$df.$add(a, b)
                }
                #[inline(always)]
                fn hsum(self, v: $v) -> u32 {
                    let l: [u64; $words] = cast(v);
                    l.iter().sum::<u64>() as u32
                }
            }
        };
    }

    lanes!(
        /// 16-byte vectors (SSE2).
        Sse2(V1), __m128i, 16, 2,
        sse2._mm_setzero_si128, sse2._mm_and_si128, sse2._mm_sad_epu8, sse2._mm_add_epi64
    );
    lanes!(
        /// 32-byte vectors (AVX2).
        Avx2(V3), __m256i, 32, 4,
        avx._mm256_setzero_si256, avx2._mm256_and_si256, avx2._mm256_sad_epu8, avx2._mm256_add_epi64
    );
    lanes!(
        /// 64-byte vectors (AVX-512F and BW).
        Avx512(V4), __m512i, 64, 8,
        avx512f._mm512_setzero_si512, avx512f._mm512_and_si512, avx512bw._mm512_sad_epu8,
        avx512f._mm512_add_epi64
    );

    /// One window: rows in groups of four between limit checks (vector
    /// chunks of the template's width, which is `L::W`).
    #[inline(always)]
    pub(super) fn window<L: Lanes>(
        l: L,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        limit: u32,
    ) -> u32 {
        let (w, nc) = (t.width, t.chunks);
        let mut total = 0u32;
        let mut r = 0;
        while r < t.rows {
            let end = (r + 4).min(t.rows);
            let mut acc = l.zero();
            for rr in r..end {
                let fo = start + rr * stride;
                let to = rr * nc * w;
                for c in 0..nc {
                    let fv = l.and(l.ld(f, fo + c * w), l.ld(&t.masks, c * w));
                    acc = l.add(acc, l.sad(fv, l.ld(&t.padded, to + c * w)));
                }
            }
            total += l.hsum(acc);
            if total > limit {
                break;
            }
            r = end;
        }
        total
    }

    /// Consecutive windows (`step` bytes apart), no limit: `$nb` windows
    /// at a time in registers when `step` is 1 or 3 (one bounds check per
    /// row and chunk for all of them), the rest one by one. `$l` gives the
    /// vector operations, `$w` is its width (a literal: it sizes arrays).
    macro_rules! windows {
        ($l:expr, $t:ident, $f:ident, $stride:ident, $start:ident, $step:ident,
         $out:ident, $w:literal, $nb:literal) => {{
            let l = $l;
            let nc = $t.chunks;
            let mut k = 0;
            macro_rules! batch {
                ($s:literal) => {
                    while k + $nb <= $out.len() {
                        let base = $start + k * $s;
                        if !$t.fits($f, $stride, base + ($nb - 1) * $s) {
                            break;
                        }
                        let mut acc = [l.zero(); $nb];
                        for r in 0..$t.rows {
                            for c in 0..nc {
                                let o = base + r * $stride + c * $w;
                                let blk: &[u8; $w + ($nb - 1) * $s] =
                                    $f[o..o + $w + ($nb - 1) * $s].try_into().unwrap();
                                let m = l.ld(&$t.masks, c * $w);
                                let tv = l.ld(&$t.padded, (r * nc + c) * $w);
                                for (j, a) in acc.iter_mut().enumerate() {
                                    let fv = l.and(l.ld(blk, j * $s), m);
                                    *a = l.add(*a, l.sad(fv, tv));
                                }
                            }
                        }
                        for (o, a) in $out[k..k + $nb].iter_mut().zip(acc) {
                            *o = l.hsum(a);
                        }
                        k += $nb;
                    }
                };
            }
            if $step == 1 {
                batch!(1);
            } else if $step == 3 {
                batch!(3);
            }
            for (kk, o) in $out.iter_mut().enumerate().skip(k) {
                let base = $start + kk * $step;
                if !$t.fits($f, $stride, base) {
                    *o = $t.sad_scalar($f, $stride, base, u32::MAX);
                    continue;
                }
                let mut acc = l.zero();
                for r in 0..$t.rows {
                    let fo = base + r * $stride;
                    let to = r * nc * $w;
                    for c in 0..nc {
                        let fv = l.and(l.ld($f, fo + c * $w), l.ld(&$t.masks, c * $w));
                        acc = l.add(acc, l.sad(fv, l.ld(&$t.padded, to + c * $w)));
                    }
                }
                *o = l.hsum(acc);
            }
        }};
    }
    /// [`windows!`] with 16-byte vectors, eight windows at a time.
    #[inline(always)]
    pub(super) fn windows_sse2(
        simd: V1,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        step: usize,
        out: &mut [u32],
    ) {
        windows!(Sse2(simd), t, f, stride, start, step, out, 16, 8);
    }

    /// [`windows!`] with 32-byte vectors, eight windows at a time.
    #[inline(always)]
    pub(super) fn windows_avx2(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        step: usize,
        out: &mut [u32],
    ) {
        windows!(Avx2(simd), t, f, stride, start, step, out, 32, 8);
    }

    /// [`windows_avx2`] for gray windows (`step` 1) with rows of at most
    /// [`super::QUAD_MAX`] bytes: sixty-four then thirty-two windows at a
    /// time by `vmpsadbw` ([`quads`]) or, for the templates
    /// [`super::narrow_takes`] (which have no `quads` rows), [`NARROW`]
    /// windows at a time by `vpsadbw` ([`narrow`]); the rest as
    /// [`windows_avx2`].
    #[inline(always)]
    pub(super) fn windows_avx2_narrow(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        out: &mut [u32],
    ) {
        let done = if t.quads.is_empty() {
            0
        } else {
            quads(simd, t, f, stride, start, out)
        };
        let (start, out) = (start + done, &mut out[done..]);
        let done = if t.chunks == 1 && t.width == 32 {
            narrow(simd, t, f, stride, start, out)
        } else {
            0
        };
        let (start, out, step) = (start + done, &mut out[done..], 1);
        windows!(Avx2(simd), t, f, stride, start, step, out, 32, 8);
    }

    /// Windows per batch of [`quads`].
    const QUADS: usize = 32;

    /// Gray windows with rows of 1 to [`super::QUAD_MAX`] bytes under
    /// AVX2, [`QUADS`] consecutive ones at a time, by `vmpsadbw`: per
    /// 128-bit lane it sums the absolute differences of one 4-byte block of
    /// the template row with the frame bytes at eight consecutive offsets
    /// (eight 16-bit sums). A 32-byte frame load at `p` thus advances the
    /// windows `p .. p + 8` (low lane) and `p + 16 .. p + 24` (high lane)
    /// by one block, and the load at `p + 8` the other sixteen; each load
    /// serves two blocks (the instruction's frame offset 0 or 4). One
    /// `vmpsadbw` does the work of two 32-byte `vpsadbw` (64 absolute
    /// differences) and needs no horizontal sum. A row of `n` bytes takes
    /// `ceil(n / 4)` blocks; the zero padding of the last block also
    /// counts the frame bytes past the row (`|f - 0| = f`), which are
    /// summed down the rows with no shuffle (see [`quads_g`]) and
    /// subtracted once per group of rows. The 16-bit sums wrap, which is
    /// exact as long as the true sum fits: they are widened to 32 bits
    /// every `65535 / (255 n)` rows. Returns how many windows it did (a
    /// multiple of [`QUADS`], stopping where the reads would leave `f`).
    #[inline(always)]
    pub(super) fn quads(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        out: &mut [u32],
    ) -> usize {
        let n = t.row_len;
        if t.rows == 0 || !(1..=super::QUAD_MAX).contains(&n) {
            return 0;
        }
        // One copy per number of 16-byte groups of a row: the group loop
        // unrolls and a row's loads are at constant offsets into
        // fixed-size arrays (one bounds check a row, where the general loop
        // took three a group and kept its state on the stack).
        // Sixty-four windows a batch first (the template row's loads, the
        // row's bounds check and the loop serve twice the windows), then
        // thirty-two.
        macro_rules! runs {
            ($g:literal) => {{
                let k = quads_g::<$g, { 16 * $g + 64 }, { 32 * $g }, 2>(
                    simd, t, f, stride, start, out, 0,
                );
                quads_g::<$g, { 16 * $g + 32 }, { 32 * $g }, 1>(simd, t, f, stride, start, out, k)
            }};
        }
        match n.div_ceil(16) {
            1 => runs!(1),
            2 => runs!(2),
            3 => runs!(3),
            4 => runs!(4),
            5 => runs!(5),
            6 => runs!(6),
            7 => runs!(7),
            8 => runs!(8),
            _ => 0,
        }
    }

    /// Adds the 32 bytes `v` (byte `i` to sum `i`) to 32 sums of 16 bits
    /// kept without widening shuffles: `raw` adds them as sixteen 16-bit
    /// words (wrapping: low byte plus 256 times the high byte), `odd`
    /// their high bytes (the odd sums). [`columns`] separates them.
    #[inline(always)]
    fn add_columns(simd: V3, raw: &mut __m256i, odd: &mut __m256i, v: __m256i) {
        let avx2 = simd.avx2;
        *raw = avx2._mm256_add_epi16(*raw, v);
        *odd = avx2._mm256_add_epi16(*odd, avx2._mm256_srli_epi16::<8>(v));
    }

    /// The 32 sums of [`add_columns`], modulo 2^16: the even ones are
    /// `raw - 256 odd`, interleaved with the odd ones into sums
    /// `0..8 | 16..24` and `8..16 | 24..32` (the order of the `vmpsadbw`
    /// window sums).
    #[inline(always)]
    fn columns(simd: V3, raw: __m256i, odd: __m256i) -> (__m256i, __m256i) {
        let avx2 = simd.avx2;
        let even = avx2._mm256_sub_epi16(raw, avx2._mm256_slli_epi16::<8>(odd));
        (
            avx2._mm256_unpacklo_epi16(even, odd),
            avx2._mm256_unpackhi_epi16(even, odd),
        )
    }

    /// [`quads`] for rows of `G` 16-byte groups, `H` batches of
    /// [`QUADS`] windows side by side (`SPAN = 16 G + 32 H`: the bytes a
    /// row's loads reach past the first window; `Q = 32 G`: a row of
    /// [`SadTemplate::quads`]), from window `k`; returns where it stopped.
    ///
    /// The frame bytes under the padding (columns `n .. n + pad` of each
    /// window; byte `i` of the 32-byte load at `n + q` is window `i`'s) are
    /// summed without widening shuffles, which compete with `vmpsadbw` for
    /// the same port ([`add_columns`]); modulo 2^16 is all the 16-bit
    /// window sums need, and one interleave per group of rows
    /// ([`columns`]) puts them in the order of the `vmpsadbw` sums.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn quads_g<const G: usize, const SPAN: usize, const Q: usize, const H: usize>(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        out: &mut [u32],
        mut k: usize,
    ) -> usize {
        debug_assert!(SPAN == 16 * G + 32 * H && Q == 32 * G);
        let avx2 = simd.avx2;
        let l = Avx2(simd);
        let n = t.row_len;
        let blocks = n.div_ceil(4);
        // Blocks in the last group (1 to 4).
        let last = blocks - 4 * (G - 1);
        let pad = 4 * blocks - n;
        // Rows whose 16-bit sums cannot exceed 65535.
        let run = 65535 / (255 * n);
        let zero = l.zero();
        macro_rules! m {
            ($imm:literal, $f:expr, $t:expr) => {
                avx2._mm256_mpsadbw_epu8::<$imm>($f, $t)
            };
        }
        let add = |a, b| avx2._mm256_add_epi16(a, b);
        let (tq_rows, _) = t.quads.as_chunks::<Q>();
        while k + H * QUADS <= out.len() {
            let base = start + k;
            if base + (t.rows - 1) * stride + SPAN > f.len() {
                break;
            }
            // 32-bit sums of each batch, windows [0..4 | 16..20],
            // [4..8 | 20..24], [8..12 | 24..28], [12..16 | 28..32].
            let mut w = [[zero; 4]; H];
            let mut r0 = 0;
            while r0 < t.rows {
                let r1 = (r0 + run).min(t.rows);
                // 16-bit sums, windows [0..8 | 16..24] and [8..16 | 24..32].
                let (mut a, mut b) = ([zero; H], [zero; H]);
                // The padded columns' bytes ([`add_columns`]).
                let (mut raw, mut odd) = ([zero; H], [zero; H]);
                // The frame from the row's first byte: stepped by `stride`
                // (two compares a row, no multiply and no overflow check).
                let mut from = &f[base + r0 * stride..];
                for tq in &tq_rows[r0..r1] {
                    let row: &[u8; SPAN] = from[..SPAN].try_into().unwrap();
                    from = from.get(stride..).unwrap_or_default();
                    let mut lo: [_; H] = core::array::from_fn(|h| l.ld(row, 32 * h));
                    for g in 0..G {
                        let tv = l.ld(tq, 32 * g);
                        for h in 0..H {
                            let p = 32 * h + 16 * g;
                            let mid = l.ld(row, p + 8);
                            if g + 1 < G || last == 4 {
                                let hi = l.ld(row, p + 16);
                                let a01 = add(m!(0o00, lo[h], tv), m!(0o55, lo[h], tv));
                                let a23 = add(m!(0o22, mid, tv), m!(0o77, mid, tv));
                                let b01 = add(m!(0o00, mid, tv), m!(0o55, mid, tv));
                                let b23 = add(m!(0o22, hi, tv), m!(0o77, hi, tv));
                                a[h] = add(a[h], add(a01, a23));
                                b[h] = add(b[h], add(b01, b23));
                                lo[h] = hi;
                            } else {
                                a[h] = add(a[h], m!(0o00, lo[h], tv));
                                b[h] = add(b[h], m!(0o00, mid, tv));
                                if last > 1 {
                                    a[h] = add(a[h], m!(0o55, lo[h], tv));
                                    b[h] = add(b[h], m!(0o55, mid, tv));
                                }
                                if last > 2 {
                                    let hi = l.ld(row, p + 16);
                                    a[h] = add(a[h], m!(0o22, mid, tv));
                                    b[h] = add(b[h], m!(0o22, hi, tv));
                                }
                            }
                        }
                    }
                    // Byte i of the load at n + q is window i's column n + q
                    // (unrolled: a loop took three more instructions a row).
                    for q in 0..3 {
                        if q < pad {
                            for (h, (raw, odd)) in raw.iter_mut().zip(&mut odd).enumerate() {
                                add_columns(simd, raw, odd, l.ld(row, 32 * h + n + q));
                            }
                        }
                    }
                }
                for h in 0..H {
                    let (mut a, mut b) = (a[h], b[h]);
                    if pad > 0 {
                        let (pa, pb) = columns(simd, raw[h], odd[h]);
                        a = avx2._mm256_sub_epi16(a, pa);
                        b = avx2._mm256_sub_epi16(b, pb);
                    }
                    let w = &mut w[h];
                    w[0] = avx2._mm256_add_epi32(w[0], avx2._mm256_unpacklo_epi16(a, zero));
                    w[1] = avx2._mm256_add_epi32(w[1], avx2._mm256_unpackhi_epi16(a, zero));
                    w[2] = avx2._mm256_add_epi32(w[2], avx2._mm256_unpacklo_epi16(b, zero));
                    w[3] = avx2._mm256_add_epi32(w[3], avx2._mm256_unpackhi_epi16(b, zero));
                }
                r0 = r1;
            }
            for (h, w) in w.into_iter().enumerate() {
                let sums: [[u32; 8]; 4] = [
                    cast(avx2._mm256_permute2x128_si256::<0x20>(w[0], w[1])),
                    cast(avx2._mm256_permute2x128_si256::<0x20>(w[2], w[3])),
                    cast(avx2._mm256_permute2x128_si256::<0x31>(w[0], w[1])),
                    cast(avx2._mm256_permute2x128_si256::<0x31>(w[2], w[3])),
                ];
                let sums: [u32; QUADS] = cast(sums);
                let o = k + h * QUADS;
                out[o..o + QUADS].copy_from_slice(&sums);
            }
            k += H * QUADS;
        }
        k
    }

    /// Windows per batch of [`narrow`] (the windows `narrow_rows` unrolls;
    /// at most 16, as the `vpalignr` shifts stay within 16-byte lanes).
    /// Ten measured best on Zen 3: twelve accumulators spilled two to the
    /// stack, eight paid the row's loads, bounds check and column sums for
    /// fewer windows.
    const NARROW: usize = 10;

    /// Gray windows with rows of 11 to 32 bytes under AVX2 (the templates
    /// [`super::narrow_takes`]), [`NARROW`] consecutive ones at a time,
    /// with no mask: each window's 32-byte `vpsadbw` against the
    /// zero-padded row also counts the `32 - n` frame bytes past the row's
    /// end (`|f - 0| = f`), and those are taken off afterwards from column
    /// sums of the frame (one 32-byte load, two 16-bit adds and a shift a
    /// row for the whole batch, where the mask cost an `and` a window and
    /// row).
    /// Exact: the integer sums are the same. Each window's bytes are
    /// loaded where rows are a multiple of 64 bytes apart and none of the
    /// batch's loads crosses a cache line (about a third of the batches);
    /// elsewhere they are built with `vpalignr` ([`narrow_rows`]), since
    /// a load per window, unaligned, crossed a line for about half of the
    /// windows, and such loads ran at a fraction of the rate of the others
    /// (Zen 3). Returns how many windows it did (a multiple of [`NARROW`],
    /// stopping where the reads would leave `f`); none for the templates
    /// it does not take.
    #[inline(always)]
    fn narrow(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        out: &mut [u32],
    ) -> usize {
        let n = t.row_len;
        if !super::narrow_takes(n, t.rows) {
            return 0;
        }
        // The bytes each window counts past its row: columns j + n .. j + 32.
        let pad = 32 - n;
        let l = Avx2(simd);
        let avx2 = simd.avx2;
        // Where the frame lies in memory: which loads cross a cache line.
        let addr = f.as_ptr() as usize;
        let mut k = 0;
        while k + NARROW <= out.len() {
            let base = start + k;
            // Each row reads 64 bytes from the batch's first window.
            if base + (t.rows - 1) * stride + 64 > f.len() {
                break;
            }
            // Every row of the batch at the same place in its cache line
            // (rows a multiple of 64 bytes apart), and every window's load
            // inside one line: loads, no vpalignr.
            let direct = stride.is_multiple_of(64) && (addr + base) % 64 <= 32 - (NARROW - 1);
            let (acc, raw, odd) = if direct {
                narrow_rows::<true>(simd, t, f, stride, base)
            } else {
                narrow_rows::<false>(simd, t, f, stride, base)
            };
            // Each window's sum: four accumulators' 64-bit lanes added up
            // at a time (six shuffles and three adds, where each alone took
            // three extractions and three adds).
            let mut quad = [l.zero(); NARROW.div_ceil(4) * 4];
            quad[..NARROW].copy_from_slice(&acc);
            let mut sums = [l.zero(); NARROW.div_ceil(4)];
            for (s, q) in sums.iter_mut().zip(quad.as_chunks::<4>().0) {
                let [a, b, c, d] = *q;
                // [a0 + a1, b0 + b1 | a2 + a3, b2 + b3], the same of c, d.
                let ab = avx2._mm256_add_epi64(
                    avx2._mm256_unpacklo_epi64(a, b),
                    avx2._mm256_unpackhi_epi64(a, b),
                );
                let cd = avx2._mm256_add_epi64(
                    avx2._mm256_unpacklo_epi64(c, d),
                    avx2._mm256_unpackhi_epi64(c, d),
                );
                *s = avx2._mm256_add_epi64(
                    avx2._mm256_permute2x128_si256::<0x20>(ab, cd),
                    avx2._mm256_permute2x128_si256::<0x31>(ab, cd),
                );
            }
            let sums: [[u64; 4]; NARROW.div_ceil(4)] = cast(sums);
            // The column sums, exact modulo 2^16 (at most 257 rows of 255),
            // in column order. Window j counts columns j .. j + pad (a
            // sliding sum).
            let (c0, c1) = columns(simd, raw, odd);
            let cols: [u16; 32] = cast([
                avx2._mm256_permute2x128_si256::<0x20>(c0, c1),
                avx2._mm256_permute2x128_si256::<0x31>(c0, c1),
            ]);
            let mut past: u32 = cols[..pad].iter().map(|&c| u32::from(c)).sum();
            for (j, (o, s)) in out[k..k + NARROW]
                .iter_mut()
                .zip(sums.as_flattened())
                .enumerate()
            {
                *o = *s as u32 - past;
                past = past + u32::from(cols[j + pad]) - u32::from(cols[j]);
            }
            k += NARROW;
        }
        k
    }

    /// The row loop of a [`narrow`] batch from `f[base]`: the windows'
    /// `vpsadbw` sums, and the column sums ([`add_columns`]) of the bytes
    /// past the first window's row. `DIRECT`: each window's 32 bytes loaded
    /// (where no load crosses a cache line); otherwise window `j` is
    /// `vpalignr` by `j` of the 32 bytes at the first window and those 16
    /// further (per 128-bit lane, the bytes `j .. j + 16` of the lanes'
    /// concatenation), two loads a row for the batch. The loads are about
    /// as fast as `vpalignr` where none crosses a line: the direct batches
    /// took some 4% less time over the surface (mixing the two in one
    /// batch, five windows loaded and four shifted, took more).
    #[inline(always)]
    fn narrow_rows<const DIRECT: bool>(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        base: usize,
    ) -> ([__m256i; NARROW], __m256i, __m256i) {
        let n = t.row_len;
        let l = Avx2(simd);
        let avx2 = simd.avx2;
        let mut acc = [l.zero(); NARROW];
        // Column sums of the bytes n .. n + 32 past the first window's row.
        let (mut raw, mut odd) = (l.zero(), l.zero());
        // The template's rows as arrays and the frame from the row's first
        // byte, stepped by `stride`, as in quads_g: two compares a row, no
        // multiply (the loop is bound by the instructions it issues).
        let (t_rows, _) = t.padded.as_chunks::<32>();
        let mut from = &f[base..];
        for tq in &t_rows[..t.rows] {
            let blk: &[u8; 64] = from[..64].try_into().unwrap();
            from = from.get(stride..).unwrap_or_default();
            let tv = l.ld(tq, 0);
            // Window j's 32 bytes (vpalignr's shift is an immediate: one
            // arm a window, unrolled).
            let (f0, f16) = (l.ld(blk, 0), l.ld(blk, 16));
            macro_rules! each_window {
                ($($j:literal)*) => {$(
                    {
                        let v = if DIRECT {
                            l.ld(blk, $j)
                        } else if $j == 0 {
                            f0
                        } else {
                            avx2._mm256_alignr_epi8::<$j>(f16, f0)
                        };
                        acc[$j] = l.add(acc[$j], l.sad(v, tv));
                    }
                )*};
            }
            const _: () = assert!(NARROW == 10, "one window a literal below");
            each_window!(0 1 2 3 4 5 6 7 8 9);
            add_columns(simd, &mut raw, &mut odd, l.ld(blk, n));
        }
        (acc, raw, odd)
    }

    /// [`super::SadTemplate::sad_window_rows`] under AVX2 for the
    /// templates [`super::narrow_takes`]: each group of
    /// [`super::MULTI_ROWS`] rows of windows by [`multi`] (for templates of
    /// at least that many rows), then the windows it left in each row, and
    /// the rows of a last, smaller group, as [`windows_avx2_narrow`].
    #[inline(always)]
    pub(super) fn windows_avx2_rows(
        simd: V3,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        width: usize,
        out: &mut [u32],
    ) {
        const S: usize = super::MULTI_ROWS;
        let rows = out.len() / width;
        // multi's accumulators, zeroed once for all its calls (3 KiB).
        let mut accs = [[Avx2(simd).zero(); MULTI_PIECE8]; S];
        for r in (0..rows).step_by(S) {
            let done = if r + S <= rows && t.rows >= S {
                multi(
                    simd,
                    &mut accs,
                    t,
                    f,
                    stride,
                    start + r * stride,
                    width,
                    &mut out[r * width..][..S * width],
                )
            } else {
                0
            };
            for rr in r..(r + S).min(rows) {
                let o = &mut out[rr * width..(rr + 1) * width];
                windows_avx2_narrow(
                    simd,
                    t,
                    f,
                    stride,
                    start + rr * stride + done,
                    &mut o[done..],
                );
            }
        }
    }

    /// Windows per row of a [`multi`] batch built by `vpalignr` (a piece's
    /// last windows; with two rows of windows: six accumulators, the two
    /// loads, two template rows and the shifted windows fill the 16 vector
    /// registers: four windows spilled an accumulator).
    const MULTI_W: usize = 3;

    /// Windows per row of a [`multi`] batch whose windows are loaded
    /// (twelve accumulators and two template rows; seven windows spilled
    /// an accumulator and took 1.2 times as long over the surface).
    const MULTI_DW: usize = 6;

    /// Most windows per row of a [`multi`] piece (whole batches): the
    /// column sums of its frame bytes past the rows (columns `n .. piece +
    /// 31` of the piece's first window, `n >= 11`) fit in two 32-byte
    /// loads.
    const MULTI_PIECE: usize = 44;

    /// [`MULTI_PIECE`] rounded up to whole groups of eight windows (the
    /// vectors of [`multi`]'s last pass).
    const MULTI_PIECE8: usize = MULTI_PIECE.div_ceil(8) * 8;

    /// [`super::MULTI_ROWS`] rows of gray windows (rows `stride` apart
    /// from `start`, `width` windows a row, into `out[r * width + k]`)
    /// under AVX2, for the templates [`super::narrow_takes`] with at least
    /// that many rows: [`narrow`]'s unmasked `vpsadbw` sums, in batches of
    /// consecutive windows of each row where a frame row's windows serve
    /// every row of windows that meets it (against the template row each
    /// needs), so that loading them is shared ([`multi_rows`]): batches
    /// of [`MULTI_DW`] windows, each window's 32 bytes loaded (a load
    /// serves two `vpsadbw`), then batches of [`MULTI_W`] built by
    /// `vpalignr` for the piece's last windows. Pieces of at most
    /// [`MULTI_PIECE`] windows: the frame bytes past the rows (`|f - 0| =
    /// f`) are taken off from their column sums, summed once a piece (the
    /// frame rows all rows of windows share once for all of them), and the
    /// batches' accumulators are kept until the piece's end, then added up
    /// and corrected eight windows a vector. Returns how many windows of
    /// each row it did (whole batches, stopping where the reads would leave
    /// `f`); it may have written scratch into up to seven windows of each
    /// row past those, for the caller to overwrite. `accs` is scratch.
    ///
    /// On Zen 3 (2026-12-04) the gray MAD surface of a 30x20 template
    /// over 320x240 took about 0.38 ms this way against 0.43 ms row by row
    /// ([`narrow`]). Unlike there, the loads that cross a cache line did
    /// not slow the batches down (loaded batches of four only where none
    /// crossed, `vpalignr` batches elsewhere, took as long as loaded
    /// batches of four everywhere, and the batches of six are faster
    /// still): the loop is bound by the front end (about six instructions
    /// a cycle: a frame row's `vpsadbw` and `vpaddq`, its loads and the
    /// loop's bounds checks). The rest is the first and last frame rows,
    /// the column sums and the last pass. Three rows of windows were
    /// slower (loaded batches of three windows 0.40 ms, of four 0.46 ms:
    /// out of registers).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn multi(
        simd: V3,
        accs: &mut [[__m256i; MULTI_PIECE8]; super::MULTI_ROWS],
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        width: usize,
        out: &mut [u32],
    ) -> usize {
        const S: usize = super::MULTI_ROWS;
        const W: usize = MULTI_W;
        const P: usize = MULTI_PIECE;
        let (n, th) = (t.row_len, t.rows);
        if !super::narrow_takes(n, th) || th < S {
            return 0;
        }
        let pad = 32 - n;
        let l = Avx2(simd);
        let avx2 = simd.avx2;
        let zero = l.zero();
        let (t_rows, _) = t.padded.as_chunks::<32>();
        let t_rows = &t_rows[..th];
        // `accs`: each window's accumulator (four 64-bit lanes) until the
        // piece's end; past the piece's windows, stale or zero lanes nobody
        // reads.
        const DW: usize = MULTI_DW;
        let mut k = 0;
        while k + W <= width {
            let len = (width - k).min(P);
            let base = start + k;
            // The last frame row's reads: the column loads reach n + 64
            // bytes (at most 96) from the piece's first window, the
            // batches' 48 bytes from the last batch's.
            if base + (th + S - 2) * stride + 96 > f.len() {
                break;
            }
            // Batches of DW windows loaded, then W built by vpalignr for
            // the piece's last windows.
            let mut b = 0;
            while b < len {
                if b + DW <= len {
                    let acc = multi_rows::<DW, true>(simd, t_rows, f, stride, base + b);
                    for (accs, acc) in accs.iter_mut().zip(acc) {
                        accs[b..b + DW].copy_from_slice(&acc);
                    }
                    b += DW;
                } else if b + W <= len {
                    let acc = multi_rows::<W, false>(simd, t_rows, f, stride, base + b);
                    for (accs, acc) in accs.iter_mut().zip(acc) {
                        accs[b..b + W].copy_from_slice(&acc);
                    }
                    b += W;
                } else {
                    break;
                }
            }
            let len = b;
            // Column sums of the bytes n .. n + 64 from the piece's first
            // window: the frame rows every row of windows has (S - 1 ..
            // th), then each row's own. (A macro: a closure is not compiled
            // for AVX2.)
            macro_rules! col_row {
                ($raw:ident, $odd:ident, $r:expr) => {{
                    let o = base + $r * stride + n;
                    let blk: &[u8; 64] = f[o..o + 64].try_into().unwrap();
                    add_columns(simd, &mut $raw[0], &mut $odd[0], l.ld(blk, 0));
                    add_columns(simd, &mut $raw[1], &mut $odd[1], l.ld(blk, 32));
                }};
            }
            let (mut raw, mut odd) = ([zero; 2], [zero; 2]);
            for r in S - 1..th {
                col_row!(raw, odd, r);
            }
            for s in 0..S {
                let (mut raw, mut odd) = (raw, odd);
                for r in (s..S - 1).chain(th..th + s) {
                    col_row!(raw, odd, r);
                }
                let (c0, c1) = columns(simd, raw[0], odd[0]);
                let (c2, c3) = columns(simd, raw[1], odd[1]);
                // In column order, and zeros past them: window j counts
                // columns j .. j + pad.
                let cols: [[u16; 8]; 12] = cast([
                    avx2._mm256_permute2x128_si256::<0x20>(c0, c1),
                    avx2._mm256_permute2x128_si256::<0x31>(c0, c1),
                    avx2._mm256_permute2x128_si256::<0x20>(c2, c3),
                    avx2._mm256_permute2x128_si256::<0x31>(c2, c3),
                    zero,
                    zero,
                ]);
                let cols = cols.as_flattened();
                let o = &mut out[s * width..][..width];
                let accs = &accs[s];
                for g in (0..len).step_by(8) {
                    // Windows g .. g + 8: their columns' sums, 32 bits.
                    let mut past = zero;
                    for q in 0..pad {
                        let c: [u16; 8] = cols[g + q..g + q + 8].try_into().unwrap();
                        past = avx2._mm256_add_epi32(past, avx2._mm256_cvtepu16_epi32(cast(c)));
                    }
                    // The windows' sums: four accumulators' lanes added up
                    // at a time (windows g, g + 2, g + 4, g + 6 and the
                    // odd ones), then interleaved into 32-bit lanes (each
                    // sum is below 2^32).
                    let a: &[__m256i; 8] = accs[g..g + 8].try_into().unwrap();
                    let even = sum4(simd, a[0], a[2], a[4], a[6]);
                    let odd = sum4(simd, a[1], a[3], a[5], a[7]);
                    let sums = avx2._mm256_or_si256(even, avx2._mm256_slli_epi64::<32>(odd));
                    let res: [u32; 8] = cast(avx2._mm256_sub_epi32(sums, past));
                    // A whole group as one store where the row has room (a
                    // copy of a variable length is a call to memcpy): the
                    // sums past the piece are overwritten, by the next
                    // piece or by windows_avx2_rows's windows_avx2_narrow.
                    let at = k + g;
                    if at + 8 <= width {
                        o[at..at + 8].copy_from_slice(&res);
                    } else {
                        o[at..].copy_from_slice(&res[..width - at]);
                    }
                }
            }
            k += len;
        }
        k
    }

    /// The sums of the 64-bit lanes of `a`, `b`, `c`, `d`, in that order.
    #[inline(always)]
    fn sum4(simd: V3, a: __m256i, b: __m256i, c: __m256i, d: __m256i) -> __m256i {
        let avx2 = simd.avx2;
        // [a0 + a1, b0 + b1 | a2 + a3, b2 + b3], the same of c, d.
        let ab = avx2._mm256_add_epi64(
            avx2._mm256_unpacklo_epi64(a, b),
            avx2._mm256_unpackhi_epi64(a, b),
        );
        let cd = avx2._mm256_add_epi64(
            avx2._mm256_unpacklo_epi64(c, d),
            avx2._mm256_unpackhi_epi64(c, d),
        );
        avx2._mm256_add_epi64(
            avx2._mm256_permute2x128_si256::<0x20>(ab, cd),
            avx2._mm256_permute2x128_si256::<0x31>(ab, cd),
        )
    }

    /// The frame rows of a [`multi`] batch from `f[base]`: `S` rows of `W`
    /// windows' `vpsadbw` sums (row `s` of windows meets template row
    /// `r - s` in frame row `r`). Each frame row's windows are built once,
    /// as in [`narrow_rows`] (`DIRECT`: loaded; otherwise `vpalignr` of two
    /// loads), and summed against the template row of each row of windows
    /// that meets it.
    #[inline(always)]
    fn multi_rows<const W: usize, const DIRECT: bool>(
        simd: V3,
        t_rows: &[[u8; 32]],
        f: &[u8],
        stride: usize,
        base: usize,
    ) -> [[__m256i; W]; super::MULTI_ROWS] {
        const S: usize = super::MULTI_ROWS;
        let l = Avx2(simd);
        let th = t_rows.len();
        let zero = l.zero();
        let mut acc = [[zero; W]; S];
        // Frame row `r`'s windows against the template rows `r - s` of
        // the rows of windows `s` in LO..HI.
        #[inline(always)]
        fn step<const W: usize, const DIRECT: bool, const LO: usize, const HI: usize>(
            simd: V3,
            acc: &mut [[__m256i; W]; super::MULTI_ROWS],
            blk: &[u8; 48],
            tv: [__m256i; super::MULTI_ROWS],
        ) {
            let l = Avx2(simd);
            let avx2 = simd.avx2;
            let (f0, f16) = (l.ld(blk, 0), l.ld(blk, 16));
            macro_rules! each_window {
                ($($j:literal)*) => {$(
                    if $j < W {
                        let v = if DIRECT {
                            l.ld(blk, $j)
                        } else if $j == 0 {
                            f0
                        } else {
                            avx2._mm256_alignr_epi8::<$j>(f16, f0)
                        };
                        for s in LO..HI {
                            acc[s][$j] = l.add(acc[s][$j], l.sad(v, tv[s]));
                        }
                    }
                )*};
            }
            each_window!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        }
        // The first and last S - 1 frame rows meet only some rows of
        // windows (rows of windows lo..hi): frame row r's 48 bytes and the
        // template rows r - s (a zero vector for the others). A macro, not
        // a closure: a closure is not compiled for AVX2 (its intrinsics
        // became calls).
        macro_rules! edge {
            ($r:expr, $lo:expr, $hi:expr) => {{
                let r = $r;
                let blk: &[u8; 48] = f[base + r * stride..][..48].try_into().unwrap();
                let tv: [__m256i; S] = core::array::from_fn(|s| match r.checked_sub(s) {
                    Some(i) if i < th => l.ld(&t_rows[i], 0),
                    _ => zero,
                });
                match ($lo, $hi) {
                    (0, 1) => step::<W, DIRECT, 0, 1>(simd, &mut acc, blk, tv),
                    (0, 2) => step::<W, DIRECT, 0, 2>(simd, &mut acc, blk, tv),
                    (1, 2) => step::<W, DIRECT, 1, 2>(simd, &mut acc, blk, tv),
                    (1, 3) => step::<W, DIRECT, 1, 3>(simd, &mut acc, blk, tv),
                    (2, 3) => step::<W, DIRECT, 2, 3>(simd, &mut acc, blk, tv),
                    _ => unreachable!("MULTI_ROWS is 2 or 3"),
                }
            }};
        }
        const _: () = assert!(S == 2 || S == 3);
        for r in 0..S - 1 {
            edge!(r, 0, r + 1);
        }
        // The batch's frame rows from its first window (one slice: one
        // check a row, no overflow checks).
        let fb = &f[base..][..(th + S - 2) * stride + 48];
        // The frame rows every row of windows meets (r = S - 1 .. th), two
        // a turn (the loop's counting and bounds checks once for both),
        // with the template rows r, r - 1, ...
        macro_rules! body {
            ($blk:expr, $tr:expr) => {{
                let blk: &[u8; 48] = $blk[..48].try_into().unwrap();
                let tr: &[[u8; 32]] = $tr;
                let tv: [__m256i; S] = core::array::from_fn(|s| l.ld(&tr[S - 1 - s], 0));
                step::<W, DIRECT, 0, S>(simd, &mut acc, blk, tv);
            }};
        }
        // U frame rows a turn: one bounds check for all (the others' follow
        // from it), one count.
        const U: usize = 2;
        let mut o = (S - 1) * stride;
        let span = (U - 1) * stride + 48;
        let mut turns = t_rows.windows(S + U - 1);
        for tr in turns.by_ref().step_by(U) {
            let rows = &fb[o..][..span];
            let mut q = 0;
            for u in 0..U {
                body!(&rows[q..], &tr[u..u + S]);
                q += stride;
            }
            o += U * stride;
        }
        // The last (th + 1 - S) mod U rows.
        for r in th - (th + 1 - S) % U..th {
            body!(&fb[o..], &t_rows[r + 1 - S..=r]);
            o += stride;
        }
        for r in th..th + S - 1 {
            edge!(r, r + 1 - th, S);
        }
        acc
    }

    /// [`windows!`] under AVX-512: 64-byte chunks eight windows at a time;
    /// 32-byte rows (gray windows) two per 64-byte `vpsadbw`, sixty-four
    /// at a time ([`paired`]), the rest with 32-byte vectors, sixteen
    /// windows at a time (32 vector registers).
    #[inline(always)]
    pub(super) fn windows_avx512(
        simd: V4,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        step: usize,
        out: &mut [u32],
    ) {
        if t.width == 64 {
            windows!(Avx512(simd), t, f, stride, start, step, out, 64, 8);
        } else {
            let done = if step == 1 && !t.doubled.is_empty() {
                paired(simd, t, f, stride, start, out)
            } else {
                0
            };
            let (start, out) = (start + done, &mut out[done..]);
            windows!(Avx2(*simd), t, f, stride, start, step, out, 32, 16);
        }
    }

    /// Gray windows with rows of at most 32 bytes under AVX-512: a 64-byte
    /// load at byte `o` holds the row of window `o` in its low half and
    /// that of window `o + 32` in its high half, so one `vpsadbw` against
    /// the row stored twice (`SadTemplate::doubled`) advances two windows.
    /// Sixty-four consecutive windows at a time, as two batches of sixteen
    /// accumulators; returns how many windows it did (a multiple of 64,
    /// stopping where the reads would leave `f`).
    #[inline(always)]
    fn paired(
        simd: V4,
        t: &SadTemplate,
        f: &[u8],
        stride: usize,
        start: usize,
        out: &mut [u32],
    ) -> usize {
        // Bytes one batch reads from each row: 15 offsets plus 64.
        const SPAN: usize = 15 + 64;
        let l = Avx512(simd);
        let m = l.ld(&t.masks, 0);
        let mut k = 0;
        while k + 64 <= out.len() {
            let base = start + k;
            // The second batch starts at base + 16 and reads SPAN bytes a row.
            if t.rows == 0 || base + 16 + (t.rows - 1) * stride + SPAN > f.len() {
                break;
            }
            for half in [0, 16] {
                let mut acc = [l.zero(); 16];
                for r in 0..t.rows {
                    let o = base + half + r * stride;
                    let blk: &[u8; SPAN] = f[o..o + SPAN].try_into().unwrap();
                    let tv = l.ld(&t.doubled, r * 64);
                    for (j, a) in acc.iter_mut().enumerate() {
                        let fv = l.and(l.ld(blk, j), m);
                        *a = l.add(*a, l.sad(fv, tv));
                    }
                }
                for (j, a) in acc.into_iter().enumerate() {
                    let q: [u64; 8] = cast(a);
                    out[k + half + j] = (q[0] + q[1] + q[2] + q[3]) as u32;
                    out[k + 32 + half + j] = (q[4] + q[5] + q[6] + q[7]) as u32;
                }
            }
            k += 64;
        }
        k
    }

    /// SAD of two equal-length slices: whole chunks by `psadbw`, the tail
    /// in scalar code.
    #[inline(always)]
    pub(super) fn slices<L: Lanes>(l: L, a: &[u8], b: &[u8]) -> u32 {
        let mut acc = l.zero();
        let n = a.len() / L::W * L::W;
        for o in (0..n).step_by(L::W) {
            acc = l.add(acc, l.sad(l.ld(a, o), l.ld(b, o)));
        }
        l.hsum(acc) + super::abs_diff_sum(&a[n..], &b[n..])
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::{Image, Rect};

    fn random(w: usize, h: usize, ch: usize, seed: u32) -> Image<u8> {
        Image::from_vec(w, h, ch, bayestrack_testkit::noise_bytes(w * h * ch, seed)).unwrap()
    }

    /// Asserts that `n` consecutive windows from `(x0, y)` are the
    /// reference's SADs (`what` names the case).
    fn windows_match(
        tpl: &SadTemplate,
        frame: ImageView<'_, u8>,
        t: ImageView<'_, u8>,
        (x0, y): (usize, usize),
        n: usize,
        what: &str,
    ) {
        let mut out = vec![0u32; n];
        tpl.sad_windows(frame, x0, y, &mut out);
        for (i, &o) in out.iter().enumerate() {
            let want = reference(frame, t, x0 + i, y);
            assert_eq!(o, want, "{what}: ({}, {y}) of {n}", x0 + i);
        }
    }

    fn reference(f: ImageView<'_, u8>, t: ImageView<'_, u8>, x: usize, y: usize) -> u32 {
        let ch = f.channels();
        let n = t.width() * ch;
        (0..t.height())
            .map(|r| {
                t.row(r)
                    .iter()
                    .zip(&f.row(y + r)[x * ch..x * ch + n])
                    .map(|(&a, &b)| u32::from(a.abs_diff(b)))
                    .sum::<u32>()
            })
            .sum()
    }

    /// Every level this CPU runs (the SAD and warp tests force each).
    pub(crate) fn levels() -> Vec<SimdLevel> {
        let l: Vec<_> = SimdLevel::ALL
            .into_iter()
            .filter(|l| l.is_available())
            .collect();
        // This crate's CI machines are x86-64: every vector path must run.
        #[cfg(target_arch = "x86_64")]
        assert!(l.contains(&SimdLevel::Sse2));
        l
    }

    #[test]
    fn every_level_equals_the_scalar_reference_on_random_images() {
        let mut seed = 1;
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            assert_eq!(tpl.level(), level, "a forced level runs as asked");
            for ch in [1, 3] {
                for (tw, th) in [
                    (1, 1),
                    (5, 3),
                    (8, 2),
                    (11, 4),
                    (16, 5),
                    (21, 3),
                    (30, 20),
                    (33, 2),
                    (64, 3),
                    (70, 2),
                ] {
                    seed += 1;
                    // A crop of a larger frame: stride > width, and windows
                    // at the right and bottom edges of the buffer take the
                    // scalar fallback for their padded reads.
                    // 150 wide: gray rows of up to 32 bytes leave more than
                    // 64 windows, so the paired AVX-512 kernel runs too.
                    let big = random(157, 30, ch, seed);
                    let frame = big.crop(Rect::new(7, 3, 150, 27)).unwrap();
                    let t_img = random(tw, th, ch, seed + 100);
                    tpl.set(t_img.view());
                    let npx = 150 - tw + 1;
                    let mut out = vec![0u32; npx];
                    for y in [0, 27 - th] {
                        tpl.sad_windows(frame, 0, y, &mut out);
                        for (x, &o) in out.iter().enumerate() {
                            let want = reference(frame, t_img.view(), x, y);
                            assert_eq!(o, want, "{level:?} ch {ch} {tw}x{th} at ({x}, {y})");
                            let start = y * frame.stride() + x * ch;
                            let s = frame.as_slice();
                            assert_eq!(tpl.sad_at(s, frame.stride(), start, u32::MAX), want);
                            // A limit: exact at or below it, above it when cut.
                            let limit = want / 2;
                            let cut = tpl.sad_at(s, frame.stride(), start, limit);
                            assert!(
                                cut <= want && (want <= limit || cut > limit),
                                "{level:?} cut {cut} want {want}"
                            );
                            assert_eq!(tpl.sad_at(s, frame.stride(), start, want), want);
                        }
                    }
                    // Saturated bytes: 255 against 0 everywhere.
                    let white = Image::new(tw + 40, th, ch, 255u8).unwrap();
                    let black = Image::new(tw, th, ch, 0u8).unwrap();
                    tpl.set(black.view());
                    let mut out = vec![0u32; 41];
                    tpl.sad_windows(white.view(), 0, 0, &mut out);
                    assert!(out.iter().all(|&o| o as usize == 255 * tw * th * ch));
                }
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 256, ..proptest::prelude::ProptestConfig::default()
        })]

        /// Random frame and template sizes, crops (stride past the width),
        /// channels, first window and run length: every level gives the
        /// scalar reference's sums, windows at the buffer's right and
        /// bottom edges included (the gray AVX2 batches of twelve and the
        /// AVX-512 pairs of 64 need long runs: frames up to 200 wide).
        #[test]
        fn windows_at_every_level_equal_the_reference(
            (fw, fh, ch) in (1usize..=200, 1usize..=24, proptest::sample::select(vec![1usize, 3])),
            (left, top, right) in (0usize..4, 0usize..3, 0usize..40),
            (tw_pick, th_pick, x_pick, y_pick, n_pick) in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
            seed in 0u32..1000,
        ) {
            let pick = |p: f64, n: usize| ((p * n as f64) as usize).min(n - 1);
            let big = random(fw + left + right, fh + top, ch, seed);
            let frame = big.crop(Rect::new(left, top, fw, fh)).unwrap();
            // mostly the tracker's widths (gray rows of 11 to 32 bytes)
            let tw = 1 + pick(tw_pick, fw.min(40));
            let th = 1 + pick(th_pick, fh.min(12));
            let t_img = random(tw, th, ch, seed + 7);
            let npx = fw - tw + 1;
            let x0 = pick(x_pick, npx);
            let y = pick(y_pick, fh - th + 1);
            let n = 1 + pick(n_pick, npx - x0);
            for level in levels() {
                let mut tpl = SadTemplate::new(level);
                tpl.set(t_img.view());
                let mut out = vec![0u32; n];
                tpl.sad_windows(frame, x0, y, &mut out);
                for (i, &o) in out.iter().enumerate() {
                    let want = reference(frame, t_img.view(), x0 + i, y);
                    proptest::prop_assert_eq!(o, want, "{:?} ch {} {}x{} at ({}, {})", level, ch, tw, th, x0 + i, y);
                }
            }
        }
    }

    #[test]
    fn saturated_rows_of_every_narrow_width() {
        // 255 against 0 in every byte: the largest column sums and window
        // sums the gray batches take off and add up.
        for level in levels() {
            for tw in 1..=33 {
                for th in [1, 20, 257, 258] {
                    let white = Image::new(tw + 40, th, 1, 255u8).unwrap();
                    let black = Image::new(tw, th, 1, 0u8).unwrap();
                    let mut tpl = SadTemplate::new(level);
                    tpl.set(black.view());
                    let mut out = vec![0u32; 41];
                    tpl.sad_windows(white.view(), 0, 0, &mut out);
                    assert!(
                        out.iter().all(|&o| o as usize == 255 * tw * th),
                        "{level:?} {tw}x{th}: {out:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn gray_batches_of_every_width_equal_the_reference() {
        // Every gray row length the AVX2 vmpsadbw kernel takes (1 to
        // QUAD_MAX bytes: every number of blocks and of padded columns) and
        // a few past it; runs of 31 to 110 windows from two first windows
        // (batches of 64, of 32 and leftovers), in a crop (stride past the width)
        // whose last windows reach the buffer's end (the batch stops where
        // its reads would leave it).
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            for tw in 1..=QUAD_MAX + 2 {
                for th in [1, 2, 5] {
                    let seed = (tw * 10 + th) as u32;
                    let fw = tw + 109;
                    let big = random(fw + 2, th + 3, 1, seed);
                    let frame = big.crop(Rect::new(2, 1, fw, th + 2)).unwrap();
                    let t_img = random(tw, th, 1, seed + 1);
                    tpl.set(t_img.view());
                    for (x0, y) in [(0, 0), (1, 2)] {
                        for n in [31, 32, 33, 64, 70, 97, 110 - x0] {
                            let what = format!("{level:?} {tw}x{th}");
                            windows_match(&tpl, frame, t_img.view(), (x0, y), n, &what);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn gray_batches_at_every_cache_line_offset_equal_the_reference() {
        // Rows 64 and 128 bytes apart (the vpsadbw batches load each
        // window's bytes where no load crosses a cache line, and build the
        // windows with vpalignr elsewhere): crops from every offset of a
        // line, so that every batch kind runs at every place in it, for
        // every row length those batches take, with runs of 10 to 41
        // windows (whole batches and leftovers) up to the buffer's end.
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            for stride in [64, 128] {
                for tw in 11..=32 {
                    for th in [1, 3, 20] {
                        let seed = (stride + tw * 10 + th) as u32;
                        let big = random(stride, th + 1, 1, seed);
                        let t_img = random(tw, th, 1, seed + 1);
                        tpl.set(t_img.view());
                        for left in 0..=64.min(stride - tw - 9) {
                            let fw = stride - left;
                            let frame = big.crop(Rect::new(left, 0, fw, th + 1)).unwrap();
                            let npx = fw - tw + 1;
                            for (x0, y) in [(0, 0), (npx.saturating_sub(41), 1)] {
                                let n = (npx - x0).min(41);
                                let what =
                                    format!("{level:?} {tw}x{th} stride {stride} from {left}");
                                windows_match(&tpl, frame, t_img.view(), (x0, y), n, &what);
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn saturated_gray_rows_at_the_16_bit_widening_period() {
        // 255 against 0 everywhere: the vmpsadbw kernel's 16-bit sums reach
        // 65535 - (65535 mod 255 n) before they are widened (every
        // 65535 / (255 n) rows); one row more must not wrap. 100 windows:
        // a batch of 64, one of 32 and a tail, so the frame bytes under
        // the padding are 255 in every kind of batch.
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            for tw in 1..=QUAD_MAX + 2 {
                let run = 65535 / (255 * tw);
                for th in [run.max(1), run + 1, 2 * run + 1] {
                    let white = Image::new(tw + 99, th, 1, 255u8).unwrap();
                    let black = Image::new(tw, th, 1, 0u8).unwrap();
                    tpl.set(black.view());
                    let mut out = vec![0u32; 100];
                    tpl.sad_windows(white.view(), 0, 0, &mut out);
                    assert!(
                        out.iter().all(|&o| o as usize == 255 * tw * th),
                        "{level:?} {tw}x{th}: {out:?}"
                    );
                }
            }
        }
    }

    /// Asserts that `rows` rows of `n` windows from `(x0, y)` by
    /// [`SadTemplate::sad_window_rows`] are the reference's SADs.
    fn window_rows_match(
        tpl: &SadTemplate,
        frame: ImageView<'_, u8>,
        t: ImageView<'_, u8>,
        (x0, y): (usize, usize),
        (n, rows): (usize, usize),
        what: &str,
    ) {
        let mut out = vec![0u32; n * rows];
        tpl.sad_window_rows(frame, x0, y, n, &mut out);
        for (i, &o) in out.iter().enumerate() {
            let (x, yy) = (x0 + i % n, y + i / n);
            let want = reference(frame, t, x, yy);
            assert_eq!(o, want, "{what}: ({x}, {yy}) of {n} x {rows}");
        }
    }

    #[test]
    fn window_rows_of_every_gray_width_equal_the_reference() {
        // Every gray row length the shared-row batches take (11 to 32
        // bytes) and some around them, templates of 1 to 4 rows and 20,
        // 1 to 7 rows of windows (groups of MULTI_ROWS and a smaller
        // last one), runs of windows of every length up to past a piece
        // (whole batches and leftovers), up to the buffer's right and
        // bottom edges (where the batches stop), in a crop (stride past
        // the width), at every place in a cache line.
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            for tw in [1, 8, 10, 11, 12, 16, 21, 29, 30, 31, 32, 33, 40] {
                for th in [1, 2, 3, 4, 20] {
                    let seed = (tw * 100 + th) as u32;
                    let t_img = random(tw, th, 1, seed + 1);
                    tpl.set(t_img.view());
                    for left in [0, 5, 33, 63] {
                        let fw = tw + 120;
                        let fh = th + 8;
                        let big = random(fw + left + 3, fh + 1, 1, seed + left as u32);
                        let frame = big.crop(Rect::new(left, 1, fw, fh)).unwrap();
                        let npx = fw - tw + 1;
                        for rows in 1..=7.min(fh - th + 1) {
                            for (x0, n) in
                                [(0, npx), (1, 44), (3, 47), (npx - 57, 57), (2, 5), (7, 1)]
                            {
                                let y = fh - th + 1 - rows;
                                let what = format!("{level:?} {tw}x{th} from {left}");
                                window_rows_match(
                                    &tpl,
                                    frame,
                                    t_img.view(),
                                    (x0, 0),
                                    (n, rows),
                                    &what,
                                );
                                window_rows_match(
                                    &tpl,
                                    frame,
                                    t_img.view(),
                                    (x0, y),
                                    (n, rows),
                                    &what,
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn window_rows_at_every_cache_line_offset_equal_the_reference() {
        // Rows 64 and 320 bytes apart: crops from every offset of a cache
        // line (every fourth one 320 apart), so that the shared-row
        // batches (windows loaded, and vpalignr for a piece's last ones)
        // run at every place in it, for every row length they take, with
        // runs of windows up to the buffer's right and bottom edges.
        for level in levels() {
            let mut tpl = SadTemplate::new(level);
            for (stride, step) in [(64, 1), (320, 4)] {
                for tw in 11..=32 {
                    for th in [2, 3, 20] {
                        let seed = (stride + tw * 10 + th) as u32;
                        let big = random(stride, th + 4, 1, seed);
                        let t_img = random(tw, th, 1, seed + 1);
                        tpl.set(t_img.view());
                        for left in (0..=64.min(stride - tw - 9)).step_by(step) {
                            let fw = (stride - left).min(tw + 99);
                            let frame = big.crop(Rect::new(left, 0, fw, th + 4)).unwrap();
                            let npx = fw - tw + 1;
                            for (x0, y, rows) in
                                [(0, 0, 2), (1, 1, 4), (npx.saturating_sub(50), 2, 3)]
                            {
                                let what =
                                    format!("{level:?} {tw}x{th} stride {stride} from {left}");
                                let n = npx - x0;
                                window_rows_match(
                                    &tpl,
                                    frame,
                                    t_img.view(),
                                    (x0, y),
                                    (n, rows),
                                    &what,
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn saturated_window_rows_of_every_narrow_width() {
        // 255 against 0 in every byte: the largest column sums (16 bits
        // at 257 rows) and window sums the shared-row batches take off and
        // add up, in loaded and vpalignr batches.
        for level in levels() {
            for tw in 10..=33 {
                for th in [2, 20, 256, 257, 258] {
                    let white = Image::new(128, th + 3, 1, 255u8).unwrap();
                    let black = Image::new(tw, th, 1, 0u8).unwrap();
                    let mut tpl = SadTemplate::new(level);
                    tpl.set(black.view());
                    let n = 128 - tw + 1;
                    let mut out = vec![0u32; n * 4];
                    tpl.sad_window_rows(white.view(), 0, 0, n, &mut out);
                    assert!(
                        out.iter().all(|&o| o as usize == 255 * tw * th),
                        "{level:?} {tw}x{th}: {out:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn slices_at_every_level() {
        let a = random(300, 1, 1, 5).into_vec();
        let b = random(300, 1, 1, 6).into_vec();
        for level in levels() {
            for n in [0, 1, 15, 16, 17, 31, 32, 33, 63, 64, 65, 127, 200, 300] {
                let want: u32 = a[..n]
                    .iter()
                    .zip(&b[..n])
                    .map(|(&x, &y)| u32::from(x.abs_diff(y)))
                    .sum();
                assert_eq!(sad_u8_at(level, &a[..n], &b[..n]), want, "{level:?} n {n}");
            }
            assert_eq!(sad_u8_at(level, &[255; 9000], &[0; 9000]), 255 * 9000);
        }
        assert_eq!(
            sad_u8(&a, &b[..10]),
            sad_u8_at(SimdLevel::Scalar, &a[..10], &b[..10])
        );
    }
}
