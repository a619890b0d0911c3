#![doc = include_str!("../README.md")]

pub mod metrics;
pub mod otb_table;
#[cfg(feature = "suite")]
pub mod plot;
pub mod published;
pub mod sequence;
pub mod source;
#[cfg(feature = "suite")]
pub mod suite;
pub mod table;
pub mod track;
pub mod write;
pub mod y4m;

pub use metrics::{MetricsError, OtbScore, score_otb};
pub use sequence::{OtbError, Sequence};
pub use source::{Frame, FrameSelection, FrameSource, Select};
pub use table::Table;
pub use track::{OnBadFrame, TrackError, TrackRun, track_frames, track_source};
pub use write::WriteError;
