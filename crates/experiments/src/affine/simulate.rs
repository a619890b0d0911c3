//! Rendering the sequences and running the filters, the jobs, the per-frame log.

use super::*;

/// A fresh tracker of `filter` for `setting`, seeded with `seed`.
pub(super) fn new_tracker(
    filter: Filter,
    setting: Setting,
    config: &AffineConfig,
    seed: u64,
) -> bayestrack_trackers::Result<Box<dyn AffineTracker>> {
    Ok(match filter {
        Filter::Hkpf => Box::new(HkpfTracker::new(config.hkpf(setting), seed)?),
        Filter::Ispf => Box::new(IspfTracker::new(config.ispf(), seed)?),
        Filter::Stpf => Box::new(StpfTracker::new(config.stpf(), seed)?),
    })
}

pub(super) fn matrix(rows: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| rows[i][j])
}

pub(super) fn apply(m: &Matrix3<f64>, p: [f64; 2]) -> [f64; 2] {
    let v = m * Vector3::new(p[0], p[1], 1.0);
    [v[0], v[1]]
}

/// One filter through one rendered sequence.
pub(super) fn track(
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
        new_tracker(filter, setting, config, run as u64).map_err(|e| failed(e.to_string()))?;
    let first = affine(0)?;
    let init_box = truth[0]
        .objects
        .first()
        .ok_or_else(|| failed("no target in frame 1".into()))?
        .bbox;
    let start = Instant::now();
    t.init(frames[0].view(), init_box)
        .map_err(|e| failed(format!("frame 1: {e}")))?;
    let mut seconds = start.elapsed().as_secs_f64();
    let est0 = t
        .pose()
        .map(|p| matrix(&p.to_matrix3()))
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
            .step(frame.view())
            .map_err(|e| failed(format!("frame {}: {e}", k + 1)))?;
        seconds += start.elapsed().as_secs_f64();
        let stats = t.stats();
        let m = est
            .pose
            .map(|p| matrix(&p.to_matrix3()))
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
pub(super) fn job(config: &AffineConfig, j: usize) -> (Setting, usize) {
    (Setting::ALL[j / config.runs], j % config.runs)
}

/// Every filter through setting `s`'s run `r`.
pub(super) fn run_job(
    config: &AffineConfig,
    s: Setting,
    r: usize,
) -> Result<Vec<TrackRun>, ExperimentError> {
    let scene = s
        .scene(config)
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
pub(super) fn assemble(config: &AffineConfig, done: Vec<Vec<TrackRun>>) -> AffineResult {
    let base = Setting::ALL.len() * config.runs;
    let mut done = done.into_iter();
    let mut runs = vec![Vec::new(); Setting::ALL.len()];
    for (j, r) in done.by_ref().take(base).enumerate() {
        runs[j / config.runs].push(r);
    }
    let mut readings: Vec<ReadingResult> = READINGS
        .iter()
        .map(|reading| ReadingResult {
            reading,
            result: AffineResult {
                // the run's own options where the overrides are refused
                // (`check` refuses such a run before it starts)
                config: reading.config(config).unwrap_or_else(|_| config.clone()),
                runs: runs.clone(),
                readings: Vec::new(),
            },
        })
        .collect();
    let mut fresh = vec![vec![false; Setting::ALL.len()]; READINGS.len()];
    for ((i, s, _), r) in reading_jobs(config).into_iter().zip(done) {
        let slot = &mut readings[i].result.runs[s.index()];
        if !fresh[i][s.index()] {
            slot.clear();
            fresh[i][s.index()] = true;
        }
        slot.push(r);
    }
    if !config.readings {
        readings.clear();
    }
    AffineResult {
        config: config.clone(),
        runs,
        readings,
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
pub(super) fn frame_rows(setting: Setting, run: usize, tracks: &[TrackRun]) -> Vec<FrameRow> {
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
