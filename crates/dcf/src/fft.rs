//! Cached real 2-D FFTs of one fixed size, and FFT-friendly sizes.
//!
//! [`Fft2`] transforms a real `w x h` row-major array into its half
//! spectrum: a real-to-complex FFT along each row (`w / 2 + 1` complex
//! outputs, [`realfft`]) and a complex FFT along each of those columns
//! ([`rustfft`]). The spectrum is stored **column-major**: bin `(u, v)`
//! (`u < w / 2 + 1` horizontal frequency, `v < h` vertical) is at
//! `u * h + v`, so that every column transform is one contiguous call.
//! Element-wise products of spectra (all a correlation filter does) do not
//! care about the layout.
//!
//! The plans and every scratch buffer are made once, by [`Fft2::new`]; the
//! transforms then allocate nothing (but for the row buffers of
//! [`Fft2::forward_many`], which grow to the most arrays a call has had).
//!
//! **Float type: `f32`.** The filters' inputs are 8-bit pixels and
//! features clipped at 0.2 (fHOG), with about 3 significant digits; `f32`
//! keeps 7, halves the memory traffic and doubles the SIMD width of the
//! FFT kernels. The round trip is exact to about `1e-6` relative (tested
//! at `1e-5`).

use std::sync::Arc;

use realfft::{ComplexToReal, RealFftPlanner};
use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};

use bayestrack_image::simd::{
    Kernel, SimdLevel, Token, add8, complex_parts, complex_parts_mut, deinterleave8, interleave8,
    mul_add8, mul8, neg8, sub8, transpose8,
};

use crate::error::{DcfError, Result};

/// The complex type of the spectra.
pub type C32 = Complex32;

/// Whether `n` has no prime factor above 5 (a fast size for the mixed
/// radix FFTs).
pub fn is_smooth(mut n: usize) -> bool {
    if n == 0 {
        return false;
    }
    for p in [2, 3, 5] {
        while n.is_multiple_of(p) {
            n /= p;
        }
    }
    n == 1
}

/// The smallest 2,3,5-smooth size at least `n` (1 for 0).
pub fn next_smooth(n: usize) -> usize {
    let mut m = n.max(1);
    while !is_smooth(m) {
        m += 1;
    }
    m
}

/// Real 2-D FFT plans of one size, with their scratch buffers.
#[derive(Clone)]
pub struct Fft2 {
    w: usize,
    h: usize,
    /// The row transforms, all rows of a call at once.
    row_fwd: Rows,
    c2r: Arc<dyn ComplexToReal<f32>>,
    /// The inverse row transforms of a width of 16 or 12 in lanes
    /// ([`InverseRows`]), where `rustfft` runs its AVX code; `None`
    /// elsewhere (one `realfft` call per row).
    inv_rows: Option<InverseTwiddles>,
    col_fwd: Arc<dyn Fft<f32>>,
    col_inv: Arc<dyn Fft<f32>>,
    /// The forward and inverse column transforms of a height of 40 in
    /// lanes ([`Columns40`]), where `rustfft` runs its AVX code; `None`
    /// elsewhere (`rustfft` down each column).
    col_lanes: Option<ColumnLanes>,
    rows: Vec<C32>,
    real_scratch: Vec<C32>,
    col_scratch: Vec<C32>,
}

/// The forward row transforms of a width.
#[derive(Clone)]
enum Rows {
    Even(EvenRows),
    Odd(OddRows),
}

/// `realfft`'s real-to-complex transform of an odd length `w`, batched:
/// the rows as complex numbers of zero imaginary part through one call of
/// the complex FFT of length `w` (the FFT `realfft` plans, one call over
/// every row instead of one per row), the first `w / 2 + 1` bins kept, the
/// DC bin's imaginary part set to zero: `RealToComplexOdd`'s steps, so its
/// bits.
#[derive(Clone)]
struct OddRows {
    fft: Arc<dyn Fft<f32>>,
    /// The rows as complex numbers, then their transforms.
    buffer: Vec<C32>,
    scratch: Vec<C32>,
}

impl OddRows {
    fn new(w: usize, planner: &mut FftPlanner<f32>) -> Self {
        let fft = planner.plan_fft_forward(w);
        let scratch = vec![C32::default(); fft.get_inplace_scratch_len()];
        Self {
            fft,
            buffer: Vec::new(),
            scratch,
        }
    }

    /// The row spectra of `input` (`k` arrays of `h` rows of `w`) into
    /// `spectra` (`k` column-major half spectra of `(w / 2 + 1) h`).
    fn forward(&mut self, w: usize, h: usize, input: &[f32], spectra: &mut [C32]) {
        let len = input.len();
        // grown only, as EvenRows' buffers
        if self.buffer.len() < len {
            self.buffer.resize(len, C32::default());
        }
        let buffer = &mut self.buffer[..len];
        for (b, &v) in buffer.iter_mut().zip(input) {
            *b = C32::new(v, 0.0);
        }
        self.fft.process_with_scratch(buffer, &mut self.scratch);
        let s = (w / 2 + 1) * h;
        for (rows, dst) in buffer.chunks_exact(h * w).zip(spectra.chunks_exact_mut(s)) {
            // transpose rows (h x w, the first w / 2 + 1 of each kept) into
            // columns: each column written in order, read down the rows
            for (u, col) in dst.chunks_exact_mut(h).enumerate() {
                for (o, row) in col.iter_mut().zip(rows.chunks_exact(w)) {
                    *o = row[u];
                }
            }
            for dc in &mut dst[..h] {
                dc.im = 0.0;
            }
        }
    }
}

/// `realfft`'s real-to-complex transform of an even length `w`, batched:
/// the rows, read as `w / 2` complex numbers, go through the inner complex
/// FFT of length `w / 2` in one call (one plan look-up and one call instead
/// of one per row), then each is untangled into its `w / 2 + 1` bins with
/// `realfft`'s twiddles and the very arithmetic of its
/// `RealToComplexEven` (same operations, same order: the same bits), written
/// straight into the column-major spectrum. The bins of a row that is all
/// zero (a cosine-windowed patch's first and last) are written as zeros.
///
/// The untangling takes [`LANES`] consecutive rows of an array at a time,
/// one per vector lane ([`untangle_block`]): a bin's outputs for those rows
/// are next to each other in the column-major spectrum, so each step of the
/// scalar recipe is one vector operation and each bin one contiguous store;
/// arrays of fewer rows go row by row ([`untangle_row`]). The common widths
/// (`w / 2` of 4, 5, 6, 8, 9, 10 or 12 bins) are unrolled
/// ([`untangle_fixed`]), and widths of 16 and 12 where `rustfft` runs
/// its AVX planner skip the packing and the inner FFT call too:
/// [`RowLanes`] computes the whole row transforms in lanes,
/// with `rustfft`'s bits.
#[derive(Clone)]
struct EvenRows {
    fft: Arc<dyn Fft<f32>>,
    /// `realfft`'s `compute_twiddle(i, w) * 0.5`, `i = 1..`.
    twiddles: Vec<C32>,
    /// The rows as complex pairs, then their transforms.
    packed: Vec<C32>,
    out: Vec<C32>,
    scratch: Vec<C32>,
    /// Which rows (over all arrays of a call) are not all zero.
    nonzero: Vec<bool>,
    /// One block of [`LANES`] rows' transforms, bin-major: `block[k][r]`
    /// is row `r`'s bin `k`.
    block: Vec<[C32; LANES]>,
    /// The twiddles of `rustfft`'s 8-point butterfly ([`RowLanes`]).
    fft8_twiddles: [C32; 4],
    /// The twiddle of `rustfft`'s butterfly of 3 ([`RowLanes`]).
    fft3_twiddle: C32,
    /// Whether a width of 16 or 12 takes [`RowLanes`]: where
    /// `rustfft` runs its AVX butterflies, whose bits they reproduce
    /// (elsewhere `rustfft` and the untangling, as other widths).
    lanes: bool,
}

/// Whether `rustfft` plans its AVX algorithms on this machine (AVX and
/// FMA).
fn rustfft_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Rows untangled at once (one AVX2 vector of `f32`).
const LANES: usize = 8;

/// One value per row of a block.
type Lanes = [f32; LANES];

/// `rustfft`'s and `realfft`'s `compute_twiddle(i, n)` (forward): the
/// angle in `f64`, rounded to `f32`.
fn compute_twiddle(i: usize, n: usize) -> C32 {
    let angle = -2f64 * std::f64::consts::PI / n as f64 * i as f64;
    C32::new(angle.cos() as f32, angle.sin() as f32)
}

/// One more than the number of `realfft`'s twiddles of an even width `w`
/// (`i = 1..untangle_end(w)`).
fn untangle_end(w: usize) -> usize {
    if w.is_multiple_of(4) {
        w / 4
    } else {
        w / 4 + 1
    }
}

impl EvenRows {
    fn new(w: usize, planner: &mut FftPlanner<f32>) -> Self {
        let twiddles = (1..untangle_end(w))
            .map(|i| compute_twiddle(i, w) * 0.5f32)
            .collect();
        let fft = planner.plan_fft_forward(w / 2);
        let scratch = vec![C32::default(); fft.get_outofplace_scratch_len()];
        Self {
            fft,
            twiddles,
            packed: Vec::new(),
            out: Vec::new(),
            scratch,
            nonzero: Vec::new(),
            block: vec![[C32::default(); LANES]; w / 2],
            fft8_twiddles: std::array::from_fn(|j| compute_twiddle(j, 8)),
            fft3_twiddle: compute_twiddle(1, 3),
            lanes: (w == 16 || w == 12) && rustfft_avx(),
        }
    }

    /// [`RowLanes`] for a width `w` of 16 or 12 (`h >= LANES`), compiled
    /// for `level`.
    fn row_lanes(&self, level: SimdLevel, w: usize, h: usize, input: &[f32], spectra: &mut [C32]) {
        fn run<const W: usize>(
            rows: &EvenRows,
            level: SimdLevel,
            h: usize,
            input: &[f32],
            spectra: &mut [C32],
        ) {
            level.run(RowLanes::<W> {
                h,
                fft8_twiddles: &rows.fft8_twiddles,
                fft3_twiddle: rows.fft3_twiddle,
                twiddles: &rows.twiddles,
                input,
                spectra,
            });
        }
        if w == 16 {
            run::<16>(self, level, h, input, spectra);
        } else {
            run::<12>(self, level, h, input, spectra);
        }
    }

    /// The row spectra of `input` (`k` arrays of `h` rows of `w`) into
    /// `spectra` (`k` column-major half spectra of `(w / 2 + 1) h`), the
    /// packing and untangling compiled for `level` (every level gives the
    /// same bits).
    fn forward(
        &mut self,
        level: SimdLevel,
        w: usize,
        h: usize,
        input: &[f32],
        spectra: &mut [C32],
    ) {
        if self.lanes && h >= LANES {
            self.row_lanes(level, w, h, input, spectra);
            return;
        }
        let (m, count) = (w / 2, input.len() / w);
        let len = count * m;
        self.nonzero.clear();
        self.nonzero.resize(count, false);
        // grown only: calls alternate between many arrays and one, and
        // clearing the tail again each time would cost more than the rest
        if self.packed.len() < len {
            self.packed.resize(len, C32::default());
            self.out.resize(len, C32::default());
        }
        level.run(Pack {
            w,
            input,
            nonzero: &mut self.nonzero,
            packed: &mut self.packed[..len],
        });
        // (zero rows too: testing each row before packing it cost more
        // than their transforms)
        self.fft.process_outofplace_with_scratch(
            &mut self.packed[..len],
            &mut self.out[..len],
            &mut self.scratch,
        );
        level.run(Untangle {
            h,
            twiddles: &self.twiddles,
            nonzero: &self.nonzero,
            rows: &self.out[..len],
            block: &mut self.block,
            spectra,
        });
    }
}

/// The packing of [`EvenRows::forward`]: the rows of `input` (of `w`) as
/// complex pairs into `packed`, and which ones are not all zero into
/// `nonzero`.
struct Pack<'a> {
    w: usize,
    input: &'a [f32],
    nonzero: &'a mut [bool],
    packed: &'a mut [C32],
}

impl Kernel for Pack<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        for (d, pair) in self.packed.iter_mut().zip(self.input.chunks_exact(2)) {
            *d = C32::new(pair[0], pair[1]);
        }
        // the whole row tested, LANES samples at a time (no early exit:
        // vector compares)
        for (row, nz) in self.input.chunks_exact(self.w).zip(self.nonzero.iter_mut()) {
            let mut lanes = [0u32; LANES];
            let chunks = row.chunks_exact(LANES);
            let tail = chunks.remainder();
            for c in chunks {
                for (a, &v) in lanes.iter_mut().zip(c) {
                    *a |= u32::from(v != 0.0);
                }
            }
            let any = lanes.iter().fold(0, |a, &b| a | b) != 0;
            *nz = any || tail.iter().any(|&v| v != 0.0);
        }
    }
}

/// The untangling of [`EvenRows::forward`]: the row transforms `rows` into
/// the column-major `spectra`, zeros for the rows that are all zero (not
/// their transforms' untangling, which may hold `-0.0`).
struct Untangle<'a> {
    h: usize,
    twiddles: &'a [C32],
    nonzero: &'a [bool],
    rows: &'a [C32],
    block: &'a mut [[C32; LANES]],
    spectra: &'a mut [C32],
}

impl Kernel for Untangle<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        let (h, m) = (self.h, self.block.len());
        let s = (m + 1) * h;
        for ((nonzero, rows), dst) in self
            .nonzero
            .chunks_exact(h)
            .zip(self.rows.chunks_exact(h * m))
            .zip(self.spectra.chunks_exact_mut(s))
        {
            if h >= LANES {
                // blocks of LANES rows, the last one flush with the end
                // (overlapping the one before: the same rows again give
                // the same bins)
                let last = h - LANES;
                let mut fixed = true;
                for y in (0..last).step_by(LANES).chain([last]) {
                    let (o, d) = (&rows[y * m..][..LANES * m], &mut dst[y..]);
                    let keep: &[bool; LANES] = nonzero[y..y + LANES].try_into().expect("LANES");
                    // the common widths unrolled (fixed-size arrays: no
                    // loop or bounds check left; zero rows' bins written
                    // as zeros), the others generic
                    match m {
                        4 => untangle_fixed::<_, 4>(token, h, self.twiddles, o, keep, d),
                        5 => untangle_fixed::<_, 5>(token, h, self.twiddles, o, keep, d),
                        6 => untangle_fixed::<_, 6>(token, h, self.twiddles, o, keep, d),
                        8 => untangle_fixed::<_, 8>(token, h, self.twiddles, o, keep, d),
                        9 => untangle_fixed::<_, 9>(token, h, self.twiddles, o, keep, d),
                        10 => untangle_fixed::<_, 10>(token, h, self.twiddles, o, keep, d),
                        12 => untangle_fixed::<_, 12>(token, h, self.twiddles, o, keep, d),
                        _ => {
                            untangle_block(h, self.twiddles, o, self.block, d);
                            fixed = false;
                        }
                    }
                }
                if fixed {
                    continue;
                }
            } else {
                for (y, o) in rows.chunks_exact(m).enumerate() {
                    untangle_row(h, self.twiddles, o, &mut dst[y..]);
                }
            }
            for (y, _) in nonzero.iter().enumerate().filter(|(_, nz)| !**nz) {
                for d in dst[y..].iter_mut().step_by(h) {
                    *d = C32::default();
                }
            }
        }
    }
}

/// One row transform `o` (`m` bins) untangled into its `m + 1` bins
/// `dst[u h]`: `realfft`'s `RealToComplexEven`, term for term.
#[inline(always)]
fn untangle_row(h: usize, twiddles: &[C32], o: &[C32], dst: &mut [C32]) {
    let m = o.len();
    let at = |u: usize| u * h;
    let first = o[0];
    dst[at(0)] = C32::new(first.re + first.im, 0.0);
    dst[at(m)] = C32::new(first.re - first.im, 0.0);
    for (i, tw) in twiddles.iter().enumerate() {
        let (k, kr) = (i + 1, m - i - 1);
        let (out, out_rev) = (o[k], o[kr]);
        let sum = out + out_rev;
        let diff = out - out_rev;
        let half = 0.5f32;
        let twiddled_re_sum = sum * tw.re;
        let twiddled_im_sum = sum * tw.im;
        let twiddled_re_diff = diff * tw.re;
        let twiddled_im_diff = diff * tw.im;
        let half_sum_re = half * sum.re;
        let half_diff_im = half * diff.im;
        let output_twiddled_real = twiddled_re_sum.im + twiddled_im_diff.re;
        let output_twiddled_im = twiddled_im_sum.im - twiddled_re_diff.re;
        dst[at(k)] = C32::new(
            half_sum_re + output_twiddled_real,
            half_diff_im + output_twiddled_im,
        );
        dst[at(kr)] = C32::new(
            half_sum_re - output_twiddled_real,
            output_twiddled_im - half_diff_im,
        );
    }
    // an odd number of bins leaves the middle one: conjugated
    if m.is_multiple_of(2) && m >= 2 {
        let c = o[m / 2];
        dst[at(m / 2)] = C32::new(c.re, -c.im);
    }
}

/// [`untangle_row`] for the [`LANES`] consecutive rows of `o` (`LANES`
/// row transforms of `m` bins) at once, row `r` into `dst[u h + r]`: each
/// lane does a row's arithmetic, the same operations in the same order
/// (separate multiplications and additions: the same bits), so each step
/// is one vector operation and each bin's `LANES` outputs one store.
#[inline(always)]
fn untangle_block(
    h: usize,
    twiddles: &[C32],
    o: &[C32],
    block: &mut [[C32; LANES]],
    dst: &mut [C32],
) {
    let m = block.len();
    // rows into lanes: block[k] holds bin k of every row
    for (r, row) in o.chunks_exact(m).enumerate() {
        for (b, &c) in block.iter_mut().zip(row) {
            b[r] = c;
        }
    }
    let split = |b: &[C32; LANES]| -> (Lanes, Lanes) {
        (
            std::array::from_fn(|l| b[l].re),
            std::array::from_fn(|l| b[l].im),
        )
    };
    let mut store = |u: usize, re: Lanes, im: Lanes| {
        let d = &mut dst[u * h..][..LANES];
        for l in 0..LANES {
            d[l] = C32::new(re[l], im[l]);
        }
    };
    let (re, im) = split(&block[0]);
    let zero = [0.0f32; LANES];
    store(0, std::array::from_fn(|l| re[l] + im[l]), zero);
    store(m, std::array::from_fn(|l| re[l] - im[l]), zero);
    let half = 0.5f32;
    for (i, tw) in twiddles.iter().enumerate() {
        let (k, kr) = (i + 1, m - i - 1);
        let ((out_re, out_im), (rev_re, rev_im)) = (split(&block[k]), split(&block[kr]));
        let sum_re: Lanes = std::array::from_fn(|l| out_re[l] + rev_re[l]);
        let sum_im: Lanes = std::array::from_fn(|l| out_im[l] + rev_im[l]);
        let diff_re: Lanes = std::array::from_fn(|l| out_re[l] - rev_re[l]);
        let diff_im: Lanes = std::array::from_fn(|l| out_im[l] - rev_im[l]);
        let half_sum_re: Lanes = std::array::from_fn(|l| half * sum_re[l]);
        let half_diff_im: Lanes = std::array::from_fn(|l| half * diff_im[l]);
        // twiddled_re_sum.im + twiddled_im_diff.re
        let real: Lanes = std::array::from_fn(|l| sum_im[l] * tw.re + diff_re[l] * tw.im);
        // twiddled_im_sum.im - twiddled_re_diff.re
        let imag: Lanes = std::array::from_fn(|l| sum_im[l] * tw.im - diff_re[l] * tw.re);
        store(
            k,
            std::array::from_fn(|l| half_sum_re[l] + real[l]),
            std::array::from_fn(|l| half_diff_im[l] + imag[l]),
        );
        store(
            kr,
            std::array::from_fn(|l| half_sum_re[l] - real[l]),
            std::array::from_fn(|l| imag[l] - half_diff_im[l]),
        );
    }
    if m.is_multiple_of(2) && m >= 2 {
        let (re, im) = split(&block[m / 2]);
        store(m / 2, re, std::array::from_fn(|l| -im[l]));
    }
}

/// [`untangle_block`] for rows of a fixed `M` bins (twiddles
/// `(M - 1) / 2`), the rows whose `keep` is false written as zeros: the
/// rows moved into lanes, then [`untangle_lanes`].
#[inline(always)]
fn untangle_fixed<T: Token, const M: usize>(
    tk: T,
    h: usize,
    twiddles: &[C32],
    o: &[C32],
    keep: &[bool; LANES],
    dst: &mut [C32],
) {
    let (rows, _) = o.as_chunks::<M>();
    let rows: &[[C32; M]; LANES] = rows[..LANES].try_into().expect("LANES rows");
    // bin k of every row, real and imaginary parts apart
    let re: [Lanes; M] = std::array::from_fn(|k| std::array::from_fn(|r| rows[r][k].re));
    let im: [Lanes; M] = std::array::from_fn(|k| std::array::from_fn(|r| rows[r][k].im));
    let keep: Lanes32 = std::array::from_fn(|l| 0u32.wrapping_sub(u32::from(keep[l])));
    untangle_lanes(tk, h, twiddles, &re, &im, &keep, dst);
}

/// [`untangle_row`] for [`LANES`] rows' transforms of a fixed `M` bins
/// (twiddles `(M - 1) / 2`) held in lanes (`re[k][r]`, `im[k][r]`: row
/// `r`'s bin `k`), row `r` into `dst[u h + r]`, zeros where `keep[r]` is
/// zero (it is all ones or zero: the bins are masked with it, one vector
/// `and`): each step unrolled over fixed-size arrays, one vector operation
/// for the `LANES` rows, the same operations in the same order as the
/// scalar recipe (the same bits).
#[inline(always)]
fn untangle_lanes<T: Token, const M: usize>(
    tk: T,
    h: usize,
    twiddles: &[C32],
    re: &[Lanes; M],
    im: &[Lanes; M],
    keep: &Lanes32,
    dst: &mut [C32],
) {
    let twiddles = &twiddles[..(M - 1) / 2];
    // a bin's LANES outputs interleaved into whole vectors, stored whole
    let mut store = |u: usize, re: Lanes, im: Lanes| {
        let d: &mut [f32; 2 * LANES] = complex_parts_mut(&mut dst[u * h..][..LANES])
            .try_into()
            .expect("LANES bins");
        let masked = |v: Lanes| -> Lanes {
            std::array::from_fn(|l| f32::from_bits(v[l].to_bits() & keep[l]))
        };
        *d = interleave8(tk, &masked(re), &masked(im));
    };
    let zero = [0.0f32; LANES];
    store(0, std::array::from_fn(|l| re[0][l] + im[0][l]), zero);
    store(M, std::array::from_fn(|l| re[0][l] - im[0][l]), zero);
    let half = 0.5f32;
    for (i, tw) in twiddles.iter().enumerate() {
        let (k, kr) = (i + 1, M - i - 1);
        let (out_re, out_im, rev_re, rev_im) = (&re[k], &im[k], &re[kr], &im[kr]);
        let sum_re: Lanes = std::array::from_fn(|l| out_re[l] + rev_re[l]);
        let sum_im: Lanes = std::array::from_fn(|l| out_im[l] + rev_im[l]);
        let diff_re: Lanes = std::array::from_fn(|l| out_re[l] - rev_re[l]);
        let diff_im: Lanes = std::array::from_fn(|l| out_im[l] - rev_im[l]);
        let half_sum_re: Lanes = std::array::from_fn(|l| half * sum_re[l]);
        let half_diff_im: Lanes = std::array::from_fn(|l| half * diff_im[l]);
        let real: Lanes = std::array::from_fn(|l| sum_im[l] * tw.re + diff_re[l] * tw.im);
        let imag: Lanes = std::array::from_fn(|l| sum_im[l] * tw.im - diff_re[l] * tw.re);
        store(
            k,
            std::array::from_fn(|l| half_sum_re[l] + real[l]),
            std::array::from_fn(|l| half_diff_im[l] + imag[l]),
        );
        store(
            kr,
            std::array::from_fn(|l| half_sum_re[l] - real[l]),
            std::array::from_fn(|l| imag[l] - half_diff_im[l]),
        );
    }
    if M.is_multiple_of(2) && M >= 2 {
        store(M / 2, re[M / 2], std::array::from_fn(|l| -im[M / 2][l]));
    }
}

/// The row transforms of a width `W` of 16 or 12 (the inner complex FFT
/// of `W / 2` and the untangling) for [`LANES`] rows at a time, one per
/// lane, straight from the real rows to the column-major spectrum (no
/// packing, no call of the inner FFT, no transposition of its output).
/// The inner FFT is the arithmetic of what `rustfft`'s AVX planner gives
/// that length (what it gives a machine with AVX and FMA, as every
/// x86-64-v3 one): for 8, `Butterfly8Avx` ([`width16_block`]: the same
/// additions, and its twiddle products as fused multiply-adds, exactly
/// rounded at every level, so every level gives the same bits); for 6,
/// `Butterfly6` ([`width12_block`]: Good-Thomas over two butterflies of 3
/// and three of 2, plain multiplications and additions); then
/// [`untangle_lanes`]. Zero rows' bins are written as zeros, as the other
/// widths'.
struct RowLanes<'a, const W: usize> {
    h: usize,
    /// `rustfft`'s twiddles of its 8-point butterfly, `compute_twiddle(j, 8)`
    /// (a width of 16).
    fft8_twiddles: &'a [C32; 4],
    /// `rustfft`'s twiddle of its butterfly of 3, `compute_twiddle(1, 3)`
    /// (a width of 12).
    fft3_twiddle: C32,
    /// `realfft`'s untangling twiddles.
    twiddles: &'a [C32],
    input: &'a [f32],
    spectra: &'a mut [C32],
}

impl<const W: usize> Kernel for RowLanes<'_, W> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        let h = self.h;
        for (array, dst) in self
            .input
            .chunks_exact(W * h)
            .zip(self.spectra.chunks_exact_mut((W / 2 + 1) * h))
        {
            let (rows, _) = array.as_chunks::<W>();
            // blocks of LANES rows, the last one flush with the end (as
            // Untangle's)
            let last = h - LANES;
            for y in (0..last).step_by(LANES).chain([last]) {
                // (the block at its own width: W is one of the two)
                let flat = rows[y..y + LANES].as_flattened();
                let dst = &mut dst[y..];
                if W == 16 {
                    let block = flat.as_chunks::<16>().0.try_into().expect("LANES");
                    width16_block(token, self.fft8_twiddles, self.twiddles, block, h, dst);
                } else {
                    let block = flat.as_chunks::<12>().0.try_into().expect("LANES");
                    width12_block(token, self.fft3_twiddle, self.twiddles, block, h, dst);
                }
            }
        }
    }
}

/// `rustfft`'s `Butterfly3::perform_fft_contiguous` on lanes.
#[inline(always)]
fn butterfly3<T: Token>(tk: T, t: C32, v: [CLanes; 3]) -> [CLanes; 3] {
    let xp = cadd(tk, &v[1], &v[2]);
    let xn = csub(tk, &v[1], &v[2]);
    let sum = cadd(tk, &v[0], &xp);
    let scaled = (mul8(tk, splat(t.re), xp.0), mul8(tk, splat(t.re), xp.1));
    let temp_b = (mul8(tk, splat(-t.im), xn.1), mul8(tk, splat(t.im), xn.0));
    let temp_a = cadd(tk, &v[0], &scaled);
    [sum, cadd(tk, &temp_a, &temp_b), csub(tk, &temp_a, &temp_b)]
}

/// `rustfft`'s `Butterfly6` on lanes (either direction: `tw3` is its
/// butterfly of 3's twiddle): Good-Thomas, columns of 3 then rows of 2.
#[inline(always)]
fn butterfly6<T: Token>(tk: T, tw3: C32, z: &[CLanes; 6]) -> [CLanes; 6] {
    let a = butterfly3(tk, tw3, [z[0], z[2], z[4]]);
    let b = butterfly3(tk, tw3, [z[3], z[5], z[1]]);
    [
        cadd(tk, &a[0], &b[0]),
        csub(tk, &a[1], &b[1]),
        cadd(tk, &a[2], &b[2]),
        csub(tk, &a[0], &b[0]),
        cadd(tk, &a[1], &b[1]),
        csub(tk, &a[2], &b[2]),
    ]
}

/// [`RowLanes`]' [`LANES`] rows of 12.
#[inline(always)]
fn width12_block<T: Token>(
    tk: T,
    tw3: C32,
    twiddles: &[C32],
    rows: &[[f32; 12]; LANES],
    h: usize,
    dst: &mut [C32],
) {
    // samples 0..8 and 4..12 of each row transposed: complex pairs 0..4
    // and 2..6, one row per lane
    let a = transpose8(tk, &rows.map(|r| r[..8].try_into().expect("8")));
    let b = transpose8(tk, &rows.map(|r| r[4..].try_into().expect("8")));
    let z = [
        (a[0], a[1]),
        (a[2], a[3]),
        (a[4], a[5]),
        (a[6], a[7]),
        (b[4], b[5]),
        (b[6], b[7]),
    ];
    let (ka, kb) = (nonzero_lanes(&a), nonzero_lanes(&b[4..]));
    let keep = std::array::from_fn(|l| ka[l] | kb[l]);
    let out = butterfly6(tk, tw3, &z);
    untangle_outputs(tk, h, twiddles, &out, &keep, dst);
}

/// The inner FFT's `M` outputs of [`RowLanes`]' blocks (complex lanes)
/// split into real and imaginary lanes, then [`untangle_lanes`].
#[inline(always)]
fn untangle_outputs<T: Token, const M: usize>(
    tk: T,
    h: usize,
    twiddles: &[C32],
    out: &[CLanes; M],
    keep: &Lanes32,
    dst: &mut [C32],
) {
    let mut re = [[0.0f32; LANES]; M];
    let mut im = [[0.0f32; LANES]; M];
    for ((r, i), o) in re.iter_mut().zip(&mut im).zip(out) {
        (*r, *i) = *o;
    }
    untangle_lanes(tk, h, twiddles, &re, &im, keep, dst);
}

/// All ones in the lanes where one of `samples` is not zero, zero in the
/// others (the rows' samples transposed: which rows are not all zero).
#[inline(always)]
fn nonzero_lanes(samples: &[Lanes]) -> Lanes32 {
    let mut any = [0u32; LANES];
    for v in samples {
        for l in 0..LANES {
            any[l] |= u32::from(v[l] != 0.0);
        }
    }
    std::array::from_fn(|l| 0u32.wrapping_sub(any[l]))
}

/// A complex number per lane: real parts, imaginary parts.
type CLanes = (Lanes, Lanes);

/// A bit mask per lane.
type Lanes32 = [u32; LANES];

/// `a + b` lane by lane.
#[inline(always)]
fn cadd<T: Token>(tk: T, a: &CLanes, b: &CLanes) -> CLanes {
    (add8(tk, a.0, b.0), add8(tk, a.1, b.1))
}

/// `a - b` lane by lane.
#[inline(always)]
fn csub<T: Token>(tk: T, a: &CLanes, b: &CLanes) -> CLanes {
    (sub8(tk, a.0, b.0), sub8(tk, a.1, b.1))
}

/// `t` in every lane.
#[inline(always)]
fn splat(t: f32) -> Lanes {
    [t; LANES]
}

/// `a t` as `rustfft`'s `AvxVector::mul_complex`, lane by lane:
/// `fmaddsub(re, t, im * swap(t))`, fused.
#[inline(always)]
fn ctwiddle<T: Token>(tk: T, a: &CLanes, t: C32) -> CLanes {
    (
        mul_add8(tk, a.0, splat(t.re), neg8(tk, mul8(tk, a.1, splat(t.im)))),
        mul_add8(tk, a.0, splat(t.im), mul8(tk, a.1, splat(t.re))),
    )
}

/// `a (-i)`: the parts swapped, the new imaginary one negated (a sign
/// flip, as `rustfft`'s xor).
#[inline(always)]
fn crotate<T: Token>(tk: T, a: &CLanes) -> CLanes {
    (a.1, neg8(tk, a.0))
}

/// `a i`: the parts swapped, the new real one negated (`rustfft`'s
/// inverse rotation).
#[inline(always)]
fn crotate_inverse<T: Token>(tk: T, a: &CLanes) -> CLanes {
    (neg8(tk, a.1), a.0)
}

/// `rustfft`'s `Butterfly8Avx::perform_fft_f32` on lanes: butterflies of 2
/// down the two halves, the twiddles `tw8` (fused, as its `mul_complex`),
/// butterflies of 4 (two of 2 with a rotation by a quarter turn: `rotate`,
/// [`crotate`] forward, [`crotate_inverse`] inverse).
#[inline(always)]
fn butterfly8<T: Token>(
    tk: T,
    tw8: &[C32; 4],
    z: &[CLanes; 8],
    rotate: impl Fn(T, &CLanes) -> CLanes,
) -> [CLanes; 8] {
    let i0 = [
        cadd(tk, &z[0], &z[4]),
        cadd(tk, &z[1], &z[5]),
        cadd(tk, &z[2], &z[6]),
        cadd(tk, &z[3], &z[7]),
    ];
    let i1 = [
        ctwiddle(tk, &csub(tk, &z[0], &z[4]), tw8[0]),
        ctwiddle(tk, &csub(tk, &z[1], &z[5]), tw8[1]),
        ctwiddle(tk, &csub(tk, &z[2], &z[6]), tw8[2]),
        ctwiddle(tk, &csub(tk, &z[3], &z[7]), tw8[3]),
    ];
    let pb0 = [
        cadd(tk, &i0[0], &i0[2]),
        cadd(tk, &i0[1], &i0[3]),
        cadd(tk, &i1[0], &i1[2]),
        cadd(tk, &i1[1], &i1[3]),
    ];
    let pb1 = [
        csub(tk, &i0[0], &i0[2]),
        rotate(tk, &csub(tk, &i0[1], &i0[3])),
        csub(tk, &i1[0], &i1[2]),
        rotate(tk, &csub(tk, &i1[1], &i1[3])),
    ];
    [
        cadd(tk, &pb0[0], &pb0[1]),
        cadd(tk, &pb0[2], &pb0[3]),
        cadd(tk, &pb1[0], &pb1[1]),
        cadd(tk, &pb1[2], &pb1[3]),
        csub(tk, &pb0[0], &pb0[1]),
        csub(tk, &pb0[2], &pb0[3]),
        csub(tk, &pb1[0], &pb1[1]),
        csub(tk, &pb1[2], &pb1[3]),
    ]
}

/// [`RowLanes`]' [`LANES`] rows of 16.
#[inline(always)]
fn width16_block<T: Token>(
    tk: T,
    tw8: &[C32; 4],
    twiddles: &[C32],
    rows: &[[f32; 16]; LANES],
    h: usize,
    dst: &mut [C32],
) {
    // the rows as 8 complex pairs, sample 2j + 1 the imaginary part (each
    // half of the rows transposed: one row per lane), and which rows are
    // not all zero
    let a = transpose8(tk, &rows.map(|r| r[..8].try_into().expect("8")));
    let b = transpose8(tk, &rows.map(|r| r[8..].try_into().expect("8")));
    let z = [
        (a[0], a[1]),
        (a[2], a[3]),
        (a[4], a[5]),
        (a[6], a[7]),
        (b[0], b[1]),
        (b[2], b[3]),
        (b[4], b[5]),
        (b[6], b[7]),
    ];
    let (ka, kb) = (nonzero_lanes(&a), nonzero_lanes(&b));
    let keep = std::array::from_fn(|l| ka[l] | kb[l]);
    untangle_outputs(
        tk,
        h,
        twiddles,
        &butterfly8(tk, tw8, &z, crotate),
        &keep,
        dst,
    );
}

/// The twiddles of [`InverseRows`]: `realfft`'s complex-to-real ones and
/// those of `rustfft`'s inverse butterfly.
#[derive(Clone, Debug)]
struct InverseTwiddles {
    /// `realfft`'s `compute_twiddle(i, w).conj()`, `i = 1..w / 4`.
    c2r: Vec<C32>,
    /// `rustfft`'s `compute_twiddle(j, 8, Inverse)` (a width of 16).
    fft8: [C32; 4],
    /// `rustfft`'s `compute_twiddle(1, 3, Inverse)` (a width of 12).
    fft3: C32,
}

impl InverseTwiddles {
    fn new(w: usize) -> Self {
        let twiddle = |i: usize, n: usize| compute_twiddle(i, n).conj();
        Self {
            c2r: (1..untangle_end(w)).map(|i| twiddle(i, w)).collect(),
            fft8: std::array::from_fn(|j| twiddle(j, 8)),
            fft3: twiddle(1, 3),
        }
    }
}

/// The inverse row transforms of [`Fft2::inverse`] for a width of 16 or
/// 12, [`LANES`] rows at a time, one per lane: each block's bins read
/// straight from the column-major spectrum (a bin of `LANES` consecutive
/// rows is contiguous there: no transposition into rows), `realfft`'s
/// `ComplexToRealEven` on them ([`c2r_lanes`]: its pre-processing, then the
/// inverse complex FFT of `w / 2` as `rustfft`'s AVX planner computes it,
/// [`butterfly8`] for 16, [`butterfly6`] for 12), normalised and written
/// into the rows. The same operations in the same order as the one row at
/// a time path (the DC and Nyquist bins' imaginary parts taken as zero, as
/// it sets them): the same bits at every level, and `realfft`'s where
/// `rustfft` runs its AVX code (only there is this taken).
struct InverseRows<'a> {
    w: usize,
    h: usize,
    twiddles: &'a InverseTwiddles,
    spectrum: &'a [C32],
    out: &'a mut [f32],
}

impl Kernel for InverseRows<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        let (w, h) = (self.w, self.h);
        let norm = 1.0 / (w * h) as f32;
        let t = self.twiddles;
        // blocks of LANES rows, the last one flush with the end (as
        // Untangle's: the rows written twice get the same values)
        let last = h - LANES;
        for y in (0..last).step_by(LANES).chain([last]) {
            let (spec, rows) = (&self.spectrum[y..], &mut self.out[y * w..][..LANES * w]);
            if w == 16 {
                let z = c2r_lanes::<_, 8>(token, &t.c2r, spec, h);
                let z = butterfly8(token, &t.fft8, &z, crotate_inverse);
                store_rows(token, &z, norm, rows.as_chunks_mut::<16>().0);
            } else {
                let z = c2r_lanes::<_, 6>(token, &t.c2r, spec, h);
                let z = butterfly6(token, t.fft3, &z);
                store_rows(token, &z, norm, rows.as_chunks_mut::<12>().0);
            }
        }
    }
}

/// The [`LANES`] complex numbers of `spec` from `at`, their real and
/// imaginary parts apart (whole vectors split: [`deinterleave8`]).
#[inline(always)]
fn bins<T: Token>(tk: T, spec: &[C32], at: usize) -> CLanes {
    let [re, im] = deinterleave8(
        tk,
        complex_parts(&spec[at..][..LANES])
            .try_into()
            .expect("LANES bins"),
    );
    (re, im)
}

/// `realfft`'s `ComplexToRealEven` pre-processing of [`LANES`] rows'
/// half spectra of `M + 1` bins (row `r`'s bin `u` at `spec[u h + r]`),
/// lane by lane, term for term: the `M` inputs of its inverse complex FFT.
/// The DC and Nyquist bins' imaginary parts are taken as zero (as
/// [`Fft2::inverse`] sets them), which makes `realfft`'s subtractions of
/// them exact: left out.
#[inline(always)]
fn c2r_lanes<T: Token, const M: usize>(
    tk: T,
    twiddles: &[C32],
    spec: &[C32],
    h: usize,
) -> [CLanes; M] {
    let load = |u: usize| bins(tk, spec, u * h);
    let mut z = [([0.0f32; LANES], [0.0f32; LANES]); M];
    let (first, last) = (load(0).0, load(M).0);
    z[0] = (
        std::array::from_fn(|l| first[l] + last[l]),
        std::array::from_fn(|l| first[l] - last[l]),
    );
    for (i, tw) in twiddles[..(M - 1) / 2].iter().enumerate() {
        let (k, kr) = (i + 1, M - i - 1);
        let (sum, diff) = {
            let (a, b) = (load(k), load(kr));
            (cadd(tk, &a, &b), csub(tk, &a, &b))
        };
        // twiddled_re_sum.im + twiddled_im_diff.re
        let real: Lanes = std::array::from_fn(|l| sum.1[l] * tw.re + diff.0[l] * tw.im);
        // twiddled_im_sum.im - twiddled_re_diff.re
        let imag: Lanes = std::array::from_fn(|l| sum.1[l] * tw.im - diff.0[l] * tw.re);
        z[k] = (
            std::array::from_fn(|l| sum.0[l] - real[l]),
            std::array::from_fn(|l| diff.1[l] - imag[l]),
        );
        z[kr] = (
            std::array::from_fn(|l| sum.0[l] + real[l]),
            std::array::from_fn(|l| -imag[l] - diff.1[l]),
        );
    }
    // an odd number of bins leaves the middle one: doubled, conjugated
    if M.is_multiple_of(2) {
        let c = load(M / 2);
        z[M / 2] = (
            std::array::from_fn(|l| c.0[l] + c.0[l]),
            std::array::from_fn(|l| -(c.1[l] + c.1[l])),
        );
    }
    z
}

/// The inverse FFT's outputs `z` of [`LANES`] rows (complex `j` of row
/// `r`: its samples `2 j` and `2 j + 1`) times `norm`, into `rows`.
#[inline(always)]
fn store_rows<T: Token, const M: usize, const W: usize>(
    tk: T,
    z: &[CLanes; M],
    norm: f32,
    rows: &mut [[f32; W]],
) {
    let mut parts = [[0.0f32; LANES]; 8];
    // four complex outputs (eight samples) of every row at a time,
    // transposed into the rows; a last group of fewer (a width of 12)
    // pads with zeros and stores its rows' first samples
    for g in (0..M).step_by(4) {
        let n = (M - g).min(4);
        for (k, zk) in z[g..g + n].iter().enumerate() {
            parts[2 * k] = mul8(tk, zk.0, splat(norm));
            parts[2 * k + 1] = mul8(tk, zk.1, splat(norm));
        }
        let t = transpose8(tk, &parts);
        for (row, t) in rows[..LANES].iter_mut().zip(&t) {
            row[2 * g..2 * (g + n)].copy_from_slice(&t[..2 * n]);
        }
    }
}

/// What [`Columns40`] needs: both directions' twiddles, and its blocks.
#[derive(Clone)]
struct ColumnLanes {
    twiddles: [Radix5x8; 2],
    blocks: Box<[Points40; 2]>,
}

/// The twiddles of `rustfft`'s AVX plan for columns of 40, one direction:
/// `MixedRadix5xnAvx` over `Butterfly8Avx` ([`Columns40`]).
#[derive(Clone, Debug)]
struct Radix5x8 {
    /// `MixedRadix5xnAvx`'s, `compute_twiddle(i j, 40)` at `[i - 1][j]`.
    mixed: [[C32; 8]; 4],
    /// Its butterfly of 5's, `compute_twiddle(1, 5)` and `(2, 5)`.
    fft5: [C32; 2],
    /// `Butterfly8Avx`'s, `compute_twiddle(j, 8)`.
    fft8: [C32; 4],
}

impl Radix5x8 {
    /// The forward twiddles, or the inverse ones (`rustfft`'s inverse
    /// twiddles are the forward ones conjugated).
    fn new(inverse: bool) -> Self {
        let twiddle = |i: usize, n: usize| {
            let t = compute_twiddle(i, n);
            if inverse { t.conj() } else { t }
        };
        Self {
            mixed: std::array::from_fn(|i| std::array::from_fn(|j| twiddle((i + 1) * j, 40))),
            fft5: [twiddle(1, 5), twiddle(2, 5)],
            fft8: std::array::from_fn(|j| twiddle(j, 8)),
        }
    }
}

/// The column FFTs of a height of 40 (the complex FFT of every column of
/// `data`, in place, at least [`LANES`] columns), [`LANES`] columns at a
/// time, one per lane. `rustfft`'s AVX planner makes `MixedRadix5xnAvx`
/// over `Butterfly8Avx` for that length: the column as 5 rows of 8,
/// butterflies of 5 down its 8 columns ([`butterfly5`]), its twiddles
/// ([`ctwiddle_left`]), butterflies of 8 along the 5 rows
/// ([`butterfly8`]), the 5 x 8 result read out transposed. This is that
/// arithmetic, term for term, each step one lane operation of the image
/// crate's (`mul_add8` where it fuses, exactly rounded at every level: the
/// same bits at every level, and `rustfft`'s where it runs its AVX code;
/// only there is this taken). The columns go into lanes and back by 8 x 8
/// transposes ([`load_lanes`], [`store_lanes`]). A count of columns that
/// is not a multiple of [`LANES`] ends with a block flush with the end,
/// of which only the columns not done before are stored (lanes do not mix:
/// the others' lanes, transformed twice, touch nothing).
struct Columns40<'a> {
    twiddles: &'a Radix5x8,
    inverse: bool,
    /// A block's points and its transform (kept by the caller: not
    /// cleared at each call).
    blocks: &'a mut [Points40; 2],
    data: &'a mut [C32],
}

impl Kernel for Columns40<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, token: T) {
        // Butterfly8Avx's quarter turn is the direction's (its butterfly
        // of 5's is always `a i`)
        let (t, blocks, data) = (self.twiddles, self.blocks, self.data);
        if self.inverse {
            columns40(token, t, blocks, data, crotate_inverse);
        } else {
            columns40(token, t, blocks, data, crotate);
        }
    }
}

/// [`Columns40`]'s blocks.
#[inline(always)]
fn columns40<T: Token>(
    token: T,
    t: &Radix5x8,
    [z, out]: &mut [Points40; 2],
    data: &mut [C32],
    rotate: impl Fn(T, &CLanes) -> CLanes + Copy,
) {
    let n = data.len() / 40;
    let data = complex_parts_mut(data);
    for c in (0..n - n % LANES).step_by(LANES) {
        load_lanes(token, data, c, z);
        fft40(token, t, z, out, rotate);
        store_lanes(token, out, data, c, 0);
    }
    if !n.is_multiple_of(LANES) {
        load_lanes(token, data, n - LANES, z);
        fft40(token, t, z, out, rotate);
        store_lanes(token, out, data, n - LANES, LANES - n % LANES);
    }
}

/// [`LANES`] columns of 40 points in lanes, the real parts and the
/// imaginary parts apart (each a run of whole vectors: kept so, the
/// compiler does each step on whole 256-bit vectors).
#[derive(Clone, Copy)]
struct Points40 {
    re: [Lanes; 40],
    im: [Lanes; 40],
}

impl Points40 {
    const ZERO: Self = Self {
        re: [[0.0; LANES]; 40],
        im: [[0.0; LANES]; 40],
    };

    #[inline(always)]
    fn get(&self, p: usize) -> CLanes {
        (self.re[p], self.im[p])
    }

    #[inline(always)]
    fn set(&mut self, p: usize, v: CLanes) {
        (self.re[p], self.im[p]) = v;
    }
}

/// `MixedRadix5xnAvx`'s length-40 FFT of [`LANES`] columns in lanes, `z`
/// into `out` (`z` left changed): row `i`'s bin `j` of the 5 x 8 rows'
/// transforms is output `5 j + i`.
#[inline(always)]
fn fft40<T: Token>(
    tk: T,
    t: &Radix5x8,
    z: &mut Points40,
    out: &mut Points40,
    rotate: impl Fn(T, &CLanes) -> CLanes + Copy,
) {
    // (the steps' values named one by one: arrays of them indexed in
    // loops stay in memory)
    for j in 0..8 {
        let [o0, o1, o2, o3, o4] = butterfly5(
            tk,
            &t.fft5,
            [
                z.get(j),
                z.get(j + 8),
                z.get(j + 16),
                z.get(j + 24),
                z.get(j + 32),
            ],
        );
        let m = |i: usize| t.mixed[i][j];
        z.set(j, o0);
        z.set(j + 8, ctwiddle_left(tk, m(0), &o1));
        z.set(j + 16, ctwiddle_left(tk, m(1), &o2));
        z.set(j + 24, ctwiddle_left(tk, m(2), &o3));
        z.set(j + 32, ctwiddle_left(tk, m(3), &o4));
    }
    for i in 0..5 {
        let g = |k: usize| z.get(8 * i + k);
        let row = [g(0), g(1), g(2), g(3), g(4), g(5), g(6), g(7)];
        let [o0, o1, o2, o3, o4, o5, o6, o7] = butterfly8(tk, &t.fft8, &row, rotate);
        out.set(i, o0);
        out.set(5 + i, o1);
        out.set(10 + i, o2);
        out.set(15 + i, o3);
        out.set(20 + i, o4);
        out.set(25 + i, o5);
        out.set(30 + i, o6);
        out.set(35 + i, o7);
    }
}

/// `rustfft`'s `AvxVector::column_butterfly5` on lanes (either direction:
/// `tw5` are its twiddles of the direction; its quarter turns are always
/// `a i`, [`crotate_inverse`]): plain sums and differences, its twiddle
/// products fused where it fuses (`fmadd`, `fnmadd`).
#[inline(always)]
fn butterfly5<T: Token>(tk: T, tw5: &[C32; 2], r: [CLanes; 5]) -> [CLanes; 5] {
    // a t + c, lane by lane, fused (fnmadd: -t)
    let fmadd = |t: f32, a: &CLanes, c: &CLanes| -> CLanes {
        (
            mul_add8(tk, splat(t), a.0, c.0),
            mul_add8(tk, splat(t), a.1, c.1),
        )
    };
    let scale =
        |t: f32, a: &CLanes| -> CLanes { (mul8(tk, splat(t), a.0), mul8(tk, splat(t), a.1)) };
    let (sum1, diff4) = (cadd(tk, &r[1], &r[4]), csub(tk, &r[1], &r[4]));
    let (sum2, diff3) = (cadd(tk, &r[2], &r[3]), csub(tk, &r[2], &r[3]));
    let (rotated4, rotated3) = (crotate_inverse(tk, &diff4), crotate_inverse(tk, &diff3));
    let output0 = cadd(tk, &r[0], &cadd(tk, &sum1, &sum2));
    let [t0, t1] = *tw5;
    let twiddled1_mid = fmadd(t0.re, &sum1, &r[0]);
    let twiddled2_mid = fmadd(t1.re, &sum1, &r[0]);
    let twiddled3_mid = scale(t1.im, &rotated4);
    let twiddled4_mid = scale(t0.im, &rotated4);
    let twiddled1 = fmadd(t1.re, &sum2, &twiddled1_mid);
    let twiddled2 = fmadd(t0.re, &sum2, &twiddled2_mid);
    let twiddled3 = fmadd(-t0.im, &rotated3, &twiddled3_mid);
    let twiddled4 = fmadd(t1.im, &rotated3, &twiddled4_mid);
    [
        output0,
        cadd(tk, &twiddled1, &twiddled4),
        cadd(tk, &twiddled2, &twiddled3),
        csub(tk, &twiddled2, &twiddled3),
        csub(tk, &twiddled1, &twiddled4),
    ]
}

/// `t a` as `rustfft`'s `AvxVector::mul_complex(t, a)`, the twiddle the
/// left operand (its mixed-radix steps; [`ctwiddle`] is the other order,
/// which fuses the other product): `fmaddsub(t.re, a, t.im * swap(a))`.
#[inline(always)]
fn ctwiddle_left<T: Token>(tk: T, t: C32, a: &CLanes) -> CLanes {
    (
        mul_add8(tk, splat(t.re), a.0, neg8(tk, mul8(tk, splat(t.im), a.1))),
        mul_add8(tk, splat(t.re), a.1, mul8(tk, splat(t.im), a.0)),
    )
}

/// The [`LANES`] columns of 40 from column `c` of `data` (its
/// [`complex_parts`]: a column is 80 values) into lanes: `z[p]` is point
/// `p` of each. Four points of the eight columns at a time: a column's
/// four complex numbers are eight consecutive `f32` (real, imaginary,
/// ...), and the transpose of those eight rows of eight
/// ([`transpose8`]) is the four points' real and imaginary parts, one
/// column per lane.
#[inline(always)]
fn load_lanes<T: Token>(token: T, data: &[f32], c: usize, z: &mut Points40) {
    let cols = &data[c * 80..].as_chunks::<80>().0[..LANES];
    for p in 0..10 {
        let mut rows = [[0.0f32; LANES]; LANES];
        for (r, col) in rows.iter_mut().zip(cols) {
            *r = col.as_chunks::<8>().0[p];
        }
        let t = transpose8(token, &rows);
        for k in 0..4 {
            z.set(4 * p + k, (t[2 * k], t[2 * k + 1]));
        }
    }
}

/// [`load_lanes`]' way back, the columns from `c + skip` on only.
#[inline(always)]
fn store_lanes<T: Token>(token: T, z: &Points40, data: &mut [f32], c: usize, skip: usize) {
    let cols = &mut data[c * 80..].as_chunks_mut::<80>().0[..LANES];
    for p in 0..10 {
        let mut rows = [[0.0f32; LANES]; LANES];
        for k in 0..4 {
            (rows[2 * k], rows[2 * k + 1]) = z.get(4 * p + k);
        }
        let t = transpose8(token, &rows);
        for (col, r) in cols.iter_mut().zip(&t).skip(skip) {
            col.as_chunks_mut::<8>().0[p] = *r;
        }
    }
}

impl std::fmt::Debug for Fft2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fft2")
            .field("w", &self.w)
            .field("h", &self.h)
            .finish_non_exhaustive()
    }
}

impl Fft2 {
    /// Plans for `w x h` real arrays.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a zero side or more than 2^24
    /// samples.
    pub fn new(w: usize, h: usize) -> Result<Self> {
        if w == 0 || h == 0 || w.saturating_mul(h) > 1 << 24 {
            return Err(DcfError::InvalidParameter {
                name: "fft size",
                value: (w * h) as f64,
                reason: "each side must be positive and w*h at most 2^24",
            });
        }
        let mut real = RealFftPlanner::<f32>::new();
        let c2r = real.plan_fft_inverse(w);
        let mut cplx = FftPlanner::<f32>::new();
        let row_fwd = if w.is_multiple_of(2) {
            Rows::Even(EvenRows::new(w, &mut cplx))
        } else {
            Rows::Odd(OddRows::new(w, &mut cplx))
        };
        let col_fwd = cplx.plan_fft_forward(h);
        let col_inv = cplx.plan_fft_inverse(h);
        let inv_rows = ((w == 16 || w == 12) && rustfft_avx()).then(|| InverseTwiddles::new(w));
        let col_lanes = (h == 40 && rustfft_avx()).then(|| ColumnLanes {
            twiddles: [false, true].map(Radix5x8::new),
            blocks: Box::new([Points40::ZERO; 2]),
        });
        let wc = w / 2 + 1;
        let real_scratch_len = c2r.get_scratch_len();
        let col_scratch_len = col_fwd
            .get_inplace_scratch_len()
            .max(col_inv.get_inplace_scratch_len());
        Ok(Self {
            w,
            h,
            row_fwd,
            c2r,
            inv_rows,
            col_fwd,
            col_inv,
            col_lanes,
            rows: vec![C32::default(); wc * h],
            real_scratch: vec![C32::default(); real_scratch_len],
            col_scratch: vec![C32::default(); col_scratch_len],
        })
    }

    /// Width of the real arrays.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Height of the real arrays.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Number of real samples, `w h`.
    pub fn real_len(&self) -> usize {
        self.w * self.h
    }

    /// Number of complex bins of the half spectrum, `(w / 2 + 1) h`.
    pub fn spectrum_len(&self) -> usize {
        (self.w / 2 + 1) * self.h
    }

    fn check(&self, real: usize, spectrum: usize) -> Result<()> {
        if real != self.real_len() || spectrum != self.spectrum_len() {
            return Err(DcfError::Size {
                what: "fft buffers",
                expected: self.real_len(),
                got: real,
            });
        }
        Ok(())
    }

    /// The column FFTs of `data` (columns of `h`), in place: in lanes
    /// where [`Columns40`] reproduces `rustfft`'s plan, there are
    /// [`LANES`] columns or more and the kernels may run AVX2 (below, its
    /// plain loops' fused products cost more than `rustfft`'s AVX code,
    /// which gives the same bits), else `rustfft`.
    fn columns(&mut self, inverse: bool, data: &mut [C32]) {
        match &mut self.col_lanes {
            Some(lanes) if data.len() >= LANES * self.h && SimdLevel::Avx2.is_available() => {
                // the best level this CPU has (as the rows)
                SimdLevel::Avx512.run(Columns40 {
                    twiddles: &lanes.twiddles[usize::from(inverse)],
                    inverse,
                    blocks: &mut lanes.blocks,
                    data,
                });
            }
            _ => {
                let fft = if inverse {
                    &self.col_inv
                } else {
                    &self.col_fwd
                };
                fft.process_with_scratch(data, &mut self.col_scratch);
            }
        }
    }

    /// The half spectrum of `input` (`w x h` row-major) into `out`
    /// (column-major, see the module docs). Unnormalised.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn forward(&mut self, input: &[f32], out: &mut [C32]) -> Result<()> {
        self.check(input.len(), out.len())?;
        self.forward_many(input, out)
    }

    /// The half spectra of `k` arrays (`input`: `k` times `w x h`
    /// row-major, one after the other) into `out` (`k` spectra of
    /// [`Fft2::spectrum_len`], one after the other): the same numbers as
    /// `k` calls of [`Fft2::forward`], the transforms of all the arrays
    /// batched (one call of the row FFT over every row, an even width's
    /// rows untangled eight at a time in vector lanes, a width of 16's or
    /// 12's whole row transforms in lanes where `rustfft` runs its AVX code (see
    /// `EvenRows`), and one call of the
    /// column FFT over every column).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of other sizes or counts.
    pub fn forward_many(&mut self, input: &[f32], out: &mut [C32]) -> Result<()> {
        let (n, s) = (self.real_len(), self.spectrum_len());
        let k = input.len() / n;
        if input.len() != k * n || out.len() != k * s {
            return Err(DcfError::Size {
                what: "fft buffers",
                expected: k.max(1) * n,
                got: input.len(),
            });
        }
        if k == 0 {
            return Ok(());
        }
        let (w, h) = (self.w, self.h);
        match &mut self.row_fwd {
            // the best level this CPU has (as `dispatch`)
            Rows::Even(rows) => rows.forward(SimdLevel::Avx512, w, h, input, out),
            Rows::Odd(rows) => rows.forward(w, h, input, out),
        }
        self.columns(false, out);
        Ok(())
    }

    /// The real array of the half spectrum `spectrum` into `out`,
    /// normalised (`inverse(forward(x)) == x`). `spectrum` is used as
    /// scratch and left changed. The column FFTs in one call, then the row
    /// transforms: one `realfft` call per row, or for a width of 16 or 12
    /// where `rustfft` runs its AVX code, eight rows at a time in vector
    /// lanes with `realfft`'s bits (see `InverseRows`).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn inverse(&mut self, spectrum: &mut [C32], out: &mut [f32]) -> Result<()> {
        self.check(out.len(), spectrum.len())?;
        let (w, h, wc) = (self.w, self.h, self.w / 2 + 1);
        self.columns(true, spectrum);
        if let Some(twiddles) = &self.inv_rows
            && h >= LANES
        {
            // the best level this CPU has (as `forward_many`)
            SimdLevel::Avx512.run(InverseRows {
                w,
                h,
                twiddles,
                spectrum,
                out,
            });
            return Ok(());
        }
        // columns to rows, each row written in order (bin (u, y) at u h + y)
        for (y, row) in self.rows.chunks_exact_mut(wc).enumerate() {
            for (o, col) in row.iter_mut().zip(spectrum.chunks_exact(h)) {
                *o = col[y];
            }
        }
        let norm = 1.0 / (w * h) as f32;
        for (y, row) in out.chunks_exact_mut(w).enumerate() {
            let src = &mut self.rows[y * wc..(y + 1) * wc];
            // a Hermitian spectrum has real DC (and Nyquist) bins; rounding
            // leaves a tiny imaginary part that the real transform refuses
            src[0].im = 0.0;
            if w % 2 == 0 {
                src[wc - 1].im = 0.0;
            }
            self.c2r
                .process_with_scratch(src, row, &mut self.real_scratch)
                .map_err(|_| DcfError::Fft)?;
            for v in row.iter_mut() {
                *v *= norm;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A deterministic pseudo-random signal in [-1, 1] (also the other
    /// modules' test noise).
    pub(crate) fn signal(w: usize, h: usize, seed: u32) -> Vec<f32> {
        let mut s = seed.wrapping_mul(2_654_435_761).max(1);
        (0..w * h)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                (s as f32 / u32::MAX as f32) * 2.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn smooth_sizes() {
        assert!(is_smooth(1) && is_smooth(30) && is_smooth(64) && is_smooth(45));
        assert!(!is_smooth(7) && !is_smooth(0) && !is_smooth(33));
        assert_eq!(next_smooth(31), 32);
        assert_eq!(next_smooth(37), 40);
        assert_eq!(next_smooth(49), 50);
        assert_eq!(next_smooth(0), 1);
    }

    #[test]
    fn round_trip_and_parseval() {
        for (w, h) in [(8, 8), (7, 5), (12, 9), (40, 30), (1, 6), (6, 1)] {
            let mut f = Fft2::new(w, h).unwrap();
            let x = signal(w, h, (w * 31 + h) as u32);
            let mut spec = vec![C32::default(); f.spectrum_len()];
            f.forward(&x, &mut spec).unwrap();
            // Parseval on the half spectrum: the columns u in 1..ceil(w/2)
            // stand for their mirror images too
            let wc = w / 2 + 1;
            let mut energy = 0.0f64;
            for u in 0..wc {
                let twice = u != 0 && !(w % 2 == 0 && u == wc - 1);
                let k = if twice { 2.0 } else { 1.0 };
                for v in 0..h {
                    energy += k * spec[u * h + v].norm_sqr() as f64;
                }
            }
            let direct: f64 = x.iter().map(|&v| (v as f64) * (v as f64)).sum();
            let rel = (energy / (w * h) as f64 - direct).abs() / direct;
            assert!(rel < 1e-5, "{w}x{h}: Parseval off by {rel}");
            let mut back = vec![0.0; w * h];
            f.inverse(&mut spec, &mut back).unwrap();
            for (a, b) in x.iter().zip(&back) {
                assert!((a - b).abs() < 1e-5, "{w}x{h}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn correlation_theorem() {
        // ifft(fft(a) conj(fft(b)))[d] = sum_p a[p + d] b[p] (circular)
        let (w, h) = (10, 6);
        let a = signal(w, h, 3);
        let b = signal(w, h, 4);
        let mut f = Fft2::new(w, h).unwrap();
        let mut fa = vec![C32::default(); f.spectrum_len()];
        let mut fb = fa.clone();
        f.forward(&a, &mut fa).unwrap();
        f.forward(&b, &mut fb).unwrap();
        let mut prod: Vec<C32> = fa.iter().zip(&fb).map(|(x, y)| x * y.conj()).collect();
        let mut corr = vec![0.0; w * h];
        f.inverse(&mut prod, &mut corr).unwrap();
        for dy in 0..h {
            for dx in 0..w {
                let mut s = 0.0f64;
                for y in 0..h {
                    for x in 0..w {
                        let ya = (y + dy) % h;
                        let xa = (x + dx) % w;
                        s += a[ya * w + xa] as f64 * b[y * w + x] as f64;
                    }
                }
                let got = corr[dy * w + dx] as f64;
                assert!((got - s).abs() < 1e-4, "({dx},{dy}): {got} vs {s}");
            }
        }
    }

    /// The spectrum as the plain recipe computes it: `realfft` on each row,
    /// then `rustfft` on each column.
    fn reference(w: usize, h: usize, x: &[f32]) -> Vec<C32> {
        let r2c = RealFftPlanner::<f32>::new().plan_fft_forward(w);
        let col = FftPlanner::<f32>::new().plan_fft_forward(h);
        let wc = w / 2 + 1;
        let mut out = vec![C32::default(); wc * h];
        for y in 0..h {
            let mut row = x[y * w..(y + 1) * w].to_vec();
            let mut spec = vec![C32::default(); wc];
            r2c.process(&mut row, &mut spec).unwrap();
            for u in 0..wc {
                out[u * h + y] = spec[u];
            }
        }
        col.process(&mut out);
        out
    }

    #[test]
    fn batched_transforms_are_realfft_bit_for_bit() {
        // even widths take the batched rows (zero rows' bins written as
        // zeros), odd ones one complex FFT over every row: both give the
        // plain recipe's bits
        for (w, h) in [
            (16, 40),
            (2, 3),
            (4, 5),
            (6, 4),
            (10, 9),
            (12, 8),
            (30, 20),
            (9, 6),
            (15, 10),
            (1, 5),
            (3, 1),
            (7, 9),
            (25, 45),
        ] {
            let mut f = Fft2::new(w, h).unwrap();
            let (n, s) = (f.real_len(), f.spectrum_len());
            let mut x = Vec::new();
            for k in 0..3 {
                let mut a = signal(w, h, (w * 7 + h * 3 + k) as u32);
                // zero rows: the first and last (a cosine window's) and,
                // in the middle array, every other one
                a[..w].fill(0.0);
                a[(h - 1) * w..].fill(0.0);
                if k == 1 {
                    for y in (0..h).step_by(2) {
                        a[y * w..(y + 1) * w].fill(0.0);
                    }
                }
                x.extend(a);
            }
            // output buffers hold stale values (as a model's reused ones
            // do): every bin must be written
            let stale = C32::new(f32::NAN, 7.0);
            let mut many = vec![stale; 3 * s];
            f.forward_many(&x, &mut many).unwrap();
            for k in 0..3 {
                let a = &x[k * n..(k + 1) * n];
                let want = reference(w, h, a);
                let mut one = vec![stale; s];
                f.forward(a, &mut one).unwrap();
                for (i, ((m, o), r)) in many[k * s..].iter().zip(&one).zip(&want).enumerate() {
                    // (an even width's zero row has zero bins where
                    // realfft's may hold -0.0; an odd width's are its bits)
                    let same = |p: &C32, q: &C32| {
                        p.re.to_bits() == q.re.to_bits() && p.im.to_bits() == q.im.to_bits()
                            || w % 2 == 0 && p == q
                    };
                    assert!(
                        same(m, r) && same(o, r),
                        "{w}x{h} array {k} bin {i}: {m} {o} vs {r}"
                    );
                }
            }
            // a partial count is an error
            assert!(f.forward_many(&x[..n + 1], &mut many).is_err());
        }
    }

    /// The row spectra of `x` (arrays of `h` rows of an even `w`) as the
    /// scalar code computes them, row by row: each row packed and
    /// transformed alone, untangled by [`untangle_row`], zeros for a row
    /// that is all zero.
    fn scalar_rows(w: usize, h: usize, x: &[f32]) -> Vec<C32> {
        let mut even = EvenRows::new(w, &mut FftPlanner::new());
        let m = w / 2;
        let s = (m + 1) * h;
        let mut out = vec![C32::new(f32::NAN, 7.0); x.len() / (w * h) * s];
        for (r, row) in x.chunks_exact(w).enumerate() {
            let (a, y) = (r / h, r % h);
            let dst = &mut out[a * s + y..];
            if row.iter().all(|&v| v == 0.0) {
                for u in 0..=m {
                    dst[u * h] = C32::default();
                }
                continue;
            }
            let mut packed: Vec<C32> = row.chunks_exact(2).map(|p| C32::new(p[0], p[1])).collect();
            let mut o = vec![C32::default(); m];
            even.fft
                .process_outofplace_with_scratch(&mut packed, &mut o, &mut even.scratch);
            untangle_row(h, &even.twiddles, &o, dst);
        }
        out
    }

    #[test]
    fn row_lanes_are_the_scalar_rows_at_every_level() {
        // every even width to 40, heights below, at and around multiples
        // of the 8 lanes; three arrays with zero rows (the first and last,
        // every third of the second array) and, in the third, rows that
        // are zero but for their last or first sample (a vector test's
        // tail and head)
        for w in (2..=40).step_by(2) {
            for h in [1, 2, 5, 7, 8, 9, 15, 16, 17, 24, 33, 40, 45] {
                let mut x = Vec::new();
                for k in 0..3 {
                    let mut a = signal(w, h, (w * 131 + h * 17 + k) as u32);
                    a[..w].fill(0.0);
                    a[(h - 1) * w..].fill(0.0);
                    if k == 1 {
                        for y in (1..h).step_by(3) {
                            a[y * w..(y + 1) * w].fill(0.0);
                        }
                    }
                    if k == 2 && h >= 4 {
                        a[w..2 * w - 1].fill(0.0);
                        a[2 * w + 1..3 * w].fill(0.0);
                    }
                    x.extend(a);
                }
                let want = scalar_rows(w, h, &x);
                let s = (w / 2 + 1) * h;
                for level in SimdLevel::ALL {
                    let mut rows = EvenRows::new(w, &mut FftPlanner::new());
                    // stale output (every bin must be written); three
                    // arrays, then one (the buffers are grown only)
                    let mut got = vec![C32::new(f32::NAN, 7.0); want.len()];
                    rows.forward(level, w, h, &x, &mut got);
                    let mut one = vec![C32::new(f32::NAN, 7.0); s];
                    rows.forward(level, w, h, &x[..w * h], &mut one);
                    for (i, (g, e)) in got
                        .iter()
                        .chain(&one)
                        .zip(want.iter().chain(&want[..s]))
                        .enumerate()
                    {
                        assert_eq!(
                            (g.re.to_bits(), g.im.to_bits()),
                            (e.re.to_bits(), e.im.to_bits()),
                            "{w}x{h} {level:?}: bin {i} {g} vs {e}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn lane_widths_are_the_same_at_every_level_and_rustfft_where_it_runs_avx() {
        // the width-16 and width-12 kernels on their own (whether or not
        // this machine takes them): every level the scalar level's bits,
        // and where rustfft runs its AVX planner, the rows of rustfft and
        // the scalar untangling; heights at and around multiples of the
        // lanes, zero rows (first, last, every third of the second array)
        // and rows zero but for one sample
        for w in [12, 16] {
            for h in [8, 9, 15, 16, 17, 24, 40, 45] {
                let mut x = Vec::new();
                for k in 0..3 {
                    let mut a = signal(w, h, (w * 131 + h * 17 + k) as u32);
                    a[..w].fill(0.0);
                    a[(h - 1) * w..].fill(0.0);
                    if k == 1 {
                        for y in (1..h).step_by(3) {
                            a[y * w..(y + 1) * w].fill(0.0);
                        }
                    }
                    if k == 2 {
                        a[w..2 * w - 1].fill(0.0);
                        a[2 * w + 1..3 * w].fill(0.0);
                    }
                    x.extend(a);
                }
                let rows = EvenRows::new(w, &mut FftPlanner::new());
                let run = |level: SimdLevel| {
                    let mut got = vec![C32::new(f32::NAN, 7.0); 3 * (w / 2 + 1) * h];
                    rows.row_lanes(level, w, h, &x, &mut got);
                    got
                };
                let bits = |v: &[C32]| -> Vec<(u32, u32)> {
                    v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect()
                };
                let want = bits(&run(SimdLevel::Scalar));
                for level in SimdLevel::ALL {
                    assert_eq!(bits(&run(level)), want, "{w}x{h} {level:?}");
                }
                if rustfft_avx() {
                    assert_eq!(bits(&scalar_rows(w, h, &x)), want, "{w}x{h} rustfft");
                }
            }
        }
    }

    /// The real arrays of `spectrum` (a half spectrum of `w x h`, its
    /// columns already inverse transformed) as the plain recipe computes
    /// them: each row gathered, its DC and Nyquist bins' imaginary parts
    /// zeroed, one `realfft` call, normalised.
    fn reference_inverse_rows(w: usize, h: usize, spectrum: &[C32]) -> Vec<f32> {
        let c2r = RealFftPlanner::<f32>::new().plan_fft_inverse(w);
        let wc = w / 2 + 1;
        let norm = 1.0 / (w * h) as f32;
        let mut out = vec![0.0f32; w * h];
        for (y, row) in out.chunks_exact_mut(w).enumerate() {
            let mut src: Vec<C32> = (0..wc).map(|u| spectrum[u * h + y]).collect();
            src[0].im = 0.0;
            if w.is_multiple_of(2) {
                src[wc - 1].im = 0.0;
            }
            c2r.process(&mut src, row).unwrap();
            for v in row.iter_mut() {
                *v *= norm;
            }
        }
        out
    }

    #[test]
    fn inverse_row_lanes_are_the_same_at_every_level_and_realfft_where_it_runs_avx() {
        // the inverse lane kernel on its own (whether or not this machine
        // takes it), widths 16 and 12, heights at and around multiples of
        // the lanes: every level the scalar level's bits, and where rustfft
        // runs its AVX planner, realfft's; the DC and Nyquist bins hold
        // imaginary parts (ignored), and every sample must be written
        for w in [12, 16] {
            for h in [8, 9, 15, 16, 17, 24, 40, 45] {
                let wc = w / 2 + 1;
                let re = signal(wc, h, (w * 31 + h) as u32);
                let im = signal(wc, h, (w * 37 + h) as u32);
                let spectrum: Vec<C32> =
                    re.iter().zip(&im).map(|(&a, &b)| C32::new(a, b)).collect();
                let twiddles = InverseTwiddles::new(w);
                let run = |level: SimdLevel| {
                    let mut out = vec![f32::NAN; w * h];
                    level.run(InverseRows {
                        w,
                        h,
                        twiddles: &twiddles,
                        spectrum: &spectrum,
                        out: &mut out,
                    });
                    out.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                };
                let want = run(SimdLevel::Scalar);
                for level in SimdLevel::ALL {
                    assert_eq!(run(level), want, "{w}x{h} {level:?}");
                }
                if rustfft_avx() {
                    let r = reference_inverse_rows(w, h, &spectrum);
                    let r: Vec<u32> = r.iter().map(|v| v.to_bits()).collect();
                    assert_eq!(r, want, "{w}x{h} realfft");
                }
            }
        }
    }

    #[test]
    fn inverse_is_the_plain_recipe_bit_for_bit() {
        // Fft2::inverse (lanes or one realfft call per row, whichever this
        // machine takes) against rustfft down the columns and realfft on
        // each row
        for (w, h) in [
            (16, 40),
            (16, 9),
            (16, 3),
            (12, 17),
            (12, 5),
            (10, 9),
            (8, 8),
            (7, 9),
        ] {
            let mut f = Fft2::new(w, h).unwrap();
            let s = f.spectrum_len();
            let re = signal(s, 1, (w * 11 + h) as u32);
            let im = signal(s, 1, (w * 13 + h) as u32);
            let spectrum: Vec<C32> = re.iter().zip(&im).map(|(&a, &b)| C32::new(a, b)).collect();
            let mut cols = spectrum.clone();
            FftPlanner::<f32>::new()
                .plan_fft_inverse(h)
                .process(&mut cols);
            let want: Vec<u32> = reference_inverse_rows(w, h, &cols)
                .iter()
                .map(|v| v.to_bits())
                .collect();
            let mut spec = spectrum.clone();
            let mut out = vec![f32::NAN; w * h];
            f.inverse(&mut spec, &mut out).unwrap();
            let got: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, want, "{w}x{h}");
        }
    }

    #[test]
    fn column_lanes_of_40_are_rustfft_bit_for_bit_at_every_level() {
        // Columns40 on its own, both directions, every count of columns
        // from 8 (its least) to 40, multiples of the lanes or not: every
        // level the scalar level's bits, and where rustfft runs its AVX
        // code (the plan it reproduces), rustfft's
        for inverse in [false, true] {
            let twiddles = Radix5x8::new(inverse);
            let mut planner = FftPlanner::<f32>::new();
            let fft = if inverse {
                planner.plan_fft_inverse(40)
            } else {
                planner.plan_fft_forward(40)
            };
            for n in LANES..=40 {
                let re = signal(40, n, (n * 3 + usize::from(inverse)) as u32);
                let im = signal(40, n, (n * 5 + 1) as u32);
                let data: Vec<C32> = re.iter().zip(&im).map(|(&a, &b)| C32::new(a, b)).collect();
                let bits = |v: &[C32]| -> Vec<(u32, u32)> {
                    v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect()
                };
                let run = |level: SimdLevel| {
                    let mut d = data.clone();
                    level.run(Columns40 {
                        twiddles: &twiddles,
                        inverse,
                        blocks: &mut Box::new([Points40::ZERO; 2]),
                        data: &mut d,
                    });
                    bits(&d)
                };
                let want = run(SimdLevel::Scalar);
                for level in SimdLevel::ALL {
                    assert_eq!(run(level), want, "{n} columns {level:?} inverse {inverse}");
                }
                if rustfft_avx() {
                    let mut r = data.clone();
                    fft.process(&mut r);
                    assert_eq!(bits(&r), want, "{n} columns rustfft inverse {inverse}");
                }
            }
        }
    }

    #[test]
    fn wrong_sizes_are_errors() {
        assert!(Fft2::new(0, 4).is_err());
        let mut f = Fft2::new(4, 4).unwrap();
        let mut spec = vec![C32::default(); 3];
        assert!(matches!(
            f.forward(&[0.0; 16], &mut spec),
            Err(DcfError::Size { .. })
        ));
    }
}
