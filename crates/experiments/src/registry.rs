//! Every experiment by id: what `cargo xtask reproduce-table` lists and runs.
//! An experiment added to [`REGISTRY`] joins `list`, `all` and `bless`.

use crate::affine::AffineExperiment;
use crate::ball::BallExperiment;
use crate::condensation::CondensationExperiment;
use crate::correlation::CorrelationExperiment;
use crate::experiment::{Experiment, ExperimentError};
use crate::hikpf::HikpfExperiment;

/// Every experiment, in the order `all` runs them.
pub const REGISTRY: &[&dyn Experiment] = &[
    &HikpfExperiment,
    &BallExperiment,
    &AffineExperiment,
    &CorrelationExperiment,
    &CondensationExperiment,
];

/// The experiment called `id`.
///
/// # Errors
/// [`ExperimentError::Unknown`].
pub fn find(id: &str) -> Result<&'static dyn Experiment, ExperimentError> {
    REGISTRY
        .iter()
        .copied()
        .find(|e| e.id() == id)
        .ok_or_else(|| ExperimentError::Unknown(id.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_unique() {
        let mut ids: Vec<_> = REGISTRY.iter().map(|e| e.id()).collect();
        ids.sort();
        ids.dedup();
        assert_eq!(ids.len(), REGISTRY.len());
    }

    #[test]
    fn unknown_id_is_an_error() {
        assert!(matches!(find("nope"), Err(ExperimentError::Unknown(_))));
    }
}
