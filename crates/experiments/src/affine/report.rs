//! Tables and figures of a finished run.

use super::*;

impl AffineResult {
    /// One summary per setting x filter, settings then filters in order.
    pub fn summaries(&self) -> Vec<Summary> {
        let mut out = Vec::new();
        for (s, setting) in Setting::ALL.iter().enumerate() {
            for filter in Filter::ALL {
                let tr: Vec<&TrackRun> = self.runs[s].iter().map(|r| &r[filter.index()]).collect();
                let rms: Vec<f64> = tr.iter().flat_map(|t| t.rms.iter().copied()).collect();
                let cat = |f: fn(&TrackRun) -> &Vec<usize>| -> Vec<usize> {
                    tr.iter().flat_map(|t| f(t).iter().copied()).collect()
                };
                let frames: usize = tr.iter().map(|t| t.rms.len()).sum();
                let seconds: f64 = tr.iter().map(|t| t.seconds).sum();
                out.push(Summary {
                    setting: *setting,
                    filter,
                    rms: quantiles(&rms),
                    lost_frames: tr
                        .iter()
                        .map(|t| t.lost.iter().filter(|&&l| l).count())
                        .sum::<usize>() as f64
                        / tr.len() as f64,
                    first_lost: tr
                        .iter()
                        .map(|t| t.lost.iter().position(|&l| l).map(|k| k + 2))
                        .collect(),
                    particles: mean_usize(&cat(|t| &t.particles)),
                    evaluations: mean_usize(&cat(|t| &t.evaluations)),
                    pose_estimator_calls: mean_usize(&cat(|t| &t.pose_estimator_calls)),
                    // no time recorded (`timing=false`): no fps, not frames / 0
                    fps: if seconds > 0.0 {
                        frames as f64 / seconds
                    } else {
                        f64::NAN
                    },
                });
            }
        }
        out
    }

    /// The summary of `setting` x `filter`.
    pub fn summary(&self, setting: Setting, filter: Filter) -> Summary {
        self.summaries()
            .into_iter()
            .find(|s| s.setting == setting && s.filter == filter)
            .expect("every setting x filter is summarised")
    }

    /// The paper's particles per frame beside ours, and our accuracy.
    pub fn table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "affine (paper 002 Fig. 7-8): {} frames x {} run(s) per setting; RMS of eq. 6 in px; \
                 lost = RMS > {} x target side",
                self.config.frames(),
                self.config.runs,
                self.config.lost_fraction
            ),
            &[
                "setting",
                "filter",
                "paper particles/frame",
                "ours particles/frame",
                "RMS mean",
                "RMS median",
                "RMS p90",
                "lost frames",
                "evaluations/frame",
                "PE calls/frame",
                "fps",
            ],
        );
        for s in self.summaries() {
            let paper = s.setting.paper_particles()[s.filter.index()]
                .map_or("-".to_string(), |v| format!("{v}"));
            t.push(vec![
                s.setting.name().to_string(),
                s.filter.name().to_string(),
                paper,
                format!("{:.1}", s.particles),
                format!("{:.2}", s.rms[0]),
                format!("{:.2}", s.rms[1]),
                format!("{:.2}", s.rms[2]),
                format!("{:.1}", s.lost_frames),
                format!("{:.1}", s.evaluations),
                format!("{:.1}", s.pose_estimator_calls),
                if s.fps.is_finite() {
                    format!("{:.0}", s.fps)
                } else {
                    "-".to_string()
                },
            ]);
        }
        t
    }

    /// The paper's qualitative claims beside what we measured.
    pub fn claims_table(&self) -> Table {
        let mut t = Table::new("affine: the paper's claims", &["claim (paper 002)", "ours"]);
        let first_lost = |s: &Summary| {
            let v: Vec<String> = s
                .first_lost
                .iter()
                .map(|f| f.map_or("never".to_string(), |k| k.to_string()))
                .collect();
            v.join(" ")
        };
        let cock_ispf = self.summary(Setting::Cock, Filter::Ispf);
        let cock_stpf = self.summary(Setting::Cock, Filter::Stpf);
        t.push(vec![
            "ISPF fails under abrupt motion and blur (Cock, near frame 148); the self-tuning filter does not".into(),
            format!(
                "first lost frame per run: ISPF {}, self-tuning {}; lost frames ISPF {:.1}, self-tuning {:.1}",
                first_lost(&cock_ispf),
                first_lost(&cock_stpf),
                cock_ispf.lost_frames,
                cock_stpf.lost_frames
            ),
        ]);
        for setting in [Setting::Sylvester, Setting::Dudek] {
            let h = self.summary(setting, Filter::Hkpf);
            let s = self.summary(setting, Filter::Stpf);
            t.push(vec![
                format!(
                    "HKPF drifts in orientation and scale under pose change ({})",
                    setting.name()
                ),
                format!(
                    "RMS mean HKPF {:.2} vs self-tuning {:.2} ({:.2}x)",
                    h.rms[0],
                    s.rms[0],
                    h.rms[0] / s.rms[0]
                ),
            ]);
        }
        for setting in Setting::ALL {
            let i = self.summary(setting, Filter::Ispf);
            let s = self.summary(setting, Filter::Stpf);
            t.push(vec![
                format!(
                    "the self-tuning filter needs fewer particles than ISPF ({})",
                    setting.name()
                ),
                format!(
                    "{:.1} vs {:.1} particles/frame at RMS {:.2} vs {:.2}",
                    s.particles, i.particles, s.rms[0], i.rms[0]
                ),
            ]);
        }
        t
    }
}

/// Writes the summary CSV files and the figures under `dir` (`frames.csv`
/// is written by [`AffineExperiment`] as the runs finish).
pub(super) fn write_outputs(result: &AffineResult, dir: &Path) -> Result<(), ExperimentError> {
    write_text(&dir.join("summary.csv"), &result.table().to_csv())?;
    write_text(&dir.join("claims.csv"), &result.claims_table().to_csv())?;
    if !result.readings.is_empty() {
        write_text(&dir.join("readings.csv"), &readings_table(result).to_csv())?;
    }
    for (s, setting) in Setting::ALL.iter().enumerate() {
        let run0 = &result.runs[s][0];
        let series = |f: &dyn Fn(&TrackRun, usize) -> f64| -> Vec<Series> {
            Filter::ALL
                .iter()
                .zip(run0)
                .map(|(filter, tr)| Series {
                    name: filter.name().to_string(),
                    points: (0..tr.rms.len())
                        .map(|k| ((k + 2) as f64, f(tr, k)))
                        .collect(),
                })
                .collect()
        };
        let name = setting.name().to_lowercase();
        line_chart(
            &dir.join(format!("rms_{name}.svg")),
            &format!(
                "affine, {}: RMS error of eq. 6 per frame, run 0 (cf. Fig. 7)",
                setting.name()
            ),
            "frame",
            "RMS (px)",
            &series(&|tr, k| tr.rms[k]),
        )?;
        line_chart(
            &dir.join(format!("particles_{name}.svg")),
            &format!(
                "affine, {}: particles per frame, run 0 (cf. Fig. 8)",
                setting.name()
            ),
            "frame",
            "particles",
            &series(&|tr, k| tr.particles[k] as f64),
        )?;
    }
    Ok(())
}
