//! Particle marginal Metropolis-Hastings (Andrieu, Doucet and Holenstein
//! 2010) on a stochastic volatility model:
//!
//! ```text
//! x_k = phi x_{k-1} + sigma v,        v ~ N(0, 1)
//! y_k = beta exp(x_k / 2) e,          e ~ N(0, 1)
//! ```
//!
//! `T = 200` returns are simulated with `phi = 0.95`, `sigma = 0.25`,
//! `beta = 0.6`; the chain samples `(phi, sigma)` (`beta` known) with a
//! bootstrap filter of 200 particles estimating each likelihood, and prints
//! the posterior means and 95 % credible intervals.
//!
//! `cargo run --release -p bayestrack-particle --example pmmh_sv`

use bayestrack_particle::nalgebra::{Vector1, Vector2, vector};
use bayestrack_particle::rand::Rng;
use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
use bayestrack_particle::{
    Bootstrap, ParticleError, ParticleFilter, ParticleSet, Pmmh, ScalarModel, Smc, stream_rng,
};

const LN_2PI: f64 = 1.837_877_066_409_345_3;
const BETA: f64 = 0.6;
const T: usize = 200;
const N: usize = 200;

struct Sv {
    phi: f64,
    sigma: f64,
}

impl ScalarModel for Sv {
    type Observation = f64;
    #[inline(always)]
    fn sample_transition<G: Rng + ?Sized>(&self, _k: usize, x: f64, rng: &mut G) -> f64 {
        let v: f64 = StandardNormal.sample(rng);
        self.phi * x + self.sigma * v
    }
    #[inline]
    fn log_likelihood(&self, _k: usize, x: f64, y: &f64) -> f64 {
        -0.5 * (y * y / (BETA * BETA * x.exp()) + x + LN_2PI + 2.0 * BETA.ln())
    }
}

/// The bootstrap filter's log evidence of `ys` under `(phi, sigma)`.
fn log_evidence(theta: &Vector2<f64>, ys: &[f64], seed: u64) -> Result<f64, ParticleError> {
    let m = Sv {
        phi: theta[0],
        sigma: theta[1],
    };
    // the stationary distribution N(0, sigma^2 / (1 - phi^2))
    let sd = m.sigma / (1.0 - m.phi * m.phi).sqrt();
    let mut rng = stream_rng(&[seed, 0]);
    let x0 = (0..N)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            Vector1::new(sd * e)
        })
        .collect();
    let mut pf = Smc::new(ParticleFilter::default(), ParticleSet::new(x0)?, seed)?;
    for y in ys {
        pf.step(&Bootstrap(&m), y)?;
    }
    Ok(pf.log_evidence())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let truth = Sv {
        phi: 0.95,
        sigma: 0.25,
    };
    let mut rng = stream_rng(&[2026]);
    let e: f64 = StandardNormal.sample(&mut rng);
    let mut x = e * truth.sigma / (1.0 - truth.phi * truth.phi).sqrt();
    let ys: Vec<f64> = (1..=T)
        .map(|k| {
            x = truth.sample_transition(k, x, &mut rng);
            let e: f64 = StandardNormal.sample(&mut rng);
            BETA * (x / 2.0).exp() * e
        })
        .collect();
    // flat priors on the stationary region and on sigma > 0
    let prior = |t: &Vector2<f64>| {
        if t[0].abs() < 1.0 && t[1] > 0.0 {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    };
    let pmmh = Pmmh {
        iterations: 3000,
        step: vector![0.03, 0.03],
        seed: 7,
    };
    let chain = pmmh.run(vector![0.8, 0.5], prior, |t, seed| {
        log_evidence(t, &ys, seed)
    })?;
    let burn_in = 500;
    let mean = chain.mean(burn_in).ok_or("no samples")?;
    println!(
        "PMMH, {} iterations ({burn_in} burn-in), bootstrap filter N = {N}, T = {T}; acceptance rate {:.2}",
        pmmh.iterations,
        chain.acceptance_rate()
    );
    for (i, (name, value)) in [("phi", truth.phi), ("sigma", truth.sigma)]
        .into_iter()
        .enumerate()
    {
        let (lo, hi) = chain
            .credible_interval(i, 0.95, burn_in)
            .ok_or("no samples")?;
        println!(
            "  {name:<5} true {value:.3}  posterior mean {:.3}  95 % interval [{lo:.3}, {hi:.3}]",
            mean[i]
        );
    }
    Ok(())
}
