//! The IMM estimator: identities (IMM over UKFs = IMM over KFs on linear
//! models; square-root models mixed as factors = covariance models; one
//! model = its filter), log-domain mode probabilities, typed errors. The
//! filterpy oracle is in `tests/filterpy_imm.rs`.

use bayestrack_kalman::nalgebra::{Matrix2, Matrix4, Vector2, Vector4};
use bayestrack_kalman::{
    Ckf, Gaussian, Imm, ImmBelief, ImmModel, KalmanError, Kf, LinearDynamics, LinearMeasurement,
    Mode, NoiseModel, SrKf, SrUkf, Ukf,
};

fn sensor() -> LinearMeasurement<4, 2> {
    LinearMeasurement::position_with_noise(Matrix2::new(0.5, 0.1, 0.1, 0.3)).unwrap()
}

/// Three constant-velocity models of increasing process noise.
fn dynamics() -> [LinearDynamics<4>; 3] {
    [0.01, 0.5, 5.0]
        .map(|q| LinearDynamics::constant_velocity(0.5, q, NoiseModel::Discrete).unwrap())
}

const TRANSITION: [f64; 9] = [0.9, 0.07, 0.03, 0.1, 0.8, 0.1, 0.05, 0.15, 0.8];

fn start() -> Gaussian<4> {
    Gaussian::new(
        Vector4::new(0.0, 1.0, 0.0, 0.5),
        Matrix4::from_diagonal(&Vector4::new(2.0, 1.0, 2.0, 1.0)),
    )
    .unwrap()
}

/// A track that turns and accelerates, every fifth measurement missing.
fn zs() -> Vec<Option<Vector2<f64>>> {
    let (mut p, mut v) = (Vector2::zeros(), Vector2::new(1.0, 0.5));
    (0..60)
        .map(|k| {
            if (20..30).contains(&k) {
                v = Vector2::new(v[0] * 0.9 - 0.3, v[1] + 0.4);
            }
            p += v * 0.5;
            let wobble = Vector2::new((k as f64 * 1.7).sin(), (k as f64 * 2.3).cos()) * 0.4;
            (k % 5 != 4).then_some(p + wobble)
        })
        .collect()
}

fn run(imm: &Imm<'_, 4, 2>) -> Vec<(ImmBelief<4>, Option<f64>)> {
    let mut belief = imm.start(&[0.5, 0.3, 0.2], &start()).unwrap();
    zs().iter()
        .map(|z| {
            let step = imm.step(&belief, z.as_ref()).unwrap();
            belief = step.belief.clone();
            (step.belief, step.log_likelihood)
        })
        .collect()
}

fn imm_of(models: Vec<Box<dyn ImmModel<4, 2>>>) -> Imm<'static, 4, 2> {
    Imm::new(models, &TRANSITION).unwrap()
}

fn boxed<F: 'static>(filter: impl Fn() -> F) -> Vec<Box<dyn ImmModel<4, 2>>>
where
    Mode<F, LinearDynamics<4>, LinearMeasurement<4, 2>>: ImmModel<4, 2>,
{
    dynamics()
        .into_iter()
        .map(|d| Box::new(Mode::new(filter(), d, sensor())) as Box<dyn ImmModel<4, 2>>)
        .collect()
}

/// Largest difference of probabilities, mode means and covariances, and
/// log-likelihoods, relative to the magnitudes.
fn max_diff(a: &[(ImmBelief<4>, Option<f64>)], b: &[(ImmBelief<4>, Option<f64>)]) -> f64 {
    let mut worst: f64 = 0.0;
    for ((x, lx), (y, ly)) in a.iter().zip(b) {
        for (p, q) in x.probabilities().iter().zip(y.probabilities()) {
            worst = worst.max((p - q).abs());
        }
        for (m, n) in x.modes().iter().zip(y.modes()) {
            worst = worst.max((m.mean() - n.mean()).amax() / m.mean().amax().max(1.0));
            worst = worst.max((m.covariance() - n.covariance()).amax());
        }
        assert_eq!(lx.is_some(), ly.is_some());
        if let (Some(p), Some(q)) = (lx, ly) {
            worst = worst.max((p - q).abs() / p.abs().max(1.0));
        }
    }
    worst
}

#[test]
fn imm_over_ukfs_equals_imm_over_kfs_on_linear_models() {
    let kf = run(&imm_of(boxed(Kf::default)));
    let ukf = run(&imm_of(boxed(|| Ukf::new(0.5, 2.0, 0.0).unwrap())));
    let d = max_diff(&kf, &ukf);
    assert!(d < 1e-9, "{d:e}");
    // the case moves the probabilities: the manoeuvre favours the agile
    // models, the straight track the quiet one
    let agile = kf
        .iter()
        .map(|(b, _)| b.probabilities()[2])
        .fold(0.0, f64::max);
    let quiet = kf.last().unwrap().0.probabilities()[0];
    assert!(agile > 0.5 && quiet > 0.5, "{agile} {quiet}");
}

#[test]
fn square_root_models_mixed_as_factors_equal_covariance_models() {
    // every form at once: a square-root KF, an SR-UKF and a CKF
    let models: Vec<Box<dyn ImmModel<4, 2>>> = {
        let [a, b, c] = dynamics();
        vec![
            Box::new(Mode::new(SrKf, a, sensor())),
            Box::new(Mode::new(SrUkf::new(1.0, 2.0, 0.0).unwrap(), b, sensor())),
            Box::new(Mode::new(Ckf, c, sensor())),
        ]
    };
    let mixed = run(&imm_of(models));
    let kf = run(&imm_of(boxed(Kf::default)));
    let d = max_diff(&kf, &mixed);
    assert!(d < 1e-9, "{d:e}");
    // the square-root models keep their factor between steps
    let last = &mixed.last().unwrap().0;
    assert!(matches!(
        last.modes()[0],
        bayestrack_kalman::ModeBelief::Sqrt(_)
    ));
    assert!(matches!(
        last.modes()[2],
        bayestrack_kalman::ModeBelief::Full(_)
    ));
}

#[test]
fn one_model_is_its_filter() {
    let [d, ..] = dynamics();
    let imm = Imm::new(
        vec![Box::new(Mode::new(Kf::default(), d, sensor()))],
        &[1.0],
    )
    .unwrap();
    let mut belief = imm.start(&[1.0], &start()).unwrap();
    let mut g = start();
    let kf = Kf::default();
    for z in zs() {
        let step = imm.step(&belief, z.as_ref()).unwrap();
        let u = kf
            .update(&kf.predict(&g, &d).unwrap(), &sensor(), z.as_ref())
            .unwrap();
        g = u.posterior;
        assert_eq!(step.belief.estimate().unwrap(), g);
        assert_eq!(
            step.log_likelihood,
            u.innovation.map(|i| i.log_likelihood())
        );
        belief = step.belief;
    }
}

#[test]
fn mode_probabilities_stay_normalised_when_every_likelihood_underflows() {
    let imm = imm_of(boxed(Kf::default));
    let belief = imm.start(&[0.5, 0.3, 0.2], &start()).unwrap();
    // a residual of 1e4 standard deviations: every likelihood is exp(-1e8)
    let step = imm.step(&belief, Some(&Vector2::new(1e4, 0.0))).unwrap();
    let p = step.belief.probabilities();
    assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{p:?}");
    assert!(p.iter().all(|x| x.is_finite()));
    // the agile model explains it best
    assert!(p[2] > 0.99, "{p:?}");
    assert!(step.log_likelihood.unwrap() < -1e6);
}

#[test]
fn bad_parameters_are_typed_errors() {
    let invalid = |r: Result<_, KalmanError>, name: &str| match r {
        Err(KalmanError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
        other => panic!("{other:?}"),
    };
    invalid(Imm::<4, 2>::new(vec![], &[]).map(|_| ()), "models");
    invalid(
        Imm::new(boxed(Kf::default), &[1.0; 4]).map(|_| ()),
        "transition matrix",
    );
    let mut rows = TRANSITION;
    rows[0] = 0.8;
    invalid(
        Imm::new(boxed(Kf::default), &rows).map(|_| ()),
        "transition matrix",
    );
    rows[0] = f64::NAN;
    invalid(
        Imm::new(boxed(Kf::default), &rows).map(|_| ()),
        "transition matrix",
    );
    let imm = imm_of(boxed(Kf::default));
    invalid(
        imm.start(&[0.5, 0.5], &start()).map(|_| ()),
        "mode probabilities",
    );
    invalid(
        imm.start(&[0.5, 0.5, 0.5], &start()).map(|_| ()),
        "mode probabilities",
    );
    invalid(
        imm.start(&[-0.5, 1.0, 0.5], &start()).map(|_| ()),
        "mode probabilities",
    );
    invalid(
        imm.belief(&[0.5, 0.3, 0.2], vec![]).map(|_| ()),
        "mode beliefs",
    );
}
