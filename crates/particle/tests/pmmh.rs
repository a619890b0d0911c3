//! Particle marginal Metropolis-Hastings recovers a simulated model's
//! parameter.

use bayestrack_particle::{
    Bootstrap, ParticleFilter, ParticleSet, Pmmh, ScalarModel, Smc, stream_rng,
};
use nalgebra::{Vector1, vector};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

const LN_2PI: f64 = 1.837_877_066_409_345_3;

/// `x_k = a x_{k-1} + v`, `z_k = x_k + n`, `v ~ N(0, q)`, `n ~ N(0, r)`.
struct Ar1 {
    a: f64,
    q: f64,
    r: f64,
}

impl ScalarModel for Ar1 {
    type Observation = f64;
    fn sample_transition<R: Rng + ?Sized>(&self, _k: usize, x: f64, rng: &mut R) -> f64 {
        let v: f64 = StandardNormal.sample(rng);
        self.a * x + self.q.sqrt() * v
    }
    fn log_likelihood(&self, _k: usize, x: f64, z: &f64) -> f64 {
        -0.5 * ((z - x).powi(2) / self.r + LN_2PI + self.r.ln())
    }
}

/// The bootstrap filter's log evidence of `zs` under `a`.
fn log_evidence(a: f64, zs: &[f64], seed: u64) -> bayestrack_particle::Result<f64> {
    let m = Ar1 { a, q: 0.5, r: 0.5 };
    let mut rng = stream_rng(&[seed]);
    let x0: Vec<Vector1<f64>> = (0..100)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            Vector1::new(e)
        })
        .collect();
    let mut pf = Smc::new(ParticleFilter::default(), ParticleSet::new(x0)?, seed)?;
    for z in zs {
        pf.step(&Bootstrap(&m), z)?;
    }
    Ok(pf.log_evidence())
}

fn simulate(a: f64, t: usize) -> Vec<f64> {
    let m = Ar1 { a, q: 0.5, r: 0.5 };
    let mut rng = stream_rng(&[21]);
    let mut x: f64 = StandardNormal.sample(&mut rng);
    (0..t)
        .map(|k| {
            x = m.sample_transition(k + 1, x, &mut rng);
            let n: f64 = StandardNormal.sample(&mut rng);
            x + 0.5f64.sqrt() * n
        })
        .collect()
}

#[test]
fn pmmh_recovers_a_known_parameter_inside_its_95_percent_interval() {
    let truth = 0.8;
    let zs = simulate(truth, 60);
    let pmmh = Pmmh {
        iterations: 1500,
        step: vector![0.1],
        seed: 22,
    };
    // uniform prior on the stationary region
    let prior = |t: &Vector1<f64>| {
        if t[0].abs() < 1.0 {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    };
    let chain = pmmh
        .run(vector![0.0], prior, |t, seed| log_evidence(t[0], &zs, seed))
        .unwrap();
    let burn_in = 300;
    let (lo, hi) = chain.credible_interval(0, 0.95, burn_in).unwrap();
    let mean = chain.mean(burn_in).unwrap()[0];
    let rate = chain.acceptance_rate();
    eprintln!("a: mean {mean:.3}, 95 % [{lo:.3}, {hi:.3}], acceptance {rate:.2}");
    assert!(lo < truth && truth < hi, "[{lo}, {hi}]");
    // informative: the interval is narrower than half the prior's width
    // and excludes a = 0 (no dynamics)
    assert!(hi - lo < 0.5 && lo > 0.0, "[{lo}, {hi}]");
    assert!((0.1..0.9).contains(&rate), "{rate}");
    assert_eq!(chain.samples.len(), 1501);
    // seeded: the same chain again
    let short = Pmmh {
        iterations: 20,
        ..pmmh
    };
    let run = || {
        short
            .run(vector![0.0], prior, |t, seed| log_evidence(t[0], &zs, seed))
            .unwrap()
    };
    assert_eq!(run(), run());
}

#[test]
fn pmmh_refuses_a_bad_start_or_step() {
    let prior = |t: &Vector1<f64>| {
        if t[0].abs() < 1.0 {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    };
    let p = Pmmh {
        iterations: 5,
        step: vector![0.1],
        seed: 1,
    };
    assert!(p.run(vector![2.0], prior, |_, _| Ok(0.0)).is_err());
    assert!(p.run(vector![0.0], prior, |_, _| Ok(f64::NAN)).is_err());
    let bad = Pmmh {
        step: vector![f64::NAN],
        ..p
    };
    assert!(bad.run(vector![0.0], prior, |_, _| Ok(0.0)).is_err());
}
