//! Every experiment by id: what `cargo xtask reproduce-table` lists and runs.
//! An experiment added to [`REGISTRY`] joins `list`, `all` and `bless`.

use crate::affine::AffineExperiment;
use crate::ball::BallExperiment;
use crate::correlation::CorrelationExperiment;
use crate::experiment::{Experiment, ExperimentError, RunOptions};
use crate::hikpf::HikpfExperiment;
use bayestrack_otb::Table;

/// An experiment that the SPEC asks for and that is not built yet.
struct Planned {
    id: &'static str,
    source: &'static str,
    summary: &'static str,
}

impl Experiment for Planned {
    fn id(&self) -> &'static str {
        self.id
    }
    fn source(&self) -> &'static str {
        self.source
    }
    fn summary(&self) -> &'static str {
        self.summary
    }
    fn implemented(&self) -> bool {
        false
    }
    fn run(&self, _opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
        Err(ExperimentError::NotImplemented(self.id))
    }
}

/// Every experiment, in the order `all` runs them.
pub const REGISTRY: &[&dyn Experiment] = &[
    &HikpfExperiment,
    &BallExperiment,
    &AffineExperiment,
    &CorrelationExperiment,
    &Planned {
        id: "condensation",
        source: "paper 003",
        summary: "CONDENSATION with IFD, skin, OR and AND cues; c-AVQ; priority IFD",
    },
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
