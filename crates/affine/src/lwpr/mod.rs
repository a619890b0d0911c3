//! Locally weighted projection regression (LWPR; Vijayakumar, D'Souza and
//! Schaal, "Incremental online learning in high dimensions", Neural
//! Computation 17, 2005), written from the algorithm as the reference library
//! of Klanke and Vijayakumar implements it (see `notes/lwpr.md`).
//!
//! Each output dimension is learnt by its own set of receptive fields (RFs).
//! An RF k has a centre `c_k`, a distance metric `D_k = M_k^T M_k` (M upper
//! triangular, or diagonal) and a local partial-least-squares (PLS) model with
//! `R_k` projection directions. For a normalised input `x`:
//!
//! ```text
//! w_k   = exp(-1/2 (x - c_k)^T D_k (x - c_k))                (Gaussian kernel)
//! y_k   = beta0_k + sum_j beta_kj s_kj,  s_kj = u_kj^T xres_kj (PLS on x - mean_x_k)
//! y     = sum_k w_k y_k / sum_k w_k                          (trustworthy RFs, w_k > cutoff)
//! ```
//!
//! Every update adjusts the weighted means, the incremental PLS statistics
//! (with forgetting factor lambda), the distance metric by a stochastic
//! gradient step on M that lowers the leave-one-out cross-validation error
//! plus the penalty `gamma / N sum D_ij^2` (learning rates optionally adapted
//! by incremental delta-bar-delta meta learning), and may add a PLS
//! direction. A new RF is created at `x` when no RF is activated above
//! `w_gen`; one of two RFs that overlap above `w_prune` is removed.

#![allow(clippy::needless_range_loop)] // index loops mirror the algorithm's equations

mod pack;
mod rf;

use bayestrack_image::simd::{self, Token, dispatch};

use crate::error::{AffineError, Result, check_finite};
use pack::ActivationPack;
use rf::{ReceptiveField, Workspace, derivs, distances4, weight};

/// Activation kernel of the receptive fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Kernel {
    /// `w = exp(-d / 2)` with `d = (x - c)^T D (x - c)`.
    #[default]
    Gaussian,
    /// `w = (1 - d / 4)^2` for `d < 4`, else 0.
    BiSquare,
}

/// Parameters of an LWPR model. [`LwprConfig::new`] sets the reference
/// library's defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct LwprConfig {
    /// Input dimension N.
    pub n_in: usize,
    /// Output dimension.
    pub n_out: usize,
    /// Diagonal distance metrics only (default true). Needed for
    /// high-dimensional inputs: a full metric stores N^2 numbers per RF.
    pub diag_only: bool,
    /// Adapt the metric learning rates by incremental delta-bar-delta
    /// (default false).
    pub meta: bool,
    /// Meta learning rate (default 250).
    pub meta_rate: f64,
    /// Penalty gamma on the size of D (default 1e-6; divided by N).
    pub penalty: f64,
    /// Initial learning rate of every element of M (default 50).
    pub init_alpha: f64,
    /// Initial distance metric, N x N row-major and symmetric positive
    /// definite (default 25 I). Only the diagonal is used when `diag_only`.
    pub init_d: Vec<f64>,
    /// Create an RF when no activation exceeds this (default 0.1).
    pub w_gen: f64,
    /// Prune one of two RFs whose activations both exceed this (default 1.0,
    /// which never fires for the Gaussian kernel).
    pub w_prune: f64,
    /// Initial forgetting factor (default 0.999).
    pub init_lambda: f64,
    /// Final forgetting factor (default 0.99999).
    pub final_lambda: f64,
    /// Annealing rate of the forgetting factor (default 0.9999).
    pub tau_lambda: f64,
    /// Initial value of the PLS sums of squared projections (default 1e-10).
    pub init_s2: f64,
    /// Add a PLS direction when it lowers the cross-validation MSE below this
    /// fraction of the previous one (default 0.5).
    pub add_threshold: f64,
    /// Activation kernel (default Gaussian).
    pub kernel: Kernel,
    /// Learn the distance metric (default true).
    pub update_d: bool,
    /// Input scales: the model sees `x / norm_in` (default all 1).
    pub norm_in: Vec<f64>,
    /// Output scales: the model learns `y / norm_out` (default all 1).
    pub norm_out: Vec<f64>,
}

impl LwprConfig {
    /// The reference library's defaults for `n_in` inputs and `n_out`
    /// outputs.
    pub fn new(n_in: usize, n_out: usize) -> Self {
        let mut init_d = vec![0.0; n_in * n_in];
        for i in 0..n_in {
            init_d[i * n_in + i] = 25.0;
        }
        Self {
            n_in,
            n_out,
            diag_only: true,
            meta: false,
            meta_rate: 250.0,
            penalty: 1e-6,
            init_alpha: 50.0,
            init_d,
            w_gen: 0.1,
            w_prune: 1.0,
            init_lambda: 0.999,
            final_lambda: 0.99999,
            tau_lambda: 0.9999,
            init_s2: 1e-10,
            add_threshold: 0.5,
            kernel: Kernel::Gaussian,
            update_d: true,
            norm_in: vec![1.0; n_in],
            norm_out: vec![1.0; n_out],
        }
    }

    /// Sets `init_d = d I`.
    pub fn init_d_spherical(mut self, d: f64) -> Self {
        let n = self.n_in;
        self.init_d = vec![0.0; n * n];
        for i in 0..n {
            self.init_d[i * n + i] = d;
        }
        self
    }

    /// Checks every parameter; returns the upper-triangular Cholesky factor
    /// `M` of `init_d` (column-major, `M[i + j N]`, i <= j).
    fn validate(&self) -> Result<Vec<f64>> {
        let n = self.n_in;
        if n == 0 {
            return Err(invalid("n_in", 0.0, "must be >= 1"));
        }
        if self.n_out == 0 {
            return Err(invalid("n_out", 0.0, "must be >= 1"));
        }
        if self.init_d.len() != n * n {
            return Err(AffineError::DimensionMismatch {
                what: "init_d",
                expected: n * n,
                got: self.init_d.len(),
            });
        }
        if self.norm_in.len() != n {
            return Err(AffineError::DimensionMismatch {
                what: "norm_in",
                expected: n,
                got: self.norm_in.len(),
            });
        }
        if self.norm_out.len() != self.n_out {
            return Err(AffineError::DimensionMismatch {
                what: "norm_out",
                expected: self.n_out,
                got: self.norm_out.len(),
            });
        }
        check_finite("init_d", &self.init_d)?;
        for (name, v) in [
            ("meta_rate", self.meta_rate),
            ("init_alpha", self.init_alpha),
            ("init_s2", self.init_s2),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        if !(self.penalty.is_finite() && self.penalty >= 0.0) {
            return Err(invalid("penalty", self.penalty, "must be finite and >= 0"));
        }
        for (name, v) in [
            ("w_gen", self.w_gen),
            ("init_lambda", self.init_lambda),
            ("final_lambda", self.final_lambda),
            ("tau_lambda", self.tau_lambda),
            ("add_threshold", self.add_threshold),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                return Err(invalid(name, v, "must lie in (0, 1]"));
            }
        }
        if self.w_prune.is_nan() || self.w_prune <= 0.0 {
            return Err(invalid("w_prune", self.w_prune, "must be > 0"));
        }
        for (what, xs) in [("norm_in", &self.norm_in), ("norm_out", &self.norm_out)] {
            if let Some(i) = xs.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(invalid(what, xs[i], "must be finite and > 0"));
            }
        }
        cholesky_upper(&self.init_d, n)
    }
}

/// The upper-triangular Cholesky factor `M` of the `n x n` row-major
/// `init_d` (`D = M^T M`, `M` column-major, `M[i + j N]`, i <= j), checking
/// that `init_d` is symmetric positive definite.
///
/// A diagonal `init_d` whose off-diagonal entries are all `+0.0` (as
/// [`LwprConfig::new`] and [`LwprConfig::init_d_spherical`] make it) takes a
/// direct path: in the general loop every product of two off-diagonal
/// entries of `M` there is `+0 * +0`, every difference `+0 - +0` or
/// `d_jj - +0`, so `M` is the diagonal of square roots with `+0.0`
/// elsewhere, the same bits (and the same error for a non-positive
/// diagonal entry) without the `N^3 / 6` multiply-adds (a 144-input
/// model's took more than a percent of an `ispf` run).
fn cholesky_upper(init_d: &[f64], n: usize) -> Result<Vec<f64>> {
    let diagonal = init_d.chunks_exact(n).enumerate().all(|(i, row)| {
        row.iter()
            .enumerate()
            .all(|(j, v)| i == j || v.to_bits() == 0)
    });
    if diagonal {
        let mut m = vec![0.0; n * n];
        for j in 0..n {
            let d = init_d[j * n + j];
            if d <= 0.0 {
                return Err(AffineError::NotPositiveDefinite { which: "init_d" });
            }
            m[j + j * n] = d.sqrt();
        }
        return Ok(m);
    }
    cholesky_upper_general(init_d, n)
}

/// The general loop of [`cholesky_upper`].
fn cholesky_upper_general(init_d: &[f64], n: usize) -> Result<Vec<f64>> {
    // Cholesky D = M^T M with M upper triangular (column-major storage).
    let mut m = vec![0.0; n * n];
    for j in 0..n {
        for i in 0..=j {
            let dij = init_d[i * n + j];
            if (dij - init_d[j * n + i]).abs() > 1e-12 * dij.abs().max(1.0) {
                return Err(AffineError::NotPositiveDefinite { which: "init_d" });
            }
            let mut sum = dij;
            for k in 0..i {
                sum -= m[k + i * n] * m[k + j * n];
            }
            if i == j {
                if sum <= 0.0 {
                    return Err(AffineError::NotPositiveDefinite { which: "init_d" });
                }
                m[j + j * n] = sum.sqrt();
            } else {
                m[i + j * n] = sum / m[i + i * n];
            }
        }
    }
    Ok(m)
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> AffineError {
    AffineError::InvalidParameter {
        name,
        value,
        reason,
    }
}

/// Learnt model of one output dimension.
#[derive(Debug, Clone)]
struct SubModel {
    rfs: Vec<ReceptiveField>,
    n_pruned: usize,
}

/// A prediction with its confidence bound, per output.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// Predicted outputs.
    pub y: Vec<f64>,
    /// One-sigma confidence bound per output (the reference library's
    /// `conf`): combines the local models' predictive variances and their
    /// disagreement. Infinite where no trustworthy RF is active.
    pub conf: Vec<f64>,
    /// Largest activation per output.
    pub max_w: Vec<f64>,
}

/// An incremental LWPR model.
#[derive(Debug, Clone)]
pub struct Lwpr {
    cfg: LwprConfig,
    /// Upper-triangular Cholesky factor of init_d (column-major).
    init_m: Vec<f64>,
    subs: Vec<SubModel>,
    n_data: u64,
    mean_x: Vec<f64>,
    var_x: Vec<f64>,
    ws: Workspace,
    xn: Vec<f64>,
    /// Every input scale is 1 (normalising is then a copy).
    unit_norm_in: bool,
    /// Packed trustworthy fields for predictions (diagonal metrics).
    pack: ActivationPack,
    /// Per-output sums of a prediction (weights, weighted outputs).
    sums: Vec<(f64, f64)>,
    /// The activated trustworthy RFs of a prediction: (output, field,
    /// activation).
    active: Vec<(usize, usize, f64)>,
    /// Squared distances of an update's input to every RF (diagonal
    /// metrics), by output, then field.
    q: Vec<f64>,
}

impl Lwpr {
    /// A new, empty model. Fails on invalid parameters (e.g. `init_d` not
    /// symmetric positive definite, dimension mismatch).
    pub fn new(cfg: LwprConfig) -> Result<Self> {
        let init_m = cfg.validate()?;
        let n = cfg.n_in;
        Ok(Self {
            init_m,
            subs: vec![
                SubModel {
                    rfs: Vec::new(),
                    n_pruned: 0
                };
                cfg.n_out
            ],
            n_data: 0,
            mean_x: vec![0.0; n],
            var_x: vec![0.0; n],
            ws: Workspace::new(n, !cfg.diag_only),
            xn: vec![0.0; n],
            unit_norm_in: cfg.norm_in.iter().all(|&v| v == 1.0),
            pack: ActivationPack::default(),
            sums: vec![(0.0, 0.0); cfg.n_out],
            q: Vec::new(),
            active: Vec::new(),
            cfg,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &LwprConfig {
        &self.cfg
    }

    /// Number of receptive fields of output `dim`.
    ///
    /// # Panics
    /// If `dim >= n_out`.
    pub fn num_rfs(&self, dim: usize) -> usize {
        self.subs[dim].rfs.len()
    }

    /// Number of RFs pruned so far for output `dim`.
    ///
    /// # Panics
    /// If `dim >= n_out`.
    pub fn num_pruned(&self, dim: usize) -> usize {
        self.subs[dim].n_pruned
    }

    /// Number of training samples seen.
    pub fn num_data(&self) -> u64 {
        self.n_data
    }

    /// Running mean and variance of the (unnormalised) inputs seen so far.
    pub fn input_stats(&self) -> (&[f64], &[f64]) {
        (&self.mean_x, &self.var_x)
    }

    /// Number of PLS directions of each RF of output `dim`.
    ///
    /// # Panics
    /// If `dim >= n_out`.
    pub fn projections(&self, dim: usize) -> Vec<usize> {
        self.subs[dim].rfs.iter().map(|rf| rf.n_reg()).collect()
    }

    fn check_input(&self, x: &[f64]) -> Result<()> {
        if x.len() != self.cfg.n_in {
            return Err(AffineError::DimensionMismatch {
                what: "LWPR input",
                expected: self.cfg.n_in,
                got: x.len(),
            });
        }
        // With unit scales, one pass shows every input finite and within
        // the magnitude bound (NaN fails the comparison); otherwise (and to
        // name the offending input) the two checks below.
        if self.unit_norm_in && x.iter().fold(true, |ok, v| ok & (v.abs() <= MAX_MAGNITUDE)) {
            return Ok(());
        }
        check_finite("LWPR input", x)?;
        check_magnitude("LWPR input", x, &self.cfg.norm_in)
    }

    /// Writes `xn = x / norm_in` unless every scale is 1 (then `x / 1 = x`
    /// exactly, and the callers read `x` itself: the normalised input).
    fn normalise_input(&mut self, x: &[f64]) {
        if !self.unit_norm_in {
            for (xn, (xi, ni)) in self.xn.iter_mut().zip(x.iter().zip(&self.cfg.norm_in)) {
                *xn = xi / ni;
            }
        }
    }

    /// Trains on one sample; returns the model's prediction for `x` made
    /// during the update (before the new sample could create an RF), as the
    /// reference library does. Fails on wrong lengths or non-finite values;
    /// the model is unchanged then.
    pub fn update(&mut self, x: &[f64], y: &[f64]) -> Result<Vec<f64>> {
        let mut yp = vec![0.0; self.cfg.n_out];
        self.update_into(x, y, &mut yp)?;
        Ok(yp)
    }

    /// As [`Lwpr::update`], writing the prediction into `yp` (no allocation
    /// once the RFs exist).
    pub fn update_into(&mut self, x: &[f64], y: &[f64], yp: &mut [f64]) -> Result<()> {
        self.check_input(x)?;
        if y.len() != self.cfg.n_out || yp.len() != self.cfg.n_out {
            return Err(AffineError::DimensionMismatch {
                what: "LWPR output",
                expected: self.cfg.n_out,
                got: if y.len() != self.cfg.n_out {
                    y.len()
                } else {
                    yp.len()
                },
            });
        }
        check_finite("LWPR target", y)?;
        check_magnitude("LWPR target", y, &self.cfg.norm_out)?;
        // Model statistics of the raw inputs.
        let nd = self.n_data as f64;
        self.n_data += 1;
        let inv = 1.0 / self.n_data as f64;
        for ((mean, var), xi) in self.mean_x.iter_mut().zip(self.var_x.iter_mut()).zip(x) {
            *mean = (*mean * nd + xi) * inv;
            let d = xi - *mean;
            *var = (*var * nd + d * d) * inv;
        }
        self.normalise_input(x);
        self.pack.invalidate();
        // The distances to every RF (of every output) before any moves,
        // four fields at a time; an update of one RF changes no other RF.
        // Compiled for the best instruction set this CPU has (run-time
        // dispatch); every path does the same operations in the same order.
        dispatch(Update {
            lwpr: self,
            x,
            y,
            yp,
        });
        Ok(())
    }

    /// Predicts all outputs at `x`, using RFs activated above `cutoff` (the
    /// reference uses 0.001).
    pub fn predict(&mut self, x: &[f64], cutoff: f64) -> Result<Vec<f64>> {
        let mut y = vec![0.0; self.cfg.n_out];
        self.predict_into(x, cutoff, &mut y)?;
        Ok(y)
    }

    /// As [`Lwpr::predict`], writing into `y`. Takes `&mut self` only for the
    /// scratch buffers.
    pub fn predict_into(&mut self, x: &[f64], cutoff: f64, y: &mut [f64]) -> Result<()> {
        self.check_input(x)?;
        check_cutoff(cutoff)?;
        if y.len() != self.cfg.n_out {
            return Err(AffineError::DimensionMismatch {
                what: "LWPR prediction buffer",
                expected: self.cfg.n_out,
                got: y.len(),
            });
        }
        self.normalise_input(x);
        // Per output, the trustworthy RFs activated above the cutoff, in
        // field order (an untrustworthy RF is skipped before its activation
        // is computed), compiled for the best instruction set this CPU has.
        self.sums.fill((0.0, 0.0));
        dispatch(Predict {
            lwpr: self,
            x,
            cutoff,
        });
        for ((yd, &(sum_w, mut yp)), norm) in y.iter_mut().zip(&self.sums).zip(&self.cfg.norm_out) {
            if sum_w > 0.0 {
                yp /= sum_w;
            }
            *yd = yp * norm;
        }
        check_finite("LWPR prediction (inputs or model beyond its range)", y)?;
        Ok(())
    }

    /// Predicts all outputs with confidence bounds and maximal activations.
    pub fn predict_conf(&mut self, x: &[f64], cutoff: f64) -> Result<Prediction> {
        self.check_input(x)?;
        check_cutoff(cutoff)?;
        self.normalise_input(x);
        let xn: &[f64] = if self.unit_norm_in { x } else { &self.xn };
        let n_out = self.cfg.n_out;
        let mut out = Prediction {
            y: vec![0.0; n_out],
            conf: vec![0.0; n_out],
            max_w: vec![0.0; n_out],
        };
        for dim in 0..n_out {
            let mut sum_w = 0.0;
            let mut sum_wy = 0.0;
            let mut sum_wyy = 0.0;
            let mut sum_conf = 0.0;
            let mut w_max: f64 = 0.0;
            for rf in &self.subs[dim].rfs {
                let w = rf.activation(&self.cfg, xn, &mut self.ws);
                w_max = w_max.max(w);
                if w > cutoff && rf.trustworthy() {
                    let mut s2 = 0.0;
                    let yk = rf.predict_local(&self.cfg, xn, &mut self.ws, Some(&mut s2));
                    let sigma2 = rf.local_variance(w, s2);
                    sum_wyy += w * yk * yk;
                    sum_conf += w * sigma2;
                    sum_wy += w * yk;
                    sum_w += w;
                }
            }
            let norm = self.cfg.norm_out[dim];
            if sum_w > 0.0 {
                let yp = sum_wy / sum_w;
                out.y[dim] = yp * norm;
                out.conf[dim] = norm * (sum_conf + sum_wyy - sum_wy * yp).abs().sqrt() / sum_w;
                check_finite(
                    "LWPR prediction and confidence (inputs or model beyond its range)",
                    &[out.y[dim], out.conf[dim]],
                )?;
            } else {
                out.conf[dim] = f64::INFINITY;
            }
            out.max_w[dim] = w_max;
        }
        Ok(out)
    }
}

/// The body of [`Lwpr::update_into`] after the checks and the input
/// statistics, as a dispatched kernel.
struct Update<'a> {
    lwpr: &'a mut Lwpr,
    x: &'a [f64],
    y: &'a [f64],
    yp: &'a mut [f64],
}

impl simd::Kernel for Update<'_> {
    type Output = ();
    /// AVX2 at most: measured slower with AVX-512 (see
    /// [`simd::Kernel::WIDEST`]).
    const WIDEST: simd::SimdLevel = simd::SimdLevel::Avx2;
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        self.lwpr.update_inline(self.x, self.y, self.yp);
    }
}

/// The weighted sums of [`Lwpr::predict_into`], as a dispatched kernel.
struct Predict<'a> {
    lwpr: &'a mut Lwpr,
    x: &'a [f64],
    cutoff: f64,
}

impl simd::Kernel for Predict<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        self.lwpr.predict_inline(self.x, self.cutoff);
    }
}

impl Lwpr {
    /// [`Update`]'s body: the distances to every RF (diagonal metrics),
    /// then each output's update, its prediction into `yp`.
    #[inline(always)]
    fn update_inline(&mut self, x: &[f64], y: &[f64], yp: &mut [f64]) {
        let xn: &[f64] = if self.unit_norm_in { x } else { &self.xn };
        self.q.clear();
        if self.cfg.diag_only {
            let mut rfs = self.subs.iter().flat_map(|s| s.rfs.iter());
            loop {
                match (rfs.next(), rfs.next(), rfs.next(), rfs.next()) {
                    (Some(a), Some(b), Some(c), Some(d)) => {
                        self.q
                            .extend(distances4(xn, [a, b, c, d], &mut self.ws.terms));
                    }
                    (a, b, c, _) => {
                        for rf in [a, b, c].into_iter().flatten() {
                            self.q.push(rf.distance(xn, &mut self.ws));
                        }
                        break;
                    }
                }
            }
        }
        let mut first = 0;
        for dim in 0..self.cfg.n_out {
            let yn = y[dim] / self.cfg.norm_out[dim];
            let n_rfs = self.subs[dim].rfs.len();
            let q = self.q.get(first..first + n_rfs);
            first += n_rfs;
            let p = update_one(
                &self.cfg,
                &self.init_m,
                &mut self.subs[dim],
                &mut self.ws,
                xn,
                yn,
                q,
            );
            yp[dim] = p * self.cfg.norm_out[dim];
        }
    }

    /// [`Predict`]'s body: the activated trustworthy RFs' weights and
    /// weighted local predictions, summed per output into `self.sums`.
    #[inline(always)]
    fn predict_inline(&mut self, x: &[f64], cutoff: f64) {
        let xn: &[f64] = if self.unit_norm_in { x } else { &self.xn };
        let kernel = self.cfg.kernel;
        if self.cfg.diag_only {
            self.active.clear();
            for (&(dim, k), &q) in self.pack.distances(&self.subs, kernel, xn, cutoff) {
                let w = weight(kernel, q);
                if w > cutoff {
                    self.active.push((dim, k, w));
                }
            }
            // The local predictions two fields at a time, added in
            // field order.
            for pair in self.active.chunks(2) {
                let (da, ka, wa) = pair[0];
                let a = &self.subs[da].rfs[ka];
                let (ya, b) = match pair.get(1) {
                    Some(&(db, kb, wb)) => {
                        let b = &self.subs[db].rfs[kb];
                        let (ya, yb) = ReceptiveField::predict_local_pair(a, b, xn, &mut self.ws);
                        (ya, Some((db, wb, yb)))
                    }
                    None => (a.predict_local(&self.cfg, xn, &mut self.ws, None), None),
                };
                for (dim, w, yk) in std::iter::once((da, wa, ya)).chain(b) {
                    let (sum_w, yp) = &mut self.sums[dim];
                    *yp += w * yk;
                    *sum_w += w;
                }
            }
        } else {
            for (sub, (sum_w, yp)) in self.subs.iter().zip(self.sums.iter_mut()) {
                for rf in sub.rfs.iter().filter(|rf| rf.trustworthy()) {
                    let w = rf.activation(&self.cfg, xn, &mut self.ws);
                    if w > cutoff {
                        *yp += w * rf.predict_local(&self.cfg, xn, &mut self.ws, None);
                        *sum_w += w;
                    }
                }
            }
        }
    }
}

/// The largest normalised input or target magnitude: the receptive
/// fields keep sums of squares and cross-products, which overflow (and
/// turn the model's predictions into NaN for good) for values near 1e154.
const MAX_MAGNITUDE: f64 = 1e100;

/// Checks that `|v_i / norm_i| <= MAX_MAGNITUDE`.
fn check_magnitude(what: &'static str, v: &[f64], norm: &[f64]) -> Result<()> {
    match v
        .iter()
        .zip(norm)
        .find(|(x, n)| (*x / *n).abs() > MAX_MAGNITUDE)
    {
        Some((&value, _)) => Err(AffineError::InvalidParameter {
            name: what,
            value,
            reason: "normalised magnitude above 1e100: the receptive fields' sums of squares would overflow",
        }),
        None => Ok(()),
    }
}

/// An activation cutoff is a number in `[0, 1)` (activations lie in
/// `[0, 1]`): a NaN cutoff activated nothing, and the prediction was a
/// silent 0.
fn check_cutoff(cutoff: f64) -> Result<()> {
    if !(0.0..1.0).contains(&cutoff) {
        return Err(AffineError::InvalidParameter {
            name: "activation cutoff",
            value: cutoff,
            reason: "must lie in [0, 1)",
        });
    }
    Ok(())
}

/// One update of output `dim` (the reference's `lwpr_aux_update_one`):
/// returns the prediction made from the trustworthy RFs during the update.
/// `q`: the RFs' squared distances to `xn`, when computed beforehand.
#[inline(always)]
fn update_one(
    cfg: &LwprConfig,
    init_m: &[f64],
    sub: &mut SubModel,
    ws: &mut Workspace,
    xn: &[f64],
    yn: f64,
    q: Option<&[f64]>,
) -> f64 {
    let mut w_max = 0.0;
    let mut w_sec = 0.0;
    let mut ind_max: Option<usize> = None;
    let mut ind_sec: Option<usize> = None;
    let mut yp = 0.0;
    let mut sum_w = 0.0;
    for (n, rf) in sub.rfs.iter_mut().enumerate() {
        let (w, dwdq, ddwdqdq) = match q {
            Some(q) => derivs(cfg.kernel, q[n]),
            None => rf.activation_derivs(cfg, xn, ws),
        };
        if w > w_sec {
            if w > w_max {
                ind_sec = ind_max;
                w_sec = w_max;
                ind_max = Some(n);
                w_max = w;
            } else {
                ind_sec = Some(n);
                w_sec = w;
            }
        }
        if w > 0.001 {
            if let Some(yp_n) = rf.update(cfg, xn, yn, w, dwdq, ddwdqdq, ws) {
                yp += w * yp_n;
                sum_w += w;
            }
        } else {
            rf.set_w(0.0);
        }
    }
    let pred = if sum_w > 0.0 { yp / sum_w } else { 0.0 };

    if w_max <= cfg.w_gen {
        let template = match ind_max {
            Some(i) if w_max > 0.1 * cfg.w_gen && sub.rfs[i].trustworthy() => Some(&sub.rfs[i]),
            _ => None,
        };
        let rf = ReceptiveField::new(cfg, init_m, template, xn, yn);
        sub.rfs.push(rf);
        return pred;
    }
    if w_sec > cfg.w_prune
        && let (Some(imax), Some(isec)) = (ind_max, ind_sec)
    {
        // The reference library removes the RF whose D has the smaller trace
        // (its documentation says the larger; with the default w_prune = 1 it
        // never fires for Gaussian kernels). We follow the paper (and the
        // library's MATLAB code): remove the one with the larger trace, the
        // narrower one, which adds less coverage.
        let tr_max = sub.rfs[imax].trace_d(cfg);
        let tr_sec = sub.rfs[isec].trace_d(cfg);
        let prune = if tr_max > tr_sec { imax } else { isec };
        sub.rfs.swap_remove(prune);
        sub.n_pruned += 1;
    }
    pred
}

#[cfg(test)]
mod tests;
