//! [`batch_filter`]: a whole measurement sequence through any filter, as
//! filterpy's `batch_filter`.

use nalgebra::{SMatrix, SVector};

use crate::belief::Belief;
use crate::error::Result;
use crate::filter::KalmanFilter;
use crate::gaussian::Gaussian;
use crate::update::Innovation;

/// What [`batch_filter`] returns: per step `k`, the prediction
/// `x_{k|k-1}`, the posterior `x_{k|k}` and the innovation statistics
/// (`None` where the measurement was missing), the beliefs in the filter's
/// form `B` ([`Gaussian`] but for the square-root filters).
#[derive(Debug, Clone, PartialEq)]
pub struct Batch<const N: usize, const M: usize, B = Gaussian<N>> {
    /// `x_{k|k-1}`.
    pub predicted: Vec<B>,
    /// `x_{k|k}` (the prediction where the measurement is missing).
    pub posterior: Vec<B>,
    /// Residual, `S`, NIS and log-likelihood of each update.
    pub innovations: Vec<Option<Innovation<M>>>,
}

impl<const N: usize, const M: usize, B: Belief<N>> Batch<N, M, B> {
    /// The posterior means (filterpy's `means`).
    pub fn means(&self) -> Vec<SVector<f64, N>> {
        self.posterior.iter().map(|g| *g.mean()).collect()
    }

    /// The posterior covariances (filterpy's `covariances`).
    pub fn covariances(&self) -> Vec<SMatrix<f64, N, N>> {
        self.posterior.iter().map(|g| g.covariance()).collect()
    }

    /// The sum of the log-likelihoods of the measurements that were there.
    pub fn log_likelihood(&self) -> f64 {
        self.innovations
            .iter()
            .flatten()
            .map(|i| i.log_likelihood())
            .sum()
    }
}

/// Filters `zs` from `initial` (the belief before the first measurement):
/// for each `z_k`, predict with `dynamics`, then update with `measurement`
/// (`None`: missing, the posterior is the prediction). Works with every
/// filter ([`Kf`](crate::Kf), [`Ekf`](crate::Ekf), [`Iekf`](crate::Iekf),
/// [`Ukf`](crate::Ukf), [`Ckf`](crate::Ckf), and in its own belief form
/// [`SrUkf`](crate::SrUkf)); smooth the result with the filter's `rts_smooth`
/// on [`Batch::posterior`].
///
/// ```
/// use bayestrack_kalman::{batch_filter, Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel};
/// use nalgebra::{Matrix2, Matrix4, Vector2, Vector4};
///
/// let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.5, NoiseModel::Discrete)?;
/// let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::new(0.25, 0.05, 0.05, 0.5))?;
/// let zs = [Some(Vector2::new(0.1, 0.0)), None, Some(Vector2::new(0.32, 0.11))];
/// let start = Gaussian::new(Vector4::zeros(), Matrix4::identity())?;
/// let kf = Kf::default();
/// let batch = batch_filter(&kf, &start, &dynamics, &sensor, &zs)?;
/// assert_eq!(batch.means().len(), 3);
/// assert!(batch.innovations[1].is_none());
/// let smoothed = kf.rts_smooth(&batch.posterior, &dynamics, None)?;
/// assert_eq!(smoothed.len(), 3);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
///
/// # Errors
/// The first error of a step, as the filter's `predict` and `update`.
pub fn batch_filter<const N: usize, const M: usize, F, D, H>(
    filter: &F,
    initial: &F::Belief,
    dynamics: &D,
    measurement: &H,
    zs: &[Option<SVector<f64, M>>],
) -> Result<Batch<N, M, F::Belief>>
where
    F: KalmanFilter<N, M, D, H>,
{
    let mut batch = Batch {
        predicted: Vec::with_capacity(zs.len()),
        posterior: Vec::with_capacity(zs.len()),
        innovations: Vec::with_capacity(zs.len()),
    };
    let mut belief = initial.clone();
    for z in zs {
        let predicted = filter.predict(&belief, dynamics)?;
        let update = filter.update(&predicted, measurement, z.as_ref())?;
        belief = update.posterior;
        batch.predicted.push(predicted);
        batch.posterior.push(belief.clone());
        batch.innovations.push(update.innovation);
    }
    Ok(batch)
}
