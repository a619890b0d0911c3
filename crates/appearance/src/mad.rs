//! MAD template matching (Dong and Chen (paper 004), eq. 1 and eq. 7).
//!
//! `MAD(i, j) = 1/(M N) sum_m sum_n |T(m, n) - F(m + i, n + j)|`, the mean
//! absolute difference between the template `T` and the frame window whose
//! top-left corner is `(i, j)` (averaged over channels too). The
//! observation likelihood is `p(z | x) = exp(-MAD / (2 sigma^2))` (eq. 7),
//! evaluated here in the log domain.

use std::cell::RefCell;

use bayestrack_image::simd::{Kernel, Token, dispatch};
use bayestrack_image::{ImageError, ImageView, ImageViewMut, Pixel, Rect, SadTemplate, SimdLevel};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// Most positions one call of [`MadPixel::sad_positions`] handles.
pub const SAD_CHUNK: usize = 512;

/// Rows of the MAD surface [`mad_map_into`] asks of the SAD kernel at once
/// ([`SadTemplate::sad_window_rows`]: its AVX2 gray kernel shares frame
/// rows between pairs of rows of windows).
const MAP_ROWS: usize = 6;

/// Scalars MAD can be computed on, with fast kernels.
pub trait MadPixel: Pixel {
    /// `sum |a_k - b_k|` over two rows of equal length.
    fn sad_row(a: &[Self], b: &[Self]) -> f64;

    /// The view as bytes when `Self` is `u8`: byte images take the SIMD
    /// SAD kernels of [`SadTemplate`] (run-time dispatch to SSE2, AVX2 or
    /// AVX-512BW, integer sums equal to the scalar ones).
    fn as_bytes<'a>(view: &ImageView<'a, Self>) -> Option<ImageView<'a, u8>> {
        let _ = view;
        None
    }

    /// Sums of absolute differences between `template` and the frame
    /// windows with top-left corners `(x0 + i, y)`, `i < out.len()`, into
    /// `out` (at most [`SAD_CHUNK`] positions). The caller guarantees that
    /// every window is inside the frame and the channels agree.
    ///
    /// The default evaluates window by window; `u8` overrides it with a
    /// kernel that runs across positions (broadcast one template value,
    /// stream a frame row), which vectorises.
    fn sad_positions(
        frame: &ImageView<'_, Self>,
        template: &ImageView<'_, Self>,
        x0: usize,
        y: usize,
        out: &mut [f64],
    ) {
        sad_positions_by_rows(frame, template, x0, y, out);
    }
}

/// [`MadPixel::sad_positions`] window by window, row by row (f64 sums).
fn sad_positions_by_rows<T: MadPixel>(
    frame: &ImageView<'_, T>,
    template: &ImageView<'_, T>,
    x0: usize,
    y: usize,
    out: &mut [f64],
) {
    let ch = template.channels();
    let n = template.width() * ch;
    for (i, o) in out.iter_mut().enumerate() {
        let x = x0 + i;
        *o = (0..template.height())
            .map(|r| T::sad_row(template.row(r), &frame.row(y + r)[x * ch..x * ch + n]))
            .sum();
    }
}

impl MadPixel for u8 {
    #[inline]
    fn sad_row(a: &[u8], b: &[u8]) -> f64 {
        f64::from(bayestrack_image::sad_u8(a, b))
    }

    fn as_bytes<'a>(view: &ImageView<'a, u8>) -> Option<ImageView<'a, u8>> {
        Some(*view)
    }

    fn sad_positions(
        frame: &ImageView<'_, u8>,
        template: &ImageView<'_, u8>,
        x0: usize,
        y: usize,
        out: &mut [f64],
    ) {
        if !fits_u32(template) {
            // The kernels' u32 sums could wrap.
            sad_positions_by_rows(frame, template, x0, y, out);
            return;
        }
        let npos = out.len().min(SAD_CHUNK);
        let mut sums = [0u32; SAD_CHUNK];
        with_thread_template(*template, |t| {
            t.sad_windows(*frame, x0, y, &mut sums[..npos]);
        });
        for (o, &s) in out.iter_mut().zip(&sums[..npos]) {
            *o = f64::from(s);
        }
    }
}

thread_local! {
    /// A per-thread padded template for the free functions, so that they
    /// allocate nothing once warm.
    static THREAD_TEMPLATE: RefCell<SadTemplate> = RefCell::new(SadTemplate::new(SimdLevel::detect()));
}

/// Runs `f` on this thread's [`SadTemplate`] loaded with `template`.
fn with_thread_template<R>(template: ImageView<'_, u8>, f: impl FnOnce(&SadTemplate) -> R) -> R {
    THREAD_TEMPLATE.with(|cell| {
        let mut t = cell.borrow_mut();
        t.set(template);
        f(&t)
    })
}

/// Whether integer SADs of this template fit in `u32` (the SIMD kernels'
/// sums): `255 * elements < 2^32`, templates of up to 16.8 million bytes.
fn fits_u32(template: &ImageView<'_, u8>) -> bool {
    (template.width() * template.channels()).saturating_mul(template.height())
        < (u32::MAX / 255) as usize
}

impl MadPixel for f32 {
    #[inline]
    fn sad_row(a: &[f32], b: &[f32]) -> f64 {
        let mut acc = [0f32; 8];
        let mut ca = a.chunks_exact(8);
        let mut cb = b.chunks_exact(8);
        for (x, y) in (&mut ca).zip(&mut cb) {
            for k in 0..8 {
                acc[k] += (x[k] - y[k]).abs();
            }
        }
        let tail: f32 = ca
            .remainder()
            .iter()
            .zip(cb.remainder())
            .map(|(x, y)| (x - y).abs())
            .sum();
        f64::from(acc.iter().sum::<f32>() + tail)
    }
}

fn check_template<T: Pixel>(frame: &ImageView<'_, T>, template: &ImageView<'_, T>) -> Result<()> {
    if frame.channels() != template.channels() {
        return Err(ImageError::Channels {
            operation: "mad",
            expected: frame.channels(),
            got: template.channels(),
        }
        .into());
    }
    Ok(())
}

/// MAD between `template` and the frame window with top-left `(x, y)` (eq. 1).
///
/// # Errors
/// [`AppearanceError::WindowOutside`] if the window leaves the frame;
/// [`ImageError::Channels`] if the channel counts differ;
/// [`AppearanceError::NonFinite`] when the MAD is not a number (NaN or
/// infinite pixels in a float template or window, or differences that
/// overflow the pixel type).
pub fn mad<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    x: usize,
    y: usize,
) -> Result<f64> {
    check_template(&frame, &template)?;
    let window = Rect::new(x, y, template.width(), template.height());
    check_window("mad", window, frame.width(), frame.height())?;
    check_finite_template(&template)?;
    let m = mad_unchecked(&frame, &template, x, y);
    if !m.is_finite() {
        return Err(AppearanceError::NonFinite {
            what: "MAD window of the frame (NaN or infinite pixels, or differences beyond the \
                   pixel type's range)",
        });
    }
    Ok(m)
}

/// Refuses a float template with a NaN or infinite pixel (every window's
/// MAD would be NaN or infinite). Byte templates pass at once.
fn check_finite_template<T: MadPixel>(template: &ImageView<'_, T>) -> Result<()> {
    if T::as_bytes(template).is_some() {
        return Ok(());
    }
    for r in 0..template.height() {
        if !template.row(r).iter().all(|v| v.to_f32().is_finite()) {
            return Err(AppearanceError::NonFinite {
                what: "MAD template",
            });
        }
    }
    Ok(())
}

/// The error of a search whose SAD at some position was NaN or infinite
/// (the template was checked first, so the frame is the cause).
fn non_finite_region() -> AppearanceError {
    AppearanceError::NonFinite {
        what: "MAD search region of the frame (NaN or infinite pixels, or differences beyond \
               the pixel type's range)",
    }
}

#[inline]
fn mad_unchecked<T: MadPixel>(
    frame: &ImageView<'_, T>,
    template: &ImageView<'_, T>,
    x: usize,
    y: usize,
) -> f64 {
    let ch = template.channels();
    let n = template.width() * ch;
    let mut sum = 0.0;
    for r in 0..template.height() {
        let fr = &frame.row(y + r)[x * ch..x * ch + n];
        sum += T::sad_row(template.row(r), fr);
    }
    sum / (n * template.height()) as f64
}

/// The best match of an exhaustive search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MadMatch {
    /// Left column of the best window in the frame (0-based).
    pub x: usize,
    /// Top row of the best window in the frame (0-based).
    pub y: usize,
    /// Its MAD (eq. 1).
    pub mad: f64,
}

impl MadMatch {
    /// The matched window.
    pub fn window(&self, template_width: usize, template_height: usize) -> Rect {
        Rect::new(self.x, self.y, template_width, template_height)
    }
}

fn check_region<T: Pixel>(
    frame: &ImageView<'_, T>,
    template: &ImageView<'_, T>,
    region: Rect,
) -> Result<()> {
    check_template(frame, template)?;
    check_window("mad_search", region, frame.width(), frame.height())?;
    if template.width() > region.width || template.height() > region.height {
        return Err(AppearanceError::TemplateLargerThanRegion {
            template_width: template.width(),
            template_height: template.height(),
            region,
        });
    }
    Ok(())
}

/// Exhaustive MAD search: the window inside `region` (template fully
/// inside) with the smallest MAD; ties go to the first in raster order.
///
/// Convenience over [`MadSearch`]: a per-thread one keeps its buffers
/// between calls.
///
/// # Errors
/// [`AppearanceError::WindowOutside`] if `region` leaves the frame;
/// [`AppearanceError::TemplateLargerThanRegion`]; [`ImageError::Channels`];
/// [`AppearanceError::NonFinite`] naming the template or the frame region
/// when a float image holds NaN or infinite pixels (a NaN frame returned
/// position (0, 0) with MAD inf) or values whose differences overflow.
pub fn mad_search<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    region: Rect,
) -> Result<MadMatch> {
    THREAD_SEARCH.with(|cell| cell.borrow_mut().search(frame, template, region))
}

thread_local! {
    /// A per-thread search for [`mad_search`], so that it allocates nothing
    /// once warm (its bound buffers are a few hundred kilobytes for a
    /// 320x240 region, and fresh ones cost page faults on every call).
    static THREAD_SEARCH: RefCell<MadSearch> = RefCell::new(MadSearch::new());
}

/// Most row blocks of the template in [`MadSearch`]'s lower bound.
const BOUND_BLOCKS: usize = 8;
/// Template rows per block of the bound where there are few enough rows
/// (the SAD kernels compare their running sum with the best after every
/// four rows).
const BOUND_BLOCK_ROWS: usize = 4;

/// `bounds[i] += |(bottom[i] - top[i]) - tsum|` (wrapping differences of
/// cumulated sums), one block's term of the search's lower bound.
struct AddBlockBound<'a> {
    bounds: &'a mut [u32],
    top: &'a [u32],
    bottom: &'a [u32],
    tsum: u32,
    /// The first block sets `bounds` instead of adding to it.
    first: bool,
}

impl Kernel for AddBlockBound<'_> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        let terms = self.bounds.iter_mut().zip(self.top).zip(self.bottom);
        if self.first {
            for ((b, &t), &d) in terms {
                *b = d.wrapping_sub(t).abs_diff(self.tsum);
            }
        } else {
            for ((b, &t), &d) in terms {
                *b += d.wrapping_sub(t).abs_diff(self.tsum);
            }
        }
    }
}

/// `out[i] = (sums[i] * norm) as f32`, the surface's MADs from its
/// integer SADs: dispatched, so that the conversions vectorise (they were
/// a tenth of the gray surface's instructions one at a time); the same
/// IEEE operations, so the same numbers. `signed`: every sum is at most
/// `i32::MAX`, so each converts from `i32` (one instruction for four, the
/// same `f64`: both conversions are exact).
struct ScaleSums<'a> {
    sums: &'a [u32],
    out: &'a mut [f32],
    norm: f64,
    signed: bool,
}

impl Kernel for ScaleSums<'_> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        if self.signed {
            for (o, &s) in self.out.iter_mut().zip(self.sums) {
                *o = (f64::from(s as i32) * self.norm) as f32;
            }
        } else {
            for (o, &s) in self.out.iter_mut().zip(self.sums) {
                *o = (f64::from(s) * self.norm) as f32;
            }
        }
    }
}

/// The smallest element (`u32::MAX` for none).
struct MinOf<'a>(&'a [u32]);

impl Kernel for MinOf<'_> {
    type Output = u32;
    #[inline(always)]
    fn run<K: Token>(self, _: K) -> u32 {
        self.0.iter().fold(u32::MAX, |m, &b| m.min(b))
    }
}

/// Exhaustive MAD search with reusable buffers (no allocation once warm).
///
/// The result is exactly the minimum of eq. 1 over all positions (first in
/// raster order on ties). Byte images are searched with successive
/// elimination: the absolute difference of the template's and a window's
/// sums is at most their SAD, so a position whose bound exceeds the best
/// SAD so far cannot win and is skipped; the search is seeded with the
/// position of smallest bound and with the region's centre (where a
/// tracker's prediction usually is), so that the bound bites from the first
/// row, and the SADs run on the SIMD kernels of [`SadTemplate`]. Other
/// scalars (floats, whose sums are not exact) are searched exhaustively,
/// with [`MadPixel::sad_positions`] across positions.
#[derive(Clone, Debug, Default)]
pub struct MadSearch {
    sad: SadTemplate,
    prefix: Vec<u32>,
    cum: Vec<u32>,
    row_mins: Vec<u32>,
    byte_bounds: Vec<u32>,
}

impl MadSearch {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Searches `region` for `template`; see [`mad_search`].
    ///
    /// # Errors
    /// As [`mad_search`].
    pub fn search<T: MadPixel>(
        &mut self,
        frame: ImageView<'_, T>,
        template: ImageView<'_, T>,
        region: Rect,
    ) -> Result<MadMatch> {
        check_region(&frame, &template, region)?;
        check_finite_template(&template)?;
        let (tw, th, ch) = (template.width(), template.height(), template.channels());
        let n = tw * ch;
        let (npx, npy) = (region.width - tw + 1, region.height - th + 1);
        let norm = (n * th) as f64;
        let mut best = (f64::INFINITY, region.y, region.x);
        // (sum, y, x): smaller sum wins, then earlier raster position.
        let better = |s: f64, y: usize, x: usize, b: &(f64, usize, usize)| {
            s < b.0 || (s == b.0 && (y, x) < (b.1, b.2))
        };
        if let (Some(f), Some(t)) = (T::as_bytes(&frame), T::as_bytes(&template))
            && fits_u32(&t)
        {
            let (y, x, s) = self.search_bytes(f, t, region);
            return Ok(MadMatch {
                x,
                y,
                mad: f64::from(s) / norm,
            });
        }
        let mut sums = [0f64; SAD_CHUNK];
        // every SAD is >= 0; `s <= MAX` fails for NaN and inf alike
        let mut finite = true;
        for j in 0..npy {
            let y = region.y + j;
            let mut i0 = 0;
            while i0 < npx {
                let k = (npx - i0).min(SAD_CHUNK);
                T::sad_positions(&frame, &template, region.x + i0, y, &mut sums[..k]);
                for (i, &s) in sums[..k].iter().enumerate() {
                    finite &= s <= f64::MAX;
                    if better(s, y, region.x + i0 + i, &best) {
                        best = (s, y, region.x + i0 + i);
                    }
                }
                i0 += k;
            }
        }
        if !finite {
            return Err(non_finite_region());
        }
        Ok(MadMatch {
            x: best.2,
            y: best.1,
            mad: best.0 / norm,
        })
    }

    /// The byte-image search: `(y, x, SAD)` of the best window.
    ///
    /// Successive elimination with a block bound: the template's rows are
    /// split into blocks (four rows each, at most eight blocks) and
    /// `sum_blocks |sum T_block - sum W_block| <= SAD`. Every window row's
    /// sum comes from prefix sums along the frame row, cumulated down the
    /// region, so a block's sum is one subtraction and the bound costs a
    /// few vector operations per position. The search is seeded with the
    /// first position of smallest bound and the region's centre; then, row
    /// of positions by row, the SIMD kernel over the whole row where many
    /// positions survive, else each survivor's SAD with an exit after the
    /// first four-row group that exceeds the best so far. Sums are
    /// integers, so the minimum and the raster-order tie-break are exactly
    /// those of the exhaustive search. On the David and Couple benches
    /// (30x20 next-frame templates over 320x240) the five-block bound
    /// takes 0.67 and 0.54 times the instructions of the whole-window one.
    fn search_bytes(
        &mut self,
        frame: ImageView<'_, u8>,
        template: ImageView<'_, u8>,
        region: Rect,
    ) -> (usize, usize, u32) {
        let (tw, th, ch) = (template.width(), template.height(), template.channels());
        let n = tw * ch;
        let (npx, npy) = (region.width - tw + 1, region.height - th + 1);
        self.sad.set(template);
        // The template's rows in `nb` blocks, `edges[k]..edges[k + 1]`.
        let nb = th.div_ceil(BOUND_BLOCK_ROWS).min(BOUND_BLOCKS);
        let mut edges = [0usize; BOUND_BLOCKS + 1];
        for (k, e) in edges[..=nb].iter_mut().enumerate() {
            *e = k * th / nb;
        }
        let mut tblocks = [0u32; BOUND_BLOCKS];
        for (k, t) in tblocks[..nb].iter_mut().enumerate() {
            *t = (edges[k]..edges[k + 1])
                .map(|r| template.row(r).iter().map(|&v| u32::from(v)).sum::<u32>())
                .sum();
        }
        // The sums of every window row in the region, cumulated down the
        // region: `cum[yy * npx + i]` sums the rows above region row `yy` of
        // the windows in column `i`, so a block's sum is a difference of
        // two. Window-row sums are differences of prefix sums along the
        // row. Both wrap in u32, but every block sum is below 2^32
        // (`fits_u32`), so the wrapped differences are exact.
        let cols = region.width * ch;
        let x0 = region.x * ch;
        // Four rows' prefix sums at a time: four independent chains of adds.
        const ROWS: usize = 4;
        let len = cols + 1;
        self.prefix.resize(ROWS * len, 0);
        for r in 0..ROWS {
            self.prefix[r * len] = 0;
        }
        self.cum.resize((region.height + 1) * npx, 0);
        self.cum[..npx].fill(0);
        for y4 in (0..region.height).step_by(ROWS) {
            let k = ROWS.min(region.height - y4);
            let rows: [&[u8]; ROWS] =
                std::array::from_fn(|r| &frame.row(region.y + y4 + r.min(k - 1))[x0..x0 + cols]);
            {
                let mut p = self.prefix.chunks_exact_mut(len);
                let mut next = || &mut p.next().unwrap()[1..];
                let (p0, p1, p2, p3) = (next(), next(), next(), next());
                let [r0, r1, r2, r3] = rows;
                let mut acc = [0u32; ROWS];
                for c in 0..cols {
                    acc[0] = acc[0].wrapping_add(u32::from(r0[c]));
                    acc[1] = acc[1].wrapping_add(u32::from(r1[c]));
                    acc[2] = acc[2].wrapping_add(u32::from(r2[c]));
                    acc[3] = acc[3].wrapping_add(u32::from(r3[c]));
                    p0[c] = acc[0];
                    p1[c] = acc[1];
                    p2[c] = acc[2];
                    p3[c] = acc[3];
                }
            }
            for r in 0..k {
                let yy = y4 + r;
                let prefix = &self.prefix[r * len..(r + 1) * len];
                let (above, below) = self.cum.split_at_mut((yy + 1) * npx);
                let (above, below) = (&above[yy * npx..], &mut below[..npx]);
                if ch == 1 {
                    for (((c, &a), &lo), &hi) in
                        below.iter_mut().zip(above).zip(prefix).zip(&prefix[n..])
                    {
                        *c = a.wrapping_add(hi.wrapping_sub(lo));
                    }
                } else {
                    for (i, (c, &a)) in below.iter_mut().zip(above).enumerate() {
                        let w = prefix[i * ch + n].wrapping_sub(prefix[i * ch]);
                        *c = a.wrapping_add(w);
                    }
                }
            }
        }
        self.byte_bounds.resize(npx * npy, 0);
        self.row_mins.resize(npy, 0);
        for j in 0..npy {
            let bounds = &mut self.byte_bounds[j * npx..(j + 1) * npx];
            for k in 0..nb {
                let top = &self.cum[(j + edges[k]) * npx..][..npx];
                let bottom = &self.cum[(j + edges[k + 1]) * npx..][..npx];
                dispatch(AddBlockBound {
                    bounds,
                    top,
                    bottom,
                    tsum: tblocks[k],
                    first: k == 0,
                });
            }
            self.row_mins[j] = dispatch(MinOf(bounds));
        }
        let data = frame.as_slice();
        let stride = frame.stride();
        let sad_at = |x: usize, y: usize, limit: u32| {
            self.sad.sad_at(data, stride, y * stride + x * ch, limit)
        };
        // (sum, y, x): smaller sum wins, then earlier raster position.
        let better = |s: u32, y: usize, x: usize, b: &(u32, usize, usize)| {
            s < b.0 || (s == b.0 && (y, x) < (b.1, b.2))
        };
        let mut best = (u32::MAX, usize::MAX, usize::MAX);
        // The first position of smallest bound: the row with the smallest
        // minimum, then the position in it.
        let j_min = (0..npy).min_by_key(|&j| self.row_mins[j]).unwrap_or(0);
        let row = &self.byte_bounds[j_min * npx..(j_min + 1) * npx];
        let k_min = j_min * npx
            + row
                .iter()
                .position(|&b| b == self.row_mins[j_min])
                .unwrap_or(0);
        for (x, y) in [
            (region.x + k_min % npx, region.y + k_min / npx),
            (region.x + npx / 2, region.y + npy / 2),
        ] {
            let s = sad_at(x, y, best.0);
            if better(s, y, x, &best) {
                best = (s, y, x);
            }
        }
        let mut sums = [0u32; SAD_CHUNK];
        for j in 0..npy {
            let y = region.y + j;
            let bounds = &self.byte_bounds[j * npx..(j + 1) * npx];
            let survivors = bounds.iter().filter(|&&b| b <= best.0).count();
            if survivors == 0 {
                continue;
            }
            if survivors * 4 > npx {
                let mut i0 = 0;
                while i0 < npx {
                    let k = (npx - i0).min(SAD_CHUNK);
                    self.sad
                        .sad_windows(frame, region.x + i0, y, &mut sums[..k]);
                    for (i, &s) in sums[..k].iter().enumerate() {
                        if better(s, y, region.x + i0 + i, &best) {
                            best = (s, y, region.x + i0 + i);
                        }
                    }
                    i0 += k;
                }
            } else {
                for (i, &b) in bounds.iter().enumerate() {
                    if b > best.0 {
                        continue;
                    }
                    let x = region.x + i;
                    let s = sad_at(x, y, best.0);
                    if better(s, y, x, &best) {
                        best = (s, y, x);
                    }
                }
            }
        }
        (best.1, best.2, best.0)
    }
}

/// The full MAD surface over `region`: `out(i, j) = MAD(region.x + i,
/// region.y + j)`. `out` must be 1-channel, `(region.width - tw + 1) x
/// (region.height - th + 1)`. Allocation-free.
///
/// # Errors
/// As [`mad_search`] (a MAD that is not a finite `f32`), plus
/// [`ImageError::SizeMismatch`] for a wrong `out`; on error `out` holds
/// partial results.
pub fn mad_map_into<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    region: Rect,
    out: &mut ImageViewMut<'_, f32>,
) -> Result<()> {
    check_region(&frame, &template, region)?;
    let (tw, th) = (template.width(), template.height());
    let (ow, oh) = (region.width - tw + 1, region.height - th + 1);
    if out.width() != ow || out.height() != oh || out.channels() != 1 {
        return Err(ImageError::SizeMismatch {
            operation: "mad_map_into",
            a_width: ow,
            a_height: oh,
            a_channels: 1,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        }
        .into());
    }
    check_finite_template(&template)?;
    let norm = 1.0 / (tw * th * template.channels()) as f64;
    if let (Some(f), Some(t)) = (T::as_bytes(&frame), T::as_bytes(&template))
        && fits_u32(&t)
    {
        // MAP_ROWS rows of the surface a call: the kernel may share each
        // frame row between rows of windows (SadTemplate::sad_window_rows).
        let mut sums = [0u32; SAD_CHUNK * MAP_ROWS];
        // Every SAD is at most 255 a byte of the template.
        let signed = t.width() * t.channels() * t.height() <= (i32::MAX / 255) as usize;
        with_thread_template(t, |sad| {
            for j in (0..oh).step_by(MAP_ROWS) {
                let rows = (oh - j).min(MAP_ROWS);
                let mut i0 = 0;
                while i0 < ow {
                    let n = (ow - i0).min(SAD_CHUNK);
                    let sums = &mut sums[..n * rows];
                    sad.sad_window_rows(f, region.x + i0, region.y + j, n, sums);
                    for (r, sums) in sums.chunks_exact(n).enumerate() {
                        dispatch(ScaleSums {
                            sums,
                            out: &mut out.row_mut(j + r)[i0..i0 + n],
                            norm,
                            signed,
                        });
                    }
                    i0 += n;
                }
            }
        });
        return Ok(());
    }
    let mut sums = [0f64; SAD_CHUNK];
    // `o <= MAX` fails for NaN and inf (and a MAD beyond f32) alike
    let mut finite = true;
    for j in 0..oh {
        let mut i0 = 0;
        while i0 < ow {
            let n = (ow - i0).min(SAD_CHUNK);
            T::sad_positions(
                &frame,
                &template,
                region.x + i0,
                region.y + j,
                &mut sums[..n],
            );
            for (o, &s) in out.row_mut(j)[i0..i0 + n].iter_mut().zip(&sums[..n]) {
                *o = (s * norm) as f32;
                finite &= *o <= f32::MAX;
            }
            i0 += n;
        }
    }
    if !finite {
        return Err(non_finite_region());
    }
    Ok(())
}

/// The MAD likelihood of eq. 7, `p = exp(-MAD / (2 sigma^2))`, kept in logs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MadLikelihood {
    sigma: f64,
}

impl MadLikelihood {
    /// With spread `sigma` (in the MAD's own units, e.g. gray levels).
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] unless `sigma` is finite and at
    /// least 1e-100 (below it `2 sigma^2` underflows and a MAD of 0 scored
    /// NaN).
    pub fn new(sigma: f64) -> Result<Self> {
        Ok(Self {
            sigma: crate::error::spread("sigma", sigma)?,
        })
    }

    /// The spread sigma.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// `ln p = -MAD / (2 sigma^2)`.
    ///
    /// # Errors
    /// [`AppearanceError::NonFinite`] for a NaN or infinite MAD.
    pub fn log_likelihood(&self, mad: f64) -> Result<f64> {
        if !mad.is_finite() {
            return Err(AppearanceError::NonFinite { what: "MAD" });
        }
        Ok(-mad / (2.0 * self.sigma * self.sigma))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn hand_computed_mad() {
        // Frame 4x3, template 2x2.
        let f = Image::from_vec(4, 3, 1, vec![1u8, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]).unwrap();
        let t = Image::from_vec(2, 2, 1, vec![2u8, 2, 6, 9]).unwrap();
        // Window (1, 1): [6 7; 10 11]; |2-6|+|2-7|+|6-10|+|9-11| = 4+5+4+2 = 15.
        assert_eq!(mad(f.view(), t.view(), 1, 1).unwrap(), 15.0 / 4.0);
        // Window (0, 0): [1 2; 5 6]: 1+0+1+3 = 5.
        assert_eq!(mad(f.view(), t.view(), 0, 0).unwrap(), 5.0 / 4.0);
        let ff = f.map(f32::from);
        let tf = t.map(f32::from);
        assert_eq!(mad(ff.view(), tf.view(), 1, 1).unwrap(), 15.0 / 4.0);
        // Window (1, 0): [2 3; 6 7]: 0+1+0+2 = 3, the minimum of the six sums
        // (5, 3, 5 on the top row of positions; 11, 15, 19 below).
        let m = mad_search(f.view(), t.view(), Rect::new(0, 0, 4, 3)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (1, 0, 0.75));
        let mut out = Image::new(3, 2, 1, 0f32).unwrap();
        mad_map_into(
            f.view(),
            t.view(),
            Rect::new(0, 0, 4, 3),
            &mut out.view_mut(),
        )
        .unwrap();
        assert_eq!(out.get(1, 1, 0), Some(3.75));
        assert_eq!(out.get(0, 0, 0), Some(1.25));
        assert_eq!(out.get(1, 0, 0), Some(0.75));
    }

    #[test]
    fn sad_kernel_matches_naive_on_long_rows() {
        let a: Vec<u8> = (0..5000u32).map(|i| (i * 37 % 256) as u8).collect();
        let b: Vec<u8> = (0..5000u32).map(|i| (i * 91 % 256) as u8).collect();
        let naive: u32 = a
            .iter()
            .zip(&b)
            .map(|(x, y)| u32::from(x.abs_diff(*y)))
            .sum();
        assert_eq!(u8::sad_row(&a, &b), f64::from(naive));
        assert_eq!(u8::sad_row(&[255; 9000], &[0; 9000]), 255.0 * 9000.0);
    }

    use bayestrack_testkit::noise;

    fn textured(w: usize, h: usize, seed: u32) -> Image<u8> {
        noise(w, h, 1, seed)
    }

    #[test]
    fn search_finds_a_pasted_template() {
        let mut frame = textured(120, 90, 1);
        let tpl = textured(30, 20, 2);
        let (px, py) = (71, 43);
        bayestrack_testkit::paste(&mut frame, tpl.view(), px, py);
        let m = mad_search(frame.view(), tpl.view(), Rect::new(0, 0, 120, 90)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (px, py, 0.0));
        // Restricted region that still contains it, and one that does not.
        let m = mad_search(frame.view(), tpl.view(), Rect::new(60, 40, 50, 30)).unwrap();
        assert_eq!((m.x, m.y), (px, py));
        let m = mad_search(frame.view(), tpl.view(), Rect::new(0, 0, 60, 60)).unwrap();
        assert!(m.mad > 50.0);
        // Brute force agrees.
        let region = Rect::new(5, 7, 70, 50);
        let mut best = (f64::INFINITY, 0, 0);
        for y in region.y..=region.bottom() - 20 {
            for x in region.x..=region.right() - 30 {
                let v = mad(frame.view(), tpl.view(), x, y).unwrap();
                if v < best.0 {
                    best = (v, x, y);
                }
            }
        }
        let m = mad_search(frame.view(), tpl.view(), region).unwrap();
        assert_eq!((m.mad, m.x, m.y), best);
    }

    #[test]
    fn wide_regions_and_colour_templates_match_brute_force() {
        // More than SAD_CHUNK positions per row, and a 3-channel template.
        let frame = textured(700, 12, 7);
        let tpl = frame.crop(Rect::new(681, 5, 9, 4)).unwrap().to_image();
        let m = mad_search(frame.view(), tpl.view(), Rect::new(0, 0, 700, 12)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (681, 5, 0.0));
        let rgb = Image::from_vec(100, 10, 3, textured(300, 10, 8).into_vec()).unwrap();
        let tpl = rgb.crop(Rect::new(60, 3, 5, 4)).unwrap().to_image();
        let region = Rect::new(0, 0, 100, 10);
        let m = mad_search(rgb.view(), tpl.view(), region).unwrap();
        assert_eq!((m.x, m.y, m.mad), (60, 3, 0.0));
        let mut out = Image::new(96, 7, 1, 0f32).unwrap();
        mad_map_into(rgb.view(), tpl.view(), region, &mut out.view_mut()).unwrap();
        for (x, y) in [(0, 0), (17, 2), (95, 6)] {
            let want = mad(rgb.view(), tpl.view(), x, y).unwrap();
            assert!((f64::from(out.get(x, y, 0).unwrap()) - want).abs() < 1e-4);
        }
        // A template wider than 257 elements per row exercises the lane flush.
        let wide = textured(400, 3, 9);
        let tpl = wide.crop(Rect::new(50, 1, 300, 2)).unwrap().to_image();
        let m = mad_search(wide.view(), tpl.view(), Rect::new(0, 0, 400, 3)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (50, 1, 0.0));
        let mut out = Image::new(101, 2, 1, 0f32).unwrap();
        mad_map_into(
            wide.view(),
            tpl.view(),
            Rect::new(0, 0, 400, 3),
            &mut out.view_mut(),
        )
        .unwrap();
        let want = mad(wide.view(), tpl.view(), 7, 0).unwrap();
        assert!((f64::from(out.get(7, 0, 0).unwrap()) - want).abs() < 1e-4);
    }

    #[test]
    fn pruned_search_equals_brute_force_including_ties() {
        let mut searcher = MadSearch::new();
        // Smooth image with repeated structure: many near-ties.
        let img = Image::from_fn(90, 70, |x, y| ((x / 3 + y / 5) % 7 * 30) as u8).unwrap();
        for (tx, ty, region) in [
            (10, 10, Rect::new(0, 0, 90, 70)),
            (40, 33, Rect::new(20, 15, 50, 40)),
            (3, 50, Rect::new(0, 30, 60, 40)),
        ] {
            let tpl = img.crop(Rect::new(tx, ty, 12, 9)).unwrap().to_image();
            let mut best = (f64::INFINITY, 0, 0);
            for y in region.y..=region.bottom() - 9 {
                for x in region.x..=region.right() - 12 {
                    let v = mad(img.view(), tpl.view(), x, y).unwrap();
                    if v < best.0 {
                        best = (v, x, y);
                    }
                }
            }
            let m = searcher.search(img.view(), tpl.view(), region).unwrap();
            assert_eq!((m.mad, m.x, m.y), best, "template at ({tx}, {ty})");
            // f32 takes the unpruned path and agrees.
            let f = img.map(f32::from);
            let t = tpl.map(f32::from);
            let mf = mad_search(f.view(), t.view(), region).unwrap();
            assert_eq!((mf.mad, mf.x, mf.y), best);
        }
        // A flat frame: every position ties, the first one wins.
        let flat = Image::new(30, 20, 1, 9u8).unwrap();
        let tpl = Image::new(5, 5, 1, 9u8).unwrap();
        let m = searcher
            .search(flat.view(), tpl.view(), Rect::new(3, 4, 20, 10))
            .unwrap();
        assert_eq!((m.x, m.y, m.mad), (3, 4, 0.0));
    }

    #[test]
    fn a_tie_with_the_bound_keeps_the_earlier_window() {
        // Template 4x9 of 100 over a 40x30 frame of 50: the frame is below
        // the template everywhere, so every block bound is exact (bound =
        // SAD = 36 * 50). Two windows of 90, at (5, 5) and at the region's
        // centre (18, 11), tie at SAD 360. A checkerboard of 0 and 200 at
        // (30, 2) has bound 0 in every block (so it is the smallest-bound
        // seed) but SAD 3600. The centre is the other seed, so the best so
        // far is 360 at the centre when the scan reaches (5, 5), whose bound
        // is exactly 360: it must still be scored, and win as the earlier
        // window. A bound that over-counts any block skips it.
        let mut frame = Image::new(40, 30, 1, 50u8).unwrap();
        for (x0, y0) in [(5, 5), (18, 11)] {
            for y in y0..y0 + 9 {
                for x in x0..x0 + 4 {
                    frame.set(x, y, 0, 90);
                }
            }
        }
        for y in 2..11 {
            for x in 30..34 {
                frame.set(x, y, 0, if (x + y) % 2 == 0 { 0 } else { 200 });
            }
        }
        let tpl = Image::new(4, 9, 1, 100u8).unwrap();
        let m = MadSearch::new()
            .search(frame.view(), tpl.view(), Rect::new(0, 0, 40, 30))
            .unwrap();
        assert_eq!((m.x, m.y, m.mad), (5, 5, 10.0));
    }

    #[test]
    fn bad_inputs() {
        let f = textured(40, 30, 3);
        let t = textured(10, 10, 4);
        assert!(matches!(
            mad(f.view(), t.view(), 35, 0),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert!(matches!(
            mad_search(f.view(), t.view(), Rect::new(0, 0, 9, 30)),
            Err(AppearanceError::TemplateLargerThanRegion { .. })
        ));
        assert!(matches!(
            mad_search(f.view(), t.view(), Rect::new(20, 0, 30, 30)),
            Err(AppearanceError::WindowOutside { .. })
        ));
        let big = textured(50, 10, 5);
        assert!(matches!(
            mad_search(f.view(), big.view(), Rect::new(0, 0, 40, 30)),
            Err(AppearanceError::TemplateLargerThanRegion { .. })
        ));
        let rgb = Image::new(10, 10, 3, 0u8).unwrap();
        assert!(matches!(
            mad(f.view(), rgb.view(), 0, 0),
            Err(AppearanceError::Image(ImageError::Channels { .. }))
        ));
        let mut wrong = Image::new(3, 3, 1, 0f32).unwrap();
        assert!(
            mad_map_into(
                f.view(),
                t.view(),
                Rect::new(0, 0, 40, 30),
                &mut wrong.view_mut()
            )
            .is_err()
        );
    }

    #[test]
    fn gray_surfaces_are_the_exact_sads_scaled() {
        // Every value of the byte surface is the integer SAD times
        // 1 / (tw th), rounded to f32 once: the SIMD kernels' sums (here at
        // the best level of this CPU; crates/image tests every level) and
        // the vectorised scaling give exactly that. Templates of 30x20 (the
        // benches'), 13x7 and 64x3 (other row groups and paddings) over a
        // crop wider than 2 x 32 windows (whole batches and a tail), and
        // saturated pixels.
        let big = textured(140, 50, 21);
        let frame = big.crop(Rect::new(3, 2, 131, 45)).unwrap();
        for (tw, th) in [(30, 20), (13, 7), (64, 3)] {
            for saturated in [false, true] {
                let tpl = if saturated {
                    Image::new(tw, th, 1, 0u8).unwrap()
                } else {
                    textured(tw, th, (tw * th) as u32)
                };
                let white = Image::new(131, 45, 1, 255u8).unwrap();
                let f = if saturated { white.view() } else { frame };
                let region = Rect::new(1, 2, 129, 40);
                let (ow, oh) = (region.width - tw + 1, region.height - th + 1);
                let mut out = Image::new(ow, oh, 1, 0f32).unwrap();
                mad_map_into(f, tpl.view(), region, &mut out.view_mut()).unwrap();
                let norm = 1.0 / (tw * th) as f64;
                for j in 0..oh {
                    for i in 0..ow {
                        let (x, y) = (region.x + i, region.y + j);
                        let sad: u32 = (0..th)
                            .map(|r| {
                                tpl.row(r)
                                    .iter()
                                    .zip(&f.row(y + r)[x..x + tw])
                                    .map(|(&a, &b)| u32::from(a.abs_diff(b)))
                                    .sum::<u32>()
                            })
                            .sum();
                        let want = (f64::from(sad) * norm) as f32;
                        assert_eq!(
                            out.get(i, j, 0).unwrap().to_bits(),
                            want.to_bits(),
                            "{tw}x{th} at ({x}, {y})"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn scaled_sums_converted_from_i32_are_the_u32_ones() {
        // ScaleSums's signed path (sums up to i32::MAX) against the plain
        // formula, bit for bit, over runs of every length to past a few
        // vectors (whole vectors and tails), with the largest sums, those
        // around 2^24 (where f32 stops being exact) and pseudo-random ones.
        let mut x = 12345u32;
        let mut pool = vec![
            0,
            1,
            2,
            255,
            (1 << 24) - 1,
            1 << 24,
            (1 << 24) + 1,
            i32::MAX as u32,
        ];
        pool.extend((0..200).map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x >> (x % 8)
        }));
        pool.retain(|&s| s <= i32::MAX as u32);
        for norm in [1.0 / 600.0, 1.0 / 7.0, 1.0, 0.1] {
            for len in 0..=40 {
                for start in [0, 3, len] {
                    let sums: Vec<u32> =
                        pool.iter().cycle().skip(start).take(len).copied().collect();
                    for signed in [false, true] {
                        let mut out = vec![f32::NAN; len];
                        dispatch(ScaleSums {
                            sums: &sums,
                            out: &mut out,
                            norm,
                            signed,
                        });
                        for (o, &s) in out.iter().zip(&sums) {
                            let want = (f64::from(s) * norm) as f32;
                            assert_eq!(o.to_bits(), want.to_bits(), "{s} * {norm} ({signed})");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn wide_gray_surfaces_are_the_sads_of_each_window() {
        // Surfaces wider than SAD_CHUNK windows and of every height from 1
        // to 2 MAP_ROWS + 1: several kernel calls a row, groups of rows of
        // every size, against the integer SADs scaled.
        let frame = textured(SAD_CHUNK + 80, 40, 5);
        let tpl = textured(30, 20, 6);
        for oh in 1..=2 * MAP_ROWS + 1 {
            let region = Rect::new(3, 1, SAD_CHUNK + 70, oh + 19);
            let ow = region.width - 29;
            let mut out = Image::new(ow, oh, 1, 0f32).unwrap();
            mad_map_into(frame.view(), tpl.view(), region, &mut out.view_mut()).unwrap();
            for j in 0..oh {
                for i in (0..ow).step_by(7).chain(ow - 12..ow) {
                    let (x, y) = (region.x + i, region.y + j);
                    let sad: u32 = (0..20)
                        .map(|r| {
                            tpl.row(r)
                                .iter()
                                .zip(&frame.row(y + r)[x..x + 30])
                                .map(|(&a, &b)| u32::from(a.abs_diff(b)))
                                .sum::<u32>()
                        })
                        .sum();
                    let want = (f64::from(sad) * (1.0 / 600.0)) as f32;
                    assert_eq!(
                        out.get(i, j, 0).unwrap().to_bits(),
                        want.to_bits(),
                        "height {oh} at ({x}, {y})"
                    );
                }
            }
        }
    }

    #[test]
    fn likelihood_in_log_domain() {
        let l = MadLikelihood::new(2.0).unwrap();
        assert_eq!(l.log_likelihood(4.0).unwrap(), -0.5);
        // A MAD that would underflow exp() is still ordered correctly.
        let a = l.log_likelihood(1e4).unwrap();
        let b = l.log_likelihood(2e4).unwrap();
        assert!(a > b && (a.exp() == 0.0));
        assert!(MadLikelihood::new(0.0).is_err());
        assert!(MadLikelihood::new(f64::NAN).is_err());
        assert!(l.log_likelihood(f64::NAN).is_err());
    }

    /// The byte search (SIMD kernels, whole-window bound, early exits)
    /// against brute force over every position, on smooth textured frames
    /// with a template cut from a shifted, re-noised copy (a tracker's
    /// next-frame case), gray and RGB, including regions at the frame's
    /// right and bottom edges (where the kernels fall back to scalar reads).
    #[test]
    fn byte_search_equals_brute_force_on_next_frame_templates() {
        let mut searcher = MadSearch::new();
        for ch in [1usize, 3] {
            for seed in 0..6u32 {
                let noise = textured(96 * ch, 72, seed + 20);
                let scene = |dx: usize, dy: usize, k: u32| {
                    Image::from_vec(
                        96,
                        72,
                        ch,
                        (0..96 * 72 * ch)
                            .map(|i| {
                                let (x, y) = ((i / ch) % 96 + dx, (i / ch) / 96 + dy);
                                let v = (x as f32 * 1.7 + (y as f32 * 0.21).sin() * 50.0) as u32
                                    + u32::from(
                                        noise.as_slice()[(i + k as usize) % noise.as_slice().len()],
                                    ) / 6;
                                (v % 256) as u8
                            })
                            .collect(),
                    )
                    .unwrap()
                };
                let first = scene(0, 0, 0);
                let next = scene(2, 1, 7);
                // One to eight blocks in the bound (41 rows: eight uneven).
                let (tw, th) =
                    [(13, 7), (16, 8), (19, 9), (22, 10), (6, 1), (10, 41)][seed as usize];
                let tpl = first.crop(Rect::new(30, 20, tw, th)).unwrap().to_image();
                for region in [
                    Rect::new(0, 0, 96, 72),
                    Rect::new(40, 30, 56, 42),
                    Rect::new(5, 3, 60, 45),
                ] {
                    let mut best = (f64::INFINITY, 0, 0);
                    for y in region.y..=region.bottom() - th {
                        for x in region.x..=region.right() - tw {
                            let v = mad(next.view(), tpl.view(), x, y).unwrap();
                            if v < best.0 {
                                best = (v, x, y);
                            }
                        }
                    }
                    let m = searcher.search(next.view(), tpl.view(), region).unwrap();
                    assert_eq!((m.mad, m.x, m.y), best, "ch {ch} seed {seed} {region:?}");
                }
            }
        }
    }
}
