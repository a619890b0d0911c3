//! The `condensation` experiment: paper 003 (Lee, Jo and Kang 2005) on the
//! synthetic webcam of [`WebcamScene`].
//!
//! - **Tracking grid** (sec. 3): cue {IFD, skin, OR, AND} x representation
//!   {point cloud (sec. 3.1), B-spline contour (sec. 3.3)} x `N` {50, 100,
//!   200} on the default scene (a face wandering in clutter: two static
//!   skin-coloured and two moving non-skin distractors): mean centre error,
//!   mean distance from the mean contour to the true outline (contours
//!   only), loss rate and frames per second, over seeded runs.
//! - **Re-initialisation** (sec. 4): on [`WebcamScene::entering`] the
//!   trackers start on the face; a hand enters through the left or right
//!   border at frame 30. Frames from its entry to lock-on (the estimate
//!   within [`CondensationConfig::lock_distance`] of the newcomer for
//!   [`CondensationConfig::lock_frames`] frames in a row), with and without
//!   c-AVQ.
//! - **Crossing** (sec. 5): on [`WebcamScene::crossing`] a face and a hand
//!   cross; [`MultiCondensation`] with and without the priority-subtracted
//!   IFD (eq. 15); after the crossing each frame is scored kept, swapped,
//!   merged or lost.
//! - **The claim** (sec. 3.3): with both cues (AND) the contour tracker
//!   needs half the particles for better tracking: AND at `N/2` against
//!   IFD and skin alone at `N`, for `N = 100` and `200`, read off the grid.
//!
//! Run `r` renders the scenes with seed `scene_seed + r` and seeds every
//! tracker with `r`; every job has its own seeds, so the numbers do not
//! depend on the thread count (the frames per second do). Positions are
//! 0-based pixels. Every choice is a named option
//! ([`CondensationConfig::apply`]); the reasons are in docs/reproduction.md.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use bayestrack_image::{BBox, Image, write_png};
use bayestrack_trackers::{
    CAvqConfig, ContourConfig, ContourTracker, CueSet, MultiCondensation, MultiConfig,
    ObjectConfig, PointCloudConfig, PointCloudTracker, Tracker,
};
use rayon::prelude::*;

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_FRAMES, MAX_RUNS, write_text};
use crate::scenes::{FrameTruth, Outline, SceneStream, WebcamScene};
use bayestrack_options::{Options, above, inside, options};
use bayestrack_otb::Table;
use bayestrack_otb::plot::{Series, line_chart};

const ID: &str = "condensation";

/// The particle counts of the grid: the paper's 50 (sec. 3.1, 3.3), 100
/// (sec. 3.3) and 200 (sec. 3.2).
pub const PARTICLES: [usize; 3] = [50, 100, 200];

/// Which cues weight the particles (sec. 2.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Cue {
    /// Interframe difference alone (eq. 7; eq. 9 with `lambda = 0`).
    Ifd,
    /// HSV skin colour alone (eq. 8).
    Skin,
    /// OR fusion, eq. 9, `lambda = 1/N`.
    Or,
    /// AND fusion, eq. 11, `lambda = 1/N`.
    And,
}

impl Cue {
    /// Every cue, in column order.
    pub const ALL: [Cue; 4] = [Cue::Ifd, Cue::Skin, Cue::Or, Cue::And];

    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            Cue::Ifd => "IFD",
            Cue::Skin => "skin",
            Cue::Or => "OR",
            Cue::And => "AND",
        }
    }

    /// The tracker's cue set for `n` particles (`lambda = 1/N`, sec. 3.1
    /// and 3.3).
    pub fn cue_set(self, n: usize) -> CueSet {
        let lambda = 1.0 / n.max(1) as f64;
        match self {
            Cue::Ifd => CueSet::Ifd,
            Cue::Skin => CueSet::Skin,
            Cue::Or => CueSet::Or { lambda },
            Cue::And => CueSet::And { lambda },
        }
    }
}

/// Point cloud or contour particles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Representation {
    /// Sec. 3.1: `[x, y, x_prev, y_prev]`, 30 px diffusion.
    Points,
    /// Sec. 3.3: the face's B-spline contour, 21 control points.
    Contour,
}

impl Representation {
    /// Both, in row order.
    pub const ALL: [Representation; 2] = [Representation::Points, Representation::Contour];

    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            Representation::Points => "points",
            Representation::Contour => "contour",
        }
    }
}

/// One cell of the tracking grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct GridKey {
    /// Point cloud or contour.
    pub representation: Representation,
    /// The cues.
    pub cue: Cue,
    /// `N`.
    pub particles: usize,
}

impl GridKey {
    /// Every cell, in table order (representation, `N`, cue).
    pub fn all() -> Vec<GridKey> {
        let mut v = Vec::new();
        for representation in Representation::ALL {
            for particles in PARTICLES {
                for cue in Cue::ALL {
                    v.push(GridKey {
                        representation,
                        cue,
                        particles,
                    });
                }
            }
        }
        v
    }

    /// `points OR N=50`.
    pub fn label(&self) -> String {
        format!(
            "{} {} N={}",
            self.representation.name(),
            self.cue.name(),
            self.particles
        )
    }
}

/// The trackers of the re-initialisation and crossing runs: the point
/// cloud of sec. 3.1 (OR, `N = 50`), the same with AND (the cue that tracks
/// in our clutter), and the contour of sec. 3.3 (AND, `N = 100`).
pub const SIDE_TRACKERS: [GridKey; 3] = [
    GridKey {
        representation: Representation::Points,
        cue: Cue::Or,
        particles: 50,
    },
    GridKey {
        representation: Representation::Points,
        cue: Cue::And,
        particles: 50,
    },
    GridKey {
        representation: Representation::Contour,
        cue: Cue::And,
        particles: 100,
    },
];

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
        /// Measure the trackers' wall-clock time (the fps column); `false`
        /// records 0 s, so that two runs write byte-identical files.
        pub timing: bool = true;
    }
    check check;
}

/// The cross-option rule: c-AVQ's constants must be ones it accepts.
fn check(c: &CondensationConfig) -> Result<(), String> {
    c.avq().validate().map_err(|e| e.to_string())
}

impl CondensationConfig {
    /// Paper scale: 10 runs of the whole 150-frame scene.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: 2 runs of 60 frames, 45 frames after the entry.
    pub fn quick() -> Self {
        Self {
            runs: 2,
            frames: 60,
            reinit_frames: 45,
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

    /// The c-AVQ constants of the re-initialisation runs.
    pub fn avq(&self) -> CAvqConfig {
        CAvqConfig {
            ifd_threshold: self.avq_threshold,
            trigger_fraction: self.avq_trigger,
            ..CAvqConfig::default()
        }
    }
}

fn failed(what: &str, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: ID,
        message: format!("{what}: {e}"),
    }
}

/// A single-target tracker of either representation.
enum Single {
    Points(PointCloudTracker),
    Contour(ContourTracker),
}

impl Single {
    fn new(
        representation: Representation,
        cue: Cue,
        particles: usize,
        avq: Option<CAvqConfig>,
        seed: u64,
    ) -> Result<Self, ExperimentError> {
        let what = format!("{} {} N={particles}", representation.name(), cue.name());
        Ok(match representation {
            Representation::Points => Single::Points(
                PointCloudTracker::new(
                    PointCloudConfig {
                        cues: cue.cue_set(particles),
                        avq,
                        ..PointCloudConfig::paper(particles)
                    },
                    seed,
                )
                .map_err(|e| failed(&what, e))?,
            ),
            Representation::Contour => Single::Contour(
                ContourTracker::new(
                    ContourConfig {
                        cues: cue.cue_set(particles),
                        avq,
                        ..ContourConfig::face(particles)
                    },
                    seed,
                )
                .map_err(|e| failed(&what, e))?,
            ),
        })
    }

    fn tracker(&mut self) -> &mut dyn Tracker {
        match self {
            Single::Points(t) => t,
            Single::Contour(t) => t,
        }
    }

    /// The mean contour's measurement points (contours only).
    fn mean_curve(&self) -> Option<Vec<[f64; 2]>> {
        match self {
            Single::Points(_) => None,
            Single::Contour(t) => {
                let m = t.mean_state()?;
                Some(t.curve(&m).iter().map(|p| [p.x, p.y]).collect())
            }
        }
    }
}

/// One tracker through one tracking scene.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct TrackRun {
    /// Centre error per frame (px), frames 1..
    pub centre: Vec<f64>,
    /// Mean distance from the mean contour's points to the true outline per
    /// frame (px); empty for the point cloud.
    pub outline: Vec<f64>,
    /// Whether the frame counts as lost (centre error over
    /// `lost_fraction` x the smaller side of the object's box).
    pub lost: Vec<bool>,
    /// Seconds spent in `step`.
    pub seconds: f64,
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn box_centre(b: &BBox) -> [f64; 2] {
    let (x, y) = b.center();
    [x - 1.0, y - 1.0]
}

fn track(
    key: GridKey,
    config: &CondensationConfig,
    run: usize,
    frames: &[Image<u8>],
    truth: &[FrameTruth],
    outlines: &[Outline],
) -> Result<TrackRun, ExperimentError> {
    let what = format!("{} run {run}", key.label());
    let mut t = Single::new(key.representation, key.cue, key.particles, None, run as u64)?;
    let target = |k: usize| {
        truth[k]
            .target()
            .ok_or_else(|| failed(&what, format!("frame {k} has no target")))
    };
    t.tracker()
        .init(frames[0].view(), target(0)?.bbox)
        .map_err(|e| failed(&what, e))?;
    let mut out = TrackRun::default();
    for (k, frame) in frames.iter().enumerate().skip(1) {
        let start = Instant::now();
        let e = t
            .tracker()
            .step(frame.view())
            .map_err(|e| failed(&what, format!("frame {k}: {e}")))?;
        if config.timing {
            out.seconds += start.elapsed().as_secs_f64();
        }
        let o = target(k)?;
        let [x, y] = box_centre(&e.bbox);
        let [tx, ty] = o.center0();
        let err = (x - tx).hypot(y - ty);
        out.centre.push(err);
        out.lost
            .push(err > config.lost_fraction * o.bbox.width.min(o.bbox.height));
        if let Some(curve) = t.mean_curve() {
            let d: Vec<f64> = curve.iter().map(|&p| outlines[k].distance(p)).collect();
            out.outline.push(mean(&d));
        }
    }
    Ok(out)
}

/// A tracking scene in memory: frames, truth and the target's outline.
struct Rendered {
    frames: Vec<Image<u8>>,
    truth: Vec<FrameTruth>,
    /// Outline of object 0 per frame.
    outlines: Vec<Outline>,
}

fn render(scene: &WebcamScene, seed: u64) -> Result<Rendered, ExperimentError> {
    let mut stream = scene.stream(seed).map_err(|e| failed("scene", e))?;
    let mut out = Rendered {
        frames: Vec::new(),
        truth: Vec::new(),
        outlines: Vec::new(),
    };
    while let Some(f) = stream.next_frame() {
        let mut o = stream.outlines(f.truth.index);
        out.outlines.push(o.swap_remove(0));
        out.frames.push(f.image);
        out.truth.push(f.truth);
    }
    Ok(out)
}

/// The tracking scene of run `r`.
fn tracking_scene(config: &CondensationConfig) -> WebcamScene {
    WebcamScene {
        frames: config.frames,
        ..WebcamScene::default()
    }
}

/// The entering scene, cut `reinit_frames` after the entry.
fn entering_scene(config: &CondensationConfig) -> (WebcamScene, usize) {
    let mut s = WebcamScene::entering();
    let entry = match s.second {
        crate::scenes::SecondObject::Entering { frame } => frame,
        _ => 0,
    };
    s.frames = (entry + config.reinit_frames).min(s.frames).max(entry + 1);
    (s, entry)
}

/// One re-initialisation run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReinitRun {
    /// The tracker.
    pub key: GridKey,
    /// The run.
    pub run: usize,
    /// Whether c-AVQ was on.
    pub avq: bool,
    /// Frames from the entry to the first of `lock_frames` consecutive
    /// frames on the newcomer; `None`: no lock-on within the scene.
    pub lock_on: Option<usize>,
    /// Distance from the estimate to the newcomer's centre, per frame from
    /// the entry on.
    pub distance: Vec<f64>,
}

fn reinit_run(
    key: GridKey,
    avq: bool,
    config: &CondensationConfig,
    run: usize,
    scene: &Rendered,
    entry: usize,
) -> Result<ReinitRun, ExperimentError> {
    let what = format!(
        "re-initialisation {} {} run {run}",
        key.label(),
        if avq { "c-AVQ" } else { "plain" }
    );
    let mut t = Single::new(
        key.representation,
        key.cue,
        key.particles,
        avq.then_some(config.avq()),
        run as u64,
    )?;
    let face = scene.truth[0]
        .target()
        .ok_or_else(|| failed(&what, "no face"))?;
    t.tracker()
        .init(scene.frames[0].view(), face.bbox)
        .map_err(|e| failed(&what, e))?;
    let mut out = ReinitRun {
        key,
        run,
        avq,
        lock_on: None,
        distance: Vec::new(),
    };
    let mut streak = 0;
    for (k, frame) in scene.frames.iter().enumerate().skip(1) {
        let e = t
            .tracker()
            .step(frame.view())
            .map_err(|e| failed(&what, format!("frame {k}: {e}")))?;
        if k < entry {
            continue;
        }
        let new = scene.truth[k]
            .object(1)
            .ok_or_else(|| failed(&what, "no newcomer"))?;
        let [x, y] = box_centre(&e.bbox);
        let [nx, ny] = new.center0();
        let d = (x - nx).hypot(y - ny);
        out.distance.push(d);
        if d <= config.lock_distance {
            streak += 1;
            if streak == config.lock_frames && out.lock_on.is_none() {
                out.lock_on = Some(k + 1 - config.lock_frames - entry);
            }
        } else {
            streak = 0;
        }
    }
    Ok(out)
}

/// How the frames after a crossing were scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct CrossingCount {
    /// Each estimate on its own object.
    pub kept: usize,
    /// Each estimate on the other object.
    pub swapped: usize,
    /// Both estimates on the same object.
    pub merged: usize,
    /// Anything else (at least one estimate on no object).
    pub lost: usize,
}

impl CrossingCount {
    /// Frames scored.
    pub fn total(&self) -> usize {
        self.kept + self.swapped + self.merged + self.lost
    }
}

/// One crossing run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CrossingRun {
    /// The tracker of every object.
    pub key: GridKey,
    /// Priority-subtracted IFD (eq. 15) or all sets on the raw IFD.
    pub priority: bool,
    /// The frames after the crossing.
    pub count: CrossingCount,
    /// Whether the last frame is kept (identities right at the end).
    pub kept_at_end: bool,
}

fn crossing_run(
    key: GridKey,
    priority: bool,
    config: &CondensationConfig,
    run: usize,
    scene: &Rendered,
    aligned: usize,
) -> Result<CrossingRun, ExperimentError> {
    let what = format!("crossing {} priority={priority} run {run}", key.label());
    let n = key.particles;
    let object = match key.representation {
        Representation::Points => ObjectConfig::Points(PointCloudConfig {
            cues: key.cue.cue_set(n),
            ..PointCloudConfig::paper(n)
        }),
        Representation::Contour => ObjectConfig::Contour(ContourConfig {
            cues: key.cue.cue_set(n),
            ..ContourConfig::face(n)
        }),
    };
    let mut m = MultiCondensation::new(
        MultiConfig {
            object,
            priority,
            ..MultiConfig::default()
        },
        run as u64,
    )
    .map_err(|e| failed(&what, e))?;
    let mut ids = Vec::new();
    for o in &scene.truth[0].objects {
        ids.push(
            m.add_object(scene.frames[0].view(), o.bbox)
                .map_err(|e| failed(&what, e))?,
        );
    }
    let mut out = CrossingRun {
        key,
        priority,
        count: CrossingCount::default(),
        kept_at_end: false,
    };
    for (k, frame) in scene.frames.iter().enumerate().skip(1) {
        let est = m
            .step(frame.view())
            .map_err(|e| failed(&what, format!("frame {k}: {e}")))?;
        let truth: Vec<[f64; 2]> = scene.truth[k].objects.iter().map(|o| o.center0()).collect();
        if k <= aligned || (truth[0][0] - truth[1][0]).abs() <= config.separation {
            continue;
        }
        let at = |id: u64| {
            est.iter()
                .find(|e| e.id == id)
                .map_or([f64::NAN; 2], |e| [e.centre.0, e.centre.1])
        };
        let on = |i: usize, j: usize| {
            let c = at(ids[i]);
            (c[0] - truth[j][0]).hypot(c[1] - truth[j][1]) <= config.lock_distance
        };
        let kept = on(0, 0) && on(1, 1);
        if kept {
            out.count.kept += 1;
        } else if on(0, 1) && on(1, 0) {
            out.count.swapped += 1;
        } else if (on(0, 0) && on(1, 0)) || (on(0, 1) && on(1, 1)) {
            out.count.merged += 1;
        } else {
            out.count.lost += 1;
        }
        out.kept_at_end = kept;
    }
    Ok(out)
}

/// A snapshot of the contour particles for the figure.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ParticleSnapshot {
    /// Frame index.
    pub frame: usize,
    /// The frame.
    #[serde(with = "packed_image")]
    pub image: Image<u8>,
    /// Each particle's curve (0-based px) and its weight.
    pub curves: Vec<(Vec<[f64; 2]>, f64)>,
    /// The mean contour.
    pub mean: Vec<[f64; 2]>,
    /// The true outline.
    pub truth: Outline,
}

fn snapshot(scene: &Rendered, frame: usize) -> Result<ParticleSnapshot, ExperimentError> {
    let what = "particle figure";
    let mut t = ContourTracker::new(ContourConfig::face(100), 0).map_err(|e| failed(what, e))?;
    let face = scene.truth[0]
        .target()
        .ok_or_else(|| failed(what, "no face"))?;
    t.init(scene.frames[0].view(), face.bbox)
        .map_err(|e| failed(what, e))?;
    let frame = frame.clamp(1, scene.frames.len() - 1);
    for f in &scene.frames[1..=frame] {
        t.step(f.view()).map_err(|e| failed(what, e))?;
    }
    let pts = |v: Vec<nalgebra::Vector2<f64>>| v.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>();
    let particles = t.particles().ok_or_else(|| failed(what, "no particles"))?;
    let weights = t.weights().ok_or_else(|| failed(what, "no weights"))?;
    let curves = particles
        .iter()
        .zip(weights)
        .map(|(s, w)| (pts(t.curve(s)), w))
        .collect();
    let m = t.mean_state().ok_or_else(|| failed(what, "no mean"))?;
    Ok(ParticleSnapshot {
        frame,
        image: scene.frames[frame].clone(),
        curves,
        mean: pts(t.curve(&m)),
        truth: scene.outlines[frame].clone(),
    })
}

/// The whole result.
#[derive(Debug, Clone)]
pub struct CondensationResult {
    /// The configuration that produced it.
    pub config: CondensationConfig,
    /// Per grid cell ([`GridKey::all`] order), one run per seed.
    pub grid: Vec<(GridKey, Vec<TrackRun>)>,
    /// Re-initialisation runs (representation x c-AVQ x seed).
    pub reinit: Vec<ReinitRun>,
    /// Crossing runs (representation x priority x seed).
    pub crossing: Vec<CrossingRun>,
    /// Contour particles on one frame of run 0.
    pub snapshot: ParticleSnapshot,
}

/// What job `j` is: the grid runs key-major (`frames.csv`'s order), then
/// per run the side trackers' re-initialisation and crossing runs, then the
/// particle snapshot of run 0.
#[derive(Debug, Clone, Copy)]
enum Job {
    Grid(GridKey, usize),
    Reinit(GridKey, bool, usize),
    Crossing(GridKey, bool, usize),
    Snapshot,
}

/// Job `j` of `config`.
fn job(config: &CondensationConfig, j: usize) -> Job {
    let keys = GridKey::all();
    let grid = keys.len() * config.runs;
    if j < grid {
        return Job::Grid(keys[j / config.runs], j % config.runs);
    }
    let side = j - grid;
    let per_run = SIDE_TRACKERS.len() * 4;
    if side >= per_run * config.runs {
        return Job::Snapshot;
    }
    let (r, i) = (side / per_run, side % per_run);
    let key = SIDE_TRACKERS[i / 4];
    let flag = (i % 4) / 2 == 0;
    if i % 2 == 0 {
        Job::Reinit(key, flag, r)
    } else {
        Job::Crossing(key, flag, r)
    }
}

/// What one job gives.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub enum Done {
    /// A grid run.
    Grid(TrackRun),
    /// A re-initialisation run.
    Reinit(ReinitRun),
    /// A crossing run.
    Crossing(CrossingRun),
    /// The particle snapshot.
    Snapshot(Box<ParticleSnapshot>),
}

/// An [`Image`] as `(width, height, channels, packed samples)`.
mod packed_image {
    use bayestrack_image::Image;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(img: &Image<u8>, s: S) -> Result<S::Ok, S::Error> {
        let packed = img.view().to_image();
        (
            packed.width(),
            packed.height(),
            packed.channels(),
            packed.as_slice(),
        )
            .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Image<u8>, D::Error> {
        let (w, h, c, data) = <(usize, usize, usize, Vec<u8>)>::deserialize(d)?;
        Image::from_vec(w, h, c, data).map_err(serde::de::Error::custom)
    }
}

/// The scenes a run's jobs track: the tracking, entering and crossing
/// scenes.
type Scenes = [Rendered; 3];

/// The scenes of the runs one process's jobs track, rendered once.
pub struct RenderedRuns(Vec<Option<Scenes>>);

/// Renders the scenes of the runs `jobs` need (in parallel).
fn prepare(config: &CondensationConfig, jobs: &[usize]) -> Result<RenderedRuns, ExperimentError> {
    let mut needed = vec![false; config.runs];
    for &j in jobs {
        match job(config, j) {
            Job::Grid(_, r) | Job::Reinit(_, _, r) | Job::Crossing(_, _, r) => needed[r] = true,
            Job::Snapshot => needed[0] = true,
        }
    }
    let (enter, _) = entering_scene(config);
    let cross = WebcamScene::crossing();
    needed
        .par_iter()
        .enumerate()
        .map(|(r, &need)| {
            if !need {
                return Ok(None);
            }
            let s = config.scene_seed + r as u64;
            Ok(Some([
                render(&tracking_scene(config), s)?,
                render(&enter, s)?,
                render(&cross, s)?,
            ]))
        })
        .collect::<Result<_, _>>()
        .map(RenderedRuns)
}

/// Runs job `j` on the rendered scenes.
fn run_job(
    config: &CondensationConfig,
    scenes: &RenderedRuns,
    j: usize,
) -> Result<Done, ExperimentError> {
    let job = job(config, j);
    let r = match job {
        Job::Grid(_, r) | Job::Reinit(_, _, r) | Job::Crossing(_, _, r) => r,
        Job::Snapshot => 0,
    };
    let scenes = scenes
        .0
        .get(r)
        .and_then(Option::as_ref)
        .ok_or_else(|| failed("scene", format!("run {r} not rendered")))?;
    let (_, entry) = entering_scene(config);
    let aligned = match WebcamScene::crossing().second {
        crate::scenes::SecondObject::Crossing { frame } => frame,
        _ => 0,
    };
    Ok(match job {
        Job::Grid(key, r) => {
            let s = &scenes[0];
            Done::Grid(track(key, config, r, &s.frames, &s.truth, &s.outlines)?)
        }
        Job::Reinit(key, avq, r) => {
            Done::Reinit(reinit_run(key, avq, config, r, &scenes[1], entry)?)
        }
        Job::Crossing(key, pr, r) => {
            Done::Crossing(crossing_run(key, pr, config, r, &scenes[2], aligned)?)
        }
        Job::Snapshot => Done::Snapshot(Box::new(snapshot(&scenes[0], config.frames / 2)?)),
    })
}

/// The result from every job's, in job order.
fn assemble(
    config: &CondensationConfig,
    done: Vec<Done>,
) -> Result<CondensationResult, ExperimentError> {
    let mut grid: Vec<(GridKey, Vec<TrackRun>)> = GridKey::all()
        .into_iter()
        .map(|k| (k, Vec::new()))
        .collect();
    let mut reinit = Vec::new();
    let mut crossing = Vec::new();
    let mut snapshot = None;
    for (j, d) in done.into_iter().enumerate() {
        match (job(config, j), d) {
            (Job::Grid(key, _), Done::Grid(t)) => {
                if let Some(cell) = grid.iter_mut().find(|(k, _)| *k == key) {
                    cell.1.push(t);
                }
            }
            (_, Done::Reinit(r)) => reinit.push(r),
            (_, Done::Crossing(c)) => crossing.push(c),
            (_, Done::Snapshot(s)) => snapshot = Some(*s),
            _ => return Err(failed("jobs", format!("job {j} out of place"))),
        }
    }
    Ok(CondensationResult {
        config: *config,
        grid,
        reinit,
        crossing,
        snapshot: snapshot.ok_or_else(|| failed("particle figure", "no snapshot"))?,
    })
}

/// Runs the experiment (jobs in parallel; each has its own seeds, so the
/// result does not depend on the thread count).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, run and frame;
/// [`ExperimentError::BadOption`] for options outside their domains.
pub fn run(
    config: &CondensationConfig,
    progress: bool,
) -> Result<CondensationResult, ExperimentError> {
    let done = crate::driver::run_all::<CondensationExperiment>(config, None, progress)?;
    assemble(config, done)
}

/// One row of `frames.csv`: one frame of one grid run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameRow {
    /// [`Representation::name`].
    pub representation: &'static str,
    /// [`Cue::name`].
    pub cue: &'static str,
    /// Particles (contours or points).
    pub particles: usize,
    /// Run index (0-based).
    pub run: usize,
    /// Frame number (1-based).
    pub frame: usize,
    /// Centre error (pixels).
    pub centre: f64,
    /// Outline error (pixels); empty for the point clouds (no outline).
    pub outline: Option<f64>,
    /// Whether the frame is lost.
    pub lost: bool,
}

/// The `frames.csv` rows of one grid cell's run.
fn frame_rows(key: GridKey, run: usize, tr: &TrackRun) -> Vec<FrameRow> {
    (0..tr.centre.len())
        .map(|k| FrameRow {
            representation: key.representation.name(),
            cue: key.cue.name(),
            particles: key.particles,
            run,
            frame: k + 1,
            centre: tr.centre[k],
            outline: tr.outline.get(k).copied(),
            lost: tr.lost[k],
        })
        .collect()
}

/// One grid cell over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSummary {
    /// The cell.
    pub key: GridKey,
    /// Mean centre error (px) over frames and runs.
    pub centre: f64,
    /// Mean curve-to-outline distance (px); NaN for the point cloud.
    pub outline: f64,
    /// Share of frames lost.
    pub loss: f64,
    /// Frames per second (step only; one thread, measured while the other
    /// jobs run).
    pub fps: f64,
}

/// Re-initialisation over runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ReinitSummary {
    /// The tracker.
    pub key: GridKey,
    /// Whether c-AVQ was on.
    pub avq: bool,
    /// Lock-on frames per run (`None`: never).
    pub lock_on: Vec<Option<usize>>,
}

impl ReinitSummary {
    /// Runs that locked on.
    pub fn locked(&self) -> usize {
        self.lock_on.iter().flatten().count()
    }

    /// The slowest lock-on among the runs that locked on.
    pub fn worst(&self) -> Option<usize> {
        self.lock_on.iter().flatten().copied().max()
    }

    /// Mean lock-on among the runs that locked on.
    pub fn mean(&self) -> f64 {
        let v: Vec<f64> = self.lock_on.iter().flatten().map(|&k| k as f64).collect();
        mean(&v)
    }
}

/// Crossing over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossingSummary {
    /// The tracker of every object.
    pub key: GridKey,
    /// Priority IFD on or off.
    pub priority: bool,
    /// Frames pooled over runs.
    pub count: CrossingCount,
    /// Runs whose last frame has both identities right.
    pub kept_at_end: usize,
    /// Runs.
    pub runs: usize,
}

/// Sec. 3.3's claim at one `N`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClaimRow {
    /// `N`: one cue runs with `N`, AND with `N/2`.
    pub n: usize,
    /// The single cue compared.
    pub single: Cue,
    /// AND at `N/2`.
    pub and: GridSummary,
    /// The single cue at `N`.
    pub one: GridSummary,
}

impl ClaimRow {
    /// Whether AND at `N/2` is better on centre error, outline distance and
    /// loss rate together (ties on loss allowed).
    pub fn reproduces(&self) -> bool {
        self.and.centre < self.one.centre
            && self.and.outline < self.one.outline
            && self.and.loss <= self.one.loss
    }
}

fn opt(v: Option<usize>) -> String {
    v.map_or("never".to_string(), |k| k.to_string())
}

impl CondensationResult {
    /// Summaries in [`GridKey::all`] order.
    pub fn grid_summary(&self) -> Vec<GridSummary> {
        self.grid
            .iter()
            .map(|(key, runs)| {
                let all = |f: fn(&TrackRun) -> &Vec<f64>| -> Vec<f64> {
                    runs.iter().flat_map(|r| f(r).iter().copied()).collect()
                };
                let lost: Vec<f64> = runs
                    .iter()
                    .flat_map(|r| r.lost.iter().map(|&l| f64::from(u8::from(l))))
                    .collect();
                let frames: usize = runs.iter().map(|r| r.centre.len()).sum();
                let seconds: f64 = runs.iter().map(|r| r.seconds).sum();
                GridSummary {
                    key: *key,
                    centre: mean(&all(|r| &r.centre)),
                    outline: mean(&all(|r| &r.outline)),
                    loss: mean(&lost),
                    fps: frames as f64 / seconds.max(1e-12),
                }
            })
            .collect()
    }

    /// The summary of one cell.
    pub fn cell(&self, representation: Representation, cue: Cue, particles: usize) -> GridSummary {
        let key = GridKey {
            representation,
            cue,
            particles,
        };
        self.grid_summary()
            .into_iter()
            .find(|s| s.key == key)
            .unwrap_or(GridSummary {
                key,
                centre: f64::NAN,
                outline: f64::NAN,
                loss: f64::NAN,
                fps: f64::NAN,
            })
    }

    /// Re-initialisation per tracker ([`SIDE_TRACKERS`]) and c-AVQ (on
    /// first).
    pub fn reinit_summary(&self) -> Vec<ReinitSummary> {
        let mut out = Vec::new();
        for key in SIDE_TRACKERS {
            for avq in [true, false] {
                out.push(ReinitSummary {
                    key,
                    avq,
                    lock_on: self
                        .reinit
                        .iter()
                        .filter(|r| r.key == key && r.avq == avq)
                        .map(|r| r.lock_on)
                        .collect(),
                });
            }
        }
        out
    }

    /// Crossing per tracker ([`SIDE_TRACKERS`]) and priority (on first).
    pub fn crossing_summary(&self) -> Vec<CrossingSummary> {
        let mut out = Vec::new();
        for key in SIDE_TRACKERS {
            for priority in [true, false] {
                let runs: Vec<&CrossingRun> = self
                    .crossing
                    .iter()
                    .filter(|c| c.key == key && c.priority == priority)
                    .collect();
                let mut count = CrossingCount::default();
                for r in &runs {
                    count.kept += r.count.kept;
                    count.swapped += r.count.swapped;
                    count.merged += r.count.merged;
                    count.lost += r.count.lost;
                }
                out.push(CrossingSummary {
                    key,
                    priority,
                    count,
                    kept_at_end: runs.iter().filter(|r| r.kept_at_end).count(),
                    runs: runs.len(),
                });
            }
        }
        out
    }

    /// Sec. 3.3: contour AND at `N/2` against IFD and skin alone at `N`.
    pub fn claim(&self) -> Vec<ClaimRow> {
        let mut out = Vec::new();
        for n in [100, 200] {
            for single in [Cue::Ifd, Cue::Skin] {
                out.push(ClaimRow {
                    n,
                    single,
                    and: self.cell(Representation::Contour, Cue::And, n / 2),
                    one: self.cell(Representation::Contour, single, n),
                });
            }
        }
        out
    }

    /// The tracking grid.
    pub fn grid_table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "condensation: tracking grid on the webcam scene ({} frames, {} runs); \
                 lost = centre error > {} x the face's smaller side",
                self.config.frames, self.config.runs, self.config.lost_fraction
            ),
            &[
                "representation",
                "N",
                "cues",
                "centre (px)",
                "outline (px)",
                "lost",
                "fps",
            ],
        );
        for s in self.grid_summary() {
            t.push(vec![
                s.key.representation.name().to_string(),
                s.key.particles.to_string(),
                s.key.cue.name().to_string(),
                format!("{:.2}", s.centre),
                if s.outline.is_nan() {
                    "-".to_string()
                } else {
                    format!("{:.2}", s.outline)
                },
                format!("{:.0}%", 100.0 * s.loss),
                format!("{:.0}", s.fps),
            ]);
        }
        t
    }

    /// Sec. 3.3's claim.
    pub fn claim_table(&self) -> Table {
        let mut t = Table::new(
            "condensation: sec. 3.3 claim, contour AND at N/2 vs one cue at N \
             (centre px / outline px / lost)",
            &["N", "AND at N/2", "one cue at N", "reproduces"],
        );
        let cell = |s: &GridSummary| {
            format!(
                "{} {:.2} / {:.2} / {:.0}%",
                s.key.cue.name(),
                s.centre,
                s.outline,
                100.0 * s.loss
            )
        };
        for c in self.claim() {
            t.push(vec![
                c.n.to_string(),
                cell(&c.and),
                cell(&c.one),
                if c.reproduces() { "yes" } else { "no" }.to_string(),
            ]);
        }
        t
    }

    /// Re-initialisation.
    pub fn reinit_table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "condensation: sec. 4 re-initialisation, frames from the entry to lock-on \
                 (within {} px for {} frames; {} frames tracked after the entry)",
                self.config.lock_distance, self.config.lock_frames, self.config.reinit_frames
            ),
            &["tracker", "c-AVQ", "locked", "mean", "worst", "per run"],
        );
        for s in self.reinit_summary() {
            let per: Vec<String> = s.lock_on.iter().map(|&k| opt(k)).collect();
            t.push(vec![
                s.key.label(),
                if s.avq { "on" } else { "off" }.to_string(),
                format!("{}/{}", s.locked(), s.lock_on.len()),
                if s.locked() > 0 {
                    format!("{:.1}", s.mean())
                } else {
                    "-".to_string()
                },
                opt(s.worst()),
                per.join(" "),
            ]);
        }
        t
    }

    /// Crossing.
    pub fn crossing_table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "condensation: sec. 5 crossing (face and hand, 90 frames), frames after the \
                 crossing with the objects over {} px apart, pooled over runs; on = within {} px",
                self.config.separation, self.config.lock_distance
            ),
            &[
                "tracker",
                "priority IFD",
                "kept",
                "swapped",
                "merged",
                "lost",
                "kept at end",
            ],
        );
        for s in self.crossing_summary() {
            let share =
                |n: usize| format!("{:.0}%", 100.0 * n as f64 / s.count.total().max(1) as f64);
            t.push(vec![
                s.key.label(),
                if s.priority { "on" } else { "off" }.to_string(),
                share(s.count.kept),
                share(s.count.swapped),
                share(s.count.merged),
                share(s.count.lost),
                format!("{}/{}", s.kept_at_end, s.runs),
            ]);
        }
        t
    }

    /// Every table, in print order.
    pub fn tables(&self) -> Vec<Table> {
        vec![
            self.grid_table(),
            self.claim_table(),
            self.reinit_table(),
            self.crossing_table(),
        ]
    }
}

/// The SVG of the particle snapshot: the frame (a PNG beside it), every
/// particle's curve (opacity by weight), the mean contour and the truth.
fn particle_svg(s: &ParticleSnapshot, png: &str) -> String {
    let (w, h) = (s.image.width(), s.image.height());
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\" \
         width=\"{}\" height=\"{}\" viewBox=\"-0.5 -0.5 {w} {h}\">\n\
         <title>condensation: contour particles (AND, N=100), frame {}</title>\n\
         <image x=\"-0.5\" y=\"-0.5\" width=\"{w}\" height=\"{h}\" href=\"{png}\" xlink:href=\"{png}\"/>\n",
        2 * w,
        2 * h,
        s.frame
    );
    let poly = |pts: &[[f64; 2]]| {
        pts.iter()
            .map(|p| format!("{:.2},{:.2}", p[0], p[1]))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let wmax = s.curves.iter().map(|c| c.1).fold(0.0, f64::max).max(1e-300);
    for (curve, wt) in &s.curves {
        let _ = writeln!(
            svg,
            "<polygon points=\"{}\" fill=\"none\" stroke=\"#ffd000\" stroke-width=\"0.4\" stroke-opacity=\"{:.3}\"/>",
            poly(curve),
            0.15 + 0.85 * wt / wmax
        );
    }
    for line in &s.truth.polylines {
        let _ = writeln!(
            svg,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#00c000\" stroke-width=\"0.8\"/>",
            poly(line)
        );
    }
    let _ = writeln!(
        svg,
        "<polygon points=\"{}\" fill=\"none\" stroke=\"#ff0000\" stroke-width=\"0.8\"/>",
        poly(&s.mean)
    );
    svg.push_str(
        "<text x=\"4\" y=\"10\" font-size=\"8\" fill=\"#000\">yellow: particles (opacity by weight); red: mean contour; green: true outline</text>\n</svg>\n",
    );
    svg
}

/// Writes the summary CSV files and the figures under `dir` (`frames.csv`
/// is written by [`CondensationExperiment`] as the runs finish).
fn write_outputs(result: &CondensationResult, dir: &Path) -> Result<(), ExperimentError> {
    for (name, table) in [
        ("grid.csv", result.grid_table()),
        ("claim.csv", result.claim_table()),
        ("reinit.csv", result.reinit_table()),
        ("crossing.csv", result.crossing_table()),
    ] {
        write_text(&dir.join(name), &table.to_csv())?;
    }
    // Error per frame per configuration, averaged over runs.
    let per_frame = |runs: &[TrackRun], f: fn(&TrackRun) -> &Vec<f64>| -> Vec<(f64, f64)> {
        let len = runs.iter().map(|r| f(r).len()).min().unwrap_or(0);
        (0..len)
            .map(|k| {
                let v: Vec<f64> = runs.iter().map(|r| f(r)[k]).collect();
                ((k + 1) as f64, mean(&v))
            })
            .collect()
    };
    for rep in Representation::ALL {
        let series: Vec<Series> = result
            .grid
            .iter()
            .filter(|(k, _)| k.representation == rep)
            .map(|(k, runs)| Series {
                name: format!("{} N={}", k.cue.name(), k.particles),
                points: per_frame(runs, |r| &r.centre),
            })
            .collect();
        line_chart(
            &dir.join(format!("centre_error_{}.svg", rep.name())),
            &format!(
                "condensation, {}: centre error per frame, mean over runs",
                rep.name()
            ),
            "frame",
            "centre error (px)",
            &series,
        )?;
    }
    let outline: Vec<Series> = result
        .grid
        .iter()
        .filter(|(k, _)| k.representation == Representation::Contour)
        .map(|(k, runs)| Series {
            name: format!("{} N={}", k.cue.name(), k.particles),
            points: per_frame(runs, |r| &r.outline),
        })
        .collect();
    line_chart(
        &dir.join("outline_distance_contour.svg"),
        "condensation, contour: mean contour to true outline per frame, mean over runs",
        "frame",
        "outline distance (px)",
        &outline,
    )?;
    let reinit: Vec<Series> = result
        .reinit
        .iter()
        .filter(|r| r.run == 0)
        .map(|r| Series {
            name: format!(
                "{} {}",
                r.key.label(),
                if r.avq { "c-AVQ" } else { "plain" }
            ),
            points: r
                .distance
                .iter()
                .enumerate()
                .map(|(k, &d)| (k as f64, d))
                .collect(),
        })
        .collect();
    line_chart(
        &dir.join("reinit_distance.svg"),
        "condensation: distance from the estimate to the entering hand, run 0",
        "frames since the entry",
        "distance (px)",
        &reinit,
    )?;
    let png = "particles_frame.png";
    write_png(dir.join(png), result.snapshot.image.view()).map_err(|e| failed("figure", e))?;
    write_text(
        &dir.join("particles.svg"),
        &particle_svg(&result.snapshot, png),
    )?;
    Ok(())
}

/// The registry entry (jobs: see [`Done`]).
pub struct CondensationExperiment;

impl Paper for CondensationExperiment {
    type Config = CondensationConfig;
    type Done = Done;
    type Row = FrameRow;
    type Shared = RenderedRuns;
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 003 (sec. 3-5)";
    const SUMMARY: &'static str =
        "CONDENSATION with IFD, skin, OR and AND cues; c-AVQ; priority IFD";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "condensation jobs";

    fn quick() -> CondensationConfig {
        CondensationConfig::quick()
    }
    fn full() -> CondensationConfig {
        CondensationConfig::paper()
    }
    fn jobs(c: &CondensationConfig) -> usize {
        GridKey::all().len() * c.runs + SIDE_TRACKERS.len() * 4 * c.runs + 1
    }
    fn prepare(c: &CondensationConfig, jobs: &[usize]) -> Result<Self::Shared, ExperimentError> {
        prepare(c, jobs)
    }
    fn run_job(
        c: &CondensationConfig,
        scenes: &Self::Shared,
        j: usize,
    ) -> Result<Done, ExperimentError> {
        run_job(c, scenes, j)
    }
    fn rows(c: &CondensationConfig, j: usize, done: &Done) -> Vec<FrameRow> {
        match (job(c, j), done) {
            (Job::Grid(key, r), Done::Grid(tr)) => frame_rows(key, r, tr),
            _ => Vec::new(),
        }
    }
    fn report(
        config: &CondensationConfig,
        done: Vec<Done>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let result = assemble(config, done)?;
        write_outputs(&result, dir)?;
        Ok(result.tables())
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&CondensationConfig::quick(), false)?;
        let mut out = String::from("table,row,column,value\n");
        for s in r.grid_summary() {
            let row = s.key.label();
            for (col, v) in [
                ("centre", s.centre),
                ("outline", s.outline),
                ("lost", s.loss),
            ] {
                // The point cloud has no outline (NaN never equals itself).
                if v.is_finite() {
                    let _ = writeln!(out, "grid,{row},{col},{v:.17e}");
                }
            }
        }
        for (i, rr) in r.reinit.iter().enumerate() {
            let _ = writeln!(
                out,
                "reinit,{} {} job {i},lock_on,{}",
                rr.key.label(),
                if rr.avq { "c-AVQ" } else { "plain" },
                opt(rr.lock_on)
            );
        }
        for (i, c) in r.crossing.iter().enumerate() {
            let _ = writeln!(
                out,
                "crossing,{} priority={} job {i},kept swapped merged lost,{} {} {} {}",
                c.key.label(),
                c.priority,
                c.count.kept,
                c.count.swapped,
                c.count.merged,
                c.count.lost
            );
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let mut c = CondensationConfig::quick();
        c.apply("runs", "3").unwrap();
        c.apply("lost_fraction", "0.25").unwrap();
        c.apply("avq_trigger", "0.04").unwrap();
        assert_eq!((c.runs, c.lost_fraction), (3, 0.25));
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("frames", "1").is_err());
        assert!(c.apply("bogus", "1").is_err());
        assert!(c.apply("lock_distance", "nan").is_err());
        assert!(!c.describe().is_empty());
    }

    #[test]
    fn the_grid_has_every_cell_once() {
        let all = GridKey::all();
        assert_eq!(all.len(), 24);
        for (i, a) in all.iter().enumerate() {
            assert!(all[i + 1..].iter().all(|b| b != a));
        }
    }

    #[test]
    fn lambda_is_one_over_n() {
        assert_eq!(Cue::Or.cue_set(50), CueSet::Or { lambda: 0.02 });
        assert_eq!(Cue::And.cue_set(100), CueSet::And { lambda: 0.01 });
        assert_eq!(Cue::Ifd.cue_set(100), CueSet::Ifd);
    }
}
