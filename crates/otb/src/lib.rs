#![doc = include_str!("../README.md")]

pub mod error;
pub mod ground_truth;
pub mod metrics;
pub mod otb_table;
#[cfg(feature = "plot")]
pub mod plot;
pub mod published;
pub mod sequence;
#[cfg(feature = "suite")]
pub mod shard;
pub mod source;
#[cfg(feature = "suite")]
pub mod suite;
pub mod table;
#[cfg(feature = "track")]
pub mod track;
pub mod write;
pub mod y4m;

pub use error::{OtbError, WriteError};
pub use metrics::{OtbScore, score_otb};
pub use sequence::Sequence;
pub use source::{Frame, FrameSelection, FrameSource, Select};
pub use table::Table;
#[cfg(feature = "track")]
pub use track::{OnBadFrame, TrackRun, track_frames, track_source, track_stream};
