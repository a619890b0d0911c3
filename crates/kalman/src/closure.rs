//! Models from closures: [`FnDynamics`] and [`FnMeasurement`], with the
//! noise checked once and an optional Jacobian closure for the EKF and
//! IEKF, instead of a struct and trait implementations.

use nalgebra::{SMatrix, SVector};

use crate::error::{Result, Step};
use crate::model::{Dynamics, DynamicsJacobian, Measurement, MeasurementJacobian, NoiseCovariance};

/// The Jacobian slot of a closure model that has none: such a model serves
/// the UKF (and the CKF-style sigma-point filters), not the EKF or IEKF.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoJacobian;

/// Additive-noise dynamics `x_k = f(x_{k-1}) + v`, `v ~ N(0, Q)`, from a
/// closure `f`, and optionally its Jacobian closure (for the EKF and IEKF).
/// `Q` is checked once, when the model is built.
///
/// ```
/// use bayestrack_kalman::{Ekf, FnDynamics, Gaussian, Ukf};
/// use nalgebra::{Matrix2, Vector2};
///
/// let dt = 0.01;
/// let pendulum = FnDynamics::new(
///     move |x: &Vector2<f64>| Vector2::new(x[0] + dt * x[1], x[1] - dt * 9.81 * x[0].sin()),
///     Matrix2::new(1e-8, 0.0, 0.0, 1e-6),
/// )?;
/// let belief = Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1)?;
/// let ukf_prior = Ukf::new(1e-3, 2.0, 0.0)?.predict(&belief, &pendulum)?;
/// // the EKF needs the Jacobian
/// let pendulum = pendulum.with_jacobian(move |x: &Vector2<f64>| {
///     Matrix2::new(1.0, dt, -dt * 9.81 * x[0].cos(), 1.0)
/// });
/// let ekf_prior = Ekf::default().predict(&belief, &pendulum)?;
/// assert!((ukf_prior.mean() - ekf_prior.mean()).amax() < 1e-2);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct FnDynamics<const N: usize, F, J = NoJacobian> {
    f: F,
    jacobian: J,
    q: NoiseCovariance<N>,
}

impl<const N: usize, F> FnDynamics<N, F>
where
    F: Fn(&SVector<f64, N>) -> SVector<f64, N>,
{
    /// `x_k = f(x_{k-1}) + v`, `v ~ N(0, q)`.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite),
    /// [`KalmanError::NotSymmetric`](crate::KalmanError::NotSymmetric) or
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite)
    /// naming "process noise Q" when `q` is not finite, symmetric and
    /// positive semi-definite.
    pub fn new(f: F, q: SMatrix<f64, N, N>) -> Result<Self> {
        Ok(Self {
            f,
            jacobian: NoJacobian,
            q: NoiseCovariance::named(q, "process noise Q", Step::Construction)?,
        })
    }

    /// The same model with the Jacobian `df/dx` as a closure.
    pub fn with_jacobian<J>(self, jacobian: J) -> FnDynamics<N, F, J>
    where
        J: Fn(&SVector<f64, N>) -> SMatrix<f64, N, N>,
    {
        FnDynamics {
            f: self.f,
            jacobian,
            q: self.q,
        }
    }
}

impl<const N: usize, F, J> Dynamics<N> for FnDynamics<N, F, J>
where
    F: Fn(&SVector<f64, N>) -> SVector<f64, N>,
{
    #[inline]
    fn propagate(&self, x: &SVector<f64, N>) -> SVector<f64, N> {
        (self.f)(x)
    }
    #[inline]
    fn process_noise(&self) -> SMatrix<f64, N, N> {
        *self.q.matrix()
    }
    #[inline(always)]
    fn checked_process_noise(&self) -> Option<NoiseCovariance<N>> {
        Some(self.q)
    }
}

impl<const N: usize, F, J> DynamicsJacobian<N> for FnDynamics<N, F, J>
where
    F: Fn(&SVector<f64, N>) -> SVector<f64, N>,
    J: Fn(&SVector<f64, N>) -> SMatrix<f64, N, N>,
{
    #[inline]
    fn jacobian(&self, x: &SVector<f64, N>) -> SMatrix<f64, N, N> {
        (self.jacobian)(x)
    }
}

/// Additive-noise measurement `z = h(x) + n`, `n ~ N(0, R)`, from a closure
/// `h`, and optionally its Jacobian closure. `R` is checked once, when the
/// model is built.
///
/// The range-bearing radar of an EKF, as filterpy users write it:
///
/// ```
/// use bayestrack_kalman::{Ekf, FnMeasurement, Gaussian};
/// use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector2, Vector4};
///
/// let radar = FnMeasurement::new(
///     |x: &Vector4<f64>| Vector2::new(x[0].hypot(x[2]), x[2].atan2(x[0])),
///     Matrix2::new(0.25, 0.0, 0.0, 1e-4),
/// )?
/// .with_jacobian(|x: &Vector4<f64>| {
///     let r2 = x[0] * x[0] + x[2] * x[2];
///     let r = r2.sqrt();
///     Matrix2x4::new(x[0] / r, 0.0, x[2] / r, 0.0, -x[2] / r2, 0.0, x[0] / r2, 0.0)
/// });
/// let prior = Gaussian::new(Vector4::new(100.0, 1.0, 50.0, 0.0), Matrix4::identity())?;
/// let update = Ekf::default().update(&prior, &radar, Some(&Vector2::new(111.0, 0.47)))?;
/// assert!(update.innovation.unwrap().nis.is_finite());
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct FnMeasurement<const N: usize, const M: usize, H, J = NoJacobian> {
    h: H,
    jacobian: J,
    r: NoiseCovariance<M>,
    _state: std::marker::PhantomData<[(); N]>,
}

impl<const N: usize, const M: usize, H> FnMeasurement<N, M, H>
where
    H: Fn(&SVector<f64, N>) -> SVector<f64, M>,
{
    /// `z = h(x) + n`, `n ~ N(0, r)`.
    ///
    /// # Errors
    /// As [`FnDynamics::new`], naming "measurement noise R".
    pub fn new(h: H, r: SMatrix<f64, M, M>) -> Result<Self> {
        Ok(Self {
            h,
            jacobian: NoJacobian,
            r: NoiseCovariance::named(r, "measurement noise R", Step::Construction)?,
            _state: std::marker::PhantomData,
        })
    }

    /// The same model with the Jacobian `dh/dx` as a closure.
    pub fn with_jacobian<J>(self, jacobian: J) -> FnMeasurement<N, M, H, J>
    where
        J: Fn(&SVector<f64, N>) -> SMatrix<f64, M, N>,
    {
        FnMeasurement {
            h: self.h,
            jacobian,
            r: self.r,
            _state: std::marker::PhantomData,
        }
    }
}

impl<const N: usize, const M: usize, H, J> Measurement<N, M> for FnMeasurement<N, M, H, J>
where
    H: Fn(&SVector<f64, N>) -> SVector<f64, M>,
{
    #[inline]
    fn observe(&self, x: &SVector<f64, N>) -> SVector<f64, M> {
        (self.h)(x)
    }
    #[inline]
    fn measurement_noise(&self) -> SMatrix<f64, M, M> {
        *self.r.matrix()
    }
    #[inline(always)]
    fn checked_measurement_noise(&self) -> Option<NoiseCovariance<M>> {
        Some(self.r)
    }
}

impl<const N: usize, const M: usize, H, J> MeasurementJacobian<N, M> for FnMeasurement<N, M, H, J>
where
    H: Fn(&SVector<f64, N>) -> SVector<f64, M>,
    J: Fn(&SVector<f64, N>) -> SMatrix<f64, M, N>,
{
    #[inline]
    fn jacobian(&self, x: &SVector<f64, N>) -> SMatrix<f64, M, N> {
        (self.jacobian)(x)
    }
}
