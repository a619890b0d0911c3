//! [`KalmanFilter`]: the predict and update steps every filter of the crate
//! shares, so that user code can be generic over the KF, EKF, IEKF and UKF.

use nalgebra::SVector;

use crate::error::Result;
use crate::gaussian::Gaussian;
use crate::kf::{Ekf, Iekf, Kf};
use crate::model::{
    Dynamics, DynamicsJacobian, LinearDynamics, LinearMeasurement, Measurement, MeasurementJacobian,
};
use crate::ukf::Ukf;
use crate::update::Update;

/// A Gaussian filter for dynamics `D` and measurements `H` on a state of
/// dimension `N` and measurements of dimension `M`: the stateless
/// `predict` / `update` pair that [`Kf`], [`Ekf`], [`Iekf`] and [`Ukf`]
/// implement (the UKF in its additive-noise form, redrawing sigma points
/// after the prediction).
///
/// Each filter keeps its inherent methods; the trait methods call them.
/// [`Kf`]'s trait `predict` has no control input (its inherent
/// [`Kf::predict`] takes one). Where an inherent method of the same name
/// exists, method-call syntax on the concrete filter picks the inherent one;
/// generic code bounded by this trait, or `KalmanFilter::predict(&kf, ..)`,
/// gets the trait's.
///
/// ```
/// use bayestrack_kalman::{
///     Gaussian, Iekf, KalmanFilter, Kf, LinearDynamics, LinearMeasurement, Result, Ukf,
/// };
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// /// Filters `zs` with any of the filters.
/// fn run<F>(filter: &F, zs: &[f64]) -> Result<Gaussian<2>>
/// where
///     F: KalmanFilter<2, 1, LinearDynamics<2>, LinearMeasurement<2, 1>>,
/// {
///     let dynamics = LinearDynamics::new(
///         Matrix2::new(1.0, 0.1, 0.0, 1.0),
///         Matrix2::identity() * 1e-3,
///     )?;
///     let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25))?;
///     let mut belief = Gaussian::new(Vector2::zeros(), Matrix2::identity())?;
///     for z in zs {
///         let prior = filter.predict(&belief, &dynamics)?;
///         belief = filter.update(&prior, &sensor, Some(&Vector1::new(*z)))?.posterior;
///     }
///     Ok(belief)
/// }
///
/// let zs = [0.1, 0.22, 0.29];
/// let kf = run(&Kf::default(), &zs)?;
/// let ukf = run(&Ukf::new(1.0, 2.0, 0.0)?, &zs)?;
/// let iekf = run(&Iekf::new(5, 1e-12)?, &zs)?;
/// assert!((kf.mean() - ukf.mean()).amax() < 1e-12);
/// assert!((kf.mean() - iekf.mean()).amax() < 1e-12);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
pub trait KalmanFilter<const N: usize, const M: usize, D, H> {
    /// Time update: the belief at `k-1` to the prediction at `k`.
    ///
    /// # Errors
    /// As the filter's inherent `predict`.
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>>;

    /// Measurement update with `z` (`None` = missing: the prior is returned).
    ///
    /// # Errors
    /// As the filter's inherent `update`.
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>>;
}

impl<const N: usize, const M: usize, const U: usize>
    KalmanFilter<N, M, LinearDynamics<N, U>, LinearMeasurement<N, M>> for Kf
{
    /// [`Kf::predict`] without a control input.
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &LinearDynamics<N, U>) -> Result<Gaussian<N>> {
        Kf::predict(self, prior, dynamics, None)
    }

    #[inline]
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &LinearMeasurement<N, M>,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Kf::update(self, prior, measurement, z)
    }
}

impl<const N: usize, const M: usize, D: DynamicsJacobian<N>, H: MeasurementJacobian<N, M>>
    KalmanFilter<N, M, D, H> for Ekf
{
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Ekf::predict(self, prior, dynamics)
    }

    #[inline]
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Ekf::update(self, prior, measurement, z)
    }
}

impl<const N: usize, const M: usize, D: DynamicsJacobian<N>, H: MeasurementJacobian<N, M>>
    KalmanFilter<N, M, D, H> for Iekf
{
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Iekf::predict(self, prior, dynamics)
    }

    #[inline]
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Iekf::update(self, prior, measurement, z)
    }
}

impl<const N: usize, const M: usize, D: Dynamics<N>, H: Measurement<N, M>> KalmanFilter<N, M, D, H>
    for Ukf
{
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Ukf::predict(self, prior, dynamics)
    }

    #[inline]
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Ukf::update(self, prior, measurement, z)
    }
}
