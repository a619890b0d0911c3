//! Experiments, synthetic scenes with exact ground truth, sequence loading and
//! metrics for bayestrack.
//!
//! The experiments that reproduce the papers' tables live here (not in
//! `xtask`) so that tests can call them: `xtask` only parses arguments and
//! prints. [`experiment::registry`] lists every experiment id that
//! `cargo xtask reproduce-table` knows.

pub mod experiment;
pub mod table;

pub use experiment::{Experiment, ExperimentError, Mode, RunOptions, registry};
pub use table::Table;
