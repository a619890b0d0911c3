//! The sequential importance sampling / resampling step (paper 000 eq. 7-10,
//! sec. 2.3), with an optional Metropolis-Hastings move after resampling
//! (van der Merwe et al. 2000, UPF-MCMC).
//!
//! Particles are propagated in fixed chunks of [`ParticleFilter::chunk_size`],
//! each chunk with its own random stream seeded from `(key, chunk)`, in
//! parallel with rayon; every reduction runs sequentially in particle order.
//! The same key therefore gives the same bits on any number of threads.

use rand::RngExt;
use rayon::prelude::*;

use crate::error::{ParticleError, Result};
use crate::proposal::Proposal;
use crate::resample::Resampling;
use crate::seed::stream_rng;
use crate::set::{ParticleSet, check_threshold, exp_flushed};

/// When to resample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ResamplePolicy {
    /// After every step (paper 000, the original UPF demo).
    Always,
    /// When the ESS falls below this fraction of `N` (adaptive).
    Ess(f64),
    /// Never (sequential importance sampling).
    Never,
}

/// What to do when every particle gets weight zero.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Degenerate {
    /// Return [`ParticleError::AllWeightsZero`] (the default).
    #[default]
    Error,
    /// Keep the propagated particles with their previous weights: the step
    /// ignores the measurement. Counted in [`StepReport::degenerate`].
    IgnoreMeasurement,
}

/// The configuration of a particle filter; the particle set is the caller's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleFilter {
    /// Resampling scheme.
    pub resampling: Resampling,
    /// When to resample.
    pub policy: ResamplePolicy,
    /// Metropolis-Hastings move after each resampling.
    pub mcmc: bool,
    /// Particles per chunk (per random stream and per parallel task).
    pub chunk_size: usize,
    /// Handling of an all-zero weight step.
    pub degenerate: Degenerate,
}

impl Default for ParticleFilter {
    fn default() -> Self {
        Self {
            resampling: Resampling::Systematic,
            policy: ResamplePolicy::Always,
            mcmc: false,
            chunk_size: 1024,
            degenerate: Degenerate::Error,
        }
    }
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// `log sum_i w_{k-1,i} w~_{k,i}`: the log evidence increment
    /// `log p(z_k | z_{1:k-1})` estimate.
    pub log_evidence: f64,
    /// ESS before resampling.
    pub ess: f64,
    /// Whether the set was resampled.
    pub resampled: bool,
    /// Metropolis-Hastings moves accepted.
    pub accepted: usize,
    /// Whether every weight was zero (see [`Degenerate`]).
    pub degenerate: bool,
}

/// Stream ids beyond any chunk index.
const RESAMPLE_STREAM: u64 = u64::MAX;
const MCMC_STREAM: u64 = u64::MAX - 1;

impl ParticleFilter {
    /// Checks the configuration.
    ///
    /// # Errors
    /// [`ParticleError::InvalidParameter`] for a zero chunk size or an ESS
    /// threshold outside [0, 1].
    pub fn validate(&self) -> Result<()> {
        if self.chunk_size == 0 {
            return Err(ParticleError::InvalidParameter {
                name: "chunk_size",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        if let ResamplePolicy::Ess(t) = self.policy {
            check_threshold(t)?;
        }
        Ok(())
    }

    /// Runs `f(chunk index, particle offset, particles, log-weight slots,
    /// generator)` over fixed chunks, in parallel when there is more than
    /// one; returns the first error in particle order.
    fn chunked<T: Send, F>(
        &self,
        parts: &mut [T],
        extra: &mut [f64],
        key: &[u64],
        f: F,
    ) -> Result<()>
    where
        F: Fn(usize, &mut [T], &mut [f64], &mut rand_xoshiro::Xoshiro256PlusPlus) -> Result<()>
            + Sync,
    {
        let cs = self.chunk_size;
        let run = |(c, (p, e)): (usize, (&mut [T], &mut [f64]))| {
            let mut k = key.to_vec();
            k.push(c as u64);
            let mut rng = stream_rng(&k);
            f(c * cs, p, e, &mut rng)
        };
        let results: Vec<Result<()>> = if parts.len() <= cs {
            vec![run((0, (parts, extra)))]
        } else {
            parts
                .par_chunks_mut(cs)
                .zip(extra.par_chunks_mut(cs))
                .enumerate()
                .map(run)
                .collect()
        };
        results.into_iter().collect()
    }

    /// One step: propose every particle, weight, normalise, resample per
    /// the policy, and move (MCMC) if enabled. `key` identifies the step's
    /// random streams (for example `[experiment, run, k]`).
    ///
    /// On error the weights are those before the step; the particles may
    /// already have been moved by the proposal.
    ///
    /// # Errors
    /// [`ParticleError::Proposal`] naming the particle whose local filter
    /// failed, [`ParticleError::NonFiniteState`], [`ParticleError::NonFiniteWeight`],
    /// [`ParticleError::AllWeightsZero`] (unless [`Degenerate::IgnoreMeasurement`]),
    /// and configuration errors of [`ParticleFilter::validate`].
    pub fn step<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
    ) -> Result<StepReport>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        self.validate()?;
        let n = set.len();
        let parents: Option<Vec<T>> = self.mcmc.then(|| set.particles().to_vec());
        let previous_log_w = set.log_weights().to_vec();
        let mut increments = vec![0.0; n];
        {
            let (particles, _) = set.parts_mut();
            self.chunked(particles, &mut increments, key, |offset, ps, inc, rng| {
                for (i, (p, w)) in ps.iter_mut().zip(inc.iter_mut()).enumerate() {
                    let (child, lw) =
                        proposal
                            .propose(p, z, rng)
                            .map_err(|source| ParticleError::Proposal {
                                index: offset + i,
                                source,
                            })?;
                    if !child.state().iter().all(|v| v.is_finite()) {
                        return Err(ParticleError::NonFiniteState { index: offset + i });
                    }
                    *p = child;
                    *w = lw;
                }
                Ok(())
            })?;
        }
        // weights: w_k = w_{k-1} * increment (log domain), then normalise
        let (_, log_w) = set.parts_mut();
        let mut max = f64::NEG_INFINITY;
        for (index, (l, &inc)) in log_w.iter_mut().zip(&increments).enumerate() {
            if inc.is_nan() || inc == f64::INFINITY {
                log_w.copy_from_slice(&previous_log_w);
                return Err(ParticleError::NonFiniteWeight { index, value: inc });
            }
            *l += inc;
            max = max.max(*l);
        }
        if max == f64::NEG_INFINITY {
            log_w.copy_from_slice(&previous_log_w);
            if self.degenerate == Degenerate::Error {
                return Err(ParticleError::AllWeightsZero { count: n });
            }
        }
        let degenerate = max == f64::NEG_INFINITY;
        if degenerate {
            max = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        }
        // linear weights relative to the largest, with chunked partial sums
        // (added in chunk order: the same bits on any number of threads)
        let mut weights = vec![0.0; n];
        let partial: Vec<(f64, f64)> = log_w
            .par_chunks(self.chunk_size)
            .zip(weights.par_chunks_mut(self.chunk_size))
            .map(|(l, w)| {
                let (mut s, mut s2) = (0.0, 0.0);
                for (l, w) in l.iter().zip(w.iter_mut()) {
                    *w = exp_flushed(l - max);
                    s += *w;
                    s2 += *w * *w;
                }
                (s, s2)
            })
            .collect();
        let (sum, sum2) = partial
            .iter()
            .fold((0.0, 0.0), |(a, b), (s, s2)| (a + s, b + s2));
        let lse = max + sum.ln();
        for l in log_w.iter_mut() {
            *l -= lse;
        }
        let log_evidence = if degenerate { f64::NEG_INFINITY } else { lse };
        let ess = sum * sum / sum2;
        let resample = match self.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::Ess(t) => ess < t * n as f64,
            ResamplePolicy::Never => false,
        };
        let mut accepted = 0;
        if resample {
            let mut rng = stream_rng(&[key, &[RESAMPLE_STREAM]].concat());
            let mut ancestors = vec![0; n];
            self.resampling
                .resample_checked(&weights, sum, &mut rng, &mut ancestors);
            set.gather(&ancestors);
            if let Some(parents) = parents {
                accepted =
                    self.mcmc_move(set, proposal, z, key, &parents, &ancestors, &increments)?;
            }
        }
        Ok(StepReport {
            log_evidence,
            ess,
            resampled: resample,
            accepted,
            degenerate,
        })
    }

    /// Independent Metropolis-Hastings move of each resampled particle: a
    /// fresh draw from the proposal of its parent is accepted with
    /// probability `min(1, exp(w' - w))`, `w` the log incremental weights
    /// (the target `p(z|x) p(x|x_prev)` over the proposal `q`).
    #[allow(clippy::too_many_arguments)]
    fn mcmc_move<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
        parents: &[T],
        ancestors: &[usize],
        increments: &[f64],
    ) -> Result<usize>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        let mut accepted = vec![0.0; set.len()];
        let (particles, _) = set.parts_mut();
        let mcmc_key = [key, &[MCMC_STREAM]].concat();
        self.chunked(
            particles,
            &mut accepted,
            &mcmc_key,
            |offset, ps, acc, rng| {
                for (i, (p, a)) in ps.iter_mut().zip(acc.iter_mut()).enumerate() {
                    let j = offset + i;
                    let anc = ancestors[j];
                    let (cand, lw) = proposal
                        .propose(&parents[anc], z, rng)
                        .map_err(|source| ParticleError::Proposal { index: j, source })?;
                    let u: f64 = rng.random();
                    if cand.state().iter().all(|v| v.is_finite())
                        && !lw.is_nan()
                        && u.ln() < lw - increments[anc]
                    {
                        *p = cand;
                        *a = 1.0;
                    }
                }
                Ok(())
            },
        )?;
        Ok(accepted.iter().filter(|&&a| a > 0.0).count())
    }
}
