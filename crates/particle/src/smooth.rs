//! Particle smoothing: forward-filtering backward-simulation (Godsill,
//! Doucet and West 2004, "Monte Carlo smoothing for nonlinear time
//! series", JASA 99, sec. 4, Algorithm 1) and the fixed-lag smoother of
//! the particles' genealogy (Kitagawa 1996; Doucet and Johansen 2011, sec.
//! 5.1).

use nalgebra::SVector;
use rand::RngExt;

use crate::chunks::{check_chunk_size, for_chunks};
use crate::error::{ParticleError, Result};
use crate::filter::StepReport;
use crate::proposal::TransitionDensity;
use crate::set::{Particle, ParticleSet, exp_flushed};

/// The most bytes of paths one [`ffbs`] call returns: 1 GiB.
pub const FFBS_MAX_BYTES: usize = 1 << 30;

/// Forward-filtering backward-simulation (Godsill, Doucet and West 2004,
/// sec. 4, Algorithm 1): draws `trajectories` paths from
/// the joint smoothing distribution `p(x_{0:T} | z_{1:T})` given the
/// filtering sets `history` (the set after each step, oldest first; the
/// first may be the initial set at `k = 0`). Each path starts from a
/// particle of the last set drawn by its weight, and steps back with
/// weights `w_{t,i} p(x_{t+1} | x_{t,i})` ([`TransitionDensity`] at the
/// time index of the later set).
///
/// Returns the paths, `paths[j][t]` the state of path `j` at `history[t]`.
/// Cost: `O(trajectories x N x T)` transition densities. The paths are
/// drawn `chunk_size` at a time, each chunk from its own stream keyed by
/// `key`: the same bits on any number of threads. The marginal means of
/// the paths ([`path_means`]) estimate the smoothed means `E[x_t | z_{1:T}]`.
///
/// The paths are kept in memory: at most [`FFBS_MAX_BYTES`] of states
/// (`trajectories x history.len()` of them; draw more in several calls
/// with different keys).
///
/// # Errors
/// [`ParticleError::Empty`] for no sets or no trajectories,
/// [`ParticleError::TooLarge`] past [`FFBS_MAX_BYTES`],
/// [`ParticleError::InvalidParameter`] for a zero chunk size,
/// [`ParticleError::NonFiniteWeight`] for a NaN or `+inf` backward log
/// weight, [`ParticleError::AllWeightsZero`] when no particle of a set can
/// reach the path's next state.
pub fn ffbs<M, const N: usize>(
    history: &[ParticleSet<SVector<f64, N>>],
    model: &M,
    trajectories: usize,
    chunk_size: usize,
    key: &[u64],
) -> Result<Vec<Vec<SVector<f64, N>>>>
where
    M: TransitionDensity<N>,
{
    check_chunk_size(chunk_size)?;
    let last = history.last().ok_or(ParticleError::Empty)?;
    if trajectories == 0 {
        return Err(ParticleError::Empty);
    }
    let t_len = history.len();
    let state = std::mem::size_of::<SVector<f64, N>>().max(1);
    let limit = FFBS_MAX_BYTES / state;
    let states = trajectories.saturating_mul(t_len);
    if states > limit {
        return Err(ParticleError::TooLarge {
            what: "ffbs trajectories x steps",
            requested: states,
            limit,
        });
    }
    let mut paths = vec![vec![SVector::<f64, N>::zeros(); t_len]; trajectories];
    let mut unused = vec![(); trajectories];
    for_chunks(chunk_size, &mut paths, &mut unused, key, |_, ps, _, rng| {
        let mut logs = Vec::new();
        for path in ps.iter_mut() {
            let i = draw(last.log_weights(), rng.random::<f64>())?;
            path[t_len - 1] = last.particles()[i];
            for t in (0..t_len - 1).rev() {
                let set = &history[t];
                let next = path[t + 1];
                let k = history[t + 1].k();
                logs.clear();
                for (x, &l) in set.particles().iter().zip(set.log_weights()) {
                    logs.push(l + model.log_transition(k, x, &next));
                }
                let i = draw(&logs, rng.random::<f64>())?;
                path[t] = set.particles()[i];
            }
        }
        Ok(())
    })?;
    Ok(paths)
}

/// The index drawn with probability proportional to `exp(logs)` for the
/// uniform `u`.
fn draw(logs: &[f64], u: f64) -> Result<usize> {
    let mut max = f64::NEG_INFINITY;
    for (index, &l) in logs.iter().enumerate() {
        if l.is_nan() || l == f64::INFINITY {
            return Err(ParticleError::NonFiniteWeight { index, value: l });
        }
        max = max.max(l);
    }
    if max == f64::NEG_INFINITY {
        return Err(ParticleError::AllWeightsZero { count: logs.len() });
    }
    let sum: f64 = logs.iter().map(|&l| exp_flushed(l - max)).sum();
    let target = u * sum;
    let mut acc = 0.0;
    let mut chosen = 0;
    for (i, &l) in logs.iter().enumerate() {
        let w = exp_flushed(l - max);
        if w > 0.0 {
            chosen = i;
            acc += w;
            if acc > target {
                break;
            }
        }
    }
    Ok(chosen)
}

/// The mean over paths at each time: `out[t] = mean_j paths[j][t]`.
///
/// # Errors
/// [`ParticleError::Empty`] for no paths,
/// [`ParticleError::LengthMismatch`] when a path's length (`weights`)
/// differs from the first's (`particles`),
/// [`ParticleError::NonFiniteState`] naming the first path with a
/// non-finite state.
pub fn path_means<const N: usize>(paths: &[Vec<SVector<f64, N>>]) -> Result<Vec<SVector<f64, N>>> {
    let first = paths.first().ok_or(ParticleError::Empty)?;
    let mut out = vec![SVector::<f64, N>::zeros(); first.len()];
    for (j, p) in paths.iter().enumerate() {
        if p.len() != first.len() {
            return Err(ParticleError::LengthMismatch {
                particles: first.len(),
                weights: p.len(),
            });
        }
        if !p.iter().all(|x| x.iter().all(|v| v.is_finite())) {
            return Err(ParticleError::NonFiniteState { index: j });
        }
    }
    for (t, o) in out.iter_mut().enumerate() {
        *o = bounded_mean(paths.iter().map(|p| &p[t]));
    }
    Ok(out)
}

/// The mean of finite vectors, finite at any magnitude: per component,
/// the values over their largest magnitude are summed (each partial sum
/// of `k` terms at most `k`), so the mean is within the values' range
/// and never rounds past `f64::MAX`. Zero for no vectors.
pub(crate) fn bounded_mean<'a, const N: usize>(
    xs: impl Iterator<Item = &'a SVector<f64, N>> + Clone,
) -> SVector<f64, N> {
    let scale = xs.clone().fold(SVector::<f64, N>::zeros(), |m, x| {
        m.zip_map(x, |a, b| a.max(b.abs()))
    });
    let (mut sum, mut n) = (SVector::<f64, N>::zeros(), 0usize);
    for x in xs {
        n += 1;
        for c in 0..N {
            if scale[c] > 0.0 {
                sum[c] += x[c] / scale[c];
            }
        }
    }
    if n == 0 {
        return sum;
    }
    SVector::<f64, N>::from_fn(|c, _| sum[c] / n as f64 * scale[c])
}

/// Fixed-lag smoothing by the particles' genealogy: each particle keeps
/// the last `lag + 1` states of its ancestral line, and the weighted mean
/// of the oldest estimates `E[x_{k-lag} | z_{1:k}]`. Record the set after
/// every step ([`crate::ParticleFilter::step`] or
/// [`crate::AuxiliaryFilter::step`]) with its report: where the step
/// resampled, the lines follow the drawn ancestors. Cost `O(N lag)` memory
/// and copying per step; lags beyond a few times the filter's
/// decorrelation time see the lines collapse onto few ancestors (path
/// degeneracy), where [`ffbs`] does better.
#[derive(Debug, Clone)]
pub struct FixedLag<const N: usize> {
    lag: usize,
    lines: Vec<Vec<SVector<f64, N>>>,
}

impl<const N: usize> FixedLag<N> {
    /// A smoother of lag `lag` (0 is the filter).
    pub fn new(lag: usize) -> Self {
        Self {
            lag,
            lines: Vec::new(),
        }
    }

    /// Takes in the set after a step (or the initial set, with no report).
    ///
    /// # Errors
    /// [`ParticleError::LengthMismatch`] when the set's size changed since
    /// the last record, or when `report` says the step resampled but the
    /// set holds no ancestors for each of its particles (a report of
    /// another set).
    pub fn record<T: Particle<N>>(
        &mut self,
        set: &ParticleSet<T>,
        report: Option<&StepReport<N>>,
    ) -> Result<()> {
        let n = set.len();
        if self.lines.is_empty() {
            self.lines = set.particles().iter().map(|p| vec![*p.state()]).collect();
            return Ok(());
        }
        if self.lines.len() != n {
            return Err(ParticleError::LengthMismatch {
                particles: n,
                weights: self.lines.len(),
            });
        }
        if report.is_some_and(|r| r.resampled) {
            let anc = &set.scratch.ancestors;
            if anc.len() != n || anc.iter().any(|&a| a >= n) {
                // a report of another set, or of a step that did not
                // leave its ancestors here
                return Err(ParticleError::LengthMismatch {
                    particles: n,
                    weights: anc.len(),
                });
            }
            self.lines = anc.iter().map(|&a| self.lines[a].clone()).collect();
        }
        for (line, p) in self.lines.iter_mut().zip(set.particles()) {
            line.push(*p.state());
            if line.len() > self.lag.saturating_add(1) {
                line.remove(0);
            }
        }
        Ok(())
    }

    /// `E[x_{k-lag} | z_{1:k}]` under the weights of `set` (the set last
    /// recorded); `None` before `lag` steps have been recorded.
    pub fn estimate<T: Particle<N>>(&self, set: &ParticleSet<T>) -> Option<SVector<f64, N>> {
        if self.lines.len() != set.len() || self.lines.first()?.len() != self.lag.saturating_add(1)
        {
            return None;
        }
        let mut m = SVector::<f64, N>::zeros();
        for (line, &l) in self.lines.iter().zip(set.log_weights()) {
            m.axpy(l.exp(), &line[0], 1.0);
        }
        Some(m)
    }
}
