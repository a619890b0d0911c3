//! The `affine` experiment: Xu, Gao and Yang 2015 (paper 002), section 4,
//! on synthetic sequences with exact affine ground truth.
//!
//! The paper compares HKPF (Yin et al. 2011), ISPF (Li et al. 2012) and its
//! self-tuning HKPF on three real videos, by the RMS error of eq. 6 over
//! seven labelled feature points and the centre (Fig. 7) and by the
//! particles used per frame (Fig. 8). We cannot label the real videos'
//! points, so each video is mirrored by a setting of
//! [`AffineScene`] whose poses and points are exact ([`Setting`]).
//!
//! Per setting and filter: RMS of eq. 6 (mean, median, 90th percentile over
//! the tracked frames), frames lost, mean particles, appearance evaluations
//! and pose-estimator calls per frame, and frames per second.
//!
//! # How the points are carried
//! The tracker starts from the ground-truth box of frame 1 and reports its
//! pose `M^_k` (template coordinates centred on its own template, which is
//! that box, to 0-based image coordinates). The true pose `M_k` maps the
//! scene's template. A feature point `p` of the scene's template is, in the
//! tracker's template, `q = M^_0^-1 M_0 p`; its estimate in frame `k` is
//! `M^_k q` (for a perfect tracker `M^_k = M_k M_0^-1 M^_0`, so the error is
//! zero). Frame 1 is the initialisation and is not scored.
//!
//! # Lost
//! A frame is lost when its RMS error exceeds `lost_fraction` (0.25) times
//! the side `sqrt(w_k h_k)` of the true target, `w_k h_k` its area at that
//! frame (`|det|` of the true pose times the template area): 13 px for the
//! 48x56 patch at scale 1, about the distance from an eye's outer corner to
//! the nose.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use bayestrack_image::Image;
use bayestrack_otb::Table;
use bayestrack_otb::metrics::{FeaturePoints, rms_error_eq6};
use bayestrack_otb::plot::{Series, line_chart};
use bayestrack_trackers::{
    FrameStats, HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StpfConfig, StpfTracker, Tracker,
};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_FRAMES, MAX_PARTICLES, MAX_RUNS, write_text};
use bayestrack_options::{IfSome, Options, above, options};

/// The experiment's id.
const ID: &str = "affine";
use crate::scenes::{AffineScene, TEMPLATE_POINTS};

/// The three synthetic settings, each mirroring one of the paper's videos.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Setting {
    /// "Cock": abrupt, erratic motion with motion blur and little pose
    /// change: a 15 px jump (random direction) every 8 frames, blurred over
    /// 6 px (0.4 of the jump, as if the shutter were open for 0.4 of the
    /// frame interval).
    ///
    /// Why 15 px: the paper says only "abrupt and erratic motion" and
    /// "blur resulting from severe camera vibration", and reports that its
    /// filter follows it. A jump must then land inside a region the
    /// filters search in the jump frame itself. The widest first-frame
    /// region of the three is ISPF's shift spread (5 px, so 3 sigma =
    /// 15 px); the Kalman region of HKPF and the self-tuning filter is
    /// narrower (`S = P_xy + r^2 I` is 5.1 px^2 in steady state, 2.25 px
    /// per axis, so 3 sigma = 6.8 px; 3x wider after a detected
    /// manoeuvre, but a manoeuvre is detected from the innovation of the
    /// jump frame's own estimate, so only from the next frame on), and the
    /// pose estimator corrects shifts of a few pixels (trained at 2 px).
    /// The first version jumped 30 px (0.6 of the target's width in one
    /// frame), twice any region: all three filters lost the target at the
    /// first or second jump and never recovered (RMS 46-52 px, 64-68 of 79
    /// frames lost), which says nothing about the filters. The size is
    /// this reach; a sweep (80 frames, 2 seeds) agrees with it: at 6-10 px
    /// no filter loses a frame, at 15 px HKPF loses some on one seed, at
    /// 20 px HKPF loses frames on both seeds and all three lose the target
    /// on one, at 30 px all three on both. Cock
    /// stays the most abrupt setting by frequency: a jump every 8 frames
    /// against Dudek's 20 px every 15 (beyond the 15 px reach, so Dudek's
    /// jump frames test recovery rather than following).
    Cock,
    /// "Sylvester": strong illumination change and severe pose change
    /// (rotation up to 0.9 rad, scale 0.7-1.3, aspect 0.85-1.15, gain
    /// 0.55-1.45), smooth motion, no jumps.
    Sylvester,
    /// "Dudek": a face with fast motion and pose change: 20 px jumps every
    /// 15 frames with 6 px blur, rotation up to 0.5 rad, scale 0.8-1.2.
    Dudek,
}

impl Setting {
    /// Every setting, in table order.
    pub const ALL: [Setting; 3] = [Setting::Cock, Setting::Sylvester, Setting::Dudek];

    /// Row label.
    pub fn name(self) -> &'static str {
        match self {
            Setting::Cock => "Cock",
            Setting::Sylvester => "Sylvester",
            Setting::Dudek => "Dudek",
        }
    }

    /// The scene of this setting with `frames` frames.
    pub fn scene(self, frames: usize) -> AffineScene {
        let base = AffineScene {
            frames,
            ..AffineScene::default()
        };
        match self {
            Setting::Cock => AffineScene {
                jump_every: 8,
                jump_size: 15.0,
                jump_blur: 6.0,
                rotation_amplitude: 0.2,
                scale_amplitude: 0.1,
                aspect_amplitude: 0.05,
                illumination_amplitude: 0.1,
                ..base
            },
            Setting::Sylvester => AffineScene {
                jump_every: 0,
                rotation_amplitude: 0.9,
                rotation_period: 80.0,
                scale_amplitude: 0.3,
                aspect_amplitude: 0.15,
                illumination_amplitude: 0.45,
                ..base
            },
            Setting::Dudek => AffineScene {
                jump_every: 15,
                jump_size: 20.0,
                jump_blur: 6.0,
                rotation_amplitude: 0.5,
                scale_amplitude: 0.2,
                aspect_amplitude: 0.1,
                illumination_amplitude: 0.2,
                ..base
            },
        }
    }

    /// HKPF's particles on the paper's video of this setting (150, 100, 50).
    pub fn hkpf_particles(self) -> usize {
        match self {
            Setting::Cock => 150,
            Setting::Sylvester => 100,
            Setting::Dudek => 50,
        }
    }

    /// The paper's mean particles per frame: (HKPF, ISPF, self-tuning HKPF).
    /// The paper gives no ISPF figure on Cock (ISPF fails near frame 148).
    pub fn paper_particles(self) -> [Option<f64>; 3] {
        match self {
            Setting::Cock => [Some(150.0), None, Some(28.2)],
            Setting::Sylvester => [Some(100.0), Some(13.2), Some(9.7)],
            Setting::Dudek => [Some(50.0), Some(15.5), Some(8.6)],
        }
    }
}

/// The three filters compared, in column order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Filter {
    /// The hierarchical Kalman-particle filter (Yin et al. 2011).
    Hkpf,
    /// The incremental self-tuning particle filter (Li et al. 2012).
    Ispf,
    /// The self-tuning HKPF of paper 002 (Algorithm 1).
    Stpf,
}

impl Filter {
    /// Every filter, in column order.
    pub const ALL: [Filter; 3] = [Filter::Hkpf, Filter::Ispf, Filter::Stpf];

    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Hkpf => "HKPF",
            Filter::Ispf => "ISPF",
            Filter::Stpf => "self-tuning HKPF",
        }
    }

    fn index(self) -> usize {
        match self {
            Filter::Hkpf => 0,
            Filter::Ispf => 1,
            Filter::Stpf => 2,
        }
    }
}

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
        /// Measure the trackers' wall-clock time (the fps column); `false`
        /// records 0 s, so that two runs write byte-identical files.
        pub timing: bool = true;
    }
}

impl AffineConfig {
    /// Paper scale: 300 frames, 5 runs.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: 80 frames, 1 run.
    pub fn quick() -> Self {
        Self {
            frames: 80,
            runs: 1,
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

    /// The self-tuning filter's settings (Algorithm 1's defaults).
    pub fn stpf(&self) -> StpfConfig {
        StpfConfig {
            max_particles: self.max_particles,
            ..StpfConfig::default()
        }
    }

    /// ISPF's settings.
    pub fn ispf(&self) -> IspfConfig {
        IspfConfig {
            max_particles: self.max_particles,
            ..IspfConfig::default()
        }
    }
}

/// One filter on one sequence: per scored frame (frames 2..n).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct TrackRun {
    /// RMS error of eq. 6.
    pub rms: Vec<f64>,
    /// Whether the frame is lost.
    pub lost: Vec<bool>,
    /// Particles used.
    pub particles: Vec<usize>,
    /// Appearance evaluations.
    pub evaluations: Vec<usize>,
    /// Pose-estimator calls.
    pub pose_estimator_calls: Vec<usize>,
    /// Seconds spent in the tracker's own calls (init and steps).
    pub seconds: f64,
}

/// Mean, median and 90th percentile of a sample (`NaN`s if empty).
fn quantiles(v: &[f64]) -> [f64; 3] {
    if v.is_empty() {
        return [f64::NAN; 3];
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
    [s.iter().sum::<f64>() / s.len() as f64, at(0.5), at(0.9)]
}

fn mean_usize(v: &[usize]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().sum::<usize>() as f64 / v.len() as f64
}

/// One setting x filter over every run.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The setting.
    pub setting: Setting,
    /// The filter.
    pub filter: Filter,
    /// RMS mean, median and 90th percentile over every scored frame of
    /// every run.
    pub rms: [f64; 3],
    /// Lost frames per run (mean over runs).
    pub lost_frames: f64,
    /// Frame (1-based) of the first lost frame of each run (`None`: never).
    pub first_lost: Vec<Option<usize>>,
    /// Particles per frame.
    pub particles: f64,
    /// Appearance evaluations per frame.
    pub evaluations: f64,
    /// Pose-estimator calls per frame.
    pub pose_estimator_calls: f64,
    /// Frames per second (tracker calls only; runs share the cores).
    pub fps: f64,
}

/// Everything the experiment measured.
#[derive(Debug, Clone, PartialEq)]
pub struct AffineResult {
    /// The configuration.
    pub config: AffineConfig,
    /// `runs[setting][run][filter]`, settings in [`Setting::ALL`] order.
    pub runs: Vec<Vec<Vec<TrackRun>>>,
}

/// A fresh tracker of `filter` for `setting`, seeded with `seed`.
enum AnyTracker {
    Hkpf(HkpfTracker),
    Ispf(IspfTracker),
    Stpf(StpfTracker),
}

impl AnyTracker {
    fn new(
        filter: Filter,
        setting: Setting,
        config: &AffineConfig,
        seed: u64,
    ) -> bayestrack_trackers::Result<Self> {
        Ok(match filter {
            Filter::Hkpf => Self::Hkpf(HkpfTracker::new(
                HkpfConfig {
                    particles: config
                        .hkpf_particles
                        .unwrap_or_else(|| setting.hkpf_particles()),
                    ..HkpfConfig::default()
                },
                seed,
            )?),
            Filter::Ispf => Self::Ispf(IspfTracker::new(config.ispf(), seed)?),
            Filter::Stpf => Self::Stpf(StpfTracker::new(config.stpf(), seed)?),
        })
    }

    fn tracker(&mut self) -> &mut dyn Tracker {
        match self {
            Self::Hkpf(t) => t,
            Self::Ispf(t) => t,
            Self::Stpf(t) => t,
        }
    }

    fn stats(&self) -> FrameStats {
        match self {
            Self::Hkpf(t) => t.stats(),
            Self::Ispf(t) => t.stats(),
            Self::Stpf(t) => t.stats(),
        }
    }

    fn pose(&self) -> Option<Matrix3<f64>> {
        match self {
            Self::Hkpf(t) => t.pose(),
            Self::Ispf(t) => t.pose(),
            Self::Stpf(t) => t.pose(),
        }
        .map(|p| *p.matrix())
    }
}

fn matrix(rows: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| rows[i][j])
}

fn apply(m: &Matrix3<f64>, p: [f64; 2]) -> [f64; 2] {
    let v = m * Vector3::new(p[0], p[1], 1.0);
    [v[0], v[1]]
}

/// One filter through one rendered sequence.
fn track(
    filter: Filter,
    setting: Setting,
    config: &AffineConfig,
    run: usize,
    frames: &[Image<u8>],
    truth: &[crate::scenes::FrameTruth],
) -> Result<TrackRun, ExperimentError> {
    let failed = |message: String| ExperimentError::Failed {
        id: "affine",
        message: format!(
            "{} on {} run {run}: {message}",
            filter.name(),
            setting.name()
        ),
    };
    let affine = |k: usize| {
        truth[k]
            .affine
            .ok_or_else(|| failed(format!("frame {} has no affine truth", k + 1)))
    };
    let mut t =
        AnyTracker::new(filter, setting, config, run as u64).map_err(|e| failed(e.to_string()))?;
    let first = affine(0)?;
    let init_box = truth[0]
        .objects
        .first()
        .ok_or_else(|| failed("no target in frame 1".into()))?
        .bbox;
    let start = Instant::now();
    t.tracker()
        .init(frames[0].view(), init_box)
        .map_err(|e| failed(format!("frame 1: {e}")))?;
    let mut seconds = start.elapsed().as_secs_f64();
    let est0 = t
        .pose()
        .ok_or_else(|| failed("no pose after init".into()))?;
    // The scene's template points in the tracker's template coordinates.
    let carry = est0
        .try_inverse()
        .ok_or_else(|| failed("singular initial pose".into()))?
        * matrix(&first.matrix);
    let [tw, th] = first.template_size;
    let template: Vec<[f64; 2]> = TEMPLATE_POINTS
        .iter()
        .map(|p| apply(&carry, [p[0] * tw, p[1] * th]))
        .collect();
    let centre = apply(&carry, [0.0, 0.0]);
    let mut out = TrackRun::default();
    for (k, frame) in frames.iter().enumerate().skip(1) {
        let start = Instant::now();
        let est = t
            .tracker()
            .step(frame.view())
            .map_err(|e| failed(format!("frame {}: {e}", k + 1)))?;
        seconds += start.elapsed().as_secs_f64();
        let stats = t.stats();
        let m = est
            .pose
            .ok_or_else(|| failed(format!("frame {}: no pose", k + 1)))?;
        let mut estimated = FeaturePoints {
            center: apply(&m, centre),
            ..FeaturePoints::default()
        };
        for (e, q) in estimated.points.iter_mut().zip(&template) {
            *e = apply(&m, *q);
        }
        let truth_k = affine(k)?;
        let rms = rms_error_eq6(&estimated, &truth_k.points)
            .map_err(|e| failed(format!("frame {}: {e}", k + 1)))?;
        let det = matrix(&truth_k.matrix)
            .fixed_view::<2, 2>(0, 0)
            .determinant();
        let side = (det.abs() * tw * th).sqrt();
        out.rms.push(rms);
        out.lost.push(rms > config.lost_fraction * side);
        out.particles.push(est.particles);
        out.evaluations.push(est.evaluations);
        out.pose_estimator_calls.push(stats.pose_estimator_calls);
    }
    out.seconds = if config.timing { seconds } else { 0.0 };
    Ok(out)
}

/// Runs every setting, run and filter (in parallel; the result does not
/// depend on the thread count).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the filter, setting, run and frame.
pub fn run(config: &AffineConfig, progress: bool) -> Result<AffineResult, ExperimentError> {
    let done = crate::driver::run_all::<AffineExperiment>(config, None, progress)?;
    Ok(assemble(config, done))
}

/// Job `j`: setting `j / runs`, run `j % runs`.
fn job(config: &AffineConfig, j: usize) -> (Setting, usize) {
    (Setting::ALL[j / config.runs], j % config.runs)
}

/// Every filter through setting `s`'s run `r`.
fn run_job(config: &AffineConfig, s: Setting, r: usize) -> Result<Vec<TrackRun>, ExperimentError> {
    let scene = s
        .scene(config.frames())
        .generate(config.scene_seed + r as u64)
        .map_err(|e| ExperimentError::Failed {
            id: "affine",
            message: format!("{} scene: {e}", s.name()),
        })?;
    Filter::ALL
        .par_iter()
        .map(|&f| track(f, s, config, r, &scene.frames, &scene.truth))
        .collect()
}

/// The result from every job's, in job order.
fn assemble(config: &AffineConfig, done: Vec<Vec<TrackRun>>) -> AffineResult {
    let mut runs = vec![Vec::new(); Setting::ALL.len()];
    for (j, r) in done.into_iter().enumerate() {
        runs[j / config.runs].push(r);
    }
    AffineResult {
        config: config.clone(),
        runs,
    }
}

/// One row of `frames.csv`: one filter on one scored frame of one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameRow {
    /// [`Setting::name`].
    pub setting: &'static str,
    /// Run index (0-based).
    pub run: usize,
    /// [`Filter::name`].
    pub filter: &'static str,
    /// Frame number (1-based; frame 1 initialises).
    pub frame: usize,
    /// RMS error of eq. 6 (pixels).
    pub rms: f64,
    /// Whether the frame is lost.
    pub lost: bool,
    /// Particles used.
    pub particles: usize,
    /// Appearance evaluations.
    pub evaluations: usize,
    /// Pose-estimator calls.
    pub pe_calls: usize,
}

/// The `frames.csv` rows of one setting's run (every filter, every scored
/// frame).
fn frame_rows(setting: Setting, run: usize, tracks: &[TrackRun]) -> Vec<FrameRow> {
    let mut rows = Vec::new();
    for (f, tr) in Filter::ALL.iter().zip(tracks) {
        for k in 0..tr.rms.len() {
            rows.push(FrameRow {
                setting: setting.name(),
                run,
                filter: f.name(),
                frame: k + 2,
                rms: tr.rms[k],
                lost: tr.lost[k],
                particles: tr.particles[k],
                evaluations: tr.evaluations[k],
                pe_calls: tr.pose_estimator_calls[k],
            });
        }
    }
    rows
}

impl AffineResult {
    /// One summary per setting x filter, settings then filters in order.
    pub fn summaries(&self) -> Vec<Summary> {
        let mut out = Vec::new();
        for (s, setting) in Setting::ALL.iter().enumerate() {
            for filter in Filter::ALL {
                let tr: Vec<&TrackRun> = self.runs[s].iter().map(|r| &r[filter.index()]).collect();
                let rms: Vec<f64> = tr.iter().flat_map(|t| t.rms.iter().copied()).collect();
                let cat = |f: fn(&TrackRun) -> &Vec<usize>| -> Vec<usize> {
                    tr.iter().flat_map(|t| f(t).iter().copied()).collect()
                };
                let frames: usize = tr.iter().map(|t| t.rms.len()).sum();
                let seconds: f64 = tr.iter().map(|t| t.seconds).sum();
                out.push(Summary {
                    setting: *setting,
                    filter,
                    rms: quantiles(&rms),
                    lost_frames: tr
                        .iter()
                        .map(|t| t.lost.iter().filter(|&&l| l).count())
                        .sum::<usize>() as f64
                        / tr.len() as f64,
                    first_lost: tr
                        .iter()
                        .map(|t| t.lost.iter().position(|&l| l).map(|k| k + 2))
                        .collect(),
                    particles: mean_usize(&cat(|t| &t.particles)),
                    evaluations: mean_usize(&cat(|t| &t.evaluations)),
                    pose_estimator_calls: mean_usize(&cat(|t| &t.pose_estimator_calls)),
                    fps: frames as f64 / seconds.max(1e-12),
                });
            }
        }
        out
    }

    /// The summary of `setting` x `filter`.
    pub fn summary(&self, setting: Setting, filter: Filter) -> Summary {
        self.summaries()
            .into_iter()
            .find(|s| s.setting == setting && s.filter == filter)
            .expect("every setting x filter is summarised")
    }

    /// The paper's particles per frame beside ours, and our accuracy.
    pub fn table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "affine (paper 002 Fig. 7-8): {} frames x {} run(s) per setting; RMS of eq. 6 in px; \
                 lost = RMS > {} x target side",
                self.config.frames(),
                self.config.runs,
                self.config.lost_fraction
            ),
            &[
                "setting",
                "filter",
                "paper particles/frame",
                "ours particles/frame",
                "RMS mean",
                "RMS median",
                "RMS p90",
                "lost frames",
                "evaluations/frame",
                "PE calls/frame",
                "fps",
            ],
        );
        for s in self.summaries() {
            let paper = s.setting.paper_particles()[s.filter.index()]
                .map_or("-".to_string(), |v| format!("{v}"));
            t.push(vec![
                s.setting.name().to_string(),
                s.filter.name().to_string(),
                paper,
                format!("{:.1}", s.particles),
                format!("{:.2}", s.rms[0]),
                format!("{:.2}", s.rms[1]),
                format!("{:.2}", s.rms[2]),
                format!("{:.1}", s.lost_frames),
                format!("{:.1}", s.evaluations),
                format!("{:.1}", s.pose_estimator_calls),
                format!("{:.0}", s.fps),
            ]);
        }
        t
    }

    /// The paper's qualitative claims beside what we measured.
    pub fn claims_table(&self) -> Table {
        let mut t = Table::new("affine: the paper's claims", &["claim (paper 002)", "ours"]);
        let first_lost = |s: &Summary| {
            let v: Vec<String> = s
                .first_lost
                .iter()
                .map(|f| f.map_or("never".to_string(), |k| k.to_string()))
                .collect();
            v.join(" ")
        };
        let cock_ispf = self.summary(Setting::Cock, Filter::Ispf);
        let cock_stpf = self.summary(Setting::Cock, Filter::Stpf);
        t.push(vec![
            "ISPF fails under abrupt motion and blur (Cock, near frame 148); the self-tuning filter does not".into(),
            format!(
                "first lost frame per run: ISPF {}, self-tuning {}; lost frames ISPF {:.1}, self-tuning {:.1}",
                first_lost(&cock_ispf),
                first_lost(&cock_stpf),
                cock_ispf.lost_frames,
                cock_stpf.lost_frames
            ),
        ]);
        for setting in [Setting::Sylvester, Setting::Dudek] {
            let h = self.summary(setting, Filter::Hkpf);
            let s = self.summary(setting, Filter::Stpf);
            t.push(vec![
                format!(
                    "HKPF drifts in orientation and scale under pose change ({})",
                    setting.name()
                ),
                format!(
                    "RMS mean HKPF {:.2} vs self-tuning {:.2} ({:.2}x)",
                    h.rms[0],
                    s.rms[0],
                    h.rms[0] / s.rms[0]
                ),
            ]);
        }
        for setting in Setting::ALL {
            let i = self.summary(setting, Filter::Ispf);
            let s = self.summary(setting, Filter::Stpf);
            t.push(vec![
                format!(
                    "the self-tuning filter needs fewer particles than ISPF ({})",
                    setting.name()
                ),
                format!(
                    "{:.1} vs {:.1} particles/frame at RMS {:.2} vs {:.2}",
                    s.particles, i.particles, s.rms[0], i.rms[0]
                ),
            ]);
        }
        t
    }
}

/// Writes the summary CSV files and the figures under `dir` (`frames.csv`
/// is written by [`AffineExperiment`] as the runs finish).
fn write_outputs(result: &AffineResult, dir: &Path) -> Result<(), ExperimentError> {
    write_text(&dir.join("summary.csv"), &result.table().to_csv())?;
    write_text(&dir.join("claims.csv"), &result.claims_table().to_csv())?;
    for (s, setting) in Setting::ALL.iter().enumerate() {
        let run0 = &result.runs[s][0];
        let series = |f: &dyn Fn(&TrackRun, usize) -> f64| -> Vec<Series> {
            Filter::ALL
                .iter()
                .zip(run0)
                .map(|(filter, tr)| Series {
                    name: filter.name().to_string(),
                    points: (0..tr.rms.len())
                        .map(|k| ((k + 2) as f64, f(tr, k)))
                        .collect(),
                })
                .collect()
        };
        let name = setting.name().to_lowercase();
        line_chart(
            &dir.join(format!("rms_{name}.svg")),
            &format!(
                "affine, {}: RMS error of eq. 6 per frame, run 0 (cf. Fig. 7)",
                setting.name()
            ),
            "frame",
            "RMS (px)",
            &series(&|tr, k| tr.rms[k]),
        )?;
        line_chart(
            &dir.join(format!("particles_{name}.svg")),
            &format!(
                "affine, {}: particles per frame, run 0 (cf. Fig. 8)",
                setting.name()
            ),
            "frame",
            "particles",
            &series(&|tr, k| tr.particles[k] as f64),
        )?;
    }
    Ok(())
}

/// The registry entry: job `j` is setting `j / runs`, run `j % runs`.
pub struct AffineExperiment;

impl Paper for AffineExperiment {
    type Config = AffineConfig;
    type Done = Vec<TrackRun>;
    type Row = FrameRow;
    type Shared = ();
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 002 (RMS eq. 6, particles per frame)";
    const SUMMARY: &'static str = "HKPF, ISPF and self-tuning HKPF on synthetic affine sequences";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "affine sequences";

    fn quick() -> AffineConfig {
        AffineConfig::quick()
    }
    fn full() -> AffineConfig {
        AffineConfig::paper()
    }
    fn jobs(c: &AffineConfig) -> usize {
        Setting::ALL.len() * c.runs
    }
    fn prepare(_: &AffineConfig, _: &[usize]) -> Result<(), ExperimentError> {
        Ok(())
    }
    fn run_job(c: &AffineConfig, _: &(), j: usize) -> Result<Vec<TrackRun>, ExperimentError> {
        let (s, r) = job(c, j);
        run_job(c, s, r)
    }
    fn rows(c: &AffineConfig, j: usize, done: &Vec<TrackRun>) -> Vec<FrameRow> {
        let (s, r) = job(c, j);
        frame_rows(s, r, done)
    }
    fn report(
        config: &AffineConfig,
        done: Vec<Vec<TrackRun>>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let result = assemble(config, done);
        write_outputs(&result, dir)?;
        Ok(vec![result.table(), result.claims_table()])
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&AffineConfig::quick(), false)?;
        let mut out = String::from("setting,filter,column,value\n");
        for s in r.summaries() {
            for (col, v) in [
                ("rms_mean", s.rms[0]),
                ("rms_median", s.rms[1]),
                ("rms_p90", s.rms[2]),
                ("lost_frames", s.lost_frames),
                ("particles", s.particles),
                ("evaluations", s.evaluations),
                ("pe_calls", s.pose_estimator_calls),
            ] {
                let _ = writeln!(
                    out,
                    "{},{},{col},{v:.17e}",
                    s.setting.name(),
                    s.filter.name()
                );
            }
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let mut c = AffineConfig::quick();
        c.apply("frames", "30").unwrap();
        c.apply("max_particles", "20").unwrap();
        assert_eq!(
            (c.frames, c.stpf().max_particles, c.ispf().max_particles),
            (30, 20, 20)
        );
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("lost_fraction", "nan").is_err());
        assert!(c.apply("bogus", "1").is_err());
    }

    #[test]
    fn quantiles_by_hand() {
        let q = quantiles(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!(q, [3.0, 3.0, 5.0]);
        assert!(quantiles(&[])[0].is_nan());
    }

    /// A tracker that reports the true pose scores zero: the carrying of
    /// the points through the initial poses is exact.
    #[test]
    fn the_true_pose_scores_zero() {
        let scene = Setting::Sylvester.scene(3).generate(1).unwrap();
        let a0 = scene.truth[0].affine.unwrap();
        let a2 = scene.truth[2].affine.unwrap();
        // Any initial pose of the tracker: the box centre, no rotation.
        let est0 = Matrix3::new(1.0, 0.0, 100.0, 0.0, 1.0, 80.0, 0.0, 0.0, 1.0);
        let carry = est0.try_inverse().unwrap() * matrix(&a0.matrix);
        let perfect = matrix(&a2.matrix) * matrix(&a0.matrix).try_inverse().unwrap() * est0;
        let [tw, th] = a0.template_size;
        let mut e = FeaturePoints {
            center: apply(&perfect, apply(&carry, [0.0, 0.0])),
            ..FeaturePoints::default()
        };
        for (p, t) in e.points.iter_mut().zip(TEMPLATE_POINTS) {
            *p = apply(&perfect, apply(&carry, [t[0] * tw, t[1] * th]));
        }
        assert!(rms_error_eq6(&e, &a2.points).unwrap() < 1e-9);
    }
}
