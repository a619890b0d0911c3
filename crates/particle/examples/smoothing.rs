//! Smoothing against filtering on the univariate nonstationary growth
//! model (Kitagawa 1996; Godsill, Doucet and West 2004, sec. 5.1):
//!
//! ```text
//! x_k = x_{k-1} / 2 + 25 x_{k-1} / (1 + x_{k-1}^2) + 8 cos(1.2 k) + v,  v ~ N(0, 10)
//! z_k = x_k^2 / 20 + n,                                               n ~ N(0, 1)
//! ```
//!
//! A bootstrap filter's estimates `E[x_k | z_{1:k}]` against the
//! fixed-lag smoother's `E[x_k | z_{1:k+L}]` and the FFBS smoother's
//! `E[x_k | z_{1:T}]`, RMS error against the simulated truth.
//!
//! `cargo run --release -p bayestrack-particle --example smoothing`

use bayestrack_particle::nalgebra::Vector1;
use bayestrack_particle::rand::Rng;
use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
use bayestrack_particle::{
    Bootstrap, FixedLag, ParticleFilter, ParticleSet, ScalarModel, ScalarTransitionDensity, ffbs,
    path_means, stream_rng,
};

const Q: f64 = 10.0;
const R: f64 = 1.0;
const T: usize = 100;
const N: usize = 1000;
const PATHS: usize = 200;
const LAG: usize = 5;
const RUNS: u64 = 10;

struct Growth;

impl Growth {
    fn drift(k: usize, x: f64) -> f64 {
        x / 2.0 + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * k as f64).cos()
    }
}

impl ScalarModel for Growth {
    type Observation = f64;
    fn sample_transition<G: Rng + ?Sized>(&self, k: usize, x: f64, rng: &mut G) -> f64 {
        let v: f64 = StandardNormal.sample(rng);
        Self::drift(k, x) + Q.sqrt() * v
    }
    fn log_likelihood(&self, _k: usize, x: f64, z: &f64) -> f64 {
        -0.5 * (z - x * x / 20.0).powi(2) / R
    }
}

impl ScalarTransitionDensity for Growth {
    fn log_transition(&self, k: usize, x_prev: f64, x: f64) -> f64 {
        -0.5 * (x - Self::drift(k, x_prev)).powi(2) / Q
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let pf = ParticleFilter::default();
    let (mut se_f, mut se_l, mut se_s, mut n_l) = (0.0, 0.0, 0.0, 0);
    for run in 0..RUNS {
        let mut rng = stream_rng(&[run]);
        let e: f64 = StandardNormal.sample(&mut rng);
        let mut x = 0.1 * e;
        let (mut xs, mut zs) = (vec![], vec![]);
        for k in 1..=T {
            x = Growth.sample_transition(k, x, &mut rng);
            let n: f64 = StandardNormal.sample(&mut rng);
            xs.push(x);
            zs.push(x * x / 20.0 + R.sqrt() * n);
        }
        let initial = (0..N)
            .map(|_| Vector1::from_fn(|_, _| StandardNormal.sample(&mut rng)))
            .collect();
        let mut set = ParticleSet::new(initial)?;
        let mut history = vec![set.clone()];
        let mut lag = FixedLag::new(LAG);
        lag.record(&set, None)?;
        for (k, z) in zs.iter().enumerate() {
            let r = pf.step(&mut set, &Bootstrap(&Growth), z, &[run, k as u64])?;
            se_f += (r.mean[0] - xs[k]).powi(2);
            lag.record(&set, Some(&r))?;
            // E[x_{k+1-LAG} | z_{1:k+1}] (xs[k - LAG]); x_0 is not scored
            if let (Some(e), Some(i)) = (lag.estimate(&set), k.checked_sub(LAG)) {
                se_l += (e[0] - xs[i]).powi(2);
                n_l += 1;
            }
            history.push(set.clone());
        }
        let paths = ffbs(&history, &Growth, PATHS, 64, &[run, u64::MAX])?;
        let means = path_means(&paths)?;
        for (m, x) in means[1..].iter().zip(&xs) {
            se_s += (m[0] - x).powi(2);
        }
    }
    let steps = (RUNS as usize * T) as f64;
    println!("growth model, N = {N}, {RUNS} runs of {T} steps, RMS error against the truth:");
    println!(
        "  filter            E[x_k | z_1:k]      {:.3}",
        (se_f / steps).sqrt()
    );
    println!(
        "  fixed lag L = {LAG}   E[x_k | z_1:k+{LAG}]    {:.3}",
        (se_l / n_l as f64).sqrt()
    );
    println!(
        "  FFBS ({PATHS} paths)  E[x_k | z_1:T]      {:.3}",
        (se_s / steps).sqrt()
    );
    Ok(())
}
