//! Bad input gives the documented error, never a panic or a NaN.

use crate::common;

use bayestrack_kalman::{
    Ekf, Gaussian, Iekf, KalmanError, Kf, LinearDynamics, LinearMeasurement, NoiseCovariance, Step,
    Ukf,
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
            .predict_with_control(&prior, &dynamics, &nalgebra::SVector::<f64, 0>::zeros())
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

/// A linear model that hands the filters whatever `Q` and `R` it holds,
/// through the traits (no constructor checks them).
struct Handed {
    q: Matrix2<f64>,
    r: Matrix1<f64>,
}

impl bayestrack_kalman::Dynamics<2> for Handed {
    fn propagate(&self, x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(x[0] + 0.1 * x[1], x[1])
    }
    fn process_noise(&self) -> Matrix2<f64> {
        self.q
    }
}

impl bayestrack_kalman::DynamicsJacobian<2> for Handed {
    fn jacobian(&self, _: &Vector2<f64>) -> Matrix2<f64> {
        Matrix2::new(1.0, 0.1, 0.0, 1.0)
    }
}

impl bayestrack_kalman::Measurement<2, 1> for Handed {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0])
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        self.r
    }
}

impl bayestrack_kalman::MeasurementJacobian<2, 1> for Handed {
    fn jacobian(&self, _: &Vector2<f64>) -> Matrix1x2<f64> {
        Matrix1x2::new(1.0, 0.0)
    }
}

/// filterpy's `Q_discrete_white_noise(2, dt, var)`: rank 1 in 2-D (the
/// 3-D block has rank 2 in the piecewise form users combine); singular
/// but positive semi-definite.
fn white_noise_q(dt: f64, var: f64) -> Matrix2<f64> {
    Matrix2::new(
        dt.powi(4) / 4.0,
        dt.powi(3) / 2.0,
        dt.powi(3) / 2.0,
        dt * dt,
    ) * var
}

#[test]
fn a_model_handed_noise_is_checked_where_it_is_used() {
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let z = Vector1::new(0.3);
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let iekf = Iekf::new(3, 1e-9).unwrap();
    let good_r = Matrix1::new(0.5);
    // an indefinite Q reached Ekf/Ukf::predict unchecked: a predicted
    // covariance that is not positive definite, then an update with Ok
    // and a negative variance
    let bad_q = Handed {
        q: Matrix2::new(-4.0, 0.0, 0.0, 0.1),
        r: good_r,
    };
    let q_err: Result<Gaussian<2>, _> = Err(KalmanError::NotPositiveDefinite {
        matrix: "process noise Q",
        step: Step::Predict,
    });
    assert_eq!(Ekf::default().predict(&prior, &bad_q), q_err);
    assert_eq!(iekf.predict(&prior, &bad_q), q_err);
    assert_eq!(ukf.predict(&prior, &bad_q), q_err);
    assert_eq!(
        ukf.step(&prior, &bad_q, &bad_q, Some(&z))
            .map(|s| s.predicted),
        q_err
    );
    assert_eq!(
        ukf.rts_smooth(&[prior, prior], &bad_q),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "process noise Q",
            step: Step::Smooth,
        })
    );
    let asym = Handed {
        q: Matrix2::new(1.0, 0.5, -0.5, 1.0),
        r: good_r,
    };
    assert!(matches!(
        Ekf::default().predict(&prior, &asym),
        Err(KalmanError::NotSymmetric {
            matrix: "process noise Q",
            step: Step::Predict,
            ..
        })
    ));
    let nan = Handed {
        q: Matrix2::new(f64::NAN, 0.0, 0.0, 1.0),
        r: good_r,
    };
    assert_eq!(
        ukf.predict(&prior, &nan),
        Err(KalmanError::NonFinite {
            what: "process noise Q",
            step: Step::Predict
        })
    );
    // a negative R: the update said Ok with a negative innovation variance
    // whenever H P H^T outweighed it
    let bad_r = Handed {
        q: Matrix2::identity() * 0.01,
        r: Matrix1::new(-0.5),
    };
    let r_err = Err(KalmanError::NotPositiveDefinite {
        matrix: "measurement noise R",
        step: Step::Update,
    });
    assert_eq!(Ekf::default().update(&prior, &bad_r, Some(&z)), r_err);
    assert_eq!(iekf.update(&prior, &bad_r, Some(&z)), r_err);
    assert_eq!(ukf.update(&prior, &bad_r, Some(&z)), r_err);
    assert_eq!(
        ukf.step(&prior, &bad_r, &bad_r, Some(&z)).map(|s| s.update),
        r_err
    );
    let err = Ekf::default().update(&prior, &bad_r, Some(&z)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "measurement noise R is not positive definite in the update step"
    );
    // a missing measurement never reads R
    assert!(Ekf::default().update(&prior, &bad_r, None).is_ok());
    // singular but positive semi-definite Q stays accepted
    let singular = Handed {
        q: white_noise_q(0.1, 2.0),
        r: good_r,
    };
    for predicted in [
        Ekf::default().predict(&prior, &singular).unwrap(),
        ukf.predict(&prior, &singular).unwrap(),
        ukf.step(&prior, &singular, &singular, Some(&z))
            .unwrap()
            .predicted,
    ] {
        assert!(predicted.cov().symmetric_eigenvalues().min() > 0.0);
    }
    let zero_r = Handed {
        q: Matrix2::zeros(),
        r: Matrix1::zeros(),
    };
    assert!(Ekf::default().update(&prior, &zero_r, Some(&z)).is_ok());
    assert!(ukf.predict(&prior, &zero_r).is_ok());
}

#[test]
fn a_measurement_too_large_for_its_statistics_is_an_error() {
    // 1e155 squares past the largest f64: NIS = inf and log-likelihood =
    // -inf came back with Ok
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let prior = Gaussian::new(Vector4::zeros(), nalgebra::Matrix4::identity()).unwrap();
    let expected = Err(KalmanError::NonFinite {
        what: "normalised innovation squared (NIS) and log-likelihood",
        step: Step::Update,
    });
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    for big in [1e155, -1e200, 1e300] {
        let z = Vector2::new(big, 0.0);
        assert_eq!(Kf::default().update(&prior, &sensor, Some(&z)), expected);
        assert_eq!(Ekf::default().update(&prior, &sensor, Some(&z)), expected);
        assert_eq!(
            Iekf::new(3, 1e-9)
                .unwrap()
                .update(&prior, &sensor, Some(&z)),
            expected
        );
        assert_eq!(ukf.update(&prior, &sensor, Some(&z)), expected);
        assert_eq!(
            ukf.step(&prior, &dynamics, &sensor, Some(&z))
                .map(|s| s.update),
            expected
        );
    }
    // large but representable: a finite answer
    let z = Vector2::new(1e100, 0.0);
    let u = Kf::default().update(&prior, &sensor, Some(&z)).unwrap();
    let inn = u.innovation.unwrap();
    assert!(inn.nis.is_finite() && inn.log_likelihood().is_finite());
    assert!(u.posterior.mean().iter().all(|v| v.is_finite()));
}

/// `x -> x^2`: a model whose sigma points do not average to `f(mean)`, so
/// the covariance weight `Wc_0` matters.
struct Square;

impl bayestrack_kalman::Dynamics<1> for Square {
    fn propagate(&self, x: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(x[0] * x[0])
    }
    fn process_noise(&self) -> Matrix1<f64> {
        Matrix1::new(1e-4)
    }
}

#[test]
fn ukf_parameters_that_give_an_indefinite_covariance_are_refused() {
    // issue 28: `Ukf::new(1, -1e6, 0).predict(..)` returned variance -999995
    let prior = Gaussian::new(Vector1::new(1.0), Matrix1::new(1.0)).unwrap();
    let ukf = Ukf::new(1.0, -1e6, 0.0).unwrap();
    assert!(matches!(
        ukf.predict(&prior, &Square),
        Err(KalmanError::InvalidParameter { name: "beta", .. })
    ));
    assert!(matches!(
        ukf.weights(1),
        Err(KalmanError::InvalidParameter { name: "beta", .. })
    ));
    // Julier's kappa = 3 - L with beta = 0 for L = 5: alpha^2 kappa + beta L < 0
    assert!(matches!(
        Ukf::new(1.0, 0.0, -2.0).unwrap().weights(5),
        Err(KalmanError::InvalidParameter { name: "kappa", .. })
    ));
    // the usual parameters stay valid
    for (a, b, k, l) in [
        (1e-3, 2.0, 0.0, 5),
        (1.0, 0.0, 2.0, 2),
        (0.5, 2.0, -4.0, 10),
    ] {
        assert!(
            Ukf::new(a, b, k).unwrap().weights(l).is_ok(),
            "{a} {b} {k} {l}"
        );
    }
}

#[test]
fn a_tiny_alpha_is_blamed_on_alpha() {
    // issue 28: `Ukf::new(1e-160, ..)` had weights (-inf, -inf, inf), and a
    // tiny alpha was reported as "kappa = 0"
    for alpha in [1e-160, 1e-300, 1e-5, f64::MIN_POSITIVE / 4.0] {
        let err = Ukf::new(alpha, 2.0, 0.0)
            .and_then(|u| u.weights(3))
            .unwrap_err();
        assert!(
            matches!(err, KalmanError::InvalidParameter { name: "alpha", .. }),
            "{alpha}: {err}"
        );
    }
    // alpha^2 overflows
    assert!(matches!(
        Ukf::new(1e200, 2.0, 0.0),
        Err(KalmanError::InvalidParameter { name: "alpha", .. })
    ));
    // L + kappa so close to 0 that the points collapse onto the mean
    let err = Ukf::new(1.0, 2.0, -3.0 + 1e-300)
        .unwrap()
        .weights(3)
        .unwrap_err();
    assert!(
        matches!(err, KalmanError::InvalidParameter { name: "kappa", .. }),
        "{err}"
    );
}

/// A prior so large that `S = H P H^T + R` overflows is named as not
/// finite, not as a matrix that lost definiteness (issue 28: "Kalman
/// overflow reported as S not PD").
#[test]
fn an_innovation_covariance_that_overflows_is_not_finite_not_indefinite() {
    // S = H P H^T + R = 4 x 1e308 + 1: past the largest f64
    let sensor = LinearMeasurement::new(Matrix1x2::new(2.0, 0.0), Matrix1::new(1.0)).unwrap();
    let z = Vector1::new(1.0);
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::new(1e308, 0.0, 0.0, 1.0)).unwrap();
    let err = Kf::default().update(&prior, &sensor, Some(&z)).unwrap_err();
    assert!(
        matches!(
            err,
            KalmanError::NonFinite {
                step: Step::Update,
                ..
            }
        ),
        "{err}"
    );
    // large but representable: a finite answer
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::new(1e307, 0.0, 0.0, 1.0)).unwrap();
    assert!(Kf::default().update(&prior, &sensor, Some(&z)).is_ok());
}

#[test]
fn a_spread_that_overflows_the_covariance_names_the_sigma_point_scale() {
    // alpha^2 (L + kappa) = 1e300 times a covariance of 1e10 is not a number
    let prior = Gaussian::new(Vector1::new(1.0), Matrix1::new(1e10)).unwrap();
    let err = Ukf::new(1.0, 2.0, 1e300)
        .unwrap()
        .predict(&prior, &Square)
        .unwrap_err();
    assert!(
        matches!(
            err,
            KalmanError::InvalidParameter {
                name: "alpha^2 (L + kappa)",
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn densities_and_chi_square_statistics_that_overflow_are_errors() {
    use bayestrack_kalman::{ChiSquareBand, chi_square_cdf, chi_square_quantile, nees};
    // log_pdf returned NaN and -inf, nees NaN, with Ok
    let wide = Gaussian::new(Vector2::new(1e308, -1e308), Matrix2::identity() * 1e308).unwrap();
    let far = Vector2::new(-1e308, 1e308);
    assert!(matches!(
        wide.log_pdf(&far),
        Err(KalmanError::NonFinite {
            step: Step::Evaluate,
            ..
        })
    ));
    assert!(wide.mahalanobis_sq(&far).is_err());
    let narrow = Gaussian::new(Vector2::zeros(), Matrix2::identity() * 1e-300).unwrap();
    assert!(nees(&Vector2::new(1e300, 0.0), &narrow).is_err());
    let tiny = Gaussian::new(Vector2::new(1.0, 1.0), Matrix2::identity() * 5e-324).unwrap();
    assert!(tiny.log_pdf(&Vector2::zeros()).is_err());
    // dof * runs overflowed (a panic in debug builds)
    assert!(matches!(
        ChiSquareBand::for_average(usize::MAX, 2, 0.95),
        Err(KalmanError::InvalidParameter { name: "runs", .. })
    ));
    // k = 1e308 never returned; k = 1e20 had a CDF of 0 at its median;
    // p = 1e-300 returned 3e-61
    assert!(chi_square_quantile(0.5, 1e308).is_err());
    assert!(chi_square_cdf(1e20, 1e20).is_err());
    assert!(chi_square_quantile(0.975, 1e10).is_ok());
    // with 2 degrees of freedom the quantile is -2 ln(1 - p) = 2e-300
    let q = chi_square_quantile(1e-300, 2.0).unwrap();
    assert!((q / 2e-300 - 1.0).abs() < 1e-9, "{q}");
}

/// A model whose `Q` and `R` are checked once ([`NoiseCovariance`]).
struct Once {
    q: NoiseCovariance<2>,
    r: NoiseCovariance<1>,
}

impl bayestrack_kalman::Dynamics<2> for Once {
    fn propagate(&self, x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(x[0] + 0.1 * x[1], x[1])
    }
    fn process_noise(&self) -> Matrix2<f64> {
        *self.q.matrix()
    }
    fn checked_process_noise(&self) -> Option<NoiseCovariance<2>> {
        Some(self.q)
    }
}

impl bayestrack_kalman::Measurement<2, 1> for Once {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0])
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        *self.r.matrix()
    }
    fn checked_measurement_noise(&self) -> Option<NoiseCovariance<1>> {
        Some(self.r)
    }
}

#[test]
fn noise_checked_once_is_refused_when_bad_and_used_unchanged_when_good() {
    // issue 30: the checks of a constant Q and R moved to construction;
    // they still refuse what the per-step checks refused
    assert_eq!(
        NoiseCovariance::new(Matrix2::new(-4.0, 0.0, 0.0, 0.1)),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "noise covariance",
            step: Step::Construction
        })
    );
    assert!(matches!(
        NoiseCovariance::new(Matrix2::new(1.0, 0.5, -0.5, 1.0)),
        Err(KalmanError::NotSymmetric { .. })
    ));
    assert!(matches!(
        NoiseCovariance::new(Matrix1::new(f64::NAN)),
        Err(KalmanError::NonFinite { .. })
    ));
    // singular is accepted, as by the per-step check
    assert!(NoiseCovariance::new(white_noise_q(0.1, 2.0)).is_ok());
    // a checked model gives the same numbers as the same model checked on
    // every step
    let once = Once {
        q: NoiseCovariance::new(white_noise_q(0.1, 2.0)).unwrap(),
        r: NoiseCovariance::new(Matrix1::new(0.5)).unwrap(),
    };
    let every = Handed {
        q: white_noise_q(0.1, 2.0),
        r: Matrix1::new(0.5),
    };
    let prior = Gaussian::new(Vector2::new(0.2, -0.1), Matrix2::identity()).unwrap();
    let z = Vector1::new(0.3);
    let ukf = Ukf::new(0.5, 2.0, 0.0).unwrap();
    assert_eq!(
        ukf.predict(&prior, &once).unwrap(),
        ukf.predict(&prior, &every).unwrap()
    );
    assert_eq!(
        ukf.update(&prior, &once, Some(&z)).unwrap(),
        ukf.update(&prior, &every, Some(&z)).unwrap()
    );
}

#[test]
fn a_posterior_variance_below_the_priors_round_off_is_an_error() {
    // the floor is -1e-9 times the prior's largest variance (its largest
    // entry, for a positive semi-definite prior): a UKF whose points do
    // not resolve a variance of 1 at a mean of 1e12 gives a wrong negative
    // variance, refused
    let prior = Gaussian::new(Vector2::new(1e12, 0.0), Matrix2::new(1.0, 0.0, 0.0, 1e-30)).unwrap();
    let sensor = SquareSensor;
    let ukf = Ukf::new(1e-3, 2.0, 0.0).unwrap();
    let got = ukf.update(&prior, &sensor, Some(&Vector1::new(1e24)));
    assert!(
        matches!(
            got,
            Err(KalmanError::NotPositiveDefinite {
                matrix: "posterior covariance",
                step: Step::Update
            })
        ),
        "{got:?}"
    );
}

/// `z = x_0^2`, tiny noise.
struct SquareSensor;

impl bayestrack_kalman::Measurement<2, 1> for SquareSensor {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0] * x[0])
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        Matrix1::new(1e-6)
    }
}

/// Issue 28 ("Ok with a negative variance"): a noise or prior covariance
/// with a variance below zero, however small, is refused (the semi-definite
/// path's eigenvalue tolerance let `R = -5e-324` through, and `Kf::update`
/// on a subnormal prior then returned a posterior variance of -5e-324).
#[test]
fn a_negative_variance_is_refused_however_small() {
    let tiny = -5e-324;
    assert!(matches!(
        LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(tiny)),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        LinearDynamics::new(Matrix2::identity(), Matrix2::new(1.0, 0.0, 0.0, tiny)),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        Gaussian::new(Vector2::zeros(), Matrix2::new(tiny, 0.0, 0.0, 1.0)),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        NoiseCovariance::new(Matrix1::new(tiny)),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
    // zero stays a valid (degenerate) variance
    assert!(LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.0)).is_ok());
}

/// Every posterior a filter returns with `Ok` has no negative variance:
/// subnormal and tiny priors and noises, where round-off reaches below
/// zero, come back clamped to zero or as an error.
#[test]
fn posterior_variances_returned_with_ok_are_never_negative() {
    // exact measurements (R = 0) of one component leave it 0 up to
    // round-off, which reaches below zero for some priors
    let scales = [
        0.0, 5e-324, 1e-310, 1e-300, 1e-160, 1e-20, 0.1, 0.3, 0.7, 1.0, 1.7, 3.3, 1e20, 1e150,
    ];
    let mut checked = 0;
    for &p0 in &scales {
        for &r in &scales {
            for &c in &[0.0, 0.5, 0.3, 0.999_999] {
                let off = c * p0;
                let Ok(prior) = Gaussian::new(
                    Vector2::new(1.0, -1.0),
                    Matrix2::new(p0, off, off, 2.0 * p0),
                ) else {
                    continue;
                };
                for row in [Matrix1x2::new(1.0, 1.0), Matrix1x2::new(1.0, 0.0)] {
                    let Ok(h) = LinearMeasurement::new(row, Matrix1::new(r)) else {
                        continue;
                    };
                    let z = Vector1::new(0.5);
                    let updates = [
                        Kf::default()
                            .update(&prior, &h, Some(&z))
                            .map(|u| u.posterior),
                        Ukf::new(1.0, 2.0, 0.0)
                            .unwrap()
                            .update(&prior, &h, Some(&z))
                            .map(|u| u.posterior),
                    ];
                    for u in updates.into_iter().flatten() {
                        checked += 1;
                        for i in 0..2 {
                            let v = u.cov()[(i, i)];
                            assert!(v >= 0.0, "p0 {p0:e}, r {r:e}, c {c}: variance {v:e}");
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 100, "{checked}");
}

/// A measurement space whose mean is not finite while its residuals are:
/// only the check of the sigma-point mean of `h` (and of `z`) can report
/// it, since every output of the update is finite.
struct InfiniteMean;

impl bayestrack_kalman::Manifold<1> for InfiniteMean {
    fn residual(&self, _: &Vector1<f64>, _: &Vector1<f64>) -> Vector1<f64> {
        Vector1::zeros()
    }
    fn boxplus(&self, _: &Vector1<f64>, _: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(f64::INFINITY)
    }
}

/// A pendulum-like model whose state and measurement spaces are
/// [`InfiniteMean`]-style when asked.
struct BadSpaces {
    bad_state: bool,
    bad_measurement: bool,
}

/// The state space of [`BadSpaces`]: plain, or with an infinite mean.
struct StateSpace(bool);

impl bayestrack_kalman::Manifold<2> for StateSpace {
    fn boxplus(&self, c: &Vector2<f64>, o: &Vector2<f64>) -> Vector2<f64> {
        if self.0 {
            Vector2::new(f64::INFINITY, 0.0)
        } else {
            c + o
        }
    }
}

/// The measurement space of [`BadSpaces`].
struct MeasurementSpace(bool);

impl bayestrack_kalman::Manifold<1> for MeasurementSpace {
    fn residual(&self, a: &Vector1<f64>, b: &Vector1<f64>) -> Vector1<f64> {
        if self.0 {
            InfiniteMean.residual(a, b)
        } else {
            a - b
        }
    }
    fn boxplus(&self, c: &Vector1<f64>, o: &Vector1<f64>) -> Vector1<f64> {
        if self.0 {
            InfiniteMean.boxplus(c, o)
        } else {
            c + o
        }
    }
}

impl bayestrack_kalman::Dynamics<2> for BadSpaces {
    fn propagate(&self, x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(x[0] + 0.1 * x[1], x[1] - 0.1 * x[0].sin())
    }
    fn process_noise(&self) -> Matrix2<f64> {
        Matrix2::identity() * 1e-4
    }
    fn state_space(&self) -> impl bayestrack_kalman::Manifold<2> {
        StateSpace(self.bad_state)
    }
}

impl bayestrack_kalman::Measurement<2, 1> for BadSpaces {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0].sin())
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        Matrix1::new(0.01)
    }
    fn measurement_space(&self) -> impl bayestrack_kalman::Manifold<1> {
        MeasurementSpace(self.bad_measurement)
    }
}

/// The UKF checks the sigma-point means and `z` even when they leave no
/// trace in the outputs (the checks are folded into the test of the
/// outputs, and run in order, each named, when it fails): a measurement
/// space whose residuals are zero and whose mean is infinite gives finite
/// outputs, so only these checks report it.
#[test]
fn the_ukf_names_a_non_finite_sigma_point_mean_or_z_even_with_finite_outputs() {
    use bayestrack_kalman::Manifold;
    let prior = Gaussian::new(Vector2::new(0.5, 0.1), Matrix2::identity() * 0.1).unwrap();
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let z = Vector1::new(0.4);
    let (plain, bad_f, bad_h) = (
        BadSpaces {
            bad_state: false,
            bad_measurement: false,
        },
        BadSpaces {
            bad_state: true,
            bad_measurement: false,
        },
        BadSpaces {
            bad_state: false,
            bad_measurement: true,
        },
    );
    fn non_finite<T>(what: &'static str, step: Step) -> Result<T, KalmanError> {
        Err(KalmanError::NonFinite { what, step })
    }
    assert!(ukf.predict(&prior, &plain).is_ok());
    assert!(ukf.update(&prior, &plain, Some(&z)).is_ok());
    assert_eq!(
        ukf.predict(&prior, &bad_f),
        non_finite("sigma-point mean of f", Step::Predict)
    );
    assert_eq!(
        ukf.update(&prior, &bad_h, Some(&z)),
        non_finite("sigma-point mean of h", Step::Update)
    );
    // one sigma-point set: both means are checked with the prediction
    assert_eq!(
        ukf.step(&prior, &plain, &bad_h, Some(&z)).map(|s| s.update),
        non_finite("sigma-point mean of h", Step::Predict)
    );
    assert_eq!(
        ukf.step(&prior, &bad_f, &plain, Some(&z)).map(|s| s.update),
        non_finite("sigma-point mean of f", Step::Predict)
    );
    // a NaN z whose residual the space maps to zero: every output is
    // finite, z is still refused (and named before the bad mean of h
    // would be: the means first)
    let zero_residual = MeasurementSpace(true);
    assert_eq!(
        zero_residual.residual(&Vector1::new(f64::NAN), &z),
        Vector1::zeros()
    );
    let nan = Vector1::new(f64::NAN);
    assert_eq!(
        ukf.update(&prior, &bad_h, Some(&nan)),
        non_finite("sigma-point mean of h", Step::Update)
    );
    let nan_z_only = ZeroResidual;
    assert_eq!(
        ukf.update(&prior, &nan_z_only, Some(&nan)),
        non_finite("measurement z", Step::Update)
    );
    assert_eq!(
        ukf.step(&prior, &plain, &nan_z_only, Some(&nan))
            .map(|s| s.update),
        non_finite("measurement z", Step::Update)
    );
}

/// `h(x) = sin x_0` in a measurement space whose residuals are zero (its
/// mean is plain): a non-finite `z` leaves the outputs finite.
struct ZeroResidual;

/// The space of [`ZeroResidual`].
struct ZeroResidualSpace;

impl bayestrack_kalman::Manifold<1> for ZeroResidualSpace {
    fn residual(&self, _: &Vector1<f64>, _: &Vector1<f64>) -> Vector1<f64> {
        Vector1::zeros()
    }
}

impl bayestrack_kalman::Measurement<2, 1> for ZeroResidual {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0].sin())
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        Matrix1::new(0.01)
    }
    fn measurement_space(&self) -> impl bayestrack_kalman::Manifold<1> {
        ZeroResidualSpace
    }
}

/// When the innovation covariance cannot be factored and an input is bad,
/// the input is named (the checks of the inputs run first, as when each
/// was checked before use): an `h` that is infinite at one sigma point
/// makes both the mean of `h` and `S` non-finite.
#[test]
fn a_bad_sigma_point_mean_is_named_before_the_innovation_covariance() {
    struct Spike;
    impl bayestrack_kalman::Measurement<2, 1> for Spike {
        fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
            Vector1::new(if x[0] > 0.6 { f64::INFINITY } else { x[0] })
        }
        fn measurement_noise(&self) -> Matrix1<f64> {
            Matrix1::new(0.01)
        }
    }
    let prior = Gaussian::new(Vector2::new(0.5, 0.1), Matrix2::identity() * 0.1).unwrap();
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let expected = Err(KalmanError::NonFinite {
        what: "sigma-point mean of h",
        step: Step::Update,
    });
    assert_eq!(
        ukf.update(&prior, &Spike, Some(&Vector1::new(0.4))),
        expected
    );
    // and before a bad z
    assert_eq!(
        ukf.update(&prior, &Spike, Some(&Vector1::new(f64::NAN))),
        expected
    );
}
