//! The experiment's declared options.

use super::*;

/// Widest MAD search margin an option may ask for, px (wider than any
/// frame).
pub const MAX_MAD_MARGIN: usize = 4096;

/// The cross-option rule: the PF trackers' settings must be ones they
/// accept.
pub(super) fn check(c: &CorrelationConfig) -> Result<(), String> {
    PfCorrelationTracker::new(c.pf()).map_err(|e| e.to_string())?;
    for v in Variant::ALL.into_iter().filter(|v| v.is_pf()) {
        c.tracker(v, 0).map_err(|e| e.to_string())?;
    }
    Ok(())
}

options! {
    /// Every choice of the experiment, at paper scale by default (50 runs).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CorrelationConfig {
        /// Runs (scene noise and particle seeds; 50 at paper scale).
        pub runs: usize = 50, in 1..=MAX_RUNS;
        /// Scene seed of run 0.
        pub scene_seed: u64 = 1;
        /// Margin of the MAD tracker's search window, px (16).
        pub mad_margin: usize = 16, in 0..=MAX_MAD_MARGIN;
        /// Particles of the PF trackers (paper 004 sec. 3: `Ns = 15`).
        pub particles: usize = 15, in 1..=MAX_PARTICLES;
        /// Likelihood width of the PF trackers, gray levels (1.5; the
        /// tracker checks its range).
        pub sigma: f64 = 1.5;
        /// Initial spread of the particles, px per axis (5).
        pub spread: f64 = 5.0;
        /// `B` of the drift model's random walk, px (4).
        pub b: f64 = 4.0;
        /// Gain of the drift model (0.5).
        pub gain: f64 = 0.5;
        /// `B` of the printed eq. 6 random walk, px (8).
        pub printed_b: f64 = 8.0;
        /// MAD cap of the `PF drift+cap` row, gray levels (40).
        pub cap: f64 = 40.0;
        /// `B` (px) of the `PF const drift` row: the constant drift carries
        /// the motion, `B w` only absorbs the error of `c`, which the
        /// integer-pixel MAD match measures to +-0.5 px per axis; 1 px
        /// covers it.
        pub const_b: f64 = 1.0;
    }
    check check;
}

impl CorrelationConfig {
    /// Paper scale: 50 runs.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: 8 runs.
    pub fn quick() -> Self {
        Self {
            runs: 8,
            ..Self::paper()
        }
    }

    /// Applies a `key=value` override (see [`Options::set`]).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or value, listing
    /// every key with its domain; a refused option leaves the configuration
    /// as it was.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        crate::driver::apply(ID, self, key, value)
    }

    /// Every option as `key=value`, for the table footer.
    pub fn describe(&self) -> String {
        Options::describe(self)
    }

    /// The PF tracker's settings (seed replaced per run) for the drift rows.
    pub fn pf(&self) -> PfCorrelationConfig {
        PfCorrelationConfig {
            particles: self.particles,
            spread: [self.spread; 2],
            motion: ArpMotion::Drift {
                b: [self.b; 2],
                gain: self.gain,
            },
            sigma: self.sigma,
            ..PfCorrelationConfig::default()
        }
    }

    pub(super) fn tracker(
        &self,
        v: Variant,
        run: usize,
    ) -> Result<Box<dyn Tracker>, ExperimentError> {
        let pf = |c: PfCorrelationConfig| -> Result<Box<dyn Tracker>, ExperimentError> {
            Ok(Box::new(
                PfCorrelationTracker::new(PfCorrelationConfig {
                    seed: run as u64,
                    ..c
                })
                .map_err(|e| failed(v.name(), e))?,
            ))
        };
        let mad = |search| -> Result<Box<dyn Tracker>, ExperimentError> {
            Ok(Box::new(
                MadTracker::new(MadTrackerConfig {
                    search,
                    ..MadTrackerConfig::default()
                })
                .map_err(|e| failed(v.name(), e))?,
            ))
        };
        match v {
            Variant::MadWindow => mad(SearchArea::Window {
                margin: self.mad_margin,
            }),
            Variant::MadFrame => mad(SearchArea::Frame),
            Variant::PfPrinted => pf(PfCorrelationConfig {
                motion: ArpMotion::Position {
                    a: [1.0, 1.0],
                    b: [self.printed_b; 2],
                },
                ..self.pf()
            }),
            Variant::PfDrift => pf(self.pf()),
            Variant::PfDriftCap => pf(PfCorrelationConfig {
                mad_cap: Some(self.cap),
                ..self.pf()
            }),
            Variant::PfConstDrift => pf(PfCorrelationConfig {
                motion: ArpMotion::ConstantDrift {
                    b: [self.const_b; 2],
                    margin: self.mad_margin,
                },
                ..self.pf()
            }),
        }
    }
}
