//! Running the trackers on the rendered scenes: one run, the jobs, the per-run log.

use super::*;

/// Time of the next frame a real-time tracker processes after starting
/// frame `k` at `start` (s); returns `(next frame index, start time of next)`.
pub(super) fn next_realtime(k: usize, start: f64, cost: f64) -> (usize, f64) {
    let done = start + cost;
    // Newest frame that has arrived by `done` (1e-9 s of slack for round-off).
    let newest = ((done + 1e-9) * CAMERA_FPS).floor() as usize;
    let next = newest.max(k + 1);
    let arrival = next as f64 / CAMERA_FPS;
    (next, done.max(arrival))
}

pub(super) fn failed(
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
pub(super) struct Lane {
    tracker: BallTracker,
    mode: FrameMode,
    /// Next frame to process, and when processing can start (s).
    next: usize,
    start: f64,
    cost: f64,
    last_seen: usize,
    out: TrackOutcome,
}

/// The ball's centre at time `t` (s): the ground truth of the camera frames
/// around `t`, interpolated linearly (the last frame's after the end).
pub(super) fn centre_at(centres: &[[f64; 2]], t: f64) -> [f64; 2] {
    let x = (t * CAMERA_FPS).max(0.0);
    let i = (x.floor() as usize).min(centres.len().saturating_sub(1));
    let Some(&a) = centres.get(i) else {
        return [f64::NAN; 2];
    };
    let Some(&b) = centres.get(i + 1) else {
        return a;
    };
    let u = x - i as f64;
    [a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])]
}

pub(super) fn scene_failed(condition: Condition, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: "ball",
        message: format!("scene {}: {e}", condition.name()),
    }
}

/// Runs every tracker in both modes on run `run` of `condition` (and the
/// budgeted KF/UKF unless the budget is off).
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
        .map_err(|e| scene_failed(condition, e))?;
    // The whole trajectory first (no rendering), for the delayed scoring.
    let mut centres = Vec::with_capacity(scene.frames);
    let mut ahead = scene
        .stream(scene_seed)
        .map_err(|e| scene_failed(condition, e))?;
    while let Some(t) = ahead.skip_frame() {
        let c = t.target().map_or([f64::NAN; 2], |o| {
            let (x, y) = o.bbox.center();
            [x, y]
        });
        centres.push(c);
    }
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
    let mut variants: Vec<(BallFilter, Option<usize>)> =
        BallFilter::PAPER.into_iter().map(|f| (f, None)).collect();
    for f in [BallFilter::Kf, BallFilter::Ukf] {
        if let Some(cap) = opts.budget.cap(f) {
            variants.push((f, Some(cap)));
        }
    }
    let mut lanes = Vec::new();
    for (m, mode) in FrameMode::ALL.into_iter().enumerate() {
        for (f, &(filter, budget)) in variants.iter().enumerate() {
            let seed = stream_seed(&[KEY, opts.seed, cond_index, run as u64, f as u64, m as u64]);
            let config = BallConfig {
                max_evaluations: budget,
                ..config
            };
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
                out: TrackOutcome {
                    filter,
                    budget,
                    mode,
                    frames: 0,
                    evaluations: 0,
                    score: Score::default(),
                    delayed: (mode == FrameMode::RealTime).then(Score::default),
                    self_lost: 0,
                    wall: 0.0,
                    trace: Vec::new(),
                },
            });
        }
    }
    let (lost_r, found_r) = (opts.lost_radius, opts.found_radius);
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
            if opts.timing {
                lane.out.wall += t0.elapsed().as_secs_f64();
            }
            lane.last_seen = k;
            let err = center_error(&est.bbox, &ball);
            let out = &mut lane.out;
            out.frames += 1;
            out.evaluations += est.evaluations;
            out.self_lost += usize::from(est.lost);
            if trace {
                out.trace.push((truth.time, err));
            }
            out.score.record(truth.time, err, lost_r, found_r);
            match lane.mode {
                FrameMode::Offline => lane.next = k + 1,
                FrameMode::RealTime => {
                    // Available when the computation ends: `start + cost`.
                    let done = lane.start + lane.cost;
                    if let Some(late) = out.delayed.as_mut() {
                        let [x, y] = centre_at(&centres, done);
                        let (ex, ey) = est.bbox.center();
                        let late_err = (ex - x).hypot(ey - y);
                        late.record(done, late_err, lost_r, found_r);
                    }
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
                l.out.score.finish();
                if let Some(late) = l.out.delayed.as_mut() {
                    late.finish();
                }
                l.out
            })
            .collect(),
    })
}

/// One row of `runs.csv`: one tracker in one mode of one (condition, run)
/// pair, at full precision; the `late_*` cells are empty offline.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunRow {
    /// [`Condition::name`].
    pub condition: &'static str,
    /// Run index (0-based).
    pub run: usize,
    /// [`TrackOutcome::label`] (`PF10`, `KF`, `KF@37`).
    pub alg: String,
    /// [`FrameMode::name`].
    pub mode: &'static str,
    /// Frames processed.
    pub frames: usize,
    /// Histogram evaluations over the processed frames.
    pub evaluations: usize,
    /// Mean centre error (px).
    pub mean_error_px: f64,
    /// Losses.
    pub losses: usize,
    /// Time from each re-found loss to its re-finding (s), `;`-separated.
    pub found_times_s: String,
    /// Losses not re-found before the end.
    pub unresolved: usize,
    /// As `mean_error_px`, scored where the ball is when the estimate
    /// becomes available (real time only).
    pub late_mean_error_px: Option<f64>,
    /// As `losses`, late scoring.
    pub late_losses: Option<usize>,
    /// As `found_times_s`, late scoring.
    pub late_found_times_s: Option<String>,
    /// As `unresolved`, late scoring.
    pub late_unresolved: Option<usize>,
    /// Frames in which the tracker reported itself lost.
    pub self_lost_frames: usize,
    /// Wall-clock seconds in `step` (not deterministic).
    pub wall_s: f64,
}

/// The `runs.csv` rows of one finished (condition, run) pair.
pub(super) fn run_rows(r: &RunResult) -> Vec<RunRow> {
    let times = |s: &Score| {
        let t: Vec<String> = s.found_times.iter().map(f64::to_string).collect();
        t.join(";")
    };
    let error = |s: &Score, frames: usize| s.error_sum / frames.max(1) as f64;
    r.outcomes
        .iter()
        .map(|o| RunRow {
            condition: r.condition.name(),
            run: r.run,
            alg: o.label(),
            mode: o.mode.name(),
            frames: o.frames,
            evaluations: o.evaluations,
            mean_error_px: error(&o.score, o.frames),
            losses: o.score.losses,
            found_times_s: times(&o.score),
            unresolved: o.score.unresolved,
            late_mean_error_px: o.delayed.as_ref().map(|d| error(d, o.frames)),
            late_losses: o.delayed.as_ref().map(|d| d.losses),
            late_found_times_s: o.delayed.as_ref().map(times),
            late_unresolved: o.delayed.as_ref().map(|d| d.unresolved),
            self_lost_frames: o.self_lost,
            wall_s: o.wall,
        })
        .collect()
}

/// Runs every condition's runs (and the sweep when on) in parallel; each
/// run has its own seeds, so the result does not depend on the thread
/// count. With `runs_csv`, each run's rows are appended to
/// `runs.partial.csv` as it finishes and the whole file, in order, replaces
/// `runs_csv` at the end.
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, condition and run that
/// failed; [`ExperimentError::Io`] when the CSV cannot be written;
/// [`ExperimentError::BadOption`] for options outside their domains.
pub fn run(
    opts: &BallOptions,
    runs_csv: Option<&Path>,
    progress: bool,
) -> Result<BallResult, ExperimentError> {
    let done = crate::driver::run_all::<BallExperiment>(opts, runs_csv, progress)?;
    Ok(assemble(opts, done))
}

/// What job `j` is: run `j % runs` of condition `j / runs` (conditions in
/// [`Condition::ALL`] order), then the sweep's runs, cells in order (speeds
/// outer, noises inner), `sweep_runs` each.
#[derive(Debug, Clone, Copy)]
pub(super) enum Job {
    Run(Condition, usize),
    Sweep(usize, usize, usize),
}

pub(super) fn job(opts: &BallOptions, j: usize) -> Job {
    let main = Condition::ALL.len() * opts.runs;
    if j < main {
        return Job::Run(Condition::ALL[j / opts.runs], j % opts.runs);
    }
    let k = j - main;
    let (cell, r) = (k / opts.sweep_runs, k % opts.sweep_runs);
    let noises = opts.sweep_noises.len();
    Job::Sweep(cell / noises, cell % noises, r)
}

pub(super) fn jobs(opts: &BallOptions) -> usize {
    let sweep = if opts.sweep {
        opts.sweep_speeds.len() * opts.sweep_noises.len() * opts.sweep_runs
    } else {
        0
    };
    Condition::ALL.len() * opts.runs + sweep
}

pub(super) fn run_job(opts: &BallOptions, j: usize) -> Result<RunResult, ExperimentError> {
    match job(opts, j) {
        Job::Run(c, r) => run_one(opts, c, r, r == 0),
        Job::Sweep(i, k, r) => {
            let cell_opts = BallOptions {
                speed: opts.sweep_speeds[i],
                motion_noise: opts.sweep_noises[k],
                seconds: opts.sweep_seconds,
                ..opts.clone()
            };
            let linear_noisy = Condition {
                motion: BallMotion::Linear,
                noisy: true,
            };
            run_one(&cell_opts, linear_noisy, r, false)
        }
    }
}

/// The result from every job's, in job order.
pub(super) fn assemble(opts: &BallOptions, done: Vec<RunResult>) -> BallResult {
    let mut runs = Vec::new();
    let mut sweep: Vec<SweepCell> = Vec::new();
    for (j, d) in done.into_iter().enumerate() {
        match job(opts, j) {
            Job::Run(..) => runs.push(d),
            Job::Sweep(i, k, r) => match sweep.last_mut() {
                Some(cell) if r > 0 => cell.runs.push(d),
                _ => sweep.push(SweepCell {
                    speed: opts.sweep_speeds[i],
                    noise: opts.sweep_noises[k],
                    runs: vec![d],
                }),
            },
        }
    }
    BallResult {
        options: opts.clone(),
        runs,
        sweep,
    }
}
