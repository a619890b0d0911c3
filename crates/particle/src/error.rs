//! The error type of the crate.

use bayestrack_kalman::KalmanError;

/// Everything that can go wrong in `bayestrack-particle`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParticleError {
    /// A particle set (or weight vector) with no particles.
    #[error("the particle set is empty")]
    Empty,
    /// Every weight is zero (every log-weight is minus infinity).
    #[error("all {count} particle weights are zero")]
    AllWeightsZero {
        /// Number of particles.
        count: usize,
    },
    /// A weight is NaN, infinite or negative (a log-weight NaN or plus
    /// infinity).
    #[error("the weight of particle {index} is not a finite non-negative number ({value})")]
    NonFiniteWeight {
        /// Which particle.
        index: usize,
        /// Its (log-)weight.
        value: f64,
    },
    /// Weights and particles of different lengths.
    #[error("{particles} particles but {weights} weights")]
    LengthMismatch {
        /// Number of particles.
        particles: usize,
        /// Number of weights.
        weights: usize,
    },
    /// A tuning parameter out of its domain.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why.
        reason: &'static str,
    },
    /// A particle's Kalman proposal failed.
    #[error("Kalman proposal of particle {index} failed: {source}")]
    Proposal {
        /// Which particle.
        index: usize,
        /// What the filter said.
        source: KalmanError,
    },
    /// A filter step given the random-stream key of the step before it,
    /// which would draw the same noise again.
    #[error(
        "step {k} reuses the random-stream key of step {}: every step needs its own key (Smc numbers them)",
        k - 1
    )]
    KeyReused {
        /// The time index of the refused step.
        k: usize,
    },
    /// A proposed particle is not finite.
    #[error("proposed state of particle {index} is not finite")]
    NonFiniteState {
        /// Which particle.
        index: usize,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = ParticleError> = std::result::Result<T, E>;
