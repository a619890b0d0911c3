//! What the CONDENSATION trackers share: the cue sets, the filter's
//! configuration, one object's particle filter and the checks.

use bayestrack_appearance::{Cue, DEFAULT_FLOOR, Frame, Fusion, FusionRule, IfdCue, SkinCue};
use bayestrack_image::{Affine2, BBox, ImageView};
use bayestrack_particle::{
    Degenerate, ParticleFilter, ResamplePolicy, ResampleTiming, Resampling, StepReport,
};
use nalgebra::SVector;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::avq::CAvq;
use crate::engine::{CueFilter, StateModel};
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, Needs};
use crate::tracker::Estimate;

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
    /// Disjunctive fusion over the *subtracted pixels* only (a reading of
    /// eq. 9, whose sum runs over "the particle's point `(x_P, y_P) in
    /// dP_i` of both the subtracted pixel and the associated skin-colour
    /// point"): a pixel of the particle's support counts when its IFD
    /// exceeds `threshold`, and then adds `IFD + lambda skin`; the weight
    /// is that sum over the support's size. Point clouds only (the paper
    /// uses eq. 9 with points, sec. 3.1); a contour refuses it.
    OrSubtracted {
        /// The balancing coefficient `lambda` (the paper: `1/N`; 0 is the
        /// thresholded IFD alone, eq. 9 with sec. 3.2's `lambda = 0`).
        lambda: f64,
        /// The IFD level (in `[0, 1]` grey) above which a pixel is
        /// "subtracted".
        threshold: f64,
    },
    /// Disjunctive fusion with each cue *normalised over the particle set*
    /// before the sum (a reading of eq. 9 that puts the two cues on one
    /// scale before `lambda` balances them): each particle `i` inside the
    /// frame gets its window's IFD score `a_i` and skin score `b_i` (each
    /// the window mean plus the cues' floor, [`DEFAULT_FLOOR`], so never
    /// zero), and weighs `a_i / mean_j a_j + lambda b_i / mean_j b_j`, the
    /// means over the particles inside the frame after the prediction. A
    /// cue that is zero everywhere thus adds the same to every particle. A
    /// particle off the frame weighs zero. Point clouds only (a contour
    /// refuses it).
    OrNormalised {
        /// The balancing coefficient `lambda` (the paper: `1/N`).
        lambda: f64,
    },
}

impl CueSet {
    /// Whether the skin cue takes part (then frames must be RGB).
    pub fn uses_skin(self) -> bool {
        !matches!(self, CueSet::Ifd)
    }

    /// Short label: `ifd`, `skin`, `or`, `and`, `or-subtracted`,
    /// `or-normalised`.
    pub fn label(self) -> &'static str {
        match self {
            CueSet::Ifd => "ifd",
            CueSet::Skin => "skin",
            CueSet::Or { .. } => "or",
            CueSet::And { .. } => "and",
            CueSet::OrSubtracted { .. } => "or-subtracted",
            CueSet::OrNormalised { .. } => "or-normalised",
        }
    }

    pub(super) fn check(self) -> Result<()> {
        if let CueSet::OrSubtracted { lambda, .. } = self
            && !(lambda.is_finite() && lambda >= 0.0)
        {
            return Err(TrackerError::InvalidParameter {
                name: "lambda",
                value: lambda,
                reason: "must be finite and non-negative (0: the thresholded IFD alone)",
            });
        }
        if let CueSet::Or { lambda } | CueSet::And { lambda } | CueSet::OrNormalised { lambda } =
            self
            && !(lambda.is_finite() && lambda > 0.0)
        {
            return Err(TrackerError::InvalidParameter {
                name: "lambda",
                value: lambda,
                reason: "must be finite and positive (use CueSet::Ifd for lambda = 0)",
            });
        }
        if let CueSet::OrSubtracted { threshold, .. } = self
            && !(threshold.is_finite() && (0.0..1.0).contains(&threshold))
        {
            return Err(TrackerError::InvalidParameter {
                name: "threshold",
                value: threshold,
                reason: "the subtracted-pixel IFD level must be in [0, 1)",
            });
        }
        Ok(())
    }

    /// The fused cue: `ifd` and `skin` combined by this rule.
    pub(super) fn build(
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
            CueSet::OrSubtracted { .. } => {
                return Err(TrackerError::InvalidParameter {
                    name: "cues",
                    value: f64::NAN,
                    reason: "OR over the subtracted pixels weighs point-cloud windows only",
                });
            }
            CueSet::OrNormalised { .. } => {
                return Err(TrackerError::InvalidParameter {
                    name: "cues",
                    value: f64::NAN,
                    reason: "OR with the cues normalised over the set weighs point clouds only",
                });
            }
        })
    }
}

/// [`CueSet::OrSubtracted`] on a point's support window: the mean over the
/// window of `[dP > threshold] (dP + lambda C)`, as `ln(mean + floor)`.
#[derive(Debug, Clone, Copy)]
pub(super) struct SubtractedOr {
    pub(super) skin: bayestrack_appearance::SkinModel,
    pub(super) lambda: f64,
    pub(super) threshold: f32,
}

impl Cue for SubtractedOr {
    fn name(&self) -> &'static str {
        "or-subtracted"
    }

    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &bayestrack_appearance::Candidate,
        _scratch: &mut bayestrack_appearance::Scratch,
    ) -> bayestrack_appearance::Result<f64> {
        use bayestrack_appearance::{AppearanceError, Candidate};
        let Candidate::Window(r) = candidate else {
            return Err(AppearanceError::InvalidParameter {
                name: "candidate",
                value: "pose".to_string(),
                reason: "OR over the subtracted pixels scores windows",
            });
        };
        let ifd = frame.ifd.ok_or(AppearanceError::MissingPlane {
            cue: "or-subtracted",
            plane: "ifd",
        })?;
        let rgb = frame.rgb.ok_or(AppearanceError::MissingPlane {
            cue: "or-subtracted",
            plane: "rgb",
        })?;
        ifd.expect_channels("or-subtracted", 1)?;
        rgb.expect_channels("or-subtracted", 3)?;
        if r.right() > ifd.width()
            || r.bottom() > ifd.height()
            || (ifd.width(), ifd.height()) != (rgb.width(), rgb.height())
            || r.area() == 0
        {
            return Err(AppearanceError::InvalidParameter {
                name: "window",
                value: format!("{r:?}"),
                reason: "must be non-empty and inside the IFD and RGB planes",
            });
        }
        let mut s = 0f64;
        for y in r.y..r.bottom() {
            let d = &ifd.row(y)[r.x..r.right()];
            let c = &rgb.row(y)[3 * r.x..3 * r.right()];
            for (&v, p) in d.iter().zip(c.chunks_exact(3)) {
                if v > self.threshold {
                    let skin = self
                        .skin
                        .score_rgb(bayestrack_image::Rgb::new(p[0], p[1], p[2]));
                    s += f64::from(v) + self.lambda * f64::from(skin);
                }
            }
        }
        let mean = s / r.area() as f64;
        if !mean.is_finite() {
            return Err(AppearanceError::NonFinite { what: "IFD plane" });
        }
        Ok((mean + FLOOR).ln())
    }
}

/// A cue that weighs every candidate alike (log-likelihood 0): the
/// engine's step with it selects and predicts and leaves the weights to
/// [`NormalisedOr`].
#[derive(Debug, Clone, Copy)]
pub(super) struct Flat;

impl Cue for Flat {
    fn name(&self) -> &'static str {
        "flat"
    }

    fn log_likelihood(
        &self,
        _frame: &Frame<'_>,
        _candidate: &bayestrack_appearance::Candidate,
        _scratch: &mut bayestrack_appearance::Scratch,
    ) -> bayestrack_appearance::Result<f64> {
        Ok(0.0)
    }
}

/// [`CueSet::OrNormalised`]: the two cues of eq. 9, each normalised over
/// the predicted set before the sum.
#[derive(Debug, Clone, Copy)]
pub(super) struct NormalisedOr {
    pub(super) ifd: IfdCue,
    pub(super) skin: SkinCue,
    pub(super) lambda: f64,
}

impl NormalisedOr {
    /// Weighs the predicted set of `filter` on `frame`: the log increment
    /// `ln(a_i / mean a + lambda b_i / mean b)` of every particle inside
    /// the frame (`-inf` off it). Returns the effective sample size after
    /// and the best raw eq. 9 log score, `max ln(a_i + lambda b_i)` (the
    /// evidence the lost test reads; the normalised scores average 1 by
    /// construction and say nothing about it).
    pub(super) fn weigh<M: StateModel<D>, const D: usize>(
        &self,
        model: &M,
        filter: &mut CueFilter<D>,
        frame: &Frame<'_>,
    ) -> Result<(f64, f64)> {
        let mut scratch = bayestrack_appearance::Scratch::default();
        let mut scores = Vec::with_capacity(filter.len());
        for x in filter.set().particles() {
            scores.push(match model.candidate(x) {
                Some(c) => {
                    let a = self.ifd.log_likelihood_or_zero(frame, &c, &mut scratch)?;
                    let b = self.skin.log_likelihood_or_zero(frame, &c, &mut scratch)?;
                    Some((a.exp(), b.exp()))
                }
                None => None,
            });
        }
        let inside: Vec<(f64, f64)> = scores
            .iter()
            .flatten()
            .copied()
            .filter(|(a, b)| *a > 0.0 && *b > 0.0)
            .collect();
        if inside.is_empty() {
            return Ok((filter.set().ess(), f64::NEG_INFINITY));
        }
        let k = inside.len() as f64;
        let mean_a = inside.iter().map(|p| p.0).sum::<f64>() / k;
        let mean_b = inside.iter().map(|p| p.1).sum::<f64>() / k;
        if !(mean_a.is_finite() && mean_b.is_finite()) {
            return Err(TrackerError::InvalidParameter {
                name: "cue scores",
                value: mean_a + mean_b,
                reason: "the IFD and skin scores must be finite",
            });
        }
        let mut best = f64::NEG_INFINITY;
        let increments: Vec<f64> = scores
            .iter()
            .map(|s| match s {
                Some((a, b)) if *a > 0.0 && *b > 0.0 => {
                    best = best.max((a + self.lambda * b).ln());
                    (a / mean_a + self.lambda * b / mean_b).ln()
                }
                _ => f64::NEG_INFINITY,
            })
            .collect();
        let ess = filter.reweigh(&increments)?;
        Ok((ess, best))
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

    /// The particle filter this is: the engine of `bayestrack-particle`
    /// selecting at the start of a step ([`ResampleTiming::BeforeProposal`])
    /// when `N_eff < N / c` ([`ResamplePolicy::Ess`] with `1 / c`), with
    /// [`Condensation::resampling`], and ignoring a measurement in which
    /// every particle has zero likelihood ([`Degenerate::IgnoreMeasurement`]:
    /// the weights stay those after selection).
    pub fn filter(&self) -> ParticleFilter {
        ParticleFilter {
            resampling: self.resampling,
            policy: ResamplePolicy::Ess(1.0 / self.pi_threshold),
            timing: ResampleTiming::BeforeProposal,
            degenerate: Degenerate::IgnoreMeasurement,
            ..ParticleFilter::default()
        }
    }
}

/// What one CONDENSATION step of an object did.
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
    /// The report of an engine step over `n` particles.
    pub(super) fn new<const D: usize>(step: &StepReport<D>, n: usize) -> Self {
        Self {
            ess: step.ess,
            resampled: step.resampled,
            evaluations: n,
            degenerate: step.degenerate,
            best_log_likelihood: step.max_log_increment,
        }
    }

    /// Whether the step saw no evidence for the target anywhere
    /// ([`LOST_LOG_LIKELIHOOD`]).
    pub fn lost(&self) -> bool {
        self.best_log_likelihood < LOST_LOG_LIKELIHOOD
    }
}

/// One coordinate of eq. 10: `(q_t, q_{t-1})` from `(q_{t-1}, q_{t-2})`.
#[inline(always)]
pub(super) fn second_order<R: Rng + ?Sized>(
    q: f64,
    q_prev: f64,
    rho: f64,
    sigma: f64,
    rng: &mut R,
) -> (f64, f64) {
    let v: f64 = StandardNormal.sample(rng);
    (q + rho * (q - q_prev) + sigma * v, q)
}

pub(super) fn check_positive(name: &'static str, v: f64) -> Result<f64> {
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

pub(super) fn check_damping(rho: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&rho) {
        return Err(TrackerError::InvalidParameter {
            name: "velocity_damping",
            value: rho,
            reason: "must be in [0, 1]",
        });
    }
    Ok(())
}

pub(super) fn check_particles(n: usize) -> Result<()> {
    if n == 0 {
        return Err(TrackerError::InvalidParameter {
            name: "particles",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    Ok(())
}

/// The planes CONDENSATION reads, built by the shell once per frame: the
/// input (RGB for the skin cue) and the IFD map (eq. 7), computed over the
/// whole image on BT.601 luma rounded to 8 bits (half the work of
/// differencing two RGB frames, and within 1/255 of the float-luma
/// difference). The c-AVQ stripes and the priority field of eq. 15 need the
/// whole map; the skin cue, which costs an HSV conversion per pixel, is
/// only evaluated at the particles' pixels.
pub(super) const NEEDS: Needs = Needs {
    gray: false,
    hsv: false,
    ifd: true,
};

/// The frames a cue set accepts: the skin cue needs colour.
pub(super) fn channel_policy(cues: CueSet) -> ChannelPolicy {
    if cues.uses_skin() {
        ChannelPolicy::Rgb("3 (RGB: the skin cue needs colour; use CueSet::Ifd for gray video)")
    } else {
        ChannelPolicy::GrayOrRgb
    }
}

/// The outcome of one object's step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ObjectStep {
    /// The weighted-mean centre (eq. 4), 0-based pixels.
    pub(super) centre: (f64, f64),
    /// The box (OTB convention).
    pub(super) bbox: BBox,
    /// The mean pose (contours).
    pub(super) pose: Option<Affine2>,
    /// The filter step.
    pub(super) report: CondensationReport,
}

impl ObjectStep {
    /// The tracker's estimate of a set of `particles`.
    pub(super) fn estimate(&self, particles: usize) -> Estimate {
        Estimate {
            bbox: self.bbox,
            pose: self.pose,
            particles,
            evaluations: self.report.evaluations,
            lost: self.report.lost(),
        }
    }
}

/// One object: its model (dynamics and candidates), its cue and the
/// engine's filter ([`CueFilter`]: the particle set, the keyed random
/// streams and the cue's scratch).
pub(super) struct Object<M, const D: usize> {
    pub(super) model: M,
    pub(super) cue: Box<dyn Cue + Send + Sync>,
    pub(super) filter: CueFilter<D>,
    /// Set for [`CueSet::OrNormalised`]: the step predicts with [`Flat`]
    /// and this weighs the whole set (`cue` is then unused).
    pub(super) normalised: Option<NormalisedOr>,
}

impl<M, const D: usize> std::fmt::Debug for Object<M, D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Object")
            .field("particles", &self.filter.len())
            .field("cue", &self.cue.name())
            .field("k", &self.filter.set().k())
            .finish()
    }
}

impl<M: StateModel<D>, const D: usize> Object<M, D> {
    /// The weighted-mean position `(x, y)` (the state's first two
    /// components).
    pub(super) fn centre(&self) -> (f64, f64) {
        let m = self.mean();
        (m[0], m[1])
    }

    /// Particles in the set.
    pub(super) fn len(&self) -> usize {
        self.filter.len()
    }

    /// An object of `particles` (equally weighted) filtered by
    /// `condensation`, its random streams keyed by `seed`.
    pub(super) fn new(
        model: M,
        cue: Box<dyn Cue + Send + Sync>,
        condensation: &Condensation,
        particles: Vec<SVector<f64, D>>,
        seed: u64,
    ) -> Result<Self> {
        Ok(Self {
            model,
            cue,
            filter: CueFilter::new(condensation.filter(), particles, seed)?,
            normalised: None,
        })
    }

    /// One select / predict / measure step of the engine.
    pub(super) fn step(&mut self, frame: &Frame<'_>) -> Result<CondensationReport> {
        let Some(normalised) = self.normalised else {
            let report = self.filter.step(&self.model, &*self.cue, frame)?;
            return Ok(CondensationReport::new(&report, self.filter.len()));
        };
        let step = self.filter.step(&self.model, &Flat, frame)?;
        let mut report = CondensationReport::new(&step, self.filter.len());
        if !step.degenerate {
            let (ess, best) = normalised.weigh(&self.model, &mut self.filter, frame)?;
            report.ess = ess;
            report.best_log_likelihood = best;
        }
        Ok(report)
    }

    /// The weighted mean (eq. 4).
    pub(super) fn mean(&self) -> SVector<f64, D> {
        self.filter.mean()
    }

    /// c-AVQ (sec. 4): when `avq` finds a stripe of motion away from the
    /// set on this frame's `ifd`, moves the set there; returns whether it
    /// did.
    pub(super) fn reinitialise(&mut self, avq: Option<&mut CAvq>, ifd: ImageView<'_, f32>) -> bool {
        match avq.and_then(|a| a.reinitialise(ifd, self.centre())) {
            Some((dx, dy)) => {
                self.shift(dx, dy);
                true
            }
            None => false,
        }
    }

    /// Moves every particle (and its previous position) by `(dx, dy)`:
    /// the c-AVQ shift of the set's mean.
    pub(super) fn shift(&mut self, dx: f64, dy: f64) {
        let half = D / 2;
        self.filter.move_states(|p| {
            p[0] += dx;
            p[1] += dy;
            p[half] += dx;
            p[half + 1] += dy;
        });
    }
}

/// The default log floor of the cues.
pub(super) const FLOOR: f64 = DEFAULT_FLOOR;

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_particle::{ParticleSet, stream_rng};

    /// A proposal that keeps the particle and weighs it by `f`.
    struct Stay<F>(F);

    impl<F: Fn(f64) -> f64 + Sync> bayestrack_particle::Proposal<SVector<f64, 1>, ()> for Stay<F> {
        type Error = std::convert::Infallible;
        type Scratch = ();
        fn propose<R: Rng + ?Sized>(
            &self,
            _k: usize,
            x: &SVector<f64, 1>,
            _z: &(),
            _scratch: &mut (),
            _rng: &mut R,
        ) -> std::result::Result<(SVector<f64, 1>, f64), Self::Error> {
            Ok((*x, (self.0)(x[0])))
        }
    }

    #[test]
    fn condensation_selects_on_the_pi_threshold_and_weights_by_the_likelihood() {
        // Four particles on a line, the likelihood peaks at 2.
        let particles = [0.0, 1.0, 2.0, 3.0].map(SVector::<f64, 1>::new);
        let mut set = ParticleSet::new(particles.to_vec()).unwrap();
        let c = Condensation::POINT_CLOUD;
        let f = c.filter();
        let r = f
            .step(
                &mut set,
                &Stay(|x: f64| -2.0 * (x - 2.0).powi(2)),
                &(),
                &[1],
            )
            .unwrap();
        assert!(!r.resampled, "equal weights are not selected");
        let w = set.weights();
        let z: f64 = [8.0f64, 2.0, 0.0, 2.0].iter().map(|d| (-d).exp()).sum();
        assert!((w[2] - 1.0 / z).abs() < 1e-12);
        assert!((r.ess - 1.0 / w.iter().map(|v| v * v).sum::<f64>()).abs() < 1e-9);
        assert_eq!(r.max_log_increment, 0.0);
        // N_eff = 1.56 < 4 / 2: the next step selects, before it measures.
        assert!(r.ess < 2.0);
        let r2 = f.step(&mut set, &Stay(|_| 0.0), &(), &[2]).unwrap();
        assert!(r2.resampled);
        assert!((r2.ess - 4.0).abs() < 1e-9);
        // N_eff = 4 is not below 4 / 1.5: no selection.
        let r2b = CondensationReport::new(
            &Condensation::CONTOURS
                .filter()
                .step(&mut set, &Stay(|_| 0.0), &(), &[3])
                .unwrap(),
            4,
        );
        assert!(!r2b.resampled && !r2b.lost() && r2b.evaluations == 4);
        // Zero likelihood everywhere: the measurement is ignored.
        let before = set.weights();
        let r3 = CondensationReport::new(
            &f.step(&mut set, &Stay(|_| f64::NEG_INFINITY), &(), &[4])
                .unwrap(),
            4,
        );
        assert!(r3.degenerate && r3.lost());
        for (a, b) in set.weights().iter().zip(&before) {
            assert!((a - b).abs() < 1e-15, "{a} {b}");
        }
        assert!(f.step(&mut set, &Stay(|_| f64::NAN), &(), &[5]).is_err());
        assert!(
            Condensation {
                pi_threshold: 0.5,
                ..c
            }
            .validate()
            .is_err()
        );
    }

    /// An 8x4 frame, left half skin-coloured and right half blue, and its
    /// IFD: 0.2 in rows 0-1, 0.01 (under the 0.05 level) in rows 2-3.
    fn half_skin_frame() -> (
        bayestrack_image::Image<u8>,
        bayestrack_image::Image<f32>,
        bayestrack_image::Rgb,
        bayestrack_image::Rgb,
    ) {
        use bayestrack_image::{Image, Rgb};
        let (skin, blue) = (Rgb::new(224, 172, 138), Rgb::new(40, 70, 200));
        let mut rgb = Vec::new();
        let mut ifd = Vec::new();
        for y in 0..4 {
            for x in 0..8 {
                rgb.extend_from_slice(&if x < 4 { skin } else { blue }.to_array());
                ifd.push(if y < 2 { 0.2f32 } else { 0.01 });
            }
        }
        let rgb = Image::from_vec(8, 4, 3, rgb).unwrap();
        let ifd = Image::from_vec(8, 4, 1, ifd).unwrap();
        (rgb, ifd, skin, blue)
    }

    #[test]
    fn or_over_the_subtracted_pixels_adds_lambda_skin_where_the_ifd_passes() {
        use bayestrack_appearance::{Candidate, Scratch, SkinModel};
        use bayestrack_image::Rect;
        let (rgb, ifd, skin, blue) = half_skin_frame();
        let frame = Frame::new().with_rgb(rgb.view()).with_ifd(ifd.view());
        let model = SkinModel::new(0.066, 0.38, 0.05).unwrap();
        let cue = SubtractedOr {
            skin: model,
            lambda: 0.5,
            threshold: 0.05,
        };
        let c_skin = f64::from(model.score_rgb(skin));
        let c_blue = f64::from(model.score_rgb(blue));
        assert!(c_skin > 0.9 && c_blue < 1e-6, "{c_skin} {c_blue}");
        let mut scratch = Scratch::new();
        let mut score = |x, y, w, h| {
            cue.log_likelihood(
                &frame,
                &Candidate::Window(Rect::new(x, y, w, h)),
                &mut scratch,
            )
            .unwrap()
        };
        // Rows 0-1 pass: each pixel adds 0.2 + lambda C; rows 2-3 add 0.
        let expect = |c: f64, share: f64| (share * (0.2 + 0.5 * c) + FLOOR).ln();
        assert!((score(0, 0, 4, 2) - expect(c_skin, 1.0)).abs() < 1e-6);
        assert!((score(4, 0, 4, 2) - expect(c_blue, 1.0)).abs() < 1e-6);
        assert!((score(0, 0, 4, 4) - expect(c_skin, 0.5)).abs() < 1e-6);
        assert!((score(0, 2, 4, 2) - FLOOR.ln()).abs() < 1e-9);
        // The skin term is what tells the two halves apart.
        assert!(score(0, 0, 4, 2) > score(4, 0, 4, 2) + 0.5);
        assert!(
            cue.log_likelihood(
                &frame,
                &Candidate::Window(Rect::new(6, 0, 4, 2)),
                &mut scratch
            )
            .is_err()
        );
        assert!(
            CueSet::OrSubtracted {
                lambda: 0.02,
                threshold: f64::NAN
            }
            .check()
            .is_err()
        );
    }

    #[test]
    fn or_normalised_divides_each_cue_by_its_mean_over_the_set() {
        use bayestrack_appearance::{Candidate, SkinModel};
        use bayestrack_image::Rect;
        /// A 2x2 window at the state, which never moves; off the frame
        /// for a negative x.
        struct Still;
        impl StateModel<2> for Still {
            fn predict<R: Rng + ?Sized>(
                &self,
                _k: usize,
                x: &SVector<f64, 2>,
                _rng: &mut R,
            ) -> SVector<f64, 2> {
                *x
            }
            fn candidate(&self, x: &SVector<f64, 2>) -> Option<Candidate> {
                (x[0] >= 0.0)
                    .then(|| Candidate::Window(Rect::new(x[0] as usize, x[1] as usize, 2, 2)))
            }
        }
        let (rgb, ifd, skin, blue) = half_skin_frame();
        let frame = Frame::new().with_rgb(rgb.view()).with_ifd(ifd.view());
        let model = SkinModel::new(0.066, 0.38, 0.05).unwrap();
        let (c_skin, c_blue) = (
            f64::from(model.score_rgb(skin)),
            f64::from(model.score_rgb(blue)),
        );
        let lambda = 0.5;
        let or = NormalisedOr {
            ifd: IfdCue::new(FLOOR, 1).unwrap(),
            skin: SkinCue::new(model, FLOOR, 1).unwrap(),
            lambda,
        };
        let states = [[0.0, 0.0], [4.0, 0.0], [0.0, 2.0], [-1.0, 0.0]]
            .map(|[x, y]| SVector::<f64, 2>::new(x, y))
            .to_vec();
        let mut filter = CueFilter::new(Condensation::POINT_CLOUD.filter(), states, 3).unwrap();
        let step = filter.step(&Still, &Flat, &frame).unwrap();
        assert!(!step.degenerate && !step.resampled);
        let (ess, best) = or.weigh(&Still, &mut filter, &frame).unwrap();
        // (a, b) per particle: skin and moving, blue and moving, skin and
        // still, off the frame.
        let ab =
            [(0.2, c_skin), (0.2, c_blue), (0.01, c_skin)].map(|(a, b)| (a + FLOOR, b + FLOOR));
        let ma = ab.iter().map(|p| p.0).sum::<f64>() / 3.0;
        let mb = ab.iter().map(|p| p.1).sum::<f64>() / 3.0;
        let raw: Vec<f64> = ab.iter().map(|(a, b)| a / ma + lambda * b / mb).collect();
        let z: f64 = raw.iter().sum();
        let w = filter.set().weights();
        for (i, r) in raw.iter().enumerate() {
            assert!((w[i] - r / z).abs() < 1e-6, "{i}: {w:?} vs {raw:?}");
        }
        assert_eq!(w[3], 0.0, "off the frame weighs zero");
        assert!((ess - 1.0 / w.iter().map(|v| v * v).sum::<f64>()).abs() < 1e-9);
        assert!((best - (0.2 + lambda * c_skin).ln()).abs() < 1e-6, "{best}");
        // Normalised, the skin term moves the weight: the skin particle
        // outweighs the blue one with the same IFD by lambda (c_skin -
        // c_blue) / mb of the sum's scale.
        assert!(w[0] > w[1] * 1.2, "{w:?}");
        // Bad increments are typed errors and leave the set unchanged.
        let before = filter.set().log_weights().to_vec();
        assert!(filter.reweigh(&[0.0; 3]).is_err());
        assert!(filter.reweigh(&[0.0, f64::NAN, 0.0, 0.0]).is_err());
        assert!(filter.reweigh(&[f64::NEG_INFINITY; 4]).is_err());
        assert_eq!(filter.set().log_weights(), &before[..]);
        assert!(CueSet::OrNormalised { lambda: 0.0 }.check().is_err());
        // Over the subtracted pixels lambda = 0 is the thresholded IFD alone.
        let sub = |lambda| CueSet::OrSubtracted {
            lambda,
            threshold: 0.05,
        };
        assert!(sub(0.0).check().is_ok());
        assert!(sub(-0.01).check().is_err() && sub(f64::NAN).check().is_err());
        assert!(
            CueSet::OrNormalised { lambda: 0.02 }
                .build(IfdCue::new(FLOOR, 1).unwrap(), None::<SkinCue>)
                .is_err(),
            "contours refuse it"
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
