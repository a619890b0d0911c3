//! The crate's error: one enum, [`OtbError`], for sequences, ground truth,
//! frame sources, metrics, published results, the tracking loop and the
//! suite, each variant naming what it is about (the file, the 1-based
//! line, the frame). Writing a file fails with [`WriteError`], which
//! [`OtbError::Write`] wraps.
//!
//! A leaf module: it imports no other module of the crate, so every module
//! can import it.

use std::path::{Path, PathBuf};

use bayestrack_image::{BBox, ImageError};

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OtbError {
    /// The sequence folder does not exist or is not a folder.
    #[error("sequence folder {path} does not exist")]
    MissingFolder {
        /// The folder asked for.
        path: PathBuf,
    },
    /// The ground-truth file of a plain frame folder has more rows than
    /// there are frames (which rows belong to which frames is unknown).
    #[error("{path}: {rows} ground-truth rows for {frames} frames")]
    RowCount {
        /// The ground-truth file.
        path: PathBuf,
        /// Frames found.
        frames: usize,
        /// Ground-truth rows found (blank lines excluded).
        rows: usize,
    },
    /// A frame that cannot be read or decoded (truncated, corrupt, not an
    /// image); the source names the file too.
    #[error("frame {} ({path}): {source}", .index + 1)]
    Frame {
        /// 0-based frame index.
        index: usize,
        /// The frame file.
        path: PathBuf,
        /// What `bayestrack-image` reported.
        #[source]
        source: Box<ImageError>,
    },
    /// A frame index past the end of the sequence.
    #[error("frame {index} requested from a {len}-frame sequence")]
    IndexOutOfRange {
        /// Index asked for.
        index: usize,
        /// Frames in the sequence.
        len: usize,
    },
    /// A frame file the OTB-100 table says the sequence has is missing.
    #[error("{path} is missing (OTB-100 {sequence} runs on frames {first}-{last} of its folder)")]
    MissingFrame {
        /// The frame file expected.
        path: PathBuf,
        /// The OTB-100 sequence.
        sequence: String,
        /// First frame number of the sequence.
        first: usize,
        /// Last frame number.
        last: usize,
    },
    /// No ground-truth file in a sequence folder.
    #[error("no ground-truth file (groundtruth_rect.txt or *_gt.txt) in {path}")]
    NoGroundTruth {
        /// The sequence folder.
        path: PathBuf,
    },
    /// A ground-truth row that does not parse as four numbers.
    #[error("{path}:{line}: cannot parse ground-truth row {text:?}: {reason}")]
    GroundTruth {
        /// The ground-truth file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The text of the line.
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A plain folder's frame files that do not number the frames one to
    /// one (a gap, a number twice, a name without a number or not UTF-8).
    #[error("{path}: {reason}")]
    FrameNames {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// An OTB-100 target named by `--seq` (`Jogging_2`) whose folder has
    /// not the benchmark's layout.
    #[error(
        "{target}: {dir} has not the OTB-100 layout (no {expected}), so the target's frames and \
         ground truth cannot be found; give the folder itself and the target's ground truth \
         with --groundtruth"
    )]
    NotOtbLayout {
        /// The target asked for.
        target: String,
        /// Its folder.
        dir: PathBuf,
        /// What the layout needs.
        expected: String,
    },
    /// A ground-truth file larger than the reader's limit (or endless).
    #[error(
        "{path}: more than {limit} bytes of ground truth (an endless file such as /dev/zero, \
         or not a ground-truth file); set BAYESTRACK_GT_MAX_BYTES=<bytes> to read a larger one"
    )]
    GroundTruthTooLarge {
        /// The file.
        path: PathBuf,
        /// The limit in bytes.
        limit: u64,
    },
    /// A YUV4MPEG2 stream that cannot be read: a bad header, a frame cut
    /// short, a failed read.
    #[error("{source_name}: {}{reason}", .frame.map(|f| format!("Y4M frame {f}: ")).unwrap_or_else(|| "Y4M header: ".to_string()))]
    Y4m {
        /// The stream (`stdin`, a file).
        source_name: String,
        /// 1-based frame, `None` for the stream header.
        frame: Option<usize>,
        /// What is wrong.
        reason: String,
    },
    /// A Y4M header that asks for frames larger than the reader's limit.
    #[error(
        "{source_name}: Y4M header {header}: frames of {pixels} pixels ({bytes} bytes each) are \
         more than the {limit} pixels read by default (a corrupt header, or a larger video \
         than trackers are meant for); scale it down with ffmpeg's -vf scale=1920:-2, or set \
         BAYESTRACK_Y4M_MAX_PIXELS=<pixels> to read it as it is"
    )]
    Y4mFrameTooLarge {
        /// The stream (`stdin`, a file).
        source_name: String,
        /// The header's size fields (`W32768 H32768 C444`).
        header: String,
        /// Pixels per frame.
        pixels: usize,
        /// Bytes per frame.
        bytes: usize,
        /// The limit in pixels.
        limit: usize,
    },
    /// A video file needs an `ffmpeg` executable to decode it, and there is
    /// none.
    #[error(
        "cannot decode the video {video}: no `{program}` executable was found. bayestrack reads \
         video files by piping them through ffmpeg: install it (https://ffmpeg.org/download.html; \
         `apt install ffmpeg`, `dnf install ffmpeg`, `brew install ffmpeg`, `winget install \
         ffmpeg`) or name its path in BAYESTRACK_FFMPEG. Without it, a folder of PNG/JPEG frames \
         works, and so does Y4M on standard input from any decoder: `ffmpeg -i clip.mp4 -f \
         yuv4mpegpipe - | bayestrack track --seq - --init x,y,w,h`"
    )]
    NoFfmpeg {
        /// The video file.
        video: PathBuf,
        /// The executable looked for.
        program: String,
    },
    /// ffmpeg could not decode a video file (ffmpeg's message).
    #[error("cannot decode the video {video}: {reason}")]
    Video {
        /// The video file.
        video: PathBuf,
        /// What went wrong, with ffmpeg's own message.
        reason: String,
    },
    /// A file that cannot be read (a table of published results, a
    /// shard's files, a ground-truth file).
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The first line of a table file is not the expected header.
    #[error("{}:1: expected the header `{expected}`, found `{found}`", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// What the header should be.
        expected: String,
        /// The first line as found.
        found: String,
    },
    /// A row of a table file that cannot be read.
    #[error("{}:{line}: {message}", path.display())]
    Row {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The same key twice in a table file.
    #[error("{}:{line}: {what} repeats line {first}", path.display())]
    Duplicate {
        /// The file.
        path: PathBuf,
        /// 1-based line of the repetition.
        line: usize,
        /// 1-based line of the first occurrence.
        first: usize,
        /// The repeated key.
        what: String,
    },
    /// A table file with a header and no rows.
    #[error("{}: no rows after the header", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A file or folder could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// Predictions and ground truth cover different numbers of frames.
    #[error("{predicted} predicted boxes for {truth} ground-truth frames")]
    LengthMismatch {
        /// Number of predicted boxes.
        predicted: usize,
        /// Number of ground-truth entries.
        truth: usize,
    },
    /// A box with a non-finite number or a negative size.
    #[error("frame {frame}: invalid {which} box {bbox:?} (non-finite or negative size)")]
    InvalidBox {
        /// 0-based frame index.
        frame: usize,
        /// `"predicted"` or `"ground-truth"`.
        which: &'static str,
        /// The offending box.
        bbox: BBox,
    },
    /// A non-finite feature point or centre in the RMS error.
    #[error("non-finite {which} feature point {index}")]
    NonFinitePoint {
        /// `"estimated"` or `"true"`.
        which: &'static str,
        /// Point index (0..7, 7 is the centre).
        index: usize,
    },
    /// Every frame is unlabelled, so nothing can be scored.
    #[error("no labelled frame to score among {frames}")]
    NothingToScore {
        /// Number of frames given.
        frames: usize,
    },
    /// The tracker refused a frame (changed size, wrong channels, a box
    /// outside the first frame, ...).
    #[cfg(feature = "track")]
    #[error("{tracker} failed on frame {frame} ({path}): {source}")]
    Tracker {
        /// Tracker name.
        tracker: &'static str,
        /// 1-based frame number.
        frame: usize,
        /// The frame file.
        path: PathBuf,
        /// What the tracker reported.
        #[source]
        source: Box<bayestrack_trackers::TrackerError>,
    },
    /// A frame source delivered no frame to track.
    #[error("the sequence has no frames")]
    NoFramesToTrack,
    /// The suite's root folder holds no sequence, or cannot be listed.
    #[error("no sequence to run in {root}: {reason}")]
    NoSequences {
        /// The folder asked for.
        root: PathBuf,
        /// Why nothing was found.
        reason: String,
    },
    /// A shard `K/N` that is not one: not two whole numbers, `N` 0, or `K`
    /// outside `1..=N`.
    #[error("shard `{spec}`: {reason}")]
    Shard {
        /// The text given.
        spec: String,
        /// What is wrong.
        reason: String,
    },
    /// Shard folders that do not merge into one run: a shard missing,
    /// given twice, unfinished, or from another suite.
    #[error("cannot merge {path}: {reason}")]
    Merge {
        /// The shard folder (or its file) at fault.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Listing frames or reading a frame file failed
    /// ([`ImageError::NoFrames`] names the folder, [`ImageError::Io`] the
    /// file or folder).
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// A file or folder that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct WriteError {
    /// The file or folder.
    pub path: PathBuf,
    /// The underlying error.
    #[source]
    pub source: std::io::Error,
}

impl WriteError {
    /// Wraps `source`, naming `path`.
    pub fn new(path: &Path, source: std::io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            source,
        }
    }
}
