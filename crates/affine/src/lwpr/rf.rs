//! One receptive field: weighted means, incremental PLS, distance-metric
//! learning (the reference's `lwpr_aux_*` routines, rewritten).
//!
//! Storage: with a full metric, `m`, `d`, `alpha`, `b`, `h` are N x N
//! column-major (`[i + j N]`; M and its learning rates live in the upper
//! triangle i <= j). With a diagonal metric they hold the N diagonal entries.
//! PLS directions are stored one after another: direction j occupies
//! `[j N, (j + 1) N)` of `u`, `p`, `sxres_yres` and `ssxres`.

use super::{Kernel, LwprConfig};

/// Dimension from which the full-metric algebra (M D and M^T M) goes
/// through faer's matrix product instead of plain loops (feature `faer`).
#[cfg(feature = "faer")]
const FAER_MIN_DIM: usize = 24;

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    // Four accumulators: lets the compiler vectorise without -ffast-math.
    let mut acc = [0.0f64; 4];
    let chunks = a.len() / 4;
    for k in 0..chunks {
        let i = 4 * k;
        acc[0] += a[i] * b[i];
        acc[1] += a[i + 1] * b[i + 1];
        acc[2] += a[i + 2] * b[i + 2];
        acc[3] += a[i + 3] * b[i + 3];
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for i in 4 * chunks..a.len() {
        s += a[i] * b[i];
    }
    s
}

/// Scratch buffers shared by all RFs of a model.
#[derive(Debug, Clone)]
pub(super) struct Workspace {
    xc: Vec<f64>,
    pub(super) xmz: Vec<f64>,
    xres: Vec<f64>,
    s: Vec<f64>,
    yres: Vec<f64>,
    ytarget: Vec<f64>,
    e_cv: Vec<f64>,
    ps: Vec<f64>,
    pse: Vec<f64>,
    deriv_ok: Vec<bool>,
    dx: Vec<f64>,
    mdx: Vec<f64>,
    dj2dm: Vec<f64>,
    md: Vec<f64>,
}

impl Workspace {
    pub(super) fn new(n: usize, full: bool) -> Self {
        let nm = if full { n * n } else { n };
        Self {
            xc: vec![0.0; n],
            xmz: vec![0.0; n],
            xres: Vec::new(),
            s: Vec::new(),
            yres: Vec::new(),
            ytarget: Vec::new(),
            e_cv: Vec::new(),
            ps: Vec::new(),
            pse: Vec::new(),
            deriv_ok: Vec::new(),
            dx: vec![0.0; n],
            mdx: vec![0.0; n],
            dj2dm: vec![0.0; nm],
            md: if full { vec![0.0; n * n] } else { Vec::new() },
        }
    }

    fn ensure_reg(&mut self, n: usize, r: usize) {
        if self.s.len() < r {
            self.s.resize(r, 0.0);
            self.yres.resize(r, 0.0);
            self.ytarget.resize(r, 0.0);
            self.e_cv.resize(r, 0.0);
            self.ps.resize(r, 0.0);
            self.pse.resize(r, 0.0);
            self.deriv_ok.resize(r, false);
        }
        if self.xres.len() < r * n {
            self.xres.resize(r * n, 0.0);
        }
    }
}

/// A receptive field (local linear PLS model with a Gaussian window).
#[derive(Debug, Clone)]
pub(super) struct ReceptiveField {
    n: usize,
    full: bool,
    n_reg: usize,
    c: Vec<f64>,
    m: Vec<f64>,
    d: Vec<f64>,
    alpha: Vec<f64>,
    b: Vec<f64>,
    h: Vec<f64>,
    beta0: f64,
    mean_x: Vec<f64>,
    var_x: Vec<f64>,
    u: Vec<f64>,
    p: Vec<f64>,
    sxres_yres: Vec<f64>,
    ssxres: Vec<f64>,
    beta: Vec<f64>,
    ss_s2: Vec<f64>,
    ss_yres: Vec<f64>,
    sum_w: Vec<f64>,
    n_data: Vec<f64>,
    lambda: Vec<f64>,
    sum_e_cv2: Vec<f64>,
    big_h: Vec<f64>,
    r: Vec<f64>,
    s: Vec<f64>,
    sum_e2: f64,
    ssp: f64,
    trustworthy: bool,
    w: f64,
}

impl ReceptiveField {
    /// A new RF at `xc` (the reference's `lwpr_aux_init_rf`): metric, learning
    /// rates, offset and number of directions from `template` when given,
    /// else from the configuration.
    pub(super) fn new(
        cfg: &LwprConfig,
        init_m: &[f64],
        template: Option<&ReceptiveField>,
        xc: &[f64],
        y: f64,
    ) -> Self {
        let n = cfg.n_in;
        let full = !cfg.diag_only;
        let (n_reg, m, d, alpha, beta0) = match template {
            Some(t) => (t.n_reg, t.m.clone(), t.d.clone(), t.alpha.clone(), t.beta0),
            None => {
                let n_reg = if n > 1 { 2 } else { 1 };
                if full {
                    // init_d is symmetric, so row- and column-major agree.
                    (
                        n_reg,
                        init_m.to_vec(),
                        cfg.init_d.clone(),
                        vec![cfg.init_alpha; n * n],
                        y,
                    )
                } else {
                    (
                        n_reg,
                        (0..n).map(|i| init_m[i + i * n]).collect(),
                        (0..n).map(|i| cfg.init_d[i * n + i]).collect(),
                        vec![cfg.init_alpha; n],
                        y,
                    )
                }
            }
        };
        let b = alpha.iter().map(|a| (a + 1e-10).ln()).collect();
        let h = vec![0.0; alpha.len()];
        let mut u = vec![0.0; n_reg * n];
        let mut p = vec![0.0; n_reg * n];
        for i in 0..n_reg {
            u[i * n + i] = 1.0;
            p[i * n + i] = 1.0;
        }
        Self {
            n,
            full,
            n_reg,
            c: xc.to_vec(),
            m,
            d,
            alpha,
            b,
            h,
            beta0,
            mean_x: vec![0.0; n],
            var_x: vec![0.0; n],
            u,
            p,
            sxres_yres: vec![0.0; n_reg * n],
            ssxres: vec![0.0; n_reg * n],
            beta: vec![0.0; n_reg],
            ss_s2: vec![cfg.init_s2; n_reg],
            ss_yres: vec![0.0; n_reg],
            sum_w: vec![1e-10; n_reg],
            n_data: vec![1e-10; n_reg],
            lambda: vec![cfg.init_lambda; n_reg],
            sum_e_cv2: vec![0.0; n_reg],
            big_h: vec![0.0; n_reg],
            r: vec![0.0; n_reg],
            s: vec![0.0; n_reg],
            sum_e2: 0.0,
            ssp: 0.0,
            trustworthy: false,
            w: 0.0,
        }
    }

    pub(super) fn n_reg(&self) -> usize {
        self.n_reg
    }

    pub(super) fn trustworthy(&self) -> bool {
        self.trustworthy
    }

    pub(super) fn set_w(&mut self, w: f64) {
        self.w = w;
    }

    pub(super) fn trace_d(&self, _cfg: &LwprConfig) -> f64 {
        if self.full {
            (0..self.n).map(|i| self.d[i + i * self.n]).sum()
        } else {
            self.d.iter().sum()
        }
    }

    /// Squared Mahalanobis distance `(x - c)^T D (x - c)`, leaving `x - c` in
    /// `ws.dx`.
    fn distance(&self, xn: &[f64], ws: &mut Workspace) -> f64 {
        let n = self.n;
        for ((dx, x), c) in ws.dx.iter_mut().zip(xn).zip(&self.c) {
            *dx = x - c;
        }
        if self.full {
            // |M dx|^2 with M upper triangular.
            let mut q = 0.0;
            for i in 0..n {
                let mut v = 0.0;
                for k in i..n {
                    v += self.m[i + k * n] * ws.dx[k];
                }
                ws.mdx[i] = v;
                q += v * v;
            }
            q
        } else {
            self.d.iter().zip(&ws.dx).map(|(d, x)| d * x * x).sum()
        }
    }

    /// Activation w and its derivatives dw/dq, d2w/dq2 with respect to the
    /// distance q.
    pub(super) fn activation_derivs(
        &self,
        cfg: &LwprConfig,
        xn: &[f64],
        ws: &mut Workspace,
    ) -> (f64, f64, f64) {
        let q = self.distance(xn, ws);
        match cfg.kernel {
            Kernel::Gaussian => {
                let w = (-0.5 * q).exp();
                (w, -0.5 * w, 0.25 * w)
            }
            Kernel::BiSquare => {
                let t = 1.0 - 0.25 * q;
                if t < 0.0 {
                    (0.0, 0.0, 0.0)
                } else {
                    (t * t, -0.5 * t, 0.125)
                }
            }
        }
    }

    pub(super) fn activation(&self, cfg: &LwprConfig, xn: &[f64], ws: &mut Workspace) -> f64 {
        self.activation_derivs(cfg, xn, ws).0
    }

    /// Number of directions used for prediction: the last one only once it
    /// has seen more than 2N (effective) samples.
    fn n_pred(&self) -> usize {
        let r = self.n_reg;
        if r > 1 && self.n_data[r - 1] <= 2.0 * self.n as f64 {
            r - 1
        } else {
            r
        }
    }

    /// PLS projections of `x` onto the first `nr` directions, into `s`.
    fn project(&self, x: &[f64], nr: usize, s: &mut [f64], xu: &mut [f64]) {
        let n = self.n;
        xu.copy_from_slice(x);
        for j in 0..nr {
            let sj = dot(&self.u[j * n..(j + 1) * n], xu);
            s[j] = sj;
            if j + 1 < nr {
                for (xi, pi) in xu.iter_mut().zip(&self.p[j * n..(j + 1) * n]) {
                    *xi -= pi * sj;
                }
            }
        }
    }

    /// Local prediction at `xn` (relative to the RF's weighted input mean)
    /// and, when asked, `sum_j s_j^2 / SSs2_j` for the confidence.
    pub(super) fn predict_local(
        &self,
        _cfg: &LwprConfig,
        xn: &[f64],
        ws: &mut Workspace,
        s2: Option<&mut f64>,
    ) -> f64 {
        let nr = self.n_pred();
        ws.ensure_reg(self.n, self.n_reg);
        for ((xc, x), mx) in ws.xc.iter_mut().zip(xn).zip(&self.mean_x) {
            *xc = x - mx;
        }
        let xc = std::mem::take(&mut ws.xc);
        let mut xu = std::mem::take(&mut ws.dx);
        self.project(&xc, nr, &mut ws.s, &mut xu);
        ws.xc = xc;
        ws.dx = xu;
        let mut y = self.beta0;
        let mut q = 0.0;
        for j in 0..nr {
            y += ws.s[j] * self.beta[j];
            q += ws.s[j] * ws.s[j] / self.ss_s2[j];
        }
        if let Some(out) = s2 {
            *out = q;
        }
        y
    }

    /// Predictive variance of this RF at activation `w` given
    /// `s2 = sum_j s_j^2 / SSs2_j` (the reference's confidence formula).
    pub(super) fn local_variance(&self, w: f64, s2: f64) -> f64 {
        let nr = self.n_pred();
        self.sum_e_cv2[nr - 1] / (self.sum_w[nr - 1] - self.ssp) * (1.0 + w * s2)
    }

    /// One training step for a sample at activation `w`. Returns the
    /// prediction for the sample when the RF is trustworthy.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn update(
        &mut self,
        cfg: &LwprConfig,
        xn: &[f64],
        yn: f64,
        w: f64,
        dwdq: f64,
        ddwdqdq: f64,
        ws: &mut Workspace,
    ) -> Option<f64> {
        self.w = w;
        ws.ensure_reg(self.n, self.n_reg + 1);
        let ymz = self.update_means(xn, yn, w, ws);
        let (yp, e_cv, e) = self.update_regression(ymz, w, ws);
        let out = self.trustworthy.then_some(yp);
        if cfg.update_d {
            self.update_distance_metric(cfg, w, dwdq, ddwdqdq, e_cv, e, xn, ws);
        }
        self.check_add_projection(cfg);
        for i in 0..self.n_reg {
            self.n_data[i] = self.n_data[i] * self.lambda[i] + 1.0;
            self.lambda[i] =
                cfg.tau_lambda * self.lambda[i] + cfg.final_lambda * (1.0 - cfg.tau_lambda);
        }
        out
    }

    fn update_means(&mut self, x: &[f64], y: f64, w: f64, ws: &mut Workspace) -> f64 {
        let swl = self.sum_w[0] * self.lambda[0];
        let inv = 1.0 / (swl + w);
        for i in 0..self.n {
            let mx = (swl * self.mean_x[i] + w * x[i]) * inv;
            self.mean_x[i] = mx;
            let z = x[i] - mx;
            ws.xmz[i] = z;
            self.var_x[i] = (swl * self.var_x[i] + w * z * z) * inv;
        }
        self.beta0 = (swl * self.beta0 + w * y) * inv;
        y - self.beta0
    }

    /// Incremental PLS on (xmz, y) (the reference's
    /// `lwpr_aux_update_regression`). Returns (prediction, e_cv of the
    /// directions used, residual after the update).
    fn update_regression(&mut self, y: f64, w: f64, ws: &mut Workspace) -> (f64, f64, f64) {
        let n = self.n;
        let nr = self.n_reg;
        // Projections with residuals, before the update.
        ws.xres[..n].copy_from_slice(&ws.xmz);
        for j in 0..nr {
            let (done, rest) = ws.xres.split_at_mut((j + 1) * n);
            let xj = &done[j * n..];
            let sj = dot(&self.u[j * n..(j + 1) * n], xj);
            self.s[j] = sj;
            if j + 1 < nr {
                let pj = &self.p[j * n..(j + 1) * n];
                for ((xn, xo), pi) in rest[..n].iter_mut().zip(xj).zip(pj) {
                    *xn = xo - pi * sj;
                }
            }
        }
        let mut acc = 0.0;
        for i in 0..nr {
            acc += self.beta[i] * self.s[i];
            ws.yres[i] = acc;
            self.sum_w[i] = self.sum_w[i] * self.lambda[i] + w;
            ws.e_cv[i] = y - acc;
        }
        ws.ytarget[0] = y;
        for i in 0..nr - 1 {
            ws.ytarget[i + 1] = ws.e_cv[i];
        }
        let mut ws2_ss_s2 = 0.0;
        for j in 0..nr {
            let lambda_slow = 0.9 + 0.1 * self.lambda[j];
            let wyt = w * ws.ytarget[j];
            let xj = &ws.xres[j * n..(j + 1) * n];
            let sxy = &mut self.sxres_yres[j * n..(j + 1) * n];
            let mut unorm = 0.0;
            for (a, x) in sxy.iter_mut().zip(xj) {
                *a = *a * lambda_slow + wyt * x;
                unorm += *a * *a;
            }
            if unorm > 1e-24 {
                let inv = 1.0 / unorm.sqrt();
                for (u, a) in self.u[j * n..(j + 1) * n].iter_mut().zip(sxy.iter()) {
                    *u = a * inv;
                }
            }
            let lj = self.lambda[j];
            let wsj = w * self.s[j];
            self.ss_s2[j] = lj * self.ss_s2[j] + self.s[j] * wsj;
            self.ss_yres[j] = lj * self.ss_yres[j] + ws.ytarget[j] * wsj;
            let inv_ss_s2 = 1.0 / self.ss_s2[j];
            self.beta[j] = self.ss_yres[j] * inv_ss_s2;
            let ssx = &mut self.ssxres[j * n..(j + 1) * n];
            let pj = &mut self.p[j * n..(j + 1) * n];
            for ((a, x), p) in ssx.iter_mut().zip(xj).zip(pj.iter_mut()) {
                *a = lj * *a + wsj * x;
                *p = *a * inv_ss_s2;
            }
            ws2_ss_s2 += wsj * wsj * inv_ss_s2;
        }
        self.ssp = self.lambda[nr - 1] * self.ssp + ws2_ss_s2;
        // Projections after the update.
        let mut s = std::mem::take(&mut self.s);
        let xmz = std::mem::take(&mut ws.xmz);
        let mut xu = std::mem::take(&mut ws.xc);
        self.project(&xmz, nr, &mut s, &mut xu);
        self.s = s;
        ws.xmz = xmz;
        ws.xc = xu;
        let (ypred, e_cv_r) = if self.n_data[nr - 1] > 2.0 * n as f64 || nr == 1 {
            let yp = if self.n_data[nr - 1] > 2.0 * n as f64 {
                dot(&self.beta[..nr], &self.s[..nr])
            } else {
                0.0
            };
            (yp, ws.e_cv[nr - 1])
        } else {
            (
                dot(&self.beta[..nr - 1], &self.s[..nr - 1]),
                ws.e_cv[nr - 2],
            )
        };
        let e = y - ypred;
        if self.n_data[0] * (1.0 - self.lambda[0]) > 0.1 {
            self.sum_e2 = self.sum_e2 * self.lambda[nr - 1] + w * e * e;
            for i in 0..nr {
                self.sum_e_cv2[i] =
                    self.sum_e_cv2[i] * self.lambda[i] + w * ws.e_cv[i] * ws.e_cv[i];
            }
        }
        if self.n_data[0] > 2.0 * n as f64 {
            self.trustworthy = true;
        }
        (ypred + self.beta0, e_cv_r, e)
    }

    /// Stochastic leave-one-out gradient step on M (the reference's
    /// `lwpr_aux_update_distance_metric`), with optional incremental
    /// delta-bar-delta adaptation of the learning rates.
    #[allow(clippy::too_many_arguments)]
    fn update_distance_metric(
        &mut self,
        cfg: &LwprConfig,
        w: f64,
        dwdq: f64,
        ddwdqdq: f64,
        e_cv: f64,
        e: f64,
        xn: &[f64],
        ws: &mut Workspace,
    ) {
        let n = self.n;
        let nr = self.n_reg;
        let penalty = cfg.penalty / n as f64;
        for i in 0..nr {
            ws.deriv_ok[i] = self.n_data[i] * (1.0 - self.lambda[0]) > 0.1;
        }
        if !ws.deriv_ok[0] {
            return;
        }
        let e2 = e * e;
        let e_cv2 = e_cv * e_cv;
        let mut hh = 0.0;
        for i in 0..nr {
            if ws.deriv_ok[i] {
                hh += self.s[i] * self.s[i] / self.ss_s2[i];
            }
        }
        hh *= w;
        let big_w = self.sum_w[0];
        let big_e = if nr == 1 {
            self.sum_e_cv2[0]
        } else if self.n_data[nr - 1] > 2.0 * n as f64 {
            self.sum_e_cv2[nr - 1]
        } else {
            self.sum_e_cv2[nr - 2]
        };
        let mut trans_mul = self.sum_e2 / (big_e + 1e-10);
        trans_mul *= trans_mul;
        trans_mul *= trans_mul;
        if trans_mul > 1.0 {
            trans_mul = 1.0;
        }
        let mut dj1dw = -big_e / big_w + e_cv2;
        for i in 0..nr {
            if ws.deriv_ok[i] {
                ws.ps[i] = self.s[i] / self.ss_s2[i];
                ws.pse[i] = e * ws.ps[i];
                dj1dw -= 2.0 * ws.pse[i] * self.big_h[i] + 2.0 * ws.ps[i] * ws.ps[i] * self.r[i];
            } else {
                ws.ps[i] = 0.0;
                ws.pse[i] = 0.0;
            }
        }
        dj1dw /= big_w;
        let w_w = w / big_w;
        for ((dx, x), c) in ws.dx.iter_mut().zip(xn).zip(&self.c) {
            *dx = x - c;
        }
        let ddj1dwdw = if cfg.meta {
            let s_pse: f64 = (0..nr).map(|i| self.s[i] * ws.pse[i]).sum();
            let mut v = 2.0 * (e2 * hh / w - e_cv2 / big_w) + big_e / (big_w * big_w);
            for i in 0..nr {
                v += 4.0 * (ws.pse[i] / big_w + ws.ps[i] * s_pse) * self.big_h[i];
            }
            v / big_w
        } else {
            0.0
        };
        let penalty2 = 2.0 * penalty;
        if !self.full {
            let mut max_m: f64 = 0.0;
            for mj in &self.m {
                max_m = max_m.max(mj.abs());
            }
            for j in 0..n {
                let aux = 2.0 * self.m[j];
                let dx2 = ws.dx[j] * ws.dx[j];
                let dqdm = dx2 * aux;
                let dwdm = dqdm * dwdq;
                // dJ/dM (the reference reuses dJ2dM for it).
                let djdm = w_w * (penalty2 * self.d[j] * aux) + dwdm * dj1dw;
                if cfg.meta {
                    let ddwdmdm = ddwdqdq * dqdm * dqdm + 2.0 * dwdq * dx2;
                    let ddj2dmdm = penalty2 * (2.0 * self.d[j] + aux * aux);
                    let ddjdmdm = w_w * ddj2dmdm + ddwdmdm * dj1dw + dwdm * dwdm * ddj1dwdw;
                    self.meta_step(cfg, j, djdm, ddjdmdm, trans_mul);
                }
                ws.dj2dm[j] = djdm;
            }
            for j in 0..n {
                let delta = self.alpha[j] * trans_mul * ws.dj2dm[j];
                if delta > 0.1 * max_m {
                    self.alpha[j] *= 0.5;
                } else {
                    self.m[j] -= delta;
                }
            }
            for j in 0..n {
                self.d[j] = self.m[j] * self.m[j];
            }
        } else {
            let mut max_m: f64 = 0.0;
            for j in 0..n {
                for i in 0..=j {
                    max_m = max_m.max(self.m[i + j * n].abs());
                }
            }
            // ws.mdx[i] = (M dx)_i, ws.md = M D (column-major).
            for i in 0..n {
                let mut v = 0.0;
                for k in i..n {
                    v += self.m[i + k * n] * ws.dx[k];
                }
                ws.mdx[i] = v;
            }
            mat_mul_upper(&self.m, &self.d, &mut ws.md, n);
            for mcol in 0..n {
                for nrow in 0..=mcol {
                    let off = nrow + mcol * n;
                    let dqdm = 2.0 * ws.dx[mcol] * ws.mdx[nrow];
                    let dwdm = dqdm * dwdq;
                    let dj2dm = 2.0 * penalty2 * ws.md[off];
                    let djdm = w_w * dj2dm + dwdm * dj1dw;
                    if cfg.meta {
                        let mut sum_aux1 = 0.0;
                        for i in nrow..n {
                            let mni = self.m[nrow + i * n];
                            sum_aux1 += if i == mcol {
                                2.0 * mni * mni
                            } else {
                                mni * mni
                            };
                        }
                        let ddwdmdm =
                            ddwdqdq * dqdm * dqdm + 2.0 * dwdq * ws.dx[mcol] * ws.dx[mcol];
                        let ddj2dmdm = 2.0 * penalty2 * (self.d[mcol + mcol * n] + sum_aux1);
                        let ddjdmdm = w_w * ddj2dmdm + ddwdmdm * dj1dw + dwdm * dwdm * ddj1dwdw;
                        self.meta_step(cfg, off, djdm, ddjdmdm, trans_mul);
                    }
                    ws.dj2dm[off] = djdm;
                }
            }
            for j in 0..n {
                for i in 0..=j {
                    let off = i + j * n;
                    let delta = self.alpha[off] * trans_mul * ws.dj2dm[off];
                    if delta > 0.1 * max_m {
                        self.alpha[off] *= 0.5;
                    } else {
                        self.m[off] -= delta;
                    }
                }
            }
            gram_upper(&self.m, &mut self.d, n);
        }
        for i in 0..nr {
            if ws.deriv_ok[i] {
                self.big_h[i] = self.lambda[i] * self.big_h[i]
                    + (w / (1.0 - hh)) * self.s[i] * e_cv * trans_mul;
                self.r[i] = self.lambda[i] * self.r[i]
                    + (w * w * e_cv2 / (1.0 - hh)) * self.s[i] * self.s[i] * trans_mul;
            }
        }
    }

    /// Incremental delta-bar-delta (Sutton 1992) with the reference's safety
    /// clips, for element `off` of the metric.
    fn meta_step(&mut self, cfg: &LwprConfig, off: usize, djdm: f64, ddjdmdm: f64, trans_mul: f64) {
        let aux = (cfg.meta_rate * trans_mul * djdm * self.h[off]).clamp(-0.1, 0.1);
        let b = (self.b[off] - aux).clamp(-10.0, 10.0);
        self.b[off] = b;
        let alpha = b.exp();
        self.alpha[off] = alpha;
        let decay = (1.0 - alpha * ddjdmdm * trans_mul).max(0.0);
        self.h[off] = self.h[off] * decay - alpha * trans_mul * djdm;
    }

    /// Adds a PLS direction when the last one has lowered the
    /// cross-validation error enough (the reference's
    /// `lwpr_aux_check_add_projection`).
    fn check_add_projection(&mut self, cfg: &LwprConfig) {
        let nr = self.n_reg;
        let n = self.n;
        if nr >= n {
            return;
        }
        let mse_r = self.sum_e_cv2[nr - 1] / self.sum_w[nr - 1] + 1e-10;
        let mse_r1 = self.sum_e_cv2[nr - 2] / self.sum_w[nr - 2] + 1e-10;
        if mse_r < cfg.add_threshold * mse_r1
            && self.n_data[nr - 1] > 0.99 * self.n_data[0]
            && self.n_data[nr - 1] * (1.0 - self.lambda[nr - 1]) > 0.5
        {
            let mut unit = vec![0.0; n];
            unit[nr] = 1.0;
            self.u.extend_from_slice(&unit);
            self.p.extend_from_slice(&unit);
            self.sxres_yres.extend(std::iter::repeat_n(0.0, n));
            self.ssxres.extend(std::iter::repeat_n(0.0, n));
            self.beta.push(0.0);
            self.ss_s2.push(cfg.init_s2);
            self.ss_yres.push(0.0);
            self.sum_w.push(1e-10);
            self.n_data.push(0.0);
            self.lambda.push(cfg.init_lambda);
            self.sum_e_cv2.push(0.0);
            self.big_h.push(0.0);
            self.r.push(0.0);
            self.s.push(0.0);
            self.n_reg = nr + 1;
            self.ssp = 0.0;
        }
    }
}

/// `out = M D` for upper-triangular M and symmetric D (N x N column-major).
fn mat_mul_upper(m: &[f64], d: &[f64], out: &mut [f64], n: usize) {
    #[cfg(feature = "faer")]
    if n >= FAER_MIN_DIM {
        let mm = faer::MatRef::from_column_major_slice(m, n, n);
        let dd = faer::MatRef::from_column_major_slice(d, n, n);
        let oo = faer::MatMut::from_column_major_slice_mut(out, n, n);
        faer::linalg::matmul::triangular::matmul(
            oo,
            faer::linalg::matmul::triangular::BlockStructure::Rectangular,
            faer::Accum::Replace,
            mm,
            faer::linalg::matmul::triangular::BlockStructure::TriangularUpper,
            dd,
            faer::linalg::matmul::triangular::BlockStructure::Rectangular,
            1.0,
            faer::Par::Seq,
        );
        return;
    }
    for col in 0..n {
        for row in 0..n {
            let mut v = 0.0;
            for k in row..n {
                v += m[row + k * n] * d[k + col * n];
            }
            out[row + col * n] = v;
        }
    }
}

/// `D = M^T M` for upper-triangular M (N x N column-major), symmetric
/// result.
fn gram_upper(m: &[f64], d: &mut [f64], n: usize) {
    #[cfg(feature = "faer")]
    if n >= FAER_MIN_DIM {
        let mm = faer::MatRef::from_column_major_slice(m, n, n);
        let dd = faer::MatMut::from_column_major_slice_mut(d, n, n);
        faer::linalg::matmul::triangular::matmul(
            dd,
            faer::linalg::matmul::triangular::BlockStructure::Rectangular,
            faer::Accum::Replace,
            mm.transpose(),
            faer::linalg::matmul::triangular::BlockStructure::TriangularLower,
            mm,
            faer::linalg::matmul::triangular::BlockStructure::TriangularUpper,
            1.0,
            faer::Par::Seq,
        );
        return;
    }
    for j in 0..n {
        for i in j..n {
            // D(i, j) = sum_{k <= j} M(k, i) M(k, j).
            let mut v = 0.0;
            for k in 0..=j {
                v += m[k + i * n] * m[k + j * n];
            }
            d[i + j * n] = v;
            d[j + i * n] = v;
        }
    }
}

#[cfg(all(test, feature = "faer"))]
mod faer_tests {
    use super::*;

    /// An upper-triangular M and a symmetric D, column-major, n x n.
    fn inputs(n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut m = vec![0.0; n * n];
        let mut d = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                let v = ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.4;
                if i <= j {
                    m[i + j * n] = v + if i == j { 2.0 } else { 0.0 };
                }
                d[i + j * n] = ((i.min(j) * 5 + i.max(j) * 3) % 7) as f64 / 7.0;
            }
        }
        (m, d)
    }

    /// The faer products (n >= FAER_MIN_DIM) equal the plain loops.
    #[test]
    fn faer_products_equal_the_loops() {
        let n = FAER_MIN_DIM + 5;
        let (m, d) = inputs(n);
        let mut fast = vec![0.0; n * n];
        mat_mul_upper(&m, &d, &mut fast, n);
        let mut gram = vec![0.0; n * n];
        gram_upper(&m, &mut gram, n);
        for col in 0..n {
            for row in 0..n {
                let md: f64 = (row..n).map(|k| m[row + k * n] * d[k + col * n]).sum();
                assert!((fast[row + col * n] - md).abs() <= 1e-12 * md.abs().max(1.0));
                let mtm: f64 = (0..n).map(|k| m[k + row * n] * m[k + col * n]).sum();
                assert!((gram[row + col * n] - mtm).abs() <= 1e-12 * mtm.abs().max(1.0));
            }
        }
    }
}
