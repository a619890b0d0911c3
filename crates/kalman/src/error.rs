//! The error type of the crate.

use std::fmt;

/// The step of a filter in which an error happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Step {
    /// Building a belief or a model from user data.
    Construction,
    /// Time update (prediction).
    Predict,
    /// Measurement update.
    Update,
    /// Drawing sigma points.
    SigmaPoints,
    /// Backward (RTS) smoothing pass.
    Smooth,
    /// Evaluating a density or a consistency statistic.
    Evaluate,
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Step::Construction => "construction",
            Step::Predict => "predict",
            Step::Update => "update",
            Step::SigmaPoints => "sigma-point",
            Step::Smooth => "smoothing",
            Step::Evaluate => "evaluation",
        })
    }
}

/// Everything that can go wrong in `bayestrack-kalman`.
///
/// Each variant says which matrix or quantity failed and in which step, so a
/// message such as "innovation covariance S is not positive definite in the
/// update step" points at the cause.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum KalmanError {
    /// A covariance that must be factored (Cholesky) is not positive
    /// definite, or not positive semi-definite where that is enough.
    #[error("{matrix} is not positive definite in the {step} step")]
    NotPositiveDefinite {
        /// Which matrix, e.g. "innovation covariance S".
        matrix: &'static str,
        /// Where it happened.
        step: Step,
    },
    /// A covariance is not symmetric.
    #[error("{matrix} is not symmetric (largest |A - A^T| = {asymmetry:e}) in the {step} step")]
    NotSymmetric {
        /// Which matrix.
        matrix: &'static str,
        /// Largest absolute difference between mirrored entries.
        asymmetry: f64,
        /// Where it happened.
        step: Step,
    },
    /// A number is NaN or infinite.
    #[error("{what} is not finite in the {step} step")]
    NonFinite {
        /// Which input or intermediate result.
        what: &'static str,
        /// Where it happened.
        step: Step,
    },
    /// Lengths or sizes that must agree do not.
    #[error("dimension mismatch: {what} has {got}, expected {expected}")]
    DimensionMismatch {
        /// What was measured.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Actual size.
        got: usize,
    },
    /// A tuning parameter is out of its domain.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is invalid.
        reason: &'static str,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = KalmanError> = std::result::Result<T, E>;
