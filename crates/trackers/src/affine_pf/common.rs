//! What the paper-002 trackers share: configurations, the KF region, the
//! appearance core, the scored particles.

use bayestrack_affine::{
    Affine2, AffineError, AffineGroup, AlgebraVector, DisplacementPredictor, PoseConfig,
    PoseEstimator,
};
use bayestrack_appearance::{OnlineGaussian, TargetModel};
use bayestrack_image::{BBox, Border, Image, ImageError, ImageView, ImageViewMut, warp_into};
use bayestrack_particle::{ParticleSet, Resampling, stream_rng};
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::error::{Result, TrackerError};
use crate::tracker::{Estimate, Tracker};

/// When pose tuning has found a good enough particle (Algorithm 1 steps 2,
/// 4 and 5). Paper 002 writes the threshold both ways.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StopRule {
    /// Stop once a tuned particle's similarity exceeds `mu_T - sigma_T`
    /// (Algorithm 1, three times; section 2; SPEC). The default: about 84 %
    /// of target patches pass it if the TSD is Gaussian, so a frame where
    /// tuning reaches the target stops; the stricter rule is passed by
    /// about 16 % of target patches only, so most frames would run to
    /// `N_max`, which contradicts the paper's own account of stopping
    /// "in time" when a particle is close to the target.
    #[default]
    MuMinusSigma,
    /// Stop once it exceeds `mu_T + sigma_T` (section 1, once).
    MuPlusSigma,
}

impl StopRule {
    /// The threshold for a target similarity distribution.
    pub fn threshold(self, tsd: &OnlineGaussian) -> f64 {
        match self {
            StopRule::MuMinusSigma => tsd.mean() - tsd.std(),
            StopRule::MuPlusSigma => tsd.mean() + tsd.std(),
        }
    }
}

/// When the models (template, TSD/BSD, LWPR) learn from the frame's
/// estimate. Paper 002 writes the condition both ways.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpdateRule {
    /// Update when the final score exceeds `mu_B + sigma_B` (section 1;
    /// SPEC). The default: the estimate must look clearly unlike the
    /// background (about 84 % of background patches score below it), so a
    /// frame where the target was lost does not teach the template, the TSD
    /// and the pose estimator the background.
    #[default]
    MuBPlusSigma,
    /// Update when it exceeds `mu_B - sigma_B` (Algorithm 1 step 7): about
    /// 84 % of background patches pass this.
    MuBMinusSigma,
}

impl UpdateRule {
    /// The threshold for a background similarity distribution.
    pub fn threshold(self, bsd: &OnlineGaussian) -> f64 {
        match self {
            UpdateRule::MuBPlusSigma => bsd.mean() + bsd.std(),
            UpdateRule::MuBMinusSigma => bsd.mean() - bsd.std(),
        }
    }
}

/// Where the target similarity distribution (TSD) comes from. Paper 002
/// calls the TSD "the similarity distribution of target patches", "trained
/// online" and updated from `M*` (sec. 0-1), and leaves its initialisation
/// to ISPF's paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TsdInit {
    /// From [`AppearanceConfig::tsd_samples`] perturbations of `M_0` at
    /// start-up (half the pose estimator's training spread: about how close
    /// tuning brings a particle), then updated from each `M*` at
    /// `distribution_rate`. The default: a TSD exists from the first frame,
    /// which Algorithm 1 needs for its stop test in frame 1, and it is
    /// learnt from target patches (of the first frame).
    #[default]
    Perturbations,
    /// From the tracked patches: the start-up TSD serves only until two
    /// estimates `M*` have updated the models; from then the TSD is the
    /// sample distribution of the tracked estimates' scores (equal weights
    /// until `1 / distribution_rate` of them, then forgetting at
    /// `distribution_rate`).
    Tracked,
}

/// The observation, appearance model and pose estimator shared by the
/// three paper-002 trackers ([`HkpfTracker`](crate::HkpfTracker), [`IspfTracker`](crate::IspfTracker),
/// [`StpfTracker`](crate::StpfTracker); Xu, Gao and Yang 2015).
///
/// # Observation
/// Frames (gray or RGB) are converted to gray `f32` in `[0, 1]`. A pose
/// `M` (template coordinates centred on the initial box, `w x h` pixels,
/// to 0-based image coordinates; `M_0` = translation to the box centre) is
/// observed as the `patch_size x patch_size` patch `O(M)`
/// ([`bayestrack_affine::PoseEstimator::patch_map`]) and scored by
/// `S = max(0, NCC(O(M), template))`. A pose whose patch leaves the frame
/// or whose scale `sqrt(det A)` leaves `scale_range` is rejected (not
/// scored).
///
/// # Tuning a particle to its best neighbour (ISPF, STPF)
/// The pose estimator (LWPR) predicts the increment `Delta` from the
/// features of `O(M)` (the same warp gives the similarity of `M`); the step
/// `M' = M exp(Delta)` is kept if its similarity is higher, up to
/// `tune_steps` steps. A step is rejected, and tuning stops, when it does
/// not raise the similarity, when its patch leaves the frame, when its
/// scale leaves `scale_range`, or when `exp(Delta)` fails. The tuned
/// particle is the best pose seen (the rule of
/// [`bayestrack_affine::PoseEstimator::tune`]). Each step tried costs one
/// pose-estimator prediction and one similarity evaluation.
///
/// # Models and their update
/// Template: `O(M_0)`. TSD: similarities of `tsd_samples` perturbations
/// `M_0 exp(delta)`, `delta ~ N(0, (train_sigma / 2)^2)`. BSD:
/// similarities of the patches one box width / height away in 8 directions
/// (inside the frame; prior `N(0.3, 0.15)` when fewer than 2 fit). After a
/// frame whose final score passes `update_rule`: the template blends
/// towards `O(M*)` at `template_rate`, TSD absorbs the score, BSD the
/// scores of the 4 patches one box away from `M*`, and (ISPF, STPF) the
/// pose estimator trains on `training_per_update` perturbations of `M*`
/// (`initial_training` at `init`). An estimate scoring at or below
/// `mu_B + sigma_B` is reported lost.
#[derive(Debug, Clone, PartialEq)]
pub struct AppearanceConfig {
    /// Pose estimator; its `patch_size` (36, paper 002 sec. 3.1) is also
    /// the size of the template and of every observed patch.
    pub pose: PoseConfig,
    /// Most pose-estimator steps when tuning a particle (3; the paper does
    /// not say. One step of the estimator halves the pose error on the
    /// affine crate's test texture, so three steps take a particle within
    /// the estimator's accuracy from its training range).
    pub tune_steps: usize,
    /// Perturbations of `M_0` the pose estimator is first trained on (300).
    pub initial_training: usize,
    /// Perturbations of `M*` it is trained on at each model update (10).
    pub training_per_update: usize,
    /// Target patches that make the initial TSD (30).
    pub tsd_samples: usize,
    /// Where the TSD comes from ([`TsdInit`]; default the start-up
    /// perturbations).
    pub tsd_init: TsdInit,
    /// Forgetting rate of TSD and BSD (0.05: a time constant of 20 frames).
    pub distribution_rate: f64,
    /// Template blending rate at an update (0.1).
    pub template_rate: f64,
    /// The model-update condition.
    pub update_rule: UpdateRule,
    /// Allowed scale `sqrt(det A)` of a pose relative to the initial box
    /// (0.2 to 5): poses outside are rejected.
    pub scale_range: [f64; 2],
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            pose: PoseConfig::default(),
            tune_steps: 3,
            initial_training: 300,
            training_per_update: 10,
            tsd_samples: 30,
            tsd_init: TsdInit::Perturbations,
            distribution_rate: 0.05,
            template_rate: 0.1,
            update_rule: UpdateRule::default(),
            scale_range: [0.2, 5.0],
        }
    }
}

fn bad(name: &'static str, value: f64, reason: &'static str) -> TrackerError {
    TrackerError::InvalidParameter {
        name,
        value,
        reason,
    }
}

pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(name, v, "must be finite and > 0"))
    }
}

/// A particle count, checked: in `1..=65536`.
pub(crate) fn check_particles(name: &'static str, n: usize) -> Result<()> {
    if n == 0 || n > 1 << 16 {
        return Err(TrackerError::InvalidParameter {
            name,
            value: n as f64,
            reason: "must be in 1..=65536",
        });
    }
    Ok(())
}

pub(crate) fn check_non_negative(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(name, v, "must be finite and >= 0"))
    }
}

impl AppearanceConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let p = &self.pose;
        if p.patch_size < 4 || p.patch_size > 512 {
            return Err(bad(
                "pose.patch_size",
                p.patch_size as f64,
                "must be in 4..=512",
            ));
        }
        if p.pool == 0 || !p.patch_size.is_multiple_of(p.pool) {
            return Err(bad(
                "pose.pool",
                p.pool as f64,
                "must be >= 1 and divide patch_size",
            ));
        }
        for v in p.train_sigma.iter() {
            check_non_negative("pose.train_sigma", *v)?;
        }
        check_positive("pose.init_d", p.init_d)?;
        if !(p.w_gen > 0.0 && p.w_gen <= 1.0) {
            return Err(bad("pose.w_gen", p.w_gen, "must be in (0, 1]"));
        }
        check_non_negative("pose.cutoff", p.cutoff)?;
        if self.tune_steps > 100 {
            return Err(bad("tune_steps", self.tune_steps as f64, "must be <= 100"));
        }
        if self.tsd_samples < 2 {
            return Err(bad("tsd_samples", self.tsd_samples as f64, "must be >= 2"));
        }
        for (name, v) in [
            ("distribution_rate", self.distribution_rate),
            ("template_rate", self.template_rate),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                return Err(bad(name, v, "must be in (0, 1]"));
            }
        }
        let [lo, hi] = self.scale_range;
        check_positive("scale_range[0]", lo)?;
        if !(hi.is_finite() && hi > lo && lo <= 1.0 && hi >= 1.0) {
            return Err(bad(
                "scale_range[1]",
                hi,
                "need 0 < scale_range[0] <= 1 <= scale_range[1], finite",
            ));
        }
        Ok(())
    }
}

/// The coarse step shared by HKPF and the self-tuning filter: a Kalman
/// filter on `(x, y, vx, vy, ax, ay)` ([`DisplacementPredictor`]) predicts
/// the global displacement `d_k` and the local elliptical region.
///
/// The region is the predicted measurement covariance `S = P_xy + r^2 I`
/// (`P_xy` the predicted position covariance): the ellipse
/// `z^T S^-1 z <= gate` holds the target centre with the gate's
/// probability. A manoeuvre is detected when the last innovation fell
/// outside that gate (normalised innovation squared > `gate`, the
/// chi-square quantile with 2 degrees of freedom); the next region is then
/// widened to `manoeuvre_gain S`. Particles are drawn on the group by eq.
/// 4-5 with `Psi_k` = the region mapped into the body frame
/// (`A^-1 S A^-T`, `A` the linear part of `M_{k-1}`) for the translation
/// generators A5, A6, and `pose_sigma^2` on A1..A4.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionConfig {
    /// White-jerk spectral density `q` of the Kalman filter, px^2 per
    /// frame^5 (0.01: the acceleration wanders by 0.1 px/frame^2 a frame).
    pub q: f64,
    /// Measurement noise `r` of the estimate's centre, px (1.5).
    pub r: f64,
    /// Initial standard deviations of position, velocity and acceleration
    /// (1 px, 3 px/frame, 0.5 px/frame^2).
    pub sigma0: [f64; 3],
    /// Chi-square gate of the manoeuvre detection (9.21: the 99 % quantile
    /// with 2 degrees of freedom).
    pub gate: f64,
    /// Factor on the region covariance after a detected manoeuvre (9: three
    /// times the standard deviation).
    pub manoeuvre_gain: f64,
    /// Also adapt the region within the frame (false). Paper 002 only says
    /// the region is "adaptive to motion change" by "maneuver detection"
    /// (sec. 0-1), and its Fig. 2 feeds `M*` back to the Kalman filter at
    /// the end of the frame, so by default a manoeuvre detected from a
    /// frame's innovation widens the next frame's region. With `true` the
    /// frame that holds the jump also adapts: when the first particles of
    /// the frame (HKPF: the first half; the self-tuning filter: the first
    /// batch) all score at or below the lost threshold `mu_B + sigma_B`
    /// (none looks more like the target than the background: the target is
    /// not in the region), the region is widened by `manoeuvre_gain` for
    /// the rest of the frame.
    pub adapt_within_frame: bool,
}

impl Default for RegionConfig {
    fn default() -> Self {
        Self {
            q: 0.01,
            r: 1.5,
            sigma0: [1.0, 3.0, 0.5],
            gate: 9.21,
            manoeuvre_gain: 9.0,
            adapt_within_frame: false,
        }
    }
}

impl RegionConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        check_non_negative("region.q", self.q)?;
        check_positive("region.r", self.r)?;
        for s in self.sigma0 {
            check_positive("region.sigma0", s)?;
        }
        check_positive("region.gate", self.gate)?;
        if !(self.manoeuvre_gain.is_finite() && self.manoeuvre_gain >= 1.0) {
            return Err(bad(
                "region.manoeuvre_gain",
                self.manoeuvre_gain,
                "must be finite and >= 1",
            ));
        }
        Ok(())
    }
}

/// Standard deviations of the pose generators A1..A4 (scale, aspect,
/// rotation, skew), checked: positive, so that `Psi_k` is positive
/// definite.
pub(crate) fn check_pose_sigma(name: &'static str, s: &[f64; 4]) -> Result<()> {
    for v in s {
        check_positive(name, *v)?;
    }
    Ok(())
}

/// The Kalman filter and the manoeuvre flag of [`RegionConfig`].
#[derive(Debug, Clone)]
pub(crate) struct Region {
    cfg: RegionConfig,
    kf: DisplacementPredictor,
    manoeuvre: bool,
}

impl Region {
    pub(crate) fn new(cfg: RegionConfig, centre: Vector2<f64>) -> Result<Self> {
        Ok(Self {
            kf: DisplacementPredictor::new(centre, 1.0, cfg.q, cfg.r, cfg.sigma0)?,
            cfg,
            manoeuvre: false,
        })
    }

    /// Time update: `d_k` and `Psi_k` for particles around `m_prev`.
    pub(crate) fn predict(
        &mut self,
        m_prev: &Affine2,
        pose_sigma: &[f64; 4],
    ) -> Result<(Vector2<f64>, Matrix6<f64>)> {
        let d = self.kf.predict()?;
        let psi = self.psi(m_prev, pose_sigma, self.manoeuvre)?;
        Ok((d, psi))
    }

    /// Whether the region may still be widened within this frame
    /// ([`RegionConfig::adapt_within_frame`], and not widened already).
    pub(crate) fn can_widen(&self) -> bool {
        self.cfg.adapt_within_frame && !self.manoeuvre
    }

    /// The widened `Psi_k` of the current prediction (after
    /// [`Region::predict`]), for the rest of a frame whose first particles
    /// found nothing ([`RegionConfig::adapt_within_frame`]).
    pub(crate) fn widened(&self, m_prev: &Affine2, pose_sigma: &[f64; 4]) -> Result<Matrix6<f64>> {
        self.psi(m_prev, pose_sigma, true)
    }

    /// `Psi_k` of the predicted region, widened by `manoeuvre_gain` when
    /// `widen`.
    fn psi(&self, m_prev: &Affine2, pose_sigma: &[f64; 4], widen: bool) -> Result<Matrix6<f64>> {
        let r2 = self.cfg.r * self.cfg.r;
        let mut s = self.kf.position_covariance() + Matrix2::identity() * r2;
        if widen {
            s *= self.cfg.manoeuvre_gain;
        }
        let a = m_prev.linear();
        let a_inv = a.try_inverse().ok_or(AffineError::Singular {
            op: "region",
            det: m_prev.det(),
        })?;
        let t = a_inv * s * a_inv.transpose();
        let t = (t + t.transpose()) * 0.5;
        let mut psi = Matrix6::zeros();
        for (i, v) in pose_sigma.iter().enumerate() {
            psi[(i, i)] = v * v;
        }
        psi.fixed_view_mut::<2, 2>(4, 4).copy_from(&t);
        Ok(psi)
    }

    /// Restarts the Kalman filter at `centre` with zero velocity and
    /// acceleration and the initial covariance: called when no particle of
    /// a frame could be scored (every one left the frame or the scale
    /// range), so that there is no measurement. Coasting instead would
    /// carry the pose on by the predicted velocity and acceleration, out of
    /// the frame where no particle can be scored again (the pose then runs
    /// away quadratically; seen on the Dudek setting of the `affine`
    /// experiment, RMS in the thousands of pixels).
    pub(crate) fn restart(&mut self, centre: Vector2<f64>) -> Result<()> {
        *self = Self::new(self.cfg, centre)?;
        Ok(())
    }

    /// Measurement update with the estimate's centre; sets the manoeuvre
    /// flag for the next frame.
    pub(crate) fn update(&mut self, z: Option<Vector2<f64>>) -> Result<()> {
        let nis = self.kf.update(z)?;
        self.manoeuvre = nis.is_some_and(|n| n > self.cfg.gate);
        Ok(())
    }

    pub(crate) fn manoeuvre(&self) -> bool {
        self.manoeuvre
    }
}

/// What one frame cost and decided.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameStats {
    /// Particles drawn and scored (tuned, for ISPF and STPF).
    pub particles: usize,
    /// Similarity evaluations (patches compared with the template),
    /// including the background patches of the model update.
    pub evaluations: usize,
    /// Pose-estimator predictions (one per tuning step tried).
    pub pose_estimator_calls: usize,
    /// Batches of particles drawn (1 for HKPF).
    pub batches: usize,
    /// Similarity of the estimate `M*` (0 when no particle could be scored).
    pub best_similarity: f64,
    /// The stopping threshold of this frame (`f64::INFINITY` for HKPF,
    /// which does not stop early).
    pub stop_threshold: f64,
    /// Whether the models learnt from this frame.
    pub updated: bool,
    /// Whether this frame's region was widened by a detected manoeuvre.
    pub manoeuvre: bool,
}

/// What the paper-002 trackers ([`HkpfTracker`](crate::HkpfTracker), [`IspfTracker`](crate::IspfTracker),
/// [`StpfTracker`](crate::StpfTracker)) report beyond [`Tracker`]: the pose before the first
/// step, the cost of the last frame and its particles. The `affine`
/// experiment drives all three as `Box<dyn AffineTracker>`; the pose of
/// every frame is also in [`Estimate::pose`].
pub trait AffineTracker: Tracker {
    /// The current pose estimate `M*` (`None` before `init`; after `init`,
    /// `M_0`, the translation to the initial box's centre).
    fn pose(&self) -> Option<Affine2>;

    /// What the last frame cost.
    fn stats(&self) -> FrameStats;

    /// The particles of the last frame with their similarities (tuned, for
    /// ISPF and STPF).
    fn particles(&self) -> &[ScoredPose];

    /// The appearance model (`None` before `init`).
    fn model(&self) -> Option<&TargetModel>;
}

/// A scored particle: its pose and similarity (`f64::NEG_INFINITY` when it
/// could not be scored).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoredPose {
    /// The pose (after tuning, for the self-tuning filters).
    pub pose: Affine2,
    /// Its similarity to the template.
    pub similarity: f64,
}

/// Rows per tile of [`Core`]'s lazily converted gray frame.
const BAND: usize = 16;
/// Columns per tile of [`Core`]'s lazily converted gray frame.
const TILE: usize = 32;

/// State shared by the three trackers.
#[derive(Debug, Clone)]
pub(crate) struct Core {
    key: u64,
    seed: u64,
    cfg: AppearanceConfig,
    /// The frame as gray `f32`, converted lazily in tiles of [`BAND`]
    /// rows and [`TILE`] columns: only the tiles the frame's warps read
    /// ([`Core::ready_for`]).
    gray: Image<f32>,
    /// A copy of the frame the gray tiles are converted from.
    source: Image<u8>,
    /// Which tiles of `gray` hold the current frame (row-major: band by
    /// band, `width.div_ceil(TILE)` tiles a band).
    converted: Vec<bool>,
    /// Convert every frame whole as it arrives (the tests compare the lazy
    /// conversion with it).
    pub(crate) eager: bool,
    size: (f64, f64),
    pe: Option<PoseEstimator>,
    model: Option<TargetModel>,
    patch: Vec<f32>,
    bg: Vec<f64>,
    /// The scores of the tracked estimates that updated the models, while
    /// they make the TSD ([`TsdInit::Tracked`]).
    tracked: Vec<f64>,
    pub(crate) pose: Affine2,
    pub(crate) k: u64,
    pub(crate) stats: FrameStats,
    pub(crate) scored: Vec<ScoredPose>,
    /// The scored particles as the particle engine's weighted set (the
    /// pool the next batch's parents are drawn from).
    pool: Option<ParticleSet<Matrix3<f64>>>,
    ancestors: Vec<usize>,
}

impl Core {
    pub(crate) fn new(key: u64, seed: u64, cfg: AppearanceConfig) -> Result<Self> {
        cfg.validate()?;
        let ps = cfg.pose.patch_size;
        Ok(Self {
            key,
            seed,
            gray: Image::new(1, 1, 1, 0f32)?,
            source: Image::new(1, 1, 1, 0u8)?,
            converted: Vec::new(),
            eager: false,
            size: (0.0, 0.0),
            pe: None,
            model: None,
            patch: vec![0.0; ps * ps],
            bg: Vec::with_capacity(8),
            tracked: Vec::new(),
            pose: Affine2::identity(),
            k: 0,
            stats: FrameStats::default(),
            scored: Vec::new(),
            pool: None,
            ancestors: Vec::new(),
            cfg,
        })
    }

    pub(crate) fn model(&self) -> Option<&TargetModel> {
        self.model.as_ref()
    }

    /// The random stream of the current frame (then advances the frame
    /// counter).
    pub(crate) fn frame_rng(&mut self) -> Xoshiro256PlusPlus {
        let rng = stream_rng(&[self.key, self.seed, self.k]);
        self.k += 1;
        rng
    }

    /// Takes the frame (1 or 3 channels, checked by the shell): a copy to
    /// convert to gray `f32` in `[0, 1]` tile by tile, as the warps need
    /// pixels ([`Core::ready_for`], [`Core::ready_all`]). The affine
    /// trackers' warps read a few boxes' worth of the frame, so most of it
    /// is never converted; the conversion is pixel by pixel, so a converted
    /// tile holds the same values as converting the whole frame.
    fn load(&mut self, frame: &ImageView<'_, u8>) -> Result<()> {
        let (w, h, ch) = (frame.width(), frame.height(), frame.channels());
        if (self.gray.width(), self.gray.height()) != (w, h) {
            self.gray = Image::new(w, h, 1, 0f32)?;
        }
        if (
            self.source.width(),
            self.source.height(),
            self.source.channels(),
        ) != (w, h, ch)
        {
            self.source = Image::new(w, h, ch, 0u8)?;
        }
        for y in 0..h {
            self.source.row_mut(y).copy_from_slice(frame.row(y));
        }
        self.converted.clear();
        self.converted
            .resize(h.div_ceil(BAND) * w.div_ceil(TILE), false);
        Ok(())
    }

    /// Converts the tiles of columns `x0..=x1` and rows `y0..=y1`
    /// (clamped to the frame) that are not converted yet.
    fn ready_rect(&mut self, (x0, x1): (usize, usize), (y0, y1): (usize, usize)) -> Result<()> {
        let (w, h) = (self.gray.width(), self.gray.height());
        let (x1, y1) = (x1.min(w.saturating_sub(1)), y1.min(h.saturating_sub(1)));
        let tiles = w.div_ceil(TILE);
        for band in y0 / BAND..=y1 / BAND {
            for tile in (x0 / TILE..=x1 / TILE).take_while(|&t| t < tiles) {
                let i = band * tiles + tile;
                if self.converted.get(i) != Some(&false) {
                    continue;
                }
                let (x, y) = (tile * TILE, band * BAND);
                let rect = bayestrack_image::Rect::new(x, y, TILE.min(w - x), BAND.min(h - y));
                let src = self.source.view();
                let src = src.crop(rect)?;
                let mut gray = self.gray.view_mut();
                let mut out = gray.crop_mut(rect)?;
                bayestrack_image::to_gray_unit_into(src, &mut out)?;
                self.converted[i] = true;
            }
        }
        Ok(())
    }

    /// Converts every tile (before the pose estimator's initial training:
    /// its random perturbations may read anywhere).
    fn ready_all(&mut self) -> Result<()> {
        self.ready_rect((0, self.gray.width()), (0, self.gray.height()))
    }

    /// Converts the pixels a `ps x ps` warp through `map` reads: the
    /// corners' columns and rows (an affine map's extremes), widened by
    /// two for the bilinear neighbour and rounding; everything when a
    /// corner is not finite (the warp then fails on its own).
    fn ready_for(&mut self, map: &Affine2, ps: usize) -> Result<()> {
        let far = (ps.max(1) - 1) as f64;
        let corners =
            [(0.0, 0.0), (far, 0.0), (0.0, far), (far, far)].map(|(u, v)| map.apply(u, v));
        let range = |pick: fn(&(f64, f64)) -> f64| {
            corners
                .iter()
                .map(pick)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let ((xlo, xhi), (ylo, yhi)) = (range(|c| c.0), range(|c| c.1));
        if !(xlo.is_finite() && xhi.is_finite() && ylo.is_finite() && yhi.is_finite()) {
            return self.ready_all();
        }
        let span = |lo: f64, hi: f64, n: usize| {
            let n = n as f64;
            (
                (lo.floor() - 2.0).clamp(0.0, n) as usize,
                (hi.floor() + 2.0).clamp(0.0, n) as usize,
            )
        };
        let (w, h) = (self.gray.width(), self.gray.height());
        self.ready_rect(span(xlo, xhi, w), span(ylo, yhi, h))
    }

    /// Starts on a frame (checked, with a checked box, by the shell):
    /// converts it, builds the template,
    /// TSD, BSD and pose estimator (trained on `initial_training`
    /// perturbations when `train`). Returns the initial centre.
    pub(crate) fn init(
        &mut self,
        frame: &ImageView<'_, u8>,
        target: BBox,
        train: bool,
    ) -> Result<Vector2<f64>> {
        self.load(frame)?;
        self.ready_all()?;
        let (w, h) = (target.width, target.height);
        let (cx, cy) = target.center();
        let centre = Vector2::new(cx - 1.0, cy - 1.0);
        let m0 = Affine2::translation(centre[0], centre[1]);
        let mut pe = PoseEstimator::new(self.cfg.pose.clone(), w, h)?;
        let ps = self.cfg.pose.patch_size;
        // The template: the box may touch the border, where the outermost
        // patch samples fall half a pixel outside; replicate the edge.
        let mut template = Image::new(ps, ps, 1, 0f32)?;
        {
            let map = pe.patch_map(&m0)?;
            let mut out = template.view_mut();
            warp_into(self.gray.view(), &map, Border::Replicate, &mut out)?;
        }
        self.size = (w, h);
        self.pose = m0;
        self.k = 0;
        self.tracked.clear();
        let mut rng = stream_rng(&[self.key, self.seed, u64::MAX]);
        // Provisional model to score the TSD / BSD samples.
        let prior = OnlineGaussian::new(0.3, 0.15, self.cfg.distribution_rate)?;
        let tpl_model = TargetModel::new(template.clone(), prior, prior, self.cfg.template_rate)?;
        self.model = Some(tpl_model);
        self.pe = Some(pe.clone());
        let half = self.cfg.pose.train_sigma * 0.5;
        let mut target_scores = Vec::with_capacity(self.cfg.tsd_samples);
        for _ in 0..self.cfg.tsd_samples {
            let delta = gaussian(&half, &mut rng);
            let m = m0.compose(&Affine2::exp(&delta)?);
            if let Some(s) = self.score(&m)? {
                target_scores.push(s);
            }
        }
        if target_scores.len() < 2 {
            // Too close to the border for perturbed patches: the template
            // against itself.
            target_scores = vec![1.0, 0.9];
        }
        let mut background = Vec::with_capacity(8);
        for (i, j) in [
            (-1.0, -1.0),
            (0.0, -1.0),
            (1.0, -1.0),
            (-1.0, 0.0),
            (1.0, 0.0),
            (-1.0, 1.0),
            (0.0, 1.0),
            (1.0, 1.0),
        ] {
            let m = Affine2::translation(i * w, j * h).compose(&m0);
            if let Some(s) = self.score(&m)? {
                background.push(s);
            }
        }
        let rate = self.cfg.distribution_rate;
        let tsd = OnlineGaussian::from_samples(&target_scores, rate)?;
        let bsd = if background.len() >= 2 {
            OnlineGaussian::from_samples(&background, rate)?
        } else {
            prior
        };
        self.model = Some(TargetModel::new(
            template,
            tsd,
            bsd,
            self.cfg.template_rate,
        )?);
        if train && self.cfg.initial_training > 0 {
            pe.train(self.gray.view(), &m0, self.cfg.initial_training, &mut rng)?;
        }
        self.pe = Some(pe);
        self.stats = FrameStats::default();
        self.scored.clear();
        self.pool = None;
        Ok(centre)
    }

    /// Converts a later frame (checked by the shell); resets the frame's
    /// counters.
    pub(crate) fn begin(&mut self, frame: &ImageView<'_, u8>) -> Result<()> {
        self.load(frame)?;
        if self.eager {
            self.ready_all()?;
        }
        self.stats = FrameStats::default();
        self.scored.clear();
        self.pool = None;
        Ok(())
    }

    /// Whether the pose's scale is in range and its linear part invertible
    /// with positive determinant.
    fn valid(&self, m: &Affine2) -> bool {
        let det = m.det();
        if !(det.is_finite() && det > 0.0) {
            return false;
        }
        let s = det.sqrt();
        s >= self.cfg.scale_range[0] && s <= self.cfg.scale_range[1]
    }

    /// The similarity of pose `m`, or `None` when it is rejected (outside
    /// the frame or the scale range).
    pub(crate) fn score(&mut self, m: &Affine2) -> Result<Option<f64>> {
        if !self.valid(m) {
            return Ok(None);
        }
        let map = match &self.pe {
            Some(pe) => pe.patch_map(m)?,
            None => return Err(TrackerError::NotInitialised),
        };
        let ps = self.cfg.pose.patch_size;
        self.ready_for(&map, ps)?;
        let Some(model) = &self.model else {
            return Err(TrackerError::NotInitialised);
        };
        {
            let mut out = ImageViewMut::from_slice(&mut self.patch, ps, ps, 1, ps)?;
            match warp_into(self.gray.view(), &map, Border::Error, &mut out) {
                Ok(()) => {}
                Err(ImageError::PatchOutside { .. }) => return Ok(None),
                Err(e) => return Err(e.into()),
            }
        }
        let view = ImageView::from_slice(&self.patch, ps, ps, 1, ps)?;
        self.stats.evaluations += 1;
        Ok(Some(model.similarity(view)?))
    }

    /// One look through the pose estimator: the similarity of `m` and the
    /// predicted increment, or `None` when `m` is rejected.
    fn look(&mut self, m: &Affine2) -> Result<Option<(f64, AlgebraVector)>> {
        if !self.valid(m) {
            return Ok(None);
        }
        let map = match &self.pe {
            Some(pe) => pe.patch_map(m)?,
            None => return Err(TrackerError::NotInitialised),
        };
        self.ready_for(&map, self.cfg.pose.patch_size)?;
        let (pe, model) = match (&mut self.pe, &self.model) {
            (Some(p), Some(m)) => (p, m),
            _ => return Err(TrackerError::NotInitialised),
        };
        let delta = match pe.predict_increment(self.gray.view(), m) {
            Ok(d) => d,
            Err(AffineError::Image(ImageError::PatchOutside { .. })) => return Ok(None),
            Err(e) => return Err(e.into()),
        };
        self.stats.pose_estimator_calls += 1;
        self.stats.evaluations += 1;
        let ps = self.cfg.pose.patch_size;
        let view = ImageView::from_slice(pe.patch(), ps, ps, 1, ps)?;
        Ok(Some((model.similarity(view)?, delta)))
    }

    /// Tunes `m` to its best neighbour (see the module docs).
    pub(crate) fn tune(&mut self, m: &Affine2) -> Result<ScoredPose> {
        let Some((mut s, mut delta)) = self.look(m)? else {
            return Ok(ScoredPose {
                pose: *m,
                similarity: f64::NEG_INFINITY,
            });
        };
        let mut best = *m;
        for _ in 0..self.cfg.tune_steps {
            let Ok(e) = Affine2::exp(&delta) else { break };
            let next = best.compose(&e);
            match self.look(&next)? {
                Some((s2, d2)) if s2 > s => {
                    best = next;
                    s = s2;
                    delta = d2;
                }
                _ => break,
            }
        }
        Ok(ScoredPose {
            pose: best,
            similarity: s,
        })
    }

    /// The best scored particle (eq. 2), if any could be scored.
    pub(crate) fn best(&self) -> Option<ScoredPose> {
        self.scored
            .iter()
            .filter(|p| p.similarity.is_finite())
            .copied()
            .reduce(|a, b| if b.similarity > a.similarity { b } else { a })
    }

    /// Draws the `n` parents of the next batch among the frame's scored
    /// particles; false when no particle could be scored. The particles
    /// become a [`ParticleSet`] of their poses with log-weights
    /// `lambda (S_i - S_max)` (tempered likelihoods; a particle that could
    /// not be scored weighs zero), and the engine selects among them
    /// ([`ParticleSet::draw_ancestors`], multinomial); the parents are then
    /// [`Core::parent`]`(0..n)`.
    pub(crate) fn draw_parents<R: Rng + ?Sized>(
        &mut self,
        n: usize,
        lambda: f64,
        rng: &mut R,
    ) -> Result<bool> {
        let Some(best) = self.best() else {
            self.pool = None;
            return Ok(false);
        };
        let log_weights = self
            .scored
            .iter()
            .map(|p| {
                if p.similarity.is_finite() {
                    lambda * (p.similarity - best.similarity)
                } else {
                    f64::NEG_INFINITY
                }
            })
            .collect();
        // The set holds the poses as 3x3 matrices (finite, as the engine
        // checks); [`Core::parent`] reads them back exactly.
        let poses = self.scored.iter().map(|p| p.pose.matrix()).collect();
        let pool = self
            .pool
            .insert(ParticleSet::from_log_weights(poses, log_weights)?);
        self.ancestors.clear();
        self.ancestors.resize(n, 0);
        pool.draw_ancestors(&Resampling::Multinomial, rng, &mut self.ancestors)?;
        Ok(true)
    }

    /// Parent `i` of the batch [`Core::draw_parents`] last drew.
    pub(crate) fn parent(&self, i: usize) -> Option<Affine2> {
        let pool = self.pool.as_ref()?;
        Affine2::from_matrix(pool.particles()[*self.ancestors.get(i)?]).ok()
    }

    /// [`TsdInit::Tracked`]: the TSD becomes the sample distribution of the
    /// tracked estimates' scores once two have updated the models, until
    /// `1 / distribution_rate` of them (then the model's own forgetting
    /// update goes on alone).
    fn learn_tsd(&mut self, score: f64) -> Result<()> {
        let rate = self.cfg.distribution_rate;
        let window = (1.0 / rate).ceil() as usize;
        if self.cfg.tsd_init != TsdInit::Tracked || self.tracked.len() >= window {
            return Ok(());
        }
        self.tracked.push(score);
        if self.tracked.len() < 2 {
            return Ok(());
        }
        let tsd = OnlineGaussian::from_samples(&self.tracked, rate)?;
        let model = self.model.as_ref().ok_or(TrackerError::NotInitialised)?;
        self.model = Some(TargetModel::new(
            model.template().to_image(),
            tsd,
            *model.bsd(),
            self.cfg.template_rate,
        )?);
        Ok(())
    }

    /// Trains the pose estimator on `training_per_update` perturbations of
    /// `pose` ([`PoseEstimator::train`]'s draws): the perturbations first,
    /// so that only the rows their patches read are converted.
    fn train_at<R: Rng + ?Sized>(&mut self, pose: &Affine2, rng: &mut R) -> Result<()> {
        let pe = self.pe.as_ref().ok_or(TrackerError::NotInitialised)?;
        let poses = pe.training_poses(pose, self.cfg.training_per_update, rng)?;
        let maps = poses
            .iter()
            .map(|(_, m)| pe.patch_map(m))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        for map in &maps {
            self.ready_for(map, self.cfg.pose.patch_size)?;
        }
        let pe = self.pe.as_mut().ok_or(TrackerError::NotInitialised)?;
        pe.train_on(self.gray.view(), &poses)?;
        Ok(())
    }

    /// The end of a frame: adopts `m_star` (or keeps `fallback` when no
    /// particle could be scored), updates the models when the score passes
    /// the update rule, trains the pose estimator when `train`, and builds
    /// the estimate.
    pub(crate) fn finish<R: Rng + ?Sized>(
        &mut self,
        fallback: Affine2,
        train: bool,
        rng: &mut R,
    ) -> Result<Estimate> {
        let best = self.best();
        let model = self.model.as_ref().ok_or(TrackerError::NotInitialised)?;
        let lost_threshold = model.update_threshold();
        let update_threshold = self.cfg.update_rule.threshold(model.bsd());
        let (pose, score) = match best {
            Some(b) => (b.pose, b.similarity),
            None => (fallback, 0.0),
        };
        self.pose = pose;
        self.stats.best_similarity = score;
        if best.is_some() && score > update_threshold {
            // Background scores one box away from M*.
            let (w, h) = self.size;
            let a = pose.linear();
            self.bg.clear();
            for (i, j) in [(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)] {
                let shift = a * Vector2::new(i * w, j * h);
                let m = Affine2::translation(shift[0], shift[1]).compose(&pose);
                if let Some(s) = self.score(&m)? {
                    self.bg.push(s);
                }
            }
            // O(M*) into the scratch patch.
            if self.score(&pose)?.is_some() {
                let ps = self.cfg.pose.patch_size;
                let view = ImageView::from_slice(&self.patch, ps, ps, 1, ps)?;
                let model = self.model.as_mut().ok_or(TrackerError::NotInitialised)?;
                self.stats.updated = model.update_above(view, score, &self.bg, update_threshold)?;
                if self.stats.updated {
                    self.learn_tsd(score)?;
                }
            }
            if self.stats.updated && train && self.cfg.training_per_update > 0 {
                self.train_at(&pose, rng)?;
            }
        }
        let (w, h) = self.size;
        Ok(Estimate {
            bbox: pose.bounding_box(w, h)?,
            pose: Some(pose),
            particles: self.stats.particles,
            evaluations: self.stats.evaluations,
            lost: best.is_none() || score <= lost_threshold,
        })
    }
}

/// `delta ~ N(0, diag(sigma^2))`.
pub(crate) fn gaussian<R: Rng + ?Sized>(sigma: &AlgebraVector, rng: &mut R) -> AlgebraVector {
    let mut d = AlgebraVector::zeros();
    for (v, s) in d.iter_mut().zip(sigma.iter()) {
        let z: f64 = StandardNormal.sample(rng);
        *v = s * z;
    }
    d
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use bayestrack_image::BBox;
    use rand::SeedableRng;

    /// A textured frame whose content moves by `(0.9, 1.3) k` px in frame `k`.
    pub(crate) fn frame(k: usize) -> Image<u8> {
        let (dx, dy) = (0.9 * k as f64, 1.3 * k as f64);
        Image::from_fn(160, 120, |x, y| {
            let (u, v) = (x as f64 - dx, y as f64 - dy);
            let t = (u * 0.31).sin() * (v * 0.23).cos() + (0.11 * u + 0.17 * v).sin();
            (128.0 + 60.0 * t).round().clamp(0.0, 255.0) as u8
        })
        .unwrap()
    }

    /// Training on a new frame converts the rows its perturbations read
    /// first: the pose estimator (its whole LWPR model) learns exactly what
    /// it learns from the whole converted frame (nothing else of the frame
    /// is converted here, so a perturbation reading a stale row, the
    /// previous frame's, would change it).
    #[test]
    fn training_converts_the_rows_it_reads() {
        let (f0, f1) = (frame(0), frame(3));
        let target = BBox::new(60.0, 44.0, 36.0, 30.0);
        let cfg = AppearanceConfig {
            training_per_update: 30,
            ..AppearanceConfig::default()
        };
        let trained = |eager: bool| {
            let mut core = Core::new(1, 2, cfg.clone()).unwrap();
            core.eager = eager;
            core.init(&f0.view(), target, true).unwrap();
            core.begin(&f1.view()).unwrap();
            let pose = core.pose.compose(&Affine2::translation(2.7, 3.9));
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
            core.train_at(&pose, &mut rng).unwrap();
            // The whole model, every number printed to its last bit.
            format!("{:?}", core.pe.unwrap().model())
        };
        // (Compared as a whole: a failure would print two huge models.)
        assert!(trained(false) == trained(true), "the models differ");
    }
}
