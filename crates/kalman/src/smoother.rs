//! The Rauch-Tung-Striebel backward pass shared by the linear and the
//! unscented smoothers; [`RtsSmoother`], [`batch_smooth`] and the
//! fixed-lag smoother [`fixed_lag_smooth`] over any of them.

use nalgebra::{SMatrix, SVector};

use crate::batch::Batch;
use crate::ckf::Ckf;
use crate::error::{Result, Step};
use crate::gaussian::Gaussian;
use crate::kf::{Ekf, Kf};
use crate::linalg;
use crate::model::{self, Dynamics, DynamicsJacobian, LinearDynamics, Manifold};
use crate::ukf::Ukf;

/// One backward step: from `x_{k|k}`, the prediction `x_{k+1|k}` with the
/// cross-covariance `C_k = Cov(x_k, x_{k+1})` and the smoothed
/// `x_{k+1|T}`, `G = C_k P_{k+1|k}^{-1}` (Cholesky solve),
/// `x_s = x_k + G (x_s,{k+1} - x_{k+1|k})`,
/// `P_s = P_k + G (P_s,{k+1} - P_{k+1|k}) G^T`.
#[inline]
fn rts_step<const N: usize>(
    filtered: &Gaussian<N>,
    predicted: &Gaussian<N>,
    cross: &SMatrix<f64, N, N>,
    next: &Gaussian<N>,
    residual: &impl Fn(&SVector<f64, N>, &SVector<f64, N>) -> SVector<f64, N>,
) -> Result<Gaussian<N>> {
    let chol = linalg::Llt::new(
        predicted.cov(),
        "predicted covariance P_{k+1|k}",
        Step::Smooth,
    )?;
    let gain = chol.solve(&cross.transpose()).transpose();
    let mean = filtered.mean() + gain * residual(next.mean(), predicted.mean());
    let mut cov = linalg::symmetrize(
        &(filtered.cov() + gain * (next.cov() - predicted.cov()) * gain.transpose()),
    );
    // `P_s = P + G (P_s' - P_pred) G^T` subtracts up to `P` itself (the
    // smoothed covariance lies between 0 and `P`): a variance below the
    // round-off of `P` is a wrong number (extreme, ill-scaled beliefs),
    // an error rather than a negative variance returned with `Ok`
    linalg::check_variances(
        &mut cov,
        filtered.cov(),
        "smoothed covariance",
        Step::Smooth,
    )?;
    Gaussian::checked(mean, cov, Step::Smooth)
}

/// Backward pass over filtered beliefs `x_{k|k}`.
///
/// `predict(k, x_{k|k})` returns the one-step prediction `x_{k+1|k}` and the
/// cross-covariance `C_k = Cov(x_k, x_{k+1})` (`P_k F^T` for a linear model,
/// its sigma-point estimate for the URTS smoother of Sarkka 2008); the
/// mean difference is taken by `residual` (the model's
/// [`crate::Dynamics::state_space`]); see `rts_step`.
pub(crate) fn rts_backward<const N: usize>(
    filtered: &[Gaussian<N>],
    residual: impl Fn(&SVector<f64, N>, &SVector<f64, N>) -> SVector<f64, N>,
    mut predict: impl FnMut(usize, &Gaussian<N>) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)>,
) -> Result<Vec<Gaussian<N>>> {
    let mut smoothed = filtered.to_vec();
    for k in (0..filtered.len().saturating_sub(1)).rev() {
        let (predicted, cross) = predict(k, &filtered[k])?;
        smoothed[k] = rts_step(
            &filtered[k],
            &predicted,
            &cross,
            &smoothed[k + 1],
            &residual,
        )?;
    }
    Ok(smoothed)
}

/// A filter whose filtered beliefs can be smoothed by the RTS backward
/// pass for dynamics `D`: it gives the one-step prediction and the
/// cross-covariance `Cov(x_k, x_{k+1})` in its own approximation (`P F^T`
/// for the KF, `P J^T` with the Jacobian at the filtered mean for the EKF,
/// the sigma-point estimate for the UKF and CKF).
pub trait RtsSmoother<const N: usize, D> {
    /// `x_{k+1|k}` and `Cov(x_k, x_{k+1})` from `x_{k|k}`.
    ///
    /// # Errors
    /// As the filter's `predict`.
    fn smoothing_prediction(
        &self,
        filtered: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)>;

    /// The difference `a [-] b` of two states (in the model's
    /// [`Dynamics::state_space`] where it has one).
    fn state_residual(
        &self,
        dynamics: &D,
        a: &SVector<f64, N>,
        b: &SVector<f64, N>,
    ) -> SVector<f64, N>;
}

impl<const N: usize, const U: usize> RtsSmoother<N, LinearDynamics<N, U>> for Kf {
    fn smoothing_prediction(
        &self,
        filtered: &Gaussian<N>,
        dynamics: &LinearDynamics<N, U>,
    ) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)> {
        let predicted = self.predict(filtered, dynamics)?;
        Ok((
            predicted,
            filtered.cov() * dynamics.transition().transpose(),
        ))
    }

    fn state_residual(
        &self,
        _: &LinearDynamics<N, U>,
        a: &SVector<f64, N>,
        b: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        a - b
    }
}

impl<const N: usize, D: DynamicsJacobian<N>> RtsSmoother<N, D> for Ekf {
    fn smoothing_prediction(
        &self,
        filtered: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)> {
        let predicted = self.predict(filtered, dynamics)?;
        let f = dynamics.jacobian(filtered.mean());
        Ok((predicted, filtered.cov() * f.transpose()))
    }

    fn state_residual(
        &self,
        dynamics: &D,
        a: &SVector<f64, N>,
        b: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        dynamics.state_space().residual(a, b)
    }
}

/// The unscented RTS smoother of Sarkka 2008, one body for the UKF and the
/// CKF (whose sigma points are the cubature rule's).
macro_rules! sigma_point_smoother {
    ($($filter:ty),*) => {$(
        impl<const N: usize, D: Dynamics<N>> RtsSmoother<N, D> for $filter {
            fn smoothing_prediction(
                &self,
                filtered: &Gaussian<N>,
                dynamics: &D,
            ) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)> {
                let q = model::process_noise(dynamics, Step::Smooth)?;
                self.as_ukf().smoothing_prediction(filtered, dynamics, &q)
            }

            fn state_residual(
                &self,
                dynamics: &D,
                a: &SVector<f64, N>,
                b: &SVector<f64, N>,
            ) -> SVector<f64, N> {
                dynamics.state_space().residual(a, b)
            }
        }
    )*};
}

/// The UKF with a sigma-point filter's points.
trait AsUkf {
    fn as_ukf(&self) -> &Ukf;
}

impl AsUkf for Ukf {
    #[inline(always)]
    fn as_ukf(&self) -> &Ukf {
        self
    }
}

impl AsUkf for Ckf {
    #[inline(always)]
    fn as_ukf(&self) -> &Ukf {
        const CUBATURE: Ukf = Ukf::cubature();
        &CUBATURE
    }
}

sigma_point_smoother!(Ukf, Ckf);

/// RTS smoothing of a [`batch_filter`](crate::batch_filter) result with
/// the filter that made it (KF, EKF, UKF or CKF): `x_{k|T}` for every `k`.
///
/// ```
/// use bayestrack_kalman::{batch_filter, batch_smooth, fixed_lag_smooth, Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel};
/// use nalgebra::{Matrix2, Matrix4, Vector2, Vector4};
///
/// let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.5, NoiseModel::Discrete)?;
/// let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25)?;
/// let zs: Vec<_> = (0..20).map(|k| Some(Vector2::new(0.1 * k as f64, 0.05 * k as f64))).collect();
/// let start = Gaussian::new(Vector4::zeros(), Matrix4::identity())?;
/// let batch = batch_filter(&Kf::default(), &start, &dynamics, &sensor, &zs)?;
/// let smoothed = batch_smooth(&Kf::default(), &batch, &dynamics)?;
/// // a fixed lag as long as the batch is the full smoother
/// let lagged = fixed_lag_smooth(&Kf::default(), &batch.posterior, &dynamics, 19)?;
/// assert!((smoothed[0].mean() - lagged[0].mean()).amax() < 1e-12);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
///
/// # Errors
/// As the filter's `predict`; [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite)
/// when a predicted covariance cannot be factored.
pub fn batch_smooth<const N: usize, const M: usize, F, D>(
    filter: &F,
    batch: &Batch<N, M>,
    dynamics: &D,
) -> Result<Vec<Gaussian<N>>>
where
    F: RtsSmoother<N, D>,
{
    rts_backward(
        &batch.posterior,
        |a, b| filter.state_residual(dynamics, a, b),
        |_, g| filter.smoothing_prediction(g, dynamics),
    )
}

/// Fixed-lag smoothing: for each `k`, `x_{k|min(k + lag, T - 1)}`, the
/// estimate of the state at `k` given the measurements up to `lag` steps
/// later: the RTS backward pass over the window `k..=k + lag` of the
/// filtered beliefs (exact: the window's last belief is its own smoothed
/// one). `lag = 0` returns the filtered beliefs; a lag of `T - 1` or more
/// is the full RTS smoother. Online, call it on the last `lag + 1`
/// filtered beliefs and read the first. The predictions are formed once
/// and shared by the windows: `T` predictions and `T lag` backward steps.
///
/// # Errors
/// As [`batch_smooth`].
pub fn fixed_lag_smooth<const N: usize, F, D>(
    filter: &F,
    filtered: &[Gaussian<N>],
    dynamics: &D,
    lag: usize,
) -> Result<Vec<Gaussian<N>>>
where
    F: RtsSmoother<N, D>,
{
    let t = filtered.len();
    let predictions = filtered
        .iter()
        .take(t.saturating_sub(1))
        .map(|g| filter.smoothing_prediction(g, dynamics))
        .collect::<Result<Vec<_>>>()?;
    let residual = |a: &SVector<f64, N>, b: &SVector<f64, N>| filter.state_residual(dynamics, a, b);
    let mut out = Vec::with_capacity(t);
    for k in 0..t {
        let end = (k + lag).min(t - 1);
        let mut s = filtered[end];
        for j in (k..end).rev() {
            let (predicted, cross) = &predictions[j];
            s = rts_step(&filtered[j], predicted, cross, &s, &residual)?;
        }
        out.push(s);
    }
    Ok(out)
}
