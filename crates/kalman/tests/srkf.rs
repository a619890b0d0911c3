//! The square-root KF equals the KF (1e-10), through `batch_filter` in its
//! own belief form; typed errors. filterpy's `SquareRootKalmanFilter` is
//! the oracle of `tests/filterpy_imm.rs`.

use bayestrack_kalman::nalgebra::{Matrix2, Matrix4, Vector2, Vector4};
use bayestrack_kalman::{
    Belief, Gaussian, KalmanError, Kf, LinearDynamics, LinearMeasurement, NoiseModel, SqrtGaussian,
    SrKf, Step, batch_filter,
};

fn zs() -> Vec<Option<Vector2<f64>>> {
    (0..80)
        .map(|k| {
            let t = k as f64 * 0.1;
            (k % 7 != 3).then_some(Vector2::new(
                t + (3.1 * t).sin() * 0.3,
                0.5 * t - (1.3 * t).cos(),
            ))
        })
        .collect()
}

#[test]
fn square_root_kf_equals_kf() {
    let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.7, NoiseModel::Discrete).unwrap();
    let sensor =
        LinearMeasurement::<4, 2>::position_with_noise(Matrix2::new(0.25, 0.05, 0.05, 0.5))
            .unwrap();
    let start = Gaussian::new(
        Vector4::new(0.0, 1.0, -1.0, 0.5),
        Matrix4::from_diagonal(&Vector4::new(4.0, 1.0, 4.0, 1.0)),
    )
    .unwrap();
    let kf = batch_filter(&Kf::default(), &start, &dynamics, &sensor, &zs()).unwrap();
    let sr_start = SqrtGaussian::from_gaussian(&start).unwrap();
    let sr = batch_filter(&SrKf, &sr_start, &dynamics, &sensor, &zs()).unwrap();
    for k in 0..kf.posterior.len() {
        for (a, b) in [
            (&kf.predicted[k], &sr.predicted[k]),
            (&kf.posterior[k], &sr.posterior[k]),
        ] {
            assert!((a.mean() - b.mean()).amax() < 1e-10, "mean {k}");
            assert!((a.cov() - b.covariance()).amax() < 1e-10, "cov {k}");
        }
        match (&kf.innovations[k], &sr.innovations[k]) {
            (Some(a), Some(b)) => {
                assert!((a.log_likelihood() - b.log_likelihood()).abs() < 1e-10);
                assert!((a.nis - b.nis).abs() < 1e-10);
                assert!((a.covariance - b.covariance).amax() < 1e-10);
            }
            (None, None) => {}
            other => panic!("{other:?}"),
        }
    }
    assert!((kf.log_likelihood() - sr.log_likelihood()).abs() < 1e-9);
    // the factor stays lower triangular with a non-negative diagonal
    for g in &sr.posterior {
        let l = g.cholesky_l();
        assert_eq!(
            l.upper_triangle() - Matrix4::from_diagonal(&l.diagonal()),
            Matrix4::zeros()
        );
        assert!(l.diagonal().iter().all(|d| *d >= 0.0));
    }
}

#[test]
fn bad_inputs_are_typed_errors() {
    let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.7, NoiseModel::Discrete).unwrap();
    let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity()).unwrap();
    let prior = SqrtGaussian::new(Vector4::zeros(), Matrix4::identity()).unwrap();
    assert_eq!(
        SrKf.update(&prior, &sensor, Some(&Vector2::new(f64::NAN, 0.0))),
        Err(KalmanError::NonFinite {
            what: "measurement z",
            step: Step::Update
        })
    );
    // a factor whose propagation overflows
    let huge = SqrtGaussian::new(Vector4::repeat(1e308), Matrix4::identity() * 1e308).unwrap();
    assert!(matches!(
        SrKf.predict(&huge, &dynamics),
        Err(KalmanError::NonFinite {
            step: Step::Predict,
            ..
        })
    ));
    // a singular S: zero noise and a factor that does not reach the
    // measured coordinates
    let exact = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::zeros()).unwrap();
    let known = SqrtGaussian::new(Vector4::zeros(), Matrix4::zeros()).unwrap();
    assert_eq!(
        SrKf.update(&known, &exact, Some(&Vector2::zeros())),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "innovation covariance S",
            step: Step::Update
        })
    );
    // missing: the prior
    assert_eq!(SrKf.update(&prior, &sensor, None).unwrap().posterior, prior);
}

/// `log_likelihood()` is `log N(nu; 0, S)` from the update's own residual and
/// `S`, for the KF (pivots of `S = L D L^T`) and the square-root KF
/// (Cholesky diagonal), also where the product of the pivots underflows
/// (`det S` about 1e-400: the sum of logarithms) or overflows.
#[test]
fn log_likelihood_is_the_innovation_density() {
    for scale in [1.0, 1e-200, 1e200] {
        let r = Matrix2::new(0.25, 0.05, 0.05, 0.5) * scale;
        let sensor = LinearMeasurement::<4, 2>::position_with_noise(r).unwrap();
        let start = Gaussian::new(
            Vector4::new(0.0, 1.0, -1.0, 0.5),
            Matrix4::from_diagonal(&Vector4::new(4.0, 1.0, 4.0, 1.0)) * scale,
        )
        .unwrap();
        let z = Vector2::new(0.3, -0.2) * scale.sqrt();
        let kf = Kf::default().update(&start, &sensor, Some(&z)).unwrap();
        let sr_start = SqrtGaussian::from_gaussian(&start).unwrap();
        let sr = SrKf.update(&sr_start, &sensor, Some(&z)).unwrap();
        for inn in [kf.innovation.unwrap(), sr.innovation.unwrap()] {
            let s = inn.covariance;
            let nu = inn.residual;
            // log det S from the closed form of a 2x2 determinant, scaled
            // out so that it stays representable
            let det = (s / scale).determinant();
            let log_det = det.ln() + 2.0 * scale.ln();
            let s_inv = (s / scale).try_inverse().unwrap() / scale;
            let nis = (nu.transpose() * s_inv * nu)[(0, 0)];
            let expected = -0.5 * (nis + log_det + 2.0 * (2.0 * std::f64::consts::PI).ln());
            assert!(
                (inn.log_det() - log_det).abs() < 1e-12 * log_det.abs().max(1.0),
                "{scale}"
            );
            assert!(
                (inn.log_likelihood() - expected).abs() < 1e-12 * expected.abs().max(1.0),
                "{scale}: {} vs {expected}",
                inn.log_likelihood()
            );
            assert!((inn.nis - nis).abs() < 1e-12 * nis.max(1.0));
        }
    }
}
