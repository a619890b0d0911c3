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

// The kernels below keep one summation order, that of `dot`: four
// accumulators over whole chunks of four (lane k takes the elements
// i = k mod 4), combined as (a0 + a1) + (a2 + a3), then the tail added one
// element at a time. Iterating over exact chunks of equal-length slices (no
// index bounds checks) lets the compiler vectorise them; the fused variants
// compute the vector they multiply on the fly (and store it), with the same
// operations as the separate loops they replace, so results are identical
// bit for bit.

/// `sum_i a_i b_i` over `a.len()` elements (`b` may be longer).
#[inline(always)]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len();
    let split = n / 4 * 4;
    let (a4, at) = a.split_at(split);
    let (b4, bt) = b[..n].split_at(split);
    let mut acc = [0.0f64; 4];
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    // Through memory: combined in registers, the compiler pairs the
    // accumulators as the sum below does ((0, 2) and (1, 3) in two-lane
    // vectors) and shuffles every product into them, three instructions
    // more per four elements than one four-lane accumulator.
    let acc = core::hint::black_box(acc);
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in at.iter().zip(bt) {
        s += x * y;
    }
    s
}

// The fused kernels below write their vector first (an element-wise loop
// the compiler vectorises), then take [`dot`] of it: the same values summed
// in the same order as one fused loop with `dot`'s accumulators.

/// `dot(u, v)` with `v = a - b`, which is written into `out`.
#[inline(always)]
fn dot_diff(u: &[f64], a: &[f64], b: &[f64], out: &mut [f64]) -> f64 {
    let n = u.len();
    let (a, b, out) = (&a[..n], &b[..n], &mut out[..n]);
    for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
        *o = a - b;
    }
    dot(u, out)
}

/// `dot(u, v)` with the deflated residual `v = a - p t`, which is written
/// into `out`.
#[inline(always)]
fn dot_axpy(u: &[f64], a: &[f64], p: &[f64], t: f64, out: &mut [f64]) -> f64 {
    let n = u.len();
    let (a, p, out) = (&a[..n], &p[..n], &mut out[..n]);
    for ((o, a), p) in out.iter_mut().zip(a).zip(p) {
        *o = a - p * t;
    }
    dot(u, out)
}

/// `dot(u, x)` after deflating `x` in place: `x <- x - p t`.
#[inline(always)]
fn dot_deflate(u: &[f64], x: &mut [f64], p: &[f64], t: f64) -> f64 {
    let n = u.len();
    let (x, p) = (&mut x[..n], &p[..n]);
    for (x, p) in x.iter_mut().zip(p) {
        *x -= p * t;
    }
    dot(u, x)
}

/// [`dot_diff`] for two fields at once (`out_k = a - b_k`), the same
/// operations in the same order per field.
#[inline(always)]
fn dot_diff2(u: [&[f64]; 2], a: &[f64], b: [&[f64]; 2], out: [&mut [f64]; 2]) -> [f64; 2] {
    let [o0, o1] = out;
    [dot_diff(u[0], a, b[0], o0), dot_diff(u[1], a, b[1], o1)]
}

/// [`dot_deflate`] for two fields at once.
#[inline(always)]
fn dot_deflate2(u: [&[f64]; 2], x: [&mut [f64]; 2], p: [&[f64]; 2], t: [f64; 2]) -> [f64; 2] {
    let [x0, x1] = x;
    [
        dot_deflate(u[0], x0, p[0], t[0]),
        dot_deflate(u[1], x1, p[1], t[1]),
    ]
}

/// `max_i |m_i|` (0 for none; NaNs ignored, as `f64::max` does). The
/// maximum of a set does not depend on the order of comparison, so four
/// interleaved running maxima give the sequential fold's value exactly.
#[inline(always)]
fn max_abs(m: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let split = m.len() / 4 * 4;
    for c in m[..split].chunks_exact(4) {
        for l in 0..4 {
            acc[l] = acc[l].max(c[l].abs());
        }
    }
    let mut r = acc[0].max(acc[1]).max(acc[2].max(acc[3]));
    for v in &m[split..] {
        r = r.max(v.abs());
    }
    r
}

/// The activation at squared distance `q` (the kernel alone, no
/// derivatives).
#[inline(always)]
pub(super) fn weight(kernel: Kernel, q: f64) -> f64 {
    match kernel {
        Kernel::Gaussian => (-0.5 * q).exp(),
        Kernel::BiSquare => {
            let t = 1.0 - 0.25 * q;
            if t < 0.0 { 0.0 } else { t * t }
        }
    }
}

/// The activation at squared distance `q` and its derivatives dw/dq,
/// d2w/dq2.
#[inline(always)]
pub(super) fn derivs(kernel: Kernel, q: f64) -> (f64, f64, f64) {
    let w = weight(kernel, q);
    match kernel {
        Kernel::Gaussian => (w, -0.5 * w, 0.25 * w),
        Kernel::BiSquare => {
            let t = 1.0 - 0.25 * q;
            if t < 0.0 {
                (0.0, 0.0, 0.0)
            } else {
                (w, -0.5 * t, 0.125)
            }
        }
    }
}

/// The squared distances of `x` to four diagonal-metric fields, each summed
/// in index order as [`ReceptiveField::distance`] does (identical results);
/// the four independent sums run side by side. The terms `d_i e_i e_i`
/// (`e = x - c`) are taken first, field by field in vector lanes (the same
/// operations), into `terms` (at least `4 N` long), then added to the four
/// running sums one by one: the same additions in the same order.
#[inline(always)]
pub(super) fn distances4(x: &[f64], rfs: [&ReceptiveField; 4], terms: &mut [f64]) -> [f64; 4] {
    let n = x.len();
    let (t01, t23) = terms[..4 * n].split_at_mut(2 * n);
    let ((t0, t1), (t2, t3)) = (t01.split_at_mut(n), t23.split_at_mut(n));
    for (t, rf) in [&mut *t0, &mut *t1, &mut *t2, &mut *t3]
        .into_iter()
        .zip(rfs)
    {
        distance_terms(t, x, &rf.c[..n], &rf.d[..n]);
    }
    let mut q = [0.0f64; 4];
    for (((a, b), c), d) in t0.iter().zip(&*t1).zip(&*t2).zip(&*t3) {
        q[0] += a;
        q[1] += b;
        q[2] += c;
        q[3] += d;
    }
    q
}

/// `t_i = d_i (x_i - c_i)^2`, as `(d e) e` (the slices as separate
/// arguments, so that the compiler knows they do not overlap).
#[inline(always)]
fn distance_terms(t: &mut [f64], x: &[f64], c: &[f64], d: &[f64]) {
    for (((t, x), c), d) in t.iter_mut().zip(x).zip(c).zip(d) {
        let e = x - c;
        *t = d * e * e;
    }
}

/// Scalars of one PLS direction's update: (lambda_slow, w ytarget, lambda,
/// w s, 1 / SSs2).
type DirScalars = (f64, f64, f64, f64, f64);

/// One pass of a PLS direction's update over the inputs `x` (its residual):
/// `SXresYres <- lambda_slow SXresYres + w ytarget x`, whose squared norm is
/// returned (summed in index order), `SSXres <- lambda SSXres + w s x` and
/// `p = SSXres / SSs2`. The element-wise updates, with the squares of the
/// new `SXresYres` into `sq`, run first (a loop the compiler vectorises),
/// then the squares are added to the norm one by one in index order: the
/// same operations as one fused loop, so the same bits.
#[inline(always)]
fn fused_sums(
    sxy: &mut [f64],
    ssx: &mut [f64],
    p: &mut [f64],
    x: &[f64],
    sc: DirScalars,
    sq: &mut [f64],
) -> f64 {
    let n = sxy.len().min(x.len()).min(ssx.len()).min(p.len());
    let sq = &mut sq[..n];
    single_pass(&mut sxy[..n], &mut ssx[..n], &mut p[..n], sq, &x[..n], sc);
    let mut unorm = 0.0;
    for q in sq.iter() {
        unorm += q;
    }
    unorm
}

/// The element-wise part of [`fused_sums`] (the slices as separate
/// arguments, so that the compiler knows they do not overlap).
#[inline(always)]
fn single_pass(
    sxy: &mut [f64],
    ssx: &mut [f64],
    p: &mut [f64],
    sq: &mut [f64],
    x: &[f64],
    sc: DirScalars,
) {
    let (lambda_slow, wyt, lj, wsj, inv_ss_s2) = sc;
    for ((((a, x), sx), p), q) in sxy
        .iter_mut()
        .zip(x)
        .zip(ssx.iter_mut())
        .zip(p.iter_mut())
        .zip(sq.iter_mut())
    {
        *a = *a * lambda_slow + wyt * x;
        *q = *a * *a;
        *sx = lj * *sx + wsj * x;
        *p = *sx * inv_ss_s2;
    }
}

/// Elements per block of [`fused_sums_pair`].
const SQ_BLOCK: usize = 16;

/// [`fused_sums`] for two directions (the same operations, so the same
/// results): the element-wise updates of both, a block of [`SQ_BLOCK`]
/// elements at a time (in vector lanes, the squares of the new `SXresYres`
/// into two small arrays), then that block's squares added to the two
/// norms, each in index order, side by side. The additions are one long
/// chain of dependent operations per norm; block by block, the next block's
/// updates run while a block's additions wait on each other (a pass over
/// all the squares after all the updates waited on the chains alone).
#[inline(always)]
fn fused_sums_pair(
    sxy: [&mut [f64]; 2],
    ssx: [&mut [f64]; 2],
    p: [&mut [f64]; 2],
    x: [&[f64]; 2],
    sc: [DirScalars; 2],
) -> (f64, f64) {
    let n = x[0].len();
    let full = n / SQ_BLOCK * SQ_BLOCK;
    let [sxy0, sxy1] = sxy.map(|v| v[..n].split_at_mut(full));
    let [ssx0, ssx1] = ssx.map(|v| v[..n].split_at_mut(full));
    let [p0, p1] = p.map(|v| v[..n].split_at_mut(full));
    let [x0, x1] = x.map(|v| v[..n].split_at(full));
    let mut q = [[0f64; SQ_BLOCK]; 2];
    let (mut un0, mut un1) = (0.0, 0.0);
    let mut sums = |q0: &[f64], q1: &[f64]| {
        for (a0, a1) in q0.iter().zip(q1) {
            un0 += a0;
            un1 += a1;
        }
    };
    for (((((((a0, a1), s0), s1), r0), r1), y0), y1) in sxy0
        .0
        .chunks_exact_mut(SQ_BLOCK)
        .zip(sxy1.0.chunks_exact_mut(SQ_BLOCK))
        .zip(ssx0.0.chunks_exact_mut(SQ_BLOCK))
        .zip(ssx1.0.chunks_exact_mut(SQ_BLOCK))
        .zip(p0.0.chunks_exact_mut(SQ_BLOCK))
        .zip(p1.0.chunks_exact_mut(SQ_BLOCK))
        .zip(x0.0.chunks_exact(SQ_BLOCK))
        .zip(x1.0.chunks_exact(SQ_BLOCK))
    {
        let [q0, q1] = &mut q;
        pair_block_parts(a0, a1, s0, s1, r0, r1, q0, q1, y0, y1, sc);
        sums(q0, q1);
    }
    let t = n - full;
    let [q0, q1] = &mut q;
    let (q0, q1) = (&mut q0[..t], &mut q1[..t]);
    pair_block_parts(
        sxy0.1, sxy1.1, ssx0.1, ssx1.1, p0.1, p1.1, q0, q1, x0.1, x1.1, sc,
    );
    sums(q0, q1);
    (un0, un1)
}

/// The element-wise part of [`fused_sums_pair`], with the
/// squares of the new `SXresYres` into `q0`, `q1`. The slices arrive as
/// separate arguments (of equal length), which tells the compiler they do
/// not overlap: it then vectorises the loop without run-time overlap
/// checks between the eight written and two read slices.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pair_block_parts(
    sxy0: &mut [f64],
    sxy1: &mut [f64],
    ssx0: &mut [f64],
    ssx1: &mut [f64],
    p0: &mut [f64],
    p1: &mut [f64],
    q0: &mut [f64],
    q1: &mut [f64],
    x0: &[f64],
    x1: &[f64],
    sc: [DirScalars; 2],
) {
    let (ls0, wyt0, l0, ws0, inv0) = sc[0];
    let (ls1, wyt1, l1, ws1, inv1) = sc[1];
    let m = x0.len();
    let (sxy0, sxy1, ssx0, ssx1) = (
        &mut sxy0[..m],
        &mut sxy1[..m],
        &mut ssx0[..m],
        &mut ssx1[..m],
    );
    let (p0, p1, q0, q1, x1) = (
        &mut p0[..m],
        &mut p1[..m],
        &mut q0[..m],
        &mut q1[..m],
        &x1[..m],
    );
    for i in 0..m {
        let a0 = sxy0[i] * ls0 + wyt0 * x0[i];
        sxy0[i] = a0;
        q0[i] = a0 * a0;
        let a1 = sxy1[i] * ls1 + wyt1 * x1[i];
        sxy1[i] = a1;
        q1[i] = a1 * a1;
        let s0 = l0 * ssx0[i] + ws0 * x0[i];
        ssx0[i] = s0;
        p0[i] = s0 * inv0;
        let s1 = l1 * ssx1[i] + ws1 * x1[i];
        ssx1[i] = s1;
        p1[i] = s1 * inv1;
    }
}

/// Scratch buffers shared by all RFs of a model.
#[derive(Debug, Clone)]
pub(super) struct Workspace {
    /// The terms of [`distances4`] (`4 N`) and the squares of
    /// [`fused_sums`] (`N`).
    pub(super) terms: Vec<f64>,
    xc: Vec<f64>,
    /// The second field's residual and projections in
    /// [`ReceptiveField::predict_local_pair`].
    xc_b: Vec<f64>,
    s_b: Vec<f64>,
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
            terms: vec![0.0; 4 * n],
            xc: vec![0.0; n],
            xc_b: vec![0.0; n],
            s_b: Vec::new(),
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
            self.s_b.resize(r, 0.0);
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

    /// The centre `c`.
    pub(super) fn centre(&self) -> &[f64] {
        &self.c
    }

    /// The diagonal of the distance metric D (a diagonal metric only).
    pub(super) fn metric_diag(&self) -> &[f64] {
        debug_assert!(!self.full);
        &self.d
    }

    /// Squared Mahalanobis distance `(x - c)^T D (x - c)` (a full metric
    /// leaves `x - c` in `ws.dx` and `M (x - c)` in `ws.mdx`).
    #[inline(always)]
    pub(super) fn distance(&self, xn: &[f64], ws: &mut Workspace) -> f64 {
        let n = self.n;
        if !self.full {
            // Summed in index order (the packed kernel in `pack` keeps it).
            return self
                .d
                .iter()
                .zip(xn)
                .zip(&self.c)
                .map(|((d, x), c)| {
                    let dx = x - c;
                    d * dx * dx
                })
                .sum();
        }
        for ((dx, x), c) in ws.dx.iter_mut().zip(xn).zip(&self.c) {
            *dx = x - c;
        }
        {
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
        }
    }

    /// Activation w and its derivatives dw/dq, d2w/dq2 with respect to the
    /// distance q.
    #[inline(always)]
    pub(super) fn activation_derivs(
        &self,
        cfg: &LwprConfig,
        xn: &[f64],
        ws: &mut Workspace,
    ) -> (f64, f64, f64) {
        derivs(cfg.kernel, self.distance(xn, ws))
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

    /// PLS projections of `x` onto the first `nr` directions, into `s`
    /// (`xu` holds the deflated residuals): `s_0 = u_0^T x`,
    /// `x_j = x_(j-1) - p_(j-1) s_(j-1)`, `s_j = u_j^T x_j`.
    #[inline(always)]
    fn project(&self, x: &[f64], nr: usize, s: &mut [f64], xu: &mut [f64]) {
        let n = self.n;
        s[0] = dot(&self.u[..n], x);
        for j in 1..nr {
            let (u, p) = (&self.u[j * n..(j + 1) * n], &self.p[(j - 1) * n..j * n]);
            s[j] = if j == 1 {
                dot_axpy(u, x, p, s[0], xu)
            } else {
                dot_deflate(u, xu, p, s[j - 1])
            };
        }
    }

    /// Local prediction at `xn` (relative to the RF's weighted input mean)
    /// and, when asked, `sum_j s_j^2 / SSs2_j` for the confidence.
    #[inline(always)]
    pub(super) fn predict_local(
        &self,
        _cfg: &LwprConfig,
        xn: &[f64],
        ws: &mut Workspace,
        s2: Option<&mut f64>,
    ) -> f64 {
        let nr = self.n_pred();
        let n = self.n;
        ws.ensure_reg(n, self.n_reg);
        // The projections of x - mean_x (computed on the fly and deflated in
        // place in ws.xc).
        ws.s[0] = dot_diff(&self.u[..n], xn, &self.mean_x, &mut ws.xc);
        for j in 1..nr {
            let (u, p) = (&self.u[j * n..(j + 1) * n], &self.p[(j - 1) * n..j * n]);
            ws.s[j] = dot_deflate(u, &mut ws.xc, p, ws.s[j - 1]);
        }
        let (y, q) = self.local_output(&ws.s[..nr]);
        if let Some(out) = s2 {
            *out = q;
        }
        y
    }

    /// `beta0 + sum_j beta_j s_j` and `sum_j s_j^2 / SSs2_j` for the
    /// projections `s`.
    #[inline(always)]
    fn local_output(&self, s: &[f64]) -> (f64, f64) {
        let mut y = self.beta0;
        let mut q = 0.0;
        for (j, sj) in s.iter().enumerate() {
            y += sj * self.beta[j];
            q += sj * sj / self.ss_s2[j];
        }
        (y, q)
    }

    /// [`ReceptiveField::predict_local`] of two fields (of the same input
    /// dimension) at once: the same operations per field, direction by
    /// direction for both fields.
    #[inline(always)]
    pub(super) fn predict_local_pair(
        a: &Self,
        b: &Self,
        xn: &[f64],
        ws: &mut Workspace,
    ) -> (f64, f64) {
        let (na, nb) = (a.n_pred(), b.n_pred());
        let n = a.n;
        ws.ensure_reg(n, a.n_reg.max(b.n_reg));
        [ws.s[0], ws.s_b[0]] = dot_diff2(
            [&a.u[..n], &b.u[..n]],
            xn,
            [&a.mean_x, &b.mean_x],
            [&mut ws.xc, &mut ws.xc_b],
        );
        for j in 1..na.max(nb) {
            let rows = (j - 1) * n..j * n;
            let next = j * n..(j + 1) * n;
            if j < na && j < nb {
                [ws.s[j], ws.s_b[j]] = dot_deflate2(
                    [&a.u[next.clone()], &b.u[next]],
                    [&mut ws.xc, &mut ws.xc_b],
                    [&a.p[rows.clone()], &b.p[rows]],
                    [ws.s[j - 1], ws.s_b[j - 1]],
                );
            } else if j < na {
                ws.s[j] = dot_deflate(&a.u[next], &mut ws.xc, &a.p[rows], ws.s[j - 1]);
            } else {
                ws.s_b[j] = dot_deflate(&b.u[next], &mut ws.xc_b, &b.p[rows], ws.s_b[j - 1]);
            }
        }
        (
            a.local_output(&ws.s[..na]).0,
            b.local_output(&ws.s_b[..nb]).0,
        )
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
    #[inline(always)]
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

    #[inline(always)]
    fn update_means(&mut self, x: &[f64], y: f64, w: f64, ws: &mut Workspace) -> f64 {
        let swl = self.sum_w[0] * self.lambda[0];
        let inv = 1.0 / (swl + w);
        for (((mx, vx), xmz), xi) in self
            .mean_x
            .iter_mut()
            .zip(self.var_x.iter_mut())
            .zip(ws.xmz.iter_mut())
            .zip(x)
        {
            let m = (swl * *mx + w * xi) * inv;
            *mx = m;
            let z = xi - m;
            *xmz = z;
            *vx = (swl * *vx + w * z * z) * inv;
        }
        self.beta0 = (swl * self.beta0 + w * y) * inv;
        y - self.beta0
    }

    /// Incremental PLS on (xmz, y) (the reference's
    /// `lwpr_aux_update_regression`). Returns (prediction, e_cv of the
    /// directions used, residual after the update).
    #[inline(always)]
    fn update_regression(&mut self, y: f64, w: f64, ws: &mut Workspace) -> (f64, f64, f64) {
        let n = self.n;
        let nr = self.n_reg;
        // Projections with residuals, before the update: xres_0 = xmz (not
        // copied), xres_j = xres_(j-1) - p_(j-1) s_(j-1) at
        // ws.xres[(j - 1) N, j N).
        self.s[0] = dot(&self.u[..n], &ws.xmz);
        for j in 1..nr {
            let (u, p) = (&self.u[j * n..(j + 1) * n], &self.p[(j - 1) * n..j * n]);
            let (done, rest) = ws.xres.split_at_mut((j - 1) * n);
            let prev: &[f64] = if j == 1 {
                &ws.xmz
            } else {
                &done[(j - 2) * n..]
            };
            self.s[j] = dot_axpy(u, prev, p, self.s[j - 1], &mut rest[..n]);
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
        // Per direction: the sums of squared projections and of projected
        // targets give beta; one pass over the inputs updates SXresYres (and
        // sums its squared norm), SSXres and the loading p; then u is the
        // normalised SXresYres. Directions go in pairs, whose norms' running
        // sums (each in index order) advance side by side.
        let mut ws2_ss_s2 = 0.0;
        let mut scal = [(0.0, 0.0, 0.0, 0.0, 0.0); 2];
        let mut j = 0;
        while j < nr {
            let pair = j + 1 < nr;
            for (k, sc) in scal.iter_mut().enumerate().take(if pair { 2 } else { 1 }) {
                let jj = j + k;
                let lambda_slow = 0.9 + 0.1 * self.lambda[jj];
                let wyt = w * ws.ytarget[jj];
                let lj = self.lambda[jj];
                let wsj = w * self.s[jj];
                self.ss_s2[jj] = lj * self.ss_s2[jj] + self.s[jj] * wsj;
                self.ss_yres[jj] = lj * self.ss_yres[jj] + ws.ytarget[jj] * wsj;
                let inv_ss_s2 = 1.0 / self.ss_s2[jj];
                self.beta[jj] = self.ss_yres[jj] * inv_ss_s2;
                *sc = (lambda_slow, wyt, lj, wsj, inv_ss_s2);
            }
            let xres = |jj: usize| -> &[f64] {
                if jj == 0 {
                    &ws.xmz
                } else {
                    &ws.xres[(jj - 1) * n..jj * n]
                }
            };
            let range = j * n..(j + 1) * n;
            let unorms = if pair {
                let (sxy0, sxy1) = self.sxres_yres[j * n..(j + 2) * n].split_at_mut(n);
                let (ssx0, ssx1) = self.ssxres[j * n..(j + 2) * n].split_at_mut(n);
                let (p0, p1) = self.p[j * n..(j + 2) * n].split_at_mut(n);
                let (u0, u1) = fused_sums_pair(
                    [sxy0, sxy1],
                    [ssx0, ssx1],
                    [p0, p1],
                    [xres(j), xres(j + 1)],
                    scal,
                );
                [u0, u1]
            } else {
                let u0 = fused_sums(
                    &mut self.sxres_yres[range.clone()],
                    &mut self.ssxres[range.clone()],
                    &mut self.p[range],
                    xres(j),
                    scal[0],
                    &mut ws.terms,
                );
                [u0, 0.0]
            };
            for (k, &unorm) in unorms.iter().enumerate().take(if pair { 2 } else { 1 }) {
                let jj = j + k;
                if unorm > 1e-24 {
                    let inv = 1.0 / unorm.sqrt();
                    let sxy = &self.sxres_yres[jj * n..(jj + 1) * n];
                    for (u, a) in self.u[jj * n..(jj + 1) * n].iter_mut().zip(sxy) {
                        *u = a * inv;
                    }
                }
                let (_, _, _, wsj, inv_ss_s2) = scal[k];
                ws2_ss_s2 += wsj * wsj * inv_ss_s2;
            }
            j += if pair { 2 } else { 1 };
        }
        self.ssp = self.lambda[nr - 1] * self.ssp + ws2_ss_s2;
        // Projections after the update.
        let mut s = std::mem::take(&mut self.s);
        self.project(&ws.xmz, nr, &mut s, &mut ws.xc);
        self.s = s;
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
    #[inline(always)]
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
        if self.full || cfg.meta {
            for ((dx, x), c) in ws.dx.iter_mut().zip(xn).zip(&self.c) {
                *dx = x - c;
            }
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
        if !self.full && !cfg.meta {
            // One pass over the diagonal: the gradient of each M_jj, the step
            // (or the halved learning rate) and D_jj = M_jj^2 (each element
            // depends on its own index and max |M| alone).
            let lim = 0.1 * max_abs(&self.m);
            // The factors of the step below, opaque to the compiler (see
            // there).
            let (half, one, zero) = core::hint::black_box((0.5f64, 1.0f64, 0.0f64));
            for ((((m, d), alpha), x), c) in self
                .m
                .iter_mut()
                .zip(self.d.iter_mut())
                .zip(self.alpha.iter_mut())
                .zip(xn)
                .zip(&self.c)
            {
                let dx = x - c;
                let aux = 2.0 * *m;
                let dx2 = dx * dx;
                let dqdm = dx2 * aux;
                let dwdm = dqdm * dwdq;
                let djdm = w_w * (penalty2 * *d * aux) + dwdm * dj1dw;
                let delta = *alpha * trans_mul * djdm;
                // A step larger than a tenth of max |M| halves the rate
                // instead. Written as arithmetic on selected factors (`x * 1`
                // and `x - 0` are `x` exactly), both stored every time. As
                // selects between the old and the new value (or with the
                // factors known, which the compiler turns back into such
                // selects) the compiler stored only the changed lanes
                // (`vmaskmovpd`, slow on AMD cores: this loop took a tenth
                // of an `ispf` run).
                let too_big = delta > lim;
                *alpha *= if too_big { half } else { one };
                *m -= if too_big { zero } else { delta };
                *d = *m * *m;
            }
        } else if !self.full {
            let max_m = max_abs(&self.m);
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

#[cfg(test)]
mod term_first_tests {
    use super::*;
    use bayestrack_image::simd::{Kernel as SimdKernel, SimdLevel, Token};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn normals(rng: &mut Xoshiro256PlusPlus, n: usize) -> Vec<f64> {
        (0..n).map(|_| StandardNormal.sample(&mut *rng)).collect()
    }

    /// The three kernels on fixed inputs, as a dispatched kernel.
    struct Blocks<'a> {
        x: &'a [f64],
        rfs: [&'a ReceptiveField; 4],
        state: &'a [Vec<f64>; 6],
        sc: [DirScalars; 2],
    }

    /// `(distances, single norm and its vectors, pair norms and vectors)`.
    type Out = ([f64; 4], f64, [Vec<f64>; 3], (f64, f64), [Vec<f64>; 6]);

    impl SimdKernel for Blocks<'_> {
        type Output = Out;
        #[inline(always)]
        fn run<T: Token>(self, _: T) -> Out {
            let n = self.x.len();
            let mut terms = vec![0.0; 4 * n];
            let q = distances4(self.x, self.rfs, &mut terms);
            let [a0, a1, s0, s1, p0, p1] = self.state.clone();
            let (mut sxy, mut ssx, mut p) = (a0.clone(), s0.clone(), p0.clone());
            let single = fused_sums(&mut sxy, &mut ssx, &mut p, self.x, self.sc[0], &mut terms);
            let (mut b0, mut b1, mut t0, mut t1, mut r0, mut r1) = (a0, a1, s0, s1, p0, p1);
            let x1: Vec<f64> = self.x.iter().map(|v| 0.5 - v).collect();
            let pair = fused_sums_pair(
                [&mut b0, &mut b1],
                [&mut t0, &mut t1],
                [&mut r0, &mut r1],
                [self.x, &x1],
                self.sc,
            );
            (q, single, [sxy, ssx, p], pair, [b0, b1, t0, t1, r0, r1])
        }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// The kernels that take their terms ahead of their sums equal the
    /// plain one-loop computations bit for bit at every SIMD level, for
    /// lengths around the vector widths and the pose estimator's 144.
    #[test]
    fn term_first_kernels_equal_the_plain_loops_at_every_level() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        for n in (1..=9).chain([63, 64, 65, 127, 128, 144, 150]) {
            let cfg = LwprConfig::new(n, 1);
            let init_m = cfg.validate().unwrap();
            let x = normals(&mut rng, n);
            let rfs: Vec<ReceptiveField> = (0..4)
                .map(|_| {
                    let mut rf =
                        ReceptiveField::new(&cfg, &init_m, None, &normals(&mut rng, n), 0.0);
                    rf.d = normals(&mut rng, n).iter().map(|v| v.abs() * 3.0).collect();
                    rf
                })
                .collect();
            let state: [Vec<f64>; 6] = core::array::from_fn(|_| normals(&mut rng, n));
            let sc = [(0.95, 0.3, 0.999, -0.7, 1.3), (0.91, -1.2, 0.99, 0.4, 0.6)];
            // The plain loops.
            let mut want_q = [0.0f64; 4];
            for (q, rf) in want_q.iter_mut().zip(&rfs) {
                for i in 0..n {
                    let e = x[i] - rf.c[i];
                    *q += rf.d[i] * e * e;
                }
            }
            let x1: Vec<f64> = x.iter().map(|v| 0.5 - v).collect();
            let plain = |k: usize, xs: &[f64]| {
                let (ls, wyt, l, ws, inv) = sc[k];
                let (mut a, mut s, mut p) =
                    (state[k].clone(), state[2 + k].clone(), state[4 + k].clone());
                for i in 0..n {
                    a[i] = a[i] * ls + wyt * xs[i];
                    s[i] = l * s[i] + ws * xs[i];
                    p[i] = s[i] * inv;
                }
                let mut un = 0.0;
                for v in &a {
                    un += v * v;
                }
                (un, a, s, p)
            };
            let (u0, a0, s0, p0) = plain(0, &x);
            let (u1, a1, s1, p1) = plain(1, &x1);
            for level in SimdLevel::ALL {
                let (q, single, vecs, pair, pvecs) = level.run(Blocks {
                    x: &x,
                    rfs: [&rfs[0], &rfs[1], &rfs[2], &rfs[3]],
                    state: &state,
                    sc,
                });
                assert_eq!(bits(&q), bits(&want_q), "{level:?} n {n}: distances");
                assert_eq!(single.to_bits(), u0.to_bits(), "{level:?} n {n}: single");
                assert_eq!(vecs.map(|v| bits(&v)), [&a0, &s0, &p0].map(|v| bits(v)));
                assert_eq!(
                    [pair.0.to_bits(), pair.1.to_bits()],
                    [u0.to_bits(), u1.to_bits()]
                );
                assert_eq!(
                    pvecs.map(|v| bits(&v)),
                    [&a0, &a1, &s0, &s1, &p0, &p1].map(|v| bits(v)),
                    "{level:?} n {n}: pair"
                );
            }
        }
    }
}
