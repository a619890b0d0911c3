//! The `correlation` experiment: paper 004 Tables 1-3 on the synthetic road
//! of [`RoadScene`].
//!
//! - Table 1: the MAD correlation tracker (sec. 2), window centre every
//!   third frame; the paper's stalls at (76, 113) from frame 13, behind the
//!   billboard.
//! - Table 2: the PF correlation tracker (sec. 3, `Ns = 15`); the paper's
//!   keeps moving about (2.6, 5) px a frame from (57, 85) to (126, 220).
//! - Table 3: the Kalman multi-target tracker (sec. 4) on two cars,
//!   centroid and window size per frame (the paper's frames 42-53).
//!
//! Paper frame `n` (1-based) is our frame index `n - 1` for Tables 1-2, and
//! index `n - 42` of [`RoadScene::two_cars`] for Table 3. Positions are
//! 0-based pixel centres (the scene's convention). Run `r` renders the scene
//! with seed `scene_seed + r` and seeds the particle filters with `r`; the
//! per-frame tables show run 0, the summary averages over runs. Every choice
//! is a named option ([`CorrelationConfig::apply`]); the reasons are in
//! docs/reproduction.md.

use std::fmt::Write as _;
use std::path::Path;

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    ArpMotion, MadTracker, MadTrackerConfig, MultiTargetConfig, MultiTargetTracker,
    PfCorrelationConfig, PfCorrelationTracker, SearchArea, Tracker,
};

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_PARTICLES, MAX_RUNS, write_text};
use crate::scenes::{FrameTruth, RoadScene};
use bayestrack_options::{Options, options};
use bayestrack_otb::Table;
use bayestrack_otb::plot::{Series, line_chart};

/// The experiment's id.
const ID: &str = "correlation";

mod options;
mod paper;
mod report;
mod score;
mod simulate;
pub use options::*;
pub use paper::*;
use report::*;
pub use score::*;
pub use simulate::*;

/// The registry entry: job `r < runs` is run `r` of the single-car scene,
/// job `runs` the two-car run.
pub struct CorrelationExperiment;

impl Paper for CorrelationExperiment {
    type Config = CorrelationConfig;
    type Done = Done;
    type Row = FrameRow;
    type Shared = ();
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 004 Tables 1-3";
    const SUMMARY: &'static str =
        "MAD vs PF correlation tracker through an occlusion; Kalman multi-target";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "correlation runs";

    fn quick() -> CorrelationConfig {
        CorrelationConfig::quick()
    }
    fn full() -> CorrelationConfig {
        CorrelationConfig::paper()
    }
    fn jobs(c: &CorrelationConfig) -> usize {
        c.runs + 1
    }
    fn prepare(_: &CorrelationConfig, _: &[usize]) -> Result<(), ExperimentError> {
        Ok(())
    }
    fn run_job(c: &CorrelationConfig, _: &(), j: usize) -> Result<Done, ExperimentError> {
        if j < c.runs {
            one_run(c, j).map(Done::Run)
        } else {
            multi_run(c).map(Done::Multi)
        }
    }
    fn rows(_: &CorrelationConfig, j: usize, done: &Done) -> Vec<FrameRow> {
        match done {
            Done::Run(r) => frame_rows(j, r),
            Done::Multi(_) => Vec::new(),
        }
    }
    fn report(
        config: &CorrelationConfig,
        done: Vec<Done>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let result = assemble(config, done)?;
        write_outputs(&result, dir)?;
        Ok(result.tables())
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&CorrelationConfig::quick())?;
        let mut out = String::from("table,row,column,value\n");
        for s in r.summary() {
            let name = s.variant.name();
            for (col, v) in [
                ("before", s.phases.before),
                ("during", s.phases.during),
                ("after", s.phases.after),
                ("recovered", s.recovered),
            ] {
                let _ = writeln!(out, "summary,{name},{col},{v:.17e}");
            }
        }
        for (v, tr) in Variant::ALL.iter().zip(&r.runs[0].tracks) {
            for (k, c) in tr.centres.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "run0,{} frame {},xy,{:.17e} {:.17e}",
                    v.name(),
                    k + 1,
                    c[0],
                    c[1]
                );
            }
        }
        for (k, cars) in r.multi.tracks.iter().enumerate() {
            for (i, t) in cars.iter().enumerate() {
                let cell = t.map_or("-".to_string(), |v| {
                    format!("{:.17e} {:.17e} {:.17e} {:.17e}", v[0], v[1], v[2], v[3])
                });
                let _ = writeln!(out, "multi,frame {} car {},x y Lx Ly,{cell}", k + 42, i + 1);
            }
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let mut c = CorrelationConfig::quick();
        c.apply("sigma", "2").unwrap();
        c.apply("b", "5").unwrap();
        c.apply("gain", "1").unwrap();
        assert_eq!(c.sigma, 2.0);
        assert_eq!(
            c.pf().motion,
            ArpMotion::Drift {
                b: [5.0, 5.0],
                gain: 1.0
            }
        );
        assert!(c.apply("gain", "2").is_err());
        assert_eq!(
            c.pf().motion,
            ArpMotion::Drift {
                b: [5.0, 5.0],
                gain: 1.0
            }
        );
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("bogus", "1").is_err());
        assert!(c.apply("sigma", "nan").is_err());
        c.apply("const_b", "2").unwrap();
        assert_eq!(c.const_b, 2.0);
        assert!(c.apply("const_b", "-1").is_err());
        assert!(c.apply("cap", "-1").is_err());
    }

    #[test]
    fn the_initial_box_is_centred_on_the_car() {
        let scene = RoadScene::default().generate(1).unwrap();
        let b = initial_box(&scene.truth[0]).unwrap();
        let (cx, cy) = b.center();
        assert_eq!((cx - 1.0, cy - 1.0), (57.0, 85.0));
        assert_eq!((b.width, b.height), (25.0, 33.0));
    }
}
