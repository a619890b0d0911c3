//! A particle filter that runs: configuration, particle set and seed, with
//! the step keys numbered by the filter.

use crate::error::{ParticleError, Result};
use crate::filter::{ParticleFilter, StepReport};
use crate::proposal::Proposal;
use crate::set::{Particle, ParticleSet};

/// A running particle filter (sequential Monte Carlo): a
/// [`ParticleFilter`] configuration, the [`ParticleSet`] it moves and a
/// seed.
///
/// Step `k` (the set's time index after it, [`ParticleSet::k`]) draws its
/// random streams from the key `[seed, k]`: no two steps share noise, the
/// same seed gives the same numbers on any number of threads, and
/// different seeds give independent runs (mix a run number into the seed
/// with [`crate::stream_seed`]). [`ParticleFilter::step`] is the same step
/// with a key of the caller's.
#[derive(Debug, Clone)]
pub struct Smc<T> {
    /// The configuration.
    pub filter: ParticleFilter,
    /// The particles and their weights.
    pub set: ParticleSet<T>,
    seed: u64,
    log_evidence: f64,
}

impl<T> Smc<T> {
    /// A filter that starts from `set`.
    ///
    /// # Errors
    /// As [`ParticleFilter::validate`].
    pub fn new(filter: ParticleFilter, set: ParticleSet<T>, seed: u64) -> Result<Self> {
        filter.validate()?;
        Ok(Self {
            filter,
            set,
            seed,
            log_evidence: 0.0,
        })
    }

    /// The seed of the run.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// `log p(z_{1:k})`: the sum of the steps' [`StepReport::log_evidence`]
    /// since [`Smc::new`] (0 before the first step; minus infinity after a
    /// degenerate step). Its exponential is an unbiased estimate of the
    /// likelihood, the quantity particle marginal Metropolis-Hastings
    /// ([`crate::Pmmh`]) needs.
    pub fn log_evidence(&self) -> f64 {
        self.log_evidence
    }

    /// The time index of the particles: steps taken ([`ParticleSet::k`]).
    pub fn k(&self) -> usize {
        self.set.k()
    }

    /// One step with measurement `z`: [`ParticleFilter::step`] with the key
    /// `[seed, k]`, `k` the time index the proposal draws.
    ///
    /// # Errors
    /// As [`ParticleFilter::step`]; [`ParticleError::InvalidParameter`]
    /// when the running log evidence would pass `f64::MAX` (the set has
    /// stepped, [`Smc::log_evidence`] keeps the total before the step).
    pub fn step<Z, P, const N: usize>(&mut self, proposal: &P, z: &Z) -> Result<StepReport<N>>
    where
        T: Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        self.step_with(proposal, z, &mut Vec::new())
    }

    /// [`Smc::step`] with the proposal's per-chunk working memory kept by
    /// the caller ([`ParticleFilter::step_with`]).
    ///
    /// # Errors
    /// As [`ParticleFilter::step`]; [`ParticleError::InvalidParameter`]
    /// when the running log evidence would pass `f64::MAX` (the set has
    /// stepped, [`Smc::log_evidence`] keeps the total before the step).
    pub fn step_with<Z, P, const N: usize>(
        &mut self,
        proposal: &P,
        z: &Z,
        scratch: &mut Vec<P::Scratch>,
    ) -> Result<StepReport<N>>
    where
        T: Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        let key = [self.seed, self.set.k() as u64 + 1];
        let report = self
            .filter
            .step_with(&mut self.set, proposal, z, &key, scratch)?;
        // increments are finite or minus infinity, but their sum can
        // overflow: past -f64::MAX it saturates at minus infinity (the
        // evidence is zero to f64 precision); past f64::MAX it is an error
        let total = self.log_evidence + report.log_evidence;
        if total == f64::INFINITY {
            return Err(ParticleError::InvalidParameter {
                name: "log evidence",
                value: total,
                reason: "the sum of the steps' log evidence overflowed f64 \
                         (the set has stepped; the total is that before the step)",
            });
        }
        self.log_evidence = total;
        Ok(report)
    }
}
