//! The one error type of this crate.

use std::path::PathBuf;

use crate::Rect;

/// Everything that can go wrong in `bayestrack-image`.
///
/// Each variant carries the data needed to find the culprit: which size,
/// which window, which file, which line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// An image, view or crop with zero width, height or channels.
    #[error("image of zero size: {width}x{height} with {channels} channel(s)")]
    ZeroSize {
        /// Requested width in pixels.
        width: usize,
        /// Requested height in pixels.
        height: usize,
        /// Requested number of channels.
        channels: usize,
    },
    /// A buffer too short for the requested geometry, or a stride smaller
    /// than one row.
    #[error(
        "buffer of {len} elements cannot hold {width}x{height}x{channels} with stride {stride}"
    )]
    BufferSize {
        /// Elements in the buffer.
        len: usize,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// Channels per pixel.
        channels: usize,
        /// Row stride in elements.
        stride: usize,
    },
    /// An image whose element count overflows `usize`, or whose buffer
    /// cannot be allocated.
    #[error(
        "image of {width}x{height}x{channels} elements is too large (its size overflows, or memory for it cannot be allocated)"
    )]
    TooLarge {
        /// Requested width in pixels.
        width: usize,
        /// Requested height in pixels.
        height: usize,
        /// Requested number of channels.
        channels: usize,
    },
    /// The image has the wrong number of channels for this operation.
    #[error("{operation} needs {expected} channel(s), the image has {got}")]
    Channels {
        /// The operation that refused the image.
        operation: &'static str,
        /// Channels the operation accepts.
        expected: usize,
        /// Channels the image has.
        got: usize,
    },
    /// Two images that must have the same geometry do not.
    #[error(
        "{operation}: size mismatch, {a_width}x{a_height}x{a_channels} vs {b_width}x{b_height}x{b_channels}"
    )]
    SizeMismatch {
        /// The operation that compared the images.
        operation: &'static str,
        /// Width of the first image.
        a_width: usize,
        /// Height of the first image.
        a_height: usize,
        /// Channels of the first image.
        a_channels: usize,
        /// Width of the second image.
        b_width: usize,
        /// Height of the second image.
        b_height: usize,
        /// Channels of the second image.
        b_channels: usize,
    },
    /// A window (crop, search region) that is not inside the frame.
    #[error("window {window} is not inside the {width}x{height} frame")]
    WindowOutside {
        /// The offending window (0-based pixels).
        window: Rect,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// A warped patch whose corner maps outside the frame under
    /// [`Border::Error`](crate::Border::Error).
    #[error("patch corner ({u}, {v}) maps to ({x:.3}, {y:.3}), outside the {width}x{height} frame")]
    PatchOutside {
        /// Patch column of the offending corner.
        u: usize,
        /// Patch row of the offending corner.
        v: usize,
        /// Image x it maps to.
        x: f64,
        /// Image y it maps to.
        y: f64,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// A NaN or infinite number where a finite one is needed.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// What held the value.
        what: &'static str,
    },
    /// A 3x3 matrix whose last row is not `[0, 0, 1]`.
    #[error("not an affine matrix: last row is {row:?}, expected [0, 0, 1]")]
    NotAffine {
        /// The last row found.
        row: [f64; 3],
    },
    /// An invalid parameter (negative threshold, zero bins, ...).
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// Reading or listing a file or folder failed.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A file that is not a decodable PNG/JPEG (truncated, corrupt or another format).
    #[cfg(feature = "io")]
    #[error("cannot decode image {path}: {source}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The decoder's error.
        #[source]
        source: image::ImageError,
    },
    /// A PNG/JPEG file that ends before its end marker (cut short).
    #[cfg(feature = "io")]
    #[error("image file {path} is truncated: no {format} end marker")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// The format detected.
        format: String,
    },
    /// Writing an image failed.
    #[cfg(feature = "io")]
    #[error("cannot write image {path}: {source}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The encoder's error.
        #[source]
        source: image::ImageError,
    },
    /// A folder with no PNG/JPEG frames.
    #[error("no PNG/JPEG frames in {path}")]
    NoFrames {
        /// The folder searched.
        path: PathBuf,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = ImageError> = std::result::Result<T, E>;
