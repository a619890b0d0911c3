#![doc = include_str!("../README.md")]

mod apf;
mod chunks;
mod error;
mod filter;
mod pmmh;
mod proposal;
mod rbpf;
mod resample;
mod seed;
mod select;
mod set;
mod smc;
mod smooth;

pub use apf::{Auxiliary, AuxiliaryFilter};
pub use error::{ParticleError, ProposalError, Result};
pub use filter::{Degenerate, ParticleFilter, ResamplePolicy, ResampleTiming, StepReport};
pub use pmmh::{Chain, Pmmh};
pub use proposal::{
    Bootstrap, KalmanProposal, LocalFilter, Model, Proposal, ScalarModel, ScalarTransitionDensity,
    TransitionDensity,
};
pub use rbpf::{ConditionallyLinear, RaoBlackwellised, RbParticle};
pub use resample::{Resampler, Resampling};
pub use seed::{stream_rng, stream_seed};
pub use set::{Finite, KalmanParticle, Particle, ParticleSet, log_sum_exp};
pub use smc::Smc;
pub use smooth::{FFBS_MAX_BYTES, FixedLag, ffbs, path_means};

/// Re-exported so one dependency is enough: the filters, Gaussians and
/// errors of the Kalman proposals (`KalmanError` is in [`Proposal`]).
pub use bayestrack_kalman as kalman;
/// Re-exported: states are `nalgebra::SVector`s.
pub use nalgebra;
/// Re-exported: models and proposals draw from a `rand::Rng`.
pub use rand;
/// Re-exported: the distributions a model samples its noise from.
pub use rand_distr;
/// Re-exported: [`stream_rng`]'s generator.
pub use rand_xoshiro;
