//! Experiments, synthetic scenes with exact ground truth, sequence loading and
//! metrics for bayestrack.
//!
//! The experiments that reproduce the papers' tables live here (not in
//! `xtask`) so that tests can call them: `xtask` only parses arguments and
//! prints. [`experiment::registry`] lists every experiment id that
//! `cargo xtask reproduce-table` knows.

pub mod ball;
pub mod correlation;
pub mod experiment;
pub mod hikpf;
pub mod metrics;
pub mod otb;
pub mod plot;
pub mod scenes;
pub mod suite;
pub mod table;
pub mod track;

pub use experiment::{Experiment, ExperimentError, Mode, RunOptions, registry};
pub use metrics::{MetricsError, OtbScore, score_otb};
pub use otb::{OtbError, Sequence};
pub use scenes::{Scene, SceneError, SceneStream};
pub use table::Table;
pub use track::{OnBadFrame, TrackError, TrackRun, track_frames};
