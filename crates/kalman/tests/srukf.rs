//! The square-root UKF against the UKF (same sigma points: equal to 1e-9
//! where both are defined), on a large dynamic range where the UKF's
//! covariance loses definiteness and the SR-UKF's factor does not, and its
//! typed errors.

use crate::common;

use bayestrack_kalman::{
    Dynamics, FnDynamics, FnMeasurement, Gaussian, KalmanError, LinearDynamics, LinearMeasurement,
    Measurement, SqrtGaussian, SrUkf, Step, Ukf,
};
use nalgebra::{Matrix1, Matrix2, Matrix2x4, Matrix4, SMatrix, SVector, Vector1, Vector2, Vector4};

/// The pendulum of the benches: dt = 0.01, z = sin theta.
struct Pendulum;

impl Dynamics<2> for Pendulum {
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        Vector2::new(x[0] + 0.01 * x[1], x[1] - 0.01 * 9.81 * x[0].sin())
    }
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::new(1e-8, 0.0, 0.0, 1e-6)
    }
}

impl Measurement<2, 1> for Pendulum {
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        Vector1::new(x[0].sin())
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(0.0025)
    }
}

/// `|a - b| <= tol max(1, |b|)` entry-wise over the whole matrix.
fn close<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    b: &SMatrix<f64, R, C>,
    tol: f64,
    what: &str,
) {
    let err = (a - b).amax();
    assert!(
        err <= tol * b.amax().max(1.0),
        "{what}: differs by {err:e}\n{a}\n{b}"
    );
}

/// Runs the UKF and the SR-UKF side by side over `zs`, comparing the
/// predictions, the posteriors (mean and `L L^T` against `P`) and the
/// covariance `S` at every step to 1e-9, and the innovation, NIS and
/// log-likelihood to 1e-9 for `alpha >= 0.5`, 1e-8 for `alpha = 1e-3`:
/// there the mean of `h` is a sum of deviations weighted by `W_i = 1 /
/// (2 alpha^2 n)` (1e5 and more), which multiplies the round-off in which
/// the two filters' sigma points differ (the UKF factors `c P`, the SR-UKF
/// scales its factor) to 1e-10..2e-9 in the innovation (measured on these
/// models; 1e-15 at `alpha >= 0.5`).
fn compare<const N: usize, const M: usize, D: Dynamics<N>, H: Measurement<N, M>>(
    params: (f64, f64, f64),
    x0: Gaussian<N>,
    dynamics: &D,
    sensor: &H,
    zs: &[Option<SVector<f64, M>>],
) {
    let tol = 1e-9;
    let tol_stats = if params.0 < 0.5 { 1e-8 } else { 1e-9 };
    let ukf = Ukf::new(params.0, params.1, params.2).unwrap();
    let sr = SrUkf::new(params.0, params.1, params.2).unwrap();
    let mut gu = x0;
    let mut gs = SqrtGaussian::from_gaussian(&x0).unwrap();
    for (k, z) in zs.iter().enumerate() {
        let pu = ukf.predict(&gu, dynamics).unwrap();
        let ps = sr.predict(&gs, dynamics).unwrap();
        close(
            ps.mean(),
            pu.mean(),
            tol,
            &format!("step {k} predicted mean"),
        );
        close(&ps.cov(), pu.cov(), tol, &format!("step {k} predicted P"));
        let uu = ukf.update(&pu, sensor, z.as_ref()).unwrap();
        let us = sr.update(&ps, sensor, z.as_ref()).unwrap();
        let post = us.posterior;
        close(
            post.mean(),
            uu.posterior.mean(),
            tol,
            &format!("step {k} mean"),
        );
        close(&post.cov(), uu.posterior.cov(), tol, &format!("step {k} P"));
        let l = post.cholesky_l();
        assert_eq!(l.upper_triangle(), SMatrix::from_diagonal(&l.diagonal()));
        assert_eq!(us.iterations, uu.iterations);
        match (us.innovation, uu.innovation) {
            (Some(a), Some(b)) => {
                close(&a.residual, &b.residual, tol_stats, "innovation");
                close(&a.covariance, &b.covariance, tol, "S");
                let ll = Vector2::new(a.nis, a.log_likelihood());
                close(
                    &ll,
                    &Vector2::new(b.nis, b.log_likelihood()),
                    tol_stats,
                    "NIS, log-likelihood",
                );
            }
            (None, None) => assert_eq!(post, ps, "missing measurement: the prior"),
            _ => panic!("step {k}: one filter has an innovation, the other not"),
        }
        gu = uu.posterior;
        gs = post;
    }
}

/// Measurements of the pendulum from x0 = (0.6, 0), perturbed
/// deterministically, every 7th missing.
fn pendulum_measurements(n: usize) -> Vec<Option<SVector<f64, 1>>> {
    let mut x = Vector2::new(0.6, 0.0);
    (0..n)
        .map(|k| {
            x = Pendulum.propagate(&x);
            let z = x[0].sin() + 0.05 * ((k * 7919 % 101) as f64 / 50.0 - 1.0);
            (k % 7 != 6).then(|| Vector1::new(z))
        })
        .collect()
}

/// The parameter sets compared: van der Merwe's (beta - alpha^2 > 0: the
/// mean-shift term is an update) and two with beta - alpha^2 < 0 (a
/// downdate; alpha = 1, beta = 0, kappa = 0 is the cubature rule).
const PARAMS: [(f64, f64, f64); 3] = [(1e-3, 2.0, 0.0), (1.0, 0.0, 0.0), (0.5, 0.0, 1.0)];

#[test]
fn equals_the_ukf_on_the_pendulum() {
    let zs = pendulum_measurements(50);
    for params in PARAMS {
        let x0 = Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1).unwrap();
        compare(params, x0, &Pendulum, &Pendulum, &zs);
    }
}

#[test]
fn equals_the_ukf_on_a_linear_model() {
    let (dynamics, sensor) = common::constant_velocity(0.1, 0.1, 0.25);
    let zs: Vec<_> = (0..50)
        .map(|k| {
            let t = k as f64 * 0.1;
            Some(Vector2::new(
                t + 0.3 * (7.0 * t).sin(),
                0.5 * t + 0.3 * (5.0 * t).cos(),
            ))
        })
        .collect();
    for params in PARAMS {
        let x0 = Gaussian::new(
            Vector4::new(0.0, 0.0, 1.0, 0.5),
            Matrix4::from_diagonal(&Vector4::new(1.0, 2.0, 0.5, 0.25)),
        )
        .unwrap();
        compare(params, x0, &dynamics, &sensor, &zs);
    }
}

#[test]
fn equals_the_ukf_on_a_turning_target() {
    let model = common::Turn::new();
    let mut x = SVector::<f64, 5>::from([10.0, 5.0, 2.0, 0.3, 0.1]);
    let zs: Vec<_> = (0..30)
        .map(|k| {
            x = model.propagate(&x);
            let z = model.observe(&x);
            let e = ((k * 7919 % 101) as f64 / 50.0 - 1.0) * 0.01;
            Some(SVector::from([z[0] + 10.0 * e, z[1] + e]))
        })
        .collect();
    let p0 = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from([1.0, 1.0, 0.5, 0.1, 0.01]));
    for params in [(1e-3, 2.0, 0.0), (1.0, 0.0, 0.0)] {
        let x0 = Gaussian::new(SVector::from([10.0, 5.0, 2.0, 0.3, 0.1]), p0).unwrap();
        compare(params, x0, &model, &model, &zs);
    }
}

/// Two position-velocity pairs with variances 1e8 (positions) and 1e-8
/// (velocities), positions measured with variance 1e-10: the UKF's
/// `P - K S K^T` cancels 1e8 down to 1e-10, below its round-off (1e-8),
/// and the posterior covariance has a negative eigenvalue (its next
/// prediction cannot draw sigma points); the SR-UKF's posterior factor
/// comes from rotations alone and stays valid and accurate.
#[test]
fn keeps_a_valid_factor_where_the_ukf_loses_definiteness() {
    let mut f = Matrix4::identity();
    f[(0, 1)] = 1.0;
    f[(2, 3)] = 1.0;
    let dynamics = LinearDynamics::new(f, Matrix4::zeros()).unwrap();
    let r = 1e-10;
    let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let sensor = LinearMeasurement::new(h, Matrix2::identity() * r).unwrap();
    let p0 = Matrix4::from_diagonal(&Vector4::new(1e8, 1e-8, 1e8, 1e-8));
    let x0 = Gaussian::new(Vector4::new(1.0, 0.1, -2.0, 0.2), p0).unwrap();
    // the truth: velocities 0.1 and 0.2 from positions 1 and -2
    let truth = |k: usize| {
        let t = (k + 1) as f64;
        Vector4::new(1.0 + 0.1 * t, 0.1, -2.0 + 0.2 * t, 0.2)
    };
    let z = |k: usize| {
        let x = truth(k);
        Vector2::new(x[0], x[2])
    };

    let ukf = Ukf::new(1e-3, 2.0, 0.0).unwrap();
    let prior = ukf.predict(&x0, &dynamics).unwrap();
    let post = ukf.update(&prior, &sensor, Some(&z(0))).unwrap().posterior;
    let min_eig = post.cov().symmetric_eigen().eigenvalues.min();
    assert!(min_eig < 0.0, "the UKF's posterior stays PSD: {min_eig:e}");
    assert!(post.cov().cholesky().is_none());
    assert!(matches!(
        ukf.predict(&post, &dynamics),
        Err(KalmanError::NotPositiveDefinite {
            step: Step::Predict,
            ..
        })
    ));

    let sr = SrUkf::new(1e-3, 2.0, 0.0).unwrap();
    let mut belief = SqrtGaussian::from_gaussian(&x0).unwrap();
    for k in 0..20 {
        let prior = sr.predict(&belief, &dynamics).unwrap();
        let update = sr.update(&prior, &sensor, Some(&z(k))).unwrap();
        belief = update.posterior;
        let l = belief.cholesky_l();
        assert!(l.iter().all(|x| x.is_finite()));
        assert!(l.diagonal().min() > 0.0, "step {k}: singular factor\n{l}");
        // a valid density whose variances are those of the problem: the
        // measured positions at most R (and more than R / (k + 2), the
        // variance of k + 1 exact-velocity averages), the velocities at
        // most their prior 1e-8
        assert!(belief.factor().is_ok());
        let p = belief.cov();
        for i in [0, 2] {
            assert!(
                p[(i, i)] <= r * (1.0 + 1e-6) && p[(i, i)] > r / (k as f64 + 2.0),
                "step {k}: position variance {:e}",
                p[(i, i)]
            );
        }
        for i in [1, 3] {
            assert!(
                p[(i, i)] > 0.0 && p[(i, i)] <= 1e-8 * (1.0 + 1e-6),
                "step {k}: velocity {:e}",
                p[(i, i)]
            );
        }
        // noise-free measurements: the mean is the truth to within its
        // standard deviations
        let err = belief.mean() - truth(k);
        assert!(
            err[0].abs() < 1e-5 && err[2].abs() < 1e-5,
            "step {k}: {err}"
        );
        let nis = update.innovation.unwrap().nis;
        assert!(nis.is_finite() && nis >= 0.0);
    }
    // after 20 steps the velocities are known from the positions
    let err = belief.mean() - truth(19);
    assert!(err[1].abs() < 1e-5 && err[3].abs() < 1e-5, "{err}");
}

#[test]
fn a_downdate_that_loses_definiteness_is_a_typed_error() {
    // cubature weights (beta - alpha^2 = -1, a downdate) and an even f with
    // no process noise: the exact predicted covariance is 0, and the
    // downdate of the factor to a singular one is an error, not a NaN
    let sr = SrUkf::new(1.0, 0.0, 0.0).unwrap();
    let square = FnDynamics::new(
        |x: &SVector<f64, 1>| Vector1::new(x[0] * x[0]),
        Matrix1::zeros(),
    )
    .unwrap();
    let belief = SqrtGaussian::new(Vector1::new(0.0), Matrix1::new(1.0)).unwrap();
    assert_eq!(
        sr.predict(&belief, &square),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "predicted covariance",
            step: Step::Predict
        })
    );
    // van der Merwe's weights (an update) give the exact singular answer
    let vdm = SrUkf::new(1e-3, 2.0, 0.0).unwrap();
    let p = vdm.predict(&belief, &square).unwrap();
    assert!(p.cholesky_l()[(0, 0)].is_finite());
}

#[test]
fn bad_inputs_are_typed_errors() {
    let sr = SrUkf::new(1e-3, 2.0, 0.0).unwrap();
    let belief = SqrtGaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.3).unwrap();
    // a measurement that does not depend on the state, without noise
    let blind =
        FnMeasurement::new(|_: &SVector<f64, 2>| Vector1::new(1.0), Matrix1::zeros()).unwrap();
    assert_eq!(
        sr.update(&belief, &blind, Some(&Vector1::new(1.0))),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "innovation covariance S",
            step: Step::Update
        })
    );
    assert_eq!(
        sr.update(&belief, &Pendulum, Some(&Vector1::new(f64::NAN))),
        Err(KalmanError::NonFinite {
            what: "measurement z",
            step: Step::Update
        })
    );
    let missing = sr.update(&belief, &Pendulum, None).unwrap();
    assert_eq!(missing.posterior, belief);
    assert!(missing.innovation.is_none());
    assert_eq!(missing.iterations, 0);
    // a model whose Q is indefinite, checked where the filter uses it
    struct BadQ;
    impl Dynamics<2> for BadQ {
        fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
            *x
        }
        fn process_noise(&self) -> SMatrix<f64, 2, 2> {
            Matrix2::new(1.0, 2.0, 2.0, 1.0)
        }
    }
    let bad_q = BadQ;
    assert!(matches!(
        sr.predict(&belief, &bad_q),
        Err(KalmanError::NotPositiveDefinite {
            matrix: "process noise Q",
            ..
        })
    ));
    assert!(matches!(
        SqrtGaussian::new(Vector2::new(0.0, f64::INFINITY), Matrix2::identity()),
        Err(KalmanError::NonFinite { what: "mean", .. })
    ));
    assert!(SrUkf::new(0.0, 2.0, 0.0).is_err());
    // a singular factor is a belief but not a density
    let singular = SqrtGaussian::new(Vector2::zeros(), Matrix2::new(1.0, 0.0, 0.0, 0.0)).unwrap();
    assert!(singular.factor().is_err());
    // the upper triangle is ignored and negative pivots flip their column
    let g = SqrtGaussian::new(Vector2::zeros(), Matrix2::new(-2.0, 5.0, 1.0, 3.0)).unwrap();
    assert_eq!(*g.cholesky_l(), Matrix2::new(2.0, 0.0, -1.0, 3.0));
    let as_gaussian: Gaussian<2> = g.into();
    assert_eq!(*as_gaussian.cov(), Matrix2::new(4.0, -2.0, -2.0, 10.0));
}
