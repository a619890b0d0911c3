//! The experiment's declared options.

use super::*;

options! {
    /// Every choice of the experiment, at paper scale by default (300
    /// frames, 5 runs).
    #[derive(Debug, Clone, PartialEq)]
    pub struct AffineConfig {
        /// Frames per sequence (300: the length of the paper's videos'
        /// tracked parts, about; 1 reads as 2).
        pub frames: usize = 300, in 1..=MAX_FRAMES;
        /// Runs: run `r` renders each scene with seed `scene_seed + r` and
        /// seeds the filters with `r` (5).
        pub runs: usize = 5, in 1..=MAX_RUNS;
        /// Scene seed of run 0.
        pub scene_seed: u64 = 1;
        /// A frame is lost when its RMS exceeds this fraction of the true
        /// target's side `sqrt(w_k h_k)` (0.25).
        pub lost_fraction: f64 = 0.25, in above(0.0);
        /// HKPF's particles in every setting; `none` uses the paper's per
        /// setting ([`Setting::hkpf_particles`]: 150/100/50).
        pub hkpf_particles: Option<usize> = None, in IfSome(1..=MAX_PARTICLES);
        /// `N_max` of both self-tuning filters (ISPF and ours; Algorithm 1's
        /// default, 50).
        pub max_particles: usize = 50, in 1..=MAX_PARTICLES;
        /// How Cock's "abrupt and erratic motion" and "blur ... resulting
        /// from severe camera vibration" (paper 002 sec. 3.2) are read:
        /// `shake` (default: the view shakes, offset anew every
        /// `cock_every` frames), `teleport` (jumps the target keeps) or
        /// `drift` (smooth fast motion). See [`Setting::Cock`].
        pub cock_motion: Motion = Motion::Shake;
        /// Radius of Cock's shakes or length of its jumps, px (7.5: a shake
        /// moves the view by up to 15 px from one frame to the next).
        pub cock_jump: f64 = 7.5, in inside(0.0, 200.0);
        /// Frames between Cock's shakes or jumps (1: vibration
        /// throughout).
        pub cock_every: usize = 1, in 1..=MAX_FRAMES;
        /// How Dudek's "fast motion and pose change" (sec. 3) is read, as
        /// `cock_motion`; default `drift` (see [`Setting::Dudek`]).
        pub dudek_motion: Motion = Motion::Drift;
        /// Radius of Dudek's shakes or length of its jumps, px (20; the
        /// `teleport` and `shake` readings).
        pub dudek_jump: f64 = 20.0, in inside(0.0, 200.0);
        /// Frames between Dudek's shakes or jumps (15).
        pub dudek_every: usize = 15, in 1..=MAX_FRAMES;
        /// Peak speed of the `drift` reading, px a frame (8: the 48 px face
        /// crosses its own width in 6 frames, a fifth of a second at 30
        /// fps; the slow drift of every setting peaks at 3.5).
        pub drift_speed: f64 = 8.0, in inside(0.0, 100.0);
        /// Measurement noise `r` of the Kalman filter that places the
        /// region of HKPF and the self-tuning HKPF, px (1.5). The papers
        /// do not give it, and it sets the region's size (`S = P + r^2
        /// I`): 1.5 px gives a 3-sigma reach of 6.8 px in steady state.
        pub region_r: f64 = 1.5, in inside(0.0, 1000.0);
        /// Also adapt the Kalman region within the frame that holds a jump
        /// (HKPF and the self-tuning filter): when the frame's first
        /// particles (HKPF: the first half; self-tuning: the first batch)
        /// all score at or below `mu_B + sigma_B`, the region is widened
        /// for the rest of the frame (false: paper 002 Fig. 2 feeds `M*`
        /// back to the Kalman filter at the end of the frame, so the
        /// "maneuver detection" of sec. 1 widens the next frame's region;
        /// see `RegionConfig::adapt_within_frame`).
        pub region_in_frame: bool = false;
        /// Where the self-tuning filters' (ISPF, ours) and HKPF's target
        /// similarity distribution (TSD) comes from: `perturbations`
        /// (default: perturbations of the first frame's box at start-up)
        /// or `tracked` (the tracked estimates' scores once two exist; see
        /// `TsdInit`). Paper 002 sec. 1 calls the TSD "the similarity
        /// distribution of target patches" and leaves its initialisation
        /// to ISPF's paper.
        pub tsd_init: TsdSource = TsdSource::Perturbations;
        /// ISPF checks its stopping threshold after every tuned particle
        /// instead of after every batch (false: paper 002 sec. 3.2 counts
        /// stopping inside a batch among its own filter's advantages).
        pub ispf_stop_inside_batch: bool = false;
        /// Also run each reading of [`READINGS`] and print under which the
        /// paper's claims hold (true in `--full`).
        pub readings: bool = false;
        /// Measure the trackers' wall-clock time (the fps column); `false`
        /// records 0 s, so that two runs write byte-identical files.
        pub timing: bool = true;
    }
    check check;
}

/// Most particle-frames a run may ask for in all (runs x frames x the
/// particles of the three filters over the three settings): 1e10, about
/// ten thousand times the paper's scale. More is a typo, refused before
/// anything runs.
pub const MAX_PARTICLE_FRAMES: f64 = 1e10;

/// The cross-option rules, checked before the run starts: every filter's
/// configuration is one its tracker accepts (HKPF's particle cap, the
/// self-tuning filters' batch within `max_particles`), and the amount of
/// work is bounded.
pub(super) fn check(c: &AffineConfig) -> Result<(), String> {
    for setting in Setting::ALL {
        c.hkpf(setting)
            .validate()
            .map_err(|e| format!("HKPF: {e}"))?;
    }
    c.ispf().validate().map_err(|e| format!("ISPF: {e}"))?;
    c.stpf()
        .validate()
        .map_err(|e| format!("self-tuning HKPF: {e}"))?;
    let particles: f64 = Setting::ALL
        .iter()
        .map(|&s| (c.hkpf(s).particles + 2 * c.max_particles) as f64)
        .sum();
    // (a reading's own options have `readings` off: no recursion)
    for reading in READINGS.iter().filter(|_| c.readings) {
        let r = reading
            .config(c)
            .map_err(|e| format!("reading {}: {e}", reading.name))?;
        for setting in reading.settings {
            r.hkpf(*setting)
                .validate()
                .map_err(|e| format!("reading {}: HKPF: {e}", reading.name))?;
        }
    }
    // the readings rerun some settings: at most every setting once more each
    let passes = 1 + if c.readings { READINGS.len() } else { 0 };
    let work = c.runs as f64 * c.frames() as f64 * particles * passes as f64;
    if work > MAX_PARTICLE_FRAMES {
        return Err(format!(
            "runs x frames x particles (all filters and settings) = {work:.1e} particle-frames, \
             more than the {MAX_PARTICLE_FRAMES:.0e} a run may ask for; lower runs, frames, \
             hkpf_particles or max_particles"
        ));
    }
    Ok(())
}

impl AffineConfig {
    /// Paper scale: 300 frames, 5 runs, with the readings.
    pub fn paper() -> Self {
        Self {
            readings: true,
            ..Self::default()
        }
    }

    /// The CI scale: 80 frames, 1 run.
    pub fn quick() -> Self {
        Self {
            frames: 80,
            runs: 1,
            readings: false,
            ..Self::paper()
        }
    }

    /// Applies a `key=value` override (see [`Options::set`]).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or value, listing
    /// every key with its domain.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        crate::driver::apply(ID, self, key, value)
    }

    /// Every option as `key=value`, for the table footer.
    pub fn describe(&self) -> String {
        Options::describe(self)
    }

    /// Frames per sequence as run (at least 2: one to start, one to score).
    pub fn frames(&self) -> usize {
        self.frames.max(2)
    }

    /// HKPF's settings on `setting` (its particles: `hkpf_particles` or the
    /// paper's for that video).
    pub fn hkpf(&self, setting: Setting) -> HkpfConfig {
        let d = HkpfConfig::default();
        HkpfConfig {
            particles: self
                .hkpf_particles
                .unwrap_or_else(|| setting.hkpf_particles()),
            region: RegionConfig {
                r: self.region_r,
                adapt_within_frame: self.region_in_frame,
                ..d.region
            },
            appearance: self.appearance(d.appearance),
            ..d
        }
    }

    /// The self-tuning filter's settings (Algorithm 1's defaults).
    pub fn stpf(&self) -> StpfConfig {
        let d = StpfConfig::default();
        StpfConfig {
            max_particles: self.max_particles,
            region: RegionConfig {
                r: self.region_r,
                adapt_within_frame: self.region_in_frame,
                ..d.region
            },
            appearance: self.appearance(d.appearance),
            ..d
        }
    }

    /// ISPF's settings.
    pub fn ispf(&self) -> IspfConfig {
        let d = IspfConfig::default();
        IspfConfig {
            max_particles: self.max_particles,
            stop_inside_batch: self.ispf_stop_inside_batch,
            appearance: self.appearance(d.appearance),
            ..d
        }
    }

    /// `base` with this run's TSD source.
    fn appearance(&self, base: AppearanceConfig) -> AppearanceConfig {
        AppearanceConfig {
            tsd_init: match self.tsd_init {
                TsdSource::Perturbations => TsdInit::Perturbations,
                TsdSource::Tracked => TsdInit::Tracked,
            },
            ..base
        }
    }
}
