//! Property tests on hostile input: random matrices (indefinite,
//! asymmetric, singular, at huge and tiny scales) and measurements through
//! every filter. Nothing panics, and whatever comes back `Ok` is finite,
//! symmetric and has no negative variance.

use bayestrack_kalman::{
    Dynamics, DynamicsJacobian, Ekf, Gaussian, Iekf, Kf, LinearDynamics, LinearMeasurement,
    Measurement, MeasurementJacobian, SqrtGaussian, SrUkf, Ukf, Update, chi_square_cdf,
    chi_square_quantile,
};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use proptest::prelude::*;

use bayestrack_kalman::Additive;
use bayestrack_testkit::strategies::{cases, extreme_f64, psd3, psd3_of, spd3};

/// A number at any scale from 1e-300 to 1e300, either sign, sometimes 0.
fn scaled() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => (-1.0f64..1.0, -300i32..300).prop_map(|(m, e)| m * 10f64.powi(e)),
        4 => -10.0f64..10.0,
        1 => Just(0.0),
    ]
}

/// A 3x3 matrix: symmetric PSD (possibly singular), symmetric indefinite,
/// or arbitrary, at a random scale.
fn matrix3() -> impl Strategy<Value = Matrix3<f64>> {
    (
        prop::array::uniform9(-2.0f64..2.0),
        0usize..4,
        -300i32..300,
        0u8..3,
    )
        .prop_map(|(a, rank, e, kind)| {
            let s = 10f64.powi(e);
            let m = Matrix3::from_row_slice(&a);
            match kind {
                // rank `rank` PSD: sum of `rank` outer products
                0 => psd3_of(a, rank) * s,
                1 => (m + m.transpose()) * s,
                _ => m * s,
            }
        })
}

/// Finite, symmetric, and no variance below round-off of `scale` (the
/// largest covariance entry the filter started from: the UKF's `P - K S
/// K^T` is positive semi-definite only to round-off).
fn finite_gaussian<const N: usize>(g: &Gaussian<N>, scale: f64) -> bool {
    g.mean().iter().all(|v| v.is_finite())
        && g.cov().iter().all(|v| v.is_finite())
        && (0..N).all(|i| g.cov()[(i, i)] >= -1e-9 * scale)
        && g.cov() == &g.cov().transpose()
}

fn finite_update<const N: usize, const M: usize>(u: &Update<N, M>, scale: f64) -> bool {
    finite_gaussian(&u.posterior, scale)
        && u.innovation.as_ref().is_none_or(|i| {
            i.nis.is_finite()
                && i.nis >= 0.0
                && i.log_likelihood().is_finite()
                && i.residual.iter().all(|v| v.is_finite())
        })
}

fn finite_factor<const N: usize>(g: &SqrtGaussian<N>) -> bool {
    let l = g.cholesky_l();
    g.mean().iter().all(|v| v.is_finite())
        && l.iter().all(|v| v.is_finite())
        && (0..N).all(|i| l[(i, i)] >= 0.0 && (i + 1..N).all(|j| l[(i, j)] == 0.0))
}

/// A nonlinear model that hands over whatever noise it holds.
struct Model {
    q: Matrix3<f64>,
    r: Matrix2<f64>,
    h: Matrix2x3<f64>,
}

impl Dynamics<3> for Model {
    fn propagate(&self, x: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(x[0] + 0.1 * x[1], x[1] + 0.1 * x[2].sin(), 0.9 * x[2])
    }
    fn process_noise(&self) -> Matrix3<f64> {
        self.q
    }
}

impl DynamicsJacobian<3> for Model {
    fn jacobian(&self, x: &Vector3<f64>) -> Matrix3<f64> {
        Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.1 * x[2].cos(), 0.0, 0.0, 0.9)
    }
}

impl Measurement<3, 2> for Model {
    fn observe(&self, x: &Vector3<f64>) -> Vector2<f64> {
        self.h * x
    }
    fn measurement_noise(&self) -> Matrix2<f64> {
        self.r
    }
}

impl MeasurementJacobian<3, 2> for Model {
    fn jacobian(&self, _: &Vector3<f64>) -> Matrix2x3<f64> {
        self.h
    }
}

/// A strongly nonlinear model with even components: the sigma points'
/// deviations of `x0^2` are all equal, the case in which a negative
/// covariance weight shows.
struct Even;

impl Dynamics<3> for Even {
    fn propagate(&self, x: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(x[0] * x[0], x[1] * x[2], x[0].cos())
    }
    fn process_noise(&self) -> Matrix3<f64> {
        Matrix3::identity() * 1e-6
    }
}

impl Measurement<3, 2> for Even {
    fn observe(&self, x: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(x[0] * x[0], x[1].abs())
    }
    fn measurement_noise(&self) -> Matrix2<f64> {
        Matrix2::identity() * 1e-4
    }
}

/// Finite, symmetric and positive semi-definite to round-off (smallest
/// eigenvalue above `-1e-9` of the largest entry, or of `scale`: an
/// update's `P - K S K^T` is PSD to the round-off of the prior's `P`).
fn psd_belief(g: &Gaussian<3>, scale: f64) -> bool {
    let cov = g.cov();
    let finite = g.mean().iter().chain(cov.iter()).all(|v| v.is_finite());
    finite
        && cov == &cov.transpose()
        && cov.symmetric_eigenvalues().min() >= -1e-9 * cov.amax().max(scale)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(192), ..ProptestConfig::default() })]

    #[test]
    fn every_filter_answers_hostile_models_with_finite_numbers_or_an_error(
        p in psd3(),
        q in matrix3(),
        r in prop::array::uniform4(scaled()),
        h in prop::array::uniform6(-3.0f64..3.0),
        mean in prop::array::uniform3(scaled()),
        z in prop::array::uniform2(scaled()),
    ) {
        let model = Model {
            q,
            r: Matrix2::from_row_slice(&r),
            h: Matrix2x3::from_row_slice(&h),
        };
        let z = Vector2::from(z);
        let Ok(prior) = Gaussian::new(Vector3::from(mean), p) else {
            return Ok(());
        };
        // the largest covariance a filter starts from or adds
        let scale = p.amax().max(q.amax()).max(model.r.amax());
        let ekf = Ekf::default();
        let iekf = Iekf::new(4, 1e-9).unwrap();
        let ukf = Ukf::new(0.5, 2.0, 0.0).unwrap();
        for predicted in [ekf.predict(&prior, &model), iekf.predict(&prior, &model), ukf.predict(&prior, &model)]
            .into_iter()
            .flatten()
        {
            prop_assert!(finite_gaussian(&predicted, scale), "{predicted:?}");
        }
        for u in [
            ekf.update(&prior, &model, Some(&z)),
            iekf.update(&prior, &model, Some(&z)),
            ukf.update(&prior, &model, Some(&z)),
        ]
        .into_iter()
        .flatten()
        {
            prop_assert!(finite_update(&u, scale), "{u:?}");
        }
        if let Ok(s) = ukf.step(&prior, &model, &model, Some(&z)) {
            prop_assert!(finite_gaussian(&s.predicted, scale) && finite_update(&s.update, scale), "{s:?}");
        }
        // the square-root UKF: a finite lower-triangular factor with a
        // non-negative diagonal, or an error
        if let Ok(sqrt_prior) = SqrtGaussian::from_gaussian(&prior) {
            let sr = SrUkf::new(0.5, 2.0, 0.0).unwrap();
            if let Ok(g) = sr.predict(&sqrt_prior, &model) {
                prop_assert!(finite_factor(&g), "{g:?}");
            }
            if let Ok(u) = sr.update(&sqrt_prior, &model, Some(&z)) {
                prop_assert!(finite_factor(&u.posterior), "{u:?}");
                let i = u.innovation.unwrap();
                prop_assert!(
                    i.nis.is_finite() && i.nis >= 0.0 && i.log_likelihood().is_finite()
                        && i.residual.iter().all(|v| v.is_finite()),
                    "{u:?}"
                );
            }
        }
        // the linear filter, when the constructors accept the matrices
        let f = Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 1.0);
        let linear = LinearDynamics::new(f, q).and_then(|d| {
            let m = LinearMeasurement::new(model.h, model.r)?;
            Ok((Kf::default().predict(&prior, &d)?, m))
        });
        if let Ok((pr, m)) = linear {
            prop_assert!(finite_gaussian(&pr, scale), "{pr:?}");
            if let Ok(u) = Kf::default().update(&pr, &m, Some(&z)) {
                prop_assert!(finite_update(&u, scale), "{u:?}");
            }
        }
    }

    #[test]
    fn chi_square_functions_take_any_number(x in any::<f64>(), k in any::<f64>(), p in any::<f64>()) {
        if let Ok(c) = chi_square_cdf(x, k) {
            prop_assert!((0.0..=1.0).contains(&c), "cdf({x}, {k}) = {c}");
        }
        if let Ok(q) = chi_square_quantile(p, k.abs().min(1e6)) {
            prop_assert!(q.is_finite() && q >= 0.0, "quantile({p}, {k}) = {q}");
        }
    }

    #[test]
    fn chi_square_functions_take_extreme_numbers(x in extreme_f64(), k in extreme_f64(), p in extreme_f64()) {
        if let Ok(c) = chi_square_cdf(x, k) {
            prop_assert!((0.0..=1.0).contains(&c), "cdf({x}, {k}) = {c}");
        }
        if let Ok(q) = chi_square_quantile(p, k) {
            prop_assert!(q.is_finite() && q >= 0.0, "quantile({p}, {k}) = {q}");
            let c = chi_square_cdf(q, k).unwrap();
            // below 1e-300 the CDF of a small k steps by more than 1e-6
            // between neighbouring floats
            prop_assert!((c - p).abs() < 1e-6 || q < 1e-300, "cdf(quantile({p}, {k})) = {c}");
        }
    }

    /// Densities at any point of any belief: an error or a finite number.
    #[test]
    fn densities_are_finite_or_an_error(
        mean in prop::array::uniform3(extreme_f64()),
        x in prop::array::uniform3(extreme_f64()),
        p in psd3(),
    ) {
        let Ok(g) = Gaussian::new(Vector3::from(mean), p) else {
            return Ok(());
        };
        let x = Vector3::from(x);
        if let Ok(l) = g.log_pdf(&x) {
            prop_assert!(l.is_finite(), "log_pdf = {l}");
        }
        if let Ok(d) = g.mahalanobis_sq(&x) {
            prop_assert!(d.is_finite() && d >= 0.0, "mahalanobis_sq = {d}");
        }
    }

    /// Issue 28: any `(alpha, beta, kappa)` the UKF accepts gives finite
    /// weights that sum to 1 and a positive semi-definite covariance for
    /// every model, in the additive and the augmented forms.
    #[test]
    fn ukf_parameters_give_finite_weights_and_psd_covariances_or_an_error(
        alpha in prop_oneof![extreme_f64(), 1e-5f64..3.0],
        beta in prop_oneof![extreme_f64(), -3.0f64..3.0],
        kappa in prop_oneof![extreme_f64(), -6.0f64..6.0],
        p in spd3(),
        e in -8i32..8,
        mean in prop::array::uniform3(-3.0f64..3.0),
    ) {
        let Ok(ukf) = Ukf::new(alpha, beta, kappa) else {
            return Ok(());
        };
        for l in 1..12 {
            if let Ok((wm0, wc0, wi)) = ukf.weights(l) {
                prop_assert!(wm0.is_finite() && wc0.is_finite() && wi.is_finite() && wi > 0.0);
                let sum = wm0 + 2.0 * l as f64 * wi;
                prop_assert!((sum - 1.0).abs() <= 1e-9 * (1.0 + wm0.abs()), "weights sum to {sum}");
            }
        }
        let prior = Gaussian::new(Vector3::from(mean), p * 10f64.powi(e)).unwrap();
        let z = Vector2::new(1.0, 0.5);
        let scale = prior.cov().amax();
        if let Ok(g) = ukf.predict(&prior, &Even) {
            prop_assert!(psd_belief(&g, 0.0), "predict {alpha} {beta} {kappa}: {g:?}");
        }
        if let Ok(u) = ukf.update(&prior, &Even, Some(&z)) {
            prop_assert!(psd_belief(&u.posterior, scale), "update {alpha} {beta} {kappa}: {u:?}");
        }
        if let Ok(g) = ukf.predict_augmented(&prior, &Additive(&Even)) {
            prop_assert!(psd_belief(&g, 0.0), "augmented {alpha} {beta} {kappa}: {g:?}");
        }
        if let Ok(s) = ukf.step_augmented(&prior, &Additive(&Even), &Additive(&Even), Some(&z)) {
            let scale = s.predicted.cov().amax();
            prop_assert!(psd_belief(&s.predicted, 0.0) && psd_belief(&s.update.posterior, scale), "{s:?}");
        }
    }
}
