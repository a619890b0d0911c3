//! The `affine` experiment: Xu, Gao and Yang 2015 (paper 002), section 4,
//! on synthetic sequences with exact affine ground truth.
//!
//! The paper compares HKPF (Yin et al. 2011), ISPF (Li et al. 2012) and its
//! self-tuning HKPF on three real videos, by the RMS error of eq. 6 over
//! seven labelled feature points and the centre (Fig. 7) and by the
//! particles used per frame (Fig. 8). We cannot label the real videos'
//! points, so each video is mirrored by a setting of
//! [`AffineScene`] whose poses and points are exact ([`Setting`]).
//!
//! Per setting and filter: RMS of eq. 6 (mean, median, 90th percentile over
//! the tracked frames), frames lost, mean particles, appearance evaluations
//! and pose-estimator calls per frame, and frames per second.
//!
//! # How the points are carried
//! The tracker starts from the ground-truth box of frame 1 and reports its
//! pose `M^_k` (template coordinates centred on its own template, which is
//! that box, to 0-based image coordinates). The true pose `M_k` maps the
//! scene's template. A feature point `p` of the scene's template is, in the
//! tracker's template, `q = M^_0^-1 M_0 p`; its estimate in frame `k` is
//! `M^_k q` (for a perfect tracker `M^_k = M_k M_0^-1 M^_0`, so the error is
//! zero). Frame 1 is the initialisation and is not scored.
//!
//! # Lost
//! A frame is lost when its RMS error exceeds `lost_fraction` (0.25) times
//! the side `sqrt(w_k h_k)` of the true target, `w_k h_k` its area at that
//! frame (`|det|` of the true pose times the template area): 13 px for the
//! 48x56 patch at scale 1, about the distance from an eye's outer corner to
//! the nose.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use bayestrack_image::Image;
use bayestrack_otb::Table;
use bayestrack_otb::metrics::{FeaturePoints, rms_error_eq6};
use bayestrack_otb::plot::{Series, line_chart};
use bayestrack_trackers::{
    AffineTracker, AppearanceConfig, HkpfConfig, HkpfTracker, IspfConfig, IspfTracker,
    RegionConfig, StpfConfig, StpfTracker, TsdInit,
};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_FRAMES, MAX_PARTICLES, MAX_RUNS, write_text};
use bayestrack_options::{IfSome, Options, above, choice, inside, options};

/// The experiment's id.
const ID: &str = "affine";
use crate::scenes::{AffineScene, JumpKind, TEMPLATE_POINTS};

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

/// The registry entry: job `j` is setting `j / runs`, run `j % runs`.
pub struct AffineExperiment;

impl Paper for AffineExperiment {
    type Config = AffineConfig;
    type Done = Vec<TrackRun>;
    type Row = FrameRow;
    type Shared = ();
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 002 (RMS eq. 6, particles per frame)";
    const SUMMARY: &'static str = "HKPF, ISPF and self-tuning HKPF on synthetic affine sequences";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "affine sequences";

    fn quick() -> AffineConfig {
        AffineConfig::quick()
    }
    fn full() -> AffineConfig {
        AffineConfig::paper()
    }
    fn jobs(c: &AffineConfig) -> usize {
        Setting::ALL.len() * c.runs + reading_jobs(c).len()
    }
    fn prepare(_: &AffineConfig, _: &[usize]) -> Result<(), ExperimentError> {
        Ok(())
    }
    fn run_job(c: &AffineConfig, _: &(), j: usize) -> Result<Vec<TrackRun>, ExperimentError> {
        let base = Setting::ALL.len() * c.runs;
        if j < base {
            let (s, r) = job(c, j);
            return run_job(c, s, r);
        }
        let (i, s, r) = reading_jobs(c)[j - base];
        run_job(&READINGS[i].config(c)?, s, r)
    }
    fn rows(c: &AffineConfig, j: usize, done: &Vec<TrackRun>) -> Vec<FrameRow> {
        // frames.csv logs the run's own readings only
        if j >= Setting::ALL.len() * c.runs {
            return Vec::new();
        }
        let (s, r) = job(c, j);
        frame_rows(s, r, done)
    }
    fn report(
        config: &AffineConfig,
        done: Vec<Vec<TrackRun>>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let result = assemble(config, done);
        write_outputs(&result, dir)?;
        let mut tables = vec![result.table(), result.claims_table()];
        if !result.readings.is_empty() {
            tables.push(readings_table(&result));
        }
        Ok(tables)
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&AffineConfig::quick(), false)?;
        let mut out = String::from("setting,filter,column,value\n");
        for s in r.summaries() {
            for (col, v) in [
                ("rms_mean", s.rms[0]),
                ("rms_median", s.rms[1]),
                ("rms_p90", s.rms[2]),
                ("lost_frames", s.lost_frames),
                ("particles", s.particles),
                ("evaluations", s.evaluations),
                ("pe_calls", s.pose_estimator_calls),
            ] {
                let _ = writeln!(
                    out,
                    "{},{},{col},{v:.17e}",
                    s.setting.name(),
                    s.filter.name()
                );
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
        let mut c = AffineConfig::quick();
        c.apply("frames", "30").unwrap();
        c.apply("max_particles", "20").unwrap();
        assert_eq!(
            (c.frames, c.stpf().max_particles, c.ispf().max_particles),
            (30, 20, 20)
        );
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("lost_fraction", "nan").is_err());
        assert!(c.apply("bogus", "1").is_err());
    }

    #[test]
    fn quantiles_by_hand() {
        let q = quantiles(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!(q, [3.0, 3.0, 5.0]);
        assert!(quantiles(&[])[0].is_nan());
    }

    /// A tracker that reports the true pose scores zero: the carrying of
    /// the points through the initial poses is exact.
    #[test]
    fn the_true_pose_scores_zero() {
        let config = AffineConfig {
            frames: 3,
            ..AffineConfig::quick()
        };
        let scene = Setting::Sylvester.scene(&config).generate(1).unwrap();
        let a0 = scene.truth[0].affine.unwrap();
        let a2 = scene.truth[2].affine.unwrap();
        // Any initial pose of the tracker: the box centre, no rotation.
        let est0 = Matrix3::new(1.0, 0.0, 100.0, 0.0, 1.0, 80.0, 0.0, 0.0, 1.0);
        let carry = est0.try_inverse().unwrap() * matrix(&a0.matrix);
        let perfect = matrix(&a2.matrix) * matrix(&a0.matrix).try_inverse().unwrap() * est0;
        let [tw, th] = a0.template_size;
        let mut e = FeaturePoints {
            center: apply(&perfect, apply(&carry, [0.0, 0.0])),
            ..FeaturePoints::default()
        };
        for (p, t) in e.points.iter_mut().zip(TEMPLATE_POINTS) {
            *p = apply(&perfect, apply(&carry, [t[0] * tw, t[1] * th]));
        }
        assert!(rms_error_eq6(&e, &a2.points).unwrap() < 1e-9);
    }
}
