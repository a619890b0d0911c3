//! Tables and figures of a finished run.

use super::*;

impl CondensationResult {
    /// Summaries in [`GridKey::all`] order.
    pub fn grid_summary(&self) -> Vec<GridSummary> {
        self.grid
            .iter()
            .map(|(key, runs)| {
                let pooled = HandSummary::of(runs);
                let frames: usize = runs.iter().map(|r| r.centre.len()).sum();
                let seconds: f64 = runs.iter().map(|r| r.seconds).sum();
                GridSummary {
                    key: *key,
                    centre: pooled.centre,
                    outline: pooled.outline,
                    loss: pooled.loss,
                    // no time recorded (`timing=false`): no fps, not frames / 0
                    fps: if seconds > 0.0 {
                        frames as f64 / seconds
                    } else {
                        f64::NAN
                    },
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
                if s.fps.is_finite() {
                    format!("{:.0}", s.fps)
                } else {
                    "-".to_string()
                },
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
        let mut v = vec![
            self.grid_table(),
            self.claim_table(),
            self.hand_table(),
            self.reinit_table(),
            self.crossing_table(),
        ];
        if !self.readings.is_empty() {
            v.push(readings_table(self));
        }
        v
    }
}

/// The SVG of the particle snapshot: the frame (a PNG beside it), every
/// particle's curve (opacity by weight), the mean contour and the truth.
pub(super) fn particle_svg(s: &ParticleSnapshot, png: &str) -> String {
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
pub(super) fn write_outputs(
    result: &CondensationResult,
    dir: &Path,
) -> Result<(), ExperimentError> {
    for (name, table) in [
        ("grid.csv", result.grid_table()),
        ("claim.csv", result.claim_table()),
        ("reinit.csv", result.reinit_table()),
        ("crossing.csv", result.crossing_table()),
        ("hand.csv", result.hand_table()),
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
    if !result.readings.is_empty() {
        write_text(&dir.join("readings.csv"), &readings_table(result).to_csv())?;
    }
    let png = "particles_frame.png";
    write_png(dir.join(png), result.snapshot.image.view()).map_err(|e| failed("figure", e))?;
    write_text(
        &dir.join("particles.svg"),
        &particle_svg(&result.snapshot, png),
    )?;
    Ok(())
}
