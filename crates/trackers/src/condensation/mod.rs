//! CONDENSATION trackers with skin colour and interframe difference (Lee,
//! Jo and Kang 2005; CONDENSATION after Isard and Blake 1998).
//!
//! One step of [`Condensation`] (Lee, Jo and Kang 2005, sec. 2):
//!
//! 1. **select** (sec. 2.1): roulette-wheel selection from the cumulative
//!    weights, i.e. the multinomial resampler of `bayestrack-particle`,
//!    done adaptively: only when the effective particle size of eq. 16,
//!    `N_eff = 1 / sum pi_i^2`, shows the weights have degenerated. The
//!    paper gives the threshold "on pi" as `2/N` (point cloud) and `1.5/N`
//!    (contours); `sum pi_i^2` is the weight a particle drawn by weight
//!    carries on average (`1/N` when all are equal), so we read it as
//!    *select when `sum pi_i^2 > c / N`*, i.e. when `N_eff < N / c`
//!    (`c` = [`Condensation::pi_threshold`]). Sec. 5 also mentions
//!    resampling when `N_eff` is very *large*; with equal weights that only
//!    shuffles the set, so we do not.
//! 2. **predict** (sec. 2.2, eq. 5 and 10): deterministic drift plus
//!    stochastic diffusion, the second-order dynamics
//!    `X_t = A X_{t-1} + B v_t` on `X = [q_t, q_{t-1}]` with
//!
//!    ```text
//!    A = [ (1 + rho) I   -rho I ]      B = [ Sigma ]
//!        [      I          0    ]          [   0   ]
//!    ```
//!
//!    i.e. `q_t = q_{t-1} + rho (q_{t-1} - q_{t-2}) + Sigma v_t`,
//!    `v_t ~ N(0, I)`, `Sigma = diag(sigma_i)` the paper's diffusion
//!    deviations. `rho` ([`PointCloudConfig::velocity_damping`]) is our
//!    choice, 1/2 by default: `rho = 0` drops the previous state (a first
//!    order random walk, not the second-order model of eq. 10), and
//!    `rho = 1` (constant velocity) makes the velocity a random walk whose
//!    spread grows without bound between selections, because `B` injects
//!    the diffusion into the position and so into the next velocity;
//!    `rho = 1/2` keeps the velocity a stationary AR(1) process whose
//!    spread, `sigma / sqrt(1 - rho^2) = 1.15 sigma`, stays that of the
//!    diffusion, while still carrying half of the last displacement.
//! 3. **measure** (sec. 2.3-2.4, eq. 3, 6, 9, 11): each particle's weight
//!    is multiplied by its likelihood (the cues of [`CueSet`], through the
//!    `Cue` trait and the OR / AND `Fusion` of `bayestrack-appearance`, in
//!    the log domain), then normalised; a particle in an impossible
//!    configuration (its centre off the image, sec. 2.3) gets zero weight.
//!    The estimate is the weighted mean of eq. 4.
//!
//! Two representations: point clouds ([`PointCloudTracker`], sec. 3.1)
//! and deformable B-spline contours ([`ContourTracker`], sec. 3.2-3.3);
//! c-AVQ re-initialisation from the border stripes ([`CAvq`], sec. 4);
//! several objects by the priority-subtracted IFD ([`MultiCondensation`],
//! sec. 5).
//!
//! Randomness: frame `k` of a tracker seeded `s` draws from
//! `stream_rng([key, s, k])` (one stream per object in
//! [`MultiCondensation`]); the particles are processed in order on the
//! calling thread, so the output is the same bits on any thread and any
//! thread count.

mod avq;
mod contour;
mod multi;
mod points;

pub use avq::{CAvq, CAvqConfig};
pub use contour::{ContourConfig, ContourTracker, CurveCue, CurveCueKind};
pub use multi::{MultiCondensation, MultiConfig, ObjectConfig, ObjectEstimate};
pub use points::{PointCloudConfig, PointCloudTracker};

use bayestrack_appearance::{
    Candidate, Cue, DEFAULT_FLOOR, Frame, Fusion, FusionRule, Scratch, interframe_difference_into,
};
use bayestrack_image::{Affine2, BBox, Image, ImageView, rgb_to_gray_into};
use bayestrack_particle::{ParticleSet, Resampling};
use nalgebra::SVector;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::error::{Result, TrackerError};

/// A particle whose best log-likelihood is below this saw no evidence at
/// all: every cue score under it is at the log floor (`ln 1e-12`, about
/// -27.6) or within `e^-20` (2e-9) of zero. The tracker then reports the
/// target lost.
pub const LOST_LOG_LIKELIHOOD: f64 = -20.0;

/// Which cues weight the particles and how they are fused (Lee, Jo and
/// Kang 2005, sec. 2.4).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum CueSet {
    /// The interframe difference alone (eq. 7; eq. 9 with `lambda = 0`, the
    /// hand tracker of sec. 3.2). Works on gray frames.
    Ifd,
    /// The HSV skin colour alone (eq. 8). Needs RGB frames.
    Skin,
    /// Disjunctive fusion (OR, eq. 9): `w = IFD + lambda skin`.
    Or {
        /// The balancing coefficient `lambda` (the paper: `1/N`).
        lambda: f64,
    },
    /// Conjunctive fusion (AND, eq. 11): `w = IFD x lambda skin`. A
    /// constant `lambda` scales every weight alike, so it cancels in the
    /// normalisation; it is kept for the formula's sake.
    And {
        /// The balancing coefficient `lambda` (the paper: `1/N`).
        lambda: f64,
    },
}

impl CueSet {
    /// Whether the skin cue takes part (then frames must be RGB).
    pub fn uses_skin(self) -> bool {
        !matches!(self, CueSet::Ifd)
    }

    /// Short label: `ifd`, `skin`, `or`, `and`.
    pub fn label(self) -> &'static str {
        match self {
            CueSet::Ifd => "ifd",
            CueSet::Skin => "skin",
            CueSet::Or { .. } => "or",
            CueSet::And { .. } => "and",
        }
    }

    fn check(self) -> Result<()> {
        if let CueSet::Or { lambda } | CueSet::And { lambda } = self
            && !(lambda.is_finite() && lambda > 0.0)
        {
            return Err(TrackerError::InvalidParameter {
                name: "lambda",
                value: lambda,
                reason: "must be finite and positive (use CueSet::Ifd for lambda = 0)",
            });
        }
        Ok(())
    }

    /// The fused cue: `ifd` and `skin` combined by this rule.
    fn build(
        self,
        ifd: impl Cue + Send + Sync + 'static,
        skin: Option<impl Cue + Send + Sync + 'static>,
    ) -> Result<Box<dyn Cue + Send + Sync>> {
        let need = || TrackerError::InvalidParameter {
            name: "skin model",
            value: f64::NAN,
            reason: "the skin cue needs a skin model",
        };
        Ok(match self {
            CueSet::Ifd => Box::new(ifd),
            CueSet::Skin => Box::new(skin.ok_or_else(need)?),
            CueSet::Or { lambda } => Box::new(
                Fusion::new(FusionRule::Or)
                    .with(1.0, ifd)?
                    .with(lambda, skin.ok_or_else(need)?)?,
            ),
            CueSet::And { lambda } => Box::new(
                Fusion::new(FusionRule::And)
                    .with(1.0, ifd)?
                    .with(lambda, skin.ok_or_else(need)?)?,
            ),
        })
    }
}

/// CONDENSATION's selection rule (Lee, Jo and Kang 2005, sec. 2.1, eq. 12
/// and 16).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condensation {
    /// `c`: select when `sum pi_i^2 > c / N`, i.e. `N_eff < N / c` (2 for
    /// the point cloud, 1.5 for contours). `c = 1` selects only when the
    /// weights are unequal; a large `c` almost never selects.
    pub pi_threshold: f64,
    /// The selection scheme; the paper's roulette wheel is
    /// [`Resampling::Multinomial`].
    pub resampling: Resampling,
}

impl Condensation {
    /// Sec. 3.1: `2/N`, roulette wheel.
    pub const POINT_CLOUD: Self = Self {
        pi_threshold: 2.0,
        resampling: Resampling::Multinomial,
    };
    /// Sec. 3.2-3.3: `1.5/N`, roulette wheel.
    pub const CONTOURS: Self = Self {
        pi_threshold: 1.5,
        resampling: Resampling::Multinomial,
    };

    /// Checks the threshold.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] unless `pi_threshold >= 1` and finite.
    pub fn validate(&self) -> Result<()> {
        if !(self.pi_threshold.is_finite() && self.pi_threshold >= 1.0) {
            return Err(TrackerError::InvalidParameter {
                name: "pi_threshold",
                value: self.pi_threshold,
                reason: "must be finite and >= 1 (sum pi^2 is never below 1/N)",
            });
        }
        Ok(())
    }

    /// One select / predict / measure step on `set`: `predict` moves a
    /// particle (drift and diffusion), `measure` returns its
    /// log-likelihood (minus infinity for an impossible configuration).
    /// When every particle gets zero likelihood the measurement is ignored
    /// (the weights stay those after selection) and the report says so.
    /// Allocation-free once `buffers` have grown to `N`.
    ///
    /// # Errors
    /// Whatever `measure` returns; [`TrackerError::Particle`] for a NaN or
    /// `+inf` log-likelihood.
    pub fn step<T: Clone, R: Rng + ?Sized>(
        &self,
        set: &mut ParticleSet<T>,
        rng: &mut R,
        buffers: &mut StepBuffers,
        mut predict: impl FnMut(&mut T, &mut R),
        mut measure: impl FnMut(&T) -> Result<f64>,
    ) -> Result<CondensationReport> {
        let n = set.len();
        let ess_before = set.ess();
        // 1. select (roulette wheel), adaptively on eq. 16
        let resampled = ess_before * self.pi_threshold < n as f64;
        if resampled {
            set.resample(&self.resampling, rng, &mut buffers.ancestors)?;
        }
        // 2. predict, 3. measure
        let (particles, log_w) = set.parts_mut();
        buffers.log_likelihoods.clear();
        let mut best = f64::NEG_INFINITY;
        for p in particles.iter_mut() {
            predict(p, rng);
            let l = measure(p)?;
            if l.is_nan() || l == f64::INFINITY {
                return Err(bayestrack_particle::ParticleError::NonFiniteWeight {
                    index: buffers.log_likelihoods.len(),
                    value: l,
                }
                .into());
            }
            best = best.max(l);
            buffers.log_likelihoods.push(l);
        }
        let degenerate = best == f64::NEG_INFINITY;
        if !degenerate {
            for (lw, &l) in log_w.iter_mut().zip(&buffers.log_likelihoods) {
                *lw += l;
            }
            set.normalize()?;
        }
        Ok(CondensationReport {
            ess: set.ess(),
            resampled,
            evaluations: n,
            degenerate,
            best_log_likelihood: best,
        })
    }
}

/// Buffers reused from step to step by [`Condensation::step`].
#[derive(Debug, Clone, Default)]
pub struct StepBuffers {
    /// Ancestor indices drawn by the selection.
    pub ancestors: Vec<usize>,
    /// The log-likelihoods of the latest measurement.
    pub log_likelihoods: Vec<f64>,
}

/// What one [`Condensation::step`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CondensationReport {
    /// Effective particle size (eq. 16) after the measurement.
    pub ess: f64,
    /// Whether the set was selected (resampled) before predicting.
    pub resampled: bool,
    /// Likelihood evaluations (one per particle).
    pub evaluations: usize,
    /// Whether every particle got zero likelihood (measurement ignored).
    pub degenerate: bool,
    /// The largest log-likelihood of the step.
    pub best_log_likelihood: f64,
}

impl CondensationReport {
    /// Whether the step saw no evidence for the target anywhere
    /// ([`LOST_LOG_LIKELIHOOD`]).
    pub fn lost(&self) -> bool {
        self.best_log_likelihood < LOST_LOG_LIKELIHOOD
    }
}

/// One coordinate of eq. 10: `(q_t, q_{t-1})` from `(q_{t-1}, q_{t-2})`.
#[inline(always)]
fn second_order<R: Rng + ?Sized>(
    q: f64,
    q_prev: f64,
    rho: f64,
    sigma: f64,
    rng: &mut R,
) -> (f64, f64) {
    let v: f64 = StandardNormal.sample(rng);
    (q + rho * (q - q_prev) + sigma * v, q)
}

fn check_positive(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(TrackerError::InvalidParameter {
            name,
            value: v,
            reason: "must be finite and positive",
        })
    }
}

fn check_damping(rho: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&rho) {
        return Err(TrackerError::InvalidParameter {
            name: "velocity_damping",
            value: rho,
            reason: "must be in [0, 1]",
        });
    }
    Ok(())
}

fn check_particles(n: usize) -> Result<()> {
    if n == 0 {
        return Err(TrackerError::InvalidParameter {
            name: "particles",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    Ok(())
}

/// The planes kept from frame to frame: the previous frame's 8-bit luma
/// and the IFD map (eq. 7), computed once per frame over the whole image
/// on BT.601 luma rounded to 8 bits (`rgb_to_gray_into`, then
/// `interframe_difference_into` on the two gray planes: half the work of
/// differencing two RGB frames, and within 1/255 of the float-luma
/// difference). The c-AVQ stripes and the priority field of eq. 15 need the
/// whole map; the skin cue, which costs an HSV conversion per pixel, is
/// only evaluated at the particles' pixels.
#[derive(Debug, Clone)]
struct Planes {
    luma: Image<u8>,
    previous: Image<u8>,
    ifd: Image<f32>,
}

impl Planes {
    fn new() -> Result<Self> {
        Ok(Self {
            luma: Image::new(1, 1, 1, 0)?,
            previous: Image::new(1, 1, 1, 0)?,
            ifd: Image::new(1, 1, 1, 0.0)?,
        })
    }

    /// The 8-bit luma of `frame` into `out`.
    fn luma_into(frame: ImageView<'_, u8>, out: &mut Image<u8>) -> Result<()> {
        out.reshape(frame.width(), frame.height(), 1, 0)?;
        if frame.channels() == 3 {
            rgb_to_gray_into(frame, &mut out.view_mut())?;
        } else {
            frame.expect_channels("condensation", 1)?;
            for y in 0..frame.height() {
                out.row_mut(y).copy_from_slice(frame.row(y));
            }
        }
        Ok(())
    }

    fn start(&mut self, frame: ImageView<'_, u8>) -> Result<()> {
        Self::luma_into(frame, &mut self.previous)?;
        self.ifd.reshape(frame.width(), frame.height(), 1, 0.0)?;
        self.ifd.fill(0.0);
        Ok(())
    }

    /// `dP_t = |I_t - I_{t-1}|`, then remembers `I_t`.
    fn update(&mut self, frame: ImageView<'_, u8>) -> Result<()> {
        Self::luma_into(frame, &mut self.luma)?;
        interframe_difference_into(
            self.luma.view(),
            self.previous.view(),
            &mut self.ifd.view_mut(),
        )?;
        std::mem::swap(&mut self.luma, &mut self.previous);
        Ok(())
    }
}

/// Checks a frame's channels for a cue set.
fn check_channels(tracker: &'static str, cues: CueSet, frame: &ImageView<'_, u8>) -> Result<()> {
    let got = frame.channels();
    if cues.uses_skin() && got != 3 {
        return Err(TrackerError::Channels {
            tracker,
            expected: "3 (RGB: the skin cue needs colour; use CueSet::Ifd for gray video)",
            got,
        });
    }
    if got != 1 && got != 3 {
        return Err(TrackerError::Channels {
            tracker,
            expected: "1 or 3",
            got,
        });
    }
    Ok(())
}

/// The planes the cues read for one frame.
fn frame_planes<'a>(frame: ImageView<'a, u8>, ifd: ImageView<'a, f32>) -> Frame<'a> {
    let f = Frame::new().with_ifd(ifd);
    if frame.channels() == 3 {
        f.with_rgb(frame)
    } else {
        f.with_gray(frame)
    }
}

/// The outcome of one object's step.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ObjectStep {
    /// The weighted-mean centre (eq. 4), 0-based pixels.
    centre: (f64, f64),
    /// The box (OTB convention).
    bbox: BBox,
    /// The mean pose (contours).
    pose: Option<Affine2>,
    /// The filter step.
    report: CondensationReport,
}

/// A particle set with its cue and buffers: the part of a tracker that is
/// one object.
struct Engine<const D: usize> {
    set: ParticleSet<SVector<f64, D>>,
    cue: Box<dyn Cue + Send + Sync>,
    buffers: StepBuffers,
    scratch: Scratch,
}

impl<const D: usize> std::fmt::Debug for Engine<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Engine")
            .field("particles", &self.set.len())
            .field("cue", &self.cue.name())
            .finish()
    }
}

impl<const D: usize> Engine<D> {
    fn new(particles: Vec<SVector<f64, D>>, cue: Box<dyn Cue + Send + Sync>) -> Result<Self> {
        Ok(Self {
            set: ParticleSet::new(particles)?,
            cue,
            buffers: StepBuffers::default(),
            scratch: Scratch::new(),
        })
    }

    /// One CONDENSATION step with `predict` and the candidate each state
    /// is scored as (`None`: impossible, zero likelihood).
    fn step<R: Rng + ?Sized>(
        &mut self,
        condensation: &Condensation,
        frame: &Frame<'_>,
        rng: &mut R,
        predict: impl FnMut(&mut SVector<f64, D>, &mut R),
        candidate: impl Fn(&SVector<f64, D>) -> Option<Candidate>,
    ) -> Result<CondensationReport> {
        let Self {
            set,
            cue,
            buffers,
            scratch,
        } = self;
        condensation.step(set, rng, buffers, predict, |s| match candidate(s) {
            Some(c) => Ok(cue.log_likelihood_or_zero(frame, &c, scratch)?),
            None => Ok(f64::NEG_INFINITY),
        })
    }

    /// The weighted mean (eq. 4).
    fn mean(&self) -> SVector<f64, D> {
        self.set.mean()
    }

    /// Moves every particle (and its previous position) by `(dx, dy)`:
    /// the c-AVQ shift of the set's mean.
    fn shift(&mut self, dx: f64, dy: f64) {
        let half = D / 2;
        let (particles, _) = self.set.parts_mut();
        for p in particles {
            p[0] += dx;
            p[1] += dy;
            p[half] += dx;
            p[half + 1] += dy;
        }
    }
}

/// One tracked object in either representation.
#[derive(Debug)]
enum ObjectFilter {
    Points(points::PointModel, Engine<4>),
    Contour(Box<contour::ContourModel>, Engine<8>),
}

impl ObjectFilter {
    fn step<R: Rng + ?Sized>(&mut self, frame: &Frame<'_>, rng: &mut R) -> Result<ObjectStep> {
        match self {
            ObjectFilter::Points(model, engine) => model.step(engine, frame, rng),
            ObjectFilter::Contour(model, engine) => model.step(engine, frame, rng),
        }
    }

    fn centre(&self) -> (f64, f64) {
        let (x, y) = match self {
            ObjectFilter::Points(_, e) => {
                let m = e.mean();
                (m[0], m[1])
            }
            ObjectFilter::Contour(_, e) => {
                let m = e.mean();
                (m[0], m[1])
            }
        };
        (x, y)
    }

    fn shift(&mut self, dx: f64, dy: f64) {
        match self {
            ObjectFilter::Points(_, e) => e.shift(dx, dy),
            ObjectFilter::Contour(_, e) => e.shift(dx, dy),
        }
    }

    fn len(&self) -> usize {
        match self {
            ObjectFilter::Points(_, e) => e.set.len(),
            ObjectFilter::Contour(_, e) => e.set.len(),
        }
    }
}

/// The default log floor of the cues.
const FLOOR: f64 = DEFAULT_FLOOR;

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_particle::stream_rng;

    #[test]
    fn condensation_selects_on_the_pi_threshold_and_weights_by_the_likelihood() {
        // Four particles on a line, the likelihood peaks at 2.
        let mut set = ParticleSet::new(vec![0.0f64, 1.0, 2.0, 3.0]).unwrap();
        let mut rng = stream_rng(&[1]);
        let mut buffers = StepBuffers::default();
        let c = Condensation::POINT_CLOUD;
        let r = c
            .step(
                &mut set,
                &mut rng,
                &mut buffers,
                |_, _| {},
                |&x| Ok(-2.0 * (x - 2.0f64).powi(2)),
            )
            .unwrap();
        assert!(!r.resampled, "equal weights are not selected");
        let w = set.weights();
        let z: f64 = [8.0f64, 2.0, 0.0, 2.0].iter().map(|d| (-d).exp()).sum();
        assert!((w[2] - 1.0 / z).abs() < 1e-12);
        assert!((r.ess - 1.0 / w.iter().map(|v| v * v).sum::<f64>()).abs() < 1e-9);
        // N_eff = 1.56 < 4 / 2: the next step selects.
        assert!(r.ess < 2.0);
        let r2 = c
            .step(&mut set, &mut rng, &mut buffers, |_, _| {}, |_| Ok(0.0))
            .unwrap();
        assert!(r2.resampled);
        assert!((r2.ess - 4.0).abs() < 1e-9);
        // Zero likelihood everywhere: the measurement is ignored.
        let before = set.weights();
        let r3 = c
            .step(
                &mut set,
                &mut rng,
                &mut buffers,
                |_, _| {},
                |_| Ok(f64::NEG_INFINITY),
            )
            .unwrap();
        assert!(r3.degenerate && r3.lost());
        assert_eq!(set.weights(), before);
        assert!(
            c.step(
                &mut set,
                &mut rng,
                &mut buffers,
                |_, _| {},
                |_| Ok(f64::NAN)
            )
            .is_err()
        );
        assert!(
            Condensation {
                pi_threshold: 0.5,
                ..c
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn second_order_dynamics_is_eq_10() {
        // With sigma = 0 the drift is q + rho (q - q_prev).
        let mut rng = stream_rng(&[2]);
        assert_eq!(second_order(10.0, 6.0, 0.5, 0.0, &mut rng), (12.0, 10.0));
        assert_eq!(second_order(10.0, 6.0, 1.0, 0.0, &mut rng), (14.0, 10.0));
        // The diffusion has the given spread.
        let n = 20_000;
        let s: f64 = (0..n)
            .map(|_| second_order(0.0, 0.0, 0.5, 30.0, &mut rng).0.powi(2))
            .sum::<f64>()
            / n as f64;
        assert!((s.sqrt() - 30.0).abs() < 0.6, "{}", s.sqrt());
    }
}
