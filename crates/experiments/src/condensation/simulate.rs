//! Rendering the scenes and running the trackers: grid, re-initialisation, crossing and snapshot jobs, the per-frame log.

use super::*;

pub(super) fn failed(what: &str, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: ID,
        message: format!("{what}: {e}"),
    }
}

/// A single-target tracker of either representation.
pub(super) enum Single {
    Points(PointCloudTracker),
    Contour(ContourTracker),
}

impl Single {
    pub(super) fn new(
        config: &CondensationConfig,
        representation: Representation,
        cue: Cue,
        particles: usize,
        avq: Option<CAvqConfig>,
        seed: u64,
    ) -> Result<Self, ExperimentError> {
        let what = format!("{} {} N={particles}", representation.name(), cue.name());
        let cues = config.cue_set(representation, cue, particles);
        Ok(match representation {
            Representation::Points => Single::Points(
                PointCloudTracker::new(
                    PointCloudConfig {
                        cues,
                        avq,
                        ..PointCloudConfig::paper(particles)
                    },
                    seed,
                )
                .map_err(|e| failed(&what, e))?,
            ),
            Representation::Contour => Single::Contour(
                ContourTracker::new(
                    config.contour(ContourConfig {
                        cues,
                        avq,
                        ..ContourConfig::face(particles)
                    }),
                    seed,
                )
                .map_err(|e| failed(&what, e))?,
            ),
        })
    }

    pub(super) fn tracker(&mut self) -> &mut dyn Tracker {
        match self {
            Single::Points(t) => t,
            Single::Contour(t) => t,
        }
    }

    /// The mean contour's measurement points (contours only).
    pub(super) fn mean_curve(&self) -> Option<Vec<[f64; 2]>> {
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

pub(super) fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

pub(super) fn box_centre(b: &BBox) -> [f64; 2] {
    let (x, y) = b.center();
    [x - 1.0, y - 1.0]
}

pub(super) fn track(
    key: GridKey,
    config: &CondensationConfig,
    run: usize,
    frames: &[Image<u8>],
    truth: &[FrameTruth],
    outlines: &[Outline],
) -> Result<TrackRun, ExperimentError> {
    let what = format!("{} run {run}", key.label());
    let t = Single::new(
        config,
        key.representation,
        key.cue,
        key.particles,
        None,
        run as u64,
    )?;
    track_with(t, &what, config, frames, truth, outlines)
}

/// Sec. 3.2: the hand contour (IFD only, `N = 200`, 45 control points,
/// [`ContourConfig::hand`]; the template the ellipse inscribed in the
/// hand's first box) through the hand scene.
pub(super) fn hand_run(
    config: &CondensationConfig,
    run: usize,
    scene: &Rendered,
) -> Result<TrackRun, ExperimentError> {
    let what = format!("{} run {run}", HAND_LABEL);
    let t = Single::Contour(
        ContourTracker::new(config.contour(ContourConfig::hand()), run as u64)
            .map_err(|e| failed(&what, e))?,
    );
    track_with(
        t,
        &what,
        config,
        &scene.frames,
        &scene.truth,
        &scene.outlines,
    )
}

/// The row label of the sec. 3.2 hand run.
pub const HAND_LABEL: &str = "hand contour IFD N=200 n=45";

fn track_with(
    mut t: Single,
    what: &str,
    config: &CondensationConfig,
    frames: &[Image<u8>],
    truth: &[FrameTruth],
    outlines: &[Outline],
) -> Result<TrackRun, ExperimentError> {
    let target = |k: usize| {
        truth[k]
            .target()
            .ok_or_else(|| failed(what, format!("frame {k} has no target")))
    };
    t.tracker()
        .init(frames[0].view(), target(0)?.bbox)
        .map_err(|e| failed(what, e))?;
    let mut out = TrackRun::default();
    for (k, frame) in frames.iter().enumerate().skip(1) {
        let start = Instant::now();
        let e = t
            .tracker()
            .step(frame.view())
            .map_err(|e| failed(what, format!("frame {k}: {e}")))?;
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
pub(super) struct Rendered {
    frames: Vec<Image<u8>>,
    truth: Vec<FrameTruth>,
    /// Outline of object 0 per frame.
    outlines: Vec<Outline>,
}

pub(super) fn render(scene: &WebcamScene, seed: u64) -> Result<Rendered, ExperimentError> {
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

/// The tracking scene.
pub(super) fn tracking_scene(config: &CondensationConfig) -> WebcamScene {
    config.posed(WebcamScene {
        frames: config.frames,
        ..WebcamScene::default()
    })
}

/// The hand scene of sec. 3.2: the tracking scene with the hand as the
/// target.
pub(super) fn hand_scene(config: &CondensationConfig) -> WebcamScene {
    WebcamScene {
        target: SkinShape::Hand,
        ..tracking_scene(config)
    }
}

/// The crossing scene.
pub(super) fn crossing_scene(config: &CondensationConfig) -> WebcamScene {
    config.scene(WebcamScene::crossing())
}

/// The entering scene, cut `reinit_frames` after the entry.
pub(super) fn entering_scene(config: &CondensationConfig) -> (WebcamScene, usize) {
    let mut s = config.scene(WebcamScene::entering());
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

pub(super) fn reinit_run(
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
        config,
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

pub(super) fn crossing_run(
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
            cues: config.cue_set(key.representation, key.cue, n),
            ..PointCloudConfig::paper(n)
        }),
        Representation::Contour => ObjectConfig::Contour(config.contour(ContourConfig {
            cues: config.cue_set(key.representation, key.cue, n),
            ..ContourConfig::face(n)
        })),
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

pub(super) fn snapshot(
    config: &CondensationConfig,
    scene: &Rendered,
    frame: usize,
) -> Result<ParticleSnapshot, ExperimentError> {
    let what = "particle figure";
    let mut t = ContourTracker::new(config.contour(ContourConfig::face(100)), 0)
        .map_err(|e| failed(what, e))?;
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
    /// The sec. 3.2 hand runs, one per seed.
    pub hand: Vec<TrackRun>,
    /// The readings' runs (`readings=true`), in [`READINGS`] order.
    pub readings: Vec<ReadingResult>,
    /// Contour particles on one frame of run 0.
    pub snapshot: ParticleSnapshot,
}

/// What job `j` is: the grid runs key-major (`frames.csv`'s order), then
/// per run the side trackers' re-initialisation and crossing runs, then the
/// hand run of each run, then the particle snapshot of run 0.
#[derive(Debug, Clone, Copy)]
pub(super) enum Job {
    Grid(GridKey, usize),
    Reinit(GridKey, bool, usize),
    Crossing(GridKey, bool, usize),
    Hand(usize),
    Snapshot,
}

/// Job `j` of `config`.
pub(super) fn job(config: &CondensationConfig, j: usize) -> Job {
    let keys = GridKey::all();
    let grid = keys.len() * config.runs;
    if j < grid {
        return Job::Grid(keys[j / config.runs], j % config.runs);
    }
    let side = j - grid;
    let per_run = SIDE_TRACKERS.len() * 4;
    if side >= per_run * config.runs {
        let hand = side - per_run * config.runs;
        return if hand < config.runs {
            Job::Hand(hand)
        } else {
            Job::Snapshot
        };
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
    /// A sec. 3.2 hand run.
    Hand(TrackRun),
    /// The particle snapshot.
    Snapshot(Box<ParticleSnapshot>),
}

/// An [`Image`] as `(width, height, channels, packed samples)`.
pub(super) mod packed_image {
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

/// Which of a run's four scenes a job tracks: the tracking scene (grid
/// jobs and the snapshot), the entering, crossing and hand scenes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SceneKind {
    Tracking = 0,
    Entering = 1,
    Crossing = 2,
    Hand = 3,
}

impl Job {
    /// The run whose scenes the job tracks and which of them.
    pub(super) fn scene(self) -> (usize, SceneKind) {
        match self {
            Job::Grid(_, r) => (r, SceneKind::Tracking),
            Job::Reinit(_, _, r) => (r, SceneKind::Entering),
            Job::Crossing(_, _, r) => (r, SceneKind::Crossing),
            Job::Hand(r) => (r, SceneKind::Hand),
            Job::Snapshot => (0, SceneKind::Tracking),
        }
    }
}

/// The scenes one process's jobs track, rendered once: per run, each of
/// its four scenes (`SceneKind` order) when some job needs it.
pub struct RenderedRuns(Vec<[Option<Rendered>; 4]>);

/// Renders the scenes `jobs` need (in parallel).
pub(super) fn prepare(
    config: &CondensationConfig,
    jobs: &[usize],
) -> Result<RenderedRuns, ExperimentError> {
    let mut needed = vec![[false; 4]; config.runs];
    for &j in jobs {
        let (r, kind) = job(config, j).scene();
        needed[r][kind as usize] = true;
    }
    let (enter, _) = entering_scene(config);
    let scenes = [
        tracking_scene(config),
        enter,
        crossing_scene(config),
        hand_scene(config),
    ];
    let wanted: Vec<(usize, usize)> = needed
        .iter()
        .enumerate()
        .flat_map(|(r, n)| (0..4).filter(move |&k| n[k]).map(move |k| (r, k)))
        .collect();
    let rendered = wanted
        .par_iter()
        .map(|&(r, k)| render(&scenes[k], config.scene_seed + r as u64))
        .collect::<Result<Vec<_>, _>>()?;
    let mut out: Vec<[Option<Rendered>; 4]> =
        (0..config.runs).map(|_| Default::default()).collect();
    for ((r, k), scene) in wanted.into_iter().zip(rendered) {
        out[r][k] = Some(scene);
    }
    Ok(RenderedRuns(out))
}

/// The jobs that track one scene of one run per group (the snapshot with
/// run 0's tracking scene), so that one scene's frames are in memory at a
/// time: keeping every run's frames took 855 MB at paper scale, one run's
/// four scenes at a time about 120 MB in the 320x240 frame and four times
/// that in the `frame-640x480` reading.
pub(super) fn groups(config: &CondensationConfig, jobs: &[usize]) -> Vec<Vec<usize>> {
    let mut groups = vec![Vec::new(); 4 * config.runs];
    for &j in jobs {
        let (r, kind) = job(config, j).scene();
        groups[4 * r + kind as usize].push(j);
    }
    groups.retain(|g| !g.is_empty());
    groups
}

/// Runs job `j` on the rendered scenes.
pub(super) fn run_job(
    config: &CondensationConfig,
    scenes: &RenderedRuns,
    j: usize,
) -> Result<Done, ExperimentError> {
    let job = job(config, j);
    let (r, kind) = job.scene();
    let scene = scenes
        .0
        .get(r)
        .and_then(|s| s[kind as usize].as_ref())
        .ok_or_else(|| failed("scene", format!("run {r}'s {kind:?} scene not rendered")))?;
    let (_, entry) = entering_scene(config);
    let aligned = match WebcamScene::crossing().second {
        crate::scenes::SecondObject::Crossing { frame } => frame,
        _ => 0,
    };
    Ok(match job {
        Job::Grid(key, r) => Done::Grid(track(
            key,
            config,
            r,
            &scene.frames,
            &scene.truth,
            &scene.outlines,
        )?),
        Job::Reinit(key, avq, r) => Done::Reinit(reinit_run(key, avq, config, r, scene, entry)?),
        Job::Crossing(key, pr, r) => {
            Done::Crossing(crossing_run(key, pr, config, r, scene, aligned)?)
        }
        Job::Hand(r) => Done::Hand(hand_run(config, r, scene)?),
        Job::Snapshot => Done::Snapshot(Box::new(snapshot(config, scene, config.frames / 2)?)),
    })
}

/// The result from every job's, in job order.
pub(super) fn assemble(
    config: &CondensationConfig,
    done: Vec<Done>,
) -> Result<CondensationResult, ExperimentError> {
    let mut grid: Vec<(GridKey, Vec<TrackRun>)> = GridKey::all()
        .into_iter()
        .map(|k| (k, Vec::new()))
        .collect();
    let mut reinit = Vec::new();
    let mut crossing = Vec::new();
    let mut hand = Vec::new();
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
            (_, Done::Hand(h)) => hand.push(h),
            (_, Done::Snapshot(s)) => snapshot = Some(*s),
            _ => return Err(failed("jobs", format!("job {j} out of place"))),
        }
    }
    Ok(CondensationResult {
        config: *config,
        grid,
        reinit,
        crossing,
        hand,
        readings: Vec::new(),
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
    let mut result = assemble(config, done)?;
    result.readings = run_readings(config, progress)?;
    Ok(result)
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
pub(super) fn frame_rows(key: GridKey, run: usize, tr: &TrackRun) -> Vec<FrameRow> {
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
