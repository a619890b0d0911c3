//! The cubature Kalman filter against a direct implementation of the
//! third-degree spherical-radial rule (Arasaratnam and Haykin 2009,
//! eq. 38-40 and the filter of sec. IV): `2n` points `m +- sqrt(n) S e_i`
//! of weight `1 / (2n)`, moments as plain weighted sums about the mean.

use bayestrack_kalman::{Ckf, FnDynamics, FnMeasurement, Gaussian, KalmanError, Ukf, batch_filter};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

/// Cubature points of `N(m, p)`.
fn points<const N: usize>(m: &SVector<f64, N>, p: &SMatrix<f64, N, N>) -> Vec<SVector<f64, N>> {
    let s = p.cholesky().unwrap().l() * (N as f64).sqrt();
    (0..N)
        .flat_map(|i| [m + s.column(i), m - s.column(i)])
        .collect()
}

fn f(x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        x[0] + 0.1 * x[1].sin(),
        x[1] + 0.1 * x[2],
        0.9 * x[2] + 0.05 * x[0] * x[0],
    )
}

fn h(x: &Vector3<f64>) -> Vector2<f64> {
    Vector2::new(x[0].hypot(x[1]), x[1].atan2(x[0]))
}

fn q() -> Matrix3<f64> {
    Matrix3::new(1e-3, 1e-4, 0.0, 1e-4, 2e-3, 0.0, 0.0, 0.0, 5e-4)
}

fn r() -> Matrix2<f64> {
    Matrix2::new(0.01, 0.0, 0.0, 1e-4)
}

/// One cubature predict + update, written out.
fn reference(prior: &Gaussian<3>, z: &Vector2<f64>) -> (Gaussian<3>, Gaussian<3>) {
    let w = 1.0 / 6.0;
    let xs: Vec<_> = points(prior.mean(), prior.cov()).iter().map(f).collect();
    let xm = xs.iter().fold(Vector3::zeros(), |a, x| a + x * w);
    let pp = xs
        .iter()
        .fold(q(), |a, x| a + (x - xm) * (x - xm).transpose() * w);
    let predicted = Gaussian::new(xm, (pp + pp.transpose()) * 0.5).unwrap();
    let xs = points(&xm, predicted.cov());
    let zs: Vec<_> = xs.iter().map(h).collect();
    let zm = zs.iter().fold(Vector2::zeros(), |a, z| a + z * w);
    let s = zs
        .iter()
        .fold(r(), |a, z| a + (z - zm) * (z - zm).transpose() * w);
    let pxz = xs
        .iter()
        .zip(&zs)
        .fold(SMatrix::<f64, 3, 2>::zeros(), |a, (x, z)| {
            a + (x - xm) * (z - zm).transpose() * w
        });
    let k = pxz * s.try_inverse().unwrap();
    let mean = xm + k * (z - zm);
    let cov = predicted.cov() - k * s * k.transpose();
    (
        predicted,
        Gaussian::new(mean, (cov + cov.transpose()) * 0.5).unwrap(),
    )
}

#[test]
fn ckf_is_the_cubature_rule() {
    let dynamics = FnDynamics::new(f, q()).unwrap();
    let sensor = FnMeasurement::new(h, r()).unwrap();
    let mut belief = Gaussian::new(
        Vector3::new(3.0, 1.0, 0.2),
        Matrix3::new(0.5, 0.1, 0.0, 0.1, 0.3, 0.05, 0.0, 0.05, 0.2),
    )
    .unwrap();
    for k in 0..10 {
        let t = f64::from(k);
        let z = Vector2::new(3.2 + 0.05 * t, 0.33 + 0.01 * t);
        let (want_pred, want_post) = reference(&belief, &z);
        let pred = Ckf.predict(&belief, &dynamics).unwrap();
        let post = Ckf.update(&pred, &sensor, Some(&z)).unwrap().posterior;
        for (got, want) in [(pred, want_pred), (post, want_post)] {
            assert!((got.mean() - want.mean()).amax() < 1e-12, "{k}");
            assert!((got.cov() - want.cov()).amax() < 1e-12, "{k}");
        }
        belief = post;
    }
}

#[test]
fn ckf_is_the_ukf_with_alpha_1_beta_0_kappa_0_and_not_another() {
    let dynamics = FnDynamics::new(f, q()).unwrap();
    let sensor = FnMeasurement::new(h, r()).unwrap();
    let start = Gaussian::new(Vector3::new(3.0, 1.0, 0.2), Matrix3::identity() * 0.3).unwrap();
    let zs: Vec<_> = (0..8)
        .map(|k| Some(Vector2::new(3.2 + 0.05 * f64::from(k), 0.33)))
        .collect();
    let ckf = batch_filter(&Ckf, &start, &dynamics, &sensor, &zs).unwrap();
    let same = Ukf::new(1.0, 0.0, 0.0).unwrap();
    assert_eq!(
        ckf,
        batch_filter(&same, &start, &dynamics, &sensor, &zs).unwrap()
    );
    // the usual UKF parameters are a different rule: not the same numbers
    let other = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let u = batch_filter(&other, &start, &dynamics, &sensor, &zs).unwrap();
    assert!((ckf.posterior[7].cov() - u.posterior[7].cov()).amax() > 1e-9);
    // errors are the UKF's
    let bad = [Some(Vector2::new(f64::NAN, 0.0))];
    assert!(matches!(
        batch_filter(&Ckf, &start, &dynamics, &sensor, &bad),
        Err(KalmanError::NonFinite { .. })
    ));
}
