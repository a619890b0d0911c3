//! [`Belief`]: what the forms of a Gaussian belief ([`Gaussian`], with its
//! covariance, and [`SqrtGaussian`], with a square root of it) share, so
//! that a filter names its own form ([`FilterBelief`]) and the IMM mixes
//! each model's beliefs in that model's form ([`ModeBelief`]).

use nalgebra::{SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;
use crate::srukf::SqrtGaussian;

/// A form of a Gaussian belief over an `N`-dimensional state: its mean,
/// its covariance (formed on demand), a lower-triangular square root of
/// the covariance, and the moment-matched mixture of other beliefs in this
/// form.
pub trait Belief<const N: usize>: Clone + core::fmt::Debug {
    /// The mean.
    fn mean(&self) -> &SVector<f64, N>;

    /// The covariance (formed from the factor for a square-root belief).
    fn covariance(&self) -> SMatrix<f64, N, N>;

    /// The belief with its covariance.
    fn to_gaussian(&self) -> Gaussian<N>;

    /// The belief of `g` in this form.
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`] when a factor is needed and the
    /// covariance has a clearly negative eigenvalue.
    fn from_gaussian(g: &Gaussian<N>) -> Result<Self>;

    /// The moment-matched Gaussian of the mixture `sum_i w_i N(m_i, P_i)`
    /// of `components` with `weights` (non-negative, summing to 1), in this
    /// form: `m = sum w_i m_i`, `P = sum w_i (P_i + (m_i - m)(m_i - m)^T)`
    /// for a covariance (components of weight 0 are left out); for a
    /// square root, the triangular factor of the
    /// columns `sqrt(w_i) S_i` and `sqrt(w_i) (m_i - m)` (`S_i` a square
    /// root of `P_i`: a square-root component's own factor), by rotations,
    /// so no covariance is formed. Mean differences are plain subtraction
    /// (mix angles in a state after unwrapping them).
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] naming "mixing weights" when
    /// `weights` and `components` differ in length, are empty, or the
    /// weights are negative, non-finite or do not sum to 1 (within 1e-9);
    /// [`KalmanError::NonFinite`] for a non-finite mixture; the errors of a
    /// component's square root.
    fn mix(weights: &[f64], components: &[ModeBelief<N>]) -> Result<Self>;

    /// This belief as the IMM stores it.
    fn into_mode(self) -> ModeBelief<N>;
}

/// The belief form of a filter: [`Gaussian`] for the KF, EKF, IEKF, UKF
/// and CKF, [`SqrtGaussian`] for the SR-UKF and the square-root KF. A
/// supertrait of [`KalmanPredict`](crate::KalmanPredict) and
/// [`KalmanUpdate`](crate::KalmanUpdate), so generic code names it once:
/// `F::Belief`.
pub trait FilterBelief<const N: usize> {
    /// The belief the filter takes and returns.
    type Belief: Belief<N>;
}

/// One model's belief as the IMM keeps it: in the model's own form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModeBelief<const N: usize> {
    /// Mean and covariance.
    Full(Gaussian<N>),
    /// Mean and lower-triangular square root of the covariance.
    Sqrt(SqrtGaussian<N>),
}

impl<const N: usize> ModeBelief<N> {
    /// The mean.
    pub fn mean(&self) -> &SVector<f64, N> {
        match self {
            Self::Full(g) => g.mean(),
            Self::Sqrt(g) => g.mean(),
        }
    }

    /// The covariance.
    pub fn covariance(&self) -> SMatrix<f64, N, N> {
        match self {
            Self::Full(g) => *g.cov(),
            Self::Sqrt(g) => g.cov(),
        }
    }

    /// The belief with its covariance.
    pub fn to_gaussian(&self) -> Gaussian<N> {
        match self {
            Self::Full(g) => *g,
            Self::Sqrt(g) => g.to_gaussian(),
        }
    }

    /// A lower-triangular square root of the covariance: the factor itself,
    /// or the (semi-definite) Cholesky factor of the covariance.
    fn sqrt_cov(&self) -> Result<SMatrix<f64, N, N>> {
        match self {
            Self::Full(g) => linalg::psd_sqrt(g.cov(), "covariance", Step::Predict),
            Self::Sqrt(g) => Ok(*g.cholesky_l()),
        }
    }
}

/// Checks the mixing weights and returns the mixed mean.
fn mixed_mean<const N: usize>(
    weights: &[f64],
    components: &[ModeBelief<N>],
) -> Result<SVector<f64, N>> {
    let bad = |value: f64, reason| KalmanError::InvalidParameter {
        name: "mixing weights",
        value,
        reason,
    };
    if weights.is_empty() || weights.len() != components.len() {
        return Err(bad(
            weights.len() as f64,
            "one weight per component, at least one",
        ));
    }
    let mut total = 0.0;
    for &w in weights {
        if !(w.is_finite() && w >= 0.0) {
            return Err(bad(w, "must be finite and non-negative"));
        }
        total += w;
    }
    if (total - 1.0).abs() > 1e-9 {
        return Err(bad(total, "must sum to 1"));
    }
    let mut m = SVector::<f64, N>::zeros();
    for (w, c) in weights.iter().zip(components) {
        m += c.mean() * *w;
    }
    linalg::check_finite_vec(&m, "mixed mean", Step::Predict)?;
    Ok(m)
}

impl<const N: usize> Belief<N> for Gaussian<N> {
    #[inline]
    fn mean(&self) -> &SVector<f64, N> {
        Gaussian::mean(self)
    }

    #[inline]
    fn covariance(&self) -> SMatrix<f64, N, N> {
        *self.cov()
    }

    #[inline]
    fn to_gaussian(&self) -> Gaussian<N> {
        *self
    }

    #[inline]
    fn from_gaussian(g: &Gaussian<N>) -> Result<Self> {
        Ok(*g)
    }

    fn mix(weights: &[f64], components: &[ModeBelief<N>]) -> Result<Self> {
        let m = mixed_mean(weights, components)?;
        let mut p = SMatrix::<f64, N, N>::zeros();
        // a component of weight 0 is skipped: it adds nothing, and
        // `0 * inf` (a mean 1e154 away) would be NaN
        for (w, c) in weights.iter().zip(components).filter(|(w, _)| **w > 0.0) {
            let d = c.mean() - m;
            p += (c.covariance() + d * d.transpose()) * *w;
        }
        Gaussian::checked(m, linalg::symmetrize(&p), Step::Predict)
    }

    #[inline]
    fn into_mode(self) -> ModeBelief<N> {
        ModeBelief::Full(self)
    }
}

impl<const N: usize> Belief<N> for SqrtGaussian<N> {
    #[inline]
    fn mean(&self) -> &SVector<f64, N> {
        SqrtGaussian::mean(self)
    }

    #[inline]
    fn covariance(&self) -> SMatrix<f64, N, N> {
        self.cov()
    }

    #[inline]
    fn to_gaussian(&self) -> Gaussian<N> {
        SqrtGaussian::to_gaussian(self)
    }

    #[inline]
    fn from_gaussian(g: &Gaussian<N>) -> Result<Self> {
        SqrtGaussian::from_gaussian(g)
    }

    fn mix(weights: &[f64], components: &[ModeBelief<N>]) -> Result<Self> {
        let m = mixed_mean(weights, components)?;
        let mut l = SMatrix::<f64, N, N>::zeros();
        for (w, c) in weights.iter().zip(components).filter(|(w, _)| **w > 0.0) {
            let sw = w.sqrt();
            linalg::tria_into(&mut l, &(c.sqrt_cov()? * sw));
            linalg::chol_update(&mut l, (c.mean() - m) * sw);
        }
        linalg::check_finite_mat(&l, "mixed covariance factor", Step::Predict)?;
        Ok(SqrtGaussian::from_parts(m, l))
    }

    #[inline]
    fn into_mode(self) -> ModeBelief<N> {
        ModeBelief::Sqrt(self)
    }
}
