//! The entry points a filterpy user reaches for (issue 25): closure
//! models, `batch_filter`, a full-R position sensor, method syntax.

use bayestrack_kalman::{
    Ekf, FnDynamics, FnMeasurement, Gaussian, KalmanError, KalmanPredict, Kf, LinearDynamics,
    LinearMeasurement, NoiseModel, Step, Ukf, batch_filter,
};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector2, Vector4};

fn cv() -> LinearDynamics<4> {
    LinearDynamics::<4>::constant_velocity(0.1, 0.5, NoiseModel::default()).unwrap()
}

fn zs() -> Vec<Option<Vector2<f64>>> {
    (0..20)
        .map(|k| {
            let t = f64::from(k) * 0.1;
            (k % 7 != 3).then(|| Vector2::new(t + 0.2 * (5.0 * t).sin(), 0.5 * t))
        })
        .collect()
}

#[test]
fn closure_models_give_the_numbers_of_the_linear_models() {
    let linear = cv();
    let r = Matrix2::new(0.25, 0.05, 0.05, 0.5);
    let sensor = LinearMeasurement::<4, 2>::position_with_noise(r).unwrap();
    let f = *linear.transition();
    let h = *sensor.matrix();
    let dynamics = FnDynamics::new(move |x: &Vector4<f64>| f * x, *linear.noise())
        .unwrap()
        .with_jacobian(move |_: &Vector4<f64>| f);
    let measurement = FnMeasurement::new(move |x: &Vector4<f64>| h * x, r)
        .unwrap()
        .with_jacobian(move |_: &Vector4<f64>| h);
    let start = Gaussian::new(Vector4::zeros(), Matrix4::identity()).unwrap();
    let ekf = Ekf::default();
    // same filter, same numbers: closures or structs
    let a = batch_filter(&ekf, &start, &linear, &sensor, &zs()).unwrap();
    let b = batch_filter(&ekf, &start, &dynamics, &measurement, &zs()).unwrap();
    assert_eq!(a, b);
    // and the UKF on the closures agrees with the KF to round-off
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let u = batch_filter(&ukf, &start, &dynamics, &measurement, &zs()).unwrap();
    let k = batch_filter(&Kf::default(), &start, &linear, &sensor, &zs()).unwrap();
    for (x, y) in u.posterior.iter().zip(&k.posterior) {
        assert!((x.mean() - y.mean()).amax() < 1e-10);
        assert!((x.cov() - y.cov()).amax() < 1e-10);
    }
    assert!((u.log_likelihood() - k.log_likelihood()).abs() < 1e-9);
}

#[test]
fn closure_models_check_their_noise_when_built() {
    let f = |x: &Vector2<f64>| *x;
    assert_eq!(
        FnDynamics::new(f, Matrix2::new(-1.0, 0.0, 0.0, 1.0)).map(|_| ()),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "process noise Q",
            step: Step::Construction
        })
    );
    assert!(matches!(
        FnMeasurement::new(|x: &Vector2<f64>| *x, Matrix2::new(1.0, f64::NAN, 0.0, 1.0))
            .map(|_| ()),
        Err(KalmanError::NonFinite {
            what: "measurement noise R",
            ..
        })
    ));
}

#[test]
fn batch_filter_is_the_loop_it_replaces() {
    let dynamics = cv();
    let sensor = LinearMeasurement::<4, 2>::position(0.25).unwrap();
    let start = Gaussian::new(Vector4::zeros(), Matrix4::identity()).unwrap();
    let kf = Kf::default();
    let batch = batch_filter(&kf, &start, &dynamics, &sensor, &zs()).unwrap();
    let mut belief = start;
    for (k, z) in zs().iter().enumerate() {
        let predicted = kf.predict(&belief, &dynamics).unwrap();
        let update = kf.update(&predicted, &sensor, z.as_ref()).unwrap();
        assert_eq!(batch.predicted[k], predicted);
        assert_eq!(batch.innovations[k], update.innovation);
        assert_eq!(batch.innovations[k].is_none(), z.is_none());
        belief = update.posterior;
        assert_eq!(batch.posterior[k], belief);
        assert_eq!(batch.means()[k], *belief.mean());
        assert_eq!(batch.covariances()[k], *belief.cov());
    }
    // an error stops the batch
    let bad = [Some(Vector2::new(f64::NAN, 0.0))];
    assert!(matches!(
        batch_filter(&kf, &start, &dynamics, &sensor, &bad),
        Err(KalmanError::NonFinite { .. })
    ));
}

#[test]
fn position_with_a_full_r_selects_the_positions() {
    let r = Matrix2::new(0.25, 0.05, 0.05, 0.5);
    let sensor = LinearMeasurement::<4, 2>::position_with_noise(r).unwrap();
    assert_eq!(
        *sensor.matrix(),
        Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    );
    assert_eq!(*sensor.noise(), r);
    assert_eq!(
        LinearMeasurement::<4, 2>::position(0.25).unwrap(),
        LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25).unwrap()
    );
    assert!(matches!(
        LinearMeasurement::<4, 2>::position_with_noise(Matrix2::new(1.0, 2.0, 2.0, 1.0)),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
}

#[test]
fn method_syntax_and_trait_functions_agree_for_every_filter() {
    let dynamics = cv();
    let start = Gaussian::new(Vector4::new(0.0, 1.0, 0.0, 0.5), Matrix4::identity()).unwrap();
    let kf = Kf::default();
    let ukf = Ukf::new(0.5, 2.0, 0.0).unwrap();
    let ekf = Ekf::default();
    assert_eq!(
        kf.predict(&start, &dynamics).unwrap(),
        KalmanPredict::predict(&kf, &start, &dynamics).unwrap()
    );
    assert_eq!(
        ekf.predict(&start, &dynamics).unwrap(),
        KalmanPredict::predict(&ekf, &start, &dynamics).unwrap()
    );
    assert_eq!(
        ukf.predict(&start, &dynamics).unwrap(),
        KalmanPredict::predict(&ukf, &start, &dynamics).unwrap()
    );
}
