//! The sequential importance sampling / resampling step (Nagy, Ahmed and Zayed (paper 000) eq. 7-10,
//! sec. 2.3), with an optional Metropolis-Hastings move after resampling
//! (van der Merwe et al. 2000, UPF-MCMC).
//!
//! Particles are propagated in fixed chunks of [`ParticleFilter::chunk_size`],
//! each chunk with its own random stream seeded from `(key, chunk)`, in
//! parallel with rayon; the weights, their sums and the resampling run over
//! the same chunks, with per-chunk results combined in chunk order. The same
//! key therefore gives the same bits on any number of threads.

use nalgebra::SVector;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::error::{ParticleError, ProposalError, Result};
use crate::proposal::Proposal;
use crate::resample::{ChunkedCumulative, Resampling};
use crate::seed::{extend_seed, stream_rng, stream_seed};
use crate::set::{Particle, ParticleSet, Scratch, check_threshold, exp_flushed};

/// When to resample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ResamplePolicy {
    /// After every step (Nagy, Ahmed and Zayed (paper 000), the original UPF demo).
    Always,
    /// When the ESS falls below this fraction of `N` (adaptive).
    Ess(f64),
    /// Never (sequential importance sampling).
    Never,
}

/// Where in the step the set is resampled (when [`ResamplePolicy`] says
/// so).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ResampleTiming {
    /// After the weights (sequential importance resampling as in Nagy,
    /// Ahmed and Zayed (paper 000), the UPF demo): a step leaves the
    /// resampled, equally weighted set.
    #[default]
    AfterWeighing,
    /// At the start of the next step, from the weights the previous step
    /// left, before the proposal: the "select, predict, measure" of
    /// CONDENSATION (Isard and Blake 1998; paper 003, Lee, Jo and Kang,
    /// sec. 2.1) and of the trackers' SIR filters (paper 001, Bócsi and
    /// Csató, Algorithm 1, line 6). The same filter, but a step leaves the
    /// weighted set, so [`crate::ParticleSet::mean`] is the weighted
    /// estimate of the frame. [`ResamplePolicy::Ess`] looks at the ESS of
    /// those weights. The first step of a set (time index `k` = 0) has no
    /// previous weights to select by and does not resample. Not combined
    /// with the MCMC move.
    BeforeProposal,
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
///
/// [`ParticleFilter::default()`] is the sequential importance resampling
/// filter of Nagy, Ahmed and Zayed (paper 000) sec. 2.3:
///
/// | field | default | meaning |
/// |---|---|---|
/// | `resampling` | [`Resampling::Systematic`] | one uniform draw, `N` evenly spaced points (lowest variance of the O(N) schemes here) |
/// | `policy` | [`ResamplePolicy::Always`] | resample after every step (not adaptively on the ESS) |
/// | `timing` | [`ResampleTiming::AfterWeighing`] | a step leaves the resampled, equally weighted set |
/// | `mcmc` | `false` | no Metropolis-Hastings move after resampling |
/// | `chunk_size` | 1024 | particles per random stream and per parallel task: a set of at most 1024 particles runs on the calling thread |
/// | `degenerate` | [`Degenerate::Error`] | a step where every weight is zero is an error |
///
/// With the default, [`StepReport::mean`] is the filter's estimate of the
/// step (the weighted mean before resampling); [`ParticleSet::mean`] of the
/// set afterwards is the mean of the resampled particles, the same
/// quantity with the resampling noise added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleFilter {
    /// Resampling scheme.
    pub resampling: Resampling,
    /// When to resample.
    pub policy: ResamplePolicy,
    /// Where in the step: after the weights, or before the next proposal.
    pub timing: ResampleTiming,
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
            timing: ResampleTiming::AfterWeighing,
            mcmc: false,
            chunk_size: 1024,
            degenerate: Degenerate::Error,
        }
    }
}

/// What one step did, for particles with `N`-dimensional states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport<const N: usize> {
    /// The weighted mean `sum_i w_{k,i} x_{k,i}` of the proposed particles
    /// with their new weights, before any resampling: the filter's
    /// estimate of `E[x_k | z_{1:k}]`. After a step that resampled
    /// ([`ResampleTiming::AfterWeighing`]), [`ParticleSet::mean`] is the mean
    /// of the resampled particles instead, the same quantity with the
    /// resampling noise added; after a step that did not resample (or with
    /// [`ResampleTiming::BeforeProposal`], which leaves the weighted set) the
    /// two agree to round-off. For a degenerate step
    /// ([`Degenerate::IgnoreMeasurement`]) it is the mean under the previous
    /// weights.
    pub mean: SVector<f64, N>,
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
    /// The largest log incremental weight of the step (for a bootstrap
    /// proposal, the best particle's log-likelihood: how well the best
    /// hypothesis explains the observation, which a tracker reads to say
    /// whether the target is lost); minus infinity when every weight was
    /// zero.
    pub max_log_increment: f64,
}

/// One chunk's proposal pass, accumulated as the particles are proposed.
struct Proposed {
    /// The largest updated log-weight.
    max: f64,
    /// The largest increment.
    max_increment: f64,
    /// Whether every increment so far was below `+inf` (and not NaN).
    ok: bool,
}

impl Proposed {
    const EMPTY: Self = Self {
        max: f64::NEG_INFINITY,
        max_increment: f64::NEG_INFINITY,
        ok: true,
    };

    /// Takes in the log-weight `l` and its increment `x`.
    #[inline(always)]
    fn add(&mut self, l: f64, x: f64) {
        self.ok &= x < f64::INFINITY;
        let y = l + x;
        self.max = if y > self.max { y } else { self.max };
        self.max_increment = if x > self.max_increment {
            x
        } else {
            self.max_increment
        };
    }

    /// The first NaN or `+inf` increment of the chunk `inc` with first
    /// particle `offset`.
    fn bad(&self, inc: &[f64], offset: usize) -> Option<(usize, f64)> {
        if self.ok {
            return None;
        }
        inc.iter()
            .position(|x| x.is_nan() || *x == f64::INFINITY)
            .map(|i| (offset + i, inc[i]))
    }
}

/// One chunk's weights: their sum and the sum of their squares.
#[derive(Clone, Copy)]
struct Weighed {
    sum: f64,
    sum2: f64,
}

impl Weighed {
    const ZERO: Self = Self {
        sum: 0.0,
        sum2: 0.0,
    };

    /// Weights `exp(l + x - max)` of the log-weights `lw` updated by the
    /// increments `inc` (none: the log-weights alone), into `out`, or with
    /// `cumulative` their running sums. A `max` of minus infinity (no
    /// positive weight) gives zeros.
    fn of(lw: &[f64], inc: Option<&[f64]>, max: f64, out: &mut [f64], cumulative: bool) -> Self {
        if max == f64::NEG_INFINITY {
            out.fill(0.0);
            return Self::ZERO;
        }
        let (mut sum, mut sum2) = (0.0, 0.0);
        let mut add = |d: f64, o: &mut f64| {
            // exp_flushed(d) == 0 leaves the sums as they are (adding +0 to
            // a non-negative sum is exact): a branch, not a blend, keeps the
            // flushed particles of a sharp likelihood off the sums'
            // dependency chain
            if d < -708.0 {
                *o = if cumulative { sum } else { 0.0 };
                return;
            }
            let w = d.exp();
            sum += w;
            sum2 += w * w;
            *o = if cumulative { sum } else { w };
        };
        match inc {
            Some(inc) => {
                for ((&l, &x), o) in lw.iter().zip(inc).zip(out.iter_mut()) {
                    add(l + x - max, o);
                }
            }
            None => {
                for (&l, o) in lw.iter().zip(out.iter_mut()) {
                    add(l - max, o);
                }
            }
        }
        Self { sum, sum2 }
    }
}

/// `sum_i w_i x_i` over a chunk whose weights `out` are relative to the
/// chunk's largest (their running sums when `cumulative`).
fn weighted_states<T: Particle<N>, const N: usize>(
    ps: &[T],
    out: &[f64],
    cumulative: bool,
) -> SVector<f64, N> {
    let mut m = SVector::<f64, N>::zeros();
    let mut prev = 0.0;
    for (p, &o) in ps.iter().zip(out) {
        let w = if cumulative {
            let w = o - prev;
            prev = o;
            w
        } else {
            o
        };
        if w != 0.0 {
            m.axpy(w, p.state(), 1.0);
        }
    }
    m
}

/// One chunk's proposal and weights.
struct ChunkPass<const N: usize> {
    /// `sum_i w_i x_i` with the chunk's weights.
    weighted: SVector<f64, N>,
    /// The largest updated log-weight, to which the weights are relative.
    max: f64,
    /// The largest log increment.
    max_increment: f64,
    /// The first NaN or `+inf` log increment, with its particle.
    bad: Option<(usize, f64)>,
    weighed: Weighed,
}

/// Stream ids beyond any chunk index.
const RESAMPLE_STREAM: u64 = u64::MAX;
const MCMC_STREAM: u64 = u64::MAX - 1;

impl ParticleFilter {
    /// Whether [`ResamplePolicy`] resamples a set of `n` with this ESS.
    fn wants_resampling(&self, ess: f64, n: usize) -> bool {
        match self.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::Ess(t) => ess < t * n as f64,
            ResamplePolicy::Never => false,
        }
    }

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
        if self.mcmc && self.timing == ResampleTiming::BeforeProposal {
            return Err(ParticleError::InvalidParameter {
                name: "mcmc",
                value: 1.0,
                reason: "the MCMC move follows a resampling after the weights; \
                         ResampleTiming::BeforeProposal resamples before the proposal",
            });
        }
        Ok(())
    }

    /// Runs `f(particle offset, particles, log-weight slots, scratch,
    /// generator)` over fixed chunks, in parallel when there is more than
    /// one; returns the first error in particle order.
    #[allow(clippy::type_complexity)]
    fn chunked<T: Send, S: Send, F>(
        &self,
        parts: &mut [T],
        extra: &mut [f64],
        scratch: &mut [S],
        key: &[u64],
        f: F,
    ) -> Result<()>
    where
        F: Fn(
                usize,
                &mut [T],
                &mut [f64],
                &mut S,
                &mut rand_xoshiro::Xoshiro256PlusPlus,
            ) -> Result<()>
            + Sync,
    {
        let cs = self.chunk_size;
        let run = |(c, ((p, e), s)): (usize, ((&mut [T], &mut [f64]), &mut S))| {
            let mut k = key.to_vec();
            k.push(c as u64);
            let mut rng = stream_rng(&k);
            f(c * cs, p, e, s, &mut rng)
        };
        let results: Vec<Result<()>> = if parts.len() <= cs {
            vec![run((0, ((parts, extra), &mut scratch[0])))]
        } else {
            parts
                .par_chunks_mut(cs)
                .zip(extra.par_chunks_mut(cs))
                .zip(scratch.par_iter_mut())
                .enumerate()
                .map(run)
                .collect()
        };
        results.into_iter().collect()
    }

    /// One step: propose every particle, weight, normalise, resample per
    /// the policy, and move (MCMC) if enabled. `key` identifies the step's
    /// random streams (for example `[experiment, run, k]`): every step needs
    /// its own, and the previous step's key is refused
    /// ([`ParticleError::KeyReused`]) rather than silently drawing the same
    /// noise again. [`crate::Smc`] numbers the keys itself.
    ///
    /// The proposal sees the time index `k = set.k() + 1` of the particles
    /// it draws; the set's index advances when the step succeeds.
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
    /// [`ParticleError::KeyReused`], and configuration errors of
    /// [`ParticleFilter::validate`].
    pub fn step<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
    ) -> Result<StepReport<N>>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        self.step_with(set, proposal, z, key, &mut Vec::new())
    }

    /// [`ParticleFilter::step`] with the proposal's per-chunk working
    /// memory ([`Proposal::Scratch`]) kept by the caller between steps:
    /// `scratch` grows to one entry per chunk on the first step and is
    /// reused afterwards, so a proposal that fills buffers (an image patch,
    /// a histogram) allocates nothing once warm.
    ///
    /// # Errors
    /// As [`ParticleFilter::step`].
    pub fn step_with<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        key: &[u64],
        scratch: &mut Vec<P::Scratch>,
    ) -> Result<StepReport<N>>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        self.validate()?;
        let chunks = set.len().div_ceil(self.chunk_size).max(1);
        if scratch.len() < chunks {
            scratch.resize_with(chunks, Default::default);
        }
        let seed = stream_seed(key);
        let k = set.k + 1;
        if set.last_seed == Some(seed) {
            return Err(ParticleError::KeyReused { k });
        }
        let mut parents = std::mem::take(&mut set.scratch.parents);
        if self.mcmc {
            parents.clone_from(&set.particles);
        }
        let outcome = self.step_from(set, proposal, z, k, key, &parents, scratch);
        set.scratch.parents = parents;
        if outcome.is_ok() {
            set.k = k;
            set.last_seed = Some(seed);
        }
        outcome
    }

    /// [`ParticleFilter::step`] at time `k` with the particles before the
    /// proposal in `parents` (for the MCMC move; empty without it).
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn step_from<T, Z, P, const N: usize>(
        &self,
        set: &mut ParticleSet<T>,
        proposal: &P,
        z: &Z,
        k: usize,
        key: &[u64],
        parents: &[T],
        scratch_chunks: &mut [P::Scratch],
    ) -> Result<StepReport<N>>
    where
        T: crate::set::Particle<N>,
        Z: ?Sized + Sync,
        P: Proposal<T, Z>,
    {
        let n = set.len();
        let cs = self.chunk_size;
        let before = self.timing == ResampleTiming::BeforeProposal;
        let selected = before && set.k > 0 && self.wants_resampling(set.ess(), n);
        if selected {
            let mut rng = stream_rng(&[key, &[RESAMPLE_STREAM]].concat());
            let mut ancestors = std::mem::take(&mut set.scratch.ancestors);
            let drawn = set.resample(&self.resampling, &mut rng, &mut ancestors);
            set.scratch.ancestors = ancestors;
            drawn?;
        }
        let ParticleSet {
            particles,
            log_weights: log_w,
            scratch,
            ..
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

        // propose and weigh each chunk while it is in cache: the weights
        // (or, for systematic resampling, their running sums) relative to
        // the chunk's largest updated log-weight, which puts them on the
        // common scale with one factor per chunk below
        let cumulative = self.resampling == Resampling::Systematic;
        let seed = stream_seed(key);
        let pass = |(c, ((((ps, inc), lw), out), scratch)): (
            usize,
            (
                (((&mut [T], &mut [f64]), &[f64]), &mut [f64]),
                &mut P::Scratch,
            ),
        )| {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(extend_seed(seed, c as u64));
            let offset = c * cs;
            let mut acc = Proposed::EMPTY;
            for (i, ((p, w), &l)) in ps.iter_mut().zip(inc.iter_mut()).zip(lw).enumerate() {
                let (child, x) =
                    proposal
                        .propose(k, p, z, scratch, &mut rng)
                        .map_err(|source| ParticleError::Proposal {
                            index: offset + i,
                            source: ProposalError::new(source),
                        })?;
                if !child.state().iter().all(|v| v.is_finite()) {
                    return Err(ParticleError::NonFiniteState { index: offset + i });
                }
                *p = child;
                *w = x;
                acc.add(l, x);
            }
            let bad = acc.bad(inc, offset);
            let (weighed, weighted) = match bad {
                None => (
                    Weighed::of(lw, Some(inc), acc.max, out, cumulative),
                    weighted_states(ps, out, cumulative),
                ),
                Some(_) => (Weighed::ZERO, SVector::zeros()),
            };
            Ok(ChunkPass {
                weighted,
                max: acc.max,
                max_increment: acc.max_increment,
                bad,
                weighed,
            })
        };
        // one chunk runs on the calling thread: handing it to the pool
        // costs a cross-thread wake-up per step, which a tracker with a
        // few hundred particles at 1,000 frames a second would feel
        let passes: Vec<Result<ChunkPass<N>>> = if n <= cs {
            vec![pass((
                0,
                (
                    (
                        ((&mut particles[..], &mut increments[..]), &log_w[..]),
                        &mut weights[..],
                    ),
                    &mut scratch_chunks[0],
                ),
            ))]
        } else {
            particles
                .par_chunks_mut(cs)
                .zip(increments.par_chunks_mut(cs))
                .zip(log_w.par_chunks(cs))
                .zip(weights.par_chunks_mut(cs))
                .zip(scratch_chunks.par_iter_mut())
                .enumerate()
                .map(pass)
                .collect()
        };
        let mut chunks = passes.into_iter().collect::<Result<Vec<ChunkPass<N>>>>()?;
        if let Some((index, value)) = chunks.iter().find_map(|c| c.bad) {
            return Err(ParticleError::NonFiniteWeight { index, value });
        }
        let mut max = chunks
            .iter()
            .map(|c| c.max)
            .fold(f64::NEG_INFINITY, f64::max);
        let max_log_increment = chunks
            .iter()
            .map(|c| c.max_increment)
            .fold(f64::NEG_INFINITY, f64::max);
        // weights: w_k = w_{k-1} * increment (log domain); all zero ignores
        // the measurement (the previous weights, weighed again) or fails
        let degenerate = max == f64::NEG_INFINITY;
        let scale: Vec<f64> = if degenerate {
            if self.degenerate == Degenerate::Error {
                return Err(ParticleError::AllWeightsZero { count: n });
            }
            max = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let again: Vec<Weighed> = if n <= cs {
                vec![Weighed::of(log_w, None, max, weights, cumulative)]
            } else {
                log_w
                    .par_chunks(cs)
                    .zip(weights.par_chunks_mut(cs))
                    .map(|(lw, out)| Weighed::of(lw, None, max, out, cumulative))
                    .collect()
            };
            for ((chunk, w), (ps, out)) in chunks
                .iter_mut()
                .zip(again)
                .zip(particles.chunks(cs).zip(weights.chunks(cs)))
            {
                chunk.weighed = w;
                chunk.weighted = weighted_states(ps, out, cumulative);
            }
            vec![1.0; chunks.len()]
        } else {
            chunks.iter().map(|c| exp_flushed(c.max - max)).collect()
        };
        let log_w_k = |l: f64, x: f64| if degenerate { l } else { l + x };
        // the chunk sums on the common scale, added in chunk order
        let mut prefix = Vec::with_capacity(chunks.len() + 1);
        prefix.push(0.0);
        let (mut sum, mut sum2) = (0.0, 0.0);
        let mut mean = SVector::<f64, N>::zeros();
        for (chunk, &f) in chunks.iter().zip(&scale) {
            sum += f * chunk.weighed.sum;
            sum2 += f * f * chunk.weighed.sum2;
            mean.axpy(f, &chunk.weighted, 1.0);
            prefix.push(sum);
        }
        mean /= sum;
        let ln_sum = sum.ln();
        let lse = max + ln_sum;
        let log_evidence = if degenerate { f64::NEG_INFINITY } else { lse };
        let ess = sum * sum / sum2;
        let resample = !before && self.wants_resampling(ess, n);
        if !resample {
            let normalise = |(lw, inc): (&mut [f64], &[f64])| {
                // shift by the largest first: at large magnitudes
                // `max + ln(sum)` rounds to `max`, and subtracting it
                // whole would leave the weights unnormalised
                for (l, &x) in lw.iter_mut().zip(inc) {
                    *l = (log_w_k(*l, x) - max) - ln_sum;
                }
            };
            if n <= cs {
                normalise((log_w, increments));
            } else {
                log_w
                    .par_chunks_mut(cs)
                    .zip(increments.par_chunks(cs))
                    .for_each(normalise);
            }
            return Ok(StepReport {
                mean,
                log_evidence,
                ess,
                resampled: selected,
                accepted: 0,
                degenerate,
                max_log_increment,
            });
        }
        let mut rng = stream_rng(&[key, &[RESAMPLE_STREAM]].concat());
        ancestors.resize(n, 0);
        if spare.len() != n {
            spare.clone_from(particles);
        }
        // systematic: the points u + j step, each output chunk finding its
        // ancestors in the running sums; the other schemes draw them here
        // from the weights on the common scale
        let systematic = if cumulative {
            let step = sum / n as f64;
            let u: f64 = rng.random::<f64>() * step;
            Some((
                ChunkedCumulative::new(weights, &scale, &prefix, cs),
                u,
                step,
            ))
        } else {
            for (ws, &f) in weights.chunks_mut(cs).zip(&scale) {
                if f != 1.0 {
                    ws.iter_mut().for_each(|w| *w *= f);
                }
            }
            self.resampling
                .resample_checked(weights, sum, &mut rng, ancestors);
            None
        };
        let from: &[T] = particles;
        let uniform = -(n as f64).ln();
        let gather = |(o, ((out, anc), lw)): (usize, ((&mut [T], &mut [usize]), &mut [f64]))| {
            if let Some((cum, u, step)) = &systematic {
                cum.systematic(*u, *step, o * cs, anc);
            }
            for (p, &a) in out.iter_mut().zip(anc.iter()) {
                p.clone_from(&from[a]);
            }
            lw.fill(uniform);
        };
        if n <= cs {
            gather((0, ((spare, ancestors), log_w)));
        } else {
            spare
                .par_chunks_mut(cs)
                .zip(ancestors.par_chunks_mut(cs))
                .zip(log_w.par_chunks_mut(cs))
                .enumerate()
                .for_each(gather);
        }
        std::mem::swap(particles, spare);
        let accepted = if self.mcmc {
            self.mcmc_move(set, proposal, z, k, key, parents, scratch_chunks)?
        } else {
            0
        };
        Ok(StepReport {
            mean,
            log_evidence,
            ess,
            resampled: true,
            accepted,
            degenerate,
            max_log_increment,
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
        k: usize,
        key: &[u64],
        parents: &[T],
        chunk_scratch: &mut [P::Scratch],
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
            chunk_scratch,
            &mcmc_key,
            |offset, ps, acc, scratch, rng| {
                for (i, (p, a)) in ps.iter_mut().zip(acc.iter_mut()).enumerate() {
                    let j = offset + i;
                    let anc = ancestors[j];
                    let (cand, lw) = proposal
                        .propose(k, &parents[anc], z, scratch, rng)
                        .map_err(|source| ParticleError::Proposal {
                            index: j,
                            source: ProposalError::new(source),
                        })?;
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
