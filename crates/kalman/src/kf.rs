//! The linear Kalman filter (Bócsi and Csató (paper 001) eq. 1-7, Dong and Chen (paper 004) eq. 9-13), the
//! extended Kalman filter and the iterated extended Kalman filter (Nagy, Ahmed and Zayed (paper 000)
//! sec. 3.2), and the Rauch-Tung-Striebel smoother for linear models.

use nalgebra::{SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;
use crate::model::{
    self, DynamicsJacobian, LinearDynamics, LinearMeasurement, Manifold, MeasurementJacobian,
};
use crate::update::{CovarianceUpdate, Update, gain_step};

/// `F x, F P F^T + Q` for a symmetric `Q` (only its lower triangle is
/// read), exactly symmetric and checked.
#[inline]
fn linear_predict<const N: usize>(
    mean: SVector<f64, N>,
    f: &SMatrix<f64, N, N>,
    p: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) -> Result<Gaussian<N>> {
    let cov = linalg::mirror_lower(linalg::lower_mul_t_add(q, 1.0, &linalg::mul(f, p), f));
    linalg::check_finite_sym_belief(
        &mean,
        "predicted mean",
        &cov,
        "predicted covariance",
        Step::Predict,
    )?;
    Ok(Gaussian::from_parts(mean, cov))
}

#[inline]
fn check_measurement<const M: usize>(z: &SVector<f64, M>) -> Result<()> {
    linalg::check_finite_vec(z, "measurement z", Step::Update)
}

/// The Kalman filter for [`LinearDynamics`] and [`LinearMeasurement`].
///
/// Stateless: the caller owns the [`Gaussian`] belief.
///
/// ```
/// use bayestrack_kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement};
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let dt = 0.1;
/// let dynamics = LinearDynamics::new(
///     Matrix2::new(1.0, dt, 0.0, 1.0),
///     Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.1,
/// )?;
/// let sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25))?;
/// let kf = Kf::default();
/// let mut belief = Gaussian::new(Vector2::zeros(), Matrix2::identity())?;
/// for z in [0.1, 0.22, 0.29] {
///     let prior = kf.predict(&belief, &dynamics)?;
///     let update = kf.update(&prior, &sensor, Some(&Vector1::new(z)))?;
///     assert!(update.innovation.unwrap().nis >= 0.0);
///     belief = update.posterior;
/// }
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Kf {
    /// Posterior covariance form (Joseph by default).
    pub covariance_update: CovarianceUpdate,
}

impl Kf {
    /// A filter with the given covariance form.
    pub fn new(covariance_update: CovarianceUpdate) -> Self {
        Self { covariance_update }
    }

    /// Time update `x = F x`, `P = F P F^T + Q` (no control input; see
    /// [`Kf::predict_with_control`]).
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] for a non-finite result.
    #[inline]
    pub fn predict<const N: usize, const U: usize>(
        &self,
        prior: &Gaussian<N>,
        model: &LinearDynamics<N, U>,
    ) -> Result<Gaussian<N>> {
        let f = model.transition();
        linear_predict(linalg::mul(f, prior.mean()), f, prior.cov(), model.noise())
    }

    /// Time update with a control input: `x = F x + B u`,
    /// `P = F P F^T + Q`.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] for a non-finite control or result.
    #[inline]
    pub fn predict_with_control<const N: usize, const U: usize>(
        &self,
        prior: &Gaussian<N>,
        model: &LinearDynamics<N, U>,
        control: &SVector<f64, U>,
    ) -> Result<Gaussian<N>> {
        linalg::check_finite_vec(control, "control input u", Step::Predict)?;
        let f = model.transition();
        let mean = linalg::mul(f, prior.mean()) + model.control() * control;
        linear_predict(mean, f, prior.cov(), model.noise())
    }

    /// Measurement update with `z` (`None` = missing: the prior is returned).
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] for a non-finite `z`, or for a residual so
    /// large (1e155 and beyond) that its NIS and log-likelihood overflow;
    /// [`KalmanError::NotPositiveDefinite`] naming the innovation covariance
    /// `S` when it is singular.
    #[inline]
    pub fn update<const N: usize, const M: usize>(
        &self,
        prior: &Gaussian<N>,
        model: &LinearMeasurement<N, M>,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        // H and R were checked (R symmetrised) when the model was built
        Ekf::new(self.covariance_update).update_with(prior, model, model.noise(), z, false)
    }

    /// Rauch-Tung-Striebel smoothing of filtered beliefs `x_{k|k}`, k = 0..T-1,
    /// produced with `model`; `controls[k]` is the input applied between k and
    /// k+1 (so `T - 1` of them), or `None`.
    ///
    /// # Errors
    /// [`KalmanError::DimensionMismatch`] when `controls` has the wrong
    /// length; [`KalmanError::NotPositiveDefinite`] when a predicted
    /// covariance cannot be factored.
    pub fn rts_smooth<const N: usize, const U: usize>(
        &self,
        filtered: &[Gaussian<N>],
        model: &LinearDynamics<N, U>,
        controls: Option<&[SVector<f64, U>]>,
    ) -> Result<Vec<Gaussian<N>>> {
        if let Some(u) = controls {
            let expected = filtered.len().saturating_sub(1);
            if u.len() != expected {
                return Err(KalmanError::DimensionMismatch {
                    what: "controls",
                    expected,
                    got: u.len(),
                });
            }
        }
        let f = model.transition();
        crate::smoother::rts_backward(
            filtered,
            |a, b| a - b,
            |k, g| {
                let mut mean = f * g.mean();
                if let Some(u) = controls {
                    mean += model.control() * u[k];
                }
                let predicted = linear_predict(mean, f, g.cov(), model.noise())?;
                // cross-covariance of x_k and x_{k+1}: P_k F^T
                Ok((predicted, g.cov() * f.transpose()))
            },
        )
    }
}

/// The extended Kalman filter: `f` and `h` linearised about the current
/// estimate with user Jacobians.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Ekf {
    /// Posterior covariance form (Joseph by default).
    pub covariance_update: CovarianceUpdate,
}

impl Ekf {
    /// A filter with the given covariance form.
    pub fn new(covariance_update: CovarianceUpdate) -> Self {
        Self { covariance_update }
    }

    /// `x = f(x)`, `P = F P F^T + Q` with `F` evaluated at the prior mean.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] when `F`, `Q` or the result is not finite;
    /// [`KalmanError::NotSymmetric`] or [`KalmanError::NotPositiveDefinite`]
    /// naming "process noise Q" in the predict step when the model's `Q` is
    /// not symmetric positive semi-definite (singular is accepted).
    pub fn predict<const N: usize, D: DynamicsJacobian<N>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        let f = dynamics.jacobian(prior.mean());
        linalg::check_finite_mat(&f, "Jacobian F", Step::Predict)?;
        let q = model::process_noise(dynamics, Step::Predict)?;
        linear_predict(dynamics.propagate(prior.mean()), &f, prior.cov(), &q)
    }

    /// Update with `nu = z - h(x)` (taken in the model's [`Measurement::measurement_space`](crate::Measurement::measurement_space))
    /// and `H` evaluated at the prior mean.
    ///
    /// # Errors
    /// As [`Kf::update`]; [`KalmanError::NonFinite`],
    /// [`KalmanError::NotSymmetric`] or [`KalmanError::NotPositiveDefinite`]
    /// naming "measurement noise R" in the update step when the model's `R`
    /// is not finite, symmetric and positive semi-definite.
    #[inline]
    pub fn update<const N: usize, const M: usize, H: MeasurementJacobian<N, M>>(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        if z.is_none() {
            return Ok(Update::missing(prior));
        }
        let r = model::measurement_noise(measurement)?;
        self.update_with(prior, measurement, &r, z, true)
    }

    /// [`Ekf::update`] with the measurement noise `r` already checked and
    /// symmetrised; `check_jacobian: false` for a constant `H` checked when
    /// its model was built.
    #[inline(always)]
    fn update_with<const N: usize, const M: usize, H: MeasurementJacobian<N, M>>(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        r: &SMatrix<f64, M, M>,
        z: Option<&SVector<f64, M>>,
        check_jacobian: bool,
    ) -> Result<Update<N, M>> {
        let Some(z) = z else {
            return Ok(Update::missing(prior));
        };
        check_measurement(z)?;
        let x = prior.mean();
        let h = measurement.jacobian(x);
        if check_jacobian {
            linalg::check_finite_mat(&h, "Jacobian H", Step::Update)?;
        }
        let step = gain_step(
            x,
            prior.cov(),
            measurement
                .measurement_space()
                .residual(z, &measurement.observe(x)),
            &h,
            r,
            self.covariance_update,
        )?;
        Ok(Update {
            posterior: Gaussian::from_parts(step.mean, step.cov),
            innovation: Some(step.innovation),
            iterations: 1,
        })
    }
}

/// The iterated extended Kalman filter (Nagy, Ahmed and Zayed (paper 000) sec. 3.2): the measurement
/// update relinearises `h` about the latest iterate,
///
/// `x_{i+1} = x_f + K_i (z - h(x_i) - H_i (x_f - x_i))`,
/// `K_i = P H_i^T (H_i P H_i^T + R)^{-1}`, `H_i = dh/dx (x_i)`, `x_0 = x_f`,
///
/// the Gauss-Newton form of Bell and Cathey (1993). Nagy, Ahmed and Zayed (paper 000) prints the
/// iterate without the `- H_i (x_f - x_i)` term; that variant does not
/// converge to the MAP estimate and is not implemented. With one iteration
/// this is exactly the EKF update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iekf {
    max_iterations: usize,
    tolerance: f64,
    /// Posterior covariance form (Joseph by default).
    pub covariance_update: CovarianceUpdate,
}

impl Iekf {
    /// At most `max_iterations` relinearisations (Nagy, Ahmed and Zayed's (paper 000) `c`), stopping
    /// early when an iterate moves less than `tolerance` (infinity norm).
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] for zero iterations or a negative
    /// or non-finite tolerance.
    pub fn new(max_iterations: usize, tolerance: f64) -> Result<Self> {
        if max_iterations == 0 {
            return Err(KalmanError::InvalidParameter {
                name: "max_iterations",
                value: 0.0,
                reason: "at least one iteration is needed",
            });
        }
        if !(tolerance >= 0.0 && tolerance.is_finite()) {
            return Err(KalmanError::InvalidParameter {
                name: "tolerance",
                value: tolerance,
                reason: "must be finite and non-negative",
            });
        }
        Ok(Self {
            max_iterations,
            tolerance,
            covariance_update: CovarianceUpdate::default(),
        })
    }

    /// Maximum number of relinearisations.
    pub fn max_iterations(&self) -> usize {
        self.max_iterations
    }

    /// Early-stopping tolerance on the step.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// The prediction is the EKF's.
    ///
    /// # Errors
    /// As [`Ekf::predict`].
    pub fn predict<const N: usize, D: DynamicsJacobian<N>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        Ekf::new(self.covariance_update).predict(prior, dynamics)
    }

    /// The iterated update. The reported innovation and covariance belong to
    /// the last linearisation (the linearised residual
    /// `z - h(x_i) - H_i (x_f - x_i)`).
    ///
    /// # Errors
    /// As [`Kf::update`].
    pub fn update<const N: usize, const M: usize, H: MeasurementJacobian<N, M>>(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        self.update_from(prior, prior.mean(), measurement, z)
    }

    /// The iterated update started from the linearisation point `x0` instead
    /// of the prior mean (the hybrid UKF->IEKF step starts from the UKF's
    /// estimate).
    ///
    /// # Errors
    /// As [`Kf::update`], and [`KalmanError::NonFinite`] for a non-finite `x0`.
    pub fn update_from<const N: usize, const M: usize, H: MeasurementJacobian<N, M>>(
        &self,
        prior: &Gaussian<N>,
        x0: &SVector<f64, N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        let Some(z) = z else {
            return Ok(Update::missing(prior));
        };
        check_measurement(z)?;
        linalg::check_finite_vec(x0, "linearisation point", Step::Update)?;
        let xf = prior.mean();
        let r = model::measurement_noise(measurement)?;
        let space = measurement.measurement_space();
        let mut xi = *x0;
        let mut iterations = 0;
        loop {
            iterations += 1;
            let h = measurement.jacobian(&xi);
            linalg::check_finite_mat(&h, "Jacobian H", Step::Update)?;
            let residual = space.residual(z, &measurement.observe(&xi)) - h * (xf - xi);
            let step = gain_step(xf, prior.cov(), residual, &h, &r, self.covariance_update)?;
            let moved = (step.mean - xi).amax();
            xi = step.mean;
            if iterations >= self.max_iterations || moved <= self.tolerance {
                return Ok(Update {
                    posterior: Gaussian::from_parts(step.mean, step.cov),
                    innovation: Some(step.innovation),
                    iterations,
                });
            }
        }
    }
}
