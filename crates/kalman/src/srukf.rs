//! The square-root unscented Kalman filter (van der Merwe and Wan 2001), in
//! the additive-noise form, with the scaled sigma points of [`Ukf`].
//!
//! The belief keeps the lower Cholesky factor `L` (`P = L L^T`) between
//! steps, so the covariance is positive semi-definite by construction and
//! the sigma points need no factorisation. With the notation of [`Ukf`]
//! (`c = alpha^2 (L + kappa)`, `W_i = 1 / (2c)`, `g = beta - alpha^2`) and
//! the deviations `dX_i = X_i - X_0` of the propagated points from the
//! propagated central point, `d = W_i sum dX_i`:
//!
//! - mean `x = X_0 + d`;
//! - factor `L' = tria([sqrt(W_i) dX_1 .. sqrt(W_i) dX_2n, sqrt(Q), sqrt(g) d])`
//!   for `g >= 0` (the transposed `R` of a QR factorisation, by Householder
//!   reflections: one square root per row, not one per entry as Givens
//!   rotations take); for `g < 0` the same without the last column, then a
//!   rank-1 Cholesky downdate with `sqrt(-g) d`.
//!
//! This is van der Merwe and Wan's time update written about the central
//! point instead of the mean: `sum_i Wc_i (X_i - x)(X_i - x)^T = W_i sum
//! dX_i dX_i^T + g d d^T` exactly (the UKF forms its covariance the same
//! way), so the zeroth point's term, whose weight `Wc_0` is about
//! `-1 / alpha^2` for a small `alpha`, becomes the small `g d d^T` and the
//! update-or-downdate decision is the sign of `g` (`Wc_0`'s sign when
//! `alpha^2 >= 1`).
//!
//! The measurement update triangularises the JOINT deviations of `[y; x]`
//! (the array form of square-root filtering, Morf and Kailath 1975):
//! `tria([[sqrt(R), sqrt(W_i) dY_i], [0, sqrt(W_i) dX_i]])` (with the rank-1
//! term `g [e; d][e; d]^T`: one more column for `g >= 0`, a downdate
//! after it for `g < 0`) is `[[S_y, 0], [U, L+]]` with `S_y S_y^T = S`,
//! `U = P_xy S_y^{-T}` (so the gain is `K = U S_y^{-1}` and `K S_y = U`)
//! and `L+ L+^T = P - U U^T`, the posterior. The mean is
//! `x + U (S_y^{-1} nu)`. This is the matrix van der Merwe and Wan's update
//! forms by `M` rank-1 downdates of `L` with the columns of `U`, by
//! orthogonal transformations alone: the downdates subtract `U U^T` from `P`, and with a
//! large dynamic range (a variance of 1e8 measured with variance 1e-10)
//! they cancel below round-off exactly where the UKF's `P - K S K^T` does
//! (measured: they fail with a pivot `<= 0` on the test of
//! `tests/srukf.rs` at the first update, where the array form keeps a
//! valid factor whose variances stay within the test's bounds).

use nalgebra::{SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};
use crate::gaussian::{FactoredGaussian, Gaussian};
use crate::linalg;
use crate::model::{self, Dynamics, Manifold, Measurement};
use crate::ukf::Ukf;
use crate::update::Innovation;

/// A Gaussian belief kept as its mean and a lower-triangular square root
/// `L` of its covariance (`P = L L^T`, non-negative diagonal; a zero on the
/// diagonal is a singular, semi-definite covariance): the belief of
/// [`SrUkf`].
///
/// Unlike [`FactoredGaussian`] (a density, which needs a positive definite
/// covariance and carries its normalising constant) it accepts singular
/// factors and costs nothing beyond the factor; [`SqrtGaussian::factor`]
/// makes the density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SqrtGaussian<const N: usize> {
    mean: SVector<f64, N>,
    l: SMatrix<f64, N, N>,
}

impl<const N: usize> SqrtGaussian<N> {
    /// A belief from a mean and a square root of the covariance: only the
    /// lower triangle of `l` is read (the strictly upper one is taken as
    /// zero), and a column with a negative diagonal entry is negated
    /// (`L L^T` is unchanged).
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] naming "mean" or "covariance factor" for
    /// NaN or infinite entries.
    pub fn new(mean: SVector<f64, N>, l: SMatrix<f64, N, N>) -> Result<Self> {
        linalg::check_finite_vec(&mean, "mean", Step::Construction)?;
        let mut lower = l.lower_triangle();
        linalg::check_finite_mat(&lower, "covariance factor", Step::Construction)?;
        for j in 0..N {
            if lower[(j, j)] < 0.0 {
                lower.column_mut(j).neg_mut();
            }
        }
        Ok(Self { mean, l: lower })
    }

    /// The belief of `g`, factored (a Cholesky factor, or the triangular
    /// square root of a singular covariance).
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`] naming "covariance" (construction
    /// step) when the covariance has a clearly negative eigenvalue.
    pub fn from_gaussian(g: &Gaussian<N>) -> Result<Self> {
        let l = linalg::user_psd_sqrt(g.cov(), "covariance", Step::Construction)?;
        Ok(Self { mean: *g.mean(), l })
    }

    /// From a mean and a lower-triangular factor with a non-negative
    /// diagonal (the caller has checked them).
    #[inline]
    pub(crate) fn from_parts(mean: SVector<f64, N>, l: SMatrix<f64, N, N>) -> Self {
        Self { mean, l }
    }

    /// The mean.
    #[inline]
    pub fn mean(&self) -> &SVector<f64, N> {
        &self.mean
    }

    /// The lower-triangular square root `L` of the covariance.
    #[inline]
    pub fn cholesky_l(&self) -> &SMatrix<f64, N, N> {
        &self.l
    }

    /// The covariance `L L^T` (exactly symmetric).
    pub fn cov(&self) -> SMatrix<f64, N, N> {
        let zero = SMatrix::<f64, N, N>::zeros();
        linalg::mirror_lower(linalg::lower_mul_t_add(&zero, 1.0, &self.l, &self.l))
    }

    /// The belief with its covariance formed (`L L^T`).
    pub fn to_gaussian(&self) -> Gaussian<N> {
        Gaussian::from_parts(self.mean, self.cov())
    }

    /// The density, for sampling and evaluation, with this factor.
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`] naming "covariance factor"
    /// (evaluation step) when the covariance is singular (a zero on the
    /// diagonal of `L`).
    pub fn factor(&self) -> Result<FactoredGaussian<N>> {
        let positive = (0..N).all(|i| self.l[(i, i)] > 0.0);
        if positive {
            Ok(FactoredGaussian::from_factor(self.mean, self.l))
        } else {
            Err(KalmanError::NotPositiveDefinite {
                matrix: "covariance factor",
                step: Step::Evaluate,
            })
        }
    }
}

impl<const N: usize> From<SqrtGaussian<N>> for Gaussian<N> {
    fn from(g: SqrtGaussian<N>) -> Self {
        g.to_gaussian()
    }
}

/// The result of a square-root measurement update: an
/// [`Update`](crate::Update) with the posterior kept factored (the
/// innovation's `S = S_y S_y^T`).
pub type SqrtUpdate<const N: usize, const M: usize> = crate::update::Update<N, M, SqrtGaussian<N>>;

/// The square-root UKF of van der Merwe and Wan (2001), additive noise: the
/// scaled sigma points and weights of [`Ukf`] (same `alpha`, `beta`,
/// `kappa`), with the belief kept as a Cholesky factor ([`SqrtGaussian`])
/// between steps. Algebraically the UKF's `predict` and `update`; it stays
/// positive semi-definite where the UKF's `P - K S K^T` does not (a large
/// dynamic range of variances with near-exact measurements), and a
/// downdate that would lose definiteness is a typed error.
///
/// ```
/// use bayestrack_kalman::{Dynamics, Measurement, SqrtGaussian, SrUkf};
/// use nalgebra::{Matrix1, Matrix2, SMatrix, SVector, Vector1, Vector2};
///
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
/// let srukf = SrUkf::new(1e-3, 2.0, 0.0)?;
/// // a factor of 0.1 I
/// let mut belief = SqrtGaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1f64.sqrt())?;
/// for z in [0.47, 0.46, 0.44] {
///     let prior = srukf.predict(&belief, &Pendulum)?;
///     let update = srukf.update(&prior, &Pendulum, Some(&Vector1::new(z)))?;
///     assert!(update.innovation.is_some());
///     belief = update.posterior;
/// }
/// assert!(belief.cholesky_l()[(1, 1)] > 0.0);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SrUkf {
    ukf: Ukf,
}

impl SrUkf {
    /// Scaled sigma points with spread `alpha`, prior-knowledge `beta` and
    /// secondary scaling `kappa`, as [`Ukf::new`].
    ///
    /// # Errors
    /// As [`Ukf::new`].
    pub fn new(alpha: f64, beta: f64, kappa: f64) -> Result<Self> {
        Ok(Self {
            ukf: Ukf::new(alpha, beta, kappa)?,
        })
    }

    /// The UKF with the same sigma points.
    pub fn ukf(&self) -> &Ukf {
        &self.ukf
    }

    /// `sqrt(c) L`, the columns the sigma points are spread by.
    #[inline(always)]
    fn spread_factor<const N: usize>(l: &SMatrix<f64, N, N>, c: f64) -> Result<SMatrix<f64, N, N>> {
        let sl = l * c.sqrt();
        if !linalg::all_finite(sl.as_slice()) {
            return Err(KalmanError::InvalidParameter {
                name: "alpha^2 (L + kappa)",
                value: c,
                reason: "scaled by its square root, the covariance factor overflows: alpha or \
                         kappa is too large for this covariance",
            });
        }
        Ok(sl)
    }

    /// The rank-1 term `g v v^T` of the sigma-point covariance: an update
    /// for `g >= 0`, a downdate (which can fail, naming `matrix`) otherwise.
    #[inline(always)]
    fn mean_shift_term<const D: usize>(
        l: &mut SMatrix<f64, D, D>,
        g: f64,
        v: &SVector<f64, D>,
        matrix: &'static str,
        step: Step,
    ) -> Result<()> {
        let x = v * g.abs().sqrt();
        if g >= 0.0 {
            linalg::chol_update(l, x);
            Ok(())
        } else {
            linalg::chol_downdate(l, x, matrix, step)
        }
    }

    /// Time update: sigma points of `prior` through `f`; the predicted
    /// factor from the QR of the weighted deviations and `sqrt(Q)`, then a
    /// rank-1 update or downdate (see the module documentation).
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`], [`KalmanError::NotSymmetric`] or
    /// [`KalmanError::NotPositiveDefinite`] naming "process noise Q" when the
    /// model's `Q` is not finite, symmetric and positive semi-definite;
    /// [`KalmanError::InvalidParameter`] for weights that are invalid for
    /// dimension `N` (as [`Ukf::weights`]); [`KalmanError::NotPositiveDefinite`]
    /// naming "predicted covariance" when the downdate of a negative
    /// `beta - alpha^2` fails; [`KalmanError::NonFinite`] for a non-finite
    /// result.
    #[inline]
    pub fn predict<const N: usize, D: Dynamics<N>>(
        &self,
        prior: &SqrtGaussian<N>,
        dynamics: &D,
    ) -> Result<SqrtGaussian<N>> {
        let step = Step::Predict;
        let q = model::process_noise(dynamics, step)?;
        let wt = self.ukf.points().weights_for(N)?;
        let sq = linalg::psd_sqrt(&q, "process noise Q", step)?;
        let m = prior.mean();
        let sl = Self::spread_factor(&prior.l, wt.c)?;
        let xf0 = dynamics.propagate(m);
        let space = dynamics.state_space();
        let mut sdx = SVector::<f64, N>::repeat(-0.0);
        let mut plus = SMatrix::<f64, N, N>::zeros();
        let mut minus = SMatrix::<f64, N, N>::zeros();
        for j in 0..N {
            let (xp, xm) = linalg::spread(m, &sl, j);
            let dp = space.residual(&dynamics.propagate(&xp), &xf0);
            let dm = space.residual(&dynamics.propagate(&xm), &xf0);
            sdx += dp;
            sdx += dm;
            plus.set_column(j, &dp);
            minus.set_column(j, &dm);
        }
        let d = sdx * wt.wi;
        let mean = space.boxplus(&xf0, &d);
        let sw = wt.wi.sqrt();
        // one triangularisation of [sqrt(Q), sqrt(W_i) dX, sqrt(g) d] when
        // g >= 0; a negative g is a downdate after it
        let mut l = sq;
        linalg::tria_cols(
            &mut l,
            linalg::Cols {
                a1: plus * sw,
                a2: minus * sw,
                a3: d * wt.g.max(0.0).sqrt(),
            },
        );
        if wt.g < 0.0 {
            Self::mean_shift_term(&mut l, wt.g, &d, "predicted covariance", step)?;
        }
        linalg::check_finite_vec(&mean, "predicted mean", step)?;
        linalg::check_finite_mat(&l, "predicted covariance factor", step)?;
        Ok(SqrtGaussian { mean, l })
    }

    /// Measurement update with sigma points drawn from `prior`'s factor:
    /// `S_y`, the gain's factor `U = P_xy S_y^{-T}` and the posterior factor
    /// from one triangularisation (QR by Householder reflections) of the weighted
    /// joint deviations of measurement and state and `sqrt(R)` (see the
    /// module documentation), the mean by one triangular solve.
    ///
    /// # Errors
    /// As [`SrUkf::predict`] for the weights; the checks of `Q` applied to
    /// the model's `R` ("measurement noise R", update step);
    /// [`KalmanError::NonFinite`] for a non-finite `z`, sigma-point mean of
    /// `h`, posterior or NIS and log-likelihood;
    /// [`KalmanError::NotPositiveDefinite`] naming "innovation covariance
    /// S" when it is singular, or (`beta < alpha^2` only, where the
    /// sigma-point term `(beta - alpha^2) [e; d][e; d]^T` is a downdate)
    /// "innovation covariance S" or "posterior covariance" when that
    /// downdate would lose definiteness (never a NaN factor).
    #[inline]
    pub fn update<const N: usize, const M: usize, H: Measurement<N, M>>(
        &self,
        prior: &SqrtGaussian<N>,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<SqrtUpdate<N, M>> {
        let Some(z) = z else {
            return Ok(SqrtUpdate {
                posterior: *prior,
                innovation: None,
                iterations: 0,
            });
        };
        let step = Step::Update;
        let r = model::measurement_noise(measurement)?;
        linalg::check_finite_vec(z, "measurement z", step)?;
        let wt = self.ukf.points().weights_for(N)?;
        let sr = linalg::psd_sqrt(&r, "measurement noise R", step)?;
        let m = prior.mean();
        let sl = Self::spread_factor(&prior.l, wt.c)?;
        let y0 = measurement.observe(m);
        let space = measurement.measurement_space();
        let sw = wt.wi.sqrt();
        // the joint factor of [y; x], from sqrt(R) and the weighted
        // deviation columns; the x deviations of the points about the
        // central one are +-sqrt(c) L_j (formed as the UKF forms them)
        let mut joint = linalg::JointFactor::<M, N>::new(sr);
        let mut sdx = SVector::<f64, N>::repeat(-0.0);
        let mut sdy = SVector::<f64, M>::repeat(-0.0);
        let mut yp = SMatrix::<f64, M, N>::zeros();
        let mut ym = SMatrix::<f64, M, N>::zeros();
        let mut xp_cols = SMatrix::<f64, N, N>::zeros();
        let mut xm_cols = SMatrix::<f64, N, N>::zeros();
        for j in 0..N {
            let (xp, xm) = linalg::spread(m, &sl, j);
            let (dxp, dxm) = (xp - m, xm - m);
            let dyp = space.residual(&measurement.observe(&xp), &y0);
            let dym = space.residual(&measurement.observe(&xm), &y0);
            sdx += dxp;
            sdx += dxm;
            sdy += dyp;
            sdy += dym;
            yp.set_column(j, &dyp);
            ym.set_column(j, &dym);
            xp_cols.set_column(j, &dxp);
            xm_cols.set_column(j, &dxm);
        }
        let d = sdx * wt.wi;
        let e = sdy * wt.wi;
        let y_mean = space.boxplus(&y0, &e);
        linalg::check_finite_vec(&y_mean, "sigma-point mean of h", step)?;
        let gs = wt.g.abs().sqrt();
        // one triangularisation of the joint columns, with the rank-1 term
        // when g >= 0; a negative g is a downdate after it
        let ge = if wt.g >= 0.0 { gs } else { 0.0 };
        joint.tria(
            linalg::Cols {
                a1: yp * sw,
                a2: ym * sw,
                a3: e * ge,
            },
            linalg::Cols {
                a1: xp_cols * sw,
                a2: xm_cols * sw,
                a3: d * ge,
            },
        );
        if wt.g < 0.0 {
            joint.downdate(
                e * gs,
                d * gs,
                "innovation covariance S",
                "posterior covariance",
                step,
            )?;
        }
        let residual = space.residual(z, &y_mean);
        joint_posterior(&joint, m, residual, step)
    }
}

/// The posterior of an array-form measurement update from the joint factor
/// `[[S_y, 0], [U, L+]]` of `[y; x]` and the innovation `residual`:
/// `x + U S_y^{-1} nu`, `L+`, and the innovation statistics from `S_y`.
/// Shared by [`SrUkf`] and [`SrKf`].
#[inline(always)]
pub(crate) fn joint_posterior<const N: usize, const M: usize>(
    joint: &linalg::JointFactor<M, N>,
    m: &SVector<f64, N>,
    residual: SVector<f64, M>,
    step: Step,
) -> Result<SqrtUpdate<N, M>> {
    let sy = joint.c;
    // a zero pivot (a NaN one gives a NaN mean, reported below)
    let positive = linalg::min_diagonal(&sy) > 0.0;
    if !positive {
        return Err(KalmanError::NotPositiveDefinite {
            matrix: "innovation covariance S",
            step,
        });
    }
    // K = P_xy S^{-1} = U S_y^{-1}, U = P_xy S_y^{-T} = B; the posterior
    // factor is A (A A^T = P - U U^T)
    let w = linalg::lower_solve(&sy, &residual);
    let mean = m + linalg::mul(&joint.b, &w);
    let l = joint.a;
    let nis = w.norm_squared();
    let zero = SMatrix::<f64, M, M>::zeros();
    let covariance = linalg::mirror_lower(linalg::lower_mul_t_add(&zero, 1.0, &sy, &sy));
    linalg::check_finite_vec(&mean, "posterior mean", step)?;
    linalg::check_finite_mat(&l, "posterior covariance factor", step)?;
    let innovation = Innovation::from_sqrt(residual, covariance, nis, &sy);
    innovation.check()?;
    Ok(SqrtUpdate {
        posterior: SqrtGaussian { mean, l },
        innovation: Some(innovation),
        iterations: 1,
    })
}
