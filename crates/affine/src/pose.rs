//! The LWPR pose estimator of Xu, Gao and Yang 2015 (paper 002) section 2 (after Li et al.'s
//! incremental self-tuning particle filter, ISPF).
//!
//! A particle `M` (template -> image, see [`crate::group`]) is observed as a
//! fixed-size patch `O(M)` (36x36 in Xu, Gao and Yang 2015 (paper 002)) warped from the frame. The
//! estimator learns, with LWPR, the map from the features of `O(M)` to the
//! Lie-algebra increment `Delta` such that `M exp(Delta)` is the target pose.
//! It is trained online from random perturbations of the current estimate
//! `M*`: a perturbed pose `M* exp(delta)` is a training input whose target is
//! `-delta`. "Tuning a particle to its best neighbour" (Algorithm 1 step 2)
//! applies `M <- M exp(f(O(M)))` iteratively and keeps the best-scoring pose.

use bayestrack_image::simd::{self, Token, dispatch};
use bayestrack_image::{Border, ImageView, ImageViewMut, Pixel, warp_into};
use nalgebra::{Matrix3, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::Affine2;
use crate::error::{AffineError, Result};
use crate::group::{AffineGroup, AlgebraVector};
use crate::lwpr::{Lwpr, LwprConfig};

/// Which features of the warped patch feed the regressor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FeatureKind {
    /// Grey values.
    #[default]
    Gray,
    /// Horizontal and vertical central-difference gradients (two values per
    /// pooled cell).
    Gradient,
}

/// Parameters of the pose estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseConfig {
    /// Side of the square warped patch (Xu, Gao and Yang 2015 (paper 002): 36).
    pub patch_size: usize,
    /// Block-average pooling factor applied to the patch (must divide
    /// `patch_size`): 1 keeps all 36 x 36 = 1296 grey values, 3 gives 144.
    /// The reference LWPR trusts a receptive field only after 2N samples, so
    /// pooling shortens the training needed before the first prediction.
    pub pool: usize,
    /// Grey values or gradients.
    pub features: FeatureKind,
    /// Standard deviations of the training perturbations, in basis
    /// coordinates (scale, aspect, rotation, skew, x shift, y shift; shifts
    /// in template pixels).
    pub train_sigma: AlgebraVector,
    /// Initial LWPR distance metric `init_d I` on the unit-norm features.
    pub init_d: f64,
    /// LWPR receptive-field creation threshold.
    pub w_gen: f64,
    /// LWPR prediction cutoff.
    pub cutoff: f64,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            patch_size: 36,
            pool: 3,
            features: FeatureKind::Gray,
            train_sigma: AlgebraVector::new(0.04, 0.03, 0.06, 0.03, 2.0, 2.0),
            init_d: 2.0,
            w_gen: 0.2,
            cutoff: 0.001,
        }
    }
}

/// Learns and applies the patch -> pose-increment map.
#[derive(Debug, Clone)]
pub struct PoseEstimator {
    cfg: PoseConfig,
    template_w: f64,
    template_h: f64,
    model: Lwpr,
    patch: Vec<f32>,
    feat: Vec<f64>,
    pred: Vec<f64>,
}

/// The cell sums of a `ps x ps` patch pooled by 3 (row-major cells,
/// `(ps / 3)^2` of them into `feat`) as a dispatched kernel: four cells of
/// a band at a time in vector lanes, lane `l` summing its own cell in the
/// order of [`pool_band`] (rows top to bottom, each left to right, from
/// `0.0`), the band's last `cells % 4` one at a time in that order: the
/// same bits at every level.
struct PoolCells3<'a> {
    patch: &'a [f32],
    ps: usize,
    feat: &'a mut [f64],
}

impl simd::Kernel for PoolCells3<'_> {
    type Output = ();
    /// AVX2 at most: measured slower with AVX-512 (see
    /// [`simd::Kernel::WIDEST`]).
    const WIDEST: simd::SimdLevel = simd::SimdLevel::Avx2;
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        let (ps, cells) = (self.ps, self.ps / 3);
        for (band, feat) in self
            .patch
            .chunks_exact(3 * ps)
            .zip(self.feat.chunks_exact_mut(cells))
        {
            let (four, rest) = feat.split_at_mut(cells / 4 * 4);
            for (g, f) in four.chunks_exact_mut(4).enumerate() {
                let mut s = [0f64; 4];
                for r in 0..3 {
                    let w: &[f32; 12] = band[r * ps + 12 * g..][..12]
                        .try_into()
                        .expect("twelve pixels");
                    for k in 0..3 {
                        for (l, s) in s.iter_mut().enumerate() {
                            *s += f64::from(w[3 * l + k]);
                        }
                    }
                }
                f.copy_from_slice(&s);
            }
            for (cx, f) in rest.iter_mut().enumerate() {
                let cx = cx + cells / 4 * 4;
                let mut s = 0.0;
                for r in 0..3 {
                    for v in &band[r * ps + 3 * cx..][..3] {
                        s += f64::from(*v);
                    }
                }
                *f = s;
            }
        }
    }
}

/// The cell sums of one band of `P` patch rows (`ps` wide) into `feat`
/// (one per cell of `P x P` pixels): each cell's rows top to bottom, each
/// row left to right, added to `0.0` in `f64` (the order of the generic
/// loop in [`PoseEstimator::features`], with the pooling factor known at
/// compile time).
#[inline(always)]
fn pool_band<const P: usize>(band: &[f32], ps: usize, feat: &mut [f64]) {
    let mut rows: [core::slice::ChunksExact<'_, f32>; P] =
        core::array::from_fn(|r| band[r * ps..(r + 1) * ps].chunks_exact(P));
    for f in feat.iter_mut() {
        let mut s = 0.0;
        for row in rows.iter_mut() {
            if let Some(cell) = row.next() {
                for v in cell {
                    s += f64::from(*v);
                }
            }
        }
        *f = s;
    }
}

impl PoseEstimator {
    /// A new, untrained estimator for a `template_w x template_h` target.
    pub fn new(cfg: PoseConfig, template_w: f64, template_h: f64) -> Result<Self> {
        if cfg.patch_size < 3 || cfg.pool == 0 || !cfg.patch_size.is_multiple_of(cfg.pool) {
            return Err(AffineError::InvalidParameter {
                name: "patch_size / pool",
                value: cfg.patch_size as f64,
                reason: "patch_size must be >= 3 and a multiple of pool",
            });
        }
        if !(template_w.is_finite()
            && template_h.is_finite()
            && template_w > 0.0
            && template_h > 0.0)
        {
            return Err(AffineError::InvalidParameter {
                name: "template size",
                value: template_w.min(template_h),
                reason: "must be finite and > 0",
            });
        }
        crate::error::check_finite("train_sigma", cfg.train_sigma.as_slice())?;
        let cells = (cfg.patch_size / cfg.pool).pow(2);
        let n_in = match cfg.features {
            FeatureKind::Gray => cells,
            FeatureKind::Gradient => 2 * cells,
        };
        let mut lcfg = LwprConfig::new(n_in, 6).init_d_spherical(cfg.init_d);
        lcfg.w_gen = cfg.w_gen;
        let model = Lwpr::new(lcfg)?;
        Ok(Self {
            patch: vec![0.0; cfg.patch_size * cfg.patch_size],
            feat: vec![0.0; n_in],
            pred: vec![0.0; 6],
            cfg,
            template_w,
            template_h,
            model,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PoseConfig {
        &self.cfg
    }

    /// The underlying LWPR model.
    pub fn model(&self) -> &Lwpr {
        &self.model
    }

    /// The patch `O(M)` warped by the last successful call to
    /// [`PoseEstimator::features`] (or [`PoseEstimator::predict_increment`]),
    /// row-major `patch_size x patch_size` grey values: a tracker can score
    /// the pose it just tuned from it without warping the frame again.
    pub fn patch(&self) -> &[f32] {
        &self.patch
    }

    /// Feature dimension.
    pub fn feature_dim(&self) -> usize {
        self.feat.len()
    }

    /// The map from patch pixel coordinates to image coordinates for pose
    /// `m`: patch pixel centres cover the template evenly.
    pub fn patch_map(&self, m: &Affine2) -> Result<Affine2> {
        let ps = self.cfg.patch_size as f64;
        let (sx, sy) = (self.template_w / ps, self.template_h / ps);
        let s = Matrix3::new(
            sx,
            0.0,
            0.5 * sx - 0.5 * self.template_w,
            0.0,
            sy,
            0.5 * sy - 0.5 * self.template_h,
            0.0,
            0.0,
            1.0,
        );
        let full = m.matrix() * s;
        let c: [f64; 9] = full
            .as_slice()
            .try_into()
            .expect("a 3x3 matrix has 9 entries");
        Ok(Affine2::from_column_major(&c)?)
    }

    /// Features of the patch seen at pose `m`: warped (the patch must lie
    /// inside the frame), pooled, optionally differentiated, then shifted to
    /// zero mean and scaled to unit norm (invariant to affine illumination
    /// changes). Fails with [`AffineError::Image`] when the patch leaves the
    /// frame or the frame is not single-channel.
    pub fn features<T: Pixel>(&mut self, frame: ImageView<'_, T>, m: &Affine2) -> Result<&[f64]> {
        frame.expect_channels("pose features", 1)?;
        let map = self.patch_map(m)?;
        let ps = self.cfg.patch_size;
        {
            let mut out = ImageViewMut::from_slice(&mut self.patch, ps, ps, 1, ps)?;
            warp_into(frame, &map, Border::Error, &mut out)?;
        }
        let pool = self.cfg.pool;
        let cells = ps / pool;
        let inv = 1.0 / (pool * pool) as f64;
        let at = |patch: &[f32], x: usize, y: usize| f64::from(patch[y * ps + x]);
        // The sum of the features, in index order as it is written (from
        // -0.0, as `Iterator::sum` starts).
        let mut total = -0.0;
        match self.cfg.features {
            FeatureKind::Gray if pool == 1 => {
                // A cell's sum is one value (added to 0.0, as below).
                for (f, v) in self.feat.iter_mut().zip(&self.patch) {
                    *f = (0.0 + f64::from(*v)) * inv;
                    total += *f;
                }
            }
            FeatureKind::Gray => {
                // Cell sums over the cell's rows, each row left to right
                // (pooled by 3, all at once, vectorised across cells).
                if pool == 3 {
                    dispatch(PoolCells3 {
                        patch: &self.patch,
                        ps,
                        feat: &mut self.feat,
                    });
                }
                for (band, feat) in self
                    .patch
                    .chunks_exact(pool * ps)
                    .zip(self.feat.chunks_exact_mut(cells))
                {
                    match pool {
                        2 => pool_band::<2>(band, ps, feat),
                        // summed above by the dispatched kernel
                        3 => {}
                        4 => pool_band::<4>(band, ps, feat),
                        _ => {
                            for (cx, f) in feat.iter_mut().enumerate() {
                                let mut s = 0.0;
                                for row in band.chunks_exact(ps) {
                                    for v in &row[cx * pool..(cx + 1) * pool] {
                                        s += f64::from(*v);
                                    }
                                }
                                *f = s;
                            }
                        }
                    }
                    for f in feat.iter_mut() {
                        *f *= inv;
                        total += *f;
                    }
                }
            }
            FeatureKind::Gradient => {
                let n = cells * cells;
                for cy in 0..cells {
                    for cx in 0..cells {
                        let (mut gx, mut gy) = (0.0, 0.0);
                        for y in cy * pool..(cy + 1) * pool {
                            for x in cx * pool..(cx + 1) * pool {
                                let (x0, x1) = (x.saturating_sub(1), (x + 1).min(ps - 1));
                                let (y0, y1) = (y.saturating_sub(1), (y + 1).min(ps - 1));
                                gx += (at(&self.patch, x1, y) - at(&self.patch, x0, y))
                                    / (x1 - x0) as f64;
                                gy += (at(&self.patch, x, y1) - at(&self.patch, x, y0))
                                    / (y1 - y0) as f64;
                            }
                        }
                        self.feat[cy * cells + cx] = gx * inv;
                        self.feat[n + cy * cells + cx] = gy * inv;
                    }
                }
                total = self.feat.iter().sum::<f64>();
            }
        }
        let n = self.feat.len() as f64;
        let mean = total / n;
        let mut norm = 0.0;
        for f in self.feat.iter_mut() {
            *f -= mean;
            norm += *f * *f;
        }
        let norm = norm.sqrt();
        if norm > 1e-12 {
            for f in self.feat.iter_mut() {
                *f /= norm;
            }
        }
        // The features are pooled f32 values: all finite exactly when their
        // mean and norm are (no f64 overflow from f32 magnitudes), and the
        // scan that names the first bad one runs only then.
        if !(mean.is_finite() && norm.is_finite()) {
            crate::error::check_finite("patch features", &self.feat)?;
        }
        Ok(&self.feat)
    }

    /// Trains on `n` random perturbations `M* exp(delta)`,
    /// `delta ~ N(0, diag(train_sigma^2))`, of the estimate `m_star` in
    /// `frame`; perturbations whose patch leaves the frame are skipped.
    /// Returns the number of samples used. The same as
    /// [`PoseEstimator::training_poses`] then [`PoseEstimator::train_on`].
    pub fn train<T: Pixel, R: Rng + ?Sized>(
        &mut self,
        frame: ImageView<'_, T>,
        m_star: &Affine2,
        n: usize,
        rng: &mut R,
    ) -> Result<usize> {
        frame.expect_channels("pose training", 1)?;
        let poses = self.training_poses(m_star, n, rng)?;
        self.train_on(frame, &poses)
    }

    /// The `n` random perturbations [`PoseEstimator::train`] trains on:
    /// each `(delta, M* exp(delta))`, `delta ~ N(0, diag(train_sigma^2))`
    /// drawn from `rng` in order. A caller that must prepare the frame's
    /// pixels the patches read (see [`PoseEstimator::patch_map`]) draws
    /// them first and passes them to [`PoseEstimator::train_on`].
    pub fn training_poses<R: Rng + ?Sized>(
        &self,
        m_star: &Affine2,
        n: usize,
        rng: &mut R,
    ) -> Result<Vec<(AlgebraVector, Affine2)>> {
        let mut poses = Vec::with_capacity(n);
        for _ in 0..n {
            let mut delta = AlgebraVector::zeros();
            for (d, s) in delta.iter_mut().zip(self.cfg.train_sigma.iter()) {
                let z: f64 = StandardNormal.sample(rng);
                *d = s * z;
            }
            poses.push((delta, m_star.compose(&Affine2::exp(&delta)?)));
        }
        Ok(poses)
    }

    /// Trains on the perturbations `(delta, M* exp(delta))` of
    /// [`PoseEstimator::training_poses`], in order (the target of pose
    /// `M* exp(delta)` is `-delta`); those whose patch leaves the frame are
    /// skipped. Returns the number of samples used.
    pub fn train_on<T: Pixel>(
        &mut self,
        frame: ImageView<'_, T>,
        poses: &[(AlgebraVector, Affine2)],
    ) -> Result<usize> {
        frame.expect_channels("pose training", 1)?;
        let mut used = 0;
        let mut target = [0.0; 6];
        for (delta, m) in poses {
            match self.features(frame, m) {
                Ok(_) => {}
                Err(AffineError::Image(bayestrack_image::ImageError::PatchOutside { .. })) => {
                    continue;
                }
                Err(e) => return Err(e),
            }
            for (t, d) in target.iter_mut().zip(delta.iter()) {
                *t = -d;
            }
            self.model
                .update_into(&self.feat, &target, &mut self.pred)?;
            used += 1;
        }
        Ok(used)
    }

    /// The predicted increment `Delta` at pose `m` (zero before training).
    pub fn predict_increment<T: Pixel>(
        &mut self,
        frame: ImageView<'_, T>,
        m: &Affine2,
    ) -> Result<AlgebraVector> {
        self.features(frame, m)?;
        self.model
            .predict_into(&self.feat, self.cfg.cutoff, &mut self.pred)?;
        Ok(AlgebraVector::from_column_slice(&self.pred))
    }

    /// One tuning step: `m exp(Delta)`.
    pub fn tune_step<T: Pixel>(&mut self, frame: ImageView<'_, T>, m: &Affine2) -> Result<Affine2> {
        let d = self.predict_increment(frame, m)?;
        Ok(m.checked_compose(&Affine2::exp(&d)?)?)
    }

    /// Tunes `m` to its best neighbour: up to `max_steps` tuning steps,
    /// scoring each pose with `score` (higher is better, e.g. the
    /// similarity to the template); stops at the first step that does not
    /// improve the score or leaves the frame. Returns the best pose and its
    /// score.
    pub fn tune<T: Pixel>(
        &mut self,
        frame: ImageView<'_, T>,
        m: &Affine2,
        max_steps: usize,
        mut score: impl FnMut(&Affine2) -> Result<f64>,
    ) -> Result<(Affine2, f64)> {
        let mut best = *m;
        let mut best_score = score(m)?;
        for _ in 0..max_steps {
            let next = match self.tune_step(frame, &best) {
                Ok(n) => n,
                Err(AffineError::Image(_)) => break,
                Err(e) => return Err(e),
            };
            let s = match score(&next) {
                Ok(s) => s,
                Err(AffineError::Image(_)) => break,
                Err(e) => return Err(e),
            };
            if s > best_score {
                best = next;
                best_score = s;
            } else {
                break;
            }
        }
        Ok((best, best_score))
    }
}

/// Root-mean-square distance, in image pixels, between the template corners
/// and centre mapped by `a` and by `b`: a pose error for a `w x h` template.
pub fn pose_error(a: &Affine2, b: &Affine2, w: f64, h: f64) -> f64 {
    let pts = [
        Vector2::new(-0.5 * w, -0.5 * h),
        Vector2::new(0.5 * w, -0.5 * h),
        Vector2::new(0.5 * w, 0.5 * h),
        Vector2::new(-0.5 * w, 0.5 * h),
        Vector2::new(0.0, 0.0),
    ];
    let s: f64 = pts
        .iter()
        .map(|p| (a.map_point(*p) - b.map_point(*p)).norm_squared())
        .sum();
    (s / pts.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// The vectorised pooling by 3 equals `pool_band::<3>` band by band,
    /// bit for bit, at every level: patch sides whose bands have a multiple
    /// of four cells and others (remainders 1 to 3, bands of fewer than four
    /// cells), values of mixed signs and magnitudes (so that the order of
    /// the additions shows in the bits), zeros of both signs.
    #[test]
    fn pooling_by_three_equals_the_band_loop_bit_for_bit_at_every_level() {
        use bayestrack_image::SimdLevel;
        use rand::RngExt;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        for ps in [3, 6, 9, 12, 15, 21, 24, 27, 36, 39, 48] {
            let patch: Vec<f32> = (0..ps * ps)
                .map(|i| match i % 11 {
                    0 => 0.0,
                    1 => -0.0,
                    2 => rng.random_range(-1e6f32..1e6),
                    _ => rng.random_range(-1f32..1.0) * 10f32.powi(rng.random_range(-8..3)),
                })
                .collect();
            let cells = ps / 3;
            let mut want = vec![0f64; cells * cells];
            for (band, feat) in patch.chunks_exact(3 * ps).zip(want.chunks_exact_mut(cells)) {
                pool_band::<3>(band, ps, feat);
            }
            for level in SimdLevel::ALL {
                let mut got = vec![f64::NAN; cells * cells];
                level.run(PoolCells3 {
                    patch: &patch,
                    ps,
                    feat: &mut got,
                });
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "{level:?} side {ps}");
            }
        }
    }

    /// A smooth random texture: a sum of Gaussian blobs.
    fn texture(w: usize, h: usize, seed: u64) -> Image<f32> {
        use rand::RngExt;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let blobs: Vec<(f64, f64, f64, f64)> = (0..120)
            .map(|_| {
                (
                    rng.random_range(0.0..w as f64),
                    rng.random_range(0.0..h as f64),
                    rng.random_range(3.0..9.0),
                    rng.random_range(-1.0..1.0),
                )
            })
            .collect();
        Image::from_fn(w, h, |x, y| {
            let mut v = 0.5;
            for &(cx, cy, s, a) in &blobs {
                let d2 = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
                v += 0.3 * a * (-d2 / (2.0 * s * s)).exp();
            }
            v as f32
        })
        .unwrap()
    }

    #[test]
    fn one_tuning_step_reduces_pose_error() {
        let frame = texture(160, 160, 1);
        let (tw, th) = (40.0, 40.0);
        let m_star = Affine2::translation(80.0, 80.0);
        let mut pe = PoseEstimator::new(PoseConfig::default(), tw, th).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
        let used = pe.train(frame.view(), &m_star, 1200, &mut rng).unwrap();
        assert_eq!(used, 1200);
        let sigma = pe.config().train_sigma;
        let (mut before, mut after) = (0.0, 0.0);
        let trials = 60;
        for seed in 0..trials {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(1000 + seed);
            let mut delta = AlgebraVector::zeros();
            for (d, s) in delta.iter_mut().zip(sigma.iter()) {
                let z: f64 = StandardNormal.sample(&mut rng);
                *d = s * z;
            }
            let m = m_star.compose(&Affine2::exp(&delta).unwrap());
            let tuned = pe.tune_step(frame.view(), &m).unwrap();
            before += pose_error(&m, &m_star, tw, th);
            after += pose_error(&tuned, &m_star, tw, th);
        }
        before /= trials as f64;
        after /= trials as f64;
        println!(
            "pose: mean corner error {before:.3} px -> {after:.3} px after one step ({} RFs for dx)",
            pe.model().num_rfs(4)
        );
        assert!(after < 0.5 * before, "before {before} after {after}");
    }

    /// The features as first written (straightforward loops, the mean by
    /// `Iterator::sum`, a final finiteness scan), from a warped patch.
    fn reference_features(patch: &[f32], ps: usize, pool: usize, kind: FeatureKind) -> Vec<f64> {
        let cells = ps / pool;
        let inv = 1.0 / (pool * pool) as f64;
        let at = |x: usize, y: usize| f64::from(patch[y * ps + x]);
        let n_in = if kind == FeatureKind::Gray {
            cells * cells
        } else {
            2 * cells * cells
        };
        let mut feat = vec![0.0; n_in];
        for cy in 0..cells {
            for cx in 0..cells {
                let (mut s, mut gx, mut gy) = (0.0, 0.0, 0.0);
                for y in cy * pool..(cy + 1) * pool {
                    for x in cx * pool..(cx + 1) * pool {
                        s += at(x, y);
                        let (x0, x1) = (x.saturating_sub(1), (x + 1).min(ps - 1));
                        let (y0, y1) = (y.saturating_sub(1), (y + 1).min(ps - 1));
                        gx += (at(x1, y) - at(x0, y)) / (x1 - x0) as f64;
                        gy += (at(x, y1) - at(x, y0)) / (y1 - y0) as f64;
                    }
                }
                if kind == FeatureKind::Gray {
                    feat[cy * cells + cx] = s * inv;
                } else {
                    feat[cy * cells + cx] = gx * inv;
                    feat[cells * cells + cy * cells + cx] = gy * inv;
                }
            }
        }
        let mean = feat.iter().sum::<f64>() / feat.len() as f64;
        let mut norm = 0.0;
        for f in feat.iter_mut() {
            *f -= mean;
            norm += *f * *f;
        }
        let norm = norm.sqrt();
        if norm > 1e-12 {
            feat.iter_mut().for_each(|f| *f /= norm);
        }
        assert!(feat.iter().all(|f| f.is_finite()));
        feat
    }

    /// The features equal the straightforward computation bit for bit, for
    /// every pooling factor and both kinds, on random textures and poses
    /// (and a constant patch, whose norm is 0).
    #[test]
    fn features_equal_the_reference_bit_for_bit() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let frame = texture(120, 120, 20);
        for (pool, kind) in [
            (1, FeatureKind::Gray),
            (2, FeatureKind::Gray),
            (3, FeatureKind::Gray),
            (4, FeatureKind::Gray),
            (2, FeatureKind::Gradient),
            (3, FeatureKind::Gradient),
        ] {
            let cfg = PoseConfig {
                pool,
                features: kind,
                ..PoseConfig::default()
            };
            let mut pe = PoseEstimator::new(cfg, 30.0, 30.0).unwrap();
            for _ in 0..5 {
                let mut delta = AlgebraVector::zeros();
                for (d, s) in delta.iter_mut().zip(pe.config().train_sigma.iter()) {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    *d = 3.0 * s * z;
                }
                let m = Affine2::translation(60.0, 60.0).compose(&Affine2::exp(&delta).unwrap());
                let got = pe.features(frame.view(), &m).unwrap().to_vec();
                let want = reference_features(pe.patch(), 36, pool, kind);
                assert_eq!(got.len(), want.len());
                for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(a.to_bits(), b.to_bits(), "pool {pool} {kind:?} feature {i}");
                }
            }
            let flat = Image::from_fn(120, 120, |_, _| 0.25f32).unwrap();
            let m = Affine2::translation(60.0, 60.0);
            let got = pe.features(flat.view(), &m).unwrap().to_vec();
            let want = reference_features(pe.patch(), 36, pool, kind);
            assert!(
                got.iter()
                    .zip(&want)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
        }
    }

    #[test]
    fn gradient_features_are_normalised() {
        let frame = texture(100, 100, 5);
        let cfg = PoseConfig {
            features: FeatureKind::Gradient,
            ..PoseConfig::default()
        };
        let mut pe = PoseEstimator::new(cfg, 30.0, 30.0).unwrap();
        assert_eq!(pe.feature_dim(), 2 * 12 * 12);
        let m = Affine2::translation(50.0, 50.0);
        let f = pe.features(frame.view(), &m).unwrap().to_vec();
        let norm: f64 = f.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-12 && f.iter().sum::<f64>().abs() < 1e-12);
        // Invariant to an affine change of illumination.
        let brighter = frame.map(|v| 2.0 * v + 0.3);
        let g = pe.features(brighter.view(), &m).unwrap();
        assert!(f.iter().zip(g).all(|(a, b)| (a - b).abs() < 1e-5));
    }

    #[test]
    fn tune_keeps_the_best_neighbour_and_bad_input_errors() {
        let frame = texture(120, 120, 3);
        let (tw, th) = (30.0, 30.0);
        let m_star = Affine2::translation(60.0, 60.0);
        let cfg = PoseConfig {
            pool: 4,
            ..PoseConfig::default()
        };
        let mut pe = PoseEstimator::new(cfg, tw, th).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
        pe.train(frame.view(), &m_star, 800, &mut rng).unwrap();
        let m = m_star
            .compose(&Affine2::exp(&AlgebraVector::new(0.03, 0.0, 0.05, 0.0, 1.5, -1.5)).unwrap());
        // Score: negative pose error (a stand-in for template similarity).
        let (best, s) = pe
            .tune(frame.view(), &m, 5, |p| Ok(-pose_error(p, &m_star, tw, th)))
            .unwrap();
        let e0 = pose_error(&m, &m_star, tw, th);
        println!("tune: {e0:.3} px -> {:.3} px", -s);
        assert!(-s <= e0 && pose_error(&best, &m_star, tw, th) == -s);
        assert!(-s < 0.6 * e0, "{e0} -> {}", -s);
        // A pose whose patch leaves the frame is a typed error.
        let outside = Affine2::translation(5.0, 60.0);
        assert!(matches!(
            pe.tune_step(frame.view(), &outside),
            Err(AffineError::Image(
                bayestrack_image::ImageError::PatchOutside { .. }
            ))
        ));
        // Bad configuration.
        let bad = PoseConfig {
            pool: 5,
            ..PoseConfig::default()
        };
        assert!(PoseEstimator::new(bad, tw, th).is_err());
        assert!(PoseEstimator::new(PoseConfig::default(), f64::NAN, th).is_err());
    }
}
