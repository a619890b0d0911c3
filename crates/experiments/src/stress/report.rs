//! The stress set's tables: success rate at IoU 0.5 per stress (colour /
//! gray) and the means, and a sweep's one row per value.

use bayestrack_otb::Table;
use bayestrack_otb::suite::{MeanScore, SuiteReport};

use super::Stress;

/// One row per tracker: its success rate at IoU 0.5 on each stress
/// (`colour / gray`, `-` where the suite did not run that sequence, `n/a`
/// where the tracker cannot run on it), then its means over every sequence
/// it finished (`SR@0.5`, `AUC`, `P@20`, `fps`), the suite's
/// [`SuiteReport::mean`].
pub fn stress_table(report: &SuiteReport) -> Table {
    let mut header = vec!["tracker"];
    header.extend(Stress::ALL.iter().map(|s| s.name()));
    header.extend(["mean SR@0.5", "mean AUC", "mean P@20", "fps"]);
    let mut t = Table::new(
        "Stress set: success rate at IoU 0.5 per stress (colour / gray), means over every sequence",
        &header,
    );
    for &tracker in &report.trackers {
        let mut row = vec![tracker.to_string()];
        for s in Stress::ALL {
            let cell = |colour| match report.cell(s.sequence_name(colour), tracker) {
                None => "-".to_string(),
                Some(c) => match &c.outcome {
                    Ok(c) => format!("{:.2}", c.score.success_rate_50),
                    Err(e) if e.is_failure() => "failed".into(),
                    Err(_) => "n/a".into(),
                },
            };
            row.push(format!("{} / {}", cell(true), cell(false)));
        }
        match report.mean(tracker) {
            Some(m) => {
                let partial = if m.sequences == report.sequences.len() {
                    String::new()
                } else {
                    format!(" ({} seq.)", m.sequences)
                };
                row.extend([
                    format!("{:.3}{partial}", m.success_rate_50),
                    format!("{:.3}", m.auc),
                    format!("{:.3}", m.precision_20),
                    format!("{:.0}", m.fps),
                ]);
            }
            None => row.extend(std::iter::repeat_n("-".to_string(), 4)),
        }
        t.push(row);
    }
    t
}

/// One value of a sweep and the tracker's means over the set with it.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The option's value.
    pub value: String,
    /// The means over the sequences finished (`None`: none finished).
    pub mean: Option<MeanScore>,
    /// Sequences of the set.
    pub sequences: usize,
}

/// The sweep of option `key` of `tracker`: one row per value (mean SR@0.5,
/// AUC, P@20, fps over the set), the best mean SR@0.5 (ties: AUC, then
/// the first value) marked `<- best`. A value with which some sequence
/// did not finish is never the best.
pub fn sweep_table(tracker: &str, key: &str, rows: &[SweepRow]) -> Table {
    let complete = |r: &SweepRow| r.mean.filter(|m| m.sequences == r.sequences);
    let best = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| complete(r).map(|m| (i, m)))
        .fold(None::<(usize, MeanScore)>, |acc, (i, m)| match acc {
            Some((_, b)) if (m.success_rate_50, m.auc) <= (b.success_rate_50, b.auc) => acc,
            _ => Some((i, m)),
        })
        .map(|(i, _)| i);
    let mut t = Table::new(
        format!("Sweep of {tracker} over the stress set: {key}"),
        &[key, "mean SR@0.5", "mean AUC", "mean P@20", "fps", ""],
    );
    for (i, r) in rows.iter().enumerate() {
        let mark = if best == Some(i) { "<- best" } else { "" };
        match r.mean {
            Some(m) => {
                let partial = if m.sequences == r.sequences {
                    String::new()
                } else {
                    format!(" ({} of {} seq.)", m.sequences, r.sequences)
                };
                t.push(vec![
                    r.value.clone(),
                    format!("{:.3}{partial}", m.success_rate_50),
                    format!("{:.3}", m.auc),
                    format!("{:.3}", m.precision_20),
                    format!("{:.0}", m.fps),
                    mark.into(),
                ]);
            }
            None => t.push(vec![
                r.value.clone(),
                "failed".into(),
                "-".into(),
                "-".into(),
                "-".into(),
                mark.into(),
            ]),
        }
    }
    t
}
