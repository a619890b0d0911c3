//! The [`KalmanFilter`] trait (one generic function over the KF, EKF, IEKF
//! and UKF) and the angle hooks of the model traits (a bearing across the
//! +-pi cut).

use std::f64::consts::PI;

use bayestrack_kalman::{
    Additive, Angles, Dynamics, Ekf, Gaussian, Iekf, KalmanFilter, KalmanPredict, Kf,
    LinearDynamics, LinearMeasurement, Manifold, Measurement, Result, Ukf, Update,
};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, SMatrix, SVector, Vector2, Vector4};

/// Runs predict/update over `zs` (every third measurement missing) with any
/// filter, returning the beliefs and the NIS of each update.
fn track<F, D, H>(
    filter: &F,
    dynamics: &D,
    sensor: &H,
    start: Gaussian<4>,
    zs: &[Vector2<f64>],
) -> Result<Vec<(Gaussian<4>, Option<f64>)>>
where
    F: KalmanFilter<4, 2, D, H, Belief = Gaussian<4>>,
{
    let mut belief = start;
    let mut out = Vec::new();
    for (k, z) in zs.iter().enumerate() {
        let prior = filter.predict(&belief, dynamics)?;
        let z = (k % 3 != 2).then_some(z);
        let update: Update<4, 2> = filter.update(&prior, sensor, z)?;
        belief = update.posterior;
        out.push((belief, update.innovation.map(|i| i.nis)));
    }
    Ok(out)
}

#[test]
fn one_generic_function_runs_every_filter_with_the_same_answers() {
    let dt = 0.1;
    let mut f = Matrix4::identity();
    f[(0, 2)] = dt;
    f[(1, 3)] = dt;
    let dynamics = LinearDynamics::new(f, Matrix4::identity() * 0.01).unwrap();
    let sensor = LinearMeasurement::new(
        Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
        Matrix2::identity() * 0.25,
    )
    .unwrap();
    let start = Gaussian::new(Vector4::zeros(), Matrix4::identity() * 4.0).unwrap();
    let zs: Vec<_> = (1..=30)
        .map(|k| {
            let t = f64::from(k) * dt;
            Vector2::new(t + 0.3 * (3.0 * t).sin(), 2.0 * t - 0.2 * (5.0 * t).cos())
        })
        .collect();

    let kf = track(&Kf::default(), &dynamics, &sensor, start, &zs).unwrap();
    // the trait's `predict` is the inherent one without a control input
    let direct = Kf::default().predict(&start, &dynamics).unwrap();
    assert_eq!(
        KalmanPredict::predict(&Kf::default(), &start, &dynamics).unwrap(),
        direct
    );
    let others = [
        (
            "EKF",
            track(&Ekf::default(), &dynamics, &sensor, start, &zs).unwrap(),
        ),
        (
            "IEKF",
            track(
                &Iekf::new(5, 1e-12).unwrap(),
                &dynamics,
                &sensor,
                start,
                &zs,
            )
            .unwrap(),
        ),
        // UKF == KF on a linear model, for any sigma-point spread
        (
            "UKF",
            track(
                &Ukf::new(1.0, 2.0, 0.0).unwrap(),
                &dynamics,
                &sensor,
                start,
                &zs,
            )
            .unwrap(),
        ),
        (
            "UKF a=1e-3",
            track(
                &Ukf::new(1e-3, 2.0, 0.0).unwrap(),
                &dynamics,
                &sensor,
                start,
                &zs,
            )
            .unwrap(),
        ),
    ];
    for (name, run) in &others {
        assert_eq!(run.len(), kf.len());
        for (k, ((b, nis), (b_kf, nis_kf))) in run.iter().zip(&kf).enumerate() {
            let dm = (b.mean() - b_kf.mean()).amax();
            let dp = (b.cov() - b_kf.cov()).amax();
            assert!(
                dm < 1e-9 && dp < 1e-9,
                "{name} step {k}: mean {dm:e}, cov {dp:e}"
            );
            match (nis, nis_kf) {
                (Some(a), Some(b)) => assert!((a - b).abs() < 1e-9, "{name} step {k} NIS"),
                (None, None) => {}
                _ => panic!("{name} step {k}: missing measurement handled differently"),
            }
        }
    }
    // EKF on a linear model is the KF exactly
    assert_eq!(others[0].1, kf);
}

/// `(-pi, pi]`.
fn wrap(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w == -PI { PI } else { w }
}

/// Range and bearing of a 2-D position from the origin; `hooks` selects the
/// angle-aware residual and mean of the bearing.
struct RangeBearing {
    hooks: bool,
}

impl Measurement<2, 2> for RangeBearing {
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        Vector2::new(x[0].hypot(x[1]), x[1].atan2(x[0]))
    }
    fn measurement_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::new(0.01, 0.0, 0.0, 1e-4) // 0.1 in range, 0.01 rad
    }
    fn measurement_space(&self) -> impl Manifold<2> {
        Angles::new([false, self.hooks])
    }
}

/// One UKF update of a prior offset by `dy` from a target at bearing
/// `pi - 0.01`, 10 from the sensor: `(error of the posterior mean, NIS,
/// innovation variance of the bearing)`.
fn bearing_update(hooks: bool, dy: f64, var: f64, alpha: f64) -> (f64, f64, f64) {
    let r = 10.0;
    let truth = Vector2::new(r * (PI - 0.01).cos(), r * (PI - 0.01).sin());
    let prior = Gaussian::new(truth + Vector2::new(0.0, dy), Matrix2::identity() * var).unwrap();
    let sensor = RangeBearing { hooks };
    let z = sensor.observe(&truth);
    assert!(z[1] > PI - 0.011);
    let update = Ukf::new(alpha, 2.0, 0.0)
        .unwrap()
        .update(&prior, &sensor, Some(&z))
        .unwrap();
    let innovation = update.innovation.unwrap();
    (
        (update.posterior.mean() - truth).norm(),
        innovation.nis,
        innovation.covariance[(1, 1)],
    )
}

#[test]
fn bearing_hooks_fix_the_ukf_update_across_the_cut() {
    // (a) prior mean at bearing pi - 0.02, on the measurement's side; its
    // sigma points (spread 0.7 in y) straddle the cut
    let (err, nis, s_bearing) = bearing_update(true, 0.1, 0.25, 1.0);
    assert!(
        err < 0.05 && nis < 1.0,
        "with hooks: error {err}, NIS {nis}"
    );
    assert!(s_bearing < 0.01, "with hooks: S_bearing {s_bearing}");
    let (err_plain, _, s_plain) = bearing_update(false, 0.1, 0.25, 1.0);
    // points at +-pi make the bearing variance of S absurd (R is 1e-4), so
    // the bearing is all but ignored and the posterior stays off by 0.24
    assert!(
        err_plain > 10.0 * err,
        "without hooks: error {err_plain} vs {err}"
    );
    assert!(s_plain > 1.0, "without hooks: S_bearing {s_plain}");

    // (b) prior mean at bearing -pi + 0.02, across the cut from z (sigma
    // points all on its side): the innovation is 2 pi - 0.03 unwrapped
    let (err, nis, _) = bearing_update(true, -0.3, 0.05, 0.5);
    assert!(
        err < 0.06 && nis < 2.0,
        "with hooks: error {err}, NIS {nis}"
    );
    let (err_plain, nis_plain, _) = bearing_update(false, -0.3, 0.05, 0.5);
    assert!(
        err_plain > 10.0 && nis_plain > 1e3,
        "without hooks: error {err_plain}, NIS {nis_plain}"
    );
}

/// Heading `x = [theta]` turned by a fixed rate and wrapped to `(-pi, pi]`
/// by `f` itself (as a model that stores a normalised angle does).
struct Heading {
    hooks: bool,
}

impl Dynamics<1> for Heading {
    fn propagate(&self, x: &SVector<f64, 1>) -> SVector<f64, 1> {
        SVector::from([wrap(x[0] + 0.005)])
    }
    fn process_noise(&self) -> SMatrix<f64, 1, 1> {
        SMatrix::from([[1e-4]])
    }
    fn state_space(&self) -> impl Manifold<1> {
        Angles::new([self.hooks])
    }
}

#[test]
fn state_hooks_fix_the_ukf_prediction_across_the_cut() {
    let prior = Gaussian::new(
        SVector::from([PI - 0.01]),
        SMatrix::from([[0.02f64.powi(2)]]),
    )
    .unwrap();
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let good = ukf.predict(&prior, &Heading { hooks: true }).unwrap();
    // pi - 0.005, variance 0.02^2 + 1e-4
    assert!(
        (good.mean()[0] - (PI - 0.005)).abs() < 1e-9,
        "{}",
        good.mean()[0]
    );
    assert!((good.cov()[(0, 0)] - 5e-4).abs() < 1e-12);
    let plain = ukf.predict(&prior, &Heading { hooks: false }).unwrap();
    assert!((plain.mean()[0] - (PI - 0.005)).abs() > 1.0);
    assert!(plain.cov()[(0, 0)] > 1.0);
}

#[test]
fn the_augmented_forms_use_the_hooks_too() {
    // The same models seen through `Additive` (noise in the sigma points):
    // with the hooks the augmented UKF matches the additive one across the
    // cut; `Additive` carries the hooks over, so breaking that forwarding
    // (or the augmented forms ignoring it) fails here.
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let heading = Heading { hooks: true };
    let prior = Gaussian::new(
        SVector::from([PI - 0.01]),
        SMatrix::from([[0.02f64.powi(2)]]),
    )
    .unwrap();
    let additive = ukf.predict(&prior, &heading).unwrap();
    let augmented = ukf.predict_augmented(&prior, &Additive(&heading)).unwrap();
    assert!((augmented.mean()[0] - additive.mean()[0]).abs() < 1e-9);
    assert!((augmented.cov()[(0, 0)] - additive.cov()[(0, 0)]).abs() < 1e-9);

    let r = 10.0;
    let truth = Vector2::new(r * (PI - 0.01).cos(), r * (PI - 0.01).sin());
    let prior = Gaussian::new(truth + Vector2::new(0.0, 0.1), Matrix2::identity() * 0.25).unwrap();
    let sensor = RangeBearing { hooks: true };
    let z = sensor.observe(&truth);
    let plain = ukf.update(&prior, &sensor, Some(&z)).unwrap();
    let aug = ukf
        .update_augmented(&prior, &Additive(&sensor), Some(&z))
        .unwrap();
    // the augmented set has two more dimensions (other weights), so the
    // two agree to the accuracy of the unscented transform, not bitwise
    let gap = (aug.posterior.mean() - plain.posterior.mean()).norm();
    assert!(gap < 0.02, "augmented vs additive posterior: {gap}");
    let err = (aug.posterior.mean() - truth).norm();
    assert!(err < 0.05, "augmented posterior error {err}");
    let nis = aug.innovation.unwrap().nis;
    assert!(nis < 1.0, "augmented NIS {nis}");
    // without the hooks the augmented update is as wrong as the plain one
    let broken = ukf
        .update_augmented(&prior, &Additive(&RangeBearing { hooks: false }), Some(&z))
        .unwrap();
    assert!((broken.posterior.mean() - truth).norm() > 10.0 * err);
}
