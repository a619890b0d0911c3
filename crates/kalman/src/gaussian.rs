//! The Gaussian belief `N(mean, cov)` that every filter consumes and returns.

use nalgebra::{SMatrix, SVector};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::error::{Result, Step};
use crate::linalg;

/// `ln(2 pi)`.
pub(crate) const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// A Gaussian belief over an `N`-dimensional state.
///
/// The covariance is symmetric positive semi-definite; filters that need a
/// factor (sigma points, gains, densities) report a typed error when it does
/// not exist. Filters are stateless: they take a `&Gaussian` and return a new
/// one, so the caller owns the belief.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaussian<const N: usize> {
    mean: SVector<f64, N>,
    cov: SMatrix<f64, N, N>,
}

impl<const N: usize> Gaussian<N> {
    /// A belief from user data.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) for NaN or infinite entries,
    /// [`KalmanError::NotSymmetric`](crate::KalmanError::NotSymmetric) for an asymmetric covariance and
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite) when it has a negative eigenvalue
    /// (positive semi-definite is accepted).
    pub fn new(mean: SVector<f64, N>, cov: SMatrix<f64, N, N>) -> Result<Self> {
        linalg::check_finite_vec(&mean, "mean", Step::Construction)?;
        linalg::check_covariance(&cov, "covariance", Step::Construction)?;
        linalg::user_psd_sqrt(&cov, "covariance", Step::Construction)?;
        Ok(Self { mean, cov })
    }

    /// Filters build their outputs here; the caller has checked finiteness.
    #[inline]
    pub(crate) fn from_parts(mean: SVector<f64, N>, cov: SMatrix<f64, N, N>) -> Self {
        Self { mean, cov }
    }

    /// Builds a filter output, checking that it is finite; `cov` is
    /// exactly symmetric (every filter forms one triangle and mirrors it),
    /// so its lower triangle is what is checked.
    #[inline]
    pub(crate) fn checked(
        mean: SVector<f64, N>,
        cov: SMatrix<f64, N, N>,
        step: Step,
    ) -> Result<Self> {
        // (a NaN entry is not equal to itself: the check below reports it)
        debug_assert!(
            cov == cov.transpose() || cov.iter().any(|x| x.is_nan()),
            "filter output not exactly symmetric"
        );
        linalg::check_finite_sym_belief(&mean, "mean", &cov, "covariance", step)?;
        Ok(Self { mean, cov })
    }

    /// A belief with diagonal covariance.
    ///
    /// # Errors
    /// As [`Gaussian::new`]; a negative variance is not positive definite.
    pub fn diagonal(mean: SVector<f64, N>, variances: SVector<f64, N>) -> Result<Self> {
        Self::new(mean, SMatrix::from_diagonal(&variances))
    }

    /// The mean.
    #[inline]
    pub fn mean(&self) -> &SVector<f64, N> {
        &self.mean
    }

    /// The covariance.
    #[inline]
    pub fn cov(&self) -> &SMatrix<f64, N, N> {
        &self.cov
    }

    /// Mean and covariance by value.
    #[inline]
    pub fn into_parts(self) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        (self.mean, self.cov)
    }

    /// Factors the covariance once for repeated sampling and density
    /// evaluation.
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite) when the covariance is singular.
    pub fn factor(&self) -> Result<FactoredGaussian<N>> {
        let llt = linalg::Llt::new(&self.cov, "covariance", Step::Evaluate)?;
        Ok(FactoredGaussian {
            mean: self.mean,
            l: *llt.l(),
            log_norm: -0.5 * (llt.log_det() + N as f64 * LN_2PI),
        })
    }

    /// Log density at `x`.
    ///
    /// # Errors
    /// As [`Gaussian::factor`], and [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) for a
    /// non-finite `x`.
    pub fn log_pdf(&self, x: &SVector<f64, N>) -> Result<f64> {
        self.factor()?.log_pdf(x)
    }

    /// Squared Mahalanobis distance `(x - mean)^T cov^{-1} (x - mean)`.
    ///
    /// # Errors
    /// As [`Gaussian::log_pdf`].
    pub fn mahalanobis_sq(&self, x: &SVector<f64, N>) -> Result<f64> {
        self.factor()?.mahalanobis_sq(x)
    }

    /// One draw; works for singular (semi-definite) covariances too.
    ///
    /// # Errors
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite) if the covariance has a clearly
    /// negative eigenvalue.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<SVector<f64, N>> {
        let l = linalg::psd_sqrt(&self.cov, "covariance", Step::Evaluate)?;
        let z = SVector::<f64, N>::from_fn(|_, _| StandardNormal.sample(rng));
        Ok(self.mean + l * z)
    }
}

/// A Gaussian with its covariance factored (`cov = L L^T`), for repeated
/// sampling and density evaluation (particle proposals do both per particle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FactoredGaussian<const N: usize> {
    mean: SVector<f64, N>,
    l: SMatrix<f64, N, N>,
    log_norm: f64,
}

impl<const N: usize> FactoredGaussian<N> {
    /// From a mean and a lower-triangular factor with a positive diagonal
    /// (the caller has checked it).
    #[inline]
    pub(crate) fn from_factor(mean: SVector<f64, N>, l: SMatrix<f64, N, N>) -> Self {
        let prod: f64 = (0..N).map(|i| l[(i, i)]).product();
        let log_det = if prod.is_normal() {
            2.0 * prod.ln()
        } else {
            2.0 * (0..N).map(|i| l[(i, i)].ln()).sum::<f64>()
        };
        Self {
            mean,
            l,
            log_norm: -0.5 * (log_det + N as f64 * LN_2PI),
        }
    }

    /// The mean.
    #[inline]
    pub fn mean(&self) -> &SVector<f64, N> {
        &self.mean
    }

    /// The lower-triangular Cholesky factor `L`.
    #[inline]
    pub fn cholesky_l(&self) -> &SMatrix<f64, N, N> {
        &self.l
    }

    /// `mean + L z` for a standard-normal `z`.
    #[inline]
    pub fn transform(&self, z: &SVector<f64, N>) -> SVector<f64, N> {
        self.mean + self.l * z
    }

    /// One draw.
    #[inline]
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> SVector<f64, N> {
        let z = SVector::<f64, N>::from_fn(|_, _| StandardNormal.sample(rng));
        self.transform(&z)
    }

    /// Squared Mahalanobis distance of `x`.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) for a non-finite `x`, or one so far
    /// from the mean (in standard deviations) that the distance overflows.
    pub fn mahalanobis_sq(&self, x: &SVector<f64, N>) -> Result<f64> {
        linalg::check_finite_vec(x, "evaluation point", Step::Evaluate)?;
        let d = self.whitened_sq(x);
        if !d.is_finite() {
            return Err(crate::KalmanError::NonFinite {
                what: "squared Mahalanobis distance (the point is too far from the mean)",
                step: Step::Evaluate,
            });
        }
        Ok(d)
    }

    /// `|L^{-1} (x - mean)|^2`, unchecked.
    #[inline]
    fn whitened_sq(&self, x: &SVector<f64, N>) -> f64 {
        let mut y = x - self.mean;
        // forward substitution L y = x - mean
        for i in 0..N {
            let mut s = y[i];
            for j in 0..i {
                s -= self.l[(i, j)] * y[j];
            }
            y[i] = s / self.l[(i, i)];
        }
        y.norm_squared()
    }

    /// Log density at `x`.
    ///
    /// # Errors
    /// As [`FactoredGaussian::mahalanobis_sq`], and
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite) when the log density underflows to
    /// `-inf` (a density of exactly 0 is not a likelihood a filter can use).
    #[inline]
    pub fn log_pdf(&self, x: &SVector<f64, N>) -> Result<f64> {
        let l = self.log_norm - 0.5 * self.mahalanobis_sq(x)?;
        if !l.is_finite() {
            return Err(crate::KalmanError::NonFinite {
                what: "log density",
                step: Step::Evaluate,
            });
        }
        Ok(l)
    }
}

impl<const N: usize> From<FactoredGaussian<N>> for Gaussian<N> {
    fn from(f: FactoredGaussian<N>) -> Self {
        Gaussian::from_parts(f.mean, f.l * f.l.transpose())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::KalmanError;
    use nalgebra::{Matrix2, Vector2};
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    #[test]
    fn log_pdf_matches_the_closed_form() {
        let g = Gaussian::new(Vector2::new(1.0, -1.0), Matrix2::new(2.0, 0.5, 0.5, 1.0)).unwrap();
        let x = Vector2::new(0.3, 0.2);
        let d = x - g.mean();
        let cov = g.cov();
        let det = cov.determinant();
        let quad = (d.transpose() * cov.try_inverse().unwrap() * d)[0];
        let expected = -0.5 * (quad + det.ln() + 2.0 * LN_2PI);
        assert!((g.log_pdf(&x).unwrap() - expected).abs() < 1e-12);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let nan = Gaussian::new(Vector2::new(f64::NAN, 0.0), Matrix2::identity());
        assert_eq!(
            nan,
            Err(KalmanError::NonFinite {
                what: "mean",
                step: Step::Construction
            })
        );
        let indefinite = Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 2.0, 2.0, 1.0));
        assert!(matches!(
            indefinite,
            Err(KalmanError::NotPositiveDefinite { .. })
        ));
        // semi-definite is a valid belief (a known component) but cannot be factored
        let psd = Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 0.0, 0.0, 0.0)).unwrap();
        assert!(matches!(
            psd.factor(),
            Err(KalmanError::NotPositiveDefinite { .. })
        ));
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        assert_eq!(psd.sample(&mut rng).unwrap()[1], 0.0);
    }

    #[test]
    fn samples_have_the_requested_moments() {
        let g = Gaussian::new(Vector2::new(1.0, 2.0), Matrix2::new(2.0, 0.6, 0.6, 0.5)).unwrap();
        let f = g.factor().unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let n = 200_000;
        let mut m = Vector2::zeros();
        let mut c = Matrix2::zeros();
        for _ in 0..n {
            let x = f.sample(&mut rng);
            m += x;
            c += x * x.transpose();
        }
        m /= n as f64;
        c = c / n as f64 - m * m.transpose();
        assert!((m - g.mean()).amax() < 0.01, "{m}");
        assert!((c - g.cov()).amax() < 0.02, "{c}");
    }
}
