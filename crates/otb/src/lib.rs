#![doc = include_str!("../README.md")]

mod error;
pub mod ground_truth;
pub mod metrics;
pub mod otb_table;
#[cfg(feature = "plot")]
pub mod plot;
pub mod published;
mod sequence;
#[cfg(feature = "suite")]
pub mod shard;
mod source;
#[cfg(feature = "suite")]
pub mod suite;
mod table;
#[cfg(feature = "track")]
mod track;
pub mod write;
pub mod y4m;

pub use error::{OtbError, WriteError};
pub use sequence::{Sequence, frame_number, list_sequences, order_frames};
pub use source::{
    DecodeAhead, FFMPEG_ENV, FolderSource, Frame, FrameSelection, FrameSource, PendingFrame,
    Select, VideoSource, Y4mSource,
};
pub use table::Table;
#[cfg(feature = "track")]
pub use track::{
    CONVERTED_LISTED, FrameBox, OnBadFrame, SKIPPED_LISTED, TrackRun, clip_initial_box,
    track_frames, track_source, track_stream,
};
