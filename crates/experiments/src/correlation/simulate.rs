//! Rendering the road and running the trackers: single-car runs, the two-car run, the per-frame log.

use super::*;

pub(super) fn failed(what: &str, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: "correlation",
        message: format!("{what}: {e}"),
    }
}

/// One tracker's run on the single-car scene.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackRun {
    /// Window centre per frame (0-based); frame 0 is the initial box.
    pub centres: Vec<[f64; 2]>,
    /// Whether the tracker reported the target lost, per frame.
    pub lost: Vec<bool>,
}

/// The phases of the single-car scene, by visibility of the car.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseErrors {
    /// Mean error (px) while the car is fully visible before the billboard.
    pub before: f64,
    /// Mean error while it is partly or fully hidden.
    pub during: f64,
    /// Mean error once it is fully visible again.
    pub after: f64,
}

/// Everything one run produced.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    /// Ground truth centres per frame.
    pub truth: Vec<[f64; 2]>,
    /// Visible fraction of the car per frame.
    pub visible: Vec<f64>,
    /// One run per [`Variant::ALL`].
    pub tracks: Vec<TrackRun>,
}

impl RunResult {
    /// Errors of variant `v` per frame.
    pub fn errors(&self, v: Variant) -> Vec<f64> {
        let i = Variant::ALL.iter().position(|&x| x == v).unwrap_or(0);
        self.tracks[i]
            .centres
            .iter()
            .zip(&self.truth)
            .map(|(c, t)| (c[0] - t[0]).hypot(c[1] - t[1]))
            .collect()
    }

    /// Mean errors of variant `v` before, during and after the occlusion
    /// (frame 0, the initial box, left out).
    pub fn phases(&self, v: Variant) -> PhaseErrors {
        let e = self.errors(v);
        let first_hidden = self
            .visible
            .iter()
            .position(|&f| f < 1.0 - 1e-9)
            .unwrap_or(self.visible.len());
        let last_hidden = self
            .visible
            .iter()
            .rposition(|&f| f < 1.0 - 1e-9)
            .unwrap_or(first_hidden);
        let mean = |a: usize, b: usize| {
            let s = &e[a.min(b)..b];
            if s.is_empty() {
                f64::NAN
            } else {
                s.iter().sum::<f64>() / s.len() as f64
            }
        };
        PhaseErrors {
            before: mean(1, first_hidden),
            during: mean(first_hidden, last_hidden + 1),
            after: mean(last_hidden + 1, e.len()),
        }
    }
}

/// The multi-target run (Table 3).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MultiResult {
    /// Per frame, per car (truth order): `[x, y, Lx, Ly]` of the track that
    /// follows it, `None` when no track does.
    pub tracks: Vec<[Option<[f64; 4]>; 2]>,
    /// Per frame, the truth `[x, y, w, h]` of the two cars.
    pub truth: Vec<[[f64; 4]; 2]>,
    /// Per frame, the ids of the live tracks.
    pub ids: Vec<Vec<u64>>,
}

/// The whole result.
#[derive(Debug, Clone, PartialEq)]
pub struct CorrelationResult {
    /// The configuration that produced it.
    pub config: CorrelationConfig,
    /// Runs on the single-car scene.
    pub runs: Vec<RunResult>,
    /// Run 0 of the two-car scene.
    pub multi: MultiResult,
}

pub(super) fn car_truth(t: &FrameTruth) -> ([f64; 2], f64) {
    t.target()
        .map_or(([f64::NAN; 2], 0.0), |o| (o.center0(), o.visible_fraction))
}

/// The initial box: a template of whole pixels centred on the car's centre
/// (rounded), one pixel larger than the car so that its anti-aliased edges
/// are inside.
pub(super) fn initial_box(t: &FrameTruth) -> Result<BBox, ExperimentError> {
    let o = t
        .target()
        .ok_or_else(|| failed("scene", "the road scene has no car"))?;
    let [cx, cy] = o.center0();
    let (w, h) = (o.bbox.width.round() + 1.0, o.bbox.height.round() + 1.0);
    // 0-based top-left of a w x h window centred at (cx, cy), OTB = + 1.
    Ok(BBox::new(
        (cx - (w - 1.0) / 2.0).round() + 1.0,
        (cy - (h - 1.0) / 2.0).round() + 1.0,
        w,
        h,
    ))
}

pub(super) fn one_run(c: &CorrelationConfig, run: usize) -> Result<RunResult, ExperimentError> {
    let scene = RoadScene::default()
        .generate(c.scene_seed + run as u64)
        .map_err(|e| failed("scene", e))?;
    let (truth, visible): (Vec<[f64; 2]>, Vec<f64>) = scene.truth.iter().map(car_truth).unzip();
    let init = initial_box(&scene.truth[0])?;
    let tracks = Variant::ALL
        .iter()
        .map(|&v| {
            let mut t = c.tracker(v, run)?;
            let first = scene
                .frames
                .first()
                .ok_or_else(|| failed("scene", "no frame"))?;
            t.init(first.view(), init)
                .map_err(|e| failed(v.name(), e))?;
            let (cx, cy) = init.center();
            let mut centres = vec![[cx - 1.0, cy - 1.0]];
            let mut lost = vec![false];
            for (k, f) in scene.frames.iter().enumerate().skip(1) {
                let e = t
                    .step(f.view())
                    .map_err(|e| failed(v.name(), format!("run {run} frame {k}: {e}")))?;
                let (x, y) = e.bbox.center();
                centres.push([x - 1.0, y - 1.0]);
                lost.push(e.lost);
            }
            Ok(TrackRun { centres, lost })
        })
        .collect::<Result<_, ExperimentError>>()?;
    Ok(RunResult {
        truth,
        visible,
        tracks,
    })
}

pub(super) fn multi_run(c: &CorrelationConfig) -> Result<MultiResult, ExperimentError> {
    let params = RoadScene::two_cars();
    let bg: Image<u8> = params
        .background(c.scene_seed)
        .map_err(|e| failed("scene", e))?;
    let scene = params
        .generate(c.scene_seed)
        .map_err(|e| failed("scene", e))?;
    let mut tracker = MultiTargetTracker::new(MultiTargetConfig::default(), bg.view())
        .map_err(|e| failed("multi-target", e))?;
    let mut owner: [Option<u64>; 2] = [None, None];
    let mut out = MultiResult {
        tracks: vec![],
        truth: vec![],
        ids: vec![],
    };
    for (k, (f, t)) in scene.frames.iter().zip(&scene.truth).enumerate() {
        let tracks = tracker
            .step(f.view())
            .map_err(|e| failed("multi-target", format!("frame {k}: {e}")))?;
        let mut truth = [[f64::NAN; 4]; 2];
        for (i, slot) in truth.iter_mut().enumerate() {
            if let Some(o) = t.object(i) {
                let [x, y] = o.center0();
                *slot = [x, y, o.bbox.width, o.bbox.height];
            }
        }
        // Each car is followed by the track nearest to it when first seen;
        // the identity is then kept (a swap shows as a large error).
        for (i, own) in owner.iter_mut().enumerate() {
            if own.is_none() {
                *own = tracks
                    .iter()
                    .min_by(|a, b| {
                        let d = |tr: &bayestrack_trackers::Track| {
                            (tr.feature.centroid.0 - truth[i][0])
                                .hypot(tr.feature.centroid.1 - truth[i][1])
                        };
                        d(a).total_cmp(&d(b))
                    })
                    .map(|tr| tr.id);
            }
        }
        let follow = |i: usize| {
            owner[i]
                .and_then(|id| tracks.iter().find(|tr| tr.id == id))
                .map(|tr| {
                    [
                        tr.feature.centroid.0,
                        tr.feature.centroid.1,
                        tr.feature.size.0,
                        tr.feature.size.1,
                    ]
                })
        };
        out.tracks.push([follow(0), follow(1)]);
        out.truth.push(truth);
        out.ids.push(tracks.iter().map(|tr| tr.id).collect());
    }
    Ok(out)
}

/// Runs the experiment (runs in parallel; each has its own seeds, so the
/// result does not depend on the thread count).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, run and frame.
pub fn run(config: &CorrelationConfig) -> Result<CorrelationResult, ExperimentError> {
    let done = crate::driver::run_all::<CorrelationExperiment>(config, None, false)?;
    assemble(config, done)
}

/// What one job gives: a run on the single-car scene, or the two-car run.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub enum Done {
    /// Run `r` of the single-car scene (job `r`).
    Run(RunResult),
    /// The two-car run (the last job).
    Multi(MultiResult),
}

/// The result from every job's, in job order.
pub(super) fn assemble(
    config: &CorrelationConfig,
    done: Vec<Done>,
) -> Result<CorrelationResult, ExperimentError> {
    let mut runs = Vec::new();
    let mut multi = None;
    for d in done {
        match d {
            Done::Run(r) => runs.push(r),
            Done::Multi(m) => multi = Some(m),
        }
    }
    Ok(CorrelationResult {
        config: *config,
        runs,
        multi: multi.ok_or_else(|| failed("multi-target", "no two-car run"))?,
    })
}

/// One row of `frames.csv`: one tracker on one frame of one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameRow {
    /// Run index (0-based).
    pub run: usize,
    /// Frame number (1-based).
    pub frame: usize,
    /// True centre, x (px).
    pub truth_x: f64,
    /// True centre, y (px).
    pub truth_y: f64,
    /// Visible share of the car.
    pub visible: f64,
    /// [`Variant::name`].
    pub tracker: &'static str,
    /// Estimated centre, x (px).
    pub x: f64,
    /// Estimated centre, y (px).
    pub y: f64,
    /// Whether the tracker reported itself lost.
    pub lost: bool,
}

/// The `frames.csv` rows of run `r`: every frame of every tracker.
pub(super) fn frame_rows(r: usize, run: &RunResult) -> Vec<FrameRow> {
    let mut rows = Vec::new();
    for k in 0..run.truth.len() {
        for (v, tr) in Variant::ALL.iter().zip(&run.tracks) {
            rows.push(FrameRow {
                run: r,
                frame: k + 1,
                truth_x: run.truth[k][0],
                truth_y: run.truth[k][1],
                visible: run.visible[k],
                tracker: v.name(),
                x: tr.centres[k][0],
                y: tr.centres[k][1],
                lost: tr.lost[k],
            });
        }
    }
    rows
}
