//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong in `bayestrack-affine`.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum AffineError {
    /// A number given to the named operation was NaN or infinite.
    #[error("non-finite value in {what} (index {index})")]
    NonFinite {
        /// Which input held the value.
        what: &'static str,
        /// Position of the first offending element.
        index: usize,
    },
    /// The 2x2 linear part of an affine matrix is singular, so the matrix has
    /// no inverse (or the named operation needs an invertible matrix).
    #[error("singular affine matrix in {op}: det(A) = {det:e}")]
    Singular {
        /// The operation that needed an invertible matrix.
        op: &'static str,
        /// The determinant of the linear part.
        det: f64,
    },
    /// The matrix has no principal real logarithm: its linear part has a
    /// non-positive determinant or an eigenvalue on the closed negative real
    /// axis.
    #[error("no principal real logarithm: {reason} (det(A) = {det:e}, tr(A) = {trace:e})")]
    NoRealLog {
        /// Why the logarithm does not exist.
        reason: &'static str,
        /// Determinant of the linear part.
        det: f64,
        /// Trace of the linear part.
        trace: f64,
    },
    /// The bottom row of a 3x3 affine matrix is not (0, 0, 1) (or, for a Lie
    /// algebra element, not zero).
    #[error("not an affine {kind}: bottom row is ({r0}, {r1}, {r2})")]
    NotAffine {
        /// "group element" or "algebra element".
        kind: &'static str,
        /// Bottom row, first entry.
        r0: f64,
        /// Bottom row, second entry.
        r1: f64,
        /// Bottom row, third entry.
        r2: f64,
    },
    /// A parameter is outside its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A covariance matrix is not symmetric positive definite.
    #[error("covariance {which} is not positive definite")]
    NotPositiveDefinite {
        /// Which covariance.
        which: &'static str,
    },
    /// Vector or matrix dimensions do not agree.
    #[error("dimension mismatch in {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length received.
        got: usize,
    },
    /// An image operation (patch warp) failed, e.g. the patch of a pose
    /// leaves the frame.
    #[error(transparent)]
    Image(#[from] bayestrack_image::ImageError),
    /// The Kalman filter that predicts the global displacement failed.
    #[error(transparent)]
    Kalman(#[from] bayestrack_kalman::KalmanError),
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, AffineError>;

/// Returns an error naming `what` and the index of the first non-finite value.
pub(crate) fn check_finite(what: &'static str, xs: &[f64]) -> Result<()> {
    match xs.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(AffineError::NonFinite { what, index }),
        None => Ok(()),
    }
}
