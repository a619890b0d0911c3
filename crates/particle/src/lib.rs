#![doc = include_str!("../README.md")]

mod error;
mod filter;
mod proposal;
mod resample;
mod seed;
mod set;

pub use error::{ParticleError, Result};
pub use filter::{Degenerate, ParticleFilter, ResamplePolicy, StepReport};
pub use proposal::{Bootstrap, KalmanProposal, LocalFilter, Proposal, StateSpaceModel};
pub use resample::{Resampler, Resampling};
pub use seed::{stream_rng, stream_seed};
pub use set::{Finite, KalmanParticle, Particle, ParticleSet, log_sum_exp};
