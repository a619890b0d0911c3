//! What a measurement update returns, and the gain step shared by the KF,
//! EKF and IEKF.

use nalgebra::{SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};
use crate::gaussian::{Gaussian, LN_2PI};
use crate::linalg;

/// How the posterior covariance is formed after a linear(ised) update.
///
/// Both forms give an exactly symmetric matrix: the lower triangle is formed
/// and mirrored.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum CovarianceUpdate {
    /// `(I - K H) P (I - K H)^T + K R K^T`: stays positive semi-definite under
    /// round-off and for any gain.
    #[default]
    Joseph,
    /// `P - K H P`: cheaper, exact only for the optimal gain.
    Standard,
}

/// The innovation of an update and the statistics derived from it.
///
/// The log-likelihood is computed when asked for
/// ([`Innovation::log_likelihood`]): its logarithm is about a twentieth of a
/// small filter's step, and most steps never read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation<const M: usize> {
    /// `nu = z - z_hat`.
    pub residual: SVector<f64, M>,
    /// `S`, the innovation covariance.
    pub covariance: SMatrix<f64, M, M>,
    /// Normalised innovation squared `nu^T S^{-1} nu` (chi-square with `M`
    /// degrees of freedom for a consistent filter).
    pub nis: f64,
    /// `det S = (prod det_factors)^det_power`: the pivots `D_jj` of
    /// `S = L D L^T` (power 1) or the diagonal of a Cholesky factor of `S`
    /// (power 2), positive and finite.
    det_factors: SVector<f64, M>,
    det_power: f64,
}

impl<const M: usize> Innovation<M> {
    /// Derives the NIS from the residual, the factorisation `S = L D L^T`
    /// and the whitened residual `y = L^{-1} nu`
    /// (`nu^T S^{-1} nu = sum y_j^2 / D_jj`), unchecked: the caller runs
    /// [`Innovation::check`] (or folds `nis` into its own test).
    #[inline(always)]
    pub(crate) fn unchecked(
        residual: SVector<f64, M>,
        whitened: &SVector<f64, M>,
        covariance: SMatrix<f64, M, M>,
        ldl: &linalg::Ldl<M>,
    ) -> Self {
        let mut nis = 0.0;
        for j in 0..M {
            nis += whitened[j] * whitened[j] * ldl.inv_d()[j];
        }
        Self {
            residual,
            covariance,
            nis,
            det_factors: *ldl.d(),
            det_power: 1.0,
        }
    }

    /// The innovation of a square-root filter: `S = S_y S_y^T` with `S_y`
    /// lower triangular with a positive diagonal, `nis` from the whitened
    /// residual, unchecked.
    #[inline(always)]
    pub(crate) fn from_sqrt(
        residual: SVector<f64, M>,
        covariance: SMatrix<f64, M, M>,
        nis: f64,
        sy: &SMatrix<f64, M, M>,
    ) -> Self {
        Self {
            residual,
            covariance,
            nis,
            det_factors: sy.diagonal(),
            det_power: 2.0,
        }
    }

    /// `log det S`, with one logarithm when the product of the factors is
    /// representable.
    #[must_use]
    pub fn log_det(&self) -> f64 {
        let prod: f64 = self.det_factors.iter().product();
        if prod.is_normal() {
            self.det_power * prod.ln()
        } else {
            self.det_power * self.det_factors.iter().map(|f| f.ln()).sum::<f64>()
        }
    }

    /// `log N(nu; 0, S) = -(nis + log det S + M log 2 pi) / 2`: finite,
    /// since an update with a non-finite NIS is an error.
    #[must_use]
    pub fn log_likelihood(&self) -> f64 {
        -0.5 * (self.nis + self.log_det() + M as f64 * LN_2PI)
    }

    /// A residual of 1e155 or more squares past the largest f64: the NIS
    /// would be inf, not a number (and the log-likelihood with it: `log det
    /// S` is finite, its factors positive and finite).
    #[inline(always)]
    pub(crate) fn check(&self) -> Result<()> {
        if !self.nis.is_finite() {
            return Err(KalmanError::NonFinite {
                what: "normalised innovation squared (NIS) and log-likelihood",
                step: Step::Update,
            });
        }
        Ok(())
    }
}

/// The result of a measurement update, with the posterior in the filter's
/// belief form `B` ([`Gaussian`] but for the square-root filters, whose
/// [`SqrtUpdate`](crate::SqrtUpdate) is `Update<N, M, SqrtGaussian<N>>`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Update<const N: usize, const M: usize, B = Gaussian<N>> {
    /// The posterior belief (the prior itself when the measurement is missing).
    pub posterior: B,
    /// Innovation statistics; `None` when the measurement was missing.
    pub innovation: Option<Innovation<M>>,
    /// Relinearisations performed (IEKF); 1 for the other filters, 0 when the
    /// measurement was missing.
    pub iterations: usize,
}

impl<const N: usize, const M: usize, B: Clone> Update<N, M, B> {
    /// The update for a missing measurement: the posterior is the prior.
    pub(crate) fn missing(prior: &B) -> Self {
        Self {
            posterior: prior.clone(),
            innovation: None,
            iterations: 0,
        }
    }
}

/// The output of one linearised gain step.
pub(crate) struct GainStep<const N: usize, const M: usize> {
    pub mean: SVector<f64, N>,
    pub cov: SMatrix<f64, N, N>,
    pub innovation: Innovation<M>,
}

/// Gain step about a linearisation `H`: `S = H P H^T + R`,
/// `K = P H^T S^{-1}` (Cholesky solve), `x + K nu`, and the covariance in
/// the requested form. `residual` is the (linearised) innovation; `r` is
/// symmetric (only its lower triangle is read; the Joseph form reads all
/// of it).
///
/// With the square-root-free Cholesky factorisation `S = L D L^T`,
/// `U = P H^T L^{-T}` and `V = U D^{-1}` (triangular solves), the gain is
/// `K = V L^{-1}`, the mean step `K nu = V y` with `y = L^{-1} nu` (the
/// NIS is `sum y_j^2 / D_jj`), and `K H P = V U^T`, so the standard form
/// `P - V U^T` needs no second solve. Symmetric results are formed on the
/// lower triangle and mirrored (symmetric by construction).
#[inline(always)]
pub(crate) fn gain_step<const N: usize, const M: usize>(
    mean: &SVector<f64, N>,
    p: &SMatrix<f64, N, N>,
    residual: SVector<f64, M>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    form: CovarianceUpdate,
) -> Result<GainStep<N, M>> {
    // P H^T = (H P)^T for symmetric P
    let pht = linalg::mul_t(p, h);
    let s = linalg::mirror_lower(linalg::lower_mul_t_add(r, 1.0, h, &pht.transpose()));
    let ldl = linalg::Ldl::new(&s, "innovation covariance S", Step::Update)?;
    let u = ldl.right_solve_lt(&pht);
    let v = ldl.scale_columns(&u);
    let y = ldl.forward(&residual);
    let new_mean = mean + linalg::mul(&v, &y);
    let new_cov = match form {
        CovarianceUpdate::Joseph => {
            // (I - K H) P (I - K H)^T + K R K^T with the identity applied
            // exactly: B = (I - K H) P = P - K (P H^T)^T, then
            // B (I - K H)^T = B - (B H^T) K^T. The same products as with
            // `I - K H` formed (distributivity, valid for any gain), 120
            // instead of 172 multiply-adds for N = 4, M = 2, and round-off of
            // the same order: on random updates with R down to 1e-12 |P|
            // both keep the smallest eigenvalue above -1e-14 |P+|, where
            // `P - K H P` with an explicit gain reaches -3e-4 |P+|
            // (tests/properties.rs checks the bound).
            let k = ldl.right_solve_l(&v);
            let b = p - linalg::mul_t(&k, &pht);
            let bht = linalg::mul_t(&b, h);
            let kr = linalg::mul(&k, r);
            let lower = linalg::lower_mul_t_add(&b, -1.0, &bht, &k);
            linalg::lower_mul_t_add(&lower, 1.0, &kr, &k)
        }
        CovarianceUpdate::Standard => linalg::lower_mul_t_add(p, -1.0, &v, &u),
    };
    let mut new_cov = linalg::mirror_lower(new_cov);
    let innovation = Innovation::unchecked(residual, &y, s, &ldl);
    // every check of the outputs in one test: the variances against their
    // floor, and one sum that is finite only when the mean, the covariance
    // and the NIS are (the log-likelihood is when the NIS is); the exact
    // checks, in order, name the failure
    let fast_ok = linalg::min_diagonal(&new_cov) >= 0.0
        && (linalg::sym_sum(&new_mean, &new_cov) + innovation.nis).is_finite();
    if !fast_ok {
        linalg::check_variances(&mut new_cov, p, "posterior covariance", Step::Update)?;
        linalg::check_finite_sym_belief(
            &new_mean,
            "posterior mean",
            &new_cov,
            "posterior covariance",
            Step::Update,
        )?;
        innovation.check()?;
    }
    Ok(GainStep {
        mean: new_mean,
        cov: new_cov,
        innovation,
    })
}
