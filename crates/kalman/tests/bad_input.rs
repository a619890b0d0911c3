//! Bad input gives the documented error, never a panic or a NaN.

mod common;

use bayestrack_kalman::{
    Ekf, Gaussian, Iekf, KalmanError, Kf, LinearDynamics, LinearMeasurement, Step, Ukf,
};
use common::{Turn, constant_velocity};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2, Vector4};

#[test]
fn a_non_positive_definite_covariance_is_named() {
    let indefinite = Matrix2::new(1.0, 2.0, 2.0, 1.0);
    assert_eq!(
        Gaussian::new(Vector2::zeros(), indefinite),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "covariance",
            step: Step::Construction
        })
    );
    assert_eq!(
        LinearDynamics::new(Matrix2::identity(), indefinite),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "process noise Q",
            step: Step::Construction
        })
    );
    assert!(matches!(
        LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(-1.0)),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "measurement noise R",
            ..
        })
    ));
    // a semi-definite prior is fine for the KF but has no Cholesky factor
    // for a density
    let psd = Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 1.0, 1.0, 1.0)).unwrap();
    assert!(matches!(
        psd.log_pdf(&Vector2::zeros()),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
}

#[test]
fn a_nan_measurement_is_rejected_by_every_filter() {
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let prior = Gaussian::new(Vector4::zeros(), nalgebra::Matrix4::identity()).unwrap();
    let z = Vector2::new(f64::NAN, 0.0);
    let expected = Err(KalmanError::NonFinite {
        what: "measurement z",
        step: Step::Update,
    });
    assert_eq!(Kf::default().update(&prior, &sensor, Some(&z)), expected);
    assert_eq!(Ekf::default().update(&prior, &sensor, Some(&z)), expected);
    assert_eq!(
        Iekf::new(3, 1e-9)
            .unwrap()
            .update(&prior, &sensor, Some(&z)),
        expected
    );
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    assert_eq!(ukf.update(&prior, &sensor, Some(&z)), expected);
    assert_eq!(
        ukf.step(&prior, &dynamics, &sensor, Some(&z))
            .map(|s| s.update),
        expected
    );
    let inf = Vector2::new(0.0, f64::INFINITY);
    assert!(Kf::default().update(&prior, &sensor, Some(&inf)).is_err());
    assert!(Gaussian::new(Vector2::new(f64::NAN, 0.0), Matrix2::identity()).is_err());
    assert!(
        Kf::default()
            .predict(
                &prior,
                &dynamics,
                Some(&nalgebra::SVector::<f64, 0>::zeros())
            )
            .is_ok()
    );
}

#[test]
fn a_singular_innovation_covariance_is_named() {
    // H observes nothing and R = 0: S = 0.
    let sensor = LinearMeasurement::new(Matrix1x2::zeros(), Matrix1::zeros()).unwrap();
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let expected = Err(KalmanError::NotPositiveDefinite {
        matrix: "innovation covariance S",
        step: Step::Update,
    });
    let z = Vector1::new(1.0);
    assert_eq!(Kf::default().update(&prior, &sensor, Some(&z)), expected);
    assert_eq!(
        Ukf::new(1.0, 2.0, 0.0)
            .unwrap()
            .update(&prior, &sensor, Some(&z)),
        expected
    );
    let err = Kf::default().update(&prior, &sensor, Some(&z)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "innovation covariance S is not positive definite in the update step"
    );
}

#[test]
fn invalid_parameters_are_errors() {
    assert!(matches!(
        Ukf::new(0.0, 2.0, 0.0),
        Err(KalmanError::InvalidParameter { name: "alpha", .. })
    ));
    assert!(Ukf::new(1.0, f64::NAN, 0.0).is_err());
    assert!(matches!(
        Iekf::new(0, 1e-9),
        Err(KalmanError::InvalidParameter {
            name: "max_iterations",
            ..
        })
    ));
    assert!(Iekf::new(3, -1.0).is_err());
    // alpha^2 (L + kappa) <= 0: no sigma points
    let ukf = Ukf::new(1.0, 2.0, -5.0).unwrap();
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let (dynamics, _) = (
        LinearDynamics::new(Matrix2::identity(), Matrix2::identity()).unwrap(),
        (),
    );
    assert!(matches!(
        ukf.predict(&prior, &dynamics),
        Err(KalmanError::InvalidParameter { name: "kappa", .. })
    ));
}

#[test]
fn a_missing_measurement_returns_the_prior() {
    let model = Turn::new();
    let prior = Gaussian::new(
        nalgebra::SVector::from([1.0, 2.0, 1.0, 0.1, 0.0]),
        nalgebra::SMatrix::<f64, 5, 5>::identity(),
    )
    .unwrap();
    let u = Ekf::default().update(&prior, &model, None).unwrap();
    assert_eq!(u.posterior, prior);
    assert!(u.innovation.is_none());
    assert_eq!(u.iterations, 0);
}

#[test]
fn smoother_controls_of_the_wrong_length_are_rejected() {
    let dynamics = LinearDynamics::with_control(
        Matrix2::identity(),
        nalgebra::Matrix2x1::new(0.0, 1.0),
        Matrix2::identity(),
    )
    .unwrap();
    let g = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let controls = [Vector1::new(1.0)];
    assert_eq!(
        Kf::default().rts_smooth(&[g, g, g], &dynamics, Some(&controls)),
        Err(KalmanError::DimensionMismatch {
            what: "controls",
            expected: 2,
            got: 1
        })
    );
}
