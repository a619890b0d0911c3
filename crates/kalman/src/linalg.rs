//! Small dense helpers: checks, symmetrisation, factorisations that report
//! which matrix failed.

use nalgebra::{Cholesky, Const, SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};

/// Relative tolerance of the symmetry check on user covariances.
const SYMMETRY_TOL: f64 = 1e-9;

pub(crate) fn check_finite_vec<const D: usize>(
    v: &SVector<f64, D>,
    what: &'static str,
    step: Step,
) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what, step })
    }
}

pub(crate) fn check_finite_mat<const R: usize, const C: usize>(
    m: &SMatrix<f64, R, C>,
    what: &'static str,
    step: Step,
) -> Result<()> {
    if m.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what, step })
    }
}

/// `(A + A^T) / 2`.
#[inline]
pub(crate) fn symmetrize<const D: usize>(m: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    (m + m.transpose()) * 0.5
}

/// Checks a user covariance: finite and symmetric to a relative tolerance.
pub(crate) fn check_covariance<const D: usize>(
    m: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<()> {
    check_finite_mat(m, matrix, step)?;
    let scale = m.amax().max(1.0);
    let mut asym = 0.0f64;
    for i in 0..D {
        for j in (i + 1)..D {
            asym = asym.max((m[(i, j)] - m[(j, i)]).abs());
        }
    }
    if asym > SYMMETRY_TOL * scale {
        return Err(KalmanError::NotSymmetric {
            matrix,
            asymmetry: asym,
            step,
        });
    }
    Ok(())
}

/// Cholesky factor of a positive-definite matrix, or the error that names it.
#[inline]
pub(crate) fn cholesky<const D: usize>(
    m: SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<Cholesky<f64, Const<D>>> {
    Cholesky::new(m).ok_or(KalmanError::NotPositiveDefinite { matrix, step })
}

/// A square root `L` with `L L^T = m` of a symmetric positive semi-definite
/// matrix: the Cholesky factor when it exists, otherwise the symmetric
/// eigen-decomposition with round-off-negative eigenvalues clamped to zero.
pub(crate) fn psd_sqrt<const D: usize>(
    m: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<SMatrix<f64, D, D>> {
    if D == 0 {
        return Ok(SMatrix::zeros());
    }
    if let Some(c) = Cholesky::new(*m) {
        return Ok(c.l());
    }
    if !m.iter().all(|x| x.is_finite()) {
        return Err(KalmanError::NonFinite { what: matrix, step });
    }
    // Rare path (semi-definite): a dynamic-size eigen-decomposition.
    let sym = symmetrize(m);
    let eig = nalgebra::DMatrix::from_column_slice(D, D, sym.as_slice()).symmetric_eigen();
    let largest = eig.eigenvalues.amax();
    let tol = 1e-12 * largest.max(f64::MIN_POSITIVE) * D as f64;
    if eig.eigenvalues.iter().any(|&l| l < -tol) {
        return Err(KalmanError::NotPositiveDefinite { matrix, step });
    }
    let mut l = SMatrix::<f64, D, D>::from_column_slice(eig.eigenvectors.as_slice());
    for (j, &lambda) in eig.eigenvalues.iter().enumerate() {
        l.column_mut(j).scale_mut(lambda.max(0.0).sqrt());
    }
    Ok(l)
}

/// `log det` of the matrix factored by `c`.
#[inline]
pub(crate) fn log_det<const D: usize>(c: &Cholesky<f64, Const<D>>) -> f64 {
    2.0 * c.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    #[test]
    fn psd_sqrt_of_a_singular_matrix() {
        let m = Matrix2::new(1.0, 1.0, 1.0, 1.0);
        let l = psd_sqrt(&m, "m", Step::Evaluate).unwrap();
        assert!((l * l.transpose() - m).amax() < 1e-12);
    }

    #[test]
    fn psd_sqrt_rejects_an_indefinite_matrix() {
        let m = Matrix2::new(1.0, 2.0, 2.0, 1.0);
        assert_eq!(
            psd_sqrt(&m, "m", Step::Evaluate),
            Err(KalmanError::NotPositiveDefinite {
                matrix: "m",
                step: Step::Evaluate
            })
        );
    }

    #[test]
    fn asymmetric_covariance_is_reported() {
        let m = Matrix2::new(1.0, 0.5, 0.4, 1.0);
        assert!(matches!(
            check_covariance(&m, "P", Step::Construction),
            Err(KalmanError::NotSymmetric { matrix: "P", .. })
        ));
    }
}
