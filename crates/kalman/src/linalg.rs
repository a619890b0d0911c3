//! Small dense helpers: checks, symmetrisation, factorisations that report
//! which matrix failed.

use nalgebra::{SMatrix, SVector};

use crate::error::{KalmanError, Result, Step};

/// Relative tolerance of the symmetry check on user covariances.
const SYMMETRY_TOL: f64 = 1e-9;

/// Whether every entry is finite. Fast path: a sum containing an infinite
/// or NaN term is not finite, and a sum of finite terms is finite unless it
/// overflows, so a finite sum (lane-wise partial sums: additions only,
/// vectorised, no branch per entry) proves every entry finite; a non-finite
/// sum is resolved entry by entry.
#[inline(always)]
pub(crate) fn all_finite(xs: &[f64]) -> bool {
    sum_is_finite(xs, &[]) || xs.iter().all(|x| x.is_finite())
}

#[inline(always)]
fn sum_is_finite(xs: &[f64], ys: &[f64]) -> bool {
    let s = lane_sum(xs) + lane_sum(ys);
    s.is_finite()
}

/// The sum of `xs` over four interleaved lanes (short dependency chains);
/// indexed so that a length known after inlining unrolls completely.
#[inline(always)]
fn lane_sum(xs: &[f64]) -> f64 {
    let n = xs.len();
    if n < 4 {
        let mut s = -0.0;
        for x in xs {
            s += x;
        }
        return s;
    }
    let mut acc = [xs[0], xs[1], xs[2], xs[3]];
    for i in 4..n {
        acc[i % 4] += xs[i];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

#[inline(always)]
pub(crate) fn check_finite_vec<const D: usize>(
    v: &SVector<f64, D>,
    what: &'static str,
    step: Step,
) -> Result<()> {
    if all_finite(v.as_slice()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what, step })
    }
}

#[inline(always)]
pub(crate) fn check_finite_mat<const R: usize, const C: usize>(
    m: &SMatrix<f64, R, C>,
    what: &'static str,
    step: Step,
) -> Result<()> {
    if all_finite(m.as_slice()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what, step })
    }
}

/// The sum of the entries of `v`: finite exactly when all of them are
/// (unless the sum overflows; `-0` for `D = 0`).
#[inline(always)]
pub(crate) fn vec_sum<const D: usize>(v: &SVector<f64, D>) -> f64 {
    lane_sum(v.as_slice())
}

/// The sum of the entries of `mean` and of the lower triangle of `cov`, in
/// two interleaved partial sums: finite exactly when all of them are
/// (unless the sum overflows), so for an exactly symmetric `cov` a test
/// that the whole belief is finite.
#[inline(always)]
pub(crate) fn sym_sum<const D: usize>(mean: &SVector<f64, D>, cov: &SMatrix<f64, D, D>) -> f64 {
    let mut s = lane_sum(mean.as_slice());
    let mut t = -0.0;
    for j in 0..D {
        for i in j..D {
            if (i + j) % 2 == 0 {
                s += cov[(i, j)];
            } else {
                t += cov[(i, j)];
            }
        }
    }
    s + t
}

/// Checks a filter output: [`check_finite_vec`] then [`check_finite_mat`],
/// with one fast test for both, for a covariance that is exactly symmetric
/// (the output of [`mirror_lower`]): the mean and the lower triangle are
/// summed, since the upper triangle is a copy of it.
#[inline(always)]
pub(crate) fn check_finite_sym_belief<const D: usize>(
    mean: &SVector<f64, D>,
    mean_what: &'static str,
    cov: &SMatrix<f64, D, D>,
    cov_what: &'static str,
    step: Step,
) -> Result<()> {
    if sym_sum(mean, cov).is_finite() {
        return Ok(());
    }
    check_finite_vec(mean, mean_what, step)?;
    check_finite_mat(cov, cov_what, step)
}

/// `sum_k term(k)` for `K >= 1` terms, in two interleaved partial sums
/// (even and odd `k`): the dependency chain of a length-4 dot product is
/// two additions instead of three.
#[inline(always)]
fn dot<const K: usize>(term: impl Fn(usize) -> f64) -> f64 {
    let mut even = term(0);
    if K == 1 {
        return even;
    }
    let mut odd = term(1);
    let mut k = 2;
    while k + 1 < K {
        even += term(k);
        odd += term(k + 1);
        k += 2;
    }
    if k < K {
        even += term(k);
    }
    even + odd
}

/// `A B` with fixed-size loops that unroll for small dimensions (nalgebra's
/// general product stays an out-of-line call in the filter hot paths). The
/// first term initialises each sum: `0 + x` is not `x` for `x = -0`, so a
/// zero-initialised accumulator costs an addition per entry.
#[inline(always)]
pub(crate) fn mul<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    // every entry is overwritten (the zero stores are optimised away);
    // nalgebra's `from_fn` was left out of line for 4 x 4
    let mut out = SMatrix::<f64, R, C>::zeros();
    if K == 0 {
        return out;
    }
    for j in 0..C {
        for i in 0..R {
            let s = dot::<K>(|k| a[(i, k)] * b[(k, j)]);
            out[(i, j)] = s;
        }
    }
    out
}

/// `A B^T`, as [`mul`].
#[inline(always)]
pub(crate) fn mul_t<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, C, K>,
) -> SMatrix<f64, R, C> {
    // every entry is overwritten (the zero stores are optimised away);
    // nalgebra's `from_fn` was left out of line for 4 x 4
    let mut out = SMatrix::<f64, R, C>::zeros();
    if K == 0 {
        return out;
    }
    for j in 0..C {
        for i in 0..R {
            let s = dot::<K>(|k| a[(i, k)] * b[(j, k)]);
            out[(i, j)] = s;
        }
    }
    out
}

/// The lower triangle of `C + sign A B^T` for a product known to be
/// symmetric (`F P F^T`, `V U^T`, ...), to be copied up by
/// [`mirror_lower`] (exactly symmetric). Column `j` is formed from row `j`
/// rounded down to even, a whole column of `A` per term, so that it stays
/// in aligned pairs of rows (two-wide vectors) while skipping about half of
/// the full product. Only the lower triangle of `c` matters.
#[inline(always)]
pub(crate) fn lower_mul_t_add<const R: usize, const K: usize>(
    c: &SMatrix<f64, R, R>,
    sign: f64,
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, R, K>,
) -> SMatrix<f64, R, R> {
    let mut out = *c;
    for j in 0..R {
        let i0 = j - j % 2;
        for k in 0..K {
            let bjk = sign * b[(j, k)];
            for i in i0..R {
                out[(i, j)] += a[(i, k)] * bjk;
            }
        }
    }
    out
}

/// Copies the lower triangle onto the upper one.
#[inline(always)]
pub(crate) fn mirror_lower<const D: usize>(mut m: SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    for j in 0..D {
        for i in (j + 1)..D {
            m[(j, i)] = m[(i, j)];
        }
    }
    m
}

/// `P + (Q + Q^T) / 2` for a symmetric `P` (only its lower triangle is
/// read), exactly symmetric.
#[inline(always)]
pub(crate) fn add_sym<const D: usize>(
    p: &SMatrix<f64, D, D>,
    q: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, D> {
    let mut out = *p;
    for j in 0..D {
        out[(j, j)] += q[(j, j)];
        for i in (j + 1)..D {
            out[(i, j)] += (q[(i, j)] + q[(j, i)]) * 0.5;
        }
    }
    mirror_lower(out)
}

/// `(A + A^T) / 2`.
#[inline(always)]
pub(crate) fn symmetrize<const D: usize>(m: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    (m + m.transpose()) * 0.5
}

/// Checks a user covariance: finite and symmetric to a relative tolerance.
#[inline(always)]
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

/// The smallest variance [`check_variances`] accepts after an update from
/// `prior`: `-1e-9 max |prior|`, taken as `-1e-9 max_i prior_ii` (equal for
/// a positive semi-definite prior; D comparisons, not D^2).
#[inline(always)]
pub(crate) fn variance_floor<const D: usize>(prior: &SMatrix<f64, D, D>) -> f64 {
    -1e-9 * max_diagonal(prior)
}

/// Checks that the posterior covariance `cov` of an update from a positive
/// semi-definite prior covariance `prior` has no variance below the
/// round-off of the prior (`-1e-9 max |prior|`, which is `-1e-9 max_i
/// prior_ii` for such a matrix): a larger negative variance is a wrong number (the
/// UKF's `P - K S K^T` when the sigma points cannot resolve `P` at the
/// mean's magnitude, or a model's noise below its round-off), and is
/// reported as a covariance that is not positive semi-definite.
#[inline]
pub(crate) fn check_variances<const D: usize>(
    cov: &mut SMatrix<f64, D, D>,
    prior: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<()> {
    // NaN variances pass here (`min` skips them): the finiteness checks
    // that follow report them
    let min = min_diagonal(cov);
    if min < 0.0 {
        if min < variance_floor(prior) {
            return Err(KalmanError::NotPositiveDefinite { matrix, step });
        }
        // round-off below zero is returned as zero: a variance returned
        // with `Ok` is never negative
        for i in 0..D {
            if cov[(i, i)] < 0.0 {
                cov[(i, i)] = 0.0;
            }
        }
    }
    Ok(())
}

/// The largest diagonal entry (0 for `D = 0`): `max |A_ij|` for a positive
/// semi-definite `A`, since `|A_ij| <= sqrt(A_ii A_jj)`.
#[inline(always)]
pub(crate) fn max_diagonal<const D: usize>(a: &SMatrix<f64, D, D>) -> f64 {
    let mut largest = 0.0f64;
    for i in 0..D {
        // a compare and select (one `maxsd`), not `f64::max`'s NaN handling
        let x = a[(i, i)];
        largest = if x > largest { x } else { largest };
    }
    largest
}

/// The smallest diagonal entry (`inf` for `D = 0`; NaN entries are
/// skipped, so test finiteness separately).
#[inline(always)]
pub(crate) fn min_diagonal<const D: usize>(a: &SMatrix<f64, D, D>) -> f64 {
    let mut smallest = f64::INFINITY;
    for i in 0..D {
        let x = a[(i, i)];
        smallest = if x < smallest { x } else { smallest };
    }
    smallest
}

/// Checks a noise covariance a model hands a filter at the point of use:
/// finite, symmetric and positive semi-definite (a positive definite matrix
/// passes on the square-root-free Cholesky factorisation; a singular one
/// such as a rank-2 `Q_discrete_white_noise` block falls back to the
/// eigen-decomposition of [`psd_sqrt`]).
#[inline(always)]
pub(crate) fn check_noise<const D: usize>(
    m: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<()> {
    check_covariance(m, matrix, step)?;
    if D == 0 || Ldl::new(m, matrix, step).is_ok() {
        return Ok(());
    }
    user_psd_sqrt(m, matrix, step).map(|_| ())
}

/// [`psd_sqrt`] of a covariance a user or a model gives: a variance is
/// never negative, so a diagonal entry below zero is refused before the
/// semi-definite path, whose eigenvalue tolerance is for round-off off the
/// diagonal (`R = -5e-324` passed it and came back as a negative
/// posterior variance).
#[inline(always)]
pub(crate) fn user_psd_sqrt<const D: usize>(
    m: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<SMatrix<f64, D, D>> {
    if min_diagonal(m) < 0.0 {
        return Err(KalmanError::NotPositiveDefinite { matrix, step });
    }
    psd_sqrt(m, matrix, step)
}

/// The Cholesky factorisation `A = L L^T` of a small symmetric positive
/// definite matrix, written out with fixed-size loops: for the 1..6
/// dimensional matrices of filtering these unroll completely, where the
/// general routines of nalgebra stay out-of-line calls.
/// The error of a factorisation whose pivot `d` is not positive: an
/// infinite or NaN pivot comes from entries that overflowed (the inputs
/// were checked finite), which is [`KalmanError::NonFinite`], not a
/// matrix that lost definiteness.
#[cold]
fn pivot_error(d: f64, matrix: &'static str, step: Step) -> KalmanError {
    if d.is_finite() {
        KalmanError::NotPositiveDefinite { matrix, step }
    } else {
        KalmanError::NonFinite { what: matrix, step }
    }
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct Llt<const D: usize> {
    l: SMatrix<f64, D, D>,
    /// `1 / L_jj`: the substitutions multiply instead of dividing.
    inv_diag: SVector<f64, D>,
}

impl<const D: usize> Llt<D> {
    /// Factors `a` (lower triangle read), or names it in the error.
    #[inline(always)]
    pub(crate) fn new(a: &SMatrix<f64, D, D>, matrix: &'static str, step: Step) -> Result<Self> {
        let mut l = SMatrix::<f64, D, D>::zeros();
        let mut inv_diag = SVector::<f64, D>::zeros();
        for j in 0..D {
            let mut d = a[(j, j)];
            for k in 0..j {
                d -= l[(j, k)] * l[(j, k)];
            }
            let ljj = d.sqrt();
            let inv = 1.0 / ljj;
            // `d sqrt(d)^-1 = sqrt(d) > 0` exactly when `0 < d < inf`: NaN
            // for d = 0 (0 inf), d = inf (inf 0), d < 0 and NaN d. One float
            // compare; `0 < d < inf` written out compiles to integer bit
            // tests on the pivot.
            let positive = d * inv > 0.0;
            if !positive {
                return Err(pivot_error(d, matrix, step));
            }
            l[(j, j)] = ljj;
            inv_diag[j] = inv;
            for i in (j + 1)..D {
                let mut s = a[(i, j)];
                for k in 0..j {
                    s -= l[(i, k)] * l[(j, k)];
                }
                l[(i, j)] = s * inv;
            }
        }
        Ok(Self { l, inv_diag })
    }

    /// The lower-triangular factor.
    #[inline]
    pub(crate) fn l(&self) -> &SMatrix<f64, D, D> {
        &self.l
    }

    /// `A^{-1} B` by forward and back substitution.
    #[inline(always)]
    pub(crate) fn solve<const C: usize>(&self, b: &SMatrix<f64, D, C>) -> SMatrix<f64, D, C> {
        let l = &self.l;
        let mut x = self.forward(b);
        for c in 0..C {
            for i in (0..D).rev() {
                let mut s = x[(i, c)];
                for k in (i + 1)..D {
                    s -= l[(k, i)] * x[(k, c)];
                }
                x[(i, c)] = s * self.inv_diag[i];
            }
        }
        x
    }

    /// `L^{-1} B` (forward substitution).
    #[inline(always)]
    pub(crate) fn forward<const C: usize>(&self, b: &SMatrix<f64, D, C>) -> SMatrix<f64, D, C> {
        let l = &self.l;
        let mut x = *b;
        for c in 0..C {
            for i in 0..D {
                let mut s = x[(i, c)];
                for k in 0..i {
                    s -= l[(i, k)] * x[(k, c)];
                }
                x[(i, c)] = s * self.inv_diag[i];
            }
        }
        x
    }

    /// `log det A = 2 sum log L_ii`, with one logarithm when the product of
    /// the pivots is representable.
    #[inline]
    pub(crate) fn log_det(&self) -> f64 {
        let prod: f64 = (0..D).map(|i| self.l[(i, i)]).product();
        if prod.is_normal() {
            2.0 * prod.ln()
        } else {
            2.0 * (0..D).map(|i| self.l[(i, i)].ln()).sum::<f64>()
        }
    }
}

/// The square-root-free Cholesky factorisation `A = L D L^T` (`L` unit
/// lower triangular, `D` diagonal) of a small symmetric positive definite
/// matrix, for the gain steps: no square root on the dependency chain of a
/// filter step, one division per pivot, and `log det A = log prod D_jj`.
/// With `L_c = L D^{1/2}` (the Cholesky factor) the solves below are those
/// of [`Llt`] with the pivots' square roots cancelled.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ldl<const D: usize> {
    /// Strictly lower part of `L` (unit diagonal implied).
    l: SMatrix<f64, D, D>,
    d: SVector<f64, D>,
    inv_d: SVector<f64, D>,
}

impl<const D: usize> Ldl<D> {
    /// Factors `a` (lower triangle read), or names it in the error.
    #[inline(always)]
    pub(crate) fn new(a: &SMatrix<f64, D, D>, matrix: &'static str, step: Step) -> Result<Self> {
        let mut l = SMatrix::<f64, D, D>::zeros();
        // L D, column by column
        let mut ld = SMatrix::<f64, D, D>::zeros();
        let mut d = SVector::<f64, D>::zeros();
        let mut inv_d = SVector::<f64, D>::zeros();
        for j in 0..D {
            let mut dj = a[(j, j)];
            for k in 0..j {
                dj -= ld[(j, k)] * l[(j, k)];
            }
            let inv = 1.0 / dj;
            // rejects dj <= 0, NaN and inf (1 / inf = 0)
            let positive = dj > 0.0 && inv > 0.0;
            if !positive {
                return Err(pivot_error(dj, matrix, step));
            }
            d[j] = dj;
            inv_d[j] = inv;
            for i in (j + 1)..D {
                let mut s = a[(i, j)];
                for k in 0..j {
                    s -= ld[(i, k)] * l[(j, k)];
                }
                ld[(i, j)] = s;
                l[(i, j)] = s * inv;
            }
        }
        Ok(Self { l, d, inv_d })
    }

    /// The Cholesky factor `L D^{1/2}`. Its square roots are off the
    /// factorisation's dependency chain (which only divides), so the factor
    /// is ready sooner than from the textbook recursion.
    #[inline(always)]
    pub(crate) fn cholesky_factor(&self) -> SMatrix<f64, D, D> {
        let mut out = self.l;
        for j in 0..D {
            let r = self.d[j].sqrt();
            out[(j, j)] = r;
            for i in (j + 1)..D {
                out[(i, j)] *= r;
            }
        }
        out
    }

    /// `1 / D_jj`.
    #[inline(always)]
    pub(crate) fn inv_d(&self) -> &SVector<f64, D> {
        &self.inv_d
    }

    /// `L^{-1} B` (unit forward substitution).
    #[inline(always)]
    pub(crate) fn forward<const C: usize>(&self, b: &SMatrix<f64, D, C>) -> SMatrix<f64, D, C> {
        let mut x = *b;
        for c in 0..C {
            for i in 1..D {
                for k in 0..i {
                    x[(i, c)] -= self.l[(i, k)] * x[(k, c)];
                }
            }
        }
        x
    }

    /// `B L^{-T}`, column by column (each step a whole column of `B`).
    #[inline(always)]
    pub(crate) fn right_solve_lt<const R: usize>(
        &self,
        b: &SMatrix<f64, R, D>,
    ) -> SMatrix<f64, R, D> {
        let mut x = *b;
        for c in 1..D {
            for k in 0..c {
                let lck = self.l[(c, k)];
                for i in 0..R {
                    x[(i, c)] -= x[(i, k)] * lck;
                }
            }
        }
        x
    }

    /// `B L^{-1}`.
    #[inline(always)]
    pub(crate) fn right_solve_l<const R: usize>(
        &self,
        b: &SMatrix<f64, R, D>,
    ) -> SMatrix<f64, R, D> {
        let mut x = *b;
        for c in (0..D).rev() {
            for k in (c + 1)..D {
                let lkc = self.l[(k, c)];
                for i in 0..R {
                    x[(i, c)] -= x[(i, k)] * lkc;
                }
            }
        }
        x
    }

    /// `B D^{-1}` (columns scaled).
    #[inline(always)]
    pub(crate) fn scale_columns<const R: usize>(
        &self,
        b: &SMatrix<f64, R, D>,
    ) -> SMatrix<f64, R, D> {
        let mut x = *b;
        for c in 0..D {
            for i in 0..R {
                x[(i, c)] *= self.inv_d[c];
            }
        }
        x
    }

    /// The pivots `D_jj` (positive and finite).
    #[inline(always)]
    pub(crate) fn d(&self) -> &SVector<f64, D> {
        &self.d
    }
}

/// Rank-1 update of a lower-triangular factor in place: `L' L'^T = L L^T +
/// x x^T`, by Givens rotations (`x` is consumed). Keeps a non-negative
/// diagonal and works on a singular factor (a zero pivot with a non-zero
/// `x_k` becomes `|x_k|`); a zero `x_k` leaves column `k` as it is.
#[inline(always)]
pub(crate) fn chol_update<const D: usize>(l: &mut SMatrix<f64, D, D>, mut x: SVector<f64, D>) {
    for k in 0..D {
        let xk = x[k];
        if xk == 0.0 {
            continue;
        }
        let lkk = l[(k, k)];
        let r = (lkk * lkk + xk * xk).sqrt();
        let inv = 1.0 / r;
        let (c, s) = (lkk * inv, xk * inv);
        l[(k, k)] = r;
        for i in (k + 1)..D {
            let (a, b) = (l[(i, k)], x[i]);
            l[(i, k)] = c * a + s * b;
            x[i] = c * b - s * a;
        }
    }
}

/// Rank-1 downdate of a lower-triangular factor in place: `L' L'^T = L L^T -
/// x x^T`, by hyperbolic rotations (`x` is consumed).
///
/// # Errors
/// [`KalmanError::NotPositiveDefinite`] naming `matrix` when `L L^T - x x^T`
/// is not positive definite on the span the downdate touches (a pivot
/// `L_kk^2 - x_k^2` that is not positive, or NaN); `l` is then partly
/// rotated and must be discarded.
#[inline(always)]
pub(crate) fn chol_downdate<const D: usize>(
    l: &mut SMatrix<f64, D, D>,
    mut x: SVector<f64, D>,
    matrix: &'static str,
    step: Step,
) -> Result<()> {
    for k in 0..D {
        let xk = x[k];
        if xk == 0.0 {
            continue;
        }
        let lkk = l[(k, k)];
        let ak = xk.abs();
        // `L_kk^2 - x_k^2` without squaring the difference away
        let r2 = (lkk - ak) * (lkk + ak);
        // rejects r2 <= 0 and NaN
        let positive = r2 > 0.0;
        if !positive {
            return Err(KalmanError::NotPositiveDefinite { matrix, step });
        }
        let r = r2.sqrt();
        let inv_l = 1.0 / lkk;
        let (c, s) = (r * inv_l, xk * inv_l);
        let inv_c = lkk / r;
        l[(k, k)] = r;
        for i in (k + 1)..D {
            let a = (l[(i, k)] - s * x[i]) * inv_c;
            l[(i, k)] = a;
            x[i] = c * x[i] - s * a;
        }
    }
    Ok(())
}

/// The columns a triangularisation folds into a factor: three blocks side
/// by side, `[A1, A2, A3]` with `R` rows (the width `K1 + K2 + K3` cannot
/// be a const generic expression on stable Rust; an unused block has width
/// 0 and costs nothing).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cols<const R: usize, const K1: usize, const K2: usize, const K3: usize> {
    pub(crate) a1: SMatrix<f64, R, K1>,
    pub(crate) a2: SMatrix<f64, R, K2>,
    pub(crate) a3: SMatrix<f64, R, K3>,
}

/// One row of a [`Cols`].
#[derive(Clone, Copy)]
struct ColsRow<const K1: usize, const K2: usize, const K3: usize> {
    r1: [f64; K1],
    r2: [f64; K2],
    r3: [f64; K3],
}

impl<const K1: usize, const K2: usize, const K3: usize> ColsRow<K1, K2, K3> {
    /// The squared norm, block sums in parallel.
    #[inline(always)]
    fn norm_sq(&self) -> f64 {
        block_dot(&self.r1, &self.r1)
            + block_dot(&self.r2, &self.r2)
            + block_dot(&self.r3, &self.r3)
    }
}

/// `a . b` (`0` for `K = 0`) in two interleaved partial sums.
#[inline(always)]
fn block_dot<const K: usize>(a: &[f64; K], b: &[f64; K]) -> f64 {
    if K == 0 {
        return 0.0;
    }
    dot::<K>(|k| a[k] * b[k])
}

impl<const R: usize, const K1: usize> Cols<R, K1, 0, 0> {
    /// One block.
    #[inline(always)]
    pub(crate) fn one(a1: SMatrix<f64, R, K1>) -> Self {
        Self {
            a1,
            a2: SMatrix::zeros(),
            a3: SMatrix::zeros(),
        }
    }
}

impl<const R: usize, const K1: usize, const K2: usize, const K3: usize> Cols<R, K1, K2, K3> {
    #[inline(always)]
    fn row(&self, i: usize) -> ColsRow<K1, K2, K3> {
        ColsRow {
            r1: std::array::from_fn(|k| self.a1[(i, k)]),
            r2: std::array::from_fn(|k| self.a2[(i, k)]),
            r3: std::array::from_fn(|k| self.a3[(i, k)]),
        }
    }

    /// Row `i` dotted with `t`.
    #[inline(always)]
    fn dot_row(&self, i: usize, t: &ColsRow<K1, K2, K3>) -> f64 {
        block_dot(&self.row(i).r1, &t.r1)
            + block_dot(&self.row(i).r2, &t.r2)
            + block_dot(&self.row(i).r3, &t.r3)
    }

    /// Row `i` minus `f t`.
    #[inline(always)]
    fn sub_row(&mut self, i: usize, f: f64, t: &ColsRow<K1, K2, K3>) {
        for k in 0..K1 {
            self.a1[(i, k)] -= f * t.r1[k];
        }
        for k in 0..K2 {
            self.a2[(i, k)] -= f * t.r2[k];
        }
        for k in 0..K3 {
            self.a3[(i, k)] -= f * t.r3[k];
        }
    }
}

/// The Householder reflection that folds a row `[x0, t]` of `[L, A]`
/// (`x0 = L_rr >= 0`, the rest of the row of `L` zero, `t` the row of `A`,
/// `s = |t|^2 > 0`) into `[sigma, 0]`, `sigma = |[x0, t]|`: with
/// `v = [x0 - sigma, t]` and `H = I - 2 v v^T / v^T v`, another row
/// `[c, a]` (`d = a . t`) becomes `[(x0 c + d) / sigma, a - f t]` with
/// `f = ((x0 + sigma) d / s - c) / sigma`. The forms avoid the cancellation
/// of `x0 - sigma` (`= -s / (x0 + sigma)`), `1 / s` is computed beside the
/// square root, and the diagonal comes out non-negative.
#[derive(Clone, Copy)]
struct Reflector {
    x0: f64,
    inv_sigma: f64,
    k: f64,
}

impl Reflector {
    /// The reflection and `sigma`.
    #[inline(always)]
    fn new(x0: f64, s: f64) -> (Self, f64) {
        let inv_s = 1.0 / s;
        let sigma = (x0 * x0 + s).sqrt();
        let inv_sigma = 1.0 / sigma;
        (
            Self {
                x0,
                inv_sigma,
                k: (x0 + sigma) * inv_s,
            },
            sigma,
        )
    }

    /// The new `L` entry of a row whose entry was `c` and whose `A` row
    /// dotted with `t` is `d`, and the multiple `f` of `t` to subtract
    /// from that row.
    #[inline(always)]
    fn apply(&self, c: f64, d: f64) -> (f64, f64) {
        (
            (self.x0 * c + d) * self.inv_sigma,
            (self.k * d - c) * self.inv_sigma,
        )
    }
}

/// `L' = tria([L, A])`: the lower-triangular factor (non-negative
/// diagonal) of `L L^T + A A^T`, the `R^T` of a QR factorisation of
/// `[L, A]^T`, for a lower-triangular `L` with a non-negative diagonal, by
/// Householder reflections ([`JointFactor::tria`] with no measurement
/// block): one square root and two divisions per row of `L`, where Givens
/// rotations take one of each per entry of `A`.
#[inline(always)]
pub(crate) fn tria_into<const D: usize, const K: usize>(
    l: &mut SMatrix<f64, D, D>,
    a: &SMatrix<f64, D, K>,
) {
    tria_cols(l, Cols::one(*a));
}

/// [`tria_into`] with the columns of `A` in blocks.
#[inline(always)]
pub(crate) fn tria_cols<const D: usize, const K1: usize, const K2: usize, const K3: usize>(
    l: &mut SMatrix<f64, D, D>,
    a: Cols<D, K1, K2, K3>,
) {
    let mut joint = JointFactor::<0, D> {
        c: SMatrix::zeros(),
        b: SMatrix::zeros(),
        a: *l,
    };
    joint.tria(
        Cols::<0, K1, K2, K3> {
            a1: SMatrix::zeros(),
            a2: SMatrix::zeros(),
            a3: SMatrix::zeros(),
        },
        a,
    );
    *l = joint.a;
}

/// A lower-triangular factor `[[C, 0], [B, A]]` of a joint `(M + N) x (M +
/// N)` matrix `[[C C^T, C B^T], [B C^T, B B^T + A A^T]]` held as its blocks
/// (the size `M + N` cannot be a const generic on stable Rust). With the
/// joint covariance of a measurement `y` (first) and a state `x`, `C` is the
/// factor of `S = Cov(y)`, `B = P_xy C^{-T}` and `A A^T = P - B B^T` the
/// factor of the conditional covariance: the array form of the measurement
/// update, which forms the posterior factor by rotations alone (no
/// subtraction of `U U^T` from `P`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct JointFactor<const M: usize, const N: usize> {
    pub(crate) c: SMatrix<f64, M, M>,
    pub(crate) b: SMatrix<f64, N, M>,
    pub(crate) a: SMatrix<f64, N, N>,
}

impl<const M: usize, const N: usize> JointFactor<M, N> {
    /// `[[C, 0], [0, 0]]`.
    #[inline(always)]
    pub(crate) fn new(c: SMatrix<f64, M, M>) -> Self {
        Self {
            c,
            b: SMatrix::zeros(),
            a: SMatrix::zeros(),
        }
    }

    /// Folds the columns `[Y; X]` (`Y` the measurement rows, `X` the
    /// state rows) into the factor: `[[C, 0], [B, A]]` becomes the
    /// lower-triangular factor of `J J^T + [Y; X] [Y; X]^T`, by Householder
    /// reflections row by row (see [`tria_into`]); the diagonals of `C` and
    /// `A` must be non-negative, and stay so.
    #[inline(always)]
    pub(crate) fn tria<const K1: usize, const K2: usize, const K3: usize>(
        &mut self,
        mut y: Cols<M, K1, K2, K3>,
        mut x: Cols<N, K1, K2, K3>,
    ) {
        for r in 0..M {
            let t = y.row(r);
            let s = t.norm_sq();
            // a zero row of `Y` leaves the factor as it is (NaN passes on)
            if s == 0.0 {
                continue;
            }
            let (h, sigma) = Reflector::new(self.c[(r, r)], s);
            self.c[(r, r)] = sigma;
            for j in (r + 1)..M {
                let (c, f) = h.apply(self.c[(j, r)], y.dot_row(j, &t));
                self.c[(j, r)] = c;
                y.sub_row(j, f, &t);
            }
            for i in 0..N {
                let (c, f) = h.apply(self.b[(i, r)], x.dot_row(i, &t));
                self.b[(i, r)] = c;
                x.sub_row(i, f, &t);
            }
        }
        for r in 0..N {
            let t = x.row(r);
            let s = t.norm_sq();
            if s == 0.0 {
                continue;
            }
            let (h, sigma) = Reflector::new(self.a[(r, r)], s);
            self.a[(r, r)] = sigma;
            for j in (r + 1)..N {
                let (c, f) = h.apply(self.a[(j, r)], x.dot_row(j, &t));
                self.a[(j, r)] = c;
                x.sub_row(j, f, &t);
            }
        }
    }

    /// Rank-1 downdate with `[vy; vx]`, as [`chol_downdate`].
    ///
    /// # Errors
    /// As [`chol_downdate`], naming `matrix_y` for a pivot of `C` and
    /// `matrix_x` for one of `A`.
    #[inline(always)]
    pub(crate) fn downdate(
        &mut self,
        mut vy: SVector<f64, M>,
        mut vx: SVector<f64, N>,
        matrix_y: &'static str,
        matrix_x: &'static str,
        step: Step,
    ) -> Result<()> {
        for k in 0..M {
            let xk = vy[k];
            if xk == 0.0 {
                continue;
            }
            let lkk = self.c[(k, k)];
            let ak = xk.abs();
            let r2 = (lkk - ak) * (lkk + ak);
            let positive = r2 > 0.0;
            if !positive {
                return Err(KalmanError::NotPositiveDefinite {
                    matrix: matrix_y,
                    step,
                });
            }
            let r = r2.sqrt();
            let inv_l = 1.0 / lkk;
            let (c, s) = (r * inv_l, xk * inv_l);
            let inv_c = lkk / r;
            self.c[(k, k)] = r;
            for i in (k + 1)..M {
                let a = (self.c[(i, k)] - s * vy[i]) * inv_c;
                self.c[(i, k)] = a;
                vy[i] = c * vy[i] - s * a;
            }
            for i in 0..N {
                let a = (self.b[(i, k)] - s * vx[i]) * inv_c;
                self.b[(i, k)] = a;
                vx[i] = c * vx[i] - s * a;
            }
        }
        chol_downdate(&mut self.a, vx, matrix_x, step)
    }
}

/// `L^{-1} B` for a lower-triangular `L` with a non-zero diagonal.
#[inline(always)]
pub(crate) fn lower_solve<const D: usize, const C: usize>(
    l: &SMatrix<f64, D, D>,
    b: &SMatrix<f64, D, C>,
) -> SMatrix<f64, D, C> {
    let mut x = *b;
    for c in 0..C {
        for i in 0..D {
            let mut s = x[(i, c)];
            for k in 0..i {
                s -= l[(i, k)] * x[(k, c)];
            }
            x[(i, c)] = s / l[(i, i)];
        }
    }
    x
}

/// The sigma-point pair `m + L_j`, `m - L_j` for column `j` of a lower
/// triangular `L`: rows above `j` are copies of `m` (not `m + 0`, which is
/// not `m` for `-0`), so the points of a column agree exactly with `m` in
/// their leading coordinates, and a model reading only those coordinates
/// is evaluated on identical inputs (the optimiser merges such calls).
#[inline(always)]
pub(crate) fn spread<const D: usize>(
    m: &SVector<f64, D>,
    l: &SMatrix<f64, D, D>,
    j: usize,
) -> (SVector<f64, D>, SVector<f64, D>) {
    let (mut plus, mut minus) = (*m, *m);
    for i in j..D {
        plus[i] += l[(i, j)];
        minus[i] -= l[(i, j)];
    }
    (plus, minus)
}

/// A lower-triangular square root `L` with `L L^T = m` of a symmetric
/// positive semi-definite matrix: the Cholesky factor when it exists,
/// otherwise one from the symmetric eigen-decomposition (round-off-negative
/// eigenvalues clamped to zero), made triangular by a QR factorisation
/// (`S^T = Q R` gives `S S^T = R^T R`). Triangular in both cases, so its
/// structural zeros are constants to the optimiser, and the fallback is the
/// limit of the Cholesky factor as `m` becomes singular.
#[inline(always)]
pub(crate) fn psd_sqrt<const D: usize>(
    m: &SMatrix<f64, D, D>,
    matrix: &'static str,
    step: Step,
) -> Result<SMatrix<f64, D, D>> {
    if D == 0 {
        return Ok(SMatrix::zeros());
    }
    if let Ok(ldl) = Ldl::new(m, matrix, step) {
        return Ok(ldl.cholesky_factor());
    }
    let r = semidefinite_sqrt_t(m.as_slice(), D, matrix, step)?;
    let mut l = SMatrix::<f64, D, D>::zeros();
    for j in 0..D {
        for i in j..D {
            l[(i, j)] = r[(j, i)];
        }
    }
    Ok(l)
}

/// The rare path of [`psd_sqrt`] (semi-definite), out of line and with
/// dynamic sizes: an upper-triangular `R` with `R^T R = m` (column-major
/// `m`, `d x d`).
#[cold]
#[inline(never)]
fn semidefinite_sqrt_t(
    m: &[f64],
    d: usize,
    matrix: &'static str,
    step: Step,
) -> Result<nalgebra::DMatrix<f64>> {
    if !m.iter().all(|x| x.is_finite()) {
        return Err(KalmanError::NonFinite { what: matrix, step });
    }
    let m = nalgebra::DMatrix::from_column_slice(d, d, m);
    // Entries near the ends of the range (|m_ij| beyond 2^+-500) are
    // brought to 1 by a power of two 4^k (exact, and its square root 2^k
    // too) before the decomposition: at 1e308, `m + m^T` and the
    // eigen-solver's intermediate squares overflow, and a NaN eigenvalue
    // then passed the sign test below (a variance of -1e308 was accepted).
    let top = m.amax();
    let k = if top > 0.0 && !(2f64.powi(-500)..=2f64.powi(500)).contains(&top) {
        (top.log2() / 2.0).round() as i32
    } else {
        0
    };
    // 2^-k twice: 2^-2k itself underflows to 0 for k = 512
    let (down, up) = (2f64.powi(-k), 2f64.powi(k));
    let m = if k == 0 { m } else { m * down * down };
    let sym = (&m + m.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let largest = eig.eigenvalues.amax();
    let tol = 1e-12 * largest.max(f64::MIN_POSITIVE) * d as f64;
    // a NaN eigenvalue (or tolerance) is rejected too
    if eig.eigenvalues.iter().any(|&l| l.is_nan() || l < -tol) || tol.is_nan() {
        return Err(KalmanError::NotPositiveDefinite { matrix, step });
    }
    let mut s = eig.eigenvectors;
    for (j, &lambda) in eig.eigenvalues.iter().enumerate() {
        s.column_mut(j).scale_mut(lambda.max(0.0).sqrt());
    }
    // S S^T = m and S^T = Q R give m = R^T R; rows of R with a negative
    // diagonal are negated (R^T R is unchanged) for a non-negative diagonal.
    let mut r = s.transpose().qr().r();
    for i in 0..d {
        if r[(i, i)] < 0.0 {
            r.row_mut(i).neg_mut();
        }
    }
    if k != 0 {
        // the factor of the scaled matrix, scaled back (after the QR, whose
        // norms would overflow at the original scale)
        r *= up;
    }
    if !r.iter().all(|x| x.is_finite()) {
        return Err(KalmanError::NonFinite { what: matrix, step });
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    fn spd4(seed: u64) -> nalgebra::Matrix4<f64> {
        // a deterministic, well-spread SPD matrix
        let mut a = nalgebra::Matrix4::<f64>::zeros();
        let mut v = seed as f64 * 0.7 + 0.3;
        for x in a.iter_mut() {
            v = (v * 9.13 + 0.41).fract();
            *x = v - 0.5;
        }
        a * a.transpose() + nalgebra::Matrix4::identity() * 0.5
    }

    fn chol4(a: &nalgebra::Matrix4<f64>) -> nalgebra::Matrix4<f64> {
        a.cholesky().unwrap().l()
    }

    #[test]
    fn chol_update_matches_the_factor_recomputed() {
        for seed in 0..20 {
            let a = spd4(seed);
            let v = nalgebra::Vector4::new(0.3, -1.2, 0.7, 2.0) * (1.0 + seed as f64 * 0.1);
            let mut l = chol4(&a);
            chol_update(&mut l, v);
            let expected = chol4(&(a + v * v.transpose()));
            assert!((l - expected).amax() < 1e-12, "{seed}: {l} {expected}");
            assert_eq!(
                l.upper_triangle(),
                nalgebra::Matrix4::from_diagonal(&l.diagonal())
            );
        }
        // a singular factor: zero pivots are filled
        let mut l = nalgebra::Matrix2::zeros();
        chol_update(&mut l, nalgebra::Vector2::new(0.0, 3.0));
        chol_update(&mut l, nalgebra::Vector2::new(4.0, 0.0));
        assert!((l * l.transpose() - Matrix2::new(16.0, 0.0, 0.0, 9.0)).amax() < 1e-14);
        assert!(l.diagonal().iter().all(|&d| d > 0.0));
    }

    #[test]
    fn chol_downdate_matches_the_factor_recomputed() {
        for seed in 0..20 {
            let a = spd4(seed);
            // a v v^T that leaves A - v v^T positive definite: v = 0.9 L e
            let l0 = chol4(&a);
            let e = nalgebra::Vector4::new(0.5, -0.5, 0.5, 0.5);
            let v = l0 * e * 0.9;
            let mut l = l0;
            chol_downdate(&mut l, v, "m", Step::Update).unwrap();
            let expected = chol4(&(a - v * v.transpose()));
            assert!((l - expected).amax() < 1e-12, "{seed}: {l} {expected}");
            // update then downdate by the same vector is the identity
            let w = nalgebra::Vector4::new(1.0, 2.0, -3.0, 0.5);
            let mut l2 = l0;
            chol_update(&mut l2, w);
            chol_downdate(&mut l2, w, "m", Step::Update).unwrap();
            assert!((l2 - l0).amax() < 1e-12);
        }
    }

    #[test]
    fn chol_downdate_that_loses_definiteness_is_an_error() {
        let a = spd4(3);
        let l0 = chol4(&a);
        let e = nalgebra::Vector4::new(0.5, -0.5, 0.5, 0.5);
        for (scale, what) in [(1.01, "just indefinite"), (1.5, "indefinite")] {
            let mut l = l0;
            let r = chol_downdate(&mut l, l0 * e * scale, "posterior covariance", Step::Update);
            assert_eq!(
                r,
                Err(KalmanError::NotPositiveDefinite {
                    matrix: "posterior covariance",
                    step: Step::Update
                }),
                "{what}"
            );
        }
        // exactly singular: I - e_0 e_0^T
        let mut l = Matrix2::identity();
        assert!(
            chol_downdate(&mut l, nalgebra::Vector2::new(1.0, 0.0), "m", Step::Update).is_err()
        );
        let mut l = l0;
        let nan = nalgebra::Vector4::new(f64::NAN, 0.0, 0.0, 0.0);
        assert!(chol_downdate(&mut l, nan, "m", Step::Update).is_err());
    }

    #[test]
    fn tria_matches_the_qr_of_the_stack() {
        let a = spd4(5);
        let l0 = chol4(&a);
        let w = nalgebra::Matrix4x3::new(
            1.0, 0.2, -0.3, 0.5, -1.0, 0.0, 0.0, 2.0, 1.5, -0.7, 0.1, 0.9,
        );
        let mut l = l0;
        tria_into(&mut l, &w);
        // R of the QR of [L0, W]^T, rows signed to a positive diagonal
        let stack =
            nalgebra::DMatrix::from_fn(7, 4, |i, j| if i < 4 { l0[(j, i)] } else { w[(j, i - 4)] });
        let mut r = stack.qr().r();
        for i in 0..4 {
            if r[(i, i)] < 0.0 {
                r.row_mut(i).neg_mut();
            }
        }
        let rt = r.transpose();
        assert!((l - nalgebra::Matrix4::from_fn(|i, j| rt[(i, j)])).amax() < 1e-12);
        assert!((l * l.transpose() - (a + w * w.transpose())).amax() < 1e-12);
    }

    #[test]
    fn tria_of_a_singular_factor_and_zero_rows() {
        // a zero row of A leaves its pivot at 0; the next row is folded in
        let mut l = Matrix2::zeros();
        tria_into(
            &mut l,
            &nalgebra::Matrix2x3::new(0.0, 0.0, 0.0, 1.0, 2.0, 0.0),
        );
        assert_eq!(l, Matrix2::new(0.0, 0.0, 0.0, 5f64.sqrt()));
        // a rank-1 A onto a zero factor: L L^T = A A^T, diagonal >= 0
        let a = nalgebra::Matrix2x1::new(-3.0, 4.0);
        let mut l = Matrix2::zeros();
        tria_into(&mut l, &a);
        assert!((l * l.transpose() - a * a.transpose()).amax() < 1e-14);
        assert!(l[(0, 0)] >= 0.0 && l[(1, 1)] >= 0.0 && l[(0, 1)] == 0.0);
        // a NaN column gives a NaN factor (reported by the filters), not a
        // finite wrong one
        let mut l = Matrix2::identity();
        tria_into(&mut l, &nalgebra::Matrix2x1::new(f64::NAN, 1.0));
        assert!(l.iter().any(|x| x.is_nan()));
    }

    #[test]
    fn triangular_solves() {
        let l = chol4(&spd4(2));
        let b = nalgebra::Matrix4x2::new(1.0, 2.0, -1.0, 0.5, 3.0, 0.0, 0.25, -2.0);
        assert!((l * lower_solve(&l, &b) - b).amax() < 1e-12);
    }

    #[test]
    fn joint_factor_is_the_conditional_factor() {
        // joint covariance of [y (2); x (4)]
        let w = nalgebra::SMatrix::<f64, 6, 9>::from_fn(|i, j| {
            ((i * 7 + j * 3) % 5) as f64 - 1.7 + 0.1 * i as f64
        });
        let joint = w * w.transpose();
        let mut jf = JointFactor::<2, 4>::new(nalgebra::Matrix2::identity() * 0.5);
        // the nine columns in blocks of 4, 3 and 2
        let cols = |r0: usize, rows: usize| {
            let block = |c0: usize, k: usize| w.view((r0, c0), (rows, k)).clone_owned();
            (block(0, 4), block(4, 3), block(7, 2))
        };
        let (y1, y2, y3) = cols(0, 2);
        let (x1, x2, x3) = cols(2, 4);
        jf.tria(
            Cols::<2, 4, 3, 2> {
                a1: y1.fixed_view::<2, 4>(0, 0).into_owned(),
                a2: y2.fixed_view::<2, 3>(0, 0).into_owned(),
                a3: y3.fixed_view::<2, 2>(0, 0).into_owned(),
            },
            Cols::<4, 4, 3, 2> {
                a1: x1.fixed_view::<4, 4>(0, 0).into_owned(),
                a2: x2.fixed_view::<4, 3>(0, 0).into_owned(),
                a3: x3.fixed_view::<4, 2>(0, 0).into_owned(),
            },
        );
        assert!(jf.c.upper_triangle() == nalgebra::Matrix2::from_diagonal(&jf.c.diagonal()));
        assert!(jf.a.upper_triangle() == nalgebra::Matrix4::from_diagonal(&jf.a.diagonal()));
        assert!(
            jf.c.diagonal()
                .iter()
                .chain(jf.a.diagonal().iter())
                .all(|&d| d > 0.0)
        );
        let s = joint.fixed_view::<2, 2>(0, 0) + nalgebra::Matrix2::identity() * 0.25;
        let pxy = joint.fixed_view::<4, 2>(2, 0).into_owned();
        let p = joint.fixed_view::<4, 4>(2, 2).into_owned();
        assert!((jf.c * jf.c.transpose() - s).amax() < 1e-12);
        assert!((jf.b * jf.c.transpose() - pxy).amax() < 1e-12);
        let post = p - pxy * s.try_inverse().unwrap() * pxy.transpose();
        assert!((jf.a * jf.a.transpose() - post).amax() < 1e-11);
        // a downdate undoes an update
        let before = jf;
        let (vy, vx) = (
            nalgebra::Vector2::new(0.3, -0.2),
            nalgebra::Vector4::new(1.0, 0.0, -0.5, 2.0),
        );
        jf.tria(Cols::one(vy), Cols::one(vx));
        jf.downdate(vy, vx, "S", "P", Step::Update).unwrap();
        assert!((jf.c - before.c).amax() < 1e-12);
        assert!((jf.b - before.b).amax() < 1e-12);
        assert!((jf.a - before.a).amax() < 1e-12);
    }

    #[test]
    fn products_match_nalgebra() {
        let a = nalgebra::Matrix2x3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let b = nalgebra::Matrix3x2::new(0.5, -1.0, 2.0, 0.0, 1.5, 3.0);
        assert!((mul(&a, &b) - a * b).amax() < 1e-14);
        assert!((mul_t(&a, &a) - a * a.transpose()).amax() < 1e-14);
        // symmetric products on the lower triangle, odd and even sizes
        let c = nalgebra::Matrix3::new(1.0, 0.5, 0.2, 0.5, 2.0, 0.1, 0.2, 0.1, 3.0);
        let f = nalgebra::Matrix3::new(1.0, 0.1, 0.0, 0.2, 1.0, 0.3, -0.5, 0.0, 1.0);
        let fc = mul(&f, &c);
        let full = c + fc * f.transpose();
        let lower = mirror_lower(lower_mul_t_add(&c, 1.0, &fc, &f));
        assert!((lower - full).amax() < 1e-14);
        assert_eq!(lower, lower.transpose());
        let w = nalgebra::Matrix4x2::new(1.0, 2.0, 0.5, -1.0, 3.0, 0.0, -2.0, 1.5);
        let p = nalgebra::Matrix4::identity() * 10.0;
        let sub = mirror_lower(lower_mul_t_add(&p, -1.0, &w, &w));
        assert!((sub - (p - w * w.transpose())).amax() < 1e-14);
    }

    #[test]
    fn llt_solves_and_log_det() {
        let a = nalgebra::Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let llt = Llt::new(&a, "a", Step::Evaluate).unwrap();
        assert!((llt.l() * llt.l().transpose() - a).amax() < 1e-14);
        let b = nalgebra::Matrix3x2::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        assert!((a * llt.solve(&b) - b).amax() < 1e-13);
        assert!((llt.log_det() - a.determinant().ln()).abs() < 1e-13);
        let bad = nalgebra::Matrix2::new(1.0, 2.0, 2.0, 1.0);
        assert!(Llt::new(&bad, "bad", Step::Update).is_err());
        let nan = nalgebra::Matrix2::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(Llt::new(&nan, "nan", Step::Update).is_err());
    }

    #[test]
    fn ldl_solves_and_log_det() {
        let a = nalgebra::Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let ldl = Ldl::new(&a, "a", Step::Evaluate).unwrap();
        let l = ldl.l + nalgebra::Matrix3::identity();
        let d = nalgebra::Matrix3::from_diagonal(&ldl.d);
        assert!((l * d * l.transpose() - a).amax() < 1e-14);
        assert!((ldl.d().iter().product::<f64>().ln() - a.determinant().ln()).abs() < 1e-13);
        // B A^{-1} = B L^{-T} D^{-1} L^{-1}
        let b = nalgebra::Matrix2x3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let x = ldl.right_solve_l(&ldl.scale_columns(&ldl.right_solve_lt(&b)));
        assert!((x * a - b).amax() < 1e-13);
        let y = nalgebra::Vector3::new(1.0, -2.0, 0.5);
        assert!((l * ldl.forward(&y) - y).amax() < 1e-15);
        for bad in [
            nalgebra::Matrix2::new(1.0, 2.0, 2.0, 1.0),
            nalgebra::Matrix2::new(0.0, 0.0, 0.0, 1.0),
            nalgebra::Matrix2::new(f64::NAN, 0.0, 0.0, 1.0),
            nalgebra::Matrix2::new(1.0, 0.0, 0.0, f64::INFINITY),
        ] {
            assert!(Ldl::new(&bad, "bad", Step::Update).is_err(), "{bad}");
        }
    }

    #[test]
    fn psd_sqrt_of_a_singular_matrix() {
        let m = Matrix2::new(1.0, 1.0, 1.0, 1.0);
        let l = psd_sqrt(&m, "m", Step::Evaluate).unwrap();
        assert!((l * l.transpose() - m).amax() < 1e-12);
        assert_eq!(l[(0, 1)], 0.0, "lower triangular");
        let m3 = nalgebra::Matrix3::new(1.0, 2.0, 0.0, 2.0, 5.0, 1.0, 0.0, 1.0, 1.0);
        let l3 = psd_sqrt(&m3, "m", Step::Evaluate).unwrap();
        assert!((l3 * l3.transpose() - m3).amax() < 1e-12);
        assert!(l3.upper_triangle() == nalgebra::Matrix3::from_diagonal(&l3.diagonal()));
        assert!(l3.diagonal().iter().all(|&d| d >= 0.0));
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
