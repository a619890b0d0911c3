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
use bayestrack_otb::write::PartialCsv;
use bayestrack_trackers::{
    FrameStats, HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StpfConfig, StpfTracker, Tracker,
};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::experiment::{
    Experiment, ExperimentError, MAX_FRAMES, MAX_PARTICLES, MAX_RUNS, Mode, RunOptions, write_text,
};
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

/// Every choice of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct AffineConfig {
    /// Frames per sequence.
    pub frames: usize,
    /// Runs: run `r` renders each scene with seed `scene_seed + r` and seeds
    /// the filters with `r`.
    pub runs: usize,
    /// Scene seed of run 0.
    pub scene_seed: u64,
    /// A frame is lost when its RMS exceeds this fraction of the true
    /// target's side `sqrt(w_k h_k)` (0.25).
    pub lost_fraction: f64,
    /// HKPF's particles per setting; `None` uses the paper's
    /// ([`Setting::hkpf_particles`]).
    pub hkpf_particles: Option<usize>,
    /// The self-tuning filter's settings (Algorithm 1's defaults).
    pub stpf: StpfConfig,
    /// ISPF's settings.
    pub ispf: IspfConfig,
}

impl AffineConfig {
    /// Paper scale: 300 frames, 5 runs.
    pub fn paper() -> Self {
        Self {
            frames: 300,
            runs: 5,
            scene_seed: 1,
            lost_fraction: 0.25,
            hkpf_particles: None,
            stpf: StpfConfig::default(),
            ispf: IspfConfig::default(),
        }
    }

    /// The CI scale: 80 frames, 1 run.
    pub fn quick() -> Self {
        Self {
            frames: 80,
            runs: 1,
            ..Self::paper()
        }
    }

    /// The keys [`AffineConfig::apply`] accepts, with their domains (listed
    /// by [`ExperimentError::BadOption`]).
    pub const KEYS: &'static str = "frames (1..=1000000; 1 reads as 2), runs (1..=100000), \
        scene_seed (u64), lost_fraction (> 0, finite), hkpf_particles (1..=1000000), \
        max_particles (1..=1000000)";

    /// Applies `key=value` overrides: `frames`, `runs`, `scene_seed`,
    /// `lost_fraction`, `hkpf_particles`, `max_particles` (N_max of both
    /// self-tuning filters).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or value (listing
    /// [`AffineConfig::KEYS`]).
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        let bad = || ExperimentError::bad_option("affine", Self::KEYS, key, value);
        let int_to = |max: usize| {
            value
                .parse::<usize>()
                .ok()
                .filter(|&v| v > 0 && v <= max)
                .ok_or_else(bad)
        };
        let int = || int_to(MAX_PARTICLES);
        match key {
            "frames" => self.frames = int_to(MAX_FRAMES)?.max(2),
            "runs" => self.runs = int_to(MAX_RUNS)?,
            "scene_seed" => self.scene_seed = value.parse().map_err(|_| bad())?,
            "lost_fraction" => {
                self.lost_fraction = value
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v > 0.0)
                    .ok_or_else(bad)?;
            }
            "hkpf_particles" => self.hkpf_particles = Some(int()?),
            "max_particles" => {
                let n = int()?;
                self.stpf.max_particles = n;
                self.ispf.max_particles = n;
            }
            _ => return Err(bad()),
        }
        Ok(())
    }

    /// One line with every option.
    pub fn describe(&self) -> String {
        format!(
            "frames={} runs={} scene_seed={} lost_fraction={} hkpf_particles={} max_particles={}",
            self.frames,
            self.runs,
            self.scene_seed,
            self.lost_fraction,
            self.hkpf_particles
                .map_or("150/100/50".to_string(), |n| n.to_string()),
            self.stpf.max_particles,
        )
    }
}

/// One filter on one sequence: per scored frame (frames 2..n).
#[derive(Debug, Clone, PartialEq, Default)]
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
            Filter::Ispf => Self::Ispf(IspfTracker::new(config.ispf.clone(), seed)?),
            Filter::Stpf => Self::Stpf(StpfTracker::new(config.stpf.clone(), seed)?),
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
    out.seconds = seconds;
    Ok(out)
}

/// Runs every setting, run and filter (in parallel; the result does not
/// depend on the thread count).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the filter, setting, run and frame;
/// [`ExperimentError::BadOption`] for zero frames or runs.
pub fn run(config: &AffineConfig, progress: bool) -> Result<AffineResult, ExperimentError> {
    run_logged(config, progress, None)
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

/// [`run`], appending each finished setting x run's frames to `log` as it
/// finishes (in completion order), so that a run killed part-way keeps
/// them.
///
/// # Errors
/// Those of [`run`], and [`ExperimentError::Io`] when `log` cannot be
/// written.
pub fn run_logged(
    config: &AffineConfig,
    progress: bool,
    log: Option<&PartialCsv<FrameRow>>,
) -> Result<AffineResult, ExperimentError> {
    if config.frames < 2 || config.runs == 0 {
        return Err(ExperimentError::bad_option(
            "affine",
            AffineConfig::KEYS,
            "frames/runs",
            &format!("{}/{}", config.frames, config.runs),
        ));
    }
    let jobs: Vec<(usize, usize)> = (0..Setting::ALL.len())
        .flat_map(|s| (0..config.runs).map(move |r| (s, r)))
        .collect();
    let bar = crate::experiment::progress_bar(jobs.len(), progress, "affine sequences");
    let done: Vec<Vec<TrackRun>> = jobs
        .par_iter()
        .map(|&(s, r)| {
            let setting = Setting::ALL[s];
            let scene = setting
                .scene(config.frames)
                .generate(config.scene_seed + r as u64)
                .map_err(|e| ExperimentError::Failed {
                    id: "affine",
                    message: format!("{} scene: {e}", setting.name()),
                })?;
            let runs = Filter::ALL
                .par_iter()
                .map(|&f| track(f, setting, config, r, &scene.frames, &scene.truth))
                .collect::<Result<Vec<_>, _>>()?;
            if let Some(log) = log {
                log.append(&frame_rows(setting, r, &runs))?;
            }
            bar.inc(1);
            Ok(runs)
        })
        .collect::<Result<_, ExperimentError>>()?;
    bar.finish_and_clear();
    let mut runs = vec![Vec::new(); Setting::ALL.len()];
    for ((s, _), r) in jobs.into_iter().zip(done) {
        runs[s].push(r);
    }
    Ok(AffineResult {
        config: config.clone(),
        runs,
    })
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
                self.config.frames, self.config.runs, self.config.lost_fraction
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

/// The registry entry.
pub struct AffineExperiment;

impl Experiment for AffineExperiment {
    fn id(&self) -> &'static str {
        "affine"
    }
    fn source(&self) -> &'static str {
        "paper 002 (RMS eq. 6, particles per frame)"
    }
    fn summary(&self) -> &'static str {
        "HKPF, ISPF and self-tuning HKPF on synthetic affine sequences"
    }
    fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
        let mut config = match opts.mode {
            Mode::Quick => AffineConfig::quick(),
            Mode::Full => AffineConfig::paper(),
        };
        for (k, v) in &opts.set {
            config.apply(k, v)?;
        }
        let dir = opts.output_dir(self.id())?;
        // every frame of every run, appended as each run finishes
        let frames = PartialCsv::create(&dir.join("frames.csv"))?;
        let result = run_logged(
            &config,
            opts.progress && opts.mode == Mode::Full,
            Some(&frames),
        )?;
        let mut rows = Vec::new();
        for (setting, runs) in Setting::ALL.iter().zip(&result.runs) {
            for (r, tracks) in runs.iter().enumerate() {
                rows.extend(frame_rows(*setting, r, tracks));
            }
        }
        frames.finish(&rows)?;
        write_outputs(&result, &dir)?;
        let mut main = result.table();
        main.title = format!("{}\n  options: {}", main.title, config.describe());
        Ok(vec![main, result.claims_table()])
    }

    fn golden(&self) -> Result<Option<String>, ExperimentError> {
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
            (c.frames, c.stpf.max_particles, c.ispf.max_particles),
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
