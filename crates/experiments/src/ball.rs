//! The `ball` experiment: paper 001 (Bocsi and Csato) Tables 1-3 on the
//! synthetic ball screen ([`BallScene`]).
//!
//! Five trackers (PF10, PF30, PF70, KF, UKF; `bayestrack-trackers`'
//! [`BallTracker`]) follow a black ball on a white screen, 200x160 at
//! 22 fps, in four conditions: linear or bouncing motion, each without and
//! with motion noise ([`BallOptions::motion_noise`],
//! [`BallOptions::bounce_noise`]). Every condition has
//! [`BallOptions::runs`] runs of [`BallOptions::seconds`] seconds; each run
//! renders one scene and drives every tracker through it twice:
//!
//! - **offline**: every frame is processed;
//! - **real time**: the camera delivers a frame every 1/22 s and the tracker
//!   needs `1 / fps_paper` seconds per frame (its row of paper 001 Table 1);
//!   when it finishes it takes the newest frame that has arrived (waiting
//!   for the next one if none has), so the frames that arrive while it
//!   computes, all but the newest, are never seen
//!   ([`crate::scenes::SceneStream::skip_frame`]), and it sees
//!   `fps_paper` frames per second as the paper's fps column defines it
//!   ("the algorithm could look at the screen the given number of times in
//!   a second"). The tracker is told how many camera frames passed
//!   ([`BallOptions::rt_elapsed`]).
//!
//! # Lost and found
//! Scored against the ground truth on the frames a tracker processes: the
//! ball is **lost** at the first processed frame whose centre error exceeds
//! [`BallOptions::lost_radius`] (20 px: the ball's diameter, the estimated
//! box no longer touches the ball), and **found** again at the first later
//! processed frame whose error is at most [`BallOptions::found_radius`]
//! (10 px: the estimated centre lies on the ball). "lost" counts losses per
//! 10 minutes of video (the paper's experiments lasted 10 minutes);
//! "found" is the mean time in seconds from a loss to its re-finding, over
//! the losses that were re-found before the run ended; "error" is the mean
//! centre error in px over every processed frame (lost ones included).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use bayestrack_image::Image;
use bayestrack_particle::stream_seed;
use bayestrack_trackers::{BallConfig, BallFilter, BallTracker, MotionModel, Tracker};
use rayon::prelude::*;

use crate::experiment::{Experiment, ExperimentError, MAX_RUNS, Mode, RunOptions, write_text};
use crate::scenes::{BallMotion, BallScene, SceneStream};
use bayestrack_otb::Table;
use bayestrack_otb::metrics::center_error;
use bayestrack_otb::plot::{Series, line_chart};
use bayestrack_otb::write::PartialCsv;

/// Key of this experiment's random streams ("ball" in ASCII).
const KEY: u64 = 0x6261_6c6c;

/// Camera rate of paper 001 (frames per second).
const CAMERA_FPS: f64 = 22.0;

/// One row of paper 001: Table 1 (fps, error, lost, found), Table 2 (lost
/// without / with noise), Table 3 (lost linear / non-linear).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperRow {
    /// Frames per second.
    pub fps: f64,
    /// Error (px).
    pub error: f64,
    /// Times the ball was lost.
    pub lost: f64,
    /// Time to find it again.
    pub found: f64,
    /// Table 2: lost without and with motion noise.
    pub noise: [f64; 2],
    /// Table 3: lost with linear and non-linear motion.
    pub motion: [f64; 2],
}

/// Paper 001's cells for a tracker (SPEC section 3 `ball`).
pub fn paper_row(filter: BallFilter) -> Option<PaperRow> {
    let row = |fps, error, lost, found, noise, motion| PaperRow {
        fps,
        error,
        lost,
        found,
        noise,
        motion,
    };
    match filter {
        BallFilter::Pf(10) => Some(row(15.81, 11.31, 1.25, 6.25, [1.5, 1.0], [1.0, 1.5])),
        BallFilter::Pf(30) => Some(row(10.71, 12.28, 11.75, 5.67, [11.5, 12.0], [12.5, 11.0])),
        BallFilter::Pf(70) => Some(row(7.24, 15.69, 18.25, 4.41, [20.5, 16.0], [20.0, 16.5])),
        BallFilter::Kf => Some(row(10.28, 8.57, 7.5, 8.02, [5.5, 9.5], [2.0, 13.0])),
        BallFilter::Ukf => Some(row(10.19, 8.52, 4.0, 8.87, [3.0, 5.0], [1.5, 6.5])),
        BallFilter::Pf(_) => None,
    }
}

/// Offline (every frame) or real time (frames dropped while computing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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

/// Every choice of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct BallOptions {
    /// Runs per condition (four conditions).
    pub runs: usize,
    /// Length of a run in seconds of video.
    pub seconds: f64,
    /// Motion noise of the noisy linear condition, px/frame per axis (1):
    /// the scene restores the speed after each kick, so only the heading
    /// wanders.
    pub motion_noise: f64,
    /// Motion noise of the noisy bouncing condition, px/frame per axis
    /// (0.05): the scene keeps the kicks, so the velocity random-walks
    /// (std `0.05 sqrt(n)` px/frame after `n` frames, 5.7 after 10 minutes).
    pub bounce_noise: f64,
    /// The trackers' parameters (their motion model is set per condition).
    pub tracker: BallConfig,
    /// Which motion model the trackers get.
    pub model: ModelChoice,
    /// Whether a real-time tracker is told how many camera frames passed
    /// since the frame it saw last (else it assumes one).
    pub rt_elapsed: bool,
    /// Centre error (px) beyond which the ball counts as lost (20).
    pub lost_radius: f64,
    /// Centre error (px) at or below which a lost ball counts as found (10).
    pub found_radius: f64,
    /// Seed of the whole experiment.
    pub seed: u64,
}

impl BallOptions {
    /// Paper scale: 40 experiments of 10 minutes (10 runs per condition).
    pub fn paper() -> Self {
        Self {
            runs: 10,
            seconds: 600.0,
            motion_noise: 1.0,
            bounce_noise: 0.05,
            tracker: BallConfig::default(),
            model: ModelChoice::Matched,
            rt_elapsed: true,
            lost_radius: 20.0,
            found_radius: 10.0,
            seed: 1,
        }
    }

    /// The CI scale: one run of 20 s per condition.
    pub fn quick() -> Self {
        Self {
            runs: 1,
            seconds: 20.0,
            ..Self::paper()
        }
    }

    /// Frames per run.
    pub fn frames(&self) -> usize {
        ((self.seconds * CAMERA_FPS).round() as usize).max(2)
    }

    /// The keys [`BallOptions::apply`] accepts, with their domains (listed
    /// by [`ExperimentError::BadOption`]).
    pub const KEYS: &'static str = "runs (1..=100000), seconds (> 0, at most 86400: a day), \
        seed (u64), motion_noise (>= 0), bounce_noise (>= 0), lost_radius (> 0), \
        found_radius (> 0, at most lost_radius), rt_elapsed (true|false), \
        model (matched|linear), acceleration_noise (> 0), initial_speed (> 0), \
        measurement_noise (> 0), search_margin (0..=4096 px), likelihood_sigma (> 0), \
        lost_distance (> 0), bins (1..=256), ukf_alpha (> 0), ukf_beta (finite), \
        ukf_kappa (finite)";

    /// Longest run an option may ask for, seconds of video (a day).
    pub const MAX_SECONDS: f64 = 86_400.0;

    /// Widest search margin an option may ask for, px (wider than any frame).
    pub const MAX_SEARCH_MARGIN: usize = 4096;

    /// Applies a `key=value` override.
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or a bad value.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        let bad = || ExperimentError::bad_option("ball", Self::KEYS, key, value);
        let num = || value.parse::<f64>().map_err(|_| bad());
        let int = || value.parse::<usize>().map_err(|_| bad());
        let t = &mut self.tracker;
        match key {
            "runs" => self.runs = int()?,
            "seconds" => self.seconds = num()?,
            "seed" => self.seed = value.parse().map_err(|_| bad())?,
            "motion_noise" => self.motion_noise = num()?,
            "bounce_noise" => self.bounce_noise = num()?,
            "lost_radius" => self.lost_radius = num()?,
            "found_radius" => self.found_radius = num()?,
            "rt_elapsed" => self.rt_elapsed = value.parse().map_err(|_| bad())?,
            "model" => {
                self.model = match value {
                    "matched" => ModelChoice::Matched,
                    "linear" => ModelChoice::Linear,
                    _ => return Err(bad()),
                }
            }
            "acceleration_noise" => t.acceleration_noise = num()?,
            "initial_speed" => t.initial_speed = num()?,
            "measurement_noise" => t.measurement_noise = num()?,
            "search_margin" => t.search_margin = int()?,
            "likelihood_sigma" => t.likelihood_sigma = num()?,
            "lost_distance" => t.lost_distance = num()?,
            "bins" => t.bins = int()?,
            "ukf_alpha" => t.ukf_alpha = num()?,
            "ukf_beta" => t.ukf_beta = num()?,
            "ukf_kappa" => t.ukf_kappa = num()?,
            _ => return Err(bad()),
        }
        let ok_num = |v: f64| v.is_finite() && v > 0.0;
        let ok_noise = |v: f64| v.is_finite() && v >= 0.0;
        if !(1..=MAX_RUNS).contains(&self.runs)
            || !ok_num(self.seconds)
            || self.seconds > Self::MAX_SECONDS
            || t.search_margin > Self::MAX_SEARCH_MARGIN
            || !ok_noise(self.motion_noise)
            || !ok_noise(self.bounce_noise)
            || !ok_num(self.lost_radius)
            || !ok_num(self.found_radius)
            || self.found_radius > self.lost_radius
            || t.validate().is_err()
        {
            return Err(bad());
        }
        Ok(())
    }

    /// One line with every option, for the table footer.
    pub fn describe(&self) -> String {
        let t = &self.tracker;
        format!(
            "runs={}x4 seconds={} motion_noise={} bounce_noise={} model={:?} rt_elapsed={} lost_radius={} \
             found_radius={} acceleration_noise={} initial_speed={} measurement_noise={} \
             search_margin={} likelihood_sigma={} lost_distance={} bins={} ukf=({}, {}, {}) seed={}",
            self.runs,
            self.seconds,
            self.motion_noise,
            self.bounce_noise,
            self.model,
            self.rt_elapsed,
            self.lost_radius,
            self.found_radius,
            t.acceleration_noise,
            t.initial_speed,
            t.measurement_noise,
            t.search_margin,
            t.likelihood_sigma,
            t.lost_distance,
            t.bins,
            t.ukf_alpha,
            t.ukf_beta,
            t.ukf_kappa,
            self.seed
        )
    }

    /// The scene of a condition.
    pub fn scene(&self, condition: Condition) -> BallScene {
        BallScene {
            frames: self.frames(),
            motion: condition.motion,
            motion_noise: match (condition.noisy, condition.motion) {
                (false, _) => 0.0,
                (true, BallMotion::Linear) => self.motion_noise,
                (true, BallMotion::Bouncing) => self.bounce_noise,
            },
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
            ..self.tracker
        }
    }
}

/// What one tracker did in one run, in one mode.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackOutcome {
    /// Which tracker.
    pub filter: BallFilter,
    /// Offline or real time.
    pub mode: FrameMode,
    /// Frames processed (after the initial one).
    pub frames: usize,
    /// Sum of the centre errors over the processed frames (px).
    pub error_sum: f64,
    /// Losses (see the module docs).
    pub losses: usize,
    /// Time from each re-found loss to its re-finding (s).
    pub found_times: Vec<f64>,
    /// Losses not re-found before the end of the run.
    pub unresolved: usize,
    /// Processed frames in which the tracker reported itself lost.
    pub self_lost: usize,
    /// Wall-clock seconds spent in `step` (not deterministic; never pinned).
    pub wall: f64,
    /// `(time, centre error)` of every processed frame (first run of a
    /// condition only, for the figure).
    pub trace: Vec<(f64, f64)>,
}

/// Every outcome of one run of one condition.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// The condition.
    pub condition: Condition,
    /// Run index within the condition.
    pub run: usize,
    /// Seconds of video.
    pub seconds: f64,
    /// One outcome per tracker and mode: `BallFilter::PAPER` x `FrameMode::ALL`.
    pub outcomes: Vec<TrackOutcome>,
}

/// The loss / found bookkeeping of one tracker.
#[derive(Debug, Clone, Default)]
struct Scorer {
    lost_since: Option<f64>,
}

/// Time of the next frame a real-time tracker processes after starting
/// frame `k` at `start` (s); returns `(next frame index, start time of next)`.
fn next_realtime(k: usize, start: f64, cost: f64) -> (usize, f64) {
    let done = start + cost;
    // Newest frame that has arrived by `done` (1e-9 s of slack for round-off).
    let newest = ((done + 1e-9) * CAMERA_FPS).floor() as usize;
    let next = newest.max(k + 1);
    let arrival = next as f64 / CAMERA_FPS;
    (next, done.max(arrival))
}

fn failed(
    filter: BallFilter,
    c: Condition,
    run: usize,
    e: impl std::fmt::Display,
) -> ExperimentError {
    ExperimentError::Failed {
        id: "ball",
        message: format!("{} failed on {} run {run}: {e}", filter.label(), c.name()),
    }
}

/// One tracker in one mode during a run.
struct Lane {
    tracker: BallTracker,
    mode: FrameMode,
    /// Next frame to process, and when processing can start (s).
    next: usize,
    start: f64,
    cost: f64,
    last_seen: usize,
    scorer: Scorer,
    out: TrackOutcome,
}

/// Runs every tracker in both modes on run `run` of `condition`.
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, condition and run.
pub fn run_one(
    opts: &BallOptions,
    condition: Condition,
    run: usize,
    trace: bool,
) -> Result<RunResult, ExperimentError> {
    let cond_index = Condition::ALL
        .iter()
        .position(|c| *c == condition)
        .unwrap_or(0) as u64;
    let scene_seed = stream_seed(&[KEY, opts.seed, cond_index, run as u64]);
    let scene = opts.scene(condition);
    let mut stream = scene
        .stream(scene_seed)
        .map_err(|e| ExperimentError::Failed {
            id: "ball",
            message: format!("scene {}: {e}", condition.name()),
        })?;
    let config = opts.tracker_config(condition);
    let mut frame =
        Image::new(scene.width, scene.height, 3, 0u8).map_err(|e| ExperimentError::Failed {
            id: "ball",
            message: e.to_string(),
        })?;
    let Some(truth0) = stream.next_into(&mut frame) else {
        return Err(ExperimentError::Failed {
            id: "ball",
            message: "empty scene".to_string(),
        });
    };
    let Some(box0) = truth0.target().map(|o| o.bbox) else {
        return Err(ExperimentError::Failed {
            id: "ball",
            message: "scene without a ball".to_string(),
        });
    };
    let mut lanes = Vec::new();
    for (m, mode) in FrameMode::ALL.into_iter().enumerate() {
        for (f, filter) in BallFilter::PAPER.into_iter().enumerate() {
            let seed = stream_seed(&[KEY, opts.seed, cond_index, run as u64, f as u64, m as u64]);
            let mut tracker = BallTracker::new(filter, config, seed)
                .map_err(|e| failed(filter, condition, run, e))?;
            tracker
                .init(frame.view(), box0)
                .map_err(|e| failed(filter, condition, run, e))?;
            let cost = paper_row(filter).map_or(0.0, |p| 1.0 / p.fps);
            let (next, start) = match mode {
                FrameMode::Offline => (1, 0.0),
                FrameMode::RealTime => next_realtime(0, 0.0, cost),
            };
            lanes.push(Lane {
                tracker,
                mode,
                next,
                start,
                cost,
                last_seen: 0,
                scorer: Scorer::default(),
                out: TrackOutcome {
                    filter,
                    mode,
                    frames: 0,
                    error_sum: 0.0,
                    losses: 0,
                    found_times: Vec::new(),
                    unresolved: 0,
                    self_lost: 0,
                    wall: 0.0,
                    trace: Vec::new(),
                },
            });
        }
    }
    for k in 1..scene.frames {
        let wanted = lanes.iter().any(|l| l.next == k);
        let truth = if wanted {
            stream.next_into(&mut frame)
        } else {
            stream.skip_frame()
        };
        let Some(truth) = truth else { break };
        if !wanted {
            continue;
        }
        let Some(ball) = truth.target().map(|o| o.bbox) else {
            continue;
        };
        for lane in lanes.iter_mut().filter(|l| l.next == k) {
            let filter = lane.out.filter;
            let dt = if lane.mode == FrameMode::RealTime && !opts.rt_elapsed {
                1.0
            } else {
                (k - lane.last_seen) as f64
            };
            let t0 = Instant::now();
            let est = lane
                .tracker
                .step_elapsed(frame.view(), dt)
                .map_err(|e| failed(filter, condition, run, e))?;
            lane.out.wall += t0.elapsed().as_secs_f64();
            lane.last_seen = k;
            let err = center_error(&est.bbox, &ball);
            let out = &mut lane.out;
            out.frames += 1;
            out.error_sum += err;
            out.self_lost += usize::from(est.lost);
            if trace {
                out.trace.push((truth.time, err));
            }
            match lane.scorer.lost_since {
                None if err > opts.lost_radius => {
                    out.losses += 1;
                    lane.scorer.lost_since = Some(truth.time);
                }
                Some(since) if err <= opts.found_radius => {
                    out.found_times.push(truth.time - since);
                    lane.scorer.lost_since = None;
                }
                _ => {}
            }
            match lane.mode {
                FrameMode::Offline => lane.next = k + 1,
                FrameMode::RealTime => {
                    let (next, start) = next_realtime(k, lane.start, lane.cost);
                    lane.next = next;
                    lane.start = start;
                }
            }
        }
    }
    Ok(RunResult {
        condition,
        run,
        seconds: opts.frames() as f64 / CAMERA_FPS,
        outcomes: lanes
            .into_iter()
            .map(|mut l| {
                l.out.unresolved = usize::from(l.scorer.lost_since.is_some());
                l.out
            })
            .collect(),
    })
}

/// Pooled numbers of one tracker in one mode over a set of runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Which tracker.
    pub filter: BallFilter,
    /// Offline or real time.
    pub mode: FrameMode,
    /// Runs pooled.
    pub runs: usize,
    /// Frames processed per second of video.
    pub frames_per_second: f64,
    /// Mean centre error over the processed frames (px).
    pub error: f64,
    /// Losses per 10 minutes of video.
    pub lost_per_10min: f64,
    /// Total losses.
    pub losses: usize,
    /// Mean time to re-find (s), `NaN` when no loss was re-found.
    pub found: f64,
    /// Losses never re-found.
    pub unresolved: usize,
    /// Fraction of processed frames in which the tracker said it was lost.
    pub self_lost: f64,
    /// Wall-clock frames per second of our implementation (not pinned).
    pub wall_fps: f64,
}

/// Every run of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct BallResult {
    /// The options that produced it.
    pub options: BallOptions,
    /// Every run, conditions in [`Condition::ALL`] order.
    pub runs: Vec<RunResult>,
}

impl BallResult {
    /// The pooled summary of `filter` in `mode` over the runs whose
    /// condition passes `keep`.
    pub fn summary(
        &self,
        filter: BallFilter,
        mode: FrameMode,
        keep: impl Fn(Condition) -> bool,
    ) -> Summary {
        let (mut runs, mut frames, mut err, mut losses, mut unresolved, mut self_lost) =
            (0, 0, 0.0, 0, 0, 0);
        let (mut seconds, mut wall) = (0.0, 0.0);
        let mut found = Vec::new();
        for r in self.runs.iter().filter(|r| keep(r.condition)) {
            for o in r
                .outcomes
                .iter()
                .filter(|o| o.filter == filter && o.mode == mode)
            {
                runs += 1;
                frames += o.frames;
                err += o.error_sum;
                losses += o.losses;
                unresolved += o.unresolved;
                self_lost += o.self_lost;
                found.extend_from_slice(&o.found_times);
                seconds += r.seconds;
                wall += o.wall;
            }
        }
        let nf = frames.max(1) as f64;
        Summary {
            filter,
            mode,
            runs,
            frames_per_second: frames as f64 / seconds.max(1e-12),
            error: err / nf,
            lost_per_10min: losses as f64 * 600.0 / seconds.max(1e-12),
            losses,
            found: if found.is_empty() {
                f64::NAN
            } else {
                found.iter().sum::<f64>() / found.len() as f64
            },
            unresolved,
            self_lost: self_lost as f64 / nf,
            wall_fps: frames as f64 / wall.max(1e-12),
        }
    }

    /// Summary over every condition.
    pub fn overall(&self, filter: BallFilter, mode: FrameMode) -> Summary {
        self.summary(filter, mode, |_| true)
    }

    /// Table 1 in one mode.
    pub fn table1(&self, mode: FrameMode) -> Table {
        let n = self.runs.len();
        let mut t = Table::new(
            format!(
                "ball ({}): paper 001 Table 1 vs ours ({n} runs of {} s; lost per 10 min; found in s)",
                mode.name(),
                self.options.seconds
            ),
            &[
                "alg",
                "paper fps",
                "ours frames/s seen",
                "ours wall fps",
                "paper error",
                "ours error",
                "paper lost",
                "ours lost",
                "paper found",
                "ours found",
                "ours unresolved",
                "ours self-lost %",
            ],
        );
        for filter in BallFilter::PAPER {
            let s = self.overall(filter, mode);
            let p = paper_row(filter);
            t.push(vec![
                filter.label(),
                cell(p.map(|p| p.fps), 2),
                format!("{:.2}", s.frames_per_second),
                format!("{:.0}", s.wall_fps),
                cell(p.map(|p| p.error), 2),
                format!("{:.2}", s.error),
                cell(p.map(|p| p.lost), 2),
                format!("{:.2}", s.lost_per_10min),
                cell(p.map(|p| p.found), 2),
                cell(Some(s.found), 2),
                s.unresolved.to_string(),
                format!("{:.1}", 100.0 * s.self_lost),
            ]);
        }
        t
    }

    /// Table 2 (noise) or Table 3 (motion), both modes.
    pub fn table_split(&self, noise: bool) -> Table {
        let (title, a, b) = if noise {
            (
                "Table 2: lost without / with motion noise",
                "without",
                "with",
            )
        } else {
            (
                "Table 3: lost with linear / non-linear motion",
                "linear",
                "non-linear",
            )
        };
        let header: Vec<String> = vec![
            "alg".into(),
            format!("paper {a}"),
            format!("paper {b}"),
            format!("offline {a}"),
            format!("offline {b}"),
            format!("realtime {a}"),
            format!("realtime {b}"),
        ];
        let hdr: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut t = Table::new(format!("ball: paper 001 {title} (ours per 10 min)"), &hdr);
        for filter in BallFilter::PAPER {
            let p = paper_row(filter).map(|p| if noise { p.noise } else { p.motion });
            let mut row = vec![
                filter.label(),
                cell(p.map(|p| p[0]), 1),
                cell(p.map(|p| p[1]), 1),
            ];
            for mode in FrameMode::ALL {
                for second in [false, true] {
                    let s = self.summary(filter, mode, |c| {
                        if noise {
                            c.noisy == second
                        } else {
                            (c.motion == BallMotion::Bouncing) == second
                        }
                    });
                    row.push(format!("{:.2}", s.lost_per_10min));
                }
            }
            t.push(row);
        }
        t
    }

    /// The paper's findings and whether each mode reproduces them.
    pub fn findings(&self) -> Vec<Finding> {
        FINDINGS
            .iter()
            .map(|&(id, text, check)| Finding {
                id,
                text,
                offline: check(self, FrameMode::Offline),
                realtime: check(self, FrameMode::RealTime),
            })
            .collect()
    }

    /// The findings as a table.
    pub fn findings_table(&self) -> Table {
        let mut t = Table::new(
            "ball: paper 001 findings, reproduced? (offline / real time)",
            &["id", "finding", "offline", "realtime"],
        );
        let yn = |b: bool| if b { "yes" } else { "no" }.to_string();
        for f in self.findings() {
            t.push(vec![
                f.id.to_string(),
                f.text.to_string(),
                yn(f.offline),
                yn(f.realtime),
            ]);
        }
        t
    }
}

/// A finding of paper 001 and whether each mode reproduces it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Finding {
    /// Short id.
    pub id: &'static str,
    /// What the paper says.
    pub text: &'static str,
    /// Reproduced offline.
    pub offline: bool,
    /// Reproduced in real time.
    pub realtime: bool,
}

type Check = fn(&BallResult, FrameMode) -> bool;

fn lost(r: &BallResult, f: BallFilter, m: FrameMode) -> f64 {
    r.overall(f, m).lost_per_10min
}

fn lost_where(
    r: &BallResult,
    f: BallFilter,
    m: FrameMode,
    keep: impl Fn(Condition) -> bool,
) -> f64 {
    r.summary(f, m, keep).lost_per_10min
}

const PF10: BallFilter = BallFilter::Pf(10);
const PF30: BallFilter = BallFilter::Pf(30);
const PF70: BallFilter = BallFilter::Pf(70);
const KF: BallFilter = BallFilter::Kf;
const UKF: BallFilter = BallFilter::Ukf;

/// The findings of paper 001 sec. 3 that the tables support.
const FINDINGS: [(&str, &str, Check); 9] = [
    (
        "more_particles_lose_more",
        "more particles lost the ball more often: lost PF10 < PF30 < PF70",
        |r, m| lost(r, PF10, m) < lost(r, PF30, m) && lost(r, PF30, m) < lost(r, PF70, m),
    ),
    (
        "pf70_loses_more_than_pf30",
        "the largest particle set loses the ball more often than the middle one: lost PF70 > PF30",
        |r, m| lost(r, PF70, m) > lost(r, PF30, m),
    ),
    (
        "more_particles_find_faster",
        "more particles find the ball again faster: found PF70 < PF10",
        |r, m| r.overall(PF70, m).found < r.overall(PF10, m).found,
    ),
    (
        "pf10_loses_least",
        "PF10 lost the ball least, followed by the UKF and the KF",
        |r, m| {
            let l10 = lost(r, PF10, m);
            [PF30, PF70, KF, UKF].iter().all(|&f| l10 < lost(r, f, m))
                && lost(r, UKF, m) < lost(r, KF, m)
        },
    ),
    (
        "kalman_more_accurate",
        "KF and UKF are more accurate than every PF (error)",
        |r, m| {
            [KF, UKF].iter().all(|&k| {
                [PF10, PF30, PF70]
                    .iter()
                    .all(|&p| r.overall(k, m).error < r.overall(p, m).error)
            })
        },
    ),
    (
        "kalman_find_slower",
        "KF and UKF take longer than every PF to find the ball again",
        |r, m| {
            [KF, UKF].iter().all(|&k| {
                [PF10, PF30, PF70]
                    .iter()
                    .all(|&p| r.overall(k, m).found > r.overall(p, m).found)
            })
        },
    ),
    (
        "ukf_loses_less_than_kf",
        "the UKF loses the ball less often than the KF",
        |r, m| lost(r, UKF, m) < lost(r, KF, m),
    ),
    (
        "noise_hurts_kalman",
        "motion noise makes the KF and the UKF lose the ball more often",
        |r, m| {
            [KF, UKF]
                .iter()
                .all(|&k| lost_where(r, k, m, |c| c.noisy) > lost_where(r, k, m, |c| !c.noisy))
        },
    ),
    (
        "nonlinear_hurts_kf_most",
        "non-linear motion makes the KF lose the ball more often, and more often than the UKF",
        |r, m| {
            let bounce = |c: Condition| c.motion == BallMotion::Bouncing;
            lost_where(r, KF, m, bounce) > lost_where(r, KF, m, |c| !bounce(c))
                && lost_where(r, KF, m, bounce) > lost_where(r, UKF, m, bounce)
        },
    ),
];

fn cell(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "-".to_string(),
    }
}

/// The header of `runs.csv`.
const RUNS_HEADER: &str = "condition,run,alg,mode,frames,mean_error_px,losses,found_times_s,unresolved,self_lost_frames,wall_s";

/// The `runs.csv` rows of one finished (condition, run) pair.
fn run_rows(r: &RunResult) -> String {
    let mut text = String::new();
    for o in &r.outcomes {
        let found: Vec<String> = o.found_times.iter().map(|t| format!("{t:.4}")).collect();
        let _ = writeln!(
            text,
            "{},{},{},{},{},{:.6},{},{},{},{},{:.4}",
            r.condition.name(),
            r.run,
            o.filter.label(),
            o.mode.name(),
            o.frames,
            o.error_sum / o.frames.max(1) as f64,
            o.losses,
            found.join(";"),
            o.unresolved,
            o.self_lost,
            o.wall
        );
    }
    text
}

/// Runs the experiment: every (condition, run) pair in parallel (each has
/// its own seeded streams, so the result does not depend on the thread
/// count). With `runs_csv`, each pair's rows are appended to
/// `runs.partial.csv` beside it the moment the pair finishes, and the
/// complete file, in (condition, run) order, replaces `runs_csv` at the end
/// (see [`PartialCsv`]): a run killed part-way keeps every finished pair
/// and the previous `runs.csv`.
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, condition and run that
/// failed; [`ExperimentError::Io`] when the CSV cannot be written.
pub fn run(
    opts: &BallOptions,
    runs_csv: Option<&Path>,
    progress: bool,
) -> Result<BallResult, ExperimentError> {
    if opts.runs == 0 {
        return Err(ExperimentError::bad_option(
            "ball",
            BallOptions::KEYS,
            "runs",
            "0",
        ));
    }
    let log = runs_csv
        .map(|path| PartialCsv::create(path, RUNS_HEADER))
        .transpose()?;
    let jobs: Vec<(Condition, usize)> = (0..opts.runs)
        .flat_map(|r| Condition::ALL.into_iter().map(move |c| (c, r)))
        .collect();
    let bar = if progress {
        indicatif::ProgressBar::new(jobs.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut runs: Vec<RunResult> = jobs
        .par_iter()
        .map(|&(c, r)| {
            let done = run_one(opts, c, r, r == 0)?;
            if let Some(log) = &log {
                log.append(&run_rows(&done))?;
            }
            bar.inc(1);
            Ok(done)
        })
        .collect::<Result<_, ExperimentError>>()?;
    bar.finish_and_clear();
    // conditions in Condition::ALL order, runs in order within each
    runs.sort_by_key(|r| (Condition::ALL.iter().position(|c| *c == r.condition), r.run));
    if let Some(log) = log {
        let mut text = format!("{RUNS_HEADER}\n");
        runs.iter().for_each(|r| text.push_str(&run_rows(r)));
        log.finish(&text)?;
    }
    Ok(BallResult {
        options: opts.clone(),
        runs,
    })
}

/// Writes the table CSVs and the error-over-time figures.
fn write_outputs(result: &BallResult, dir: &Path, tables: &[Table]) -> Result<(), ExperimentError> {
    let names = [
        "table1_offline",
        "table1_realtime",
        "table2",
        "table3",
        "findings",
    ];
    for (name, t) in names.iter().zip(tables) {
        let path = dir.join(format!("{name}.csv"));
        write_text(&path, &t.to_csv())?;
    }
    // Error over time, first run of the noisy bouncing condition.
    let shown = Condition {
        motion: BallMotion::Bouncing,
        noisy: true,
    };
    if let Some(r) = result
        .runs
        .iter()
        .find(|r| r.condition == shown && r.run == 0)
    {
        for mode in FrameMode::ALL {
            let series: Vec<Series> = r
                .outcomes
                .iter()
                .filter(|o| o.mode == mode)
                .map(|o| Series {
                    name: o.filter.label(),
                    points: o.trace.clone(),
                })
                .collect();
            line_chart(
                &dir.join(format!("errors_{}.svg", mode.name())),
                &format!(
                    "ball ({}): centre error over time, bouncing + noise, run 0",
                    mode.name()
                ),
                "time (s)",
                "centre error (px)",
                &series,
            )?;
        }
    }
    Ok(())
}

/// The registry entry.
pub struct BallExperiment;

impl Experiment for BallExperiment {
    fn id(&self) -> &'static str {
        "ball"
    }
    fn source(&self) -> &'static str {
        "paper 001 Tables 1-3"
    }
    fn summary(&self) -> &'static str {
        "KF, UKF, PF_10/30/70 histogram ball trackers: fps, error, lost, found (offline and real time)"
    }
    fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
        let mut options = match opts.mode {
            Mode::Quick => BallOptions::quick(),
            Mode::Full => BallOptions::paper(),
        };
        for (k, v) in &opts.set {
            options.apply(k, v)?;
        }
        let dir = opts.output_dir(self.id())?;
        let result = run(&options, Some(&dir.join("runs.csv")), opts.progress)?;
        let mut tables = vec![
            result.table1(FrameMode::Offline),
            result.table1(FrameMode::RealTime),
            result.table_split(true),
            result.table_split(false),
            result.findings_table(),
        ];
        write_outputs(&result, &dir, &tables)?;
        tables[0].title = format!("{}\n  options: {}", tables[0].title, options.describe());
        Ok(tables)
    }

    fn golden(&self) -> Result<Option<String>, ExperimentError> {
        let result = run(&BallOptions::quick(), None, false)?;
        let mut out = String::from(
            "condition,alg,mode,frames,mean_error_px,losses,found_times_s,unresolved,self_lost_frames\n",
        );
        for r in &result.runs {
            for o in &r.outcomes {
                let found: Vec<String> =
                    o.found_times.iter().map(|t| format!("{t:.17e}")).collect();
                let _ = writeln!(
                    out,
                    "{},{},{},{},{:.17e},{},{},{},{}",
                    r.condition.name(),
                    o.filter.label(),
                    o.mode.name(),
                    o.frames,
                    o.error_sum / o.frames.max(1) as f64,
                    o.losses,
                    found.join(";"),
                    o.unresolved,
                    o.self_lost
                );
            }
        }
        for f in result.findings() {
            let _ = writeln!(out, "finding,{},{},{}", f.id, f.offline, f.realtime);
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn realtime_schedule_sees_the_papers_rate() {
        // PF70 at 7.24 fps on a 22 fps camera sees about 7.24 frames a second.
        let cost = 1.0 / 7.24;
        let (mut k, mut start, mut seen) = (0, 0.0, 0);
        while k < 22 * 60 {
            let (n, s) = next_realtime(k, start, cost);
            k = n;
            start = s;
            seen += 1;
        }
        let rate = seen as f64 / 60.0;
        assert!((rate - 7.24).abs() < 0.05, "{rate}");
        // A tracker faster than the camera sees every frame.
        assert_eq!(next_realtime(5, 5.0 / 22.0, 0.001).0, 6);
    }

    #[test]
    fn options_parse_and_reject() {
        let mut o = BallOptions::quick();
        o.apply("likelihood_sigma", "0.2").unwrap();
        o.apply("model", "linear").unwrap();
        o.apply("rt_elapsed", "false").unwrap();
        assert_eq!(o.tracker.likelihood_sigma, 0.2);
        assert_eq!(o.model, ModelChoice::Linear);
        assert!(!o.rt_elapsed);
        assert!(o.apply("model", "nope").is_err());
        assert!(o.apply("bogus", "1").is_err());
        assert!(o.apply("runs", "0").is_err());
        let mut o = BallOptions::quick();
        assert!(o.apply("found_radius", "30").is_err());
    }

    #[test]
    fn paper_cells_are_complete() {
        for f in BallFilter::PAPER {
            let p = paper_row(f).unwrap();
            assert!(p.fps > 7.0 && p.fps < 16.0);
        }
        assert!(paper_row(BallFilter::Pf(5)).is_none());
    }
}
