//! The experiment's declared options.

use super::*;

options! {
    /// Every choice of the experiment, at paper scale by default (10 runs
    /// of the whole 150-frame scene).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CondensationConfig {
        /// Seeded runs of every job (10).
        pub runs: usize = 10, in 1..=MAX_RUNS;
        /// Frames of the tracking scene (the default webcam scene's 150).
        pub frames: usize = 150, in 2..=MAX_FRAMES;
        /// Scene seed of run 0.
        pub scene_seed: u64 = 1;
        /// A frame is lost when the centre error exceeds this fraction of
        /// the smaller side of the object's box (1/2: the estimate is off
        /// the object).
        pub lost_fraction: f64 = 0.5, in above(0.0);
        /// Lock-on and identity radius (px): an estimate this close to an
        /// object's centre is on it (20: half the face's width).
        pub lock_distance: f64 = 20.0, in above(0.0);
        /// Consecutive frames on the newcomer that count as lock-on (3).
        pub lock_frames: usize = 3, in 1..=MAX_FRAMES;
        /// Frames of the entering scene after the entry (at frame 30) that
        /// are tracked (45 quick, 90 = the whole scene full).
        pub reinit_frames: usize = 90, in 1..=MAX_FRAMES;
        /// After the crossing, frames whose true centres are more than this
        /// far apart along x are scored (45 px: the objects no longer
        /// overlap).
        pub separation: f64 = 45.0, in above(0.0);
        /// c-AVQ's IFD threshold of the re-initialisation runs (paper 003
        /// sec. 4; the tracker's default, 0.05).
        pub avq_threshold: f32 = 0.05, in above(0.0);
        /// c-AVQ's trigger: the fraction of pixels over the threshold that
        /// starts a re-initialisation (the tracker's default, 0.035).
        pub avq_trigger: f64 = 0.035, in inside(0.0, 1.0);
        /// How eq. 9's OR sums the two cues for the point cloud (sec. 3.1):
        /// `subtracted` (default), the sum run only over the particle's
        /// window pixels whose IFD exceeds `subtracted_threshold`, or
        /// `raw`, `IFD + lambda skin` averaged over the whole window. Eq. 9
        /// sums over "the `i`th particle's point `(x_P, y_P) in dP_i` of
        /// both the subtracted pixel and the associated skin-color point":
        /// `dP_i` is a set belonging to particle `i` (eq. 7's map is `dP_t`),
        /// and its members are "subtracted pixel[s]", so the sum runs over
        /// the pixels that the subtraction marks, each adding its
        /// difference and `lambda` times its skin score. `raw` reads `dP_i`
        /// as the whole window (this code's first reading). `normalised`
        /// puts the two cues on one scale before `lambda` balances them:
        /// particle `i`'s window means `a_i` (IFD) and `b_i` (skin), each
        /// plus the cues' floor 1e-12, are divided by their means over the
        /// predicted particles inside the frame, and the particle weighs
        /// `a_i / mean a + lambda b_i / mean b`
        /// ([`CueSet::OrNormalised`]); with `lambda = 1/N` the skin term
        /// then weighs 1/N of the IFD's on average. Contours keep eq. 9
        /// raw (the paper uses OR only with points).
        pub or_weighting: OrWeighting = OrWeighting::Subtracted;
        /// The IFD level (grey in `[0, 1]`) above which a pixel is
        /// "subtracted" (`or_weighting=subtracted`): 0.05, the level at
        /// which c-AVQ counts a pixel as "IFD data" (sec. 4; 13 grey
        /// levels, well above the sensor's frame-to-frame noise). The
        /// paper gives no level for sec. 3.
        pub subtracted_threshold: f64 = 0.05, in inside(0.0, 1.0);
        /// Moving non-skin boxes in every scene (0). The paper "assume[s]
        /// that a human is moving in clutter" in front of "a static
        /// webcam" (sec. 1) and names no other moving object; its clutter
        /// is the static background. This code first ran with 2 (saturated
        /// boxes with 3-4x the face's IFD, which defeat the IFD alone): the
        /// `movers-2` reading.
        pub moving_distractors: usize = 0, in 0..=16;
        /// Static skin-coloured distractors in every scene (2: the
        /// "clutter" of sec. 1 for the skin cue; they never move, so the
        /// IFD ignores them).
        pub static_distractors: usize = 2, in 0..=16;
        /// Frame width in px (320: the paper gives none; a 2005 webcam's
        /// QVGA). The face stays 40x52 and wanders over about 0.8 of the
        /// frame's half-width (its path scales with the frame).
        pub width: usize = 320, in 120..=4096;
        /// Frame height in px (240).
        pub height: usize = 240, in 100..=4096;
        /// How the contours' rotation and scale move (eq. 10's "A, B are
        /// the appropriate matrices"): ar2 (default), Blake and Isard's
        /// second-order auto-regressive model around the template mean
        /// ([`ContourDynamics::Ar2`]), or velocity, eq. 10's damped
        /// velocity as for the point cloud (this code's first reading).
        /// The paper calls its contours "the deformable contours \[5\] of
        /// the B-spline snakes" and "the dynamics is similarly described by
        /// (10)": eq. 10 is the state-space form of a second-order
        /// process, and its ref. \[5\] (Blake and Isard, Active Contours,
        /// ch. 9) models a contour's shape components by exactly that
        /// process, centred on the template's mean shape, so that a
        /// contour's rotation and scale stay near the template's while
        /// its position wanders. The centroid keeps eq. 10's damped
        /// velocity either way (the object may go anywhere in the frame).
        pub contour_dynamics: ContourMotion = ContourMotion::Ar2;
        /// Stationary rms rotation of the ar2 dynamics about the template
        /// (15 degrees: a head or hand before a webcam tilts in-plane by a
        /// few tens of degrees at most; Blake and Isard set the model by
        /// such an rms displacement). The paper gives none.
        pub ar_rms_theta_deg: f64 = 15.0, in above(0.0);
        /// Stationary rms scale increment of the ar2 dynamics (0.15: a
        /// person at arm's length from a webcam who leans in or back by
        /// 10-15 cm changes size by 15-20 %). The paper gives none.
        pub ar_rms_alpha: f64 = 0.15, in above(0.0);
        /// The target of the tracking and hand scenes turns and changes
        /// size (true): the paper's contour state carries "the rotating
        /// angle and the scaling factor" (eq. 13) with their own diffusion
        /// (sigma_theta = 1 deg and sigma_alpha = 0.01 for the face, 3 deg
        /// and 0.05 for the hand), which it would not give for objects that
        /// never turn. false is this code's first, upright scene. The
        /// entering and crossing scenes stay upright.
        pub pose_motion: bool = true;
        /// Amplitude of the target's rotation under pose_motion (15
        /// degrees, a period of 4 s: at most 0.8 deg a frame, inside the
        /// face's 1 deg diffusion).
        pub rotation_deg: f64 = 15.0, in above_to(0.0, 90.0);
        /// Relative amplitude of the target's change of size under
        /// pose_motion (0.15, a period of 5 s: at most 0.0063 a frame,
        /// inside the face's 0.01 diffusion).
        pub scale_change: f64 = 0.15, in above_to(0.0, 0.5);
        /// Size of the target (the face of the tracking scene, the hand of
        /// the hand scene) relative to the 40x52 face or 31x43 hand (1;
        /// the paper gives none).
        pub face_size: f64 = 1.0, in inside(0.25, 4.0);
        /// Also run each reading of [`READINGS`] and print under which the
        /// paper's claims hold (true in `--full`).
        pub readings: bool = false;
        /// Measure the trackers' wall-clock time (the fps column); `false`
        /// records 0 s, so that two runs write byte-identical files.
        pub timing: bool = true;
    }
    check check;
}

/// Most frames a run may track in all (runs x the frames of its scenes):
/// 1e7, several thousand times the paper's scale. More is a typo, refused
/// before anything runs.
pub const MAX_RUN_FRAMES: f64 = 1e7;

/// The cross-option rules, checked before the run starts: c-AVQ's
/// constants must be ones it accepts; the ar2 contour dynamics must be
/// stationary with the face's and the hand's diffusion; `reinit_frames` must fit the entering
/// scene (it was cut silently) and hold `lock_frames` (a lock-on could
/// never be counted); the amount of work is bounded.
pub(super) fn check(c: &CondensationConfig) -> Result<(), String> {
    c.avq().validate().map_err(|e| e.to_string())?;
    for (what, base) in [
        ("face contour", ContourConfig::face(50)),
        ("hand contour", ContourConfig::hand()),
    ] {
        c.contour(base)
            .validate()
            .map_err(|e| format!("{what}: {e}"))?;
    }
    let (scene, entry) = entering_scene(&CondensationConfig {
        reinit_frames: usize::MAX / 2,
        ..*c
    });
    let after_entry = scene.frames - entry;
    if c.reinit_frames > after_entry {
        return Err(format!(
            "reinit_frames = {} is more than the {after_entry} frames of the entering scene \
             after the entry",
            c.reinit_frames
        ));
    }
    if c.lock_frames > c.reinit_frames {
        return Err(format!(
            "lock_frames = {} is more than reinit_frames = {}: a lock-on could never be counted",
            c.lock_frames, c.reinit_frames
        ));
    }
    // the tracking scene, the crossing and the entering scene, per run
    let work = c.runs as f64 * (2 * c.frames + c.reinit_frames) as f64;
    if work > MAX_RUN_FRAMES {
        return Err(format!(
            "runs x frames (all scenes) = {work:.1e} frames, more than the {MAX_RUN_FRAMES:.0e} \
             a run may ask for; lower runs, frames or reinit_frames"
        ));
    }
    Ok(())
}

impl CondensationConfig {
    /// Paper scale: 10 runs of the whole 150-frame scene, with the
    /// readings table.
    pub fn paper() -> Self {
        Self {
            readings: true,
            ..Self::default()
        }
    }

    /// The CI scale: 2 runs of 60 frames, 45 frames after the entry, no
    /// readings.
    pub fn quick() -> Self {
        Self {
            runs: 2,
            frames: 60,
            reinit_frames: 45,
            readings: false,
            ..Self::paper()
        }
    }

    /// The webcam scene of these options: `base` with the distractors and
    /// the frame size.
    pub fn scene(&self, base: WebcamScene) -> WebcamScene {
        WebcamScene {
            target_size: self.face_size,
            width: self.width,
            height: self.height,
            moving_distractors: self.moving_distractors,
            static_skin_distractors: self.static_distractors,
            ..base
        }
    }

    /// The tracking scene's target pose: base with the rotation, the
    /// change of size and the size under pose_motion.
    pub fn posed(&self, base: WebcamScene) -> WebcamScene {
        let (rotation_deg, scale_change) = if self.pose_motion {
            (self.rotation_deg, self.scale_change)
        } else {
            (0.0, 0.0)
        };
        WebcamScene {
            rotation_deg,
            scale_change,
            ..self.scene(base)
        }
    }

    /// base (a contour preset) with the contour dynamics of these options.
    pub fn contour(&self, base: ContourConfig) -> ContourConfig {
        ContourConfig {
            dynamics: match self.contour_dynamics {
                ContourMotion::Velocity => ContourDynamics::DampedVelocity,
                ContourMotion::Ar2 => ContourDynamics::Ar2 {
                    rms_theta_deg: self.ar_rms_theta_deg,
                    rms_alpha: self.ar_rms_alpha,
                },
            },
            ..base
        }
    }

    /// The cue set of `cue` with `n` particles for `representation` under
    /// `or_weighting`.
    pub fn cue_set(&self, representation: Representation, cue: Cue, n: usize) -> CueSet {
        match (representation, cue, self.or_weighting) {
            (Representation::Points, Cue::Or, OrWeighting::Subtracted) => CueSet::OrSubtracted {
                lambda: 1.0 / n.max(1) as f64,
                threshold: self.subtracted_threshold,
            },
            (Representation::Points, Cue::Or, OrWeighting::Normalised) => CueSet::OrNormalised {
                lambda: 1.0 / n.max(1) as f64,
            },
            _ => cue.cue_set(n),
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

    /// The c-AVQ constants of the re-initialisation runs.
    pub fn avq(&self) -> CAvqConfig {
        CAvqConfig {
            ifd_threshold: self.avq_threshold,
            trigger_fraction: self.avq_trigger,
            ..CAvqConfig::default()
        }
    }
}
