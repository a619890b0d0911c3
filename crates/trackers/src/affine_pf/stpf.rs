//! The self-tuning hierarchical Kalman-particle filter of paper 002 (Xu,
//! Gao and Yang 2015, Algorithm 1).

use bayestrack_affine::{Affine2, AffineGroup, BrownianDynamics};
use nalgebra::Vector2;

use super::common::{
    AffineTracker, AppearanceConfig, Core, FrameStats, Region, RegionConfig, ScoredPose, StopRule,
};
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

const NAME: &str = "stpf";
/// Key of the random streams ("stpf" in ASCII).
const KEY: u64 = 0x7374_7066;

/// Parameters of [`StpfTracker`]; the defaults are paper 002's where it
/// gives them (sec. 3.1).
#[derive(Debug, Clone, PartialEq)]
pub struct StpfConfig {
    /// `N_max`, the most particles per frame (50).
    pub max_particles: usize,
    /// `Delta N_0`, the particles of the first batch (5, "usually 10 % of
    /// N_max").
    pub initial_particles: usize,
    /// `alpha_inc`, the growth factor of the batches (2).
    pub increment: f64,
    /// The Kalman filter and the region.
    pub region: RegionConfig,
    /// Standard deviations of the pose generators A1..A4 (scale, aspect,
    /// rotation, skew) in `Psi_k` ((0.02, 0.015, 0.03, 0.015): half the pose
    /// estimator's training spread, so that drawn particles stay inside the
    /// regression scope of the learnt model, whose loss paper 002 sec. 3.2
    /// names as ISPF's failure).
    pub pose_sigma: [f64; 4],
    /// The stopping threshold (default `mu_T - sigma_T`, see [`StopRule`]).
    pub stop_rule: StopRule,
    /// `lambda` of the selection weights `w_i = exp(lambda (S_i - S_max))`
    /// of step 4-3 (20: a particle 0.05 less similar weighs e^-1 as much;
    /// the paper does not give its weights).
    pub weight_lambda: f64,
    /// Observation, appearance model and pose estimator.
    pub appearance: AppearanceConfig,
}

impl Default for StpfConfig {
    fn default() -> Self {
        Self {
            max_particles: 50,
            initial_particles: 5,
            increment: 2.0,
            region: RegionConfig::default(),
            pose_sigma: [0.02, 0.015, 0.03, 0.015],
            stop_rule: StopRule::default(),
            weight_lambda: 20.0,
            appearance: AppearanceConfig::default(),
        }
    }
}

impl StpfConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        super::common::check_particles("max_particles", self.max_particles)?;
        if self.initial_particles == 0 || self.initial_particles > self.max_particles {
            return Err(TrackerError::InvalidParameter {
                name: "initial_particles",
                value: self.initial_particles as f64,
                reason: "must be in 1..=max_particles",
            });
        }
        if !(self.increment.is_finite() && (1.0..=64.0).contains(&self.increment)) {
            return Err(TrackerError::InvalidParameter {
                name: "increment",
                value: self.increment,
                reason: "must be in [1, 64]",
            });
        }
        super::common::check_non_negative("weight_lambda", self.weight_lambda)?;
        self.region.validate()?;
        super::common::check_pose_sigma("pose_sigma", &self.pose_sigma)?;
        self.appearance.validate()
    }
}

/// The self-tuning hierarchical Kalman-particle filter (Xu, Gao and Yang
/// 2015, Algorithm 1).
///
/// Each frame:
/// 1. the Kalman filter predicts `d_k` and the region `Psi_C`
///    ([`RegionConfig`]); `Delta N_0` particles are drawn by eq. 4-5
///    (with [`RegionConfig::adapt_within_frame`], when none of them beats
///    the lost threshold `mu_B + sigma_B` the region is widened by
///    `manoeuvre_gain` for the later batches of the frame);
/// 2. each is tuned to its best neighbour and scored; the batch stops early
///    as soon as a tuned particle's similarity exceeds the threshold
///    ([`StopRule`]);
/// 3. while no particle has passed the threshold and fewer than `N_max`
///    were used: the next batch has `Delta N_t = min(ceil(alpha_inc
///    Delta N_{t-1}), N_max - n)` particles, drawn by multinomial selection
///    of all tuned particles so far by their weights, each moved by
///    `M exp(v)`, `v ~ N(0, (1 - S_max^{t-1}) Psi_C)` (`S_max^{t-1}` the
///    best similarity of the previous batch), tuned and scored, stopping
///    inside the batch at the first one above the threshold;
/// 4. the best tuned particle is `M*` (eq. 2); its centre is the Kalman
///    measurement; if its score passes the update rule, the template,
///    TSD/BSD and the pose estimator (trained on perturbations of `M*`)
///    learn from it.
///
/// The particle count reported is the number of particles tuned; particles
/// a batch did not reach after an early stop are not counted (paper 002:
/// "not all particles need to be calculated").
pub type StpfTracker = Shell<StpfCore>;

/// The model of [`StpfTracker`].
#[derive(Debug, Clone)]
pub struct StpfCore {
    config: StpfConfig,
    core: Core,
    region: Option<Region>,
}

impl StpfTracker {
    /// A tracker with `config`, its random streams keyed by `seed`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: StpfConfig, seed: u64) -> Result<Self> {
        Ok(Shell::wrap(StpfCore::new(config, seed)?))
    }
}

impl StpfCore {
    /// The model of [`StpfTracker::new`].
    ///
    /// # Errors
    /// As [`StpfTracker::new`].
    pub fn new(config: StpfConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        let core = Core::new(KEY, seed, config.appearance.clone())?;
        Ok(Self {
            config,
            core,
            region: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &StpfConfig {
        &self.config
    }
}

impl AffineTracker for StpfTracker {
    fn pose(&self) -> Option<Affine2> {
        self.core().region.as_ref().map(|_| self.core().core.pose)
    }

    fn stats(&self) -> FrameStats {
        self.core().core.stats
    }

    fn particles(&self) -> &[ScoredPose] {
        &self.core().core.scored
    }

    fn model(&self) -> Option<&bayestrack_appearance::TargetModel> {
        self.core().core.model()
    }
}

impl TrackerCore for StpfCore {
    fn name(&self) -> &'static str {
        NAME
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn start(&mut self, planes: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (frame, target) = (planes.input(), target.bbox);
        self.region = None;
        let centre = self.core.init(&frame, target, true)?;
        self.region = Some(Region::new(self.config.region, centre)?);
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let frame = planes.input();
        let c = &self.config;
        let region = self.region.as_mut().ok_or(TrackerError::NotInitialised)?;
        let core = &mut self.core;
        core.begin(&frame)?;
        let mut rng = core.frame_rng();
        core.stats.manoeuvre = region.manoeuvre();
        let threshold = {
            let model = core.model().ok_or(TrackerError::NotInitialised)?;
            c.stop_rule.threshold(model.tsd())
        };
        core.stats.stop_threshold = threshold;
        let m_prev = core.pose;
        // Step 1: hierarchical estimation and the first batch.
        let (d, psi_c) = region.predict(&m_prev, &c.pose_sigma)?;
        let psi = BrownianDynamics::new(psi_c)?;
        let mut s_max = f64::NEG_INFINITY;
        let mut n = 0;
        // Step 2.
        let mut batch = c.initial_particles;
        for _ in 0..batch {
            if s_max > threshold {
                break;
            }
            let m = psi.propagate(&m_prev, d, &mut rng)?;
            let tuned = core.tune(&m)?;
            s_max = s_max.max(tuned.similarity);
            core.scored.push(tuned);
            n += 1;
        }
        core.stats.batches = 1;
        // `adapt_within_frame`: the first batch found nothing that beats
        // the lost threshold, so the target is not in the region: widen it
        // for the rest of the frame.
        let mut psi = psi;
        if s_max <= threshold && region.can_widen() {
            let lost = core
                .model()
                .ok_or(TrackerError::NotInitialised)?
                .update_threshold();
            if s_max <= lost {
                psi = BrownianDynamics::new(region.widened(&m_prev, &c.pose_sigma)?)?;
                core.stats.manoeuvre = true;
            }
        }
        // Step 4.
        let mut s_prev = s_max;
        while s_max <= threshold && n < c.max_particles {
            let size = ((c.increment * batch as f64).ceil() as usize)
                .max(1)
                .min(c.max_particles - n);
            batch = size;
            core.stats.batches += 1;
            let spread = 1.0 - s_prev.clamp(0.0, 1.0);
            let drawn = core.draw_parents(size, c.weight_lambda, &mut rng)?;
            let moved = psi.scaled(spread)?;
            let mut s_batch = f64::NEG_INFINITY;
            for i in 0..size {
                if s_batch > threshold {
                    break;
                }
                let m = if let Some(parent) = core.parent(i).filter(|_| drawn) {
                    moved.propagate(&parent, Vector2::zeros(), &mut rng)?
                } else {
                    // No particle could be scored yet: draw from the
                    // dynamics again.
                    psi.propagate(&m_prev, d, &mut rng)?
                };
                let tuned = core.tune(&m)?;
                s_batch = s_batch.max(tuned.similarity);
                core.scored.push(tuned);
                n += 1;
            }
            s_prev = s_batch;
            s_max = s_max.max(s_batch);
        }
        core.stats.particles = n;
        // Steps 5-7.
        // No particle scored: keep M_{k-1} and restart the Kalman filter
        // there ([`Region::restart`]).
        match core.best() {
            Some(b) => region.update(Some(b.pose.offset()))?,
            None => region.restart(m_prev.offset())?,
        }
        core.finish(m_prev, true, &mut rng)
    }
}
