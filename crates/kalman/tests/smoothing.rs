//! `batch_smooth` and `fixed_lag_smooth`: identities with the filters' own
//! RTS smoothers, the full smoother when the lag covers the batch, the
//! filter at lag 0, and the definition (RTS over the data up to `k + lag`)
//! at every lag in between.

use bayestrack_kalman::nalgebra::{Matrix2, Matrix4, SVector, Vector2, Vector4};
use bayestrack_kalman::{
    Batch, Ckf, Ekf, FnDynamics, Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel, Ukf,
    batch_filter, batch_smooth, fixed_lag_smooth,
};

fn setup() -> (LinearDynamics<4>, LinearMeasurement<4, 2>, Gaussian<4>) {
    (
        LinearDynamics::constant_velocity(0.2, 0.8, NoiseModel::Discrete).unwrap(),
        LinearMeasurement::position_with_noise(Matrix2::new(0.3, 0.05, 0.05, 0.2)).unwrap(),
        Gaussian::new(
            Vector4::new(0.0, 1.0, 0.0, -0.5),
            Matrix4::from_diagonal(&Vector4::new(3.0, 1.0, 3.0, 1.0)),
        )
        .unwrap(),
    )
}

fn zs() -> Vec<Option<Vector2<f64>>> {
    (0..40)
        .map(|k| {
            let t = k as f64 * 0.2;
            (k % 6 != 5).then_some(Vector2::new(
                t + 0.4 * (2.0 * t).sin(),
                -0.5 * t + 0.3 * t.cos(),
            ))
        })
        .collect()
}

fn max_diff(a: &[Gaussian<4>], b: &[Gaussian<4>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x.mean() - y.mean()).amax().max((x.cov() - y.cov()).amax()))
        .fold(0.0, f64::max)
}

fn kf_batch() -> (Batch<4, 2>, LinearDynamics<4>) {
    let (d, h, start) = setup();
    (
        batch_filter(&Kf::default(), &start, &d, &h, &zs()).unwrap(),
        d,
    )
}

#[test]
fn batch_smooth_is_each_filters_rts_smoother() {
    let (d, h, start) = setup();
    let (batch, _) = kf_batch();
    let ours = batch_smooth(&Kf::default(), &batch, &d).unwrap();
    let theirs = Kf::default()
        .rts_smooth(&batch.posterior, &d, None)
        .unwrap();
    assert!(max_diff(&ours, &theirs) < 1e-12);
    // the smoother changes the estimates (not the filtered ones returned)
    assert!(max_diff(&ours, &batch.posterior) > 1e-2);

    let ukf = Ukf::new(0.7, 2.0, 0.0).unwrap();
    let ub = batch_filter(&ukf, &start, &d, &h, &zs()).unwrap();
    assert_eq!(
        batch_smooth(&ukf, &ub, &d).unwrap(),
        ukf.rts_smooth(&ub.posterior, &d).unwrap()
    );
    let cb = batch_filter(&Ckf, &start, &d, &h, &zs()).unwrap();
    assert_eq!(
        batch_smooth(&Ckf, &cb, &d).unwrap(),
        Ckf.rts_smooth(&cb.posterior, &d).unwrap()
    );
    // on a linear model the EKF, UKF and CKF smoothers are the KF's
    let f = *d.transition();
    let ekf_model = FnDynamics::new(move |x: &SVector<f64, 4>| f * x, *d.noise())
        .unwrap()
        .with_jacobian(move |_: &SVector<f64, 4>| f);
    let eb = batch_filter(&Ekf::default(), &start, &ekf_model, &h, &zs()).unwrap();
    let ekf = batch_smooth(&Ekf::default(), &eb, &ekf_model).unwrap();
    assert!(max_diff(&ekf, &ours) < 1e-10, "{:e}", max_diff(&ekf, &ours));
    let u = batch_smooth(&ukf, &ub, &d).unwrap();
    assert!(max_diff(&u, &ours) < 1e-10, "{:e}", max_diff(&u, &ours));
}

#[test]
fn fixed_lag_covering_the_batch_is_the_full_smoother() {
    let (batch, d) = kf_batch();
    let full = batch_smooth(&Kf::default(), &batch, &d).unwrap();
    let t = batch.posterior.len();
    for lag in [t - 1, t, 10 * t] {
        let lagged = fixed_lag_smooth(&Kf::default(), &batch.posterior, &d, lag).unwrap();
        assert_eq!(lagged, full, "lag {lag}");
    }
    let ukf = Ukf::new(0.7, 2.0, 0.0).unwrap();
    assert_eq!(
        fixed_lag_smooth(&ukf, &batch.posterior, &d, t).unwrap(),
        ukf.rts_smooth(&batch.posterior, &d).unwrap()
    );
}

#[test]
fn lag_zero_is_the_filter() {
    let (batch, d) = kf_batch();
    assert_eq!(
        fixed_lag_smooth(&Kf::default(), &batch.posterior, &d, 0).unwrap(),
        batch.posterior
    );
    assert!(
        fixed_lag_smooth(&Kf::default(), &[], &d, 3)
            .unwrap()
            .is_empty()
    );
}

#[test]
fn each_lag_is_the_smoother_of_the_data_up_to_k_plus_lag() {
    let (batch, d) = kf_batch();
    let t = batch.posterior.len();
    for lag in [1, 3, 7] {
        let lagged = fixed_lag_smooth(&Kf::default(), &batch.posterior, &d, lag).unwrap();
        for k in 0..t {
            let end = (k + lag).min(t - 1);
            let prefix = Kf::default()
                .rts_smooth(&batch.posterior[..=end], &d, None)
                .unwrap();
            let diff = max_diff(&lagged[k..=k], &prefix[k..=k]);
            assert!(diff < 1e-12, "lag {lag} k {k}: {diff:e}");
        }
        // more lag, closer to the full smoother (in the trace of P)
        let full = batch_smooth(&Kf::default(), &batch, &d).unwrap();
        let gap: f64 = lagged
            .iter()
            .zip(&full)
            .map(|(a, b)| a.cov().trace() - b.cov().trace())
            .sum();
        assert!(gap >= -1e-12, "lag {lag}: {gap}");
    }
}
