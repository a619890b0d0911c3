//! The sequential importance sampling / resampling step (paper 000 eq. 7-10,
//! sec. 2.3), with an optional Metropolis-Hastings move after resampling
//! (van der Merwe et al. 2000, UPF-MCMC).
//!
//! Particles are propagated in fixed chunks of [`ParticleFilter::chunk_size`],
//! each chunk with its own random stream seeded from `(key, chunk)`, in
//! parallel with rayon; the weights, their sums and the resampling run over
//! the same chunks, with per-chunk results combined in chunk order. The same
//! key therefore gives the same bits on any number of threads.

use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::error::{ParticleError, Result};
use crate::proposal::Proposal;
use crate::resample::{ChunkedCumulative, Resampling};
use crate::seed::{extend_seed, stream_rng, stream_seed};
use crate::set::{ParticleSet, Scratch, check_threshold, exp_flushed};

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

/// One chunk's proposal pass.
struct Proposed {
    /// The largest updated log-weight.
    max: f64,
    /// The first NaN or `+inf` log increment, with its particle.
    bad: Option<(usize, f64)>,
}

impl Proposed {
    /// The chunk of log-weights `lw` (finite or minus infinity) updated by
    /// the increments `inc`, its first particle being `offset`.
    fn of(lw: &[f64], inc: &[f64], offset: usize) -> Self {
        let mut max = f64::NEG_INFINITY;
        let mut ok = true;
        for (&l, &x) in lw.iter().zip(inc) {
            ok &= x < f64::INFINITY;
            let y = l + x;
            max = if y > max { y } else { max };
        }
        let bad = if ok {
            None
        } else {
            inc.iter()
                .position(|x| x.is_nan() || *x == f64::INFINITY)
                .map(|i| (offset + i, inc[i]))
        };
        Self { max, bad }
    }
}

/// One chunk's weight pass.
struct Weighed {
    /// Sum of the weights.
    sum: f64,
    /// Sum of their squares.
    sum2: f64,
    /// The last particle with a positive weight.
    last: Option<usize>,
}

impl Weighed {
    /// Weights `exp(l + x - max)` of the log-weights `lw` updated by the
    /// increments `inc` (none: the log-weights alone), into `out`, or with
    /// `cumulative` their running sums; the chunk's first particle is
    /// `offset`.
    fn of(
        lw: &[f64],
        inc: Option<&[f64]>,
        max: f64,
        out: &mut [f64],
        cumulative: bool,
        offset: usize,
    ) -> Self {
        let (mut sum, mut sum2) = (0.0, 0.0);
        let mut last = 0;
        let mut add = |i: usize, d: f64, o: &mut f64| {
            // exp_flushed(d) == 0 leaves the sums as they are (adding +0 to
            // a non-negative sum is exact): a branch, not a blend, keeps the
            // flushed particles of a sharp likelihood off the sums'
            // dependency chain
            if d < -708.0 {
                *o = if cumulative { sum } else { 0.0 };
                return;
            }
            let w = exp_flushed(d);
            sum += w;
            sum2 += w * w;
            last = i + 1;
            *o = if cumulative { sum } else { w };
        };
        match inc {
            Some(inc) => {
                for (i, ((&l, &x), o)) in lw.iter().zip(inc).zip(out.iter_mut()).enumerate() {
                    add(i, l + x - max, o);
                }
            }
            None => {
                for (i, (&l, o)) in lw.iter().zip(out.iter_mut()).enumerate() {
                    add(i, l - max, o);
                }
            }
        }
        Self {
            sum,
            sum2,
            last: last.checked_sub(1).map(|i| offset + i),
        }
    }
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
    /// Every pass over the particles (proposal, weights, resampling and
    /// gathering) runs chunk by chunk in parallel; the chunk results are
    /// combined in chunk order, so the same key gives the same bits on any
    /// number of threads. The buffers of the step live in the set.
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
        let mut parents = std::mem::take(&mut set.scratch.parents);
        if self.mcmc {
            parents.clone_from(&set.particles);
        }
        let outcome = self.step_from(set, proposal, z, key, &parents);
        set.scratch.parents = parents;
        outcome
    }

    /// [`ParticleFilter::step`] with the particles before the proposal in
    /// `parents` (for the MCMC move; empty without it).
    fn step_from<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
        parents: &[T],
    ) -> Result<StepReport>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        let n = set.len();
        let cs = self.chunk_size;
        let ParticleSet {
            particles,
            log_weights: log_w,
            scratch,
        } = set;
        let Scratch {
            increments,
            weights,
            ancestors,
            spare,
            ..
        } = scratch;
        increments.resize(n, 0.0);
        weights.resize(n, 0.0);

        // propose; per chunk the largest updated log-weight and the first
        // NaN or +inf increment
        let seed = stream_seed(key);
        let proposed: Vec<Result<Proposed>> = particles
            .par_chunks_mut(cs)
            .zip(increments.par_chunks_mut(cs))
            .zip(log_w.par_chunks(cs))
            .enumerate()
            .map(|(c, ((ps, inc), lw))| {
                let mut rng = Xoshiro256PlusPlus::seed_from_u64(extend_seed(seed, c as u64));
                let offset = c * cs;
                for (i, (p, w)) in ps.iter_mut().zip(inc.iter_mut()).enumerate() {
                    let (child, x) = proposal.propose(p, z, &mut rng).map_err(|source| {
                        ParticleError::Proposal {
                            index: offset + i,
                            source,
                        }
                    })?;
                    if !child.state().iter().all(|v| v.is_finite()) {
                        return Err(ParticleError::NonFiniteState { index: offset + i });
                    }
                    *p = child;
                    *w = x;
                }
                Ok(Proposed::of(lw, inc, offset))
            })
            .collect();
        let mut max = f64::NEG_INFINITY;
        let mut bad = None;
        for chunk in proposed {
            let chunk = chunk?;
            max = max.max(chunk.max);
            bad = bad.or(chunk.bad);
        }
        if let Some((index, value)) = bad {
            return Err(ParticleError::NonFiniteWeight { index, value });
        }
        // weights: w_k = w_{k-1} * increment (log domain); all zero ignores
        // the measurement (the previous weights) or fails
        let degenerate = max == f64::NEG_INFINITY;
        if degenerate {
            if self.degenerate == Degenerate::Error {
                return Err(ParticleError::AllWeightsZero { count: n });
            }
            max = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        }
        let log_w_k = |l: f64, x: f64| if degenerate { l } else { l + x };
        // linear weights relative to the largest, with chunk sums (added in
        // chunk order), the last positive weight of each chunk, and for
        // systematic resampling the running sums within each chunk instead
        // of the weights
        let cumulative = self.resampling == Resampling::Systematic;
        let partial: Vec<Weighed> = log_w
            .par_chunks(cs)
            .zip(increments.par_chunks(cs))
            .zip(weights.par_chunks_mut(cs))
            .enumerate()
            .map(|(c, ((lw, inc), out))| {
                let inc = if degenerate { None } else { Some(inc) };
                Weighed::of(lw, inc, max, out, cumulative, c * cs)
            })
            .collect();
        let mut prefix = Vec::with_capacity(partial.len() + 1);
        prefix.push(0.0);
        let (mut sum, mut sum2, mut last) = (0.0, 0.0, 0);
        for chunk in &partial {
            sum += chunk.sum;
            sum2 += chunk.sum2;
            prefix.push(sum);
            last = chunk.last.unwrap_or(last);
        }
        let lse = max + sum.ln();
        let log_evidence = if degenerate { f64::NEG_INFINITY } else { lse };
        let ess = sum * sum / sum2;
        let resample = match self.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::Ess(t) => ess < t * n as f64,
            ResamplePolicy::Never => false,
        };
        if !resample {
            log_w
                .par_chunks_mut(cs)
                .zip(increments.par_chunks(cs))
                .for_each(|(lw, inc)| {
                    for (l, &x) in lw.iter_mut().zip(inc) {
                        *l = log_w_k(*l, x) - lse;
                    }
                });
            return Ok(StepReport {
                log_evidence,
                ess,
                resampled: false,
                accepted: 0,
                degenerate,
            });
        }
        let mut rng = stream_rng(&[key, &[RESAMPLE_STREAM]].concat());
        ancestors.resize(n, 0);
        if spare.len() != n {
            spare.clone_from(particles);
        }
        let systematic = cumulative.then(|| {
            let step = sum / n as f64;
            let u: f64 = rng.random::<f64>() * step;
            (u, step)
        });
        if !cumulative {
            self.resampling
                .resample_checked(weights, sum, &mut rng, ancestors);
        }
        let cum = ChunkedCumulative {
            cum: weights,
            prefix: &prefix,
            chunk: cs,
            last,
        };
        let from: &[T] = particles;
        let uniform = -(n as f64).ln();
        spare
            .par_chunks_mut(cs)
            .zip(ancestors.par_chunks_mut(cs))
            .zip(log_w.par_chunks_mut(cs))
            .enumerate()
            .for_each(|(o, ((out, anc), lw))| {
                if let Some((u, step)) = systematic {
                    cum.systematic(u, step, o * cs, anc);
                }
                for (p, &a) in out.iter_mut().zip(anc.iter()) {
                    p.clone_from(&from[a]);
                }
                lw.fill(uniform);
            });
        std::mem::swap(particles, spare);
        let accepted = if self.mcmc {
            self.mcmc_move(set, proposal, z, key, parents)?
        } else {
            0
        };
        Ok(StepReport {
            log_evidence,
            ess,
            resampled: true,
            accepted,
            degenerate,
        })
    }

    /// Independent Metropolis-Hastings move of each resampled particle: a
    /// fresh draw from the proposal of its parent is accepted with
    /// probability `min(1, exp(w' - w))`, `w` the log incremental weights
    /// (the target `p(z|x) p(x|x_prev)` over the proposal `q`).
    fn mcmc_move<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
        parents: &[T],
    ) -> Result<usize>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        let mut accepted = vec![0.0; set.len()];
        let ParticleSet {
            particles, scratch, ..
        } = set;
        let (ancestors, increments) = (&scratch.ancestors, &scratch.increments);
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
