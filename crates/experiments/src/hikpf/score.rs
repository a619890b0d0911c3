//! Per-filter summaries of the runs and the main table.

use super::*;

/// Mean, variance (divisor `R - 1`, as MATLAB's `var`) and median of the
/// per-run errors of one filter, and its degenerate steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterSummary {
    /// Which filter.
    pub kind: FilterKind,
    /// Mean per-run error.
    pub mean: f64,
    /// Variance of the per-run errors.
    pub var: f64,
    /// Median per-run error.
    pub median: f64,
    /// Steps, over all runs, whose weights were all zero.
    pub degenerate: usize,
    /// Fraction of the Metropolis-Hastings moves accepted, over all
    /// particles, steps and runs (0 for the rows without MCMC).
    pub acceptance: f64,
}

/// The per-run outcomes of every filter: `runs[r][f]` follows
/// [`FilterKind::ALL`].
#[derive(Debug, Clone, PartialEq)]
pub struct HikpfResult {
    /// The configuration that produced it.
    pub config: HikpfConfig,
    /// Outcomes per run, per filter.
    pub runs: Vec<Vec<RunOutcome>>,
}

impl HikpfResult {
    /// The summary of every filter, in row order.
    pub fn summary(&self) -> Vec<FilterSummary> {
        FilterKind::ALL
            .iter()
            .enumerate()
            .map(|(f, &kind)| {
                let mut e: Vec<f64> = self.runs.iter().map(|r| r[f].error).collect();
                let n = e.len() as f64;
                let mean = e.iter().sum::<f64>() / n;
                let var = if e.len() > 1 {
                    e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)
                } else {
                    0.0
                };
                e.sort_by(f64::total_cmp);
                let mid = e.len() / 2;
                let median = if e.len() % 2 == 1 {
                    e[mid]
                } else {
                    0.5 * (e[mid - 1] + e[mid])
                };
                FilterSummary {
                    kind,
                    mean,
                    var,
                    median,
                    degenerate: self.runs.iter().map(|r| r[f].degenerate).sum(),
                    acceptance: self.runs.iter().map(|r| r[f].accepted).sum::<usize>() as f64
                        / (self.runs.len()
                            * self.config.particles
                            * self.config.steps.saturating_sub(1)) as f64,
                }
            })
            .collect()
    }

    /// The paper-vs-ours table.
    pub fn table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "hikpf: paper 000 Table 1 and van der Merwe et al. 2000 Table 1 vs ours ({} runs)",
                self.runs.len()
            ),
            &[
                "filter",
                "paper mean",
                "paper var",
                "vdM2000 mean",
                "ours mean",
                "ours var",
                "ours median",
                "ours/paper",
                "ours/vdM",
                "all-zero steps",
                "MCMC accepted",
            ],
        );
        let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.5}"));
        for s in self.summary() {
            let paper = s.kind.paper();
            let vdm = s.kind.van_der_merwe();
            t.push(vec![
                s.kind.name().to_string(),
                fmt(paper.map(|p| p.0)),
                paper.map_or("-".into(), |p| format!("{:.3e}", p.1)),
                vdm.map_or("-".into(), |v| format!("{v:.3}")),
                format!("{:.5}", s.mean),
                format!("{:.3e}", s.var),
                format!("{:.5}", s.median),
                paper.map_or("-".into(), |p| format!("{:.2}", s.mean / p.0)),
                vdm.map_or("-".into(), |v| format!("{:.2}", s.mean / v)),
                s.degenerate.to_string(),
                if s.acceptance > 0.0 {
                    format!("{:.1}%", 100.0 * s.acceptance)
                } else {
                    "-".into()
                },
            ]);
        }
        t
    }
}
