//! Consistency over Monte Carlo runs: a correctly specified Kalman filter has
//! NEES and NIS inside their chi-square bands; a mis-specified one does not.

use crate::common;

use bayestrack_kalman::{ChiSquareBand, Gaussian, Kf, LinearDynamics, LinearMeasurement, nees};
use common::constant_velocity;
use nalgebra::{Matrix4, SVector, Vector4};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

const RUNS: usize = 500;
const STEPS: usize = 50;

fn normal<const D: usize>(rng: &mut Xoshiro256PlusPlus) -> SVector<f64, D> {
    SVector::from_fn(|_, _| StandardNormal.sample(rng))
}

/// Simulates with `truth` models and filters with `filter` models; returns
/// (NEES averaged over runs at the last step, NIS averaged over runs and steps).
fn monte_carlo(
    truth: &(LinearDynamics<4>, LinearMeasurement<4, 2>),
    filter: &(LinearDynamics<4>, LinearMeasurement<4, 2>),
) -> (f64, f64) {
    let kf = Kf::default();
    let p0 = Matrix4::from_diagonal(&Vector4::new(1.0, 1.0, 0.25, 0.25));
    let lq = truth.0.noise().cholesky().unwrap().l();
    let lr = truth.1.noise().cholesky().unwrap().l();
    let l0 = p0.cholesky().unwrap().l();
    let (mut nees_sum, mut nis_sum) = (0.0, 0.0);
    for run in 0..RUNS {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x5eed_0000 + run as u64);
        let mean0 = Vector4::new(0.0, 0.0, 1.0, -0.5);
        let mut x = mean0 + l0 * normal::<4>(&mut rng);
        let mut belief = Gaussian::new(mean0, p0).unwrap();
        for _ in 0..STEPS {
            x = truth.0.transition() * x + lq * normal::<4>(&mut rng);
            let z = truth.1.matrix() * x + lr * normal::<2>(&mut rng);
            let prior = kf.predict(&belief, &filter.0).unwrap();
            let u = kf.update(&prior, &filter.1, Some(&z)).unwrap();
            nis_sum += u.innovation.unwrap().nis;
            belief = u.posterior;
        }
        nees_sum += nees(&x, &belief).unwrap();
    }
    (nees_sum / RUNS as f64, nis_sum / (RUNS * STEPS) as f64)
}

#[test]
fn nees_and_nis_fall_inside_their_95_percent_bands() {
    let model = constant_velocity(0.1, 0.5, 0.25);
    let (anees, anis) = monte_carlo(&model, &model);
    let nees_band = ChiSquareBand::for_average(4, RUNS, 0.95).unwrap();
    // NIS is white in time: the run-and-time average has R T m dof.
    let nis_band = ChiSquareBand::for_average(2, RUNS * STEPS, 0.95).unwrap();
    assert!(
        nees_band.contains(anees),
        "ANEES {anees} outside {nees_band:?}"
    );
    assert!(nis_band.contains(anis), "ANIS {anis} outside {nis_band:?}");
}

#[test]
fn a_filter_that_underestimates_the_process_noise_fails_the_test() {
    let truth = constant_velocity(0.1, 0.5, 0.25);
    let wrong = constant_velocity(0.1, 0.05, 0.25);
    let (anees, anis) = monte_carlo(&truth, &wrong);
    let nees_band = ChiSquareBand::for_average(4, RUNS, 0.95).unwrap();
    let nis_band = ChiSquareBand::for_average(2, RUNS * STEPS, 0.95).unwrap();
    assert!(anees > nees_band.upper, "ANEES {anees}");
    assert!(anis > nis_band.upper, "ANIS {anis}");
}
