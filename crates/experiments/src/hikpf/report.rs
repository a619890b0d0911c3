//! The sweep of paper 000's unstated parameters, the per-run log, the run and its files.

use super::*;

/// The IEKF iteration counts `c` of the sweep.
pub const SWEEP_ITERATIONS: [usize; 5] = [1, 2, 3, 5, 10];

/// The filters of paper 000's Table 1, in its row order (the sweep's
/// columns).
pub const PAPER_ROWS: [FilterKind; 5] = [
    FilterKind::Pf,
    FilterKind::PfEkf,
    FilterKind::PfUkf,
    FilterKind::PfIekf,
    FilterKind::Hikpf,
];

/// One cell of the sweep: a reading of paper 000's experiment and the
/// summaries it gives.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepCell {
    /// Error formula of the cell.
    pub error: ErrorMetric,
    /// Whether the demo's `1e-99` likelihood floor is on.
    pub likelihood_floor: bool,
    /// IEKF iterations `c` of PF-IEKF and HIKPF.
    pub iekf_iterations: usize,
    /// Every filter's summary, in [`FilterKind::ALL`] order.
    pub summary: Vec<FilterSummary>,
}

impl SweepCell {
    /// The summary of filter `kind`.
    pub fn filter(&self, kind: FilterKind) -> &FilterSummary {
        let i = FilterKind::ALL.iter().position(|&k| k == kind).unwrap_or(0);
        &self.summary[i]
    }
}

/// The configuration of sweep cell `i` (`0..SWEEP_CELLS`): likelihood
/// floor {off, on} x IEKF iterations [`SWEEP_ITERATIONS`], RMSE, every
/// other option as in `base`.
pub(super) fn sweep_config(base: &HikpfConfig, i: usize) -> HikpfConfig {
    HikpfConfig {
        error: ErrorMetric::Rmse,
        likelihood_floor: i >= SWEEP_ITERATIONS.len(),
        iekf_iterations: SWEEP_ITERATIONS[i % SWEEP_ITERATIONS.len()],
        sweep: false,
        ..*base
    }
}

/// Runs of the table in the sweep: floor {off, on} x [`SWEEP_ITERATIONS`].
pub(super) const SWEEP_CELLS: usize = 2 * SWEEP_ITERATIONS.len();

/// The sweep's cells from each (floor, iterations) run of the table, in
/// [`sweep_config`] order, each scored by both error formulas.
pub(super) fn sweep_cells(base: &HikpfConfig, mut runs: Vec<Vec<RunOutcome>>) -> Vec<SweepCell> {
    let per_cell = base.runs;
    let mut cells = vec![];
    for i in 0..SWEEP_CELLS {
        let config = sweep_config(base, i);
        let rest = runs.split_off(per_cell.min(runs.len()));
        let rmse = HikpfResult { config, runs };
        runs = rest;
        // the same runs scored by eq. 11
        let eq11 = HikpfResult {
            config: HikpfConfig {
                error: ErrorMetric::Eq11Literal,
                ..config
            },
            runs: rmse
                .runs
                .iter()
                .map(|r| {
                    r.iter()
                        .map(|o| RunOutcome {
                            error: o.other_error,
                            other_error: o.error,
                            ..*o
                        })
                        .collect()
                })
                .collect(),
        };
        for result in [rmse, eq11] {
            cells.push(SweepCell {
                error: result.config.error,
                likelihood_floor: config.likelihood_floor,
                iekf_iterations: config.iekf_iterations,
                summary: result.summary(),
            });
        }
    }
    // the table's order: error formula, then floor, then iterations
    cells.sort_by_key(|c| {
        (
            c.error == ErrorMetric::Eq11Literal,
            c.likelihood_floor,
            c.iekf_iterations,
        )
    });
    cells
}

/// Paper 000's unstated parameters swept: error formula {RMSE, eq. 11} x
/// likelihood floor {off, on} x IEKF iterations [`SWEEP_ITERATIONS`], every
/// other option as in `base`. Each (floor, iterations) pair is one run of
/// the table, scored by both error formulas; every cell uses the same
/// random streams, so cells differ only by the reading.
///
/// # Errors
/// As [`run`].
pub fn sweep(base: &HikpfConfig, progress: bool) -> Result<Vec<SweepCell>, ExperimentError> {
    let base = HikpfConfig {
        sweep: true,
        ..*base
    };
    let jobs: Vec<usize> = (base.runs..HikpfExperiment::jobs(&base)).collect();
    let runs = crate::driver::run_jobs::<HikpfExperiment>(&base, &jobs, None, progress)?;
    Ok(sweep_cells(&base, runs))
}

/// The sweep as a table: per cell, mean and variance of paper 000's five
/// filters, each mean's ratio to the paper's, and PF-IEKF / HIKPF (the
/// paper: 3.16); the paper's row first.
pub fn sweep_table(cells: &[SweepCell], runs: usize) -> Table {
    let mut header = vec!["error", "floor", "c"];
    let names: Vec<String> = PAPER_ROWS
        .iter()
        .flat_map(|k| {
            [
                format!("{} mean (x paper)", k.name()),
                format!("{} var", k.name()),
            ]
        })
        .collect();
    header.extend(names.iter().map(String::as_str));
    header.push("PF-IEKF/HIKPF");
    let mut t = Table::new(
        format!(
            "hikpf: sweep of paper 000's unstated parameters ({runs} runs each): \
             mean (ours/paper) and variance of the per-run error"
        ),
        &header,
    );
    let mut paper = vec!["paper 000".to_string(), "-".into(), "-".into()];
    for k in PAPER_ROWS {
        let (m, v) = k.paper().unwrap_or((f64::NAN, f64::NAN));
        paper.push(format!("{m:.5}"));
        paper.push(format!("{v:.2e}"));
    }
    let (pi, ph) = (
        FilterKind::PfIekf.paper().map_or(f64::NAN, |p| p.0),
        FilterKind::Hikpf.paper().map_or(f64::NAN, |p| p.0),
    );
    paper.push(format!("{:.2}", pi / ph));
    t.push(paper);
    for c in cells {
        let mut row = vec![
            match c.error {
                ErrorMetric::Rmse => "rmse".to_string(),
                ErrorMetric::Eq11Literal => "eq11".to_string(),
            },
            if c.likelihood_floor { "on" } else { "off" }.to_string(),
            c.iekf_iterations.to_string(),
        ];
        for k in PAPER_ROWS {
            let s = c.filter(k);
            let p = k.paper().map_or(f64::NAN, |p| p.0);
            row.push(format!("{:.5} ({:.2})", s.mean, s.mean / p));
            row.push(format!("{:.2e}", s.var));
        }
        row.push(format!(
            "{:.2}",
            c.filter(FilterKind::PfIekf).mean / c.filter(FilterKind::Hikpf).mean
        ));
        t.push(row);
    }
    t
}

/// One row of `runs.csv`: one filter's error in one run (full precision).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunRow {
    /// Run index (0-based).
    pub run: usize,
    /// [`FilterKind::name`].
    pub filter: &'static str,
    /// The run's error (the configured formula).
    pub error: f64,
}

/// The `runs.csv` rows of run `r`, one per filter.
pub(super) fn run_rows(r: usize, outcomes: &[RunOutcome]) -> Vec<RunRow> {
    FilterKind::ALL
        .iter()
        .zip(outcomes)
        .map(|(k, x)| RunRow {
            run: r,
            filter: k.name(),
            error: x.error,
        })
        .collect()
}

/// Runs the experiment: runs in parallel (each run has its own random
/// streams, so the result does not depend on the thread count). With
/// `runs_csv`, each run's row is appended to `runs.partial.csv` beside it
/// the moment the run finishes, and the complete file, in run order,
/// replaces `runs_csv` at the end (see [`bayestrack_otb::write::PartialCsv`]): an interrupted run
/// keeps every finished run and the previous `runs.csv`. The sweep is not
/// run (see [`sweep`]).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the filter, run and step that failed;
/// [`ExperimentError::Io`] when the CSV cannot be written.
pub fn run(
    config: &HikpfConfig,
    runs_csv: Option<&Path>,
    progress: bool,
) -> Result<HikpfResult, ExperimentError> {
    let jobs: Vec<usize> = (0..config.runs).collect();
    let runs = crate::driver::run_jobs::<HikpfExperiment>(config, &jobs, runs_csv, progress)?;
    Ok(HikpfResult {
        config: *config,
        runs,
    })
}

/// Writes the summary CSV and the per-run error figure (paper 000 Fig. 3).
pub(super) fn write_outputs(result: &HikpfResult, dir: &Path) -> Result<(), ExperimentError> {
    let csv = dir.join("table.csv");
    write_text(&csv, &result.table().to_csv())?;
    let series: Vec<Series> = FilterKind::ALL
        .iter()
        .enumerate()
        .filter(|(_, k)| {
            !matches!(
                k,
                FilterKind::PfMcmc | FilterKind::PfEkfMcmc | FilterKind::PfUkfMcmc
            )
        })
        .map(|(f, k)| Series {
            name: k.name().to_string(),
            points: result
                .runs
                .iter()
                .enumerate()
                .map(|(r, o)| ((r + 1) as f64, o[f].error))
                .collect(),
        })
        .collect();
    line_chart(
        &dir.join("errors.svg"),
        "hikpf: error of each filter per run (cf. paper 000 Fig. 3)",
        "run",
        "RMSE",
        &series,
    )?;
    Ok(())
}

/// The quick configurations that CI pins: the defaults, and the demo's
/// linear-domain likelihood floor.
pub fn golden_configs() -> [(&'static str, HikpfConfig); 2] {
    let floor = HikpfConfig {
        likelihood_floor: true,
        ..HikpfConfig::quick()
    };
    [
        ("default", HikpfConfig::quick()),
        ("likelihood_floor", floor),
    ]
}
