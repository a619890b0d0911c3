//! The paper experiments behind `cargo xtask reproduce-table` and the
//! synthetic scenes with exact ground truth they run on.
//!
//! This crate is not published: it is the project's own reproduction of the
//! five papers. It lives in a library (not in `xtask`) so that tests can call
//! the experiments: `xtask` only parses arguments and prints.
//!
//! - [`experiment`]: the [`Experiment`] trait, run options and errors;
//! - [`driver`]: the one driver of every experiment ([`driver::Paper`]):
//!   presets, `--set`, outputs, partial logs, progress, shards and merge;
//! - [`REGISTRY`]: every experiment by id, in the order `all` runs them;
//! - one module per experiment: [`hikpf`] (paper 000), [`ball`] (paper
//!   001), [`affine`] (paper 002), [`condensation`] (paper 003),
//!   [`correlation`] (paper 004);
//! - [`scenes`]: the seeded synthetic scenes and their registry;
//! - [`stress`]: the synthetic stress set (occlusion, scale, fast motion,
//!   illumination, clutter) on which tracker parameters are chosen.
//!
//! Sequences, metrics and the tracking loop come from `bayestrack-otb`.

pub mod affine;
pub mod ball;
pub mod condensation;
pub mod correlation;
pub mod driver;
pub mod experiment;
pub mod hikpf;
mod registry;
pub mod scenes;
pub mod stress;

pub use driver::{Paper, Shard};
pub use experiment::{Experiment, ExperimentError, Mode, RunOptions};
pub use registry::{REGISTRY, find};
