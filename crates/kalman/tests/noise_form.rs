//! The additive or augmented noise form is chosen once, on the [`Ukf`]
//! ([`NoiseForm`]): the inherent methods, the [`KalmanFilter`] trait, the
//! joint `step`, the batch filter and the RTS smoother all read it, so one
//! model gives the same bits whichever way it is called.

use bayestrack_kalman::{
    Additive, Gaussian, KalmanFilter, NoiseForm, Result, RtsSmoother, Ukf, Update, batch_filter,
    batch_smooth,
};
use nalgebra::{Matrix1, Matrix2, SMatrix, SVector, Vector1, Vector2};

/// A pendulum read through `sin theta` (nonlinear in both models, so the
/// two forms differ).
struct Pendulum;

impl bayestrack_kalman::Dynamics<2> for Pendulum {
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        Vector2::new(x[0] + 0.1 * x[1], x[1] - 0.981 * x[0].sin())
    }
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::new(1e-4, 0.0, 0.0, 1e-2)
    }
}

impl bayestrack_kalman::Measurement<2, 1> for Pendulum {
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        Vector1::new(x[0].sin())
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(0.01)
    }
}

const ZS: [f64; 6] = [0.45, 0.38, 0.2, -0.01, -0.22, -0.4];

fn start() -> Gaussian<2> {
    Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1).unwrap()
}

/// Generic code: the filter through the trait only.
fn through_trait<F>(filter: &F) -> Result<Vec<Update<2, 1>>>
where
    F: KalmanFilter<2, 1, Pendulum, Pendulum, Belief = Gaussian<2>>,
{
    let mut belief = start();
    let mut out = Vec::new();
    for z in ZS {
        let prior = filter.predict(&belief, &Pendulum)?;
        let update = filter.update(&prior, &Pendulum, Some(&Vector1::new(z)))?;
        belief = update.posterior;
        out.push(update);
    }
    Ok(out)
}

/// The inherent methods.
fn through_methods(ukf: &Ukf) -> Vec<Update<2, 1>> {
    let mut belief = start();
    let mut out = Vec::new();
    for z in ZS {
        let prior = ukf.predict(&belief, &Pendulum).unwrap();
        let update = ukf
            .update(&prior, &Pendulum, Some(&Vector1::new(z)))
            .unwrap();
        belief = update.posterior;
        out.push(update);
    }
    out
}

/// The form spelled out: plain `predict`/`update` of a default UKF, or the
/// augmented calls on the model seen through [`Additive`].
fn spelled_out(ukf: &Ukf, form: NoiseForm) -> Vec<Update<2, 1>> {
    let plain = Ukf::new(ukf.alpha(), ukf.beta(), ukf.kappa()).unwrap();
    assert_eq!(plain.noise_form(), NoiseForm::Additive, "the default");
    let mut belief = start();
    let mut out = Vec::new();
    for z in ZS {
        let z = Vector1::new(z);
        let update = match form {
            NoiseForm::Additive => {
                let prior = plain.predict(&belief, &Pendulum).unwrap();
                plain.update(&prior, &Pendulum, Some(&z)).unwrap()
            }
            NoiseForm::Augmented => {
                let prior = plain
                    .predict_augmented(&belief, &Additive(&Pendulum))
                    .unwrap();
                plain
                    .update_augmented(&prior, &Additive(&Pendulum), Some(&z))
                    .unwrap()
            }
        };
        belief = update.posterior;
        out.push(update);
    }
    out
}

#[test]
fn every_path_reads_the_one_noise_form() {
    let mut last = Vec::new();
    for form in [NoiseForm::Additive, NoiseForm::Augmented] {
        let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap().with_noise_form(form);
        assert_eq!(ukf.noise_form(), form);
        let a = through_trait(&ukf).unwrap();
        let b = through_methods(&ukf);
        let c = spelled_out(&ukf, form);
        assert_eq!(a, b, "{form:?}: trait and methods");
        assert_eq!(a, c, "{form:?}: the form spelled out");
        // the batch filter (generic over the trait) too
        let zs: Vec<_> = ZS.iter().map(|z| Some(Vector1::new(*z))).collect();
        let batch = batch_filter(&ukf, &start(), &Pendulum, &Pendulum, &zs).unwrap();
        let last_mean = *batch.posterior.last().unwrap().mean();
        assert_eq!(last_mean, *a.last().unwrap().posterior.mean());
        // the smoother's predictions are the filter's
        let g = a[2].posterior;
        let (predicted, _) = RtsSmoother::smoothing_prediction(&ukf, &g, &Pendulum).unwrap();
        assert_eq!(
            predicted,
            ukf.predict(&g, &Pendulum).unwrap(),
            "{form:?}: smoother"
        );
        let smoothed = batch_smooth(&ukf, &batch, &Pendulum).unwrap();
        assert!(
            smoothed
                .iter()
                .all(|g| g.cov().iter().all(|v| v.is_finite()))
        );
        // the joint step
        let z = Vector1::new(ZS[0]);
        let joint = ukf.step(&start(), &Pendulum, &Pendulum, Some(&z)).unwrap();
        let spelled = match form {
            NoiseForm::Additive => Ukf::new(1.0, 2.0, 0.0)
                .unwrap()
                .step(&start(), &Pendulum, &Pendulum, Some(&z))
                .unwrap(),
            NoiseForm::Augmented => Ukf::new(1.0, 2.0, 0.0)
                .unwrap()
                .step_augmented(
                    &start(),
                    &Additive(&Pendulum),
                    &Additive(&Pendulum),
                    Some(&z),
                )
                .unwrap(),
        };
        assert_eq!(joint, spelled, "{form:?}: step");
        last.push(*a.last().unwrap().posterior.mean());
    }
    // the forms really differ on this nonlinear model (the test above
    // would not see a path that ignored the form otherwise)
    let gap = (last[0] - last[1]).amax();
    assert!(gap > 1e-6, "additive and augmented agree to {gap}");
}
