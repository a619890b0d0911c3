//! The Rauch-Tung-Striebel backward pass shared by the linear and the
//! unscented smoothers.

use nalgebra::{SMatrix, SVector};

use crate::error::{Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;

/// Backward pass over filtered beliefs `x_{k|k}`.
///
/// `predict(k, x_{k|k})` returns the one-step prediction `x_{k+1|k}` and the
/// cross-covariance `C_k = Cov(x_k, x_{k+1})` (`P_k F^T` for a linear model,
/// its sigma-point estimate for the URTS smoother of Sarkka 2008). Then
/// `G = C_k P_{k+1|k}^{-1}` (Cholesky solve),
/// `x_s = x_k + G (x_s,{k+1} - x_{k+1|k})`,
/// `P_s = P_k + G (P_s,{k+1} - P_{k+1|k}) G^T`, the mean difference taken
/// by `residual` (the model's [`crate::Dynamics::residual_x`]).
pub(crate) fn rts_backward<const N: usize>(
    filtered: &[Gaussian<N>],
    residual: impl Fn(&SVector<f64, N>, &SVector<f64, N>) -> SVector<f64, N>,
    mut predict: impl FnMut(usize, &Gaussian<N>) -> Result<(Gaussian<N>, SMatrix<f64, N, N>)>,
) -> Result<Vec<Gaussian<N>>> {
    let mut smoothed = filtered.to_vec();
    for k in (0..filtered.len().saturating_sub(1)).rev() {
        let (predicted, cross) = predict(k, &filtered[k])?;
        let chol = linalg::Llt::new(
            predicted.cov(),
            "predicted covariance P_{k+1|k}",
            Step::Smooth,
        )?;
        let gain = chol.solve(&cross.transpose()).transpose();
        let next = &smoothed[k + 1];
        let mean = filtered[k].mean() + gain * residual(next.mean(), predicted.mean());
        let cov = filtered[k].cov() + gain * (next.cov() - predicted.cov()) * gain.transpose();
        smoothed[k] = Gaussian::checked(mean, linalg::symmetrize(&cov), Step::Smooth)?;
    }
    Ok(smoothed)
}
