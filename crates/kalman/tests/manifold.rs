//! One [`Manifold`] per model, used by every filter: an angle state that
//! crosses the +-pi cut, filtered by the EKF, IEKF, UKF, CKF and SR-UKF
//! and smoothed by the RTS smoothers, gives the answer of the same problem
//! turned by half a turn (where nothing crosses the cut) to 1e-9.

use std::f64::consts::PI;

use bayestrack_kalman::{
    Angles, Belief, Ckf, Dynamics, DynamicsJacobian, Ekf, Euclidean, Gaussian, Iekf, KalmanFilter,
    Manifold, Measurement, MeasurementJacobian, RtsSmoother, SrUkf, Ukf, batch_filter,
    batch_smooth,
};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, SMatrix, SVector, Vector1, Vector2};

const DT: f64 = 0.1;

/// A rotor: `x = [theta, omega]`, `theta` an angle kept in `(-pi, pi]`;
/// the sensor reads `theta`. `wraps` selects the [`Angles`] space for
/// both; without it the filters use plain arithmetic.
struct Rotor {
    wraps: bool,
}

fn wrap(a: f64) -> f64 {
    Angles::new([true]).wrap(Vector1::new(a))[0]
}

impl Dynamics<2> for Rotor {
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        Vector2::new(wrap(x[0] + DT * x[1]), x[1])
    }
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::new(1e-6, 0.0, 0.0, 1e-4)
    }
    fn state_space(&self) -> impl Manifold<2> {
        Angles::new([self.wraps, false])
    }
}

impl DynamicsJacobian<2> for Rotor {
    fn jacobian(&self, _: &SVector<f64, 2>) -> SMatrix<f64, 2, 2> {
        Matrix2::new(1.0, DT, 0.0, 1.0)
    }
}

impl Measurement<2, 1> for Rotor {
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        Vector1::new(x[0])
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(0.05f64.powi(2))
    }
    fn measurement_space(&self) -> impl Manifold<1> {
        Angles::new([self.wraps])
    }
}

impl MeasurementJacobian<2, 1> for Rotor {
    fn jacobian(&self, _: &SVector<f64, 2>) -> SMatrix<f64, 1, 2> {
        Matrix1x2::new(1.0, 0.0)
    }
}

/// Readings of a rotor at 1 rad/s from `theta0` (deterministic
/// pseudo-noise), 40 steps: from `pi - 1` it crosses the cut.
fn readings(theta0: f64) -> Vec<Option<Vector1<f64>>> {
    (0..40)
        .map(|k| {
            let noise = 0.03 * ((k as f64) * 1.7).sin();
            Some(Vector1::new(wrap(theta0 + DT * k as f64 + noise)))
        })
        .collect()
}

/// The filtered means of `filter` over `zs` from `theta0`.
fn run<F>(filter: &F, rotor: &Rotor, theta0: f64, zs: &[Option<Vector1<f64>>]) -> Vec<Gaussian<2>>
where
    F: KalmanFilter<2, 1, Rotor, Rotor>,
{
    let start = Gaussian::new(
        Vector2::new(theta0, 0.8),
        Matrix2::new(0.01, 0.0, 0.0, 0.25),
    )
    .unwrap();
    let mut belief = F::Belief::from_gaussian(&start).unwrap();
    let mut out = Vec::new();
    for z in zs {
        let prior = filter.predict(&belief, rotor).unwrap();
        belief = filter.update(&prior, rotor, z.as_ref()).unwrap().posterior;
        out.push(belief.to_gaussian());
    }
    out
}

/// The largest difference of two runs, the second turned back by half a
/// turn: angles compared modulo 2 pi.
fn turned_gap(a: &[Gaussian<2>], b: &[Gaussian<2>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            let dtheta = wrap(a.mean()[0] - b.mean()[0] - PI).abs();
            let domega = (a.mean()[1] - b.mean()[1]).abs();
            let dcov = (a.cov() - b.cov()).amax();
            dtheta.max(domega).max(dcov)
        })
        .fold(0.0, f64::max)
}

/// Every filter, on the problem that crosses the cut and on the same one
/// turned by half a turn: `(name, gap)`.
fn gaps(wraps: bool) -> Vec<(&'static str, f64)> {
    let rotor = Rotor { wraps };
    let across = PI - 1.0; // theta crosses pi after about 10 steps
    let away = across - PI; // the same motion about 0
    let (za, zb) = (readings(across), readings(away));
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let ekf = Ekf::default();
    let iekf = Iekf::new(5, 1e-12).unwrap();
    let ckf = Ckf;
    let srukf = SrUkf::new(1.0, 2.0, 0.0).unwrap();
    vec![
        (
            "EKF",
            turned_gap(
                &run(&ekf, &rotor, across, &za),
                &run(&ekf, &rotor, away, &zb),
            ),
        ),
        (
            "IEKF",
            turned_gap(
                &run(&iekf, &rotor, across, &za),
                &run(&iekf, &rotor, away, &zb),
            ),
        ),
        (
            "UKF",
            turned_gap(
                &run(&ukf, &rotor, across, &za),
                &run(&ukf, &rotor, away, &zb),
            ),
        ),
        (
            "CKF",
            turned_gap(
                &run(&ckf, &rotor, across, &za),
                &run(&ckf, &rotor, away, &zb),
            ),
        ),
        (
            "SR-UKF",
            turned_gap(
                &run(&srukf, &rotor, across, &za),
                &run(&srukf, &rotor, away, &zb),
            ),
        ),
    ]
}

#[test]
fn one_angle_space_serves_every_filter_across_the_cut() {
    for (name, gap) in gaps(true) {
        assert!(gap < 1e-9, "{name}: turned run differs by {gap}");
    }
    // the sigma-point filters without the angle space: each is broken
    // across the cut (the comparison above is not vacuous); the EKF's
    // state is wrapped by `f` itself, so only an innovation across the cut
    // needs the space (below)
    for (name, gap) in gaps(false).into_iter().skip(2) {
        assert!(gap > 1e-3, "{name}: without wrapping, gap only {gap}");
    }
    // a reading just across the cut from the prediction: with the space
    // the innovation is 0.02, without it -2 pi + 0.02
    let prior = Gaussian::new(Vector2::new(PI - 0.01, 1.0), Matrix2::identity() * 0.01).unwrap();
    let z = Vector1::new(-PI + 0.01);
    for wraps in [true, false] {
        let rotor = Rotor { wraps };
        for (name, update) in [
            (
                "EKF",
                Ekf::default().update(&prior, &rotor, Some(&z)).unwrap(),
            ),
            (
                "IEKF",
                Iekf::new(5, 1e-12)
                    .unwrap()
                    .update(&prior, &rotor, Some(&z))
                    .unwrap(),
            ),
        ] {
            let nu = update.innovation.unwrap().residual[0];
            let moved = wrap(update.posterior.mean()[0] - prior.mean()[0]);
            if wraps {
                assert!((nu - 0.02).abs() < 1e-12, "{name}: innovation {nu}");
                assert!(moved > 0.0 && moved < 0.02, "{name}: moved {moved}");
            } else {
                assert!(
                    (nu - (0.02 - 2.0 * PI)).abs() < 1e-12,
                    "{name}: innovation {nu}"
                );
                assert!(moved.abs() > 1.0, "{name}: moved {moved}");
            }
        }
    }
}

#[test]
fn one_angle_space_serves_the_smoothers_across_the_cut() {
    let rotor = Rotor { wraps: true };
    let across = PI - 1.0;
    let away = across - PI;
    let start =
        |t: f64| Gaussian::new(Vector2::new(t, 0.8), Matrix2::new(0.01, 0.0, 0.0, 0.25)).unwrap();
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let ekf = Ekf::default();
    let smooth_ukf = |t: f64| {
        let batch = batch_filter(&ukf, &start(t), &rotor, &rotor, &readings(t)).unwrap();
        batch_smooth(&ukf, &batch, &rotor).unwrap()
    };
    let smooth_ekf = |t: f64| {
        let batch = batch_filter(&ekf, &start(t), &rotor, &rotor, &readings(t)).unwrap();
        batch_smooth(&ekf, &batch, &rotor).unwrap()
    };
    let gap_ukf = turned_gap(&smooth_ukf(across), &smooth_ukf(away));
    let gap_ekf = turned_gap(&smooth_ekf(across), &smooth_ekf(away));
    assert!(gap_ukf < 1e-9, "URTS: {gap_ukf}");
    assert!(gap_ekf < 1e-9, "ERTS: {gap_ekf}");
    // the smoothers' mean differences go through the same space (the runs
    // above may not put a smoothed and a predicted mean across the cut)
    let (a, b) = (Vector2::new(PI - 0.01, 0.0), Vector2::new(-PI + 0.01, 0.0));
    let expect = Vector2::new(-0.02, 0.0);
    for (name, d) in [
        ("UKF", RtsSmoother::state_residual(&ukf, &rotor, &a, &b)),
        ("CKF", RtsSmoother::state_residual(&Ckf, &rotor, &a, &b)),
        ("EKF", RtsSmoother::state_residual(&ekf, &rotor, &a, &b)),
    ] {
        assert!((d - expect).amax() < 1e-12, "{name}: {d}");
    }
}

#[test]
fn euclidean_is_plain_arithmetic_and_angles_wrap_into_the_atan2_range() {
    let a = Vector2::new(3.0, -3.0);
    let b = Vector2::new(-3.0, 3.0);
    assert_eq!(Euclidean.residual(&a, &b), a - b);
    assert_eq!(Euclidean.boxplus(&a, &b), a + b);
    let space = Angles::new([true, false]);
    let d = space.residual(&a, &b);
    assert!((d[0] - (6.0 - 2.0 * PI)).abs() < 1e-15 && d[1] == -6.0);
    assert_eq!(space.wrap(Vector2::new(-PI, 0.0))[0], PI);
    assert_eq!(space.wrap(Vector2::new(PI, 0.0))[0], PI);
    assert!((space.wrap(Vector2::new(7.0 * PI + 0.5, 0.0))[0] - (0.5 - PI)).abs() < 1e-12);
    assert!(space.wrap(Vector2::new(f64::NAN, 0.0))[0].is_nan());
}
