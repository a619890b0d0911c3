//! Integral images (summed-area tables) of a 1-channel image and of its
//! squares, for constant-time window sums, means and variances; and the
//! gray, block-averaged copy of a frame region that template trackers
//! search in.
//!
//! `S(x, y) = sum_{x' < x, y' < y} I(x', y')` is stored for
//! `0 <= x <= w`, `0 <= y <= h`, so the sum over the window with top-left
//! `(x, y)` and size `w x h` is `S(x+w, y+h) - S(x, y+h) - S(x+w, y) + S(x, y)`.
//! Sums are accumulated in `f64`, exact for integer pixels up to `2^53`.

use crate::color::luma_fixed;
use crate::simd::{Kernel, Token, dispatch};
use crate::{Image, ImageError, ImageView, ImageViewMut, Pixel, Rect, Result};

/// Summed-area tables of a 1-channel image and of its squared values.
///
/// ```
/// use bayestrack_image::{Image, IntegralImage, Rect};
/// let img = Image::from_fn(4, 3, |x, y| (x + 4 * y) as u8).unwrap();
/// let ii = IntegralImage::new(img.view()).unwrap();
/// // pixels 5, 6, 9, 10
/// assert_eq!(ii.sum(Rect::new(1, 1, 2, 2)).unwrap(), 30.0);
/// let (mean, var) = ii.mean_var(Rect::new(1, 1, 2, 2)).unwrap();
/// assert_eq!((mean, var), (7.5, 4.25));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IntegralImage {
    width: usize,
    height: usize,
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

impl IntegralImage {
    /// The tables of `src`.
    ///
    /// # Errors
    /// As [`IntegralImage::compute`].
    pub fn new<T: Pixel>(src: ImageView<'_, T>) -> Result<Self> {
        let mut ii = Self::default();
        ii.compute(src)?;
        Ok(ii)
    }

    /// Recomputes the tables for `src`, reusing the allocation.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `src` has 1 channel;
    /// [`ImageError::NonFinite`] for a NaN or infinite pixel.
    pub fn compute<T: Pixel>(&mut self, src: ImageView<'_, T>) -> Result<()> {
        src.expect_channels("integral image", 1)?;
        (self.width, self.height) = (src.width(), src.height());
        summed_area::<T, true>(src, &mut self.sum, &mut self.sum_sq, "integral image input")
    }

    /// Width of the image the tables were built from.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height of the image the tables were built from.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Sum and sum of squares over the `w x h` window with top-left `(x, y)`.
    ///
    /// # Panics
    /// If the window is not inside the image (callers check once per search,
    /// not per window).
    #[inline]
    pub fn sums(&self, x: usize, y: usize, w: usize, h: usize) -> (f64, f64) {
        assert!(
            x + w <= self.width && y + h <= self.height,
            "window ({x}, {y}, {w}x{h}) outside the {}x{} integral image",
            self.width,
            self.height
        );
        let cols = self.width + 1;
        let (a, b) = (y * cols + x, y * cols + x + w);
        let (c, d) = ((y + h) * cols + x, (y + h) * cols + x + w);
        (
            self.sum[d] - self.sum[b] - self.sum[c] + self.sum[a],
            self.sum_sq[d] - self.sum_sq[b] - self.sum_sq[c] + self.sum_sq[a],
        )
    }

    fn check(&self, rect: Rect) -> Result<()> {
        if rect.fits_in(self.width, self.height) {
            Ok(())
        } else {
            Err(ImageError::WindowOutside {
                window: rect,
                width: self.width,
                height: self.height,
            })
        }
    }

    /// Sum of the pixels in `rect`.
    ///
    /// # Errors
    /// [`ImageError::WindowOutside`] unless `rect` is non-empty and inside.
    pub fn sum(&self, rect: Rect) -> Result<f64> {
        self.check(rect)?;
        Ok(self.sums(rect.x, rect.y, rect.width, rect.height).0)
    }

    /// Sum of the squared pixels in `rect`.
    ///
    /// # Errors
    /// As [`IntegralImage::sum`].
    pub fn sum_sq(&self, rect: Rect) -> Result<f64> {
        self.check(rect)?;
        Ok(self.sums(rect.x, rect.y, rect.width, rect.height).1)
    }

    /// Mean and (population) variance of the pixels in `rect`; the variance
    /// is clamped at 0 against rounding.
    ///
    /// # Errors
    /// As [`IntegralImage::sum`].
    pub fn mean_var(&self, rect: Rect) -> Result<(f64, f64)> {
        self.check(rect)?;
        let (s, q) = self.sums(rect.x, rect.y, rect.width, rect.height);
        let n = rect.area() as f64;
        let mean = s / n;
        Ok((mean, (q / n - mean * mean).max(0.0)))
    }
}

/// Area resampling through a summed-area table: each output pixel is the
/// mean of the source over an axis-aligned rectangle of any (fractional)
/// size and position. A pixel `(i, j)` of the source covers the unit square
/// `[i, i + 1] x [j, j + 1]`; the summed area `S(x, y)` of the
/// piecewise-constant image is bilinear inside each unit cell, so bilinear
/// interpolation of the table gives the exact area integral at fractional
/// corners. Shrinking by any factor is thereby anti-aliased by a box filter
/// of exactly the sampling step, the same at every scale (a scale search
/// compares like with like).
///
/// ```
/// use bayestrack_image::{AreaSampler, Image, ImageViewMut};
/// let img = Image::from_fn(4, 4, |x, y| (x + 4 * y) as u8).unwrap();
/// let mut sampler = AreaSampler::new(img.view()).unwrap();
/// let mut buf = [0f32; 4];
/// let mut out = ImageViewMut::from_slice(&mut buf, 2, 2, 1, 2).unwrap();
/// // 2x2 blocks: means of (0, 1, 4, 5), (2, 3, 6, 7), ...
/// sampler.sample_into(0.0, 0.0, 2.0, 2.0, &mut out).unwrap();
/// assert_eq!(buf, [2.5, 4.5, 10.5, 12.5]);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AreaSampler {
    width: usize,
    height: usize,
    sum: Vec<f64>,
    /// Scratch: the table at every column edge of the top and bottom
    /// edge of an output row.
    rows: [Vec<f64>; 2],
    /// Scratch: the distinct column edges of an output row (cell index
    /// and fraction, left to right).
    xs: Vec<(usize, f64)>,
    /// Scratch: per output column, the index in `xs` of both edges, and
    /// the width.
    cols: Vec<(usize, usize, f64)>,
}

impl AreaSampler {
    /// The table of `src`.
    ///
    /// # Errors
    /// As [`AreaSampler::compute`].
    pub fn new<T: Pixel>(src: ImageView<'_, T>) -> Result<Self> {
        let mut s = Self::default();
        s.compute(src)?;
        Ok(s)
    }

    /// Recomputes the table for `src`, reusing the allocation.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `src` has 1 channel;
    /// [`ImageError::NonFinite`] for a NaN or infinite pixel.
    pub fn compute<T: Pixel>(&mut self, src: ImageView<'_, T>) -> Result<()> {
        src.expect_channels("area sampler", 1)?;
        (self.width, self.height) = (src.width(), src.height());
        summed_area::<T, false>(src, &mut self.sum, &mut Vec::new(), "area sampler input")
    }

    /// Width of the source.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height of the source.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Cell index and fraction of a coordinate clamped to `[0, n]`.
    #[inline]
    fn cell(v: f64, n: usize) -> (usize, f64) {
        let v = v.clamp(0.0, n as f64);
        let i = (v as usize).min(n.saturating_sub(1));
        (i, v - i as f64)
    }

    /// The edges `a < b` of an output pixel along an axis of `n` source
    /// pixels, clipped; a degenerate interval is widened to the nearest
    /// source pixel.
    fn edges(a: f64, b: f64, n: usize) -> (f64, f64) {
        let (lo, hi) = (a.clamp(0.0, n as f64), b.clamp(0.0, n as f64));
        if hi - lo > 1e-9 {
            (lo, hi)
        } else {
            let p = (lo.min(n as f64 - 0.5)).floor().max(0.0);
            (p, p + 1.0)
        }
    }

    /// The summed-area table at row coordinate `y` and each column edge
    /// of `xs` into `out`: bilinear, the rows first (`p + f (q - p)` at the
    /// edge's two integer columns), then along the row.
    fn edge_values(&self, y: f64, xs: &[(usize, f64)], out: &mut Vec<f64>) {
        let cols = self.width + 1;
        let (j, f) = Self::cell(y, self.height);
        let (a, b) = (
            &self.sum[j * cols..(j + 1) * cols],
            &self.sum[(j + 1) * cols..(j + 2) * cols],
        );
        out.clear();
        out.extend(xs.iter().map(|&(i, g)| {
            let (p, q) = (&a[i..i + 2], &b[i..i + 2]);
            let left = p[0] + f * (q[0] - p[0]);
            let right = p[1] + f * (q[1] - p[1]);
            left + g * (right - left)
        }));
    }

    /// Fills `out` (1 channel): output pixel `(u, v)` is the mean of the
    /// source over `[x0 + u sx, x0 + (u + 1) sx] x [y0 + v sy, y0 + (v + 1) sy]`
    /// (source pixel `(i, j)` covers `[i, i + 1] x [j, j + 1]`). Rectangles
    /// are clipped to the source; one left with no area reads the nearest
    /// source pixel (edge replication).
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `out` has 1 channel;
    /// [`ImageError::NonFinite`] for non-finite or non-positive steps or a
    /// non-finite origin; [`ImageError::ZeroSize`] before any `compute`.
    pub fn sample_into(
        &mut self,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        out: &mut ImageViewMut<'_, f32>,
    ) -> Result<()> {
        if out.channels() != 1 {
            return Err(ImageError::Channels {
                operation: "area sampler output",
                expected: 1,
                got: out.channels(),
            });
        }
        if ![x0, y0, sx, sy].iter().all(|v| v.is_finite()) || sx <= 0.0 || sy <= 0.0 {
            return Err(ImageError::NonFinite {
                what: "area sampling origin or steps",
            });
        }
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::ZeroSize {
                width: self.width,
                height: self.height,
                channels: 1,
            });
        }
        let (w, h) = (self.width, self.height);
        let edges = Self::edges;
        // column edges: a column's left edge is the last right edge when
        // they are the same coordinate (columns that tile the source)
        let (mut xs, mut cols) = (std::mem::take(&mut self.xs), std::mem::take(&mut self.cols));
        xs.clear();
        cols.clear();
        let mut last = f64::NAN;
        for u in 0..out.width() {
            let (a, b) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
            if a != last {
                xs.push(Self::cell(a, w));
            }
            xs.push(Self::cell(b, w));
            last = b;
            cols.push((xs.len() - 2, xs.len() - 1, 1.0 / (b - a)));
        }
        let [mut top, mut bottom] = std::mem::take(&mut self.rows);
        // the bottom edge's values, reused as the next top edge's when it
        // is the same coordinate
        let mut last = f64::NAN;
        for v in 0..out.height() {
            let (a, b) = edges(y0 + v as f64 * sy, y0 + (v + 1) as f64 * sy, h);
            if a == last {
                std::mem::swap(&mut top, &mut bottom);
            } else {
                self.edge_values(a, &xs, &mut top);
            }
            self.edge_values(b, &xs, &mut bottom);
            last = b;
            let inv_h = 1.0 / (b - a);
            for (o, &(ea, eb, inv_w)) in out.row_mut(v).iter_mut().zip(&cols) {
                let area = bottom[eb] - bottom[ea] - top[eb] + top[ea];
                *o = (area * inv_h * inv_w) as f32;
            }
        }
        self.xs = xs;
        self.cols = cols;
        self.rows = [top, bottom];
        Ok(())
    }
}

/// The luma (BT.601, `0..=255` as `f32`) of the frame region `rect`,
/// averaged over `factor x factor` blocks, into `out` (reshaped to
/// `rect.width / factor x rect.height / factor`, 1 channel; a partial
/// block at the right or bottom edge is dropped). `factor = 1` is a plain
/// gray copy. Works on gray (1-channel) and RGB (3-channel) frames.
///
/// # Errors
/// [`ImageError::Channels`] unless the frame has 1 or 3 channels;
/// [`ImageError::WindowOutside`] unless `rect` is inside the frame;
/// [`ImageError::ZeroSize`] when `factor` is 0 or larger than the region.
pub fn gray_region_into(
    frame: ImageView<'_, u8>,
    rect: Rect,
    factor: usize,
    out: &mut Image<f32>,
) -> Result<()> {
    let ch = frame.channels();
    if ch != 1 && ch != 3 {
        return Err(ImageError::Channels {
            operation: "gray_region",
            expected: 3,
            got: ch,
        });
    }
    let region = frame.crop(rect)?;
    let (ow, oh) = match factor {
        0 => (0, 0),
        f => (rect.width / f, rect.height / f),
    };
    out.reshape(ow, oh, 1, 0.0)?;
    let f = factor;
    if f == 1 {
        for oy in 0..oh {
            dispatch(LumaRow {
                src: region.row(oy),
                channels: ch,
                out: out.row_mut(oy),
            });
        }
        return Ok(());
    }
    let scale = 1.0 / (f * f) as f32;
    let mut acc = vec![0u64; ow];
    for oy in 0..oh {
        acc.fill(0);
        for dy in 0..f {
            let row = region.row(oy * f + dy);
            if ch == 1 {
                for (a, block) in acc.iter_mut().zip(row.chunks_exact(f)) {
                    *a += block.iter().map(|&v| u64::from(v) << 16).sum::<u64>();
                }
            } else {
                for (a, block) in acc.iter_mut().zip(row.chunks_exact(3 * f)) {
                    *a += block
                        .chunks_exact(3)
                        .map(|p| u64::from(luma_fixed(p)))
                        .sum::<u64>();
                }
            }
        }
        for (o, &a) in out.row_mut(oy).iter_mut().zip(&acc) {
            *o = (a as f64 / 65536.0) as f32 * scale;
        }
    }
    Ok(())
}

/// One row of [`gray_region_into`] at factor 1: each pixel's fixed-point
/// luma (gray: the level times `2^16`) as `f32` over `2^16`. The sum is
/// below `2^24`, so the `f32` holds it exactly and the scaling by a power
/// of two is exact: the factor-`f` path's `(a as f64 / 65536.0) as f32`,
/// bit for bit, at every level.
struct LumaRow<'a> {
    src: &'a [u8],
    channels: usize,
    out: &'a mut [f32],
}

impl Kernel for LumaRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        const INV: f32 = 1.0 / 65536.0;
        if self.channels == 1 {
            for (o, &v) in self.out.iter_mut().zip(self.src) {
                *o = ((u32::from(v) << 16) as f32) * INV;
            }
        } else {
            for (o, p) in self.out.iter_mut().zip(self.src.chunks_exact(3)) {
                *o = (luma_fixed(p) as f32) * INV;
            }
        }
    }
}

/// Fills `sum` (and, when `SQUARES`, `sum_sq`) with the `(w + 1) x (h + 1)`
/// summed-area table of the 1-channel `src` (of its squares), first row and
/// column zero.
///
/// # Errors
/// [`ImageError::NonFinite`] with `what` for a NaN or infinite pixel.
fn summed_area<T: Pixel, const SQUARES: bool>(
    src: ImageView<'_, T>,
    sum: &mut Vec<f64>,
    sum_sq: &mut Vec<f64>,
    what: &'static str,
) -> Result<()> {
    let (w, h) = (src.width(), src.height());
    let cols = w + 1;
    // every entry but the first row's and first column's is written
    // below: those are zeroed, the rest not cleared first
    for t in [&mut *sum, &mut *sum_sq]
        .into_iter()
        .take(1 + usize::from(SQUARES))
    {
        t.resize(cols * (h + 1), 0.0);
        t[..cols].fill(0.0);
        for r in t.chunks_exact_mut(cols) {
            r[0] = 0.0;
        }
    }
    for y in 0..h {
        let (mut rs, mut rq) = (0f64, 0f64);
        let row = src.row(y);
        let (above, here) = sum.split_at_mut((y + 1) * cols);
        let prev = &above[y * cols..];
        for x in 0..w {
            rs += f64::from(row[x].to_f32());
            here[x + 1] = prev[x + 1] + rs;
        }
        if SQUARES {
            let (above_q, here_q) = sum_sq.split_at_mut((y + 1) * cols);
            let prev_q = &above_q[y * cols..];
            for x in 0..w {
                let v = f64::from(row[x].to_f32());
                rq += v * v;
                here_q[x + 1] = prev_q[x + 1] + rq;
            }
        }
        if !rs.is_finite() || !rq.is_finite() {
            return Err(ImageError::NonFinite { what });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_sums_match_brute_force() {
        let img = Image::from_fn(13, 9, |x, y| ((x * 31 + y * 17) % 23) as f32 - 5.0).unwrap();
        let ii = IntegralImage::new(img.view()).unwrap();
        for (x, y, w, h) in [(0, 0, 13, 9), (3, 2, 4, 5), (12, 8, 1, 1), (0, 4, 7, 1)] {
            let (mut s, mut q) = (0.0, 0.0);
            for yy in y..y + h {
                for xx in x..x + w {
                    let v = f64::from(img.get(xx, yy, 0).unwrap());
                    s += v;
                    q += v * v;
                }
            }
            assert_eq!(ii.sums(x, y, w, h), (s, q), "window {x},{y},{w}x{h}");
            let (m, v) = ii.mean_var(Rect::new(x, y, w, h)).unwrap();
            let n = (w * h) as f64;
            assert!((m - s / n).abs() < 1e-12 && (v - (q / n - (s / n).powi(2))).abs() < 1e-9);
        }
    }

    /// Tables rebuilt over earlier ones of other sizes (larger, smaller,
    /// other widths) equal tables built fresh: no stale entry survives.
    #[test]
    fn rebuilt_tables_equal_fresh_ones() {
        let img = |w: usize, h: usize, k: usize| {
            Image::from_fn(w, h, |x, y| ((x * 31 + y * 17 + k) % 23) as f32 + 1.0).unwrap()
        };
        let (mut ii, mut area) = (IntegralImage::default(), AreaSampler::default());
        for (k, (w, h)) in [(9, 7), (13, 4), (5, 11), (9, 7), (3, 3)]
            .into_iter()
            .enumerate()
        {
            let src = img(w, h, k);
            ii.compute(src.view()).unwrap();
            area.compute(src.view()).unwrap();
            let fresh = IntegralImage::new(src.view()).unwrap();
            assert!(ii.sum == fresh.sum && ii.sum_sq == fresh.sum_sq, "{w}x{h}");
            assert!(
                area.sum == AreaSampler::new(src.view()).unwrap().sum,
                "{w}x{h}"
            );
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let rgb = Image::new(4, 4, 3, 0u8).unwrap();
        assert!(matches!(
            IntegralImage::new(rgb.view()),
            Err(ImageError::Channels { .. })
        ));
        let nan = Image::from_fn(3, 3, |x, _| if x == 1 { f32::NAN } else { 0.0 }).unwrap();
        assert!(matches!(
            IntegralImage::new(nan.view()),
            Err(ImageError::NonFinite { .. })
        ));
        let ii = IntegralImage::new(Image::new(4, 4, 1, 1u8).unwrap().view()).unwrap();
        assert!(matches!(
            ii.sum(Rect::new(2, 2, 3, 1)),
            Err(ImageError::WindowOutside { .. })
        ));
        let mut out = Image::new(1, 1, 1, 0f32).unwrap();
        let two = Image::new(4, 4, 2, 0u8).unwrap();
        assert!(gray_region_into(two.view(), Rect::new(0, 0, 2, 2), 1, &mut out).is_err());
        let gray = Image::new(4, 4, 1, 0u8).unwrap();
        assert!(gray_region_into(gray.view(), Rect::new(0, 0, 2, 2), 0, &mut out).is_err());
        assert!(gray_region_into(gray.view(), Rect::new(0, 0, 2, 2), 3, &mut out).is_err());
        assert!(gray_region_into(gray.view(), Rect::new(3, 0, 2, 2), 1, &mut out).is_err());
    }

    #[test]
    fn area_sampling_is_exact_on_blocks_and_fractions() {
        let img = Image::from_fn(6, 5, |x, y| ((x * 7 + y * 3) % 11) as f32).unwrap();
        let mut s = AreaSampler::new(img.view()).unwrap();
        let mut buf = vec![0f32; 6 * 5];
        // unit steps on the pixel grid reproduce the image
        let mut out = ImageViewMut::from_slice(&mut buf, 6, 5, 1, 6).unwrap();
        s.sample_into(0.0, 0.0, 1.0, 1.0, &mut out).unwrap();
        for (a, b) in buf.iter().zip(img.as_slice()) {
            assert!((a - b).abs() < 1e-5);
        }
        let one = |s: &mut AreaSampler, x0, y0, sx, sy| -> Result<f32> {
            let mut v = [0f32; 1];
            let mut out = ImageViewMut::from_slice(&mut v, 1, 1, 1, 1).unwrap();
            s.sample_into(x0, y0, sx, sy, &mut out)?;
            Ok(v[0])
        };
        // a 1.5 x 1.5 area starting at (0.5, 1.0): weights by overlap
        let got = one(&mut s, 0.5, 1.0, 1.5, 1.5).unwrap();
        let p = |x: usize, y: usize| f64::from(img.get(x, y, 0).unwrap());
        let want = (0.5 * p(0, 1) + p(1, 1) + 0.5 * (0.5 * p(0, 2) + p(1, 2))) / 2.25;
        assert!((f64::from(got) - want).abs() < 1e-5, "{got} vs {want}");
        // areas outside replicate the edge
        let got = one(&mut s, -5.0, -5.0, 1.0, 1.0).unwrap();
        assert!((got - img.get(0, 0, 0).unwrap()).abs() < 1e-6);
        let got = one(&mut s, 100.0, 2.0, 1.0, 1.0).unwrap();
        assert!((got - img.get(5, 2, 0).unwrap()).abs() < 1e-6);
        assert!(one(&mut s, 0.0, 0.0, 0.0, 1.0).is_err());
        assert!(one(&mut s, f64::NAN, 0.0, 1.0, 1.0).is_err());
        assert!(one(&mut AreaSampler::default(), 0.0, 0.0, 1.0, 1.0).is_err());
        let rgb = Image::new(2, 2, 3, 0u8).unwrap();
        assert!(AreaSampler::new(rgb.view()).is_err());
    }

    /// Factor 1's dispatched row gives the fixed-point formula's bits at
    /// every level: every gray level, and RGB colours on a grid of every
    /// third level (and 255) in each channel.
    #[test]
    fn factor_one_luma_is_the_fixed_point_formula_at_every_level() {
        use crate::simd::SimdLevel;
        let formula = |a: u64| (a as f64 / 65536.0) as f32;
        let gray: Vec<u8> = (0..=255).collect();
        let mut levels: Vec<u8> = (0..=255).step_by(3).collect();
        levels.push(255);
        let mut rgb = Vec::new();
        for &r in &levels {
            for &g in &levels {
                for &b in &levels {
                    rgb.extend([r, g, b]);
                }
            }
        }
        let want_gray: Vec<u32> = gray
            .iter()
            .map(|&v| formula(u64::from(v) << 16).to_bits())
            .collect();
        // BT.601's weights times 2^16, rounded, written out here
        let w: [u64; 3] = [19595, 38470, 7471];
        let want_rgb: Vec<u32> = rgb
            .chunks_exact(3)
            .map(|p| {
                let a = w[0] * u64::from(p[0]) + w[1] * u64::from(p[1]) + w[2] * u64::from(p[2]);
                formula(a).to_bits()
            })
            .collect();
        for level in SimdLevel::ALL {
            for (src, channels, want) in [(&gray, 1, &want_gray), (&rgb, 3, &want_rgb)] {
                let mut out = vec![0f32; src.len() / channels];
                level.run(LumaRow {
                    src,
                    channels,
                    out: &mut out,
                });
                let got: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
                assert!(got == *want, "{level:?}, {channels} channels");
            }
        }
    }

    /// `sample_into` (the table interpolated only at the column edges, an
    /// edge shared by two columns or two rows computed once) gives the
    /// bits of the plain computation: both rows' table interpolated at
    /// every integer column for every output row, then along the row at
    /// both edges of every output pixel.
    #[test]
    fn area_sampling_reusing_rows_is_the_plain_computation() {
        let img = Image::from_fn(37, 29, |x, y| {
            ((x * 37 + y * 91 + x * y * 7) % 61) as f32 * 1.7
        })
        .unwrap();
        let mut s = AreaSampler::new(img.view()).unwrap();
        let (w, h) = (37usize, 29usize);
        let sum = s.sum.clone();
        let plain = |x0: f64, y0: f64, sx: f64, sy: f64, ow: usize, oh: usize| -> Vec<u32> {
            let edges = AreaSampler::edges;
            let row = |y: f64| -> Vec<f64> {
                let (j, f) = AreaSampler::cell(y, h);
                let cols = w + 1;
                (0..cols)
                    .map(|i| {
                        let (p, q) = (sum[j * cols + i], sum[(j + 1) * cols + i]);
                        p + f * (q - p)
                    })
                    .collect()
            };
            let at = |r: &[f64], i: usize, f: f64| r[i] + f * (r[i + 1] - r[i]);
            let mut out = Vec::new();
            for v in 0..oh {
                let (a, b) = edges(y0 + v as f64 * sy, y0 + (v + 1) as f64 * sy, h);
                let (top, bottom) = (row(a), row(b));
                for u in 0..ow {
                    let (ca, cb) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
                    let (ia, fa) = AreaSampler::cell(ca, w);
                    let (ib, fb) = AreaSampler::cell(cb, w);
                    let area = at(&bottom, ib, fb) - at(&bottom, ia, fa) - at(&top, ib, fb)
                        + at(&top, ia, fa);
                    out.push(((area * (1.0 / (b - a))) * (1.0 / (cb - ca))) as f32);
                }
            }
            out.iter().map(|v| v.to_bits()).collect()
        };
        for (x0, y0, sx, sy, ow, oh) in [
            (0.0, 0.0, 1.0, 1.0, 37, 29),
            (0.3, 0.7, 1.37, 0.61, 20, 40),
            (-3.2, -2.5, 0.9, 1.1, 45, 33),
            (10.25, 5.5, 2.5, 2.25, 9, 11),
            (30.0, 25.0, 1.0, 3.0, 12, 6),
        ] {
            let mut buf = vec![0f32; ow * oh];
            let mut out = ImageViewMut::from_slice(&mut buf, ow, oh, 1, ow).unwrap();
            s.sample_into(x0, y0, sx, sy, &mut out).unwrap();
            let got: Vec<u32> = buf.iter().map(|v| v.to_bits()).collect();
            assert!(got == plain(x0, y0, sx, sy, ow, oh), "{x0} {y0} {sx} {sy}");
        }
    }

    #[test]
    fn gray_region_averages_blocks() {
        let gray = Image::from_fn(6, 4, |x, y| (10 * x + y) as u8).unwrap();
        let mut out = Image::new(1, 1, 1, 0f32).unwrap();
        gray_region_into(gray.view(), Rect::new(1, 0, 5, 4), 2, &mut out).unwrap();
        assert_eq!((out.width(), out.height()), (2, 2));
        // block x 1..3, y 0..2: 10, 20, 11, 21
        assert!((out.get(0, 0, 0).unwrap() - 15.5).abs() < 1e-4);
        assert!((out.get(1, 1, 0).unwrap() - 37.5).abs() < 1e-4);
        // RGB: luma of a pure grey equals the grey
        let rgb = Image::from_fn(3, 2, |x, _| (40 * x) as u8).unwrap();
        let rgb = Image::from_vec(
            3,
            2,
            3,
            rgb.as_slice().iter().flat_map(|&v| [v, v, v]).collect(),
        )
        .unwrap();
        gray_region_into(rgb.view(), Rect::new(0, 0, 3, 2), 1, &mut out).unwrap();
        assert!((out.get(2, 1, 0).unwrap() - 80.0).abs() < 1e-3);
        let red = Image::from_vec(1, 1, 3, vec![255, 0, 0]).unwrap();
        gray_region_into(red.view(), Rect::new(0, 0, 1, 1), 1, &mut out).unwrap();
        assert!((out.get(0, 0, 0).unwrap() - 0.299 * 255.0).abs() < 0.01);
    }
}
