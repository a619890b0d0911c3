//! The auxiliary particle filter (Pitt and Shephard 1999, "Filtering via
//! simulation: auxiliary particle filters", JASA 94, sec. 3.2).
//!
//! Each step first resamples the parents by their weights times a
//! first-stage weight `g_i ~ p(z_k | x_{k-1,i})` (how well the parent's
//! predicted point explains the new observation), then draws every child
//! from the transition and weighs it by `p(z_k | x_k) / g_{a_j}`. Parents
//! that the observation rules out are dropped before they are propagated,
//! which pays where the observation is informative relative to the spread
//! of the predicted particles.

use nalgebra::SVector;

use crate::chunks::{check_chunk_size, for_chunks};
use crate::error::{ParticleError, Result};
use crate::filter::{ResamplePolicy, StepReport};
use crate::proposal::Model;
use crate::resample::{Resampler, Resampling};
use crate::seed::{stream_rng, stream_seed};
use crate::set::{ParticleSet, check_threshold, exp_flushed};

/// A [`Model`] that the auxiliary particle filter can look ahead with.
pub trait Auxiliary<const N: usize>: Model<N> {
    /// A point `mu_k(x_{k-1})` that sums up `p(x_k | x_{k-1})`: its mean
    /// or mode (Pitt and Shephard's `mu_k^i`).
    fn point(&self, k: usize, x_prev: &SVector<f64, N>) -> SVector<f64, N>;

    /// The log first-stage weight `log g(x_{k-1}, z_k)`: by default
    /// `log p(z_k | mu_k(x_{k-1}))` (Pitt and Shephard's choice); a model
    /// that knows the predictive `log p(z_k | x_{k-1})` returns it (the
    /// second-stage weights are then those of the "fully adapted" filter
    /// up to the proposal). Any function works (the weights stay
    /// unbiased) as long as it is finite wherever the likelihood is not
    /// zero: the child's weight divides by `g`.
    fn log_first_stage(&self, k: usize, x_prev: &SVector<f64, N>, z: &Self::Observation) -> f64 {
        self.log_likelihood(k, &self.point(k, x_prev), z)
    }
}

/// The auxiliary particle filter (Pitt and Shephard 1999, sec. 3.2): each
/// step resamples the parents by their weights times a first-stage weight
/// `g_i ~ p(z_k | x_{k-1,i})` ([`Auxiliary::log_first_stage`]), draws each
/// child from the transition and weighs it by `p(z_k | x_k) / g_{a_j}`.
/// Parents the observation rules out are dropped before they are
/// propagated, which pays where the observation is informative relative to
/// the spread of the predicted particles.
///
/// With Pitt and Shephard's default `g = p(z | mu(x_{k-1}))` and process
/// noise large against the measurement noise, `g` has lighter tails than
/// the predictive and the second-stage weights can be heavy (a child far
/// from its parent's point gets a huge weight): return the predictive,
/// or a flattened likelihood, from `log_first_stage` there.
///
/// Like the other filters it resamples per a [`ResamplePolicy`]
/// (Johansen and Doucet 2008, "A note on auxiliary particle filters",
/// Statistics & Probability Letters 78: the APF is a sequential importance
/// resampling filter on the auxiliary targets `w_{k-1,i} g_i`): with
/// [`ResamplePolicy::Ess`] the first stage resamples only when the ESS of
/// the first-stage weights `w_{k-1,i} g_i` falls below the threshold;
/// otherwise every particle keeps its own parent and carries the
/// first-stage weight `w_{k-1,i} g_i` into its second-stage weight
/// `w_{k-1,i} g_i p(z_k | x_k) / g_i`, so the estimates and the evidence
/// stay those of the same filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuxiliaryFilter {
    /// Resampling scheme of the first stage (systematic by default).
    pub resampling: Resampling,
    /// When the first stage resamples: [`ResamplePolicy::Always`] (Pitt and
    /// Shephard's filter, the default), on the ESS of the first-stage
    /// weights ([`ResamplePolicy::Ess`]), or never.
    pub policy: ResamplePolicy,
    /// Particles per chunk (per random stream and parallel task), 1024 by
    /// default.
    pub chunk_size: usize,
}

impl Default for AuxiliaryFilter {
    fn default() -> Self {
        Self {
            resampling: Resampling::Systematic,
            policy: ResamplePolicy::Always,
            chunk_size: 1024,
        }
    }
}

/// Stream id of the first-stage resampling (beyond any chunk index).
const FIRST_STAGE_STREAM: u64 = u64::MAX;

impl AuxiliaryFilter {
    /// Checks the configuration.
    ///
    /// # Errors
    /// [`ParticleError::InvalidParameter`] for a zero chunk size or an ESS
    /// threshold outside [0, 1].
    pub fn validate(&self) -> Result<()> {
        check_chunk_size(self.chunk_size)?;
        if let ResamplePolicy::Ess(t) = self.policy {
            check_threshold(t)?;
        }
        Ok(())
    }

    /// One step with observation `z`; `key` identifies the step's random
    /// streams as in [`crate::ParticleFilter::step`] (the previous step's
    /// key is refused).
    ///
    /// The set is left weighted by the second-stage weights, so
    /// [`ParticleSet::mean`] afterwards equals [`StepReport::mean`]. The
    /// report's `log_evidence` is Pitt's estimate of `log p(z_k |
    /// z_{1:k-1})`: `log (sum_i w_i g_i) + log (sum_j v_j w~_j)`, `v_j` the
    /// normalised first-stage weights after the first stage (`1/N` when it
    /// resampled), whose exponential is unbiased; `resampled` says whether
    /// the first stage resampled; `ess` is that of the second-stage
    /// weights; `max_log_increment` the largest log second-stage weight
    /// `log p(z_k | x_k) - log g`.
    ///
    /// Same bits on any number of threads: the first-stage weights and the
    /// children are computed chunk by chunk, each chunk with its own
    /// stream, and every sum runs in particle order.
    ///
    /// # Errors
    /// [`ParticleError::InvalidParameter`] as [`AuxiliaryFilter::validate`],
    /// [`ParticleError::Empty`] for an empty set,
    /// [`ParticleError::KeyReused`], [`ParticleError::NonFiniteWeight`] for
    /// a NaN or `+inf` first-stage or second-stage log weight,
    /// [`ParticleError::AllWeightsZero`] when every first-stage or every
    /// second-stage weight is zero, [`ParticleError::NonFiniteState`] for
    /// a non-finite child. The set is unchanged on error.
    pub fn step<M, const N: usize>(
        &self,
        set: &mut ParticleSet<SVector<f64, N>>,
        model: &M,
        z: &M::Observation,
        key: &[u64],
    ) -> Result<StepReport<N>>
    where
        M: Auxiliary<N>,
    {
        self.validate()?;
        let seed = stream_seed(key);
        let k = set.k + 1;
        if set.last_seed == Some(seed) {
            return Err(ParticleError::KeyReused { k });
        }
        let n = set.len();
        let cs = self.chunk_size;

        // first stage: log w_i + log g_i
        let mut first: Vec<f64> = vec![0.0; n];
        let mut g: Vec<f64> = vec![0.0; n];
        {
            let parents = &set.particles;
            let lw = &set.log_weights;
            for_chunks(cs, &mut first, &mut g, &[], |o, fs, gs, _| {
                for (i, (f, gi)) in fs.iter_mut().zip(gs.iter_mut()).enumerate() {
                    let j = o + i;
                    let l = model.log_first_stage(k, &parents[j], z);
                    if l.is_nan() || l == f64::INFINITY {
                        return Err(ParticleError::NonFiniteWeight { index: j, value: l });
                    }
                    *gi = l;
                    *f = lw[j] + l;
                }
                Ok(())
            })?;
        }
        let (max1, ln_s1) = crate::set::shifted_log_sum_exp(&first)?;
        // set.log_weights are normalised: log sum_i w_i g_i
        let log_first = max1 + ln_s1;
        let weights: Vec<f64> = first.iter().map(|&l| exp_flushed(l - max1)).collect();
        let (s1, s1sq) = weights
            .iter()
            .fold((0.0, 0.0), |(s, q), &w| (s + w, q + w * w));
        let resample = match self.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::Never => false,
            ResamplePolicy::Ess(t) => s1 * s1 / s1sq < t * n as f64,
        };
        // each child's weight before its second-stage weight: 1/N after
        // resampling, else its parent's normalised first-stage weight
        // w_i g_i / sum w g (Johansen and Doucet 2008)
        let ancestors: Vec<usize> = if resample {
            let mut ancestors = vec![0usize; n];
            let mut rng = stream_rng(&[key, &[FIRST_STAGE_STREAM]].concat());
            self.resampling
                .resample(&weights, &mut rng, &mut ancestors)?;
            ancestors
        } else {
            (0..n).collect()
        };
        let base = |j: usize| {
            if resample {
                -(n as f64).ln()
            } else {
                (first[j] - max1) - ln_s1
            }
        };

        // second stage: children from the transition, weights p(z|x) / g
        let mut children: Vec<SVector<f64, N>> =
            ancestors.iter().map(|&a| set.particles[a]).collect();
        let mut inc = vec![0.0; n];
        {
            let anc = &ancestors;
            let g = &g;
            let first = &first;
            for_chunks(cs, &mut children, &mut inc, key, |o, xs, ws, rng| {
                for (i, (x, w)) in xs.iter_mut().zip(ws.iter_mut()).enumerate() {
                    let j = o + i;
                    let child = model.sample_transition(k, x, rng);
                    if !child.iter().all(|v| v.is_finite()) {
                        return Err(ParticleError::NonFiniteState { index: j });
                    }
                    if first[anc[j]] == f64::NEG_INFINITY {
                        // a parent of first-stage weight zero (kept in
                        // place without resampling): its child's weight
                        // w g p / g is zero, whatever p / g would say
                        *x = child;
                        *w = f64::NEG_INFINITY;
                        continue;
                    }
                    let l = model.log_likelihood(k, &child, z) - g[anc[j]];
                    if l.is_nan() || l == f64::INFINITY {
                        return Err(ParticleError::NonFiniteWeight { index: j, value: l });
                    }
                    *x = child;
                    *w = l;
                }
                Ok(())
            })?;
        }
        let max_log_increment = inc.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for (j, l) in inc.iter_mut().enumerate() {
            *l += base(j);
        }
        let (max2, ln_s2) = crate::set::shifted_log_sum_exp(&inc)?;
        let log_evidence = log_first + (max2 + ln_s2);
        let (mut mean, mut sum2) = (SVector::<f64, N>::zeros(), 0.0);
        for (x, l) in children.iter().zip(inc.iter_mut()) {
            *l = (*l - max2) - ln_s2;
            let w = exp_flushed(*l);
            sum2 += w * w;
            mean.axpy(w, x, 1.0);
        }
        let mean = crate::set::finite_mean(mean, || {
            children.iter().zip(inc.iter().map(|&l| exp_flushed(l)))
        });
        set.scratch.ancestors = ancestors;
        set.particles = children;
        set.log_weights = inc;
        set.k = k;
        set.last_seed = Some(seed);
        Ok(StepReport {
            mean,
            log_evidence,
            ess: 1.0 / sum2,
            resampled: resample,
            accepted: 0,
            degenerate: false,
            max_log_increment,
        })
    }
}
