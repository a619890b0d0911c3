//! Tables and figures of a finished run.

use super::*;

impl CorrelationResult {
    /// Per-variant summaries in [`Variant::ALL`] order.
    pub fn summary(&self) -> Vec<VariantSummary> {
        let n = self.runs.len() as f64;
        Variant::ALL
            .iter()
            .map(|&v| {
                let ph: Vec<PhaseErrors> = self.runs.iter().map(|r| r.phases(v)).collect();
                let avg = |f: fn(&PhaseErrors) -> f64| ph.iter().map(f).sum::<f64>() / n;
                VariantSummary {
                    variant: v,
                    phases: PhaseErrors {
                        before: avg(|p| p.before),
                        during: avg(|p| p.during),
                        after: avg(|p| p.after),
                    },
                    recovered: ph.iter().filter(|p| p.after < 5.0).count() as f64 / n,
                }
            })
            .collect()
    }

    pub(super) fn per_frame_table(
        &self,
        title: &str,
        paper: &[(usize, f64, f64)],
        cols: &[Variant],
    ) -> Table {
        let mut header = vec!["frame", "truth", "visible", "paper"];
        header.extend(cols.iter().map(|v| v.name()));
        let mut t = Table::new(title, &header);
        let r0 = &self.runs[0];
        for &(frame, px, py) in paper {
            let k = frame - 1;
            if k >= r0.truth.len() {
                continue;
            }
            let mut row = vec![
                frame.to_string(),
                xy(r0.truth[k]),
                format!("{:.2}", r0.visible[k]),
                xy([px, py]),
            ];
            for v in cols {
                let i = Variant::ALL.iter().position(|x| x == v).unwrap_or(0);
                let lost = if r0.tracks[i].lost[k] { " lost" } else { "" };
                row.push(format!("{}{lost}", xy(r0.tracks[i].centres[k])));
            }
            t.push(row);
        }
        t
    }

    /// Table 1: the MAD tracker, every third frame (run 0).
    pub fn table1(&self) -> Table {
        self.per_frame_table(
            "correlation: paper 004 Table 1, MAD tracker centre (0-based px), run 0",
            &PAPER_TABLE1,
            &[Variant::MadWindow, Variant::MadFrame],
        )
    }

    /// Table 2: the PF tracker, every third frame (run 0).
    pub fn table2(&self) -> Table {
        self.per_frame_table(
            "correlation: paper 004 Table 2, PF tracker (Ns = 15) centre (0-based px), run 0",
            &PAPER_TABLE2,
            &[
                Variant::PfPrinted,
                Variant::PfDrift,
                Variant::PfDriftCap,
                Variant::PfConstDrift,
            ],
        )
    }

    /// Mean errors before, during and after the occlusion, over runs.
    pub fn summary_table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "correlation: mean centre error (px) by phase over {} runs; recovered = after < 5 px",
                self.runs.len()
            ),
            &["tracker", "before", "during", "after", "recovered"],
        );
        for s in self.summary() {
            t.push(vec![
                s.variant.name().to_string(),
                format!("{:.2}", s.phases.before),
                format!("{:.2}", s.phases.during),
                format!("{:.2}", s.phases.after),
                format!("{:.0}%", 100.0 * s.recovered),
            ]);
        }
        t
    }

    /// Table 3: the multi-target tracker (our frame 0 = paper frame 42).
    pub fn table3(&self) -> Table {
        let mut t = Table::new(
            "correlation: paper 004 Table 3, Kalman multi-target tracker, centroid x, y and window Lx x Ly",
            &[
                "frame", "paper 1", "ours 1", "truth 1", "paper 2", "ours 2", "truth 2", "tracks",
            ],
        );
        let fmt = |v: [f64; 4]| format!("{:.1} {:.1} {:.1}x{:.1}", v[0], v[1], v[2], v[3]);
        let paper = |v: [f64; 4]| format!("{:.0} {:.0} {:.0}x{:.0}", v[0], v[1], v[2], v[3]);
        for &(frame, p1, p2) in &PAPER_TABLE3 {
            let k = frame - 42;
            if k >= self.multi.tracks.len() {
                continue;
            }
            let ours = |i: usize| self.multi.tracks[k][i].map_or("-".to_string(), fmt);
            let ids: Vec<String> = self.multi.ids[k].iter().map(|i| i.to_string()).collect();
            t.push(vec![
                frame.to_string(),
                paper(p1),
                ours(0),
                fmt(self.multi.truth[k][0]),
                paper(p2),
                ours(1),
                fmt(self.multi.truth[k][1]),
                ids.join(" "),
            ]);
        }
        t
    }

    /// Every table, in print order.
    pub fn tables(&self) -> Vec<Table> {
        vec![
            self.table1(),
            self.table2(),
            self.summary_table(),
            self.table3(),
        ]
    }
}

/// Writes the CSV files (all but `frames.csv`, which the run writes as it
/// goes) and the figures under `dir`.
pub(super) fn write_outputs(result: &CorrelationResult, dir: &Path) -> Result<(), ExperimentError> {
    for (name, table) in [
        ("table1_mad.csv", result.table1()),
        ("table2_pf.csv", result.table2()),
        ("summary.csv", result.summary_table()),
        ("table3_multi.csv", result.table3()),
    ] {
        let path = dir.join(name);
        write_text(&path, &table.to_csv())?;
    }
    // Trajectories (run 0) with the paper's, and error over time.
    let r0 = &result.runs[0];
    let mut traj = vec![
        Series {
            name: "truth".into(),
            points: r0.truth.iter().map(|c| (c[0], c[1])).collect(),
        },
        Series {
            name: "paper MAD (Table 1)".into(),
            points: PAPER_TABLE1.iter().map(|&(_, x, y)| (x, y)).collect(),
        },
        Series {
            name: "paper PF (Table 2)".into(),
            points: PAPER_TABLE2.iter().map(|&(_, x, y)| (x, y)).collect(),
        },
    ];
    for (v, tr) in Variant::ALL.iter().zip(&r0.tracks) {
        traj.push(Series {
            name: format!("ours {}", v.name()),
            points: tr.centres.iter().map(|c| (c[0], c[1])).collect(),
        });
    }
    line_chart(
        &dir.join("trajectories.svg"),
        "correlation: window centre, run 0 (x right, y down the image)",
        "x (px)",
        "y (px)",
        &traj,
    )?;
    let err: Vec<Series> = Variant::ALL
        .iter()
        .map(|&v| Series {
            name: v.name().to_string(),
            points: r0
                .errors(v)
                .iter()
                .enumerate()
                .map(|(k, &e)| ((k + 1) as f64, e))
                .collect(),
        })
        .collect();
    line_chart(
        &dir.join("errors.svg"),
        "correlation: centre error per frame, run 0 (billboard: frames 5-21)",
        "frame",
        "error (px)",
        &err,
    )?;
    Ok(())
}
