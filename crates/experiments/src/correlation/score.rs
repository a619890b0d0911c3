//! What the tables summarise per tracker.

use super::*;

/// Summary of one variant over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariantSummary {
    /// The tracker.
    pub variant: Variant,
    /// Mean over runs of the phase errors.
    pub phases: PhaseErrors,
    /// Fraction of runs whose mean error after the occlusion is under 5 px
    /// (the car re-acquired).
    pub recovered: f64,
}

pub(super) fn xy(c: [f64; 2]) -> String {
    format!("({:.1}, {:.1})", c[0], c[1])
}
