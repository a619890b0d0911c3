#![doc = include_str!("../README.md")]

pub mod metrics;
#[cfg(feature = "suite")]
pub mod plot;
pub mod published;
pub mod sequence;
#[cfg(feature = "suite")]
pub mod suite;
pub mod table;
pub mod track;
pub mod write;

pub use metrics::{MetricsError, OtbScore, score_otb};
pub use sequence::{OtbError, Sequence};
pub use table::Table;
pub use track::{OnBadFrame, TrackError, TrackRun, track_frames};
pub use write::WriteError;
