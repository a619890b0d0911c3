//! Dynamics on Aff(2) (Xu, Gao and Yang 2015 (paper 002) eq. 4-5):
//!
//! ```text
//! M_k = exp(d_k(1) A5 + d_k(2) A6) * M_{k-1} * exp(Omega_k),
//! Omega_k = sum_{i=1..6} w_i A_i,  w ~ N(0, Psi_k)
//! ```
//!
//! The left factor is the global displacement `d_k` (a pure translation in
//! image coordinates: A5 and A6 are the translation generators of eq. 3),
//! predicted by a Kalman filter in Xu, Gao and Yang 2015 (paper 002); the right factor is Brownian
//! motion in the body frame. Xu, Gao and Yang 2015 (paper 002) writes the noise sum as
//! `sum_{i=5}^{6}` (extraction garbling) but defines `w_k` with all six
//! components and uses it to perturb orientation, scale, aspect and skew,
//! so the sum runs over all six generators here.

use nalgebra::{Cholesky, Matrix6, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::Affine2;
use crate::error::{AffineError, Result, check_finite};
use crate::group::{AffineGroup, AlgebraVector};

/// Gaussian random walk on the group with covariance `Psi` in the algebra.
#[derive(Debug, Clone, PartialEq)]
pub struct BrownianDynamics {
    /// Lower-triangular factor `L`, `Psi = L L^T`.
    chol: Matrix6<f64>,
}

impl BrownianDynamics {
    /// From a symmetric positive-definite covariance `Psi` (basis
    /// coordinates; translations in template units).
    pub fn new(psi: Matrix6<f64>) -> Result<Self> {
        check_finite("Psi", psi.as_slice())?;
        if (psi - psi.transpose()).amax() > 1e-12 * psi.amax().max(1.0) {
            return Err(AffineError::NotPositiveDefinite { which: "Psi" });
        }
        let chol = Cholesky::new(psi).ok_or(AffineError::NotPositiveDefinite { which: "Psi" })?;
        Ok(Self { chol: chol.l() })
    }

    /// Independent components with standard deviations `sigma` (zeros
    /// allowed: that generator is not perturbed).
    pub fn from_std(sigma: &AlgebraVector) -> Result<Self> {
        check_finite("sigma", sigma.as_slice())?;
        if let Some(i) = sigma.iter().position(|s| *s < 0.0) {
            return Err(AffineError::InvalidParameter {
                name: "sigma",
                value: sigma[i],
                reason: "standard deviations must be >= 0",
            });
        }
        Ok(Self {
            chol: Matrix6::from_diagonal(sigma),
        })
    }

    /// The covariance `Psi`.
    pub fn covariance(&self) -> Matrix6<f64> {
        self.chol * self.chol.transpose()
    }

    /// The same walk with covariance `factor * Psi` (Algorithm 1 step 4:
    /// `Sigma = (1 - S_max) Psi_C`).
    pub fn scaled(&self, factor: f64) -> Result<Self> {
        if !(factor.is_finite() && factor >= 0.0) {
            return Err(AffineError::InvalidParameter {
                name: "covariance factor",
                value: factor,
                reason: "must be finite and >= 0",
            });
        }
        Ok(Self {
            chol: self.chol * factor.sqrt(),
        })
    }

    /// Draws `w ~ N(0, Psi)`.
    pub fn sample_noise<R: Rng + ?Sized>(&self, rng: &mut R) -> AlgebraVector {
        let mut z = AlgebraVector::zeros();
        for v in z.iter_mut() {
            *v = StandardNormal.sample(rng);
        }
        self.chol * z
    }

    /// `M_k = exp(d(1) A5 + d(2) A6) M_{k-1} exp(Omega)` for one draw of
    /// `Omega`. Pass `d = 0` for a pure random walk.
    pub fn propagate<R: Rng + ?Sized>(
        &self,
        m_prev: &Affine2,
        d: Vector2<f64>,
        rng: &mut R,
    ) -> Result<Affine2> {
        let omega = self.sample_noise(rng);
        step(m_prev, d, &omega)
    }
}

/// The deterministic part of eq. 4-5: `exp(d(1) A5 + d(2) A6) M exp(Omega)`.
pub fn step(m_prev: &Affine2, d: Vector2<f64>, omega: &AlgebraVector) -> Result<Affine2> {
    check_finite("displacement", d.as_slice())?;
    let t = Affine2::translation(d[0], d[1]);
    Ok(t.checked_compose(&m_prev.checked_compose(&Affine2::exp(omega)?)?)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    #[test]
    fn a_step_whose_product_overflows_is_an_error_not_an_infinite_map() {
        // Finite entries near the largest f64: the translation part of
        // T(d) M overflows.
        let m_prev = Affine2::from_rows([[1.0, 0.0, f64::MAX], [0.0, 1.0, 0.0]]).unwrap();
        let e = step(
            &m_prev,
            Vector2::new(f64::MAX, 0.0),
            &AlgebraVector::zeros(),
        );
        assert!(
            matches!(
                e,
                Err(AffineError::Image(
                    bayestrack_image::ImageError::NonFinite { .. }
                ))
            ),
            "{e:?}"
        );
        // one notch below, the same step is fine
        let ok = step(&m_prev, Vector2::new(-1.0, 0.0), &AlgebraVector::zeros()).unwrap();
        assert!(ok.as_array().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn brownian_samples_have_the_requested_covariance() {
        let sig = AlgebraVector::new(0.02, 0.01, 0.05, 0.015, 2.0, 1.0);
        let mut psi = Matrix6::from_diagonal(&sig.component_mul(&sig));
        // Correlate rotation with x shift and scale with aspect.
        psi[(2, 4)] = 0.5 * sig[2] * sig[4];
        psi[(4, 2)] = psi[(2, 4)];
        psi[(0, 1)] = -0.3 * sig[0] * sig[1];
        psi[(1, 0)] = psi[(0, 1)];
        let dyn_ = BrownianDynamics::new(psi).unwrap();
        let m_prev = Affine2::exp(&AlgebraVector::new(0.1, 0.05, 0.3, -0.02, 50.0, 40.0)).unwrap();
        let m_prev_inv = m_prev.try_inverse().unwrap();
        let d = Vector2::new(3.0, -2.0);
        let t_inv = Affine2::translation(-d[0], -d[1]);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
        let n = 20_000;
        let mut samples = Vec::with_capacity(n);
        for _ in 0..n {
            let m = dyn_.propagate(&m_prev, d, &mut rng).unwrap();
            // Recover Omega = log(M_{k-1}^{-1} T(d)^{-1} M_k).
            let w = m_prev_inv.compose(&t_inv.compose(&m)).log().unwrap();
            samples.push(w);
        }
        let mean = samples.iter().fold(AlgebraVector::zeros(), |a, w| a + w) / n as f64;
        let mut cov = Matrix6::zeros();
        for w in &samples {
            let e = w - mean;
            cov += e * e.transpose();
        }
        cov /= (n - 1) as f64;
        for i in 0..6 {
            // Mean within 4 standard errors.
            assert!(
                mean[i].abs() < 4.0 * sig[i] / (n as f64).sqrt(),
                "mean {i}: {}",
                mean[i]
            );
            for j in 0..6 {
                // Standard error of a sample covariance:
                // sqrt((Psi_ii Psi_jj + Psi_ij^2) / n).
                let se = ((psi[(i, i)] * psi[(j, j)] + psi[(i, j)].powi(2)) / n as f64).sqrt();
                assert!(
                    (cov[(i, j)] - psi[(i, j)]).abs() < 4.5 * se,
                    "cov({i},{j}) = {} vs {}",
                    cov[(i, j)],
                    psi[(i, j)]
                );
            }
        }
        // The displacement moves the target centre by exactly d when Omega = 0.
        let m = step(&m_prev, d, &AlgebraVector::zeros()).unwrap();
        assert!((m.offset() - m_prev.offset() - d).amax() < 1e-12);
        assert!((m.linear() - m_prev.linear()).amax() < 1e-15);
    }

    #[test]
    fn bad_covariances_are_rejected_and_scaling_works() {
        let mut psi = Matrix6::identity();
        psi[(0, 0)] = -1.0;
        assert!(matches!(
            BrownianDynamics::new(psi),
            Err(AffineError::NotPositiveDefinite { .. })
        ));
        psi[(0, 0)] = f64::NAN;
        assert!(matches!(
            BrownianDynamics::new(psi),
            Err(AffineError::NonFinite { .. })
        ));
        assert!(BrownianDynamics::from_std(&AlgebraVector::repeat(-1.0)).is_err());
        let b = BrownianDynamics::from_std(&AlgebraVector::new(0.0, 0.0, 0.1, 0.0, 1.0, 1.0))
            .unwrap()
            .scaled(0.25)
            .unwrap();
        let c = b.covariance();
        assert!((c[(2, 2)] - 0.0025).abs() < 1e-15 && (c[(4, 4)] - 0.25).abs() < 1e-15);
        assert!(b.scaled(-1.0).is_err());
        // Zero variance: that generator stays put.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        let w = b.sample_noise(&mut rng);
        assert_eq!((w[0], w[1], w[3]), (0.0, 0.0, 0.0));
    }
}
