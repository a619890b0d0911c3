//! [`KalmanPredict`], [`KalmanUpdate`] and [`KalmanFilter`] (both): the
//! predict and update steps every filter of the crate shares, so that user
//! code can be generic over the KF, EKF, IEKF, UKF, CKF and SR-UKF, each
//! in its own belief form ([`FilterBelief`]).

use nalgebra::SVector;

use crate::belief::FilterBelief;
use crate::ckf::Ckf;
use crate::error::Result;
use crate::gaussian::Gaussian;
use crate::kf::{Ekf, Iekf, Kf};
use crate::model::{
    Dynamics, DynamicsJacobian, LinearDynamics, LinearMeasurement, Measurement, MeasurementJacobian,
};
use crate::srukf::{SqrtGaussian, SqrtUpdate, SrUkf};
use crate::ukf::Ukf;
use crate::update::Update;

/// The time update of a Gaussian filter for dynamics `D` on a state of
/// dimension `N` (the first half of [`KalmanFilter`]).
///
/// Separate from the measurement update so that a call names only what it
/// uses: `KalmanPredict::predict(&kf, &belief, &dynamics)` infers `N` and
/// `D` from its arguments. The filters' inherent methods have the same
/// arguments, so method syntax (`kf.predict(&belief, &dynamics)`) gives the
/// same answer with or without these traits in scope.
///
/// ```
/// use bayestrack_kalman::{
///     Gaussian, KalmanPredict, KalmanUpdate, Kf, LinearDynamics, LinearMeasurement, Ukf,
/// };
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let dynamics = LinearDynamics::new(Matrix2::new(1.0, 0.1, 0.0, 1.0), Matrix2::identity() * 1e-3)?;
/// let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25))?;
/// let belief = Gaussian::new(Vector2::zeros(), Matrix2::identity())?;
/// let z = Vector1::new(0.1);
/// let kf = Kf::default();
/// // method syntax, with the traits in scope
/// let prior = kf.predict(&belief, &dynamics)?;
/// let posterior = kf.update(&prior, &sensor, Some(&z))?.posterior;
/// // the trait functions, as generic code calls them
/// assert_eq!(KalmanPredict::predict(&kf, &belief, &dynamics)?, prior);
/// assert_eq!(KalmanUpdate::update(&kf, &prior, &sensor, Some(&z))?.posterior, posterior);
/// // every filter the same way
/// let ukf = Ukf::new(1.0, 2.0, 0.0)?;
/// let u = ukf.update(&ukf.predict(&belief, &dynamics)?, &sensor, Some(&z))?;
/// assert!((u.posterior.mean() - posterior.mean()).amax() < 1e-12);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
pub trait KalmanPredict<const N: usize, D>: FilterBelief<N> {
    /// Time update: the belief at `k-1` to the prediction at `k`.
    ///
    /// # Errors
    /// As the filter's inherent `predict`.
    fn predict(&self, prior: &Self::Belief, dynamics: &D) -> Result<Self::Belief>;
}

/// The measurement update of a Gaussian filter for measurements `H` of
/// dimension `M` on a state of dimension `N` (the second half of
/// [`KalmanFilter`]).
pub trait KalmanUpdate<const N: usize, const M: usize, H>: FilterBelief<N> {
    /// Measurement update with `z` (`None` = missing: the prior is returned).
    ///
    /// # Errors
    /// As the filter's inherent `update`.
    fn update(
        &self,
        prior: &Self::Belief,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M, Self::Belief>>;
}

/// A Gaussian filter for dynamics `D` and measurements `H` on a state of
/// dimension `N` and measurements of dimension `M`: the stateless
/// `predict` / `update` pair that [`Kf`], [`Ekf`], [`Iekf`], [`Ukf`],
/// [`Ckf`] and [`SrUkf`] implement (the sigma-point filters in their
/// additive-noise form, redrawing sigma points after the prediction).
///
/// Each filter takes and returns its own belief form, `F::Belief`
/// ([`FilterBelief`]): [`Gaussian`] for all but the square-root filters,
/// which keep a [`SqrtGaussian`] (the Cholesky factor) between steps.
/// Generic code over every filter starts from a [`Gaussian`] with
/// [`Belief::from_gaussian`](crate::Belief::from_gaussian) and reads the
/// result with [`Belief::to_gaussian`](crate::Belief::to_gaussian); code
/// for the covariance filters only binds `Belief = Gaussian<N>`.
///
/// Implemented for every filter that implements [`KalmanPredict`] for `D`
/// and [`KalmanUpdate`] for `H`; its methods are theirs. Each filter keeps
/// its inherent methods, with the same arguments, and the trait methods
/// call them: method syntax on a concrete filter and generic code bounded
/// by this trait give the same answer.
///
/// ```
/// use bayestrack_kalman::{
///     Belief, Gaussian, Iekf, KalmanFilter, Kf, LinearDynamics, LinearMeasurement, Result,
///     SrUkf, Ukf,
/// };
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// /// Filters `zs` with any of the filters, in its own belief form.
/// fn run<F>(filter: &F, zs: &[f64]) -> Result<Gaussian<2>>
/// where
///     F: KalmanFilter<2, 1, LinearDynamics<2>, LinearMeasurement<2, 1>>,
/// {
///     let dynamics = LinearDynamics::new(
///         Matrix2::new(1.0, 0.1, 0.0, 1.0),
///         Matrix2::identity() * 1e-3,
///     )?;
///     let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25))?;
///     let start = Gaussian::new(Vector2::zeros(), Matrix2::identity())?;
///     let mut belief = F::Belief::from_gaussian(&start)?;
///     for z in zs {
///         let prior = filter.predict(&belief, &dynamics)?;
///         belief = filter.update(&prior, &sensor, Some(&Vector1::new(*z)))?.posterior;
///     }
///     Ok(belief.to_gaussian())
/// }
///
/// /// Only the covariance filters: the belief is a `Gaussian`.
/// fn last_mean<F>(filter: &F, start: Gaussian<2>) -> Result<Vector2<f64>>
/// where
///     F: KalmanFilter<2, 1, LinearDynamics<2>, LinearMeasurement<2, 1>, Belief = Gaussian<2>>,
/// {
///     let dynamics = LinearDynamics::new(Matrix2::identity(), Matrix2::identity() * 1e-3)?;
///     Ok(*filter.predict(&start, &dynamics)?.mean())
/// }
///
/// let zs = [0.1, 0.22, 0.29];
/// let kf = run(&Kf::default(), &zs)?;
/// let ukf = run(&Ukf::new(1.0, 2.0, 0.0)?, &zs)?;
/// let iekf = run(&Iekf::new(5, 1e-12)?, &zs)?;
/// let srukf = run(&SrUkf::new(1.0, 2.0, 0.0)?, &zs)?;
/// assert!((kf.mean() - ukf.mean()).amax() < 1e-12);
/// assert!((kf.mean() - iekf.mean()).amax() < 1e-12);
/// assert!((kf.cov() - srukf.cov()).amax() < 1e-12);
/// assert_eq!(last_mean(&Kf::default(), kf)?, *kf.mean());
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
pub trait KalmanFilter<const N: usize, const M: usize, D, H>:
    KalmanPredict<N, D> + KalmanUpdate<N, M, H>
{
}

impl<const N: usize, const M: usize, D, H, F> KalmanFilter<N, M, D, H> for F where
    F: KalmanPredict<N, D> + KalmanUpdate<N, M, H>
{
}

macro_rules! gaussian_belief {
    ($($filter:ty),*) => {$(
        impl<const N: usize> FilterBelief<N> for $filter {
            type Belief = Gaussian<N>;
        }
    )*};
}

gaussian_belief!(Kf, Ekf, Iekf, Ukf, Ckf);

impl<const N: usize> FilterBelief<N> for SrUkf {
    type Belief = SqrtGaussian<N>;
}

impl<const N: usize, const U: usize> KalmanPredict<N, LinearDynamics<N, U>> for Kf {
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &LinearDynamics<N, U>) -> Result<Gaussian<N>> {
        Kf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize> KalmanUpdate<N, M, LinearMeasurement<N, M>> for Kf {
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

impl<const N: usize, D: DynamicsJacobian<N>> KalmanPredict<N, D> for Ekf {
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Ekf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize, H: MeasurementJacobian<N, M>> KalmanUpdate<N, M, H> for Ekf {
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

impl<const N: usize, D: DynamicsJacobian<N>> KalmanPredict<N, D> for Iekf {
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Iekf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize, H: MeasurementJacobian<N, M>> KalmanUpdate<N, M, H> for Iekf {
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

impl<const N: usize, D: Dynamics<N>> KalmanPredict<N, D> for Ukf {
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Ukf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize, H: Measurement<N, M>> KalmanUpdate<N, M, H> for Ukf {
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

impl<const N: usize, D: Dynamics<N>> KalmanPredict<N, D> for SrUkf {
    #[inline]
    fn predict(&self, prior: &SqrtGaussian<N>, dynamics: &D) -> Result<SqrtGaussian<N>> {
        SrUkf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize, H: Measurement<N, M>> KalmanUpdate<N, M, H> for SrUkf {
    #[inline]
    fn update(
        &self,
        prior: &SqrtGaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<SqrtUpdate<N, M>> {
        SrUkf::update(self, prior, measurement, z)
    }
}
