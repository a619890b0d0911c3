//! Target and background similarity distributions (TSD, BSD) with template
//! update (Xu, Gao and Yang 2015 (paper 002), section 1).
//!
//! The similarity of an observed patch to the target template is the
//! zero-clamped normalised cross-correlation `S = max(0, NCC)` in `[0, 1]`
//! (Xu, Gao and Yang 2015 (paper 002) needs `S` in `[0, 1]`: it scales the particle spread by
//! `1 - S_max`; it does not name the measure, and NCC is insensitive to the
//! illumination changes of its test sequences). TSD `N(mu_T, sigma_T)` is the
//! distribution of `S` for the tracked target, BSD `N(mu_B, sigma_B)` that of
//! patches from the background around it. Both are learnt online with
//! exponential forgetting. The models (template, TSD, BSD) are updated only
//! when the frame's final score exceeds `mu_B + sigma_B` (Xu, Gao and Yang 2015 (paper 002) text;
//! Algorithm 1 step 7 prints `mu_B - sigma_B`), and pose tuning stops once a
//! particle reaches `mu_T - sigma_T` ([`TargetModel::stop_threshold`]).

use bayestrack_image::simd::{Kernel, SimdLevel, Token, dispatch};
use bayestrack_image::{Image, ImageView};

use crate::{AppearanceError, Result};

/// Normalised cross-correlation of two equal-size 1-channel patches, in
/// `[-1, 1]`; 0 when either patch is flat (no texture to correlate).
///
/// # Errors
/// [`bayestrack_image::ImageError::SizeMismatch`] / [`bayestrack_image::ImageError::Channels`];
/// [`AppearanceError::NonFinite`] for NaN or infinite pixels.
pub fn ncc(a: ImageView<'_, f32>, b: ImageView<'_, f32>) -> Result<f64> {
    a.expect_channels("ncc", 1)?;
    a.expect_same_shape("ncc", &b)?;
    ncc_centred(a, &Centred::of(b))
}

/// One side of an NCC, centred: each pixel's deviation from the patch mean
/// (row-major, `f64`), their sum of squares, and whether the patch sum was
/// finite. The template side of [`TargetModel::similarity`] is computed once
/// per template, not once per observed patch. Every sum runs in pixel
/// order in one accumulator, as the two-pass NCC always did, so the scores
/// (and the trackers' boxes) are the same bits. (Independent accumulators
/// would be faster but change the last bits of a score, and the affine
/// particle filters' tuning and resampling amplify those into different
/// boxes: 43 px apart on Crossing for stpf.)
#[derive(Clone, Debug, Default)]
struct Centred {
    width: usize,
    height: usize,
    dev: Vec<f64>,
    ss: f64,
    finite: bool,
}

impl Centred {
    fn of(b: ImageView<'_, f32>) -> Self {
        let mut c = Self::default();
        c.set(b);
        c
    }

    fn set(&mut self, b: ImageView<'_, f32>) {
        let (w, h) = (b.width(), b.height());
        self.width = w;
        self.height = h;
        let mut sum = 0f64;
        for y in 0..h {
            for &q in &b.row(y)[..w] {
                sum += f64::from(q);
            }
        }
        self.finite = sum.is_finite();
        let mean = sum / (w * h) as f64;
        self.dev.clear();
        for y in 0..h {
            self.dev
                .extend(b.row(y)[..w].iter().map(|&q| f64::from(q) - mean));
        }
        self.ss = self.dev.iter().fold(0.0, |s, &d| s + d * d);
    }
}

/// [`ncc`] of patch `a` against a centred side `b` of the same shape
/// (checked by the callers).
///
/// The same operations in the same order as the two-pass loop (the patch
/// sum, then `sab` and `saa` each in one accumulator in pixel order), so
/// the same bits; the patch sum is taken in independent lanes when that
/// sum is exact ([`exact_sum`]), which shortens the chain of dependent
/// additions by a third, and the products of `sab` and `saa` are taken in
/// vector lanes ahead of their additions ([`centred_sums`]).
fn ncc_centred(a: ImageView<'_, f32>, b: &Centred) -> Result<f64> {
    let (w, h) = (b.width, b.height);
    let n = (w * h) as f64;
    let sa = match dispatch(ExactSum { a, w, h }) {
        Some(s) => s,
        None => {
            let mut sa = 0f64;
            for y in 0..h {
                for &p in &a.row(y)[..w] {
                    sa += f64::from(p);
                }
            }
            sa
        }
    };
    if !sa.is_finite() || !b.finite {
        return Err(AppearanceError::NonFinite { what: "patch" });
    }
    let ma = sa / n;
    let (sab, saa) = dispatch(CentredSums {
        a,
        dev: &b.dev,
        w,
        h,
        ma,
    });
    let den = (saa * b.ss).sqrt();
    if den <= 1e-12 * n {
        return Ok(0.0);
    }
    Ok((sab / den).clamp(-1.0, 1.0))
}

/// Pixels per block of [`centred_sums`].
const SUMS_BLOCK: usize = 64;

/// `(sab, saa)` of an NCC ([`centred_sums`]) as a dispatched kernel.
struct CentredSums<'a> {
    a: ImageView<'a, f32>,
    dev: &'a [f64],
    w: usize,
    h: usize,
    ma: f64,
}

impl Kernel for CentredSums<'_> {
    type Output = (f64, f64);
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<K: Token>(self, _: K) -> (f64, f64) {
        centred_sums(self.a, self.dev, self.w, self.h, self.ma)
    }
}

/// `sab = sum da db` and `saa = sum da da` over the `w x h` pixels of `a`
/// (`da = a - ma`) and the centred template `dev` (row-major `w x h`),
/// each summed in pixel order in one accumulator from `+0.0`, as the
/// two-pass loop does. The products of a block of [`SUMS_BLOCK`] pixels
/// are taken first, in vector lanes (each the same IEEE operations as the
/// loop's), then added to the two running sums one by one: the same
/// additions in the same order, so the same bits, with the conversions,
/// subtractions and multiplications off the two chains of dependent
/// additions.
#[inline(always)]
fn centred_sums(a: ImageView<'_, f32>, dev: &[f64], w: usize, h: usize, ma: f64) -> (f64, f64) {
    let (mut sab, mut saa) = (0f64, 0f64);
    let mut ab = [0f64; SUMS_BLOCK];
    let mut aa = [0f64; SUMS_BLOCK];
    let mut run = |px: &[f32], dev: &[f64]| {
        for (p, d) in px.chunks(SUMS_BLOCK).zip(dev.chunks(SUMS_BLOCK)) {
            let k = p.len().min(d.len());
            for (((&p, &db), ab), aa) in p.iter().zip(d).zip(ab.iter_mut()).zip(aa.iter_mut()) {
                let da = f64::from(p) - ma;
                *ab = da * db;
                *aa = da * da;
            }
            for (x, y) in ab[..k].iter().zip(&aa[..k]) {
                sab += x;
                saa += y;
            }
        }
    };
    if w == 0 || h == 0 {
        return (sab, saa);
    }
    if a.stride() == w {
        // Rows back to back (the trackers' patches): one run.
        run(&a.as_slice()[..w * h], &dev[..w * h]);
    } else {
        for (y, d) in dev.chunks_exact(w).take(h).enumerate() {
            run(&a.row(y)[..w], d);
        }
    }
    (sab, saa)
}

/// Lanes of [`ExactSum`].
const SUM_LANES: usize = 8;

/// The sum of a patch's pixels in `f64` when it is exact, else `None`
/// ([`exact_sum`]).
struct ExactSum<'a> {
    a: ImageView<'a, f32>,
    w: usize,
    h: usize,
}

impl Kernel for ExactSum<'_> {
    type Output = Option<f64>;
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<K: Token>(self, _: K) -> Option<f64> {
        exact_sum(self.a, self.w, self.h)
    }
}

/// The sum of the `w x h` pixels of `a` in `f64`, taken in
/// [`SUM_LANES`] independent accumulators, when that sum is exact: then
/// every partial sum in any order is exact, so it equals the sum in pixel
/// order bit for bit (one accumulator from `+0.0`; an exact zero is `+0.0`
/// either way). `None` when exactness is not shown (the caller then sums in
/// pixel order).
///
/// Exactness: an `f32` value `v != 0` is a multiple of
/// `2^(floor(log2 |v|) - 23)`, so every pixel, and every partial sum, is
/// a multiple of `q = 2^(floor(log2 m) - 23)` with `m` the smallest
/// non-zero `|v|`, and `q > m 2^-24`. Every partial sum is at most
/// `n M` in magnitude (`M` the largest `|v|`, `n` the pixel count), and a
/// multiple of `q` below `2^53 q` is an `f64`: so `n M <= 2^29 m` (which
/// gives `n M < 2^53 q`) makes every sum exact. Gray patches in `[0, 1]`
/// of 36 x 36 pixels pass unless a pixel is non-zero and below `2.4e-6`.
/// A NaN or an infinite pixel makes this sum and the pixel-order one
/// non-finite alike (the caller's error), whether or not the test passes.
#[inline(always)]
fn exact_sum(a: ImageView<'_, f32>, w: usize, h: usize) -> Option<f64> {
    let mut acc = [0f64; SUM_LANES];
    let mut hi = [0f32; SUM_LANES];
    let mut lo = [f32::INFINITY; SUM_LANES];
    // Pixels one at a time (row tails): their sum, largest and smallest
    // non-zero magnitude.
    let mut tail = (0f64, 0f32, f32::INFINITY);
    if a.stride() == w {
        // Rows back to back (the trackers' patches): one run.
        let all = &a.as_slice()[..w * h];
        let split = all.len() / SUM_LANES * SUM_LANES;
        sum_lanes(&all[..split], &mut acc, &mut hi, &mut lo);
        all[split..].iter().for_each(|&v| sum_one(v, &mut tail));
    } else {
        for y in 0..h {
            let row = &a.row(y)[..w];
            let split = w / SUM_LANES * SUM_LANES;
            sum_lanes(&row[..split], &mut acc, &mut hi, &mut lo);
            row[split..].iter().for_each(|&v| sum_one(v, &mut tail));
        }
    }
    let (acc1, hi1, lo1) = tail;
    // Through memory: combined in registers, the compiler pairs the lanes
    // as the folds below do and shuffles every pixel into those pairs,
    // several instructions more per pixel than whole-vector lanes.
    let (acc, hi, lo) = core::hint::black_box((acc, hi, lo));
    let m_hi = hi.iter().fold(hi1, |m, &v| if v > m { v } else { m });
    let m_lo = lo.iter().fold(lo1, |m, &v| if v < m { v } else { m });
    let n = (w * h) as f64;
    if n * f64::from(m_hi) <= f64::from(m_lo) * (1u64 << 29) as f64 {
        let s = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
        Some(s + acc1)
    } else {
        None
    }
}

/// [`exact_sum`]'s lanes over whole chunks of [`SUM_LANES`] pixels.
#[inline(always)]
fn sum_lanes(
    c: &[f32],
    acc: &mut [f64; SUM_LANES],
    hi: &mut [f32; SUM_LANES],
    lo: &mut [f32; SUM_LANES],
) {
    for c in c.chunks_exact(SUM_LANES) {
        for l in 0..SUM_LANES {
            acc[l] += f64::from(c[l]);
            let t = c[l].abs();
            hi[l] = if t > hi[l] { t } else { hi[l] };
            lo[l] = if t < lo[l] && t != 0.0 { t } else { lo[l] };
        }
    }
}

/// [`exact_sum`]'s one pixel at a time: `(sum, largest, smallest non-zero)`.
#[inline(always)]
fn sum_one(v: f32, (acc, hi, lo): &mut (f64, f32, f32)) {
    *acc += f64::from(v);
    let t = v.abs();
    *hi = if t > *hi { t } else { *hi };
    *lo = if t < *lo && t != 0.0 { t } else { *lo };
}

/// A 1-D Gaussian learnt online with exponential forgetting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OnlineGaussian {
    mean: f64,
    var: f64,
    rate: f64,
    count: u64,
}

impl OnlineGaussian {
    /// A prior `N(mean, std^2)`; each update moves it by `rate` in `(0, 1]`.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] / [`AppearanceError::NonFinite`].
    pub fn new(mean: f64, std: f64, rate: f64) -> Result<Self> {
        if !mean.is_finite() {
            return Err(AppearanceError::NonFinite { what: "mean" });
        }
        if !(std.is_finite() && std >= 0.0) {
            return Err(AppearanceError::InvalidParameter {
                name: "std",
                value: std.to_string(),
                reason: "must be finite and >= 0",
            });
        }
        check_rate("rate", rate)?;
        let var = std * std;
        if !var.is_finite() {
            return Err(AppearanceError::InvalidParameter {
                name: "std",
                value: std.to_string(),
                reason: "its square overflows (the variance would be infinite)",
            });
        }
        Ok(Self {
            mean,
            var,
            rate,
            count: 0,
        })
    }

    /// Sample mean and standard deviation of `samples` (at least 2).
    ///
    /// # Errors
    /// [`AppearanceError::TooFewSamples`]; [`AppearanceError::NonFinite`].
    pub fn from_samples(samples: &[f64], rate: f64) -> Result<Self> {
        if samples.len() < 2 {
            return Err(AppearanceError::TooFewSamples {
                what: "OnlineGaussian",
                needed: 2,
                got: samples.len(),
            });
        }
        if samples.iter().any(|v| !v.is_finite()) {
            return Err(AppearanceError::NonFinite { what: "samples" });
        }
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        let var = samples.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
        let mut g = Self::new(mean, var.sqrt(), rate)?;
        g.count = samples.len() as u64;
        Ok(g)
    }

    /// Mean.
    pub fn mean(&self) -> f64 {
        self.mean
    }
    /// Standard deviation.
    pub fn std(&self) -> f64 {
        self.var.sqrt()
    }
    /// Samples seen.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Folds in one sample: `mean += r (x - mean)`,
    /// `var = (1 - r) (var + r (x - mean_old)^2)`.
    ///
    /// # Errors
    /// [`AppearanceError::NonFinite`] for a NaN or infinite sample, or one
    /// so far from the mean that the mean or variance would overflow
    /// (1e308 after -1e308 made them inf and NaN); the distribution is
    /// then unchanged.
    pub fn update(&mut self, x: f64) -> Result<()> {
        if !x.is_finite() {
            return Err(AppearanceError::NonFinite { what: "sample" });
        }
        let d = x - self.mean;
        let mean = self.mean + self.rate * d;
        let var = (1.0 - self.rate) * (self.var + self.rate * d * d);
        if !(mean.is_finite() && var.is_finite()) {
            return Err(AppearanceError::NonFinite {
                what: "updated mean or variance (the sample is too far from the mean)",
            });
        }
        self.mean = mean;
        self.var = var;
        self.count += 1;
        Ok(())
    }
}

fn check_rate(name: &'static str, rate: f64) -> Result<f64> {
    if rate.is_finite() && rate > 0.0 && rate <= 1.0 {
        Ok(rate)
    } else {
        Err(AppearanceError::InvalidParameter {
            name,
            value: rate.to_string(),
            reason: "must be in (0, 1]",
        })
    }
}

/// The target appearance model of Xu, Gao and Yang 2015 (paper 002): template patch, TSD and BSD.
#[derive(Clone, Debug)]
pub struct TargetModel {
    template: Image<f32>,
    /// The template's side of the NCC (kept in step with `template`).
    centred: Centred,
    tsd: OnlineGaussian,
    bsd: OnlineGaussian,
    template_rate: f32,
}

impl TargetModel {
    /// A model from a template patch (1 channel, the patch size used for
    /// every observation, e.g. 36x36), TSD and BSD priors, and the template
    /// blending rate in `(0, 1]` (1 replaces the template on update).
    ///
    /// # Errors
    /// [`bayestrack_image::ImageError::Channels`]; [`AppearanceError::InvalidParameter`].
    pub fn new(
        template: Image<f32>,
        tsd: OnlineGaussian,
        bsd: OnlineGaussian,
        template_rate: f64,
    ) -> Result<Self> {
        template.view().expect_channels("TargetModel", 1)?;
        if template.as_slice().iter().any(|v| !v.is_finite()) {
            return Err(AppearanceError::NonFinite { what: "template" });
        }
        let template_rate = check_rate("template_rate", template_rate)? as f32;
        let centred = Centred::of(template.view());
        Ok(Self {
            centred,
            template,
            tsd,
            bsd,
            template_rate,
        })
    }

    /// Learns TSD and BSD from similarity samples (target patches, e.g. the
    /// initial box under small perturbations; background patches around it),
    /// both forgetting at `rate`.
    ///
    /// # Errors
    /// As [`OnlineGaussian::from_samples`] and [`TargetModel::new`].
    pub fn from_samples(
        template: Image<f32>,
        target_scores: &[f64],
        background_scores: &[f64],
        rate: f64,
        template_rate: f64,
    ) -> Result<Self> {
        let tsd = OnlineGaussian::from_samples(target_scores, rate)?;
        let bsd = OnlineGaussian::from_samples(background_scores, rate)?;
        Self::new(template, tsd, bsd, template_rate)
    }

    /// The template patch.
    pub fn template(&self) -> ImageView<'_, f32> {
        self.template.view()
    }
    /// Target-patch similarity distribution.
    pub fn tsd(&self) -> &OnlineGaussian {
        &self.tsd
    }
    /// Background-patch similarity distribution.
    pub fn bsd(&self) -> &OnlineGaussian {
        &self.bsd
    }

    /// `S = max(0, NCC(patch, template))` in `[0, 1]`.
    ///
    /// # Errors
    /// [`AppearanceError::WindowSize`] unless the patch has the template's size.
    pub fn similarity(&self, patch: ImageView<'_, f32>) -> Result<f64> {
        if patch.width() != self.template.width() || patch.height() != self.template.height() {
            return Err(AppearanceError::WindowSize {
                operation: "TargetModel::similarity",
                got_width: patch.width(),
                got_height: patch.height(),
                want_width: self.template.width(),
                want_height: self.template.height(),
            });
        }
        patch.expect_channels("ncc", 1)?;
        Ok(ncc_centred(patch, &self.centred)?.max(0.0))
    }

    /// `mu_T - sigma_T`: a tuned particle at or above this is good enough
    /// to stop pose tuning (Algorithm 1, step 4).
    pub fn stop_threshold(&self) -> f64 {
        self.tsd.mean() - self.tsd.std()
    }

    /// `mu_B + sigma_B`: a final score above this updates the models.
    pub fn update_threshold(&self) -> f64 {
        self.bsd.mean() + self.bsd.std()
    }

    /// Model update at the end of a frame. If `score > mu_B + sigma_B`, the
    /// template moves towards `patch` (`T = (1 - a) T + a patch`), TSD
    /// absorbs `score` and BSD absorbs every background score; returns
    /// whether it updated.
    ///
    /// # Errors
    /// [`AppearanceError::WindowSize`]; [`AppearanceError::NonFinite`] for a
    /// non-finite score or patch (nothing is changed then).
    pub fn update(
        &mut self,
        patch: ImageView<'_, f32>,
        score: f64,
        background_scores: &[f64],
    ) -> Result<bool> {
        self.update_above(patch, score, background_scores, self.update_threshold())
    }

    /// [`TargetModel::update`] with the caller's threshold in place of
    /// `mu_B + sigma_B` (Xu, Gao and Yang 2015 (paper 002) prints the update condition both as
    /// `mu_B + sigma_B`, section 1, and as `mu_B - sigma_B`, Algorithm 1
    /// step 7): updates only if `score > threshold`.
    ///
    /// # Errors
    /// As [`TargetModel::update`]; also [`AppearanceError::NonFinite`] for a
    /// NaN threshold.
    pub fn update_above(
        &mut self,
        patch: ImageView<'_, f32>,
        score: f64,
        background_scores: &[f64],
        threshold: f64,
    ) -> Result<bool> {
        if patch.width() != self.template.width() || patch.height() != self.template.height() {
            return Err(AppearanceError::WindowSize {
                operation: "TargetModel::update",
                got_width: patch.width(),
                got_height: patch.height(),
                want_width: self.template.width(),
                want_height: self.template.height(),
            });
        }
        patch.expect_channels("TargetModel::update", 1)?;
        if !score.is_finite() || background_scores.iter().any(|v| !v.is_finite()) {
            return Err(AppearanceError::NonFinite { what: "score" });
        }
        if (0..patch.height()).any(|y| patch.row(y).iter().any(|v| !v.is_finite())) {
            return Err(AppearanceError::NonFinite { what: "patch" });
        }
        if threshold.is_nan() {
            return Err(AppearanceError::NonFinite { what: "threshold" });
        }
        if score <= threshold {
            return Ok(false);
        }
        let a = self.template_rate;
        for y in 0..patch.height() {
            for (t, &p) in self.template.row_mut(y).iter_mut().zip(patch.row(y)) {
                *t += a * (p - *t);
            }
        }
        self.centred.set(self.template.view());
        self.tsd.update(score)?;
        for &b in background_scores {
            self.bsd.update(b)?;
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: usize, h: usize, seed: u32) -> Image<f32> {
        bayestrack_testkit::noise(w, h, 1, seed).map(|v| f32::from(v) / 255.0)
    }

    #[test]
    fn ncc_values() {
        let a = Image::from_vec(2, 2, 1, vec![0.0f32, 1.0, 2.0, 3.0]).unwrap();
        let b = a.map(|v| 5.0 + 2.0 * v); // affine brightness change
        assert!((ncc(a.view(), b.view()).unwrap() - 1.0).abs() < 1e-12);
        let c = a.map(|v| -v);
        assert!((ncc(a.view(), c.view()).unwrap() + 1.0).abs() < 1e-12);
        let flat = Image::new(2, 2, 1, 0.5f32).unwrap();
        assert_eq!(ncc(a.view(), flat.view()).unwrap(), 0.0);
        // Hand value: a = [1, 0, 0, 0], b = [1, 1, 0, 0]:
        // da = [.75, -.25, -.25, -.25], db = [.5, .5, -.5, -.5];
        // sab = .375 - .125 + .125 + .125 = .5, saa = .75, sbb = 1 -> .5 / sqrt(.75).
        let p = Image::from_vec(2, 2, 1, vec![1.0f32, 0.0, 0.0, 0.0]).unwrap();
        let q = Image::from_vec(2, 2, 1, vec![1.0f32, 1.0, 0.0, 0.0]).unwrap();
        assert!((ncc(p.view(), q.view()).unwrap() - 0.5 / 0.75f64.sqrt()).abs() < 1e-12);
        let small = Image::new(1, 2, 1, 0f32).unwrap();
        assert!(ncc(a.view(), small.view()).is_err());
    }

    /// The two-pass NCC as it was before the template side was cached.
    fn ncc_sequential(a: ImageView<'_, f32>, b: ImageView<'_, f32>) -> f64 {
        let n = (a.width() * a.height()) as f64;
        let (mut sa, mut sb) = (0f64, 0f64);
        for y in 0..a.height() {
            for (&p, &q) in a.row(y).iter().zip(b.row(y)) {
                sa += f64::from(p);
                sb += f64::from(q);
            }
        }
        let (ma, mb) = (sa / n, sb / n);
        let (mut sab, mut saa, mut sbb) = (0f64, 0f64, 0f64);
        for y in 0..a.height() {
            for (&p, &q) in a.row(y).iter().zip(b.row(y)) {
                let (da, db) = (f64::from(p) - ma, f64::from(q) - mb);
                sab += da * db;
                saa += da * da;
                sbb += db * db;
            }
        }
        let den = (saa * sbb).sqrt();
        if den <= 1e-12 * n {
            return 0.0;
        }
        (sab / den).clamp(-1.0, 1.0)
    }

    #[test]
    fn cached_side_gives_the_two_pass_bits() {
        // Widths 1 to 19 and 36, 37, a strided view; related and unrelated
        // patches, a large offset (large mean, small deviations).
        for (k, w) in (1..=19).chain([36, 37]).enumerate() {
            let h = 1 + k % 5 + w / 4;
            let a = texture(w, h, 7 + k as u32);
            let big = texture(w + 3, h, 99 + k as u32);
            let b = big.crop(bayestrack_image::Rect::new(2, 0, w, h)).unwrap();
            let c = a.map(|v| 100.0 + 0.5 * v + 0.01 * (v * 37.0).sin());
            for (x, y) in [(a.view(), b), (a.view(), c.view()), (b, c.view())] {
                let (got, want) = (ncc(x, y).unwrap(), ncc_sequential(x, y));
                assert_eq!(got.to_bits(), want.to_bits(), "{w}x{h}: {got} vs {want}");
                let (got, want) = (ncc(y, x).unwrap(), ncc_sequential(y, x));
                assert_eq!(got.to_bits(), want.to_bits(), "{w}x{h}: {got} vs {want}");
            }
        }
    }

    /// `centred_sums` at every SIMD level equals the per-pixel loop bit
    /// for bit: widths 1 to 19, 36, 37, 64, 65, 130 (blocks and their
    /// tails), contiguous and strided patches.
    #[test]
    fn centred_sums_equal_the_pixel_loop_at_every_level() {
        use bayestrack_image::simd::SimdLevel;
        for (k, w) in (1..=19).chain([36, 37, 64, 65, 130]).enumerate() {
            let h = 1 + k % 4 + 36 / w;
            let big = texture(w + 5, h, 40 + k as u32);
            let strided = big.crop(bayestrack_image::Rect::new(3, 0, w, h)).unwrap();
            let whole = texture(w, h, 80 + k as u32);
            let side = Centred::of(texture(w, h, 120 + k as u32).view());
            for a in [whole.view(), strided] {
                let ma = 0.37 + 0.01 * k as f64;
                let (mut sab, mut saa) = (0f64, 0f64);
                for (y, dev) in side.dev.chunks_exact(w).enumerate() {
                    for (&p, &db) in a.row(y)[..w].iter().zip(dev) {
                        let da = f64::from(p) - ma;
                        sab += da * db;
                        saa += da * da;
                    }
                }
                for level in SimdLevel::ALL {
                    let (gab, gaa) = level.run(CentredSums {
                        a,
                        dev: &side.dev,
                        w,
                        h,
                        ma,
                    });
                    assert_eq!(gab.to_bits(), sab.to_bits(), "{level:?} {w}x{h}");
                    assert_eq!(gaa.to_bits(), saa.to_bits(), "{level:?} {w}x{h}");
                }
            }
        }
    }

    /// The patch sum one pixel at a time in row-major order.
    fn sequential_sum(a: ImageView<'_, f32>) -> f64 {
        let mut s = 0f64;
        for y in 0..a.height() {
            for &p in a.row(y) {
                s += f64::from(p);
            }
        }
        s
    }

    #[test]
    fn the_lane_sum_is_taken_only_when_exact() {
        let mut lcg = bayestrack_testkit::Lcg64(3);
        let mut gray_taken = 0;
        for trial in 0..400 {
            let (w, h) = [(36, 36), (37, 5), (7, 3), (1, 9), (16, 2)][trial % 5];
            // Gray values in [0, 1] (bilinear-like: any f32 bits); or ones
            // mixed with tiny values whose low bits fall below the ulp of
            // the running sum, so that the order of the additions shows.
            let kind = trial % 4;
            let img = Image::from_fn(w, h, |_, _| {
                let u = lcg.unit() as f32;
                match kind {
                    0 | 1 => u,
                    2 => {
                        if u < 0.5 {
                            1.0 + u
                        } else {
                            (u - 0.5) * 1e-8
                        }
                    }
                    _ => (u - 0.5) * 1e3 + if u < 0.1 { 1e-7 } else { 0.0 },
                }
            })
            .unwrap();
            let want = sequential_sum(img.view());
            let got = exact_sum(img.view(), w, h);
            if let Some(s) = got {
                assert_eq!(s.to_bits(), want.to_bits(), "trial {trial}, {w}x{h}");
            }
            if kind < 2 && w * h >= 32 {
                gray_taken += usize::from(got.is_some());
            }
            if kind == 2 && w * h >= 32 {
                assert!(got.is_none(), "trial {trial}: tiny values must not pass");
            }
            // And the NCC against any side is the two-pass one.
            let t = texture(w, h, trial as u32);
            let (got, want) = (
                ncc(img.view(), t.view()).unwrap(),
                ncc_sequential(img.view(), t.view()),
            );
            assert_eq!(got.to_bits(), want.to_bits(), "trial {trial}");
        }
        // Gray patches (no pixel non-zero below about 1e-6) take the lanes.
        assert!(gray_taken > 100, "{gray_taken} of 120");
        // Zeros, a NaN, an infinity.
        let mut z = Image::new(9, 4, 1, 0f32).unwrap();
        assert_eq!(exact_sum(z.view(), 9, 4).map(f64::to_bits), Some(0));
        z.as_mut_slice()[5] = f32::NAN;
        assert!(exact_sum(z.view(), 9, 4).is_none_or(f64::is_nan));
        z.as_mut_slice()[5] = f32::INFINITY;
        assert!(exact_sum(z.view(), 9, 4).is_none_or(|s| !s.is_finite()));
        assert!(ncc(z.view(), texture(9, 4, 1).view()).is_err());
    }

    #[test]
    fn similarity_follows_the_updated_template() {
        // The cached template side must track every update: the model's
        // similarity is ncc(patch, template) bit for bit after each.
        let tsd = OnlineGaussian::new(0.9, 0.05, 0.1).unwrap();
        let bsd = OnlineGaussian::new(0.0, 0.01, 0.1).unwrap();
        let mut m = TargetModel::new(texture(36, 36, 1), tsd, bsd, 0.3).unwrap();
        for seed in 2..6 {
            let p = texture(36, 36, seed);
            let q = texture(36, 36, seed + 10);
            let direct = ncc(q.view(), m.template()).unwrap().max(0.0);
            assert_eq!(m.similarity(q.view()).unwrap().to_bits(), direct.to_bits());
            assert!(m.update_above(p.view(), 1.0, &[], 0.0).unwrap());
            let direct = ncc(q.view(), m.template()).unwrap().max(0.0);
            assert_eq!(m.similarity(q.view()).unwrap().to_bits(), direct.to_bits());
        }
    }

    #[test]
    fn online_gaussian() {
        let g = OnlineGaussian::from_samples(&[1.0, 2.0, 3.0], 0.1).unwrap();
        assert_eq!((g.mean(), g.std(), g.count()), (2.0, 1.0, 3));
        let mut g = OnlineGaussian::new(0.0, 0.0, 0.5).unwrap();
        g.update(2.0).unwrap();
        assert_eq!(g.mean(), 1.0);
        assert!((g.std() - 1.0).abs() < 1e-12); // 0.5 * (0 + 0.5 * 4) = 1
        // Converges to a constant stream.
        for _ in 0..100 {
            g.update(7.0).unwrap();
        }
        assert!((g.mean() - 7.0).abs() < 1e-9 && g.std() < 1e-9);
        assert!(OnlineGaussian::from_samples(&[1.0], 0.1).is_err());
        assert!(OnlineGaussian::new(0.0, 1.0, 0.0).is_err());
        assert!(OnlineGaussian::new(0.0, -1.0, 0.5).is_err());
        assert!(g.update(f64::NAN).is_err());
    }

    #[test]
    fn template_update_only_above_bsd_band() {
        let tpl = texture(36, 36, 1);
        let tsd = OnlineGaussian::new(0.9, 0.05, 0.1).unwrap();
        let bsd = OnlineGaussian::new(0.2, 0.1, 0.1).unwrap();
        let mut m = TargetModel::new(tpl.clone(), tsd, bsd, 0.5).unwrap();
        assert!((m.stop_threshold() - 0.85).abs() < 1e-12);
        assert!((m.update_threshold() - 0.3).abs() < 1e-12);
        assert!((m.similarity(tpl.view()).unwrap() - 1.0).abs() < 1e-9);
        let other = texture(36, 36, 2);
        let s = m.similarity(other.view()).unwrap();
        assert!(s < 0.2, "unrelated textures correlate little: {s}");
        // Below mu_B + sigma_B: nothing changes.
        assert!(!m.update(other.view(), 0.25, &[0.1]).unwrap());
        assert_eq!(m.template().as_slice(), tpl.as_slice());
        assert_eq!(m.tsd().count(), 0);
        // Above: template blends halfway, TSD and BSD absorb the scores.
        assert!(m.update(other.view(), 0.95, &[0.1, 0.3]).unwrap());
        let want = (tpl.as_slice()[0] + other.as_slice()[0]) / 2.0;
        assert!((m.template().as_slice()[0] - want).abs() < 1e-6);
        assert!((m.tsd().mean() - 0.905).abs() < 1e-12);
        assert_eq!(m.bsd().count(), 2);
        let wrong = texture(10, 10, 3);
        assert!(matches!(
            m.similarity(wrong.view()),
            Err(AppearanceError::WindowSize { .. })
        ));
        assert!(m.update(other.view(), f64::NAN, &[]).is_err());
        let learnt = TargetModel::from_samples(tpl, &[0.9, 0.8], &[0.1, 0.3], 0.1, 0.2).unwrap();
        assert!((learnt.tsd().mean() - 0.85).abs() < 1e-12);
    }

    #[test]
    fn update_above_takes_the_callers_threshold() {
        let tpl = texture(36, 36, 1);
        let other = texture(36, 36, 2);
        let tsd = OnlineGaussian::new(0.9, 0.05, 0.1).unwrap();
        let bsd = OnlineGaussian::new(0.2, 0.1, 0.1).unwrap();
        let mut m = TargetModel::new(tpl, tsd, bsd, 0.5).unwrap();
        // 0.25 is below mu_B + sigma_B = 0.3 but above mu_B - sigma_B = 0.1.
        assert!(!m.clone().update(other.view(), 0.25, &[]).unwrap());
        assert!(m.update_above(other.view(), 0.25, &[], 0.1).unwrap());
        assert!(!m.update_above(other.view(), 0.05, &[], 0.1).unwrap());
        assert!(m.update_above(other.view(), 0.5, &[], f64::NAN).is_err());
    }
}
