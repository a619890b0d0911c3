//! The experiment's declared options, its conditions, modes and evaluation budget.

use super::*;

/// Offline (every frame) or real time (frames dropped while computing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum FrameMode {
    /// Every frame is processed.
    Offline,
    /// Frames that arrive while the tracker computes are dropped.
    RealTime,
}

impl FrameMode {
    /// Both modes.
    pub const ALL: [FrameMode; 2] = [FrameMode::Offline, FrameMode::RealTime];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            FrameMode::Offline => "offline",
            FrameMode::RealTime => "realtime",
        }
    }
}

/// One of the four scene conditions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Condition {
    /// Linear or bouncing motion.
    pub motion: BallMotion,
    /// Whether motion noise is added.
    pub noisy: bool,
}

impl Condition {
    /// The four conditions, in run order.
    pub const ALL: [Condition; 4] = [
        Condition {
            motion: BallMotion::Linear,
            noisy: false,
        },
        Condition {
            motion: BallMotion::Linear,
            noisy: true,
        },
        Condition {
            motion: BallMotion::Bouncing,
            noisy: false,
        },
        Condition {
            motion: BallMotion::Bouncing,
            noisy: true,
        },
    ];

    /// Short name (`linear`, `linear+noise`, `bouncing`, `bouncing+noise`).
    pub fn name(self) -> &'static str {
        match (self.motion, self.noisy) {
            (BallMotion::Linear, false) => "linear",
            (BallMotion::Linear, true) => "linear+noise",
            (BallMotion::Bouncing, false) => "bouncing",
            (BallMotion::Bouncing, true) => "bouncing+noise",
        }
    }
}

/// Which motion model the trackers get.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The model of the scene: linear for linear scenes, bouncing (with the
    /// scene's gravity) for bouncing ones.
    Matched,
    /// Always the linear model.
    Linear,
}

/// Whether the scene adds the webcam's effects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Webcam {
    /// Motion blur, flicker, auto-exposure, jitter and JPEG as their
    /// options say.
    On,
    /// Every webcam effect off: the clean scene.
    Off,
}
choice! { Webcam { On = "on", Off = "off" } }

choice! { ModelChoice { Matched = "matched", Linear = "linear" } }

/// Longest run an option may ask for, seconds of video (a day).
pub const MAX_SECONDS: f64 = 86_400.0;

/// Shortest run an option may ask for, seconds of video (22 camera
/// frames): a run of a few frames leaves a slow filter in real time
/// without a frame to score.
pub const MIN_SECONDS: f64 = 1.0;

/// Widest search margin an option may ask for, px (wider than any frame).
pub const MAX_SEARCH_MARGIN: usize = 4096;

/// The cross-option rules: a ball is found only inside the radius where it
/// is lost, and the trackers' settings must be ones they accept.
pub(super) fn check(o: &BallOptions) -> Result<(), String> {
    // the UKF's weights for the ball's 4-dimensional state (x, y, vx, vy):
    // what the tracker computes on its first frame, checked now, each
    // refusal naming the option at fault
    let short = bayestrack_otb::ground_truth::short_number;
    let (alpha, kappa) = (o.ukf_alpha, o.ukf_kappa);
    if 4.0 + kappa <= 0.0 {
        return Err(format!(
            "ukf_kappa must be above -4 (it is {}): the ball's state has 4 dimensions and the \
             UKF needs alpha^2 (4 + kappa) > 0",
            short(kappa)
        ));
    }
    let spread = alpha * alpha * (4.0 + kappa);
    let weights = bayestrack_kalman::Ukf::new(alpha, o.ukf_beta, kappa)
        .and_then(|u| u.weights(4))
        .ok()
        .filter(|(wm0, wc0, wi)| [wm0, wc0, wi].iter().all(|w| w.is_finite()));
    if !spread.is_normal() || weights.is_none() {
        return Err(format!(
            "ukf_alpha {} is too small for kappa {}: alpha^2 (4 + kappa) = {} and the UKF's \
             sigma-point weights 1 / (2 alpha^2 (4 + kappa)) overflow",
            short(alpha),
            short(kappa),
            short(spread)
        ));
    }
    if o.found_radius > o.lost_radius {
        return Err("found_radius must be at most lost_radius".into());
    }
    if o.sweep_speeds.len() > 64 || o.sweep_noises.len() > 64 {
        return Err("a sweep list has at most 64 values".into());
    }
    o.tracker_config(Condition::ALL[0])
        .validate()
        .map_err(|e| e.to_string())
}

options! {
    /// Every choice of the experiment, at paper scale by default (40
    /// experiments of 10 minutes: 10 runs per condition).
    #[derive(Debug, Clone, PartialEq)]
    pub struct BallOptions {
        /// Runs per condition (four conditions; 10: paper 001's 40
        /// experiments).
        pub runs: usize = 10, in 1..=MAX_RUNS;
        /// Length of a run in seconds of video (600: the paper's 10
        /// minutes).
        pub seconds: f64 = 600.0, in MIN_SECONDS..=MAX_SECONDS;
        /// Seed of the whole experiment.
        pub seed: u64 = 1;
        /// Motion noise of the noisy linear condition, px/frame per axis
        /// (1): the scene restores the speed after each kick, so only the
        /// heading wanders.
        pub motion_noise: f64 = 1.0, in 0.0..=10.0;
        /// Motion noise of the noisy bouncing condition, px/frame per axis
        /// (0.05): the scene keeps the kicks, so the velocity random-walks
        /// (std `0.05 sqrt(n)` px/frame after `n` frames, 5.7 after 10
        /// minutes).
        pub bounce_noise: f64 = 0.05, in 0.0..=10.0;
        /// Centre error (px) beyond which the ball counts as lost (20: the
        /// ball's diameter).
        pub lost_radius: f64 = 20.0, in above(0.0);
        /// Centre error (px) at or below which a lost ball counts as found
        /// (10: the estimated centre lies on the ball; at most
        /// `lost_radius`).
        pub found_radius: f64 = 10.0, in above(0.0);
        /// Whether a real-time tracker is told how many camera frames
        /// passed since the frame it saw last (else it assumes one).
        pub rt_elapsed: bool = true;
        /// Which motion model the trackers get (`matched`: the scene's).
        pub model: ModelChoice = ModelChoice::Matched;
        /// The trackers' acceleration noise (the ball tracker's default).
        pub acceleration_noise: f64 = BallConfig::default().acceleration_noise;
        /// The trackers' initial speed, px/frame (the ball tracker's
        /// default).
        pub initial_speed: f64 = BallConfig::default().initial_speed;
        /// The Kalman trackers' measurement noise (the ball tracker's
        /// default).
        pub measurement_noise: f64 = BallConfig::default().measurement_noise;
        /// Search margin around the prediction, px (the ball tracker's
        /// default).
        pub search_margin: usize = BallConfig::default().search_margin, in 0..=MAX_SEARCH_MARGIN;
        /// Width of the PFs' histogram likelihood (the ball tracker's
        /// default).
        pub likelihood_sigma: f64 = BallConfig::default().likelihood_sigma;
        /// Histogram distance beyond which a tracker reports itself lost
        /// (the ball tracker's default).
        pub lost_distance: f64 = BallConfig::default().lost_distance;
        /// Histogram bins per channel (the ball tracker's default).
        pub bins: usize = BallConfig::default().bins, in 1..=256;
        /// The UKF's `alpha` (the ball tracker's default).
        pub ukf_alpha: f64 = BallConfig::default().ukf_alpha;
        /// The UKF's `beta` (the ball tracker's default).
        pub ukf_beta: f64 = BallConfig::default().ukf_beta;
        /// The UKF's `kappa` (the ball tracker's default).
        pub ukf_kappa: f64 = BallConfig::default().ukf_kappa;
        /// The evaluation budget of the KF and UKF run beside the
        /// exhaustive ones (see [`Budget`]; `paper`, `off` or a count).
        pub budget: Budget = Budget::Paper;
        /// Ball speed, px/frame (3: the scene's default).
        pub speed: f64 = 3.0, in 0.0..=40.0;
        /// Webcam motion blur: shutter open for this fraction of the frame
        /// interval (0.5: an indoor webcam at 22 fps exposes 1/50 to 1/30 s
        /// of its 1/22 s frame, 0.44 to 0.73).
        pub exposure: f64 = 0.5, in 0.0..=1.0;
        /// Webcam flicker: relative std of the per-frame light (0.02: the
        /// screen's refresh and the room's mains light beating against the
        /// camera's 22 fps, a few percent).
        pub flicker: f64 = 0.02, in 0.0..=0.5;
        /// Webcam auto-exposure time constant, s (0.5: consumer webcams
        /// settle in about a second; 0 turns it off).
        pub auto_exposure: f64 = 0.5, in 0.0..=1e6;
        /// Webcam frame-time jitter, std in ms (3: USB webcam frame
        /// timestamps scatter by a few ms, 7% of the 45 ms interval).
        pub frame_jitter: f64 = 3.0, in 0.0..=1000.0;
        /// Webcam JPEG quality, 0 for none (75: the IJG/libjpeg default, and
        /// a webcam streaming MJPEG at 200x160 compresses its frames).
        pub jpeg_quality: u8 = 75, in 0..=100;
        /// `off` turns every webcam effect off (the five above read as 0).
        pub webcam: Webcam = Webcam::On;
        /// Whether to run the speed x motion-noise sweep
        /// ([`BallOptions::sweep_speeds`] x [`BallOptions::sweep_noises`],
        /// linear motion; default: in `--full` only).
        pub sweep: bool = true;
        /// Ball speeds of the sweep, px/frame (2, 3, 5, 8; paper 001 ran its
        /// ball "with different speeds").
        pub sweep_speeds: Vec<f64> = vec![2.0, 3.0, 5.0, 8.0], in Each(0.0..=40.0);
        /// Motion-noise levels of the sweep, px/frame per axis (0, 0.5, 1,
        /// 2; "different levels of additive noises").
        pub sweep_noises: Vec<f64> = vec![0.0, 0.5, 1.0, 2.0], in Each(0.0..=10.0);
        /// Runs per sweep cell (2), each [`BallOptions::sweep_seconds`] long.
        pub sweep_runs: usize = 2, in 1..=MAX_RUNS;
        /// Length of a sweep run, s (60).
        pub sweep_seconds: f64 = 60.0, in MIN_SECONDS..=MAX_SECONDS;
        /// Measure the trackers' wall-clock time (the `ours wall fps`
        /// column); `false` records 0 s, so that two runs write
        /// byte-identical files.
        pub timing: bool = true;
    }
    check check;
}

/// The evaluation budget of the KF and UKF: how many histogram windows they
/// may evaluate per frame (the PFs evaluate their `N` particles, their
/// budget by construction).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Budget {
    /// No budgeted KF/UKF (only the exhaustive search).
    Off,
    /// What paper 001's measured fps allowed: a frame costs
    /// `a + b N` s, `a` and `b` fitted to the PF10 and PF70 fps (50.8 ms and
    /// 1.25 ms per particle), so a tracker at `fps` can afford
    /// `floor((1 / fps - a) / b)` evaluations: 37 for the KF (10.28 fps)
    /// and the UKF (10.19 fps). See [`paper_budget`].
    Paper,
    /// The same cap for the KF and the UKF.
    Fixed(usize),
}

/// The per-frame cost model of paper 001's trackers, fitted to the fps of
/// PF10 and PF70: `(a, b)` with a frame costing `a + b N` s.
pub fn paper_cost_model() -> (f64, f64) {
    let t = |n| paper_row(BallFilter::Pf(n)).map_or(f64::NAN, |p| 1.0 / p.fps);
    let b = (t(70) - t(10)) / 60.0;
    (t(10) - 10.0 * b, b)
}

/// The histogram evaluations per frame paper 001's fps allowed `filter`
/// (`N` for a PF; from [`paper_cost_model`] for the KF and UKF).
pub fn paper_budget(filter: BallFilter) -> Option<usize> {
    match filter {
        BallFilter::Pf(n) => Some(n),
        _ => {
            let (a, b) = paper_cost_model();
            let fps = paper_row(filter)?.fps;
            let n = ((1.0 / fps - a) / b).floor();
            (n.is_finite() && n >= 1.0).then_some(n as usize)
        }
    }
}

impl OptionValue for Budget {
    const TYPE: &'static str = "Budget";
    fn parse_option(s: &str) -> Option<Self> {
        match s.trim() {
            "paper" => Some(Budget::Paper),
            "off" => Some(Budget::Off),
            n => n
                .parse()
                .ok()
                .filter(|n| (1..=MAX_RUNS).contains(n))
                .map(Budget::Fixed),
        }
    }
    fn format_option(&self) -> String {
        match self {
            Budget::Paper => "paper".into(),
            Budget::Off => "off".into(),
            Budget::Fixed(n) => n.to_string(),
        }
    }
    fn domain() -> String {
        format!("paper|off|1..={MAX_RUNS} windows")
    }
}

impl Budget {
    /// The cap of a KF or UKF, `None` for the PFs and when off.
    pub fn cap(self, filter: BallFilter) -> Option<usize> {
        match (self, filter) {
            (_, BallFilter::Pf(_)) | (Budget::Off, _) => None,
            (Budget::Paper, f) => paper_budget(f),
            (Budget::Fixed(n), _) => Some(n),
        }
    }
}

impl BallOptions {
    /// Paper scale: 40 experiments of 10 minutes (10 runs per condition).
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: one run of 20 s per condition, no sweep.
    pub fn quick() -> Self {
        Self {
            runs: 1,
            seconds: 20.0,
            sweep: false,
            ..Self::paper()
        }
    }

    /// Turns every webcam effect off: the clean scene (`webcam=off`).
    pub fn clean_camera(&mut self) {
        self.webcam = Webcam::Off;
    }

    /// Frames per run.
    pub fn frames(&self) -> usize {
        ((self.seconds * CAMERA_FPS).round() as usize).max(2)
    }

    /// Applies a `key=value` override (see [`Options::set`]).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or a bad value,
    /// listing every key with its domain.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        crate::driver::apply(ID, self, key, value)
    }

    /// Every option as `key=value`, for the table footer.
    pub fn describe(&self) -> String {
        Options::describe(self)
    }

    /// The scene of a condition.
    pub fn scene(&self, condition: Condition) -> BallScene {
        let on = self.webcam == Webcam::On;
        let cam = |v: f64| if on { v } else { 0.0 };
        BallScene {
            frames: self.frames(),
            motion: condition.motion,
            speed: self.speed,
            motion_noise: match (condition.noisy, condition.motion) {
                (false, _) => 0.0,
                (true, BallMotion::Linear) => self.motion_noise,
                (true, BallMotion::Bouncing) => self.bounce_noise,
            },
            exposure: cam(self.exposure),
            flicker: cam(self.flicker),
            auto_exposure: cam(self.auto_exposure),
            frame_jitter: cam(self.frame_jitter),
            jpeg_quality: if on { self.jpeg_quality } else { 0 },
            ..BallScene::default()
        }
    }

    /// The tracker configuration of a condition.
    pub fn tracker_config(&self, condition: Condition) -> BallConfig {
        let motion = match (self.model, condition.motion) {
            (ModelChoice::Matched, BallMotion::Bouncing) => MotionModel::Bouncing {
                gravity: BallScene::default().gravity,
            },
            _ => MotionModel::Linear,
        };
        BallConfig {
            motion,
            acceleration_noise: self.acceleration_noise,
            initial_speed: self.initial_speed,
            measurement_noise: self.measurement_noise,
            search_margin: self.search_margin,
            likelihood_sigma: self.likelihood_sigma,
            lost_distance: self.lost_distance,
            bins: self.bins,
            ukf_alpha: self.ukf_alpha,
            ukf_beta: self.ukf_beta,
            ukf_kappa: self.ukf_kappa,
            ..BallConfig::default()
        }
    }
}
