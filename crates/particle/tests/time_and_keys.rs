//! The time index models see, bootstrap models without a transition
//! density, and step keys: `Smc` numbers them, a reused key is refused.

use bayestrack_particle::kalman::{
    Dynamics, DynamicsJacobian, Ekf, Measurement, MeasurementJacobian,
};
use bayestrack_particle::nalgebra::{Matrix1, SMatrix, SVector, Vector1};
use bayestrack_particle::rand::Rng;
use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
use bayestrack_particle::{
    Bootstrap, KalmanParticle, KalmanProposal, Model, ParticleError, ParticleFilter, ParticleSet,
    ResamplePolicy, Smc, TransitionDensity,
};

/// `x_k = x_{k-1} + k`, no noise; the measurement is the time index, and
/// the likelihood is zero unless the model is shown the same `k`. No
/// transition density: a bootstrap filter must not need one.
struct Ramp;

impl Model<1> for Ramp {
    type Observation = SVector<f64, 1>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x: &SVector<f64, 1>,
        _: &mut R,
    ) -> SVector<f64, 1> {
        x.add_scalar(k as f64)
    }
    fn log_likelihood(&self, k: usize, _: &SVector<f64, 1>, z: &SVector<f64, 1>) -> f64 {
        if z[0] == k as f64 {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    }
}

fn line(n: usize) -> ParticleSet<SVector<f64, 1>> {
    ParticleSet::new((0..n).map(|i| Vector1::new(i as f64)).collect()).unwrap()
}

#[test]
fn models_see_the_time_index_of_the_step() {
    let mut pf = Smc::new(ParticleFilter::default(), line(50), 3).unwrap();
    assert_eq!(pf.k(), 0);
    for k in 1..=4 {
        pf.step(&Bootstrap(&Ramp), &Vector1::new(k as f64)).unwrap();
        assert_eq!(pf.k(), k);
    }
    // x_4 = x_0 + 1 + 2 + 3 + 4; resampling only reorders copies
    let mut xs: Vec<f64> = pf.set.particles().iter().map(|x| x[0] - 10.0).collect();
    xs.sort_by(f64::total_cmp);
    assert!(
        xs.iter()
            .all(|x| *x >= 0.0 && *x <= 49.0 && x.fract() == 0.0)
    );
    assert!((pf.set.mean()[0] - 10.0 - 24.5).abs() < 5.0);
    // a measurement for another time index weighs every particle zero
    assert_eq!(
        pf.step(&Bootstrap(&Ramp), &Vector1::new(4.0)),
        Err(ParticleError::AllWeightsZero { count: 50 })
    );
    assert_eq!(pf.k(), 4, "a failed step does not advance the time index");
}

#[test]
fn the_mcmc_move_weighs_candidates_at_the_same_time_index() {
    // flat likelihood at the right k: every Metropolis-Hastings candidate
    // is accepted (min(1, e^0)); at a wrong k none would be
    let pf = ParticleFilter {
        mcmc: true,
        ..ParticleFilter::default()
    };
    let mut smc = Smc::new(pf, line(40), 5).unwrap();
    let r = smc.step(&Bootstrap(&Ramp), &Vector1::new(1.0)).unwrap();
    assert_eq!(r.accepted, 40);
}

/// A Gaussian random walk `x_k = x_{k-1} + N(0, 1)` observed directly with
/// variance `R`; its transition density is zero unless shown the step's
/// time index (the measurement's second half carries it).
struct Walk {
    r: f64,
}

impl Model<1> for Walk {
    type Observation = SVector<f64, 2>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _: usize,
        x: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        x.add_scalar(StandardNormal.sample(rng))
    }
    fn log_likelihood(&self, _: usize, x: &SVector<f64, 1>, z: &SVector<f64, 2>) -> f64 {
        -0.5 * (z[0] - x[0]).powi(2) / self.r
    }
}

/// Holds `k` where the filter stores the step's time index for the model.
struct AtStep(Walk, f64);

impl Model<1> for AtStep {
    type Observation = SVector<f64, 2>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        self.0.sample_transition(k, x, rng)
    }
    fn log_likelihood(&self, k: usize, x: &SVector<f64, 1>, z: &SVector<f64, 2>) -> f64 {
        self.0.log_likelihood(k, x, z)
    }
}

impl TransitionDensity<1> for AtStep {
    fn log_transition(&self, k: usize, x_prev: &SVector<f64, 1>, x: &SVector<f64, 1>) -> f64 {
        if k as f64 != self.1 {
            return f64::NEG_INFINITY;
        }
        -0.5 * (x[0] - x_prev[0]).powi(2)
    }
}

impl Dynamics<1> for Walk {
    fn propagate(&self, x: &SVector<f64, 1>) -> SVector<f64, 1> {
        *x
    }
    fn process_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(1.0)
    }
}
impl DynamicsJacobian<1> for Walk {
    fn jacobian(&self, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        Matrix1::new(1.0)
    }
}
impl Measurement<1, 2> for Walk {
    fn observe(&self, x: &SVector<f64, 1>) -> SVector<f64, 2> {
        SVector::<f64, 2>::new(x[0], 0.0)
    }
    fn measurement_noise(&self) -> SMatrix<f64, 2, 2> {
        SMatrix::<f64, 2, 2>::new(self.r, 0.0, 0.0, 1.0)
    }
}
impl MeasurementJacobian<1, 2> for Walk {
    fn jacobian(&self, _: &SVector<f64, 1>) -> SMatrix<f64, 2, 1> {
        SMatrix::<f64, 2, 1>::new(1.0, 0.0)
    }
}

#[test]
fn kalman_proposals_see_the_time_index_in_the_transition_density() {
    let particles = (0..200)
        .map(|i| KalmanParticle {
            x: Vector1::new(i as f64 / 100.0),
            cov: Matrix1::new(1.0),
        })
        .collect();
    let mut pf = Smc::new(
        ParticleFilter::default(),
        ParticleSet::new(particles).unwrap(),
        11,
    )
    .unwrap();
    let local = Walk { r: 0.5 };
    for k in 1..=3 {
        let model = AtStep(Walk { r: 0.5 }, k as f64);
        let proposal = KalmanProposal {
            model: &model,
            local: &local,
            filter: Ekf::default(),
        };
        pf.step(&proposal, &SVector::<f64, 2>::new(1.0, k as f64))
            .unwrap();
    }
    // a model told step 9 at step 4 gives every particle zero weight
    let wrong = AtStep(Walk { r: 0.5 }, 9.0);
    let proposal = KalmanProposal {
        model: &wrong,
        local: &local,
        filter: Ekf::default(),
    };
    assert_eq!(
        pf.step(&proposal, &SVector::<f64, 2>::new(1.0, 4.0)),
        Err(ParticleError::AllWeightsZero { count: 200 })
    );
}

/// Particles all at zero under a flat likelihood, never resampled: after
/// each step every particle holds the sum of the noise it was dealt.
fn walkers(n: usize) -> ParticleSet<SVector<f64, 1>> {
    ParticleSet::new(vec![Vector1::new(0.0); n]).unwrap()
}

const FLAT: Walk = Walk { r: f64::INFINITY };

fn no_resampling() -> ParticleFilter {
    ParticleFilter {
        policy: ResamplePolicy::Never,
        chunk_size: 16,
        ..ParticleFilter::default()
    }
}

#[test]
fn smc_deals_fresh_noise_every_step() {
    let z = SVector::<f64, 2>::zeros();
    let mut pf = Smc::new(no_resampling(), walkers(64), 1).unwrap();
    pf.step(&Bootstrap(&FLAT), &z).unwrap();
    let first: Vec<f64> = pf.set.particles().iter().map(|x| x[0]).collect();
    pf.step(&Bootstrap(&FLAT), &z).unwrap();
    let second: Vec<f64> = pf
        .set
        .particles()
        .iter()
        .zip(&first)
        .map(|(x, a)| x[0] - a)
        .collect();
    // the same key would deal the same increments (x_2 = 2 x_1)
    let same = first
        .iter()
        .zip(&second)
        .filter(|(a, b)| (*a - *b).abs() < 1e-12)
        .count();
    assert_eq!(same, 0, "{first:?} vs {second:?}");
    // and the increments are standard normal: mean and variance of 64
    let mean = second.iter().sum::<f64>() / 64.0;
    let var = second.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / 63.0;
    assert!(mean.abs() < 0.5 && (var - 1.0).abs() < 0.5, "{mean} {var}");
}

#[test]
fn a_reused_step_key_is_refused() {
    let z = SVector::<f64, 2>::zeros();
    let pf = no_resampling();
    let mut set = walkers(32);
    pf.step(&mut set, &Bootstrap(&FLAT), &z, &[4, 1]).unwrap();
    let after = set.clone();
    assert_eq!(
        pf.step(&mut set, &Bootstrap(&FLAT), &z, &[4, 1]),
        Err(ParticleError::KeyReused { k: 2 })
    );
    assert_eq!(set, after, "a refused step leaves the set as it was");
    assert_eq!(set.k(), 1);
    pf.step(&mut set, &Bootstrap(&FLAT), &z, &[4, 2]).unwrap();
    assert_eq!(set.k(), 2);
    let message = ParticleError::KeyReused { k: 2 }.to_string();
    assert!(
        message.contains("step 2") && message.contains("step 1"),
        "{message}"
    );
}

fn smc_run(threads: usize, seed: u64) -> ParticleSet<SVector<f64, 1>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let pf = ParticleFilter {
            chunk_size: 100,
            mcmc: true,
            ..ParticleFilter::default()
        };
        let mut smc = Smc::new(pf, walkers(1000), seed).unwrap();
        let walk = Walk { r: 0.3 };
        for k in 1..=6 {
            let z = SVector::<f64, 2>::new(0.4 * k as f64, 0.0);
            smc.step(&Bootstrap(&walk), &z).unwrap();
        }
        smc.set
    })
}

#[test]
fn smc_is_the_keyed_step_with_key_seed_k_on_any_thread_count() {
    let one = smc_run(1, 21);
    assert_eq!(one, smc_run(2, 21));
    assert_ne!(one, smc_run(1, 22));
    let pf = ParticleFilter {
        chunk_size: 100,
        mcmc: true,
        ..ParticleFilter::default()
    };
    let mut set = walkers(1000);
    let walk = Walk { r: 0.3 };
    for k in 1..=6u64 {
        let z = SVector::<f64, 2>::new(0.4 * k as f64, 0.0);
        pf.step(&mut set, &Bootstrap(&walk), &z, &[21, k]).unwrap();
    }
    assert_eq!(one, set);
    assert_eq!(one.k(), 6);
}

#[test]
fn smc_refuses_a_bad_configuration() {
    let bad = ParticleFilter {
        chunk_size: 0,
        ..ParticleFilter::default()
    };
    assert!(matches!(
        Smc::new(bad, walkers(4), 0),
        Err(ParticleError::InvalidParameter { .. })
    ));
}
