//! The `condensation` experiment: paper 003 (Lee, Jo and Kang 2005) on the
//! synthetic webcam of [`WebcamScene`].
//!
//! - **Tracking grid** (sec. 3): cue {IFD, skin, OR, AND} x representation
//!   {point cloud (sec. 3.1), B-spline contour (sec. 3.3)} x `N` {50, 100,
//!   200} on the default scene (a face wandering, turning and changing
//!   size in clutter: two static skin-coloured distractors, no other
//!   moving object unless `moving_distractors` says so; the contours'
//!   rotation and scale by Blake and Isard's AR(2) model around the
//!   template, `contour_dynamics`): mean centre error,
//!   mean distance from the mean contour to the true outline (contours
//!   only), loss rate and frames per second, over seeded runs.
//! - **Re-initialisation** (sec. 4): on [`WebcamScene::entering`] the
//!   trackers start on the face; a hand enters through the left or right
//!   border at frame 30. Frames from its entry to lock-on (the estimate
//!   within [`CondensationConfig::lock_distance`] of the newcomer for
//!   [`CondensationConfig::lock_frames`] frames in a row), with and without
//!   c-AVQ.
//! - **Crossing** (sec. 5): on [`WebcamScene::crossing`] a face and a hand
//!   cross; [`MultiCondensation`] with and without the priority-subtracted
//!   IFD (eq. 15); after the crossing each frame is scored kept, swapped,
//!   merged or lost.
//! - **The claim** (sec. 3.3): with both cues (AND) the contour tracker
//!   needs half the particles for better tracking: AND at `N/2` against
//!   IFD and skin alone at `N`, for `N = 100` and `200`, read off the grid.
//!
//! Run `r` renders the scenes with seed `scene_seed + r` and seeds every
//! tracker with `r`; every job has its own seeds, so the numbers do not
//! depend on the thread count (the frames per second do). Positions are
//! 0-based pixels. Every choice is a named option
//! ([`CondensationConfig::apply`]); the reasons are in docs/reproduction.md.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use bayestrack_image::{BBox, Image, write_png};
use bayestrack_trackers::{
    CAvqConfig, ContourConfig, ContourDynamics, ContourTracker, CueSet, MultiCondensation,
    MultiConfig, ObjectConfig, PointCloudConfig, PointCloudTracker, Tracker,
};
use rayon::prelude::*;

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_FRAMES, MAX_RUNS, write_text};
use crate::scenes::{FrameTruth, Outline, SceneStream, SkinShape, WebcamScene};
use bayestrack_options::{Options, above, above_to, inside, options};
use bayestrack_otb::Table;
use bayestrack_otb::plot::{Series, line_chart};

const ID: &str = "condensation";

mod options;
mod paper;
mod readings;
mod report;
mod score;
mod simulate;
pub use options::*;
pub use paper::*;
pub use readings::*;
use report::*;
pub use score::*;
pub use simulate::*;

/// The registry entry (jobs: see [`Done`]).
pub struct CondensationExperiment;

impl Paper for CondensationExperiment {
    type Config = CondensationConfig;
    type Done = Done;
    type Row = FrameRow;
    type Shared = RenderedRuns;
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 003 (sec. 3-5)";
    const SUMMARY: &'static str =
        "CONDENSATION with IFD, skin, OR and AND cues; c-AVQ; priority IFD";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "condensation jobs";

    fn quick() -> CondensationConfig {
        CondensationConfig::quick()
    }
    fn full() -> CondensationConfig {
        CondensationConfig::paper()
    }
    fn jobs(c: &CondensationConfig) -> usize {
        GridKey::all().len() * c.runs + SIDE_TRACKERS.len() * 4 * c.runs + c.runs + 1
    }
    fn prepare(c: &CondensationConfig, jobs: &[usize]) -> Result<Self::Shared, ExperimentError> {
        prepare(c, jobs)
    }
    fn groups(c: &CondensationConfig, jobs: &[usize]) -> Vec<Vec<usize>> {
        groups(c, jobs)
    }
    fn run_job(
        c: &CondensationConfig,
        scenes: &Self::Shared,
        j: usize,
    ) -> Result<Done, ExperimentError> {
        run_job(c, scenes, j)
    }
    fn rows(c: &CondensationConfig, j: usize, done: &Done) -> Vec<FrameRow> {
        match (job(c, j), done) {
            (Job::Grid(key, r), Done::Grid(tr)) => frame_rows(key, r, tr),
            _ => Vec::new(),
        }
    }
    fn report(
        config: &CondensationConfig,
        done: Vec<Done>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let mut result = assemble(config, done)?;
        result.readings = run_readings(config, false)?;
        write_outputs(&result, dir)?;
        Ok(result.tables())
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&CondensationConfig::quick(), false)?;
        let mut out = String::from("table,row,column,value\n");
        for s in r.grid_summary() {
            let row = s.key.label();
            for (col, v) in [
                ("centre", s.centre),
                ("outline", s.outline),
                ("lost", s.loss),
            ] {
                // The point cloud has no outline (NaN never equals itself).
                if v.is_finite() {
                    let _ = writeln!(out, "grid,{row},{col},{v:.17e}");
                }
            }
        }
        let h = r.hand_summary();
        for (col, v) in [
            ("centre", h.centre),
            ("outline", h.outline),
            ("lost", h.loss),
        ] {
            let _ = writeln!(out, "hand,{HAND_LABEL},{col},{v:.17e}");
        }
        for (i, rr) in r.reinit.iter().enumerate() {
            let _ = writeln!(
                out,
                "reinit,{} {} job {i},lock_on,{}",
                rr.key.label(),
                if rr.avq { "c-AVQ" } else { "plain" },
                opt(rr.lock_on)
            );
        }
        for (i, c) in r.crossing.iter().enumerate() {
            let _ = writeln!(
                out,
                "crossing,{} priority={} job {i},kept swapped merged lost,{} {} {} {}",
                c.key.label(),
                c.priority,
                c.count.kept,
                c.count.swapped,
                c.count.merged,
                c.count.lost
            );
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let mut c = CondensationConfig::quick();
        c.apply("runs", "3").unwrap();
        c.apply("lost_fraction", "0.25").unwrap();
        c.apply("avq_trigger", "0.04").unwrap();
        assert_eq!((c.runs, c.lost_fraction), (3, 0.25));
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("frames", "1").is_err());
        assert!(c.apply("bogus", "1").is_err());
        assert!(c.apply("lock_distance", "nan").is_err());
        c.apply("contour_dynamics", "velocity").unwrap();
        assert_eq!(c.contour_dynamics, ContourMotion::Velocity);
        assert_eq!(
            c.contour(ContourConfig::face(50)).dynamics,
            ContourDynamics::DampedVelocity
        );
        c.apply("contour_dynamics", "ar2").unwrap();
        assert!(matches!(
            c.contour(ContourConfig::hand()).dynamics,
            ContourDynamics::Ar2 { rms_theta_deg, rms_alpha } if rms_theta_deg == 15.0 && rms_alpha == 0.15
        ));
        assert!(c.apply("contour_dynamics", "random").is_err());
        c.apply("or_weighting", "normalised").unwrap();
        assert_eq!(
            c.cue_set(Representation::Points, Cue::Or, 50),
            CueSet::OrNormalised { lambda: 0.02 }
        );
        assert_eq!(
            c.cue_set(Representation::Contour, Cue::Or, 50),
            CueSet::Or { lambda: 0.02 }
        );
        c.apply("or_weighting", "subtracted").unwrap();
        assert!(c.apply("rotation_deg", "91").is_err());
        assert!(c.apply("scale_change", "-0.1").is_err());
        assert!(c.apply("face_size", "0").is_err());
        c.apply("pose_motion", "false").unwrap();
        let s = c.posed(WebcamScene::default());
        assert_eq!((s.rotation_deg, s.scale_change), (0.0, 0.0));
        c.apply("pose_motion", "true").unwrap();
        c.apply("face_size", "1.5").unwrap();
        let s = c.posed(WebcamScene::default());
        assert_eq!(
            (s.rotation_deg, s.scale_change, s.target_size),
            (15.0, 0.15, 1.5)
        );
        assert!(!c.describe().is_empty());
    }

    #[test]
    fn the_grid_has_every_cell_once() {
        let all = GridKey::all();
        assert_eq!(all.len(), 24);
        for (i, a) in all.iter().enumerate() {
            assert!(all[i + 1..].iter().all(|b| b != a));
        }
    }

    #[test]
    fn lambda_is_one_over_n() {
        assert_eq!(Cue::Or.cue_set(50), CueSet::Or { lambda: 0.02 });
        assert_eq!(Cue::And.cue_set(100), CueSet::And { lambda: 0.01 });
        assert_eq!(Cue::Ifd.cue_set(100), CueSet::Ifd);
    }
}
