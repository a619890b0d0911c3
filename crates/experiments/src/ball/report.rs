//! Summaries, tables, findings and figures of a finished run.

use super::*;

/// Pooled numbers of one tracker in one view over a set of runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Which tracker.
    pub filter: BallFilter,
    /// How it was run and scored.
    pub view: View,
    /// Runs pooled.
    pub runs: usize,
    /// Frames processed per second of video.
    pub frames_per_second: f64,
    /// Histogram evaluations per processed frame.
    pub evaluations: f64,
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

/// Pools the outcomes of `filter` in `view` over `runs`.
pub(super) fn summarize<'a>(
    runs: impl Iterator<Item = &'a RunResult>,
    filter: BallFilter,
    view: View,
) -> Summary {
    let (mut n, mut frames, mut evaluations, mut err, mut losses, mut unresolved, mut self_lost) =
        (0, 0, 0, 0.0, 0, 0, 0);
    let (mut seconds, mut wall) = (0.0, 0.0);
    let mut found = Vec::new();
    let budgeted = view.budgeted && !matches!(filter, BallFilter::Pf(_));
    for r in runs {
        for o in r
            .outcomes
            .iter()
            .filter(|o| o.filter == filter && o.mode == view.mode && o.budget.is_some() == budgeted)
        {
            let score = if view.delayed {
                o.delayed.as_ref().unwrap_or(&o.score)
            } else {
                &o.score
            };
            n += 1;
            frames += o.frames;
            evaluations += o.evaluations;
            err += score.error_sum;
            losses += score.losses;
            unresolved += score.unresolved;
            self_lost += o.self_lost;
            found.extend_from_slice(&score.found_times);
            seconds += r.seconds;
            wall += o.wall;
        }
    }
    let nf = frames.max(1) as f64;
    Summary {
        filter,
        view,
        runs: n,
        frames_per_second: frames as f64 / f64::max(seconds, 1e-12),
        // a filter that saw no frame has no error (not 0.0)
        evaluations: if frames == 0 {
            f64::NAN
        } else {
            evaluations as f64 / nf
        },
        error: if frames == 0 { f64::NAN } else { err / nf },
        lost_per_10min: losses as f64 * 600.0 / f64::max(seconds, 1e-12),
        losses,
        found: if found.is_empty() {
            f64::NAN
        } else {
            found.iter().sum::<f64>() / found.len() as f64
        },
        unresolved,
        self_lost: self_lost as f64 / nf,
        wall_fps: frames as f64 / f64::max(wall, 1e-12),
    }
}

/// One cell of the speed x motion-noise sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepCell {
    /// Ball speed, px/frame.
    pub speed: f64,
    /// Motion noise, px/frame per axis (linear motion, heading kicks).
    pub noise: f64,
    /// Its runs (condition `linear+noise`).
    pub runs: Vec<RunResult>,
}

/// Every run of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct BallResult {
    /// The options that produced it.
    pub options: BallOptions,
    /// Every run, conditions in [`Condition::ALL`] order.
    pub runs: Vec<RunResult>,
    /// The speed x motion-noise sweep (empty unless
    /// [`BallOptions::sweep`]), speeds outer, noises inner.
    pub sweep: Vec<SweepCell>,
}

/// The trackers of the tables in a view: the five, with the KF and UKF
/// labelled by their budget when on it.
pub(super) fn rows(opts: &BallOptions, view: View) -> Vec<(BallFilter, Option<usize>)> {
    BallFilter::PAPER
        .into_iter()
        .map(|f| {
            (
                f,
                if view.budgeted {
                    opts.budget.cap(f)
                } else {
                    None
                },
            )
        })
        .collect()
}

impl BallResult {
    /// The pooled summary of `filter` in `view` over the runs whose
    /// condition passes `keep`.
    pub fn summary(
        &self,
        filter: BallFilter,
        view: View,
        keep: impl Fn(Condition) -> bool,
    ) -> Summary {
        summarize(self.runs.iter().filter(|r| keep(r.condition)), filter, view)
    }

    /// Summary over every condition.
    pub fn overall(&self, filter: BallFilter, view: View) -> Summary {
        self.summary(filter, view, |_| true)
    }

    /// Table 1 in one mode, exhaustive or budgeted KF/UKF; in real time
    /// with both scorings.
    pub fn table1(&self, mode: FrameMode, budgeted: bool) -> Table {
        let n = self.runs.len();
        let view = View {
            mode,
            delayed: false,
            budgeted,
        };
        let mut header = vec![
            "alg",
            "paper fps",
            "ours frames/s seen",
            "ours evals/frame",
            "ours wall fps",
            "paper error",
            "ours error",
            "paper lost",
            "ours lost",
            "paper found",
            "ours found",
            "ours unresolved",
            "ours self-lost %",
        ];
        if mode == FrameMode::RealTime {
            header.extend(["ours error (late)", "ours lost (late)", "ours found (late)"]);
        }
        let mut t = Table::new(
            format!(
                "ball ({}{}): paper 001 Table 1 vs ours ({n} runs of {} s; lost per 10 min; found in s{})",
                mode.name(),
                if budgeted {
                    ", KF/UKF on the paper's evaluation budget"
                } else {
                    ""
                },
                self.options.seconds,
                if mode == FrameMode::RealTime {
                    "; late: scored where the ball is when the estimate is available"
                } else {
                    ""
                }
            ),
            &header,
        );
        for (filter, budget) in rows(&self.options, view) {
            let s = self.overall(filter, view);
            let p = paper_row(filter);
            let mut row = vec![
                label(filter, budget),
                cell(p.map(|p| p.fps), 2),
                format!("{:.2}", s.frames_per_second),
                format!("{:.0}", s.evaluations),
                format!("{:.0}", s.wall_fps),
                cell(p.map(|p| p.error), 2),
                format!("{:.2}", s.error),
                cell(p.map(|p| p.lost), 2),
                format!("{:.2}", s.lost_per_10min),
                cell(p.map(|p| p.found), 2),
                cell(Some(s.found), 2),
                s.unresolved.to_string(),
                format!("{:.1}", 100.0 * s.self_lost),
            ];
            if mode == FrameMode::RealTime {
                let late = self.overall(filter, view.scored_late());
                row.extend([
                    format!("{:.2}", late.error),
                    format!("{:.2}", late.lost_per_10min),
                    cell(Some(late.found), 2),
                ]);
            }
            t.push(row);
        }
        t
    }

    /// Table 2 (noise) or Table 3 (motion), both modes, exhaustive and
    /// (when on) budgeted KF/UKF.
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
        let mut all = rows(&self.options, View::OFFLINE);
        all.extend(
            rows(&self.options, View::OFFLINE.on_budget())
                .into_iter()
                .filter(|(_, b)| b.is_some()),
        );
        for (filter, budget) in all {
            let p = paper_row(filter)
                .filter(|_| budget.is_none())
                .map(|p| if noise { p.noise } else { p.motion });
            let mut row = vec![
                label(filter, budget),
                cell(p.map(|p| p[0]), 1),
                cell(p.map(|p| p[1]), 1),
            ];
            for mode in FrameMode::ALL {
                let view = View {
                    mode,
                    delayed: false,
                    budgeted: budget.is_some(),
                };
                for second in [false, true] {
                    let s = self.summary(filter, view, |c| {
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

    /// The speed x motion-noise sweep: lost per 10 min (or, with `error`,
    /// the mean centre error in px) of every tracker in real time, scored on
    /// the processed frame; `None` without a sweep.
    pub fn sweep_table(&self, error: bool) -> Option<Table> {
        if self.sweep.is_empty() {
            return None;
        }
        let o = &self.options;
        let mut variants = rows(o, View::REALTIME);
        variants.extend(
            rows(o, View::REALTIME.on_budget())
                .into_iter()
                .filter(|(_, b)| b.is_some()),
        );
        let labels: Vec<String> = variants.iter().map(|&(f, b)| label(f, b)).collect();
        let mut header = vec!["speed px/frame", "noise px/frame"];
        header.extend(labels.iter().map(String::as_str));
        let mut t = Table::new(
            format!(
                "ball sweep (real time, linear motion + heading noise, {} runs of {} s per cell): {}",
                o.sweep_runs,
                o.sweep_seconds,
                if error {
                    "mean centre error (px)"
                } else {
                    "lost per 10 min"
                }
            ),
            &header,
        );
        for c in &self.sweep {
            let mut row = vec![format!("{}", c.speed), format!("{}", c.noise)];
            for &(filter, budget) in &variants {
                let view = View {
                    budgeted: budget.is_some(),
                    ..View::REALTIME
                };
                let s = summarize(c.runs.iter(), filter, view);
                row.push(if error {
                    format!("{:.2}", s.error)
                } else {
                    format!("{:.1}", s.lost_per_10min)
                });
            }
            t.push(row);
        }
        Some(t)
    }

    /// The paper's findings and whether each view reproduces them.
    pub fn findings(&self) -> Vec<Finding> {
        FINDINGS
            .iter()
            .map(|&(id, text, check)| Finding {
                id,
                text,
                verdicts: View::ALL.map(|v| {
                    let budget_runs = !v.budgeted || self.options.budget != Budget::Off;
                    budget_runs.then(|| check(self, v))
                }),
            })
            .collect()
    }

    /// The findings as a table (one column per [`View::ALL`]).
    pub fn findings_table(&self) -> Table {
        let names: Vec<String> = View::ALL.iter().map(|v| v.name()).collect();
        let mut header = vec!["id", "finding"];
        header.extend(names.iter().map(String::as_str));
        let mut t = Table::new(
            "ball: paper 001 findings, reproduced? (offline / real time / real time scored late; \
             then with the KF/UKF on the paper's evaluation budget)",
            &header,
        );
        for f in self.findings() {
            let mut row = vec![f.id.to_string(), f.text.to_string()];
            row.extend(f.verdicts.iter().map(|v| match v {
                Some(true) => "yes".to_string(),
                Some(false) => "no".to_string(),
                None => "-".to_string(),
            }));
            t.push(row);
        }
        t
    }
}

/// A finding of paper 001 and whether each view reproduces it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Finding {
    /// Short id.
    pub id: &'static str,
    /// What the paper says.
    pub text: &'static str,
    /// Reproduced in each of [`View::ALL`] (`None`: the budget is off).
    pub verdicts: [Option<bool>; 6],
}

impl Finding {
    /// The verdict in `view` (`None`: not run).
    pub fn in_view(&self, view: View) -> Option<bool> {
        View::ALL
            .iter()
            .position(|v| *v == view)
            .and_then(|i| self.verdicts[i])
    }
}

pub(super) type Check = fn(&BallResult, View) -> bool;

pub(super) fn lost(r: &BallResult, f: BallFilter, v: View) -> f64 {
    r.overall(f, v).lost_per_10min
}

pub(super) fn lost_where(
    r: &BallResult,
    f: BallFilter,
    v: View,
    keep: impl Fn(Condition) -> bool,
) -> f64 {
    r.summary(f, v, keep).lost_per_10min
}

pub(super) const PF10: BallFilter = BallFilter::Pf(10);
pub(super) const PF30: BallFilter = BallFilter::Pf(30);
pub(super) const PF70: BallFilter = BallFilter::Pf(70);
pub(super) const KF: BallFilter = BallFilter::Kf;
pub(super) const UKF: BallFilter = BallFilter::Ukf;

/// The findings of paper 001 sec. 3 that the tables support.
pub(super) const FINDINGS: [(&str, &str, Check); 9] = [
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

pub(super) fn cell(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "-".to_string(),
    }
}

/// `error,losses,found times,unresolved` of a score for the golden file,
/// numbers as `{:.17e}` (`,,,` when absent).
pub(super) fn score_cells(score: Option<&Score>, frames: usize) -> String {
    let Some(s) = score else {
        return ",,,".to_string();
    };
    let times: Vec<String> = s.found_times.iter().map(|t| format!("{t:.17e}")).collect();
    let error = s.error_sum / frames.max(1) as f64;
    format!(
        "{error:.17e},{},{},{}",
        s.losses,
        times.join(";"),
        s.unresolved
    )
}

/// The named tables of a result, in print order.
pub(super) fn named_tables(result: &BallResult) -> Vec<(&'static str, Table)> {
    let mut named = vec![
        ("table1_offline", result.table1(FrameMode::Offline, false)),
        ("table1_realtime", result.table1(FrameMode::RealTime, false)),
    ];
    if result.options.budget != Budget::Off {
        named.push((
            "table1_offline_budget",
            result.table1(FrameMode::Offline, true),
        ));
        named.push((
            "table1_realtime_budget",
            result.table1(FrameMode::RealTime, true),
        ));
    }
    named.extend([
        ("table2", result.table_split(true)),
        ("table3", result.table_split(false)),
        ("findings", result.findings_table()),
    ]);
    named.extend(result.sweep_table(false).map(|t| ("sweep_lost", t)));
    named.extend(result.sweep_table(true).map(|t| ("sweep_error", t)));
    named
}

/// Writes the table CSVs and the error-over-time figures.
pub(super) fn write_outputs(
    result: &BallResult,
    dir: &Path,
    tables: &[(&str, Table)],
) -> Result<(), ExperimentError> {
    for (name, t) in tables {
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
                    name: o.label(),
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
