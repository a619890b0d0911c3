//! What one filter's run records, and its summaries.

use super::*;

/// One filter on one sequence: per scored frame (frames 2..n).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct TrackRun {
    /// RMS error of eq. 6.
    pub rms: Vec<f64>,
    /// Whether the frame is lost.
    pub lost: Vec<bool>,
    /// Particles used.
    pub particles: Vec<usize>,
    /// Appearance evaluations.
    pub evaluations: Vec<usize>,
    /// Pose-estimator calls.
    pub pose_estimator_calls: Vec<usize>,
    /// Seconds spent in the tracker's own calls (init and steps).
    pub seconds: f64,
}

/// Mean, median and 90th percentile of a sample (`NaN`s if empty).
pub(super) fn quantiles(v: &[f64]) -> [f64; 3] {
    if v.is_empty() {
        return [f64::NAN; 3];
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
    [s.iter().sum::<f64>() / s.len() as f64, at(0.5), at(0.9)]
}

pub(super) fn mean_usize(v: &[usize]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().sum::<usize>() as f64 / v.len() as f64
}

/// One setting x filter over every run.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The setting.
    pub setting: Setting,
    /// The filter.
    pub filter: Filter,
    /// RMS mean, median and 90th percentile over every scored frame of
    /// every run.
    pub rms: [f64; 3],
    /// Lost frames per run (mean over runs).
    pub lost_frames: f64,
    /// Frame (1-based) of the first lost frame of each run (`None`: never).
    pub first_lost: Vec<Option<usize>>,
    /// Particles per frame.
    pub particles: f64,
    /// Appearance evaluations per frame.
    pub evaluations: f64,
    /// Pose-estimator calls per frame.
    pub pose_estimator_calls: f64,
    /// Frames per second (tracker calls only; runs share the cores); NaN
    /// (printed `-`) when the run was not timed (`timing=false`).
    pub fps: f64,
}

/// Everything the experiment measured.
#[derive(Debug, Clone, PartialEq)]
pub struct AffineResult {
    /// The configuration.
    pub config: AffineConfig,
    /// `runs[setting][run][filter]`, settings in [`Setting::ALL`] order.
    pub runs: Vec<Vec<Vec<TrackRun>>>,
    /// The runs of the readings (`readings=true`; empty otherwise).
    pub readings: Vec<ReadingResult>,
}
