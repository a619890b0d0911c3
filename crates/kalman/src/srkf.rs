//! The square-root Kalman filter for linear models (the array form of
//! Morf and Kailath 1975; Bierman 1977, ch. V): the belief keeps a
//! Cholesky factor, and both steps form the new factor by rotations.

use nalgebra::SVector;

use crate::belief::FilterBelief;
use crate::error::{Result, Step};
use crate::filter::{KalmanPredict, KalmanUpdate};
use crate::linalg;
use crate::model::{LinearDynamics, LinearMeasurement};
use crate::srukf::{SqrtGaussian, SqrtUpdate, joint_posterior};

/// The square-root Kalman filter for linear-Gaussian models: the belief is
/// a [`SqrtGaussian`] (mean and lower Cholesky factor `L`, `P = L L^T`),
/// so the covariance is positive semi-definite by construction.
///
/// - predict: `x = F x`, `L' = tria([F L, sqrt(Q)])` (the factor of
///   `F P F^T + Q`, by Householder reflections; no `F P F^T` is formed);
/// - update: the triangularisation of `[[sqrt(R), H L], [0, L]]` is
///   `[[S_y, 0], [U, L+]]` with `S_y S_y^T = S = H P H^T + R`, the gain
///   `K = U S_y^{-1}` and `L+ L+^T = P - K S K^T`; the mean is
///   `x + U (S_y^{-1} nu)`. The same array form as the SR-UKF's update
///   ([`SrUkf`](crate::SrUkf)), with the deviations `H L_j` of a linear
///   model in place of sigma points.
///
/// Algebraically [`Kf`](crate::Kf) (`tests/srkf.rs` checks it to 1e-10,
/// and `tests/filterpy_imm.rs` against filterpy's
/// `SquareRootKalmanFilter`). Cost: about twice the KF's (rotations in
/// place of products), paid for a factor that cannot lose definiteness.
///
/// ```
/// use bayestrack_kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel, SqrtGaussian, SrKf};
/// use nalgebra::{Matrix2, Vector2, Vector4, Matrix4};
///
/// let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.5, NoiseModel::Discrete)?;
/// let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25)?;
/// let start = Gaussian::new(Vector4::zeros(), Matrix4::identity())?;
/// let z = Vector2::new(0.1, -0.2);
/// let sr = SrKf.update(&SrKf.predict(&SqrtGaussian::from_gaussian(&start)?, &dynamics)?, &sensor, Some(&z))?;
/// let kf = Kf::default();
/// let full = kf.update(&kf.predict(&start, &dynamics)?, &sensor, Some(&z))?;
/// assert!((sr.posterior.cov() - full.posterior.cov()).amax() < 1e-12);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SrKf;

impl SrKf {
    /// Time update `x = F x`, `L' = tria([F L, sqrt(Q)])`.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) for a
    /// non-finite result.
    #[inline]
    pub fn predict<const N: usize, const U: usize>(
        &self,
        prior: &SqrtGaussian<N>,
        model: &LinearDynamics<N, U>,
    ) -> Result<SqrtGaussian<N>> {
        let step = Step::Predict;
        let f = model.transition();
        // Q was checked (finite, symmetric, PSD) when the model was built
        let mut l = linalg::psd_sqrt(model.noise(), "process noise Q", step)?;
        linalg::tria_into(&mut l, &linalg::mul(f, prior.cholesky_l()));
        let mean = linalg::mul(f, prior.mean());
        linalg::check_finite_vec(&mean, "predicted mean", step)?;
        linalg::check_finite_mat(&l, "predicted covariance factor", step)?;
        Ok(SqrtGaussian::from_parts(mean, l))
    }

    /// Measurement update with `z` (`None` = missing: the prior is
    /// returned), in the array form (see [`SrKf`]).
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) for a
    /// non-finite `z`, posterior or NIS and log-likelihood;
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite)
    /// naming "innovation covariance S" when it is singular.
    #[inline]
    pub fn update<const N: usize, const M: usize>(
        &self,
        prior: &SqrtGaussian<N>,
        model: &LinearMeasurement<N, M>,
        z: Option<&SVector<f64, M>>,
    ) -> Result<SqrtUpdate<N, M>> {
        let Some(z) = z else {
            return Ok(SqrtUpdate::missing(prior));
        };
        let step = Step::Update;
        linalg::check_finite_vec(z, "measurement z", step)?;
        let h = model.matrix();
        let l = prior.cholesky_l();
        let mut joint = linalg::JointFactor::<M, N>::new(linalg::psd_sqrt(
            model.noise(),
            "measurement noise R",
            step,
        )?);
        joint.tria(linalg::Cols::one(linalg::mul(h, l)), linalg::Cols::one(*l));
        let residual = z - linalg::mul(h, prior.mean());
        joint_posterior(&joint, prior.mean(), residual, step)
    }
}

impl<const N: usize> FilterBelief<N> for SrKf {
    type Belief = SqrtGaussian<N>;
}

impl<const N: usize, const U: usize> KalmanPredict<N, LinearDynamics<N, U>> for SrKf {
    #[inline]
    fn predict(
        &self,
        prior: &SqrtGaussian<N>,
        dynamics: &LinearDynamics<N, U>,
    ) -> Result<SqrtGaussian<N>> {
        SrKf::predict(self, prior, dynamics)
    }
}

impl<const N: usize, const M: usize> KalmanUpdate<N, M, LinearMeasurement<N, M>> for SrKf {
    #[inline]
    fn update(
        &self,
        prior: &SqrtGaussian<N>,
        measurement: &LinearMeasurement<N, M>,
        z: Option<&SVector<f64, M>>,
    ) -> Result<SqrtUpdate<N, M>> {
        SrKf::update(self, prior, measurement, z)
    }
}
