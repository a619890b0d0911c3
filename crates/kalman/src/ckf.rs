//! The cubature Kalman filter (Arasaratnam and Haykin 2009).

use nalgebra::SVector;

use crate::error::Result;
use crate::filter::{KalmanPredict, KalmanUpdate};
use crate::gaussian::Gaussian;
use crate::model::{Dynamics, Measurement};
use crate::ukf::{Ukf, UkfStep};
use crate::update::Update;

/// The cubature Kalman filter of Arasaratnam and Haykin (2009): the
/// third-degree spherical-radial rule, `2n` points
/// `m +- sqrt(n) S e_i` (`P = S S^T`) of equal weight `1 / (2n)`.
///
/// These are the points and weights of the scaled unscented transform with
/// `alpha = 1`, `beta = 0`, `kappa = 0`: then `c = alpha^2 (n + kappa) = n`,
/// the central weights `Wm_0 = (c - n) / c` and
/// `Wc_0 = Wm_0 + 1 - alpha^2 + beta` are both 0, and
/// `W_i = 1 / (2c) = 1 / (2n)`. The mean and every
/// covariance of the two rules are therefore the same sums, and the CKF
/// runs on the UKF's sigma-point machinery (`tests/ckf.rs` checks it
/// against a direct implementation of the cubature rule). Unlike the UKF
/// with Julier's `kappa = 3 - n`, no weight is negative for any `n`, so
/// the sigma-point covariances are positive semi-definite in every
/// dimension.
///
/// ```
/// use bayestrack_kalman::{Ckf, FnDynamics, FnMeasurement, Gaussian};
/// use nalgebra::{Matrix1, Matrix2, Vector1, Vector2};
///
/// let dt = 0.01;
/// let pendulum = FnDynamics::new(
///     move |x: &Vector2<f64>| Vector2::new(x[0] + dt * x[1], x[1] - dt * 9.81 * x[0].sin()),
///     Matrix2::new(1e-8, 0.0, 0.0, 1e-6),
/// )?;
/// let sensor = FnMeasurement::new(|x: &Vector2<f64>| Vector1::new(x[0].sin()), Matrix1::new(0.0025))?;
/// let mut belief = Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1)?;
/// for z in [0.47, 0.46, 0.44] {
///     let prior = Ckf.predict(&belief, &pendulum)?;
///     belief = Ckf.update(&prior, &sensor, Some(&Vector1::new(z)))?.posterior;
/// }
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Ckf;

impl Ckf {
    /// Time update with the cubature points of the prior.
    ///
    /// # Errors
    /// As [`Ukf::predict`].
    #[inline]
    pub fn predict<const N: usize, D: Dynamics<N>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        Ukf::cubature().predict(prior, dynamics)
    }

    /// Measurement update with the cubature points of `prior`.
    ///
    /// # Errors
    /// As [`Ukf::update`].
    #[inline]
    pub fn update<const N: usize, const M: usize, H: Measurement<N, M>>(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Ukf::cubature().update(prior, measurement, z)
    }

    /// One cubature point set through `f` then `h`, as [`Ukf::step`].
    ///
    /// # Errors
    /// As [`Ukf::step`].
    #[inline]
    pub fn step<const N: usize, const M: usize, D: Dynamics<N>, H: Measurement<N, M>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<UkfStep<N, M>> {
        Ukf::cubature().step(prior, dynamics, measurement, z)
    }

    /// Cubature Rauch-Tung-Striebel smoothing, as [`Ukf::rts_smooth`].
    ///
    /// # Errors
    /// As [`Ukf::rts_smooth`].
    pub fn rts_smooth<const N: usize, D: Dynamics<N>>(
        &self,
        filtered: &[Gaussian<N>],
        dynamics: &D,
    ) -> Result<Vec<Gaussian<N>>> {
        Ukf::cubature().rts_smooth(filtered, dynamics)
    }
}

impl<const N: usize, D: Dynamics<N>> KalmanPredict<N, D> for Ckf {
    #[inline]
    fn predict(&self, prior: &Gaussian<N>, dynamics: &D) -> Result<Gaussian<N>> {
        Ckf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize, H: Measurement<N, M>> KalmanUpdate<N, M, H> for Ckf {
    #[inline]
    fn update(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        Ckf::update(self, prior, measurement, z)
    }
}
