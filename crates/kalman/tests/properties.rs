//! Property tests on random symmetric positive-definite matrices.

use bayestrack_kalman::{CovarianceUpdate, Gaussian, Kf, LinearMeasurement, Ukf};
use bayestrack_testkit::strategies::spd3;
use nalgebra::{Matrix2, Matrix2x3, Matrix2x4, Matrix4, Vector2, Vector3, Vector4};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// The Joseph form stays positive semi-definite to round-off, relative to
/// the posterior's own scale, when a very precise measurement collapses the
/// covariance by up to twenty orders of magnitude.
#[test]
fn joseph_form_stays_positive_semi_definite_under_precise_measurements() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let a = Matrix4::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let scale = 10f64.powf(rng.random_range(0.0..8.0));
        let p = (a * a.transpose() + Matrix4::identity() * 1e-3) * scale;
        let p = (p + p.transpose()) * 0.5;
        let h = Matrix2x4::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let r = Matrix2::identity() * 10f64.powf(rng.random_range(-12.0..0.0));
        let prior = Gaussian::new(Vector4::zeros(), p).unwrap();
        let sensor = LinearMeasurement::new(h, r).unwrap();
        let u = Kf::new(CovarianceUpdate::Joseph)
            .update(&prior, &sensor, Some(&Vector2::new(0.1, -0.2)))
            .unwrap();
        let post = u.posterior.cov();
        worst = worst.min(post.symmetric_eigenvalues().min() / post.amax());
    }
    assert!(worst > -1e-13, "{worst:e}");
}

proptest! {
    #[test]
    fn update_never_increases_uncertainty(
        p in spd3(),
        h in prop::array::uniform6(-2.0f64..2.0),
        r in 0.01f64..3.0,
        z in prop::array::uniform2(-5.0f64..5.0),
    ) {
        let prior = Gaussian::new(Vector3::new(0.3, -0.1, 1.0), p).unwrap();
        let sensor = LinearMeasurement::new(Matrix2x3::from_row_slice(&h), Matrix2::identity() * r).unwrap();
        let z = Vector2::from(z);
        for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Standard] {
            let u = Kf::new(form).update(&prior, &sensor, Some(&z)).unwrap();
            // P - P+ is positive semi-definite, P+ is symmetric and PSD
            let shrink = (p - u.posterior.cov()).symmetric_eigenvalues();
            prop_assert!(shrink.min() > -1e-9 * p.amax());
            prop_assert!(u.posterior.cov().symmetric_eigenvalues().min() > -1e-9 * p.amax());
            prop_assert_eq!(u.posterior.cov(), &u.posterior.cov().transpose());
            let inn = u.innovation.unwrap();
            prop_assert!(inn.nis >= 0.0 && inn.log_likelihood().is_finite());
        }
    }

    #[test]
    fn ukf_update_equals_kf_update_for_linear_h(
        p in spd3(),
        h in prop::array::uniform6(-2.0f64..2.0),
        r in 0.01f64..3.0,
        alpha in 0.1f64..1.5,
        kappa in 0.0f64..3.0,
    ) {
        let prior = Gaussian::new(Vector3::new(1.0, 2.0, -1.0), p).unwrap();
        let sensor = LinearMeasurement::new(Matrix2x3::from_row_slice(&h), Matrix2::identity() * r).unwrap();
        let z = Vector2::new(0.5, -0.5);
        let a = Kf::default().update(&prior, &sensor, Some(&z)).unwrap();
        let b = Ukf::new(alpha, 2.0, kappa).unwrap().update(&prior, &sensor, Some(&z)).unwrap();
        let scale = p.amax().max(1.0);
        prop_assert!((a.posterior.mean() - b.posterior.mean()).amax() < 1e-8 * scale);
        prop_assert!((a.posterior.cov() - b.posterior.cov()).amax() < 1e-8 * scale);
    }
}
