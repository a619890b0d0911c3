//! The error type of the crate.

use bayestrack_image::BBox;

/// Everything that can go wrong while tracking.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrackerError {
    /// `step` was called before `init`.
    #[error("the tracker was not initialised")]
    NotInitialised,
    /// The initial box has zero or negative size.
    #[error("box {bbox} (x,y,width,height) has no area")]
    EmptyBox {
        /// The box.
        bbox: BBox,
    },
    /// A coordinate of the initial box is NaN or infinite.
    #[error("box {bbox} (x,y,width,height) has a coordinate that is not a finite number")]
    NonFiniteBox {
        /// The box.
        bbox: BBox,
    },
    /// The initial box leaves the frame.
    #[error("box {bbox} (x,y,width,height) is outside the {width}x{height} frame")]
    BoxOutsideFrame {
        /// The box.
        bbox: BBox,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// A frame's size differs from the first frame's.
    #[error("frame is {got_width}x{got_height}, the first frame was {width}x{height}")]
    FrameSizeChanged {
        /// First frame width.
        width: usize,
        /// First frame height.
        height: usize,
        /// This frame's width.
        got_width: usize,
        /// This frame's height.
        got_height: usize,
    },
    /// The frame has a channel count this tracker cannot use.
    #[error("{tracker} needs {expected} channels, the frame has {got}")]
    Channels {
        /// Tracker name.
        tracker: &'static str,
        /// Accepted channel counts, e.g. "1 or 3".
        expected: &'static str,
        /// The frame's channel count.
        got: usize,
    },
    /// No registered tracker has this name.
    #[error("no tracker called '{name}'; the trackers are: {known}")]
    UnknownTracker {
        /// The name asked for.
        name: String,
        /// The registered names, comma separated.
        known: String,
    },
    /// A parameter out of its domain.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Value.
        value: f64,
        /// Why.
        reason: &'static str,
    },
    /// From the image crate.
    #[error(transparent)]
    Image(#[from] bayestrack_image::ImageError),
    /// From the appearance crate.
    #[error(transparent)]
    Appearance(#[from] bayestrack_appearance::AppearanceError),
    /// From a Kalman filter.
    #[error(transparent)]
    Kalman(#[from] bayestrack_kalman::KalmanError),
    /// From a particle filter.
    #[error(transparent)]
    Particle(#[from] bayestrack_particle::ParticleError),
    /// A `key=value` option the tracker does not take, or a value outside
    /// its domain; the message lists the tracker's keys.
    #[error("tracker {tracker}: {source}")]
    BadOption {
        /// The tracker's name.
        tracker: &'static str,
        /// Which key, which value, and the valid keys.
        source: bayestrack_options::OptionError,
    },
    /// From a correlation filter.
    #[error(transparent)]
    Dcf(#[from] bayestrack_dcf::DcfError),
    /// From the affine group, its dynamics or the pose estimator.
    #[error(transparent)]
    Affine(#[from] bayestrack_affine::AffineError),
}

/// Shorthand for results of this crate.
pub type Result<T, E = TrackerError> = std::result::Result<T, E>;
