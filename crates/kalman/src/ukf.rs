//! The unscented Kalman filter with scaled sigma points (Bócsi and Csató (paper 001) eq. 8-12;
//! Julier 2002; van der Merwe 2004), in additive-noise and augmented-state
//! forms (Nagy, Ahmed and Zayed (paper 000) sec. 3.3), and the unscented RTS smoother (Sarkka 2008).
//!
//! For an `L`-dimensional (possibly augmented) state with mean `m` and
//! covariance `P = S S^T`:
//!
//! `c = alpha^2 (L + kappa)`, `lambda = c - L`,
//! `X_0 = m`, `X_{i} = m + sqrt(c) S_i`, `X_{L+i} = m - sqrt(c) S_i`,
//! `Wm_0 = lambda / c`, `Wc_0 = Wm_0 + 1 - alpha^2 + beta`,
//! `Wm_i = Wc_i = 1 / (2c)`.
//!
//! `Wm_0` may be negative (small `alpha`); only `c > 0` is required. The
//! augmented covariance `diag(P, Q_v, R_n)` is block diagonal, so its square
//! root is taken block by block and no `L x L` matrix is ever formed.

use nalgebra::{SMatrix, SVector};

#[cfg(doc)]
use crate::error::KalmanError;
use crate::error::{Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;
use crate::model::{
    self, Additive, Dynamics, Euclidean, Manifold, Measurement, NoisyDynamics, NoisyMeasurement,
};
use crate::sigma::{SigmaPoints, no_output, none};
use crate::update::Update;

/// Scaled unscented transform parameters and the filter built on them.
///
/// ```
/// use bayestrack_kalman::{Dynamics, Gaussian, Measurement, Ukf};
/// use nalgebra::{Matrix1, Matrix2, SMatrix, SVector, Vector1, Vector2};
///
/// /// Pendulum: theta += dt omega, omega -= dt g/L sin theta; z = sin theta.
/// struct Pendulum;
/// impl Dynamics<2> for Pendulum {
///     fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
///         Vector2::new(x[0] + 0.01 * x[1], x[1] - 0.01 * 9.81 * x[0].sin())
///     }
///     fn process_noise(&self) -> SMatrix<f64, 2, 2> {
///         Matrix2::new(1e-8, 0.0, 0.0, 1e-6)
///     }
/// }
/// impl Measurement<2, 1> for Pendulum {
///     fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
///         Vector1::new(x[0].sin())
///     }
///     fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
///         Matrix1::new(0.0025)
///     }
/// }
///
/// let ukf = Ukf::new(1e-3, 2.0, 0.0)?;
/// let mut belief = Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1)?;
/// for z in [0.47, 0.46, 0.44] {
///     // the default: predict, then redraw the sigma points from the
///     // prediction for the update (as filterpy and most references do)
///     let prior = ukf.predict(&belief, &Pendulum)?;
///     let update = ukf.update(&prior, &Pendulum, Some(&Vector1::new(z)))?;
///     assert!(update.innovation.is_some());
///     belief = update.posterior;
/// }
///
/// // the faster variant: one sigma-point set through `f` and then `h`
/// // (no redraw; a slightly different answer unless `f` is linear and Q = 0)
/// let step = ukf.step(&belief, &Pendulum, &Pendulum, Some(&Vector1::new(0.43)))?;
/// assert!(step.update.innovation.is_some());
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
///
/// Angles in the state or the measurement (a heading, a bearing): the
/// model names its [`Manifold`] ([`Dynamics::state_space`],
/// [`Measurement::measurement_space`], and the same methods of
/// [`NoisyDynamics`] and [`NoisyMeasurement`] for the augmented form; an
/// [`Angles`](crate::Angles) wraps); the UKF forms every sigma-point
/// difference, mean and innovation through it.
///
/// How the noise of an additive model enters, [`NoiseForm`], is chosen
/// once, on the filter ([`Ukf::with_noise_form`]); `predict`, `update` and
/// `step`, called directly or through [`KalmanFilter`](crate::KalmanFilter)
/// and the particle filters' local step, all read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ukf {
    points: SigmaPoints,
    noise: NoiseForm,
}

/// How the noise of an additive model (`x_k = f(x_{k-1}) + v`,
/// `z = h(x) + n`) enters the sigma-point filter: the one place that
/// decides it, read by every UKF step ([`Ukf::predict`], [`Ukf::update`],
/// [`Ukf::step`]) whichever trait calls it.
///
/// The two forms agree for linear models and differ (by the spread of the
/// points: the weights depend on the dimension of the set) for nonlinear
/// ones.
///
/// ```
/// use bayestrack_kalman::{Gaussian, KalmanPredict, NoiseForm, Ukf, FnDynamics};
/// use nalgebra::{Matrix2, Vector2};
///
/// let pendulum = FnDynamics::new(
///     |x: &Vector2<f64>| Vector2::new(x[0] + 0.1 * x[1], x[1] - 0.981 * x[0].sin()),
///     Matrix2::new(1e-4, 0.0, 0.0, 1e-2),
/// )?;
/// let belief = Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1)?;
/// let augmented = Ukf::new(1.0, 2.0, 0.0)?.with_noise_form(NoiseForm::Augmented);
/// // the inherent method and the trait give the augmented form's answer
/// let p = augmented.predict(&belief, &pendulum)?;
/// assert_eq!(KalmanPredict::predict(&augmented, &belief, &pendulum)?, p);
/// assert_eq!(augmented.predict_augmented(&belief, &bayestrack_kalman::Additive(&pendulum))?, p);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum NoiseForm {
    /// `Q` and `R` are added to the sigma-point covariances
    /// (`P = sum Wc dX dX^T + Q`): sigma points of the `N`-dimensional
    /// state only. The default, as filterpy's `UnscentedKalmanFilter`.
    #[default]
    Additive,
    /// The state is augmented with the noise (Nagy, Ahmed and Zayed (paper
    /// 000) sec. 3.3): sigma points of `[x; v]` through `f(x) + v` in the
    /// prediction, of `[x; n]` through `h(x) + n` in the update
    /// ([`Ukf::predict_augmented`] and [`Ukf::update_augmented`] with the
    /// model seen through [`Additive`](crate::Additive)); in [`Ukf::step`],
    /// one set of `[x; v; n]` ([`Ukf::step_augmented`]).
    Augmented,
}

/// The predicted belief and the measurement update of a joint UKF step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UkfStep<const N: usize, const M: usize> {
    /// `x_{k|k-1}` from the sigma points pushed through `f`.
    pub predicted: Gaussian<N>,
    /// The update with the same sigma points pushed through `h`.
    pub update: Update<N, M>,
}

impl Ukf {
    /// Scaled sigma points with spread `alpha`, prior-knowledge `beta` (2 is
    /// optimal for Gaussians) and secondary scaling `kappa`.
    ///
    /// `alpha` lies in `[1e-4, 1e150]`: van der Merwe's range starts at
    /// 1e-4, and below it the points sit so close to the mean that the
    /// round-off of `f(X_i) - f(X_0)`, multiplied by `W_i ~ 1 / alpha^2`,
    /// replaces the covariance (at 1e-160 the weights themselves overflow);
    /// above 1e150 `alpha^2` overflows. The conditions that also involve
    /// the state dimension `L` are checked by [`Ukf::weights`] and every
    /// filter step.
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] naming `alpha` outside
    /// `[1e-4, 1e150]` or NaN, or a non-finite `beta` or `kappa`.
    pub fn new(alpha: f64, beta: f64, kappa: f64) -> Result<Self> {
        Ok(Self {
            points: SigmaPoints::new(alpha, beta, kappa)?,
            noise: NoiseForm::Additive,
        })
    }

    /// The UKF whose points are the cubature rule's (see [`Ckf`](crate::Ckf)).
    pub(crate) const fn cubature() -> Self {
        Self {
            points: SigmaPoints::cubature(),
            noise: NoiseForm::Additive,
        }
    }

    /// This filter with the noise of additive models entering in `form`
    /// (the default is [`NoiseForm::Additive`]).
    #[must_use]
    pub const fn with_noise_form(mut self, form: NoiseForm) -> Self {
        self.noise = form;
        self
    }

    /// How the noise of additive models enters ([`NoiseForm`]).
    pub const fn noise_form(&self) -> NoiseForm {
        self.noise
    }

    /// The checked sigma-point parameters (shared with the SR-UKF).
    #[inline(always)]
    pub(crate) fn points(&self) -> &SigmaPoints {
        &self.points
    }

    /// `alpha`.
    pub fn alpha(&self) -> f64 {
        self.points.alpha
    }

    /// `beta`.
    pub fn beta(&self) -> f64 {
        self.points.beta
    }

    /// `kappa`.
    pub fn kappa(&self) -> f64 {
        self.points.kappa
    }

    /// The weights `(Wm_0, Wc_0, W_i)` for a state of dimension `l`.
    ///
    /// Valid parameters for dimension `L` have
    /// - `1e-8 <= c = alpha^2 (L + kappa) < inf`: the sigma points exist
    ///   and lie at least 1e-4 standard deviations from the mean;
    /// - `alpha^2 kappa + beta L >= 0`: the sigma-point covariance
    ///   `sum W_i dX_i dX_i^T + (beta - alpha^2) d d^T` (see `transform`)
    ///   is positive semi-definite for every model. With all deviations
    ///   `dX_i` equal (an even `f`) it is `2 L W_i (1 + (beta - alpha^2)
    ///   L / c) dX dX^T`, so the condition is also necessary: `beta = -1e6`
    ///   gave a variance of -999995, and Julier's `kappa = 3 - L` with
    ///   `beta = 0` fails it for `L > 3`.
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] naming `kappa` or `beta` (the
    /// parameter that breaks the condition) otherwise.
    pub fn weights(&self, l: usize) -> Result<(f64, f64, f64)> {
        let w = self.points.weights_for(l)?;
        Ok((w.wm0, w.wc0, w.wi))
    }
    /// One sigma-point set through `f` then `h`; `q_add` and `r_add` are the
    /// additive noise covariances (zero in the augmented form, whose noise
    /// is in the sigma points).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn joint<const N: usize, const V: usize, const W: usize, const M: usize>(
        &self,
        prior: &Gaussian<N>,
        v: &Gaussian<V>,
        w: &Gaussian<W>,
        f: impl Fn(&SVector<f64, N>, &SVector<f64, V>) -> SVector<f64, N>,
        h: impl Fn(&SVector<f64, N>, &SVector<f64, W>) -> SVector<f64, M>,
        q_add: &SMatrix<f64, N, N>,
        r_add: &SMatrix<f64, M, M>,
        z: &SVector<f64, M>,
        sx: &impl Manifold<N>,
        sz: &impl Manifold<M>,
    ) -> Result<UkfStep<N, M>> {
        let mo = self
            .points
            .transform(prior, v, w, f, h, sx, sz, Step::Predict)?;
        // the means are checked with the prediction (both of them)
        let predicted = mo.prediction(linalg::add_sym(&mo.p_xx, q_add), Step::Predict)?;
        let s = linalg::add_sym(&mo.p_yy, r_add);
        let update =
            SigmaPoints::correct(&predicted, &mo.y_mean, s, &mo.p_xy, z, sz, -0.0, || Ok(()))?;
        Ok(UkfStep { predicted, update })
    }

    /// Time update: sigma points of the prior through `f`,
    /// `P = sum Wc (X - x)(X - x)^T + Q` ([`NoiseForm::Additive`], the
    /// default), or [`Ukf::predict_augmented`] of the model seen through
    /// [`Additive`](crate::Additive) ([`NoiseForm::Augmented`]).
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`] when the prior covariance has no
    /// square root; [`KalmanError::NonFinite`] for a non-finite result;
    /// [`KalmanError::NonFinite`], [`KalmanError::NotSymmetric`] or
    /// [`KalmanError::NotPositiveDefinite`] naming "process noise Q" in the
    /// predict step when the model's `Q` is not finite, symmetric and
    /// positive semi-definite (singular is accepted).
    #[inline]
    pub fn predict<const N: usize, D: Dynamics<N>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        if self.noise == NoiseForm::Augmented {
            return self.predict_additive_augmented(*prior, dynamics);
        }
        let q = model::process_noise(dynamics, Step::Predict)?;
        let mo = self.points.transform(
            prior,
            &none::<0>(),
            &none::<0>(),
            |x, _| dynamics.propagate(x),
            no_output,
            &dynamics.state_space(),
            &Euclidean,
            Step::Predict,
        )?;
        mo.prediction(linalg::add_sym(&mo.p_xx, &q), Step::Predict)
    }

    /// [`Ukf::predict_augmented`] of `dynamics` seen through [`Additive`],
    /// out of line and with the prior passed by value: the hot (additive)
    /// path of [`Ukf::predict`] then keeps its belief in registers (a
    /// reference passed to an out-of-line call pins it to memory).
    #[inline(never)]
    fn predict_additive_augmented<const N: usize, D: Dynamics<N>>(
        &self,
        prior: Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        self.predict_augmented(&prior, &Additive(dynamics))
    }

    /// [`Ukf::update_augmented`] of `measurement` seen through
    /// [`Additive`], out of line with its inputs by value (as
    /// [`Ukf::predict_additive_augmented`]).
    #[inline(never)]
    fn update_additive_augmented<const N: usize, const M: usize, H: Measurement<N, M>>(
        &self,
        prior: Gaussian<N>,
        measurement: &H,
        z: SVector<f64, M>,
    ) -> Result<Update<N, M>> {
        self.update_augmented(&prior, &Additive(measurement), Some(&z))
    }

    /// [`Ukf::step_augmented`] of the models seen through [`Additive`], out
    /// of line with its inputs by value (as
    /// [`Ukf::predict_additive_augmented`]).
    #[inline(never)]
    fn step_additive_augmented<
        const N: usize,
        const M: usize,
        D: Dynamics<N>,
        H: Measurement<N, M>,
    >(
        &self,
        prior: Gaussian<N>,
        dynamics: &D,
        measurement: &H,
        z: SVector<f64, M>,
    ) -> Result<UkfStep<N, M>> {
        self.step_augmented(
            &prior,
            &Additive(dynamics),
            &Additive(measurement),
            Some(&z),
        )
    }

    /// Measurement update with sigma points drawn from `prior`, in the
    /// filter's [`NoiseForm`] (augmented: [`Ukf::update_augmented`] of the
    /// model seen through [`Additive`](crate::Additive)).
    ///
    /// # Errors
    /// As [`Ukf::predict`]; [`KalmanError::NotPositiveDefinite`] naming the
    /// innovation covariance when it is singular; non-finite `z`, or NIS and
    /// log-likelihood that overflow; the checks of `Q` applied to the
    /// model's `R` ("measurement noise R", update step).
    #[inline]
    pub fn update<const N: usize, const M: usize, H: Measurement<N, M>>(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        let Some(z) = z else {
            return Ok(Update::missing(prior));
        };
        if self.noise == NoiseForm::Augmented {
            return self.update_additive_augmented(*prior, measurement, *z);
        }
        let r = model::measurement_noise(measurement)?;
        let mo = self.points.transform(
            prior,
            &none::<0>(),
            &none::<0>(),
            |x, _| *x,
            |x, _| measurement.observe(x),
            &Euclidean,
            &measurement.measurement_space(),
            Step::Update,
        )?;
        SigmaPoints::correct(
            prior,
            &mo.y_mean,
            linalg::add_sym(&mo.p_yy, &r),
            &mo.p_xy,
            z,
            &measurement.measurement_space(),
            mo.means_sum(),
            || mo.check_means(Step::Update),
        )
    }

    /// The faster variant of [`Ukf::predict`] followed by [`Ukf::update`]
    /// (the default, which redraws the sigma points from `x_{k|k-1}`, as
    /// filterpy 1.4.5 and later do): predict and update with ONE sigma-point
    /// set, the points of the prior through `f` and the propagated points
    /// through `h` (`Q` enters `P_{k|k-1}` but not the cross-covariance).
    /// One square root and one pass instead of two; identical to the default
    /// for linear `f` only when `Q = 0`. With [`NoiseForm::Augmented`],
    /// [`Ukf::step_augmented`] of the model seen through
    /// [`Additive`](crate::Additive) (one set of `[x; v; n]`).
    ///
    /// # Errors
    /// As [`Ukf::predict`] and [`Ukf::update`].
    #[inline]
    pub fn step<const N: usize, const M: usize, D: Dynamics<N>, H: Measurement<N, M>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<UkfStep<N, M>> {
        let Some(z) = z else {
            let predicted = self.predict(prior, dynamics)?;
            return Ok(UkfStep {
                predicted,
                update: Update::missing(&predicted),
            });
        };
        if self.noise == NoiseForm::Augmented {
            return self.step_additive_augmented(*prior, dynamics, measurement, *z);
        }
        let q = model::process_noise(dynamics, Step::Predict)?;
        let r = model::measurement_noise(measurement)?;
        self.joint(
            prior,
            &none::<0>(),
            &none::<0>(),
            |x, _| dynamics.propagate(x),
            |x, _| measurement.observe(x),
            &q,
            &r,
            z,
            &dynamics.state_space(),
            &measurement.measurement_space(),
        )
    }

    /// Augmented time update: sigma points of `[x; v]` through `f(x, v)`.
    ///
    /// # Errors
    /// As [`Ukf::predict`].
    pub fn predict_augmented<const N: usize, const V: usize, D: NoisyDynamics<N, V>>(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
    ) -> Result<Gaussian<N>> {
        let mo = self.points.transform(
            prior,
            &dynamics.process_noise_dist(),
            &none::<0>(),
            |x, v| dynamics.propagate_with(x, v),
            no_output,
            &dynamics.state_space(),
            &Euclidean,
            Step::Predict,
        )?;
        mo.prediction(mo.p_xx, Step::Predict)
    }

    /// Augmented measurement update: sigma points of `[x; n]` through `h(x, n)`.
    ///
    /// # Errors
    /// As [`Ukf::update`].
    pub fn update_augmented<
        const N: usize,
        const M: usize,
        const W: usize,
        H: NoisyMeasurement<N, M, W>,
    >(
        &self,
        prior: &Gaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<Update<N, M>> {
        let Some(z) = z else {
            return Ok(Update::missing(prior));
        };
        let mo = self.points.transform(
            prior,
            &none::<0>(),
            &measurement.measurement_noise_dist(),
            |x, _| *x,
            |x, n| measurement.observe_with(x, n),
            &Euclidean,
            &measurement.measurement_space(),
            Step::Update,
        )?;
        SigmaPoints::correct(
            prior,
            &mo.y_mean,
            mo.p_yy,
            &mo.p_xy,
            z,
            &measurement.measurement_space(),
            mo.means_sum(),
            || mo.check_means(Step::Update),
        )
    }

    /// The joint augmented step of Nagy, Ahmed and Zayed (paper 000) sec. 3.3 (a): ONE sigma-point
    /// set of `x_a = [x; v; n]`, pushed through `f(x, v)` and then `h(., n)`.
    ///
    /// # Errors
    /// As [`Ukf::step`].
    pub fn step_augmented<
        const N: usize,
        const V: usize,
        const M: usize,
        const W: usize,
        D: NoisyDynamics<N, V>,
        H: NoisyMeasurement<N, M, W>,
    >(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<UkfStep<N, M>> {
        let Some(z) = z else {
            let predicted = self.predict_augmented(prior, dynamics)?;
            return Ok(UkfStep {
                predicted,
                update: Update::missing(&predicted),
            });
        };
        self.joint(
            prior,
            &dynamics.process_noise_dist(),
            &measurement.measurement_noise_dist(),
            |x, v| dynamics.propagate_with(x, v),
            |x, n| measurement.observe_with(x, n),
            &SMatrix::zeros(),
            &SMatrix::zeros(),
            z,
            &dynamics.state_space(),
            &measurement.measurement_space(),
        )
    }

    /// Unscented Rauch-Tung-Striebel smoothing (Sarkka 2008) of filtered
    /// beliefs produced with additive-noise `dynamics`, its predictions in
    /// the filter's [`NoiseForm`].
    ///
    /// # Errors
    /// As [`Ukf::predict`]; [`KalmanError::NotPositiveDefinite`] when a
    /// predicted covariance cannot be factored.
    pub fn rts_smooth<const N: usize, D: Dynamics<N>>(
        &self,
        filtered: &[Gaussian<N>],
        dynamics: &D,
    ) -> Result<Vec<Gaussian<N>>> {
        let q = model::process_noise(dynamics, Step::Smooth)?;
        let space = dynamics.state_space();
        let residual = |a: &SVector<f64, N>, b: &SVector<f64, N>| space.residual(a, b);
        crate::smoother::rts_backward(filtered, residual, |_, g| {
            self.smoothing_prediction(g, dynamics, &q)
        })
    }

    /// The prediction `x_{k+1|k}` from `x_{k|k}` and the sigma-point
    /// cross-covariance `Cov(x_k, x_{k+1})` (Sarkka 2008), for the
    /// smoothers; `q` is the model's checked process noise.
    #[inline]
    pub(crate) fn smoothing_prediction<const N: usize, D: Dynamics<N>>(
        &self,
        g: &Gaussian<N>,
        dynamics: &D,
        q: &SMatrix<f64, N, N>,
    ) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)> {
        if self.noise == NoiseForm::Augmented {
            // the prediction of `predict` in this form; the noise points
            // do not move the input state, so the cross-covariance is the
            // sum over the state's points alone
            let noisy = Additive(dynamics);
            let mo = self.points.transform(
                g,
                &noisy.process_noise_dist(),
                &none::<0>(),
                |x, v| noisy.propagate_with(x, v),
                no_output,
                &dynamics.state_space(),
                &Euclidean,
                Step::Smooth,
            )?;
            let predicted = mo.prediction(mo.p_xx, Step::Smooth)?;
            return Ok((predicted, mo.p_in_x));
        }
        let mo = self.points.transform(
            g,
            &none::<0>(),
            &none::<0>(),
            |x, _| dynamics.propagate(x),
            no_output,
            &dynamics.state_space(),
            &Euclidean,
            Step::Smooth,
        )?;
        let predicted = mo.prediction(linalg::add_sym(&mo.p_xx, q), Step::Smooth)?;
        Ok((predicted, mo.p_in_x))
    }
}
