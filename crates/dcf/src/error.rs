//! The error type of the crate.

/// Everything that can go wrong in a correlation filter.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DcfError {
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
    /// A buffer of the wrong length.
    #[error("{what}: expected {expected} elements, got {got}")]
    Size {
        /// Which buffer.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// The FFT library refused its buffers (a bug: the plans own them).
    #[error("the FFT refused its buffers")]
    Fft,
    /// `detect` or `update` before `init`.
    #[error("the filter was not initialised")]
    NotInitialised,
    /// A non-finite value where a number was needed (a NaN response).
    #[error("non-finite {what}")]
    NonFinite {
        /// What it was.
        what: &'static str,
    },
    /// From the image crate.
    #[error(transparent)]
    Image(#[from] bayestrack_image::ImageError),
}

/// Shorthand for results of this crate.
pub type Result<T, E = DcfError> = std::result::Result<T, E>;

/// `Ok` for a `rate` in `[0, 1]`, else [`DcfError::InvalidParameter`]
/// naming it `name` (a NaN is outside).
pub(crate) fn check_rate(name: &'static str, rate: f64) -> Result<()> {
    if (0.0..=1.0).contains(&rate) {
        Ok(())
    } else {
        Err(DcfError::InvalidParameter {
            name,
            value: rate,
            reason: "must be in [0, 1]",
        })
    }
}
