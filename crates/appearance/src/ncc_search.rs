//! Normalised cross-correlation (NCC) template search, plain or with a
//! separable pixel weighting, with fast window statistics.
//!
//! With pixel weights `w` (summing to 1; uniform for plain NCC) and weighted
//! means `mu_T`, `mu_W`, the score of a window `W` against a template `T` is
//!
//! `NCC_w = sum w (T - mu_T)(W - mu_W) / sqrt(sum w (T - mu_T)^2 sum w (W - mu_W)^2)`,
//!
//! in `[-1, 1]`, 1 exactly when `W = a T + b` with `a > 0` (invariant to gain
//! and offset of the intensities). The template is prepared once
//! ([`NccTemplate`]: `t = w (T - mu_T) / sqrt(sum w (T - mu_T)^2)`); it sums
//! to zero, so the numerator is the plain correlation `sum t W`. The window's
//! weighted variance `sum w W^2 - (sum w W)^2` comes from an integral image of
//! the searched image and its squares (uniform weights: constant time per
//! window) or from two separable passes (weights `w(u, v) = k_x(u) k_y(v)`:
//! `tw + th` operations per window instead of `tw th`). A weighting that
//! favours the template's centre makes the box corners, usually background,
//! count less; weighting the window's variance the same way keeps the score
//! unbiased across scales (an unweighted variance would reward windows whose
//! border is smooth, i.e. zoomed-in ones).
//!
//! The correlations run across positions (one template value times a row of
//! the image, added to one accumulator per position), which vectorises. A
//! flat window (no texture) scores 0.

use bayestrack_image::simd::{Kernel, SimdLevel, Token};
use bayestrack_image::{ImageView, IntegralImage, Rect};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// A template prepared for NCC, with optional separable pixel weights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NccTemplate {
    width: usize,
    height: usize,
    values: Vec<f32>,
    /// Column and row weights, each normalised to sum 1 (empty: uniform).
    kx: Vec<f32>,
    ky: Vec<f32>,
}

impl NccTemplate {
    /// Prepares a 1-channel patch for plain NCC.
    ///
    /// # Errors
    /// As [`NccTemplate::set`].
    pub fn new(patch: ImageView<'_, f32>) -> Result<Self> {
        let mut t = Self::default();
        t.set(patch)?;
        Ok(t)
    }

    /// Replaces the template by `patch` (plain NCC), reusing the allocation.
    /// On error the template is unchanged.
    ///
    /// # Errors
    /// [`bayestrack_image::ImageError::Channels`] unless `patch` has 1
    /// channel; [`AppearanceError::NonFinite`] for NaN or infinite pixels;
    /// [`AppearanceError::FlatTemplate`] when the patch is (nearly) constant,
    /// which no window can correlate with.
    pub fn set(&mut self, patch: ImageView<'_, f32>) -> Result<()> {
        self.prepare(patch, None)
    }

    /// Replaces the template by `patch` with separable pixel weights
    /// `w(u, v) = kx[u] ky[v]` (non-negative, not all zero; normalised
    /// here). On error the template is unchanged.
    ///
    /// # Errors
    /// As [`NccTemplate::set`], and [`AppearanceError::WindowSize`] when
    /// `kx` or `ky` does not match the patch width or height,
    /// [`AppearanceError::InvalidParameter`] for negative, non-finite or
    /// all-zero weights.
    pub fn set_weighted(
        &mut self,
        patch: ImageView<'_, f32>,
        kx: &[f32],
        ky: &[f32],
    ) -> Result<()> {
        if kx.len() != patch.width() || ky.len() != patch.height() {
            return Err(AppearanceError::WindowSize {
                operation: "ncc template weights",
                got_width: kx.len(),
                got_height: ky.len(),
                want_width: patch.width(),
                want_height: patch.height(),
            });
        }
        let norm = |k: &[f32]| -> Result<Vec<f32>> {
            let s: f64 = k.iter().map(|&v| f64::from(v)).sum();
            if !(k.iter().all(|v| v.is_finite() && *v >= 0.0) && s > 0.0 && s.is_finite()) {
                return Err(AppearanceError::InvalidParameter {
                    name: "ncc template weights",
                    value: format!("{k:?}"),
                    reason: "must be finite, >= 0 and not all zero",
                });
            }
            Ok(k.iter().map(|&v| (f64::from(v) / s) as f32).collect())
        };
        let (kx, ky) = (norm(kx)?, norm(ky)?);
        self.prepare(patch, Some((kx, ky)))
    }

    fn prepare(
        &mut self,
        patch: ImageView<'_, f32>,
        k: Option<(Vec<f32>, Vec<f32>)>,
    ) -> Result<()> {
        patch.expect_channels("ncc template", 1)?;
        let (w, h) = (patch.width(), patch.height());
        let n = (w * h) as f64;
        let weight = |u: usize, v: usize| {
            k.as_ref()
                .map_or(1.0 / n, |(kx, ky)| f64::from(kx[u]) * f64::from(ky[v]))
        };
        let mut mean = 0f64;
        for v in 0..h {
            for (u, &p) in patch.row(v).iter().enumerate() {
                mean += weight(u, v) * f64::from(p);
            }
        }
        if !mean.is_finite() {
            return Err(AppearanceError::NonFinite {
                what: "ncc template",
            });
        }
        let mut var = 0f64;
        for v in 0..h {
            for (u, &p) in patch.row(v).iter().enumerate() {
                var += weight(u, v) * (f64::from(p) - mean).powi(2);
            }
        }
        // A weighted standard deviation below 1e-3 grey levels (on 0..255),
        // or 1e-6 of the mean, is no texture.
        if !var.is_finite() || var <= 1e-6 * (1.0 + mean * mean * 1e-6) {
            return Err(AppearanceError::FlatTemplate {
                width: w,
                height: h,
            });
        }
        let inv = 1.0 / var.sqrt();
        self.values.clear();
        for v in 0..h {
            for (u, &p) in patch.row(v).iter().enumerate() {
                self.values
                    .push((weight(u, v) * (f64::from(p) - mean) * inv) as f32);
            }
        }
        self.width = w;
        self.height = h;
        match k {
            Some((kx, ky)) => {
                self.kx = kx;
                self.ky = ky;
            }
            None => {
                self.kx.clear();
                self.ky.clear();
            }
        }
        Ok(())
    }

    /// Template width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Template height.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether the template carries pixel weights.
    pub fn is_weighted(&self) -> bool {
        !self.kx.is_empty()
    }

    /// The prepared values `t` (row-major, zero sum).
    pub fn values(&self) -> &[f32] {
        &self.values
    }
}

/// The best window of a search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NccMatch {
    /// Left column of the best window (0-based, in the searched image).
    pub x: usize,
    /// Top row of the best window.
    pub y: usize,
    /// Its NCC, in `[-1, 1]`.
    pub score: f64,
}

/// Exhaustive NCC search with reusable buffers (no allocation once warm).
///
/// ```
/// use bayestrack_appearance::{NccSearch, NccTemplate};
/// use bayestrack_image::{Image, Rect};
/// let img = Image::from_fn(40, 30, |x, y| ((x * 7 + y * 13) % 17) as f32 * (1.0 + y as f32)).unwrap();
/// let t = NccTemplate::new(img.crop(Rect::new(21, 9, 8, 6)).unwrap()).unwrap();
/// let mut search = NccSearch::new();
/// let mut scores = Vec::new();
/// // every top-left corner in x 10..30, y 0..20
/// let m = search.map_into(img.view(), &t, Rect::new(10, 0, 20, 20), &mut scores).unwrap();
/// assert_eq!((m.x, m.y), (21, 9));
/// assert!((m.score - 1.0).abs() < 1e-5);
/// assert_eq!(scores.len(), 400);
/// ```
#[derive(Clone, Debug, Default)]
pub struct NccSearch {
    integral: IntegralImage,
    acc: Vec<f32>,
    /// Weighted row sums of the image and its squares (separable pass 1).
    rows: Vec<f64>,
    rows_sq: Vec<f64>,
    /// Weighted window sums of one row of positions (separable pass 2).
    col: Vec<f64>,
    col_sq: Vec<f64>,
}

impl NccSearch {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Scores the template at every top-left corner `(x, y)` with
    /// `corners.x <= x < corners.right()`, `corners.y <= y < corners.bottom()`
    /// into `out` (row-major, `corners.width x corners.height`) and returns
    /// the best (the first in raster order on ties).
    ///
    /// # Errors
    /// [`bayestrack_image::ImageError::Channels`] unless `image` has 1
    /// channel; [`AppearanceError::WindowOutside`] when a window at some
    /// corner leaves the image (or `corners` is empty, or the template was
    /// never set); [`AppearanceError::NonFinite`] for NaN or infinite pixels
    /// in the searched area.
    pub fn map_into(
        &mut self,
        image: ImageView<'_, f32>,
        template: &NccTemplate,
        corners: Rect,
        out: &mut Vec<f32>,
    ) -> Result<NccMatch> {
        self.map_with(SimdLevel::detect(), image, template, corners, out)
    }

    /// [`NccSearch::map_into`] with its loops compiled for `level` (every
    /// level gives the same bits).
    fn map_with(
        &mut self,
        level: SimdLevel,
        image: ImageView<'_, f32>,
        template: &NccTemplate,
        corners: Rect,
        out: &mut Vec<f32>,
    ) -> Result<NccMatch> {
        image.expect_channels("ncc search", 1)?;
        let (tw, th) = (template.width, template.height);
        if tw == 0 || corners.width == 0 || corners.height == 0 {
            return Err(AppearanceError::WindowOutside {
                operation: "ncc search",
                window: corners,
                width: image.width(),
                height: image.height(),
            });
        }
        let area = Rect::new(
            corners.x,
            corners.y,
            corners.width + tw - 1,
            corners.height + th - 1,
        );
        check_window("ncc search", area, image.width(), image.height())?;
        let sub = image.crop(area)?;
        let (nx, ny) = (corners.width, corners.height);
        if template.is_weighted() {
            self.weighted_rows(level, sub, template, nx)?;
        } else {
            self.integral
                .compute(sub)
                .map_err(|_| AppearanceError::NonFinite {
                    what: "ncc search image",
                })?;
        }
        let n = (tw * th) as f64;
        out.clear();
        out.reserve(nx * ny);
        self.acc.resize(nx, 0.0);
        self.col.resize(nx, 0.0);
        self.col_sq.resize(nx, 0.0);
        let mut best = NccMatch {
            x: corners.x,
            y: corners.y,
            score: f64::NEG_INFINITY,
        };
        for j in 0..ny {
            let acc = &mut self.acc[..nx];
            level.run(CorrelateRow {
                values: &template.values,
                tw,
                sub,
                j,
                acc,
            });
            if template.is_weighted() {
                level.run(WeightedColumn {
                    ky: &template.ky,
                    rows: &self.rows,
                    rows_sq: &self.rows_sq,
                    j,
                    ws: &mut self.col[..nx],
                    wq: &mut self.col_sq[..nx],
                });
            }
            let acc = &self.acc[..nx];
            for (i, &num) in acc.iter().enumerate() {
                // Variance of the window (weighted: weights summing to 1).
                let var = if template.is_weighted() {
                    let s = self.col[i];
                    self.col_sq[i] - s * s
                } else {
                    let (s, q) = self.integral.sums(i, j, tw, th);
                    (q - s * s / n) / n
                };
                let score = if var > 1e-6 {
                    (f64::from(num) / var.sqrt()).clamp(-1.0, 1.0)
                } else {
                    0.0
                };
                out.push(score as f32);
                if score > best.score {
                    best = NccMatch {
                        x: corners.x + i,
                        y: corners.y + j,
                        score,
                    };
                }
            }
        }
        Ok(best)
    }

    /// First separable pass: for every row of `sub` and every position `i`,
    /// `sum_c kx[c] I(i + c)` and the same of `I^2`.
    fn weighted_rows(
        &mut self,
        level: SimdLevel,
        sub: ImageView<'_, f32>,
        t: &NccTemplate,
        nx: usize,
    ) -> Result<()> {
        let rows = sub.height();
        self.rows.clear();
        self.rows.resize(rows * nx, 0.0);
        self.rows_sq.clear();
        self.rows_sq.resize(rows * nx, 0.0);
        let pairs = self
            .rows
            .chunks_exact_mut(nx)
            .zip(self.rows_sq.chunks_exact_mut(nx));
        for (y, (s, q)) in pairs.enumerate() {
            let finite = level.run(WeightedRow {
                kx: &t.kx,
                src: sub.row(y),
                s,
                q,
            });
            if !finite {
                return Err(AppearanceError::NonFinite {
                    what: "ncc search image",
                });
            }
        }
        Ok(())
    }
}

/// `acc[i] += sum_r sum_c t(c, r) I(i + c, j + r)` for the row `j` of
/// positions, `acc` zeroed first: four template columns per pass over the
/// accumulators (fewer loads and stores of `acc` per multiply-add), each
/// position's products added in the same order at every level.
struct CorrelateRow<'a> {
    values: &'a [f32],
    tw: usize,
    sub: ImageView<'a, f32>,
    j: usize,
    acc: &'a mut [f32],
}

impl Kernel for CorrelateRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let acc = self.acc;
        let nx = acc.len();
        acc.fill(0.0);
        for (r, trow) in self.values.chunks_exact(self.tw).enumerate() {
            let frow = self.sub.row(self.j + r);
            let mut quads = trow.chunks_exact(4);
            let mut c = 0;
            for t in &mut quads {
                let (f0, f1) = (&frow[c..c + nx], &frow[c + 1..c + 1 + nx]);
                let (f2, f3) = (&frow[c + 2..c + 2 + nx], &frow[c + 3..c + 3 + nx]);
                for i in 0..nx {
                    acc[i] += t[0] * f0[i] + t[1] * f1[i] + t[2] * f2[i] + t[3] * f3[i];
                }
                c += 4;
            }
            for &t in quads.remainder() {
                let src = &frow[c..c + nx];
                for (a, &f) in acc.iter_mut().zip(src) {
                    *a += t * f;
                }
                c += 1;
            }
        }
    }
}

/// The second separable pass for the row `j` of positions: the weighted
/// sums down the columns of the row sums and of the squares' row sums
/// into `ws` and `wq` (zeroed first).
struct WeightedColumn<'a> {
    ky: &'a [f32],
    rows: &'a [f64],
    rows_sq: &'a [f64],
    j: usize,
    ws: &'a mut [f64],
    wq: &'a mut [f64],
}

impl Kernel for WeightedColumn<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let (ws, wq) = (self.ws, self.wq);
        let nx = ws.len();
        ws.fill(0.0);
        wq.fill(0.0);
        for (r, &k) in self.ky.iter().enumerate() {
            let k = f64::from(k);
            let at = (self.j + r) * nx;
            let (rs, rq) = (&self.rows[at..at + nx], &self.rows_sq[at..at + nx]);
            for (a, &v) in ws.iter_mut().zip(rs) {
                *a += k * v;
            }
            for (a, &v) in wq.iter_mut().zip(rq) {
                *a += k * v;
            }
        }
    }
}

/// The first separable pass for one image row: `s[i] += sum_c kx[c]
/// I(i + c)` and `q[i] += sum_c kx[c] I(i + c)^2`, column by column;
/// whether every sum is finite.
struct WeightedRow<'a> {
    kx: &'a [f32],
    src: &'a [f32],
    s: &'a mut [f64],
    q: &'a mut [f64],
}

impl Kernel for WeightedRow<'_> {
    type Output = bool;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> bool {
        let nx = self.s.len();
        for (c, &k) in self.kx.iter().enumerate() {
            let k = f64::from(k);
            let src = &self.src[c..c + nx];
            for (a, &p) in self.s.iter_mut().zip(src) {
                *a += k * f64::from(p);
            }
            for (b, &p) in self.q.iter_mut().zip(src) {
                let p = f64::from(p);
                *b += k * p * p;
            }
        }
        // `&` over all (no early exit), which vectorises
        let finite = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
        finite(self.s) & finite(self.q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ncc;
    use bayestrack_image::{Image, ImageError};

    fn texture(w: usize, h: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| {
            let v = ((x * 37 + y * 91 + x * y * 7) % 61) as f32;
            v + 0.5 * (x as f32) - 0.25 * (y as f32)
        })
        .unwrap()
    }

    /// The weighted NCC of two equal-size patches, directly from its
    /// definition.
    fn direct_weighted(
        a: ImageView<'_, f32>,
        b: ImageView<'_, f32>,
        kx: &[f32],
        ky: &[f32],
    ) -> f64 {
        let sx: f64 = kx.iter().map(|&v| f64::from(v)).sum();
        let sy: f64 = ky.iter().map(|&v| f64::from(v)).sum();
        let w = |u: usize, v: usize| f64::from(kx[u]) * f64::from(ky[v]) / (sx * sy);
        let px = |p: ImageView<'_, f32>, u, v| f64::from(p.get(u, v, 0).unwrap());
        let (mut ma, mut mb) = (0.0, 0.0);
        for v in 0..a.height() {
            for u in 0..a.width() {
                ma += w(u, v) * px(a, u, v);
                mb += w(u, v) * px(b, u, v);
            }
        }
        let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
        for v in 0..a.height() {
            for u in 0..a.width() {
                let (da, db) = (px(a, u, v) - ma, px(b, u, v) - mb);
                ab += w(u, v) * da * db;
                aa += w(u, v) * da * da;
                bb += w(u, v) * db * db;
            }
        }
        ab / (aa * bb).sqrt()
    }

    #[test]
    fn scores_equal_direct_ncc() {
        let img = texture(30, 25);
        let t = img.crop(Rect::new(5, 7, 9, 6)).unwrap().to_image();
        let prepared = NccTemplate::new(t.view()).unwrap();
        let mut search = NccSearch::new();
        let mut out = Vec::new();
        let corners = Rect::new(2, 3, 15, 12);
        let m = search
            .map_into(img.view(), &prepared, corners, &mut out)
            .unwrap();
        assert_eq!((m.x, m.y), (5, 7));
        for j in 0..corners.height {
            for i in 0..corners.width {
                let w = img
                    .crop(Rect::new(corners.x + i, corners.y + j, 9, 6))
                    .unwrap();
                let direct = ncc(t.view(), w).unwrap();
                let got = f64::from(out[j * corners.width + i]);
                assert!((got - direct).abs() < 1e-4, "({i}, {j}): {got} vs {direct}");
            }
        }
    }

    #[test]
    fn weighted_scores_equal_the_definition() {
        let img = texture(30, 25);
        let t = img.crop(Rect::new(5, 7, 9, 6)).unwrap().to_image();
        let kx = [0.2f32, 0.5, 0.8, 1.0, 1.0, 1.0, 0.8, 0.5, 0.2];
        let ky = [0.25f32, 0.75, 1.0, 1.0, 0.75, 0.25];
        let mut prepared = NccTemplate::default();
        prepared.set_weighted(t.view(), &kx, &ky).unwrap();
        assert!(prepared.is_weighted());
        let sum: f32 = prepared.values().iter().sum();
        assert!(sum.abs() < 1e-5);
        let mut search = NccSearch::new();
        let mut out = Vec::new();
        let corners = Rect::new(2, 3, 15, 12);
        let m = search
            .map_into(img.view(), &prepared, corners, &mut out)
            .unwrap();
        assert_eq!((m.x, m.y), (5, 7));
        assert!((m.score - 1.0).abs() < 1e-5);
        for j in 0..corners.height {
            for i in 0..corners.width {
                let w = img
                    .crop(Rect::new(corners.x + i, corners.y + j, 9, 6))
                    .unwrap();
                let direct = direct_weighted(t.view(), w, &kx, &ky);
                let got = f64::from(out[j * corners.width + i]);
                assert!((got - direct).abs() < 1e-4, "({i}, {j}): {got} vs {direct}");
            }
        }
        // pixels of zero weight do not count: change them, the score stays 1
        let kx0 = [0.0f32, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0];
        prepared.set_weighted(t.view(), &kx0, &ky).unwrap();
        let mut changed = img.clone();
        for y in 0..25 {
            changed.set(5, y, 0, 1000.0);
            changed.set(13, y, 0, -50.0);
        }
        let m = search
            .map_into(changed.view(), &prepared, Rect::new(5, 7, 1, 1), &mut out)
            .unwrap();
        assert!((m.score - 1.0).abs() < 1e-5, "{}", m.score);
        // bad weights
        assert!(matches!(
            prepared.set_weighted(t.view(), &kx[..5], &ky),
            Err(AppearanceError::WindowSize { .. })
        ));
        assert!(matches!(
            prepared.set_weighted(t.view(), &[0.0; 9], &ky),
            Err(AppearanceError::InvalidParameter { .. })
        ));
        let mut neg = kx;
        neg[0] = -1.0;
        assert!(prepared.set_weighted(t.view(), &neg, &ky).is_err());
        // a failed set leaves the template as it was
        assert_eq!(prepared.width(), 9);
        assert!(prepared.is_weighted());
    }

    /// The dispatched loops give the scalar loops' bits at every level,
    /// plain and weighted, over widths around the vector lengths and
    /// templates with and without a column remainder.
    #[test]
    fn every_level_gives_the_scalar_bits() {
        let img = texture(64, 40);
        for (tw, th) in [(9, 6), (8, 5), (3, 7), (13, 11)] {
            let t = img.crop(Rect::new(20, 9, tw, th)).unwrap().to_image();
            let kx: Vec<f32> = (0..tw).map(|u| 1.0 + (u * (tw - 1 - u)) as f32).collect();
            let ky: Vec<f32> = (0..th).map(|v| 0.5 + (v * (th - 1 - v)) as f32).collect();
            let plain = NccTemplate::new(t.view()).unwrap();
            let mut weighted = NccTemplate::default();
            weighted.set_weighted(t.view(), &kx, &ky).unwrap();
            for template in [&plain, &weighted] {
                for nx in [1, 3, 4, 7, 8, 9, 15, 16, 17, 33, 64 - tw] {
                    let corners = Rect::new(0, 2, nx, 40 - th - 2);
                    let mut search = NccSearch::new();
                    let (mut want, mut got) = (Vec::new(), Vec::new());
                    let m0 = search
                        .map_with(SimdLevel::Scalar, img.view(), template, corners, &mut want)
                        .unwrap();
                    for level in SimdLevel::ALL {
                        let m = search
                            .map_with(level, img.view(), template, corners, &mut got)
                            .unwrap();
                        assert_eq!(m, m0, "{level:?} {tw}x{th} nx {nx}");
                        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&got), bits(&want), "{level:?} {tw}x{th} nx {nx}");
                    }
                }
            }
        }
    }

    /// A NaN or infinite pixel in the searched area is an error, plain or
    /// weighted, at every level; one outside it is not read.
    #[test]
    fn non_finite_pixels_in_the_search_are_errors() {
        let t = texture(30, 25)
            .crop(Rect::new(5, 7, 9, 6))
            .unwrap()
            .to_image();
        let plain = NccTemplate::new(t.view()).unwrap();
        let mut weighted = NccTemplate::default();
        weighted
            .set_weighted(t.view(), &[1.0; 9], &[1.0, 2.0, 3.0, 3.0, 2.0, 1.0])
            .unwrap();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut img = texture(30, 25);
            img.set(17, 11, 0, bad);
            for template in [&plain, &weighted] {
                for level in SimdLevel::ALL {
                    let mut search = NccSearch::new();
                    let mut out = Vec::new();
                    let r = search.map_with(
                        level,
                        img.view(),
                        template,
                        Rect::new(2, 3, 15, 12),
                        &mut out,
                    );
                    assert!(
                        matches!(r, Err(AppearanceError::NonFinite { .. })),
                        "{bad} {level:?}"
                    );
                    // windows over columns 0..16 and rows 0..15 only: clear of (17, 11)
                    let r = search.map_with(
                        level,
                        img.view(),
                        template,
                        Rect::new(0, 0, 8, 10),
                        &mut out,
                    );
                    assert!(r.is_ok(), "{bad} {level:?}");
                }
            }
        }
    }

    #[test]
    fn invariant_to_gain_and_offset() {
        let img = texture(20, 20);
        let bright = Image::from_fn(20, 20, |x, y| 3.0 * img.get(x, y, 0).unwrap() + 40.0).unwrap();
        let t = NccTemplate::new(img.crop(Rect::new(4, 4, 6, 6)).unwrap()).unwrap();
        let mut s = NccSearch::new();
        let mut out = Vec::new();
        let m = s
            .map_into(bright.view(), &t, Rect::new(0, 0, 15, 15), &mut out)
            .unwrap();
        assert_eq!((m.x, m.y), (4, 4));
        assert!(m.score > 0.99999);
    }

    #[test]
    fn flat_windows_score_zero_and_bad_input_is_an_error() {
        let mut img = texture(12, 12);
        for y in 0..12 {
            for x in 6..12 {
                img.set(x, y, 0, 9.0);
            }
        }
        let t = NccTemplate::new(img.crop(Rect::new(0, 0, 4, 4)).unwrap()).unwrap();
        let mut s = NccSearch::new();
        let mut out = Vec::new();
        s.map_into(img.view(), &t, Rect::new(6, 0, 3, 3), &mut out)
            .unwrap();
        assert!(out.iter().all(|&v| v == 0.0));
        assert!(matches!(
            s.map_into(img.view(), &t, Rect::new(6, 0, 4, 3), &mut out),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert!(matches!(
            s.map_into(img.view(), &t, Rect::new(0, 0, 0, 3), &mut out),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert!(matches!(
            s.map_into(
                img.view(),
                &NccTemplate::default(),
                Rect::new(0, 0, 2, 2),
                &mut out
            ),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert!(matches!(
            NccTemplate::new(img.crop(Rect::new(6, 0, 4, 4)).unwrap()),
            Err(AppearanceError::FlatTemplate { .. })
        ));
        let nan = Image::from_fn(4, 4, |x, _| if x == 2 { f32::NAN } else { 1.0 }).unwrap();
        assert!(matches!(
            NccTemplate::new(nan.view()),
            Err(AppearanceError::NonFinite { .. })
        ));
        let rgb = Image::new(4, 4, 3, 1f32).unwrap();
        assert!(matches!(
            NccTemplate::new(rgb.view()),
            Err(AppearanceError::Image(ImageError::Channels { .. }))
        ));
    }
}
