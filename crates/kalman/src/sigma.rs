//! The sigma-point machinery shared by [`Ukf`](crate::Ukf), [`SrUkf`](crate::SrUkf) and
//! [`Ckf`](crate::Ckf): the scaled points and their weights, the transform of a
//! point set through `f` then `h` with the models' residual and mean
//! hooks, and the measurement correction from the transformed moments.
//!
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

use crate::error::{KalmanError, Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;
use crate::model::Manifold;
use crate::update::{Innovation, Update};

/// The smallest `alpha` accepted: van der Merwe's lower end (see [`Ukf::new`](crate::Ukf::new)).
const MIN_ALPHA: f64 = 1e-4;

/// The largest `alpha` accepted: `alpha^2` stays finite.
const MAX_ALPHA: f64 = 1e150;

/// The smallest `c = alpha^2 (L + kappa)`: points 1e-4 standard deviations
/// from the mean.
const MIN_SPREAD: f64 = 1e-8;

/// Weights of a sigma-point set of dimension `L`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Weights {
    pub(crate) wm0: f64,
    pub(crate) wc0: f64,
    pub(crate) wi: f64,
    /// `c = alpha^2 (L + kappa)`, the squared spread of the points.
    pub(crate) c: f64,
    /// `beta - alpha^2`: the weight of the mean shift in the covariances.
    pub(crate) g: f64,
}

/// Statistics of a sigma-point set pushed through `f` then `h`.
pub(crate) struct Moments<const N: usize, const K: usize, const M: usize> {
    pub(crate) x_mean: SVector<f64, K>,
    pub(crate) p_xx: SMatrix<f64, K, K>,
    pub(crate) y_mean: SVector<f64, M>,
    pub(crate) p_yy: SMatrix<f64, M, M>,
    pub(crate) p_xy: SMatrix<f64, K, M>,
    /// Cov(input state, propagated state), for the smoother.
    pub(crate) p_in_x: SMatrix<f64, N, K>,
}

impl<const N: usize, const K: usize, const M: usize> Moments<N, K, M> {
    /// The checks of the sigma-point means, in order: "sigma-point mean of
    /// f", then "of h" (the transform leaves them to its caller).
    #[inline(always)]
    pub(crate) fn check_means(&self, step: Step) -> Result<()> {
        linalg::check_finite_vec(&self.x_mean, "sigma-point mean of f", step)?;
        linalg::check_finite_vec(&self.y_mean, "sigma-point mean of h", step)
    }

    /// A sum that is finite only if both means are (the fast form of
    /// [`Moments::check_means`], folded into a caller's output test).
    #[inline(always)]
    pub(crate) fn means_sum(&self) -> f64 {
        linalg::vec_sum(&self.x_mean) + linalg::vec_sum(&self.y_mean)
    }

    /// The prediction `N(x_mean, cov)` (`cov` exactly symmetric), checked:
    /// the means (as [`Moments::check_means`]), then the belief's mean and
    /// covariance ("mean", "covariance" in `step`), with one fast test for
    /// all of them and the exact checks, in that order, only when it fails.
    #[inline(always)]
    pub(crate) fn prediction(&self, cov: SMatrix<f64, K, K>, step: Step) -> Result<Gaussian<K>> {
        debug_assert!(
            cov == cov.transpose() || cov.iter().any(|x| x.is_nan()),
            "filter output not exactly symmetric"
        );
        if !(linalg::sym_sum(&self.x_mean, &cov) + linalg::vec_sum(&self.y_mean)).is_finite() {
            self.check_means(step)?;
            linalg::check_finite_sym_belief(&self.x_mean, "mean", &cov, "covariance", step)?;
        }
        // built in one place (not in each branch): the result stays in
        // registers instead of a stack slot both branches write
        Ok(Gaussian::from_parts(self.x_mean, cov))
    }
}

/// The scaled sigma-point parameters `alpha`, `beta`, `kappa`, checked,
/// with what every step's weights need computed once: `alpha^2`,
/// `beta - alpha^2` and the dimensions whose weights are valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SigmaPoints {
    pub(crate) alpha: f64,
    pub(crate) beta: f64,
    pub(crate) kappa: f64,
    /// `alpha^2`.
    a2: f64,
    /// `beta - alpha^2`.
    g: f64,
    /// The dimensions `L` whose weights pass the checks of
    /// [`SigmaPoints::weights_for`] are `lo..=hi` (none when `lo > hi`).
    lo: usize,
    hi: usize,
}

/// The zero-dimensional Gaussian: "no noise block".
pub(crate) fn none<const D: usize>() -> Gaussian<D> {
    Gaussian::from_parts(SVector::zeros(), SMatrix::zeros())
}

/// The error of a failed square root of `c A`: the sigma-point scale `c`
/// when `A` is finite and `c A` is not (a huge `alpha` or `kappa`),
/// otherwise `err` (about `A` itself).
#[cold]
#[inline(never)]
fn spread_error<const D: usize>(err: KalmanError, a: SMatrix<f64, D, D>, c: f64) -> KalmanError {
    // `a` by value: a reference would pin the caller's covariance to memory
    // on the hot path too
    let a = a.as_slice();
    let finite = a.iter().all(|x| x.is_finite());
    if finite && a.iter().any(|x| !(x * c).is_finite()) {
        return KalmanError::InvalidParameter {
            name: "alpha^2 (L + kappa)",
            value: c,
            reason: "scaled by it, a covariance overflows: alpha or kappa is too large for \
                     this covariance",
        };
    }
    err
}

pub(crate) fn no_output<const K: usize>(
    _: &SVector<f64, K>,
    _: &SVector<f64, 0>,
) -> SVector<f64, 0> {
    SVector::zeros()
}

impl SigmaPoints {
    /// The parameters, checked as [`Ukf::new`](crate::Ukf::new) documents.
    pub(crate) fn new(alpha: f64, beta: f64, kappa: f64) -> Result<Self> {
        if !(MIN_ALPHA..=MAX_ALPHA).contains(&alpha) {
            return Err(KalmanError::InvalidParameter {
                name: "alpha",
                value: alpha,
                reason: "must lie in [1e-4, 1e150] (below 1e-4 round-off replaces the \
                         covariance of the sigma points; above, alpha^2 overflows)",
            });
        }
        for (name, value) in [("beta", beta), ("kappa", kappa)] {
            if !value.is_finite() {
                return Err(KalmanError::InvalidParameter {
                    name,
                    value,
                    reason: "must be finite",
                });
            }
        }
        let a2 = alpha * alpha;
        let mut points = Self {
            alpha,
            beta,
            kappa,
            a2,
            g: beta - a2,
            lo: 1,
            hi: 0,
        };
        (points.lo, points.hi) = points.valid_dimensions();
        Ok(points)
    }

    /// `c = alpha^2 (L + kappa)` for dimension `l`, as every step forms it.
    #[inline(always)]
    fn spread(&self, l: f64) -> f64 {
        self.a2 * (l + self.kappa)
    }

    /// The weights' checks for dimension `l`, evaluated (tests): `1e-8 <= c < inf`
    /// and `alpha^2 kappa + beta L >= 0` (what `weights_for` checked on
    /// every step before the range was computed once).
    #[cfg(test)]
    fn weights_valid(&self, l: usize) -> bool {
        let lf = l as f64;
        let c = self.spread(lf);
        c >= MIN_SPREAD && 0.5 / c > 0.0 && self.a2 * self.kappa + self.beta * lf >= 0.0
    }

    /// The range `lo..=hi` of dimensions `L` whose weights are valid. Each
    /// check is monotone in `L` (`L as f64`, `c` and `beta L` are rounded
    /// monotone functions of `L`; adding the constant `alpha^2 kappa` keeps
    /// the order): `c >= 1e-8` holds from some `L` on, `0.5 / c > 0`
    /// (given that, `c < inf`) up to some `L`, and `alpha^2 kappa + beta L >= 0` from some `L` on when
    /// `beta >= 0` and up to some `L` when `beta < 0`. So the valid
    /// dimensions are the interval of the lower and upper bounds, found by
    /// bisection on the same float expressions (tests/bad_input.rs checks
    /// it against the direct evaluation).
    fn valid_dimensions(&self) -> (usize, usize) {
        let rises = self.beta >= 0.0;
        let from = |l: usize| {
            let lf = l as f64;
            self.spread(lf) >= MIN_SPREAD
                && (!rises || self.a2 * self.kappa + self.beta * lf >= 0.0)
        };
        // with `c >= 1e-8 > 0`, `0.5 / c > 0` exactly when `c < inf` (the
        // smallest `0.5 / c`, about 2.8e-309, is a positive subnormal)
        let upto = |l: usize| {
            let lf = l as f64;
            self.spread(lf) < f64::INFINITY
                && (rises || self.a2 * self.kappa + self.beta * lf >= 0.0)
        };
        if !from(usize::MAX) || !upto(0) {
            return (1, 0);
        }
        // smallest l with from(l): from(b) holds throughout
        let (mut a, mut b) = (0usize, usize::MAX);
        while a < b {
            let mid = a + (b - a) / 2;
            if from(mid) { b = mid } else { a = mid + 1 }
        }
        let lo = a;
        // largest l with upto(l): upto(a) holds throughout
        let (mut a, mut b) = (0usize, usize::MAX);
        while a < b {
            let mid = b - (b - a) / 2;
            if upto(mid) { a = mid } else { b = mid - 1 }
        }
        (lo, a)
    }

    /// The range of valid dimensions (tests).
    #[cfg(test)]
    pub(crate) fn valid_range(&self) -> (usize, usize) {
        (self.lo, self.hi)
    }

    /// The unscented transform that is the third-degree spherical-radial
    /// cubature rule: `alpha = 1`, `beta = 0`, `kappa = 0` (see
    /// [`Ckf`](crate::Ckf)).
    pub(crate) const fn cubature() -> Self {
        // c = L: valid from L = 1 on (c < inf for every L; alpha^2 kappa +
        // beta L = 0); a unit test compares these with `new(1, 0, 0)`
        Self {
            alpha: 1.0,
            beta: 0.0,
            kappa: 0.0,
            a2: 1.0,
            g: -1.0,
            lo: 1,
            hi: usize::MAX,
        }
    }

    /// The weights for a (possibly augmented) state of dimension `l`, checked
    /// as [`Ukf::weights`](crate::Ukf::weights) documents.
    ///
    /// The checks (`1e-8 <= c < inf`, `alpha^2 kappa + beta L >= 0`) were
    /// evaluated for every `L` when the parameters were checked: here they
    /// are one range test on `L`, constant after inlining.
    #[inline(always)]
    pub(crate) fn weights_for(&self, l: usize) -> Result<Weights> {
        let lf = l as f64;
        let c = self.spread(lf);
        if l < self.lo || l > self.hi {
            return Err(self.weights_error(lf, c));
        }
        let wm0 = (c - lf) / c;
        Ok(Weights {
            wm0,
            wc0: wm0 + 1.0 - self.a2 + self.beta,
            wi: 0.5 / c,
            c,
            g: self.g,
        })
    }

    /// Which parameter makes the weights of dimension `l` invalid.
    #[cold]
    #[inline(never)]
    fn weights_error(&self, l: f64, c: f64) -> KalmanError {
        let kappa = |reason| KalmanError::InvalidParameter {
            name: "kappa",
            value: self.kappa,
            reason,
        };
        // kappa and alpha are finite (checked by `new`): nothing below is NaN
        if l + self.kappa <= 0.0 {
            return kappa(
                "L + kappa must be positive (L: the state dimension, augmented by the noise dimensions)",
            );
        }
        if c < MIN_SPREAD {
            return kappa(
                "alpha^2 (L + kappa) must be at least 1e-8: closer to the mean, round-off replaces the covariance of the sigma points",
            );
        }
        if c.is_infinite() {
            return kappa("alpha^2 (L + kappa) overflows");
        }
        let reason = "alpha^2 kappa + beta L must be >= 0 (L: the state dimension), or the sigma-point covariance can be indefinite";
        if self.beta < 0.0 {
            KalmanError::InvalidParameter {
                name: "beta",
                value: self.beta,
                reason,
            }
        } else {
            kappa(reason)
        }
    }

    /// Pushes the sigma points of `[x; v; w] ~ N([m; mv; mw], diag(P, Qv, Rw))`
    /// through `xf = f(x, v)` and `y = h(xf, w)`.
    ///
    /// The means are not checked here: the caller runs
    /// [`Moments::check_means`] (or folds it into the test of its outputs,
    /// running it first when that test fails).
    ///
    /// The moments are accumulated as deviations from the central point
    /// (`dx_i = Xf_i - Xf_0`): since `Wm_0 + 2 L W_i = 1`,
    /// `x = Xf_0 + d` with `d = W_i sum dx_i`, and
    /// `P_xx = W_i sum dx_i dx_i^T + (beta - alpha^2) d d^T` (likewise
    /// `P_yy`, `P_xy`). Algebraically the weighted sums above; without the
    /// large weights `Wm_0`, `Wc_0` of a small `alpha` there is no
    /// cancellation between them.
    ///
    /// The deviations are the residuals of `sx` (state) and `sz`
    /// (measurement), and the means `sx.boxplus(Xf_0, d)`, `sz.boxplus(Y_0, e)`:
    /// plain arithmetic unless the model overrides its hooks.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn transform<
        const N: usize,
        const V: usize,
        const W: usize,
        const K: usize,
        const M: usize,
    >(
        &self,
        prior: &Gaussian<N>,
        v: &Gaussian<V>,
        w: &Gaussian<W>,
        f: impl Fn(&SVector<f64, N>, &SVector<f64, V>) -> SVector<f64, K>,
        h: impl Fn(&SVector<f64, K>, &SVector<f64, W>) -> SVector<f64, M>,
        sx: &impl Manifold<K>,
        sz: &impl Manifold<M>,
        step: Step,
    ) -> Result<Moments<N, K, M>> {
        let wt = self.weights_for(N + V + W)?;
        // the noise distributions come from the model: checked here, where
        // they are used (finite, symmetric; the square roots below check
        // that they are positive semi-definite)
        if V > 0 {
            linalg::check_finite_vec(v.mean(), "process noise mean", step)?;
            linalg::check_covariance(v.cov(), "process noise covariance", step)?;
        }
        if W > 0 {
            linalg::check_finite_vec(w.mean(), "measurement noise mean", step)?;
            linalg::check_covariance(w.cov(), "measurement noise covariance", step)?;
        }
        // Lower-triangular factors of `c P`, `c Q_v`, `c R_w`
        // (`c = alpha^2 (L + kappa)`); `spread` builds the points of column
        // `j` from rows `j..`, so the points agree exactly with the mean in
        // the leading coordinates and a model that reads only those is
        // evaluated once for them (identical calls are merged).
        let sp = linalg::psd_sqrt(&(prior.cov() * wt.c), "state covariance P", step)
            .map_err(|e| spread_error(e, *prior.cov(), wt.c))?;
        let sv = linalg::psd_sqrt(&(v.cov() * wt.c), "process noise covariance", step)
            .map_err(|e| spread_error(e, *v.cov(), wt.c))?;
        let sw = linalg::psd_sqrt(&(w.cov() * wt.c), "measurement noise covariance", step)
            .map_err(|e| spread_error(e, *w.cov(), wt.c))?;
        let (m, mv, mw) = (prior.mean(), v.mean(), w.mean());

        let xf0 = f(m, mv);
        let y0 = h(&xf0, mw);
        // Accumulators start at -0, the identity of `+` (0 + x is not x for
        // x = -0), so the first addition folds away.
        let mut sdx = SVector::<f64, K>::repeat(-0.0);
        let mut sdy = SVector::<f64, M>::repeat(-0.0);
        let mut sxx = SMatrix::<f64, K, K>::repeat(-0.0);
        let mut syy = SMatrix::<f64, M, M>::repeat(-0.0);
        let mut sxy = SMatrix::<f64, K, M>::repeat(-0.0);
        let mut p_in_x = SMatrix::<f64, N, K>::repeat(-0.0);
        let mut add = |dx: &SVector<f64, K>, dy: &SVector<f64, M>| {
            sdx += dx;
            sdy += dy;
            // lower triangles of the symmetric sums
            for j in 0..K {
                for i in j..K {
                    sxx[(i, j)] += dx[i] * dx[j];
                }
            }
            for j in 0..M {
                for i in j..M {
                    syy[(i, j)] += dy[i] * dy[j];
                }
                for i in 0..K {
                    sxy[(i, j)] += dx[i] * dy[j];
                }
            }
        };
        for j in 0..N {
            let col = sp.column(j);
            let (xp, xm) = linalg::spread(m, &sp, j);
            let (xp, xm) = (f(&xp, mv), f(&xm, mv));
            let (dp, dm) = (sx.residual(&xp, &xf0), sx.residual(&xm, &xf0));
            add(&dp, &sz.residual(&h(&xp, mw), &y0));
            add(&dm, &sz.residual(&h(&xm, mw), &y0));
            // Cov(input, propagated) for the smoother (unused elsewhere, and
            // then optimised away)
            p_in_x += col * sx.residual(&xp, &xm).transpose();
        }
        for j in 0..V {
            let (vp, vm) = linalg::spread(mv, &sv, j);
            for vv in [vp, vm] {
                let xf = f(m, &vv);
                add(&sx.residual(&xf, &xf0), &sz.residual(&h(&xf, mw), &y0));
            }
        }
        for j in 0..W {
            let (wp, wm) = linalg::spread(mw, &sw, j);
            let dx = SVector::<f64, K>::zeros();
            add(&dx, &sz.residual(&h(&xf0, &wp), &y0));
            add(&dx, &sz.residual(&h(&xf0, &wm), &y0));
        }

        let d = sdx * wt.wi;
        let e = sdy * wt.wi;
        // the means' finiteness is checked by the caller
        // ([`Moments::check_means`]), folded into its test of its outputs
        let x_mean = sx.boxplus(&xf0, &d);
        let y_mean = sz.boxplus(&y0, &e);
        let mut p_xx = SMatrix::<f64, K, K>::zeros();
        for j in 0..K {
            for i in j..K {
                p_xx[(i, j)] = sxx[(i, j)] * wt.wi + wt.g * d[i] * d[j];
            }
        }
        let mut p_yy = SMatrix::<f64, M, M>::zeros();
        for j in 0..M {
            for i in j..M {
                p_yy[(i, j)] = syy[(i, j)] * wt.wi + wt.g * e[i] * e[j];
            }
        }
        let p_xy = sxy * wt.wi + linalg::mul_t(&(d * wt.g), &e);
        Ok(Moments {
            x_mean,
            p_xx: linalg::mirror_lower(p_xx),
            y_mean,
            p_yy: linalg::mirror_lower(p_yy),
            p_xy,
            p_in_x: p_in_x * wt.wi,
        })
    }

    /// The measurement update from transformed moments (`s` symmetric):
    /// with `S = L D L^T`, `U = P_xy L^{-T}` and `V = U D^{-1}`,
    /// `K = V L^{-1}`, `K nu = V y` for `y = L^{-1} nu`, and
    /// `K S K^T = V U^T`.
    ///
    /// The checks of the inputs are deferred and folded into the test of
    /// the outputs: `pending` (checks the caller left, such as
    /// [`Moments::check_means`], whose values sum to `pending_sum`), then
    /// the finiteness of `z` ("measurement z"), run in that order before
    /// any other error is returned, so the errors are those of checking
    /// each input first.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn correct<const N: usize, const M: usize>(
        predicted: &Gaussian<N>,
        y_mean: &SVector<f64, M>,
        s: SMatrix<f64, M, M>,
        p_xy: &SMatrix<f64, N, M>,
        z: &SVector<f64, M>,
        sz: &impl Manifold<M>,
        pending_sum: f64,
        pending: impl Fn() -> Result<()>,
    ) -> Result<Update<N, M>> {
        let inputs = || {
            pending()?;
            linalg::check_finite_vec(z, "measurement z", Step::Update)
        };
        let ldl = match linalg::Ldl::new(&s, "innovation covariance S", Step::Update) {
            Ok(ldl) => ldl,
            Err(e) => {
                inputs()?;
                return Err(e);
            }
        };
        let u = ldl.right_solve_lt(p_xy);
        let v = ldl.scale_columns(&u);
        let residual = sz.residual(z, y_mean);
        let y = ldl.forward(&residual);
        let mean = predicted.mean() + linalg::mul(&v, &y);
        let mut cov = linalg::mirror_lower(linalg::lower_mul_t_add(predicted.cov(), -1.0, &v, &u));
        let innovation = Innovation::unchecked(residual, &y, s, &ldl);
        // the checks of the outputs in one test (as the KF's gain step):
        // the exact checks, in order, name a failure
        let fast_ok = linalg::min_diagonal(&cov) >= 0.0
            && (linalg::sym_sum(&mean, &cov) + innovation.nis + (pending_sum + linalg::vec_sum(z)))
                .is_finite();
        if !fast_ok {
            inputs()?;
            linalg::check_variances(
                &mut cov,
                predicted.cov(),
                "posterior covariance",
                Step::Update,
            )?;
            Gaussian::checked(mean, cov, Step::Update)?;
            innovation.check()?;
        }
        Ok(Update {
            posterior: Gaussian::from_parts(mean, cov),
            innovation: Some(innovation),
            iterations: 1,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The range of valid dimensions computed once is exactly the set of
    /// dimensions whose weights pass the checks evaluated directly.
    #[test]
    fn the_valid_dimensions_are_those_the_checks_accept() {
        let alphas = [1e-4, 1e-3, 0.5, 1.0, 3.0, 1e100, 1e150];
        let betas = [0.0, -0.0, 2.0, -1.0, -1e6, 1e300, -1e300, f64::MAX];
        let kappas = [
            0.0,
            3.0,
            -2.0,
            -3.0,
            -60.5,
            1e-300,
            -3.0 + 1e-300,
            1e300,
            -1e300,
            f64::MAX,
        ];
        let large = [
            1usize << 40,
            1 << 53,
            (1 << 53) + 1,
            1 << 62,
            usize::MAX - 1,
            usize::MAX,
        ];
        let mut seen = [0usize; 2];
        for a in alphas {
            for b in betas {
                for k in kappas {
                    let p = SigmaPoints::new(a, b, k).unwrap();
                    let (lo, hi) = p.valid_range();
                    for l in (0..=80).chain(large) {
                        let direct = p.weights_valid(l);
                        assert_eq!(direct, lo <= l && l <= hi, "{a} {b} {k} {l}: {lo}..={hi}");
                        assert_eq!(p.weights_for(l).is_ok(), direct, "{a} {b} {k} {l}");
                        seen[usize::from(direct)] += 1;
                    }
                }
            }
        }
        // both outcomes are exercised
        assert!(seen[0] > 1000 && seen[1] > 1000, "{seen:?}");
    }

    /// The constant cubature parameters equal those `new` computes.
    #[test]
    fn the_cubature_constants_are_those_of_new() {
        assert_eq!(
            SigmaPoints::cubature(),
            SigmaPoints::new(1.0, 0.0, 0.0).unwrap()
        );
    }
}
