//! Issue 28's class "a library call returns Ok with NaN, inf or a negative
//! variance", swept over the toolbox types (Imm, SrKf, SrUkf, Ckf, the RTS
//! smoothers, batch_smooth, fixed_lag_smooth, Belief::mix): every public
//! constructor and numeric entry point gets extreme inputs (1e308, 1e-300,
//! subnormals, NaN, infinities, negative variances) and must return a typed
//! error or a finite, valid result. Nothing may panic.

use bayestrack_kalman::{
    Belief, Ckf, Dynamics, DynamicsJacobian, Ekf, Gaussian, Imm, ImmBelief, Kf, LinearDynamics,
    LinearMeasurement, Measurement, Mode, ModeBelief, RtsSmoother, SqrtGaussian, SrKf, SrUkf, Ukf,
    batch_filter, batch_smooth, fixed_lag_smooth,
};
use bayestrack_testkit::strategies::{cases, extreme_f64};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
use proptest::prelude::*;

/// An extreme value, or an ordinary one (so that some calls succeed).
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => extreme_f64(),
        2 => (-1.0f64..1.0, -300i32..300).prop_map(|(m, e)| m * 10f64.powi(e)),
        3 => -2.0f64..2.0,
    ]
}

fn vec2() -> impl Strategy<Value = Vector2<f64>> {
    (value(), value()).prop_map(|(a, b)| Vector2::new(a, b))
}

/// Arbitrary entries, or a symmetric PSD matrix `A A^T` at an extreme
/// scale, or a diagonal one with possibly negative variances.
fn mat2() -> impl Strategy<Value = Matrix2<f64>> {
    prop_oneof![
        (value(), value(), value(), value()).prop_map(|(a, b, c, d)| Matrix2::new(a, b, c, d)),
        (value(), value(), value(), value()).prop_map(|(a, b, c, s)| {
            let m = Matrix2::new(a, b, 0.0, c);
            m * m.transpose() * s.abs()
        }),
        (value(), value()).prop_map(|(a, b)| Matrix2::new(a, 0.0, 0.0, b)),
    ]
}

/// The largest magnitude in the inputs (the round-off scale of a variance).
fn scale(ms: &[&Matrix2<f64>]) -> f64 {
    ms.iter()
        .flat_map(|m| m.iter())
        .fold(f64::MIN_POSITIVE, |a, b| a.max(b.abs()))
}

/// Finite, symmetric (to the relative 1e-9 that `Gaussian::new` accepts),
/// no variance below the round-off of `scale`.
fn valid(g: &Gaussian<2>, scale: f64) -> bool {
    let c = g.cov();
    g.mean().iter().chain(c.iter()).all(|v| v.is_finite())
        && (c[(0, 1)] - c[(1, 0)]).abs() <= 1e-9 * c.amax()
        && (0..2).all(|i| c[(i, i)] >= -1e-9 * scale)
}

/// A finite lower-triangular factor with a non-negative diagonal.
fn valid_sqrt(g: &SqrtGaussian<2>) -> bool {
    let l = g.cholesky_l();
    g.mean().iter().chain(l.iter()).all(|v| v.is_finite())
        && l[(0, 1)] == 0.0
        && l[(0, 0)] >= 0.0
        && l[(1, 1)] >= 0.0
}

fn valid_innovation(i: &Option<bayestrack_kalman::Innovation<1>>) -> bool {
    i.as_ref().is_none_or(|i| {
        i.nis.is_finite()
            && i.nis >= 0.0
            && i.log_likelihood().is_finite()
            && i.residual.iter().all(|v| v.is_finite())
            && i.covariance.iter().all(|v| v.is_finite())
    })
}

/// A mildly nonlinear model holding whatever noise it is given.
struct Model {
    q: Matrix2<f64>,
    r: f64,
}

impl Dynamics<2> for Model {
    fn propagate(&self, x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(x[0] + 0.1 * x[1], x[1] - 0.1 * x[0].sin())
    }
    fn process_noise(&self) -> Matrix2<f64> {
        self.q
    }
}

impl DynamicsJacobian<2> for Model {
    fn jacobian(&self, x: &Vector2<f64>) -> Matrix2<f64> {
        Matrix2::new(1.0, 0.1, -0.1 * x[0].cos(), 1.0)
    }
}

impl Measurement<2, 1> for Model {
    fn observe(&self, x: &Vector2<f64>) -> Vector1<f64> {
        Vector1::new(x[0])
    }
    fn measurement_noise(&self) -> Matrix1<f64> {
        Matrix1::new(self.r)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(256)))]

    /// `SqrtGaussian::new` / `from_gaussian`, then `SrKf` predict and
    /// update on linear models built from extreme matrices.
    #[test]
    fn srkf_never_returns_a_bad_factor(
        mean in vec2(), l in mat2(), f in mat2(), q in mat2(), r in value(), z in value(),
    ) {
        let Ok(belief) = SqrtGaussian::new(mean, l) else { return Ok(()) };
        prop_assert!(valid_sqrt(&belief));
        if let Ok(g) = Gaussian::new(mean, l * l.transpose())
            && let Ok(s) = SqrtGaussian::from_gaussian(&g)
        {
            prop_assert!(valid_sqrt(&s));
        }
        let Ok(dynamics) = LinearDynamics::new(f, q) else { return Ok(()) };
        let Ok(sensor) = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(r)) else {
            return Ok(());
        };
        if let Ok(prior) = SrKf.predict(&belief, &dynamics) {
            prop_assert!(valid_sqrt(&prior), "{prior:?}");
            if let Ok(u) = SrKf.update(&prior, &sensor, Some(&Vector1::new(z))) {
                prop_assert!(valid_sqrt(&u.posterior), "{u:?}");
                prop_assert!(valid_innovation(&u.innovation), "{u:?}");
            }
        }
    }

    /// `SrUkf::new` with any parameters, then predict and update.
    #[test]
    fn srukf_never_returns_a_bad_factor(
        alpha in value(), beta in value(), kappa in value(),
        mean in vec2(), l in mat2(), q in mat2(), r in value(), z in value(),
    ) {
        let Ok(filter) = SrUkf::new(alpha, beta, kappa) else { return Ok(()) };
        let Ok(belief) = SqrtGaussian::new(mean, l) else { return Ok(()) };
        let model = Model { q, r };
        if let Ok(prior) = filter.predict(&belief, &model) {
            prop_assert!(valid_sqrt(&prior), "{prior:?}");
            if let Ok(u) = filter.update(&prior, &model, Some(&Vector1::new(z))) {
                prop_assert!(valid_sqrt(&u.posterior), "{u:?}");
                prop_assert!(valid_innovation(&u.innovation), "{u:?}");
            }
        }
    }

    /// `Ckf` predict and update.
    #[test]
    fn ckf_never_returns_a_bad_belief(
        mean in vec2(), p in mat2(), q in mat2(), r in value(), z in value(),
    ) {
        let Ok(belief) = Gaussian::new(mean, p) else { return Ok(()) };
        let model = Model { q, r };
        let s = scale(&[&p, &q]).max(r.abs());
        if let Ok(prior) = Ckf.predict(&belief, &model) {
            prop_assert!(valid(&prior, s), "{prior:?}");
            if let Ok(u) = Ckf.update(&prior, &model, Some(&Vector1::new(z))) {
                prop_assert!(valid(&u.posterior, scale(&[prior.cov()]).max(s)), "{u:?}");
                prop_assert!(valid_innovation(&u.innovation), "{u:?}");
            }
        }
    }

    /// `Belief::mix` in both forms, with any weights and components.
    #[test]
    fn mix_never_returns_a_bad_belief(
        w in value(), m1 in vec2(), p1 in mat2(), m2 in vec2(), p2 in mat2(), raw in any::<bool>(),
    ) {
        // complementary weights (so that some sum to 1), or raw ones
        let weights = if raw { [w, w] } else { [w, 1.0 - w] };
        let g1 = Gaussian::new(m1, p1);
        let g2 = Gaussian::new(m2, p2);
        let (Ok(g1), Ok(g2)) = (g1, g2) else { return Ok(()) };
        let mut components = vec![ModeBelief::Full(g1)];
        components.push(match SqrtGaussian::from_gaussian(&g2) {
            Ok(s) => ModeBelief::Sqrt(s),
            Err(_) => ModeBelief::Full(g2),
        });
        let s = scale(&[&p1, &p2, &(m1 * m1.transpose()), &(m2 * m2.transpose())]);
        if let Ok(g) = <Gaussian<2> as Belief<2>>::mix(&weights, &components) {
            prop_assert!(valid(&g, s), "{g:?}");
        }
        if let Ok(g) = <SqrtGaussian<2> as Belief<2>>::mix(&weights, &components) {
            prop_assert!(valid_sqrt(&g), "{g:?}");
        }
    }

    /// `Imm::new`, `Imm::start`, `Imm::step` and the estimate.
    #[test]
    fn imm_never_returns_bad_probabilities(
        t in prop::array::uniform4(value()), mu in value(), mean in vec2(), p in mat2(),
        q in mat2(), r in value(), z in value(), sticky in any::<bool>(),
    ) {
        let transition = if sticky { [0.9, 0.1, t[0], 1.0 - t[0]] } else { t };
        let Ok(dynamics) = LinearDynamics::new(Matrix2::new(1.0, 0.1, 0.0, 1.0), q) else {
            return Ok(());
        };
        let Ok(sensor) = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(r)) else {
            return Ok(());
        };
        let Ok(imm) = Imm::new(
            vec![
                Box::new(Mode::new(Kf::default(), dynamics, sensor)),
                Box::new(Mode::new(SrUkf::new(1.0, 2.0, 0.0).unwrap(), dynamics, sensor)),
            ],
            &transition,
        ) else { return Ok(()) };
        let Ok(start) = Gaussian::new(mean, p) else { return Ok(()) };
        let Ok(belief) = imm.start(&[mu, 1.0 - mu], &start) else { return Ok(()) };
        let check = |b: &ImmBelief<2>| {
            let total: f64 = b.probabilities().iter().sum();
            b.probabilities().iter().all(|p| p.is_finite() && *p >= 0.0)
                && (total - 1.0).abs() < 1e-9
                && b.modes().iter().all(|m| {
                    let g = m.to_gaussian();
                    g.mean().iter().chain(g.cov().iter()).all(|v| v.is_finite())
                })
        };
        prop_assert!(check(&belief));
        for z in [Some(Vector1::new(z)), None] {
            if let Ok(step) = imm.step(&belief, z.as_ref()) {
                prop_assert!(check(&step.belief), "{step:?}");
                prop_assert!(step.log_likelihood.is_none_or(f64::is_finite), "{step:?}");
                prop_assert!(step.innovations.iter().all(valid_innovation), "{step:?}");
                if let Ok(e) = step.belief.estimate() {
                    prop_assert!(valid(&e, scale(&[&p, &q]).max(r.abs())), "{e:?}");
                }
            }
        }
    }

    /// The RTS smoothers (KF, EKF, UKF, CKF), `batch_smooth` and
    /// `fixed_lag_smooth` over filtered beliefs with extreme entries.
    #[test]
    fn smoothers_never_return_a_bad_belief(
        m1 in vec2(), p1 in mat2(), m2 in vec2(), p2 in mat2(), q in mat2(), r in value(),
        z in value(), lag in 0usize..3,
    ) {
        let (Ok(g1), Ok(g2)) = (Gaussian::new(m1, p1), Gaussian::new(m2, p2)) else {
            return Ok(());
        };
        let filtered = [g1, g2, g1];
        let s = scale(&[&p1, &p2, &q]).max(r.abs());
        let model = Model { q, r };
        fn sweep<F: RtsSmoother<2, D>, D>(
            filter: &F,
            filtered: &[Gaussian<2>],
            dynamics: &D,
            lag: usize,
            s: f64,
        ) -> Result<(), TestCaseError> {
            for g in filtered {
                if let Ok((p, c)) = filter.smoothing_prediction(g, dynamics) {
                    prop_assert!(valid(&p, s) && c.iter().all(|v| v.is_finite()), "{p:?} {c:?}");
                }
            }
            if let Ok(out) = fixed_lag_smooth(filter, filtered, dynamics, lag) {
                for g in &out {
                    prop_assert!(valid(g, s.max(1.0) * 1e3), "{g:?}");
                }
            }
            Ok(())
        }
        sweep(&Ekf::default(), &filtered, &model, lag, s)?;
        sweep(&Ukf::new(1.0, 2.0, 0.0).unwrap(), &filtered, &model, lag, s)?;
        sweep(&Ckf, &filtered, &model, lag, s)?;
        if let Ok(dynamics) = LinearDynamics::new(Matrix2::new(1.0, 0.1, 0.0, 1.0), q) {
            sweep(&Kf::default(), &filtered, &dynamics, lag, s)?;
        }
        // batch_smooth of a batch_filter run from an extreme start
        let zs = [Some(Vector1::new(z)), None, Some(Vector1::new(0.5))];
        for filter in [Ukf::new(1.0, 2.0, 0.0).unwrap()] {
            if let Ok(batch) = batch_filter(&filter, &g1, &model, &model, &zs)
                && let Ok(out) = batch_smooth(&filter, &batch, &model)
            {
                for g in &out {
                    prop_assert!(valid(g, s.max(1.0) * 1e3), "{g:?}");
                }
            }
        }
    }
}
