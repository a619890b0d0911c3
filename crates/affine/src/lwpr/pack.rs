//! The trustworthy receptive fields' centres and diagonal metrics,
//! interleaved in groups of [`LANES`] fields, so that one pass over the
//! input computes the squared distances of a whole group with vector
//! arithmetic.
//!
//! Each lane sums `d_i (x_i - c_i)^2` in index order, exactly as
//! [`super::rf::ReceptiveField::distance`] does for one field, so the
//! distances (and activations) are identical bit for bit; the speed comes
//! from running the lanes' independent sums side by side instead of one
//! latency-bound sum after another. A group stops early, every
//! [`BLOCK`] inputs, once all its fields' partial sums exceed the distance
//! beyond which the activation is certainly below the prediction cutoff:
//! the terms are non-negative, so a partial sum never exceeds the full one.

use super::{Kernel, SubModel};

/// Fields per group.
pub(super) const LANES: usize = 8;

/// Inputs between two early-stop checks.
const BLOCK: usize = 64;

/// The packed copy of the trustworthy fields' centres and metrics (diagonal
/// metrics only); rebuilt after the model changes.
#[derive(Debug, Clone, Default)]
pub(super) struct ActivationPack {
    fresh: bool,
    /// (output, field index) per lane, by output, then field index.
    lanes: Vec<(usize, usize)>,
    /// Centres, group-major: group g, input i, lane l at `(g N + i) L + l`.
    c: Vec<f64>,
    /// Metric diagonals, laid out as `c` (0 in unused lanes).
    d: Vec<f64>,
    /// Squared distance per lane of the last call (infinite when the group
    /// stopped early).
    q: Vec<f64>,
}

impl ActivationPack {
    /// Marks the copy stale (any update may move metrics, add fields or make
    /// them trustworthy).
    pub(super) fn invalidate(&mut self) {
        self.fresh = false;
    }

    fn rebuild(&mut self, subs: &[SubModel], n: usize) {
        self.lanes.clear();
        for (dim, sub) in subs.iter().enumerate() {
            for (k, rf) in sub.rfs.iter().enumerate() {
                if rf.trustworthy() {
                    self.lanes.push((dim, k));
                }
            }
        }
        let groups = self.lanes.len().div_ceil(LANES);
        self.c.clear();
        self.c.resize(groups * n * LANES, 0.0);
        self.d.clear();
        self.d.resize(groups * n * LANES, 0.0);
        for (lane, &(dim, k)) in self.lanes.iter().enumerate() {
            let (g, l) = (lane / LANES, lane % LANES);
            let rf = &subs[dim].rfs[k];
            let base = g * n * LANES + l;
            let c = self.c[base..].iter_mut().step_by(LANES);
            for (dst, src) in c.zip(rf.centre()) {
                *dst = *src;
            }
            let d = self.d[base..].iter_mut().step_by(LANES);
            for (dst, src) in d.zip(rf.metric_diag()) {
                *dst = *src;
            }
        }
        self.q.clear();
        self.q.resize(groups * LANES, 0.0);
        self.fresh = true;
    }

    /// The squared distances of `x` to every trustworthy field, as
    /// `((output, field index), q)` in order of output, then field; `q` is
    /// infinite for fields whose activation is certainly at most `w_stop`
    /// (computed exactly otherwise).
    #[inline(always)]
    pub(super) fn distances(
        &mut self,
        subs: &[SubModel],
        kernel: Kernel,
        x: &[f64],
        w_stop: f64,
    ) -> impl Iterator<Item = (&(usize, usize), &f64)> {
        let n = x.len();
        if !self.fresh {
            self.rebuild(subs, n);
        }
        let q_stop = stop_distance(kernel, w_stop);
        let stride = n * LANES;
        for (g, q) in self.q.chunks_exact_mut(LANES).enumerate() {
            let used = (self.lanes.len() - g * LANES).min(LANES);
            let range = g * stride..(g + 1) * stride;
            group_distances(x, &self.c[range.clone()], &self.d[range], used, q_stop, q);
        }
        self.lanes.iter().zip(&self.q)
    }
}

/// A squared distance beyond which the activation is below `w_stop`, with
/// a margin far above the round-off of the kernel (infinite for
/// `w_stop = 0`).
pub(super) fn stop_distance(kernel: Kernel, w_stop: f64) -> f64 {
    // The margin 1e-6 on q lowers the activation bound by a relative
    // 5e-7 (Gaussian), against round-off of a few 1e-16.
    match kernel {
        Kernel::Gaussian => -2.0 * w_stop.ln() + 1e-6,
        Kernel::BiSquare => 4.0 * (1.0 - w_stop.sqrt()) + 1e-6,
    }
}

/// The squared distances of one group: lane l sums
/// `d[i L + l] (x_i - c[i L + l])^2` over i in order. When every used lane
/// exceeds `q_stop` at a block boundary, all lanes are set to infinity.
#[inline(always)]
fn group_distances(x: &[f64], c: &[f64], d: &[f64], used: usize, q_stop: f64, q: &mut [f64]) {
    let mut acc = [0.0f64; LANES];
    for ((xb, cb), db) in x
        .chunks(BLOCK)
        .zip(c.chunks(BLOCK * LANES))
        .zip(d.chunks(BLOCK * LANES))
    {
        for ((xi, cl), dl) in xb
            .iter()
            .zip(cb.chunks_exact(LANES))
            .zip(db.chunks_exact(LANES))
        {
            for l in 0..LANES {
                let dx = xi - cl[l];
                acc[l] += dl[l] * dx * dx;
            }
        }
        if acc[..used].iter().all(|&a| a > q_stop) {
            q.fill(f64::INFINITY);
            return;
        }
    }
    q.copy_from_slice(&acc);
}
