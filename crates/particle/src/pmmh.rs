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

    /// The posterior mean of the samples after the first `burn_in`.
    pub fn mean(&self, burn_in: usize) -> SVector<f64, P> {
        let kept = &self.samples[burn_in.min(self.samples.len())..];
        kept.iter().sum::<SVector<f64, P>>() / kept.len().max(1) as f64
    }

    /// The equal-tailed credible interval of parameter `i` with mass
    /// `level` (0.95 for 95 %) from the samples after `burn_in`: the
    /// `(1 - level) / 2` and `(1 + level) / 2` empirical quantiles (lower
    /// and upper order statistics); `None` when no sample is kept.
    pub fn credible_interval(&self, i: usize, level: f64, burn_in: usize) -> Option<(f64, f64)> {
        let mut v: Vec<f64> = self.samples.get(burn_in..)?.iter().map(|s| s[i]).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let lo = (((1.0 - level) / 2.0) * n as f64).floor() as usize;
        let hi = ((((1.0 + level) / 2.0) * n as f64).ceil() as usize).clamp(1, n) - 1;
        Some((v[lo.min(n - 1)], v[hi]))
    }
}

impl<const P: usize> Pmmh<P> {
    /// Runs the chain from `theta0`. `log_prior(theta)` is the log prior
    /// density (minus infinity outside the support: such a proposal is
    /// rejected without running a filter); `log_likelihood(theta, seed)`
    /// runs a particle filter with that seed and returns its log evidence
    /// `log p^(z_{1:T} | theta)` (minus infinity when every weight died).
    /// The chain is a function of `seed` alone.
    ///
    /// # Errors
    /// [`ParticleError::InvalidParameter`] for a non-finite or negative
    /// step, a `theta0` outside the prior's support or with a log
    /// likelihood that is not finite, or a NaN log likelihood; whatever
    /// `log_likelihood` returns.
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
            samples: vec![theta0],
            log_likelihoods: vec![ll],
            accepted: 0,
        };
        for i in 1..=self.iterations as u64 {
            let mut rng = stream_rng(&[self.seed, i, 0]);
            let e = SVector::<f64, P>::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let cand = theta + self.step.component_mul(&e);
            let u: f64 = rng.random();
            let lp_c = log_prior(&cand);
            if lp_c.is_nan() {
                return Err(ParticleError::InvalidParameter {
                    name: "log prior",
                    value: lp_c,
                    reason: "is NaN",
                });
            }
            if lp_c > f64::NEG_INFINITY {
                let ll_c = log_likelihood(&cand, stream_seed(&[self.seed, i, 1]))?;
                if ll_c.is_nan() {
                    return Err(ParticleError::InvalidParameter {
                        name: "log likelihood",
                        value: ll_c,
                        reason: "is NaN",
                    });
                }
                if u.ln() < (ll_c + lp_c) - (ll + lp) {
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
