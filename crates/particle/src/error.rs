//! The error type of the crate.

use std::sync::Arc;

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
    /// A particle's proposal failed (its local Kalman filter, its image
    /// likelihood, ...).
    #[error("the proposal of particle {index} failed: {source}")]
    Proposal {
        /// Which particle.
        index: usize,
        /// What the proposal said ([`ProposalError::downcast_ref`] gives
        /// back the proposal's own error type).
        source: ProposalError,
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
    /// A count that would make the call allocate more than its documented
    /// limit.
    #[error("{what} = {requested} needs more memory than the limit of {limit} (see its docs)")]
    TooLarge {
        /// Which count, e.g. "ffbs trajectories x steps".
        what: &'static str,
        /// The count asked for (saturated at `usize::MAX`).
        requested: usize,
        /// The largest count allowed.
        limit: usize,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = ParticleError> = std::result::Result<T, E>;

/// The error of a [`crate::Proposal`], whatever its type
/// ([`crate::Proposal::Error`]): shared, so that [`ParticleError`] stays
/// `Clone`, and recoverable with [`ProposalError::downcast_ref`].
#[derive(Clone)]
pub struct ProposalError(Arc<dyn std::error::Error + Send + Sync + 'static>);

impl ProposalError {
    /// Wraps a proposal's error.
    pub fn new<E: std::error::Error + Send + Sync + 'static>(error: E) -> Self {
        Self(Arc::new(error))
    }

    /// The proposal's error as its own type (`None` for another type).
    pub fn downcast_ref<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.0.downcast_ref::<E>()
    }
}

impl std::fmt::Debug for ProposalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(&*self.0, f)
    }
}

impl std::fmt::Display for ProposalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&*self.0, f)
    }
}

impl std::error::Error for ProposalError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// Two proposal errors are equal when they are the same error or say the
/// same thing (the wrapped types need not be comparable).
impl PartialEq for ProposalError {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.to_string() == other.to_string()
    }
}
