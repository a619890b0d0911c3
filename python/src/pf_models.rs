//! The particle-filter models built into the wheel, in plain Rust (no
//! Python): the scalar model of Nagy, Ahmed and Zayed (paper 000) sec. 4
//! (van der Merwe et al.'s unscented-particle-filter demo, the `hikpf`
//! experiment) and a constant-velocity model. The bindings run them with
//! [`Smc`] and [`Bootstrap`], exactly as a Rust program does, and
//! [`reference_run`] is that Rust program: python/tests/pf_reference.rs
//! and python/tests/test_particle.py both compare it with the stored
//! vector python/tests/data/pf_reference.txt, so a built-in model run from
//! Python equals the Rust run bit for bit.

use bayestrack_particle::nalgebra::{SVector, Vector1};
use bayestrack_particle::rand::Rng;
use bayestrack_particle::rand_distr::{Distribution, Gamma, StandardNormal};
use bayestrack_particle::{
    Bootstrap, Model, ParticleError, ParticleFilter, ParticleSet, ResamplePolicy, Resampling, Smc,
};

/// Gamma process noise of paper 000's model: shape 3, rate 2.
pub const HIKPF_GAMMA_SHAPE: f64 = 3.0;
/// Rate of the Gamma process noise.
pub const HIKPF_GAMMA_RATE: f64 = 2.0;
/// Measurement noise variance of paper 000's model.
pub const HIKPF_SIGMA: f64 = 1e-5;

/// Paper 000's scalar model (sec. 4, eq. 27-28):
/// `x_t = 1 + sin(w pi t) + 0.5 x_{t-1} + v`, `v ~ Gamma(3, rate 2)`,
/// `z_t = x_t^2 / 5 + n` for `t <= 30`, `x_t / 2 - 2 + n` after,
/// `n ~ N(0, 1e-5)`. Step `k` of a filter (1, 2, ...) is time `t = k + 1`:
/// the particles start at `x_1`.
#[derive(Debug, Clone, Copy)]
pub struct Hikpf {
    /// `w` of `sin(w pi t)` (0.04 in the demo).
    pub sin_freq: f64,
    gamma: Gamma<f64>,
}

impl Hikpf {
    /// The model with frequency `sin_freq`.
    pub fn new(sin_freq: f64) -> Self {
        Self {
            sin_freq,
            gamma: Gamma::new(HIKPF_GAMMA_SHAPE, 1.0 / HIKPF_GAMMA_RATE)
                .expect("valid Gamma parameters"),
        }
    }

    /// `h(x, t)`.
    #[inline]
    pub fn observe(x: f64, t: usize) -> f64 {
        if t <= 30 { 0.2 * x * x } else { 0.5 * x - 2.0 }
    }
}

impl Model<1> for Hikpf {
    type Observation = f64;
    #[inline(always)]
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        let t = (k + 1) as f64;
        let drift = 1.0 + (self.sin_freq * std::f64::consts::PI * t).sin();
        Vector1::new(drift + 0.5 * x[0] + self.gamma.sample(rng))
    }
    #[inline(always)]
    fn log_likelihood(&self, k: usize, x: &SVector<f64, 1>, z: &f64) -> f64 {
        let e = z - Self::observe(x[0], k + 1);
        // the demo's unnormalised sigma^(-1/2) exp(-e^2 / (2 sigma))
        -0.5 * e * e / HIKPF_SIGMA - 0.5 * HIKPF_SIGMA.ln()
    }
}

/// A constant-velocity model on `A` axes, state
/// `[p_1, v_1, ..., p_A, v_A]` (`N = 2 A`): per axis
/// `p' = p + dt v + dt^2 / 2 a`, `v' = v + dt a`, `a ~ N(0, q)` (discrete
/// white-noise acceleration), and `z = [p_1, ..., p_A] + n`,
/// `n ~ N(0, r I)`.
#[derive(Debug, Clone, Copy)]
pub struct ConstantVelocity<const A: usize> {
    /// Time step.
    pub dt: f64,
    /// Acceleration variance.
    pub q: f64,
    /// Measurement noise variance per axis.
    pub r: f64,
}

macro_rules! cv_model {
    ($a:literal, $n:literal) => {
        impl Model<$n> for ConstantVelocity<$a> {
            type Observation = SVector<f64, $a>;
            #[inline(always)]
            fn sample_transition<R: Rng + ?Sized>(
                &self,
                _k: usize,
                x: &SVector<f64, $n>,
                rng: &mut R,
            ) -> SVector<f64, $n> {
                let sq = self.q.sqrt();
                let mut out = *x;
                for i in 0..$a {
                    let e: f64 = StandardNormal.sample(rng);
                    let a = sq * e;
                    out[2 * i] = x[2 * i] + self.dt * x[2 * i + 1] + 0.5 * self.dt * self.dt * a;
                    out[2 * i + 1] = x[2 * i + 1] + self.dt * a;
                }
                out
            }
            #[inline(always)]
            fn log_likelihood(&self, _k: usize, x: &SVector<f64, $n>, z: &SVector<f64, $a>) -> f64 {
                let mut s = 0.0;
                for i in 0..$a {
                    let e = z[i] - x[2 * i];
                    s += e * e;
                }
                -0.5 * s / self.r
            }
        }
    };
}
cv_model!(1, 2);
cv_model!(2, 4);
cv_model!(3, 6);

/// The Rust program the Python test reproduces: paper 000's model with
/// `n` particles at `x_1 = 1`, the default [`ParticleFilter`] (systematic
/// resampling after every step), `seed`, the measurements `zs`; returns
/// per step the mean, the ESS and the running log evidence.
///
/// # Errors
/// A [`ParticleError`] of a step.
pub fn reference_run(n: usize, seed: u64, zs: &[f64]) -> Result<Vec<[f64; 3]>, ParticleError> {
    let model = Hikpf::new(0.04);
    let set = ParticleSet::new(vec![Vector1::new(1.0); n])?;
    let filter = ParticleFilter {
        resampling: Resampling::Systematic,
        policy: ResamplePolicy::Always,
        ..ParticleFilter::default()
    };
    let mut smc = Smc::new(filter, set, seed)?;
    let mut out = Vec::with_capacity(zs.len());
    for z in zs {
        let report = smc.step(&Bootstrap(&model), z)?;
        out.push([report.mean[0], report.ess, smc.log_evidence()]);
    }
    Ok(out)
}
