//! HKPF: the hierarchical Kalman-particle filter of Yin, Na, Choi and Oh
//! (2011), as paper 002 (Xu, Gao and Yang 2015, sections 0-2) describes it:
//! coarse then fine, no pose tuning.

use bayestrack_affine::{Affine2, AffineGroup, BrownianDynamics};

use super::common::{
    AffineTracker, AppearanceConfig, Core, FrameStats, Region, RegionConfig, ScoredPose,
};
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

const NAME: &str = "hkpf";
/// Key of the random streams ("hkpf" in ASCII).
const KEY: u64 = 0x686b_7066;

/// Parameters of [`HkpfTracker`].
#[derive(Debug, Clone, PartialEq)]
pub struct HkpfConfig {
    /// Particles per frame (100; paper 002 ran 150, 100 and 50 on its three
    /// sequences).
    pub particles: usize,
    /// The Kalman filter and the region.
    pub region: RegionConfig,
    /// Standard deviations of the pose generators A1..A4 (scale, aspect,
    /// rotation, skew) in `Psi_k` ((0.02, 0.015, 0.03, 0.015): half the pose
    /// estimator's training spread, the same as the self-tuning filter's).
    pub pose_sigma: [f64; 4],
    /// Observation and appearance model (the pose estimator is not used).
    pub appearance: AppearanceConfig,
}

impl Default for HkpfConfig {
    fn default() -> Self {
        Self {
            particles: 100,
            region: RegionConfig::default(),
            pose_sigma: [0.02, 0.015, 0.03, 0.015],
            appearance: AppearanceConfig::default(),
        }
    }
}

impl HkpfConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        super::common::check_particles("particles", self.particles)?;
        self.region.validate()?;
        super::common::check_pose_sigma("pose_sigma", &self.pose_sigma)?;
        self.appearance.validate()
    }
}

/// The hierarchical Kalman-particle filter (Yin et al. 2011).
///
/// Each frame: the Kalman filter predicts the displacement `d_k` and the
/// region ([`RegionConfig`]; widened after a manoeuvre, and with
/// [`RegionConfig::adapt_within_frame`] for the second half of the
/// particles when none of the first half beats the lost threshold
/// `mu_B + sigma_B`); `particles` poses
/// `M_i = exp(d_k(1) A5 + d_k(2) A6) M_{k-1} exp(Omega_i)`,
/// `Omega_i ~ N(0, Psi_k)` (eq. 4-5), are scored by their similarity; the
/// best one is the estimate `M*` (eq. 2) and its centre the Kalman
/// measurement. The template, TSD and BSD are updated as for the
/// self-tuning filter; there is no pose estimator.
pub type HkpfTracker = Shell<HkpfCore>;

/// The model of [`HkpfTracker`].
#[derive(Debug, Clone)]
pub struct HkpfCore {
    config: HkpfConfig,
    core: Core,
    region: Option<Region>,
}

impl HkpfTracker {
    /// A tracker with `config`, its random streams keyed by `seed`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: HkpfConfig, seed: u64) -> Result<Self> {
        Ok(Shell::wrap(HkpfCore::new(config, seed)?))
    }
}

impl HkpfCore {
    /// The model of [`HkpfTracker::new`].
    ///
    /// # Errors
    /// As [`HkpfTracker::new`].
    pub fn new(config: HkpfConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        let core = Core::new(KEY, seed, config.appearance.clone())?;
        Ok(Self {
            config,
            core,
            region: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &HkpfConfig {
        &self.config
    }
}

impl AffineTracker for HkpfTracker {
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

impl TrackerCore for HkpfCore {
    fn name(&self) -> &'static str {
        NAME
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn start(&mut self, planes: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (frame, target) = (planes.input(), target.bbox);
        self.region = None;
        let centre = self.core.init(&frame, target, false)?;
        self.region = Some(Region::new(self.config.region, centre)?);
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let frame = planes.input();
        let region = self.region.as_mut().ok_or(TrackerError::NotInitialised)?;
        let core = &mut self.core;
        core.begin(&frame)?;
        let mut rng = core.frame_rng();
        core.stats.manoeuvre = region.manoeuvre();
        let m_prev = core.pose;
        let (d, psi) = region.predict(&m_prev, &self.config.pose_sigma)?;
        let mut dynamics = BrownianDynamics::new(psi)?;
        // `adapt_within_frame`: after the first half, widen the region for
        // the second if nothing found so far beats the lost threshold.
        let half = self.config.particles.div_ceil(2);
        for i in 0..self.config.particles {
            if i == half && region.can_widen() {
                let lost = core
                    .model()
                    .ok_or(TrackerError::NotInitialised)?
                    .update_threshold();
                if core.best().is_none_or(|b| b.similarity <= lost) {
                    dynamics =
                        BrownianDynamics::new(region.widened(&m_prev, &self.config.pose_sigma)?)?;
                    core.stats.manoeuvre = true;
                }
            }
            let m = dynamics.propagate(&m_prev, d, &mut rng)?;
            let similarity = core.score(&m)?.unwrap_or(f64::NEG_INFINITY);
            core.scored.push(ScoredPose {
                pose: m,
                similarity,
            });
        }
        core.stats.particles = self.config.particles;
        core.stats.batches = 1;
        core.stats.stop_threshold = f64::INFINITY;
        // No particle scored: keep M_{k-1} and restart the Kalman filter
        // there ([`Region::restart`]).
        match core.best() {
            Some(b) => region.update(Some(b.pose.offset()))?,
            None => region.restart(m_prev.offset())?,
        }
        core.finish(m_prev, false, &mut rng)
    }
}
