//! Particle marginal Metropolis-Hastings (Andrieu, Doucet and Holenstein
//! 2010, "Particle Markov chain Monte Carlo methods", JRSS B 72, sec. 2.4.2):
//! a random-walk Metropolis-Hastings chain over static parameters `theta`
//! in which the intractable likelihood `p(z_{1:T} | theta)` is replaced by
//! a particle filter's unbiased estimate ([`crate::Smc::log_evidence`],
//! [`crate::StepReport::log_evidence`]); the chain still targets the exact
//! posterior `p(theta | z_{1:T})`.

use nalgebra::SVector;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

use crate::error::{ParticleError, Result};
use crate::seed::{stream_rng, stream_seed};

/// Particle marginal Metropolis-Hastings over `P` static parameters
/// (Andrieu, Doucet and Holenstein 2010, sec. 2.4.2): a Gaussian
/// random-walk Metropolis-Hastings chain whose likelihood is a particle
/// filter's unbiased estimate ([`crate::Smc::log_evidence`]); the chain
/// still targets the exact posterior `p(theta | z_{1:T})`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pmmh<const P: usize> {
    /// Iterations (proposals) after the initial point.
    pub iterations: usize,
    /// Standard deviations of the Gaussian random-walk proposal, one per
    /// parameter. Andrieu et al. (sec. 2.4.2) and Doucet et al. (2015)
    /// advise a particle count where the log-likelihood estimate's
    /// standard deviation is about 1.
    pub step: SVector<f64, P>,
    /// The chain's seed: proposal `i` draws from `[seed, i, 0]`, and its
    /// particle filter gets the seed `stream_seed([seed, i, 1])`.
    pub seed: u64,
}

/// A PMMH chain.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain<const P: usize> {
    /// The states of the chain, the initial point first
    /// (`iterations + 1` of them).
    pub samples: Vec<SVector<f64, P>>,
    /// The log-likelihood estimate held by each state.
    pub log_likelihoods: Vec<f64>,
    /// Proposals accepted.
    pub accepted: usize,
}

impl<const P: usize> Chain<P> {
    /// Accepted proposals over proposals made.
    pub fn acceptance_rate(&self) -> f64 {
        let proposals = self.samples.len().saturating_sub(1);
        if proposals == 0 {
            return 0.0;
        }
        self.accepted as f64 / proposals as f64
    }

    /// The posterior mean of the samples after the first `burn_in`;
    /// `None` when no sample is kept.
    pub fn mean(&self, burn_in: usize) -> Option<SVector<f64, P>> {
        let kept = self.samples.get(burn_in..).filter(|k| !k.is_empty())?;
        // the samples are finite (Pmmh::run refuses others); the plain sum
        // of samples near f64::MAX would overflow
        Some(crate::smooth::bounded_mean(kept.iter()))
    }

    /// The equal-tailed credible interval of parameter `i` with mass
    /// `level` (0.95 for 95 %) from the samples after `burn_in`: the
    /// `(1 - level) / 2` and `(1 + level) / 2` empirical quantiles (lower
    /// and upper order statistics); `None` when no sample is kept, `i` is
    /// not a parameter index or `level` is not in (0, 1].
    pub fn credible_interval(&self, i: usize, level: f64, burn_in: usize) -> Option<(f64, f64)> {
        if i >= P || !(level > 0.0 && level <= 1.0) {
            return None;
        }
        let mut v: Vec<f64> = self.samples.get(burn_in..)?.iter().map(|s| s[i]).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let lo = (((1.0 - level) / 2.0) * n as f64).floor() as usize;
        let hi = ((((1.0 + level) / 2.0) * n as f64).ceil() as usize).clamp(1, n) - 1;
        // a tiny level can put the upper order statistic below the lower
        let lo = lo.min(n - 1);
        Some((v[lo], v[hi.max(lo)]))
    }
}

impl<const P: usize> Pmmh<P> {
    /// The most samples (the initial point and the iterations) a chain
    /// keeps: 2^24, 16.8 million (about 400 MB for `P` = 2).
    pub const MAX_SAMPLES: usize = 1 << 24;

    /// Runs the chain from `theta0`. `log_prior(theta)` is the log prior
    /// density (minus infinity outside the support: such a proposal is
    /// rejected without running a filter); `log_likelihood(theta, seed)`
    /// runs a particle filter with that seed and returns its log evidence
    /// `log p^(z_{1:T} | theta)` (minus infinity when every weight died).
    /// The chain is a function of `seed` alone.
    ///
    /// The chain keeps every sample: [`ParticleError::TooLarge`] for
    /// `iterations` of [`Pmmh::MAX_SAMPLES`] or more (run longer chains
    /// in segments, each from the last sample of the previous one with
    /// its own seed).
    ///
    /// # Errors
    /// [`ParticleError::TooLarge`]; [`ParticleError::InvalidParameter`]
    /// for a non-finite or negative step, a non-finite `theta0` or one
    /// outside the prior's support or with a log likelihood that is not
    /// finite, a proposal that leaves the finite numbers, or a NaN or
    /// `+inf` log prior or log likelihood; whatever `log_likelihood`
    /// returns.
    pub fn run<F, G>(
        &self,
        theta0: SVector<f64, P>,
        log_prior: F,
        mut log_likelihood: G,
    ) -> Result<Chain<P>>
    where
        F: Fn(&SVector<f64, P>) -> f64,
        G: FnMut(&SVector<f64, P>, u64) -> Result<f64>,
    {
        let limit = Self::MAX_SAMPLES;
        if self.iterations >= limit {
            return Err(ParticleError::TooLarge {
                what: "pmmh iterations",
                requested: self.iterations,
                limit: limit - 1,
            });
        }
        if let Some(&t) = theta0.iter().find(|t| !t.is_finite()) {
            return Err(ParticleError::InvalidParameter {
                name: "theta0",
                value: t,
                reason: "the initial point must be finite",
            });
        }
        if let Some(&s) = self.step.iter().find(|s| !s.is_finite() || **s < 0.0) {
            return Err(ParticleError::InvalidParameter {
                name: "step",
                value: s,
                reason: "random-walk standard deviations must be finite and non-negative",
            });
        }
        let mut lp = log_prior(&theta0);
        let mut ll = log_likelihood(&theta0, stream_seed(&[self.seed, 0, 1]))?;
        if !(lp.is_finite() && ll.is_finite()) {
            return Err(ParticleError::InvalidParameter {
                name: "theta0",
                value: if lp.is_finite() { ll } else { lp },
                reason: "the initial point needs a finite log prior and log likelihood",
            });
        }
        let mut theta = theta0;
        let mut chain = Chain {
            samples: Vec::with_capacity(self.iterations + 1),
            log_likelihoods: Vec::with_capacity(self.iterations + 1),
            accepted: 0,
        };
        chain.samples.push(theta0);
        chain.log_likelihoods.push(ll);
        for i in 1..=self.iterations as u64 {
            let mut rng = stream_rng(&[self.seed, i, 0]);
            let e = SVector::<f64, P>::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let cand = theta + self.step.component_mul(&e);
            if let Some(&c) = cand.iter().find(|c| !c.is_finite()) {
                return Err(ParticleError::InvalidParameter {
                    name: "step",
                    value: c,
                    reason: "the random walk left the finite numbers (step too large for theta)",
                });
            }
            let u: f64 = rng.random();
            let lp_c = log_prior(&cand);
            if lp_c.is_nan() || lp_c == f64::INFINITY {
                return Err(ParticleError::InvalidParameter {
                    name: "log prior",
                    value: lp_c,
                    reason: "must be finite or minus infinity",
                });
            }
            if lp_c > f64::NEG_INFINITY {
                let ll_c = log_likelihood(&cand, stream_seed(&[self.seed, i, 1]))?;
                if ll_c.is_nan() || ll_c == f64::INFINITY {
                    return Err(ParticleError::InvalidParameter {
                        name: "log likelihood",
                        value: ll_c,
                        reason: "must be finite or minus infinity",
                    });
                }
                // differences first: the sums of two large log densities
                // can overflow where their differences do not
                if u.ln() < (ll_c - ll) + (lp_c - lp) {
                    theta = cand;
                    ll = ll_c;
                    lp = lp_c;
                    chain.accepted += 1;
                }
            }
            chain.samples.push(theta);
            chain.log_likelihoods.push(ll);
        }
        Ok(chain)
    }
}
