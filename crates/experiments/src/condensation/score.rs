//! What the tables summarise: grid, re-initialisation, crossing and claim rows.

use super::*;

/// One grid cell over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSummary {
    /// The cell.
    pub key: GridKey,
    /// Mean centre error (px) over frames and runs.
    pub centre: f64,
    /// Mean curve-to-outline distance (px); NaN for the point cloud.
    pub outline: f64,
    /// Share of frames lost.
    pub loss: f64,
    /// Frames per second (step only; one thread, measured while the other
    /// jobs run); NaN (printed `-`) when the run was not timed.
    pub fps: f64,
}

/// Re-initialisation over runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ReinitSummary {
    /// The tracker.
    pub key: GridKey,
    /// Whether c-AVQ was on.
    pub avq: bool,
    /// Lock-on frames per run (`None`: never).
    pub lock_on: Vec<Option<usize>>,
}

impl ReinitSummary {
    /// Runs that locked on.
    pub fn locked(&self) -> usize {
        self.lock_on.iter().flatten().count()
    }

    /// The slowest lock-on among the runs that locked on.
    pub fn worst(&self) -> Option<usize> {
        self.lock_on.iter().flatten().copied().max()
    }

    /// Mean lock-on among the runs that locked on.
    pub fn mean(&self) -> f64 {
        let v: Vec<f64> = self.lock_on.iter().flatten().map(|&k| k as f64).collect();
        mean(&v)
    }
}

/// Crossing over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossingSummary {
    /// The tracker of every object.
    pub key: GridKey,
    /// Priority IFD on or off.
    pub priority: bool,
    /// Frames pooled over runs.
    pub count: CrossingCount,
    /// Runs whose last frame has both identities right.
    pub kept_at_end: usize,
    /// Runs.
    pub runs: usize,
}

/// Sec. 3.3's claim at one `N`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClaimRow {
    /// `N`: one cue runs with `N`, AND with `N/2`.
    pub n: usize,
    /// The single cue compared.
    pub single: Cue,
    /// AND at `N/2`.
    pub and: GridSummary,
    /// The single cue at `N`.
    pub one: GridSummary,
}

impl ClaimRow {
    /// Whether AND at `N/2` is better on centre error, outline distance and
    /// loss rate together (ties on loss allowed).
    pub fn reproduces(&self) -> bool {
        self.and.centre < self.one.centre
            && self.and.outline < self.one.outline
            && self.and.loss <= self.one.loss
    }
}

pub(super) fn opt(v: Option<usize>) -> String {
    v.map_or("never".to_string(), |k| k.to_string())
}
