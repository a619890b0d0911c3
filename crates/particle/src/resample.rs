//! Resampling: draw `M` ancestor indices with probabilities proportional to
//! the weights. All four schemes are O(N + M) and unbiased: the expected
//! number of copies of particle `i` is `M w_i`.
//!
//! - multinomial: `M` independent draws (sorted uniforms from exponential
//!   spacings, then one pass over the cumulative weights; paper 001
//!   footnote 2, paper 003's "roulette wheel");
//! - residual: `floor(M w_i)` copies, the remainder multinomial on the
//!   residual weights (Liu and Chen 1998; paper 000 uses it);
//! - systematic: one uniform `u`, points `(u + j) / M`;
//! - stratified: one uniform per stratum, points `(j + u_j) / M`.
//!
//! Systematic and residual give every particle `floor(M w_i)` or
//! `ceil(M w_i)` copies; stratified and systematic have lower variance than
//! multinomial.

use rand::Rng;
use rand::RngExt;
use rand_distr::{Distribution, Exp1};

use crate::error::{ParticleError, Result};

/// A resampling scheme.
pub trait Resampler {
    /// Fills `ancestors` (its length is the number of draws `M`) with indices
    /// into `weights`, drawn with probabilities proportional to the weights
    /// (which need not be normalised).
    ///
    /// # Errors
    /// [`ParticleError::Empty`] for no weights,
    /// [`ParticleError::NonFiniteWeight`] for a NaN, infinite or negative
    /// weight, [`ParticleError::AllWeightsZero`] when they sum to zero.
    fn resample<R: Rng + ?Sized>(
        &self,
        weights: &[f64],
        rng: &mut R,
        ancestors: &mut [usize],
    ) -> Result<()>;
}

/// The four schemes, chosen at run time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Resampling {
    /// Independent draws.
    Multinomial,
    /// Deterministic integer parts, multinomial remainder.
    Residual,
    /// One uniform offset for evenly spaced points.
    #[default]
    Systematic,
    /// One uniform per stratum.
    Stratified,
}

impl Resampling {
    /// Every scheme, for loops in tests and experiments.
    pub const ALL: [Resampling; 4] = [
        Resampling::Multinomial,
        Resampling::Residual,
        Resampling::Systematic,
        Resampling::Stratified,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Resampling::Multinomial => "multinomial",
            Resampling::Residual => "residual",
            Resampling::Systematic => "systematic",
            Resampling::Stratified => "stratified",
        }
    }
}

/// Checks weights and returns their sum.
pub(crate) fn checked_total(weights: &[f64]) -> Result<f64> {
    if weights.is_empty() {
        return Err(ParticleError::Empty);
    }
    let mut total = 0.0;
    for (index, &w) in weights.iter().enumerate() {
        if !(w >= 0.0 && w.is_finite()) {
            return Err(ParticleError::NonFiniteWeight { index, value: w });
        }
        total += w;
    }
    if total <= 0.0 {
        return Err(ParticleError::AllWeightsZero {
            count: weights.len(),
        });
    }
    Ok(total)
}

/// Walks the cumulative weights once for sorted points `point(j)` in
/// `[0, total)`, writing the index whose cumulative interval holds each.
#[inline]
fn walk(weights: &[f64], ancestors: &mut [usize], mut point: impl FnMut(usize) -> f64) {
    let last = weights.iter().rposition(|&w| w > 0.0).unwrap_or(0);
    let mut i = 0;
    let mut cum = weights[0];
    for (j, a) in ancestors.iter_mut().enumerate() {
        let u = point(j);
        while cum <= u && i < last {
            i += 1;
            cum += weights[i];
        }
        *a = i;
    }
}

/// Cumulative weights kept chunk by chunk, so that a parallel pass can build
/// them and resampling can start anywhere: `cum[i]` is the running sum of the
/// weights of `i`'s chunk up to `i` (inclusive), `prefix[c]` the total of the
/// chunks before chunk `c` (`prefix[0] = 0`, one entry per chunk plus the
/// grand total), both summed in particle order. Particle `i` of chunk `c`
/// owns the points in `[B_{i-1}, B_i)`, `B_i = prefix[c] + cum[i]`; the last
/// `B` of a chunk is the next chunk's prefix, so the `B_i` never decrease and
/// each point has one owner, whichever range of points a task walks. With a
/// single chunk `B_i` is the running sum of [`walk`].
pub(crate) struct ChunkedCumulative<'a> {
    /// Running sums within each chunk.
    pub(crate) cum: &'a [f64],
    /// Chunk totals summed in chunk order, from 0.
    pub(crate) prefix: &'a [f64],
    /// Particles per chunk.
    pub(crate) chunk: usize,
    /// The last particle with a positive weight: points at or beyond the
    /// total (round-off) are its.
    pub(crate) last: usize,
}

impl ChunkedCumulative<'_> {
    /// The owner of point `p >= 0`: the first particle with `B_i > p`, or
    /// `last` when there is none.
    fn owner(&self, p: f64) -> usize {
        let c = self.prefix[1..].partition_point(|&b| b <= p);
        if c + 1 == self.prefix.len() {
            return self.last;
        }
        let start = c * self.chunk;
        let end = (start + self.chunk).min(self.cum.len());
        let base = self.prefix[c];
        let k = self.cum[start..end].partition_point(|&l| base + l <= p);
        (start + k).min(self.last)
    }

    /// Systematic resampling of the output slots `first..first +
    /// ancestors.len()`: the owners of the points `u + j step`.
    pub(crate) fn systematic(&self, u: f64, step: f64, first: usize, ancestors: &mut [usize]) {
        if ancestors.is_empty() {
            return;
        }
        let total = self.prefix[self.prefix.len() - 1];
        // j as a float counter (exact below 2^53): no integer conversion
        let mut j = first as f64;
        let mut i = self.owner(u + j * step);
        let mut c = i / self.chunk;
        let (mut base, mut next) = (self.prefix[c], self.prefix[c + 1]);
        for a in ancestors.iter_mut() {
            let p = u + j * step;
            j += 1.0;
            if p >= next {
                if p >= total {
                    *a = self.last;
                    continue;
                }
                while self.prefix[c + 1] <= p {
                    c += 1;
                }
                (base, next) = (self.prefix[c], self.prefix[c + 1]);
                i = c * self.chunk;
            }
            // ends inside chunk c: its last bound is `next > p`
            while base + self.cum[i] <= p {
                i += 1;
            }
            *a = i;
        }
    }
}

/// Multinomial draws of `ancestors.len()` indices with weights summing to
/// `total`.
fn multinomial<R: Rng + ?Sized>(weights: &[f64], total: f64, rng: &mut R, ancestors: &mut [usize]) {
    let m = ancestors.len();
    if m == 0 {
        return;
    }
    // Sorted uniforms: normalised partial sums of m + 1 exponentials.
    let mut spacings = Vec::with_capacity(m);
    let mut s = 0.0;
    for _ in 0..m {
        let e: f64 = Exp1.sample(rng);
        s += e;
        spacings.push(s);
    }
    let e: f64 = Exp1.sample(rng);
    let scale = total / (s + e);
    walk(weights, ancestors, |j| spacings[j] * scale);
}

impl Resampler for Resampling {
    fn resample<R: Rng + ?Sized>(
        &self,
        weights: &[f64],
        rng: &mut R,
        ancestors: &mut [usize],
    ) -> Result<()> {
        let total = checked_total(weights)?;
        self.resample_checked(weights, total, rng, ancestors);
        Ok(())
    }
}

impl Resampling {
    /// Resampling of weights already known to be finite, non-negative and to
    /// sum to `total > 0` (the filter step has just computed them).
    pub(crate) fn resample_checked<R: Rng + ?Sized>(
        &self,
        weights: &[f64],
        total: f64,
        rng: &mut R,
        ancestors: &mut [usize],
    ) {
        let m = ancestors.len();
        if m == 0 {
            return;
        }
        let step = total / m as f64;
        match self {
            Resampling::Multinomial => multinomial(weights, total, rng, ancestors),
            Resampling::Systematic => {
                let u: f64 = rng.random::<f64>() * step;
                walk(weights, ancestors, |j| u + j as f64 * step);
            }
            Resampling::Stratified => {
                walk(weights, ancestors, |j| {
                    (j as f64 + rng.random::<f64>()) * step
                });
            }
            Resampling::Residual => {
                let mut filled = 0;
                let mut residual = Vec::with_capacity(weights.len());
                for (i, &w) in weights.iter().enumerate() {
                    let expected = w / step;
                    let copies = (expected.floor() as usize).min(m - filled);
                    ancestors[filled..filled + copies].fill(i);
                    filled += copies;
                    residual.push((expected - copies as f64).max(0.0));
                }
                if filled < m {
                    let rest: f64 = residual.iter().sum();
                    if rest > 0.0 {
                        multinomial(&residual, rest, rng, &mut ancestors[filled..]);
                    } else {
                        // round-off left draws without residual mass
                        multinomial(weights, total, rng, &mut ancestors[filled..]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::stream_rng;

    #[test]
    fn degenerate_weight_vectors() {
        let mut rng = stream_rng(&[1]);
        let mut a = [0usize; 4];
        for scheme in Resampling::ALL {
            scheme
                .resample(&[0.0, 0.0, 1.0, 0.0], &mut rng, &mut a)
                .unwrap();
            assert_eq!(a, [2, 2, 2, 2], "{scheme:?}");
            assert_eq!(
                scheme.resample(&[], &mut rng, &mut a),
                Err(ParticleError::Empty)
            );
            assert_eq!(
                scheme.resample(&[0.0, 0.0], &mut rng, &mut a),
                Err(ParticleError::AllWeightsZero { count: 2 })
            );
            assert!(matches!(
                scheme.resample(&[0.5, f64::NAN], &mut rng, &mut a),
                Err(ParticleError::NonFiniteWeight { index: 1, .. })
            ));
            assert!(matches!(
                scheme.resample(&[0.5, -0.1], &mut rng, &mut a),
                Err(ParticleError::NonFiniteWeight { index: 1, .. })
            ));
        }
    }

    /// The running sums and chunk prefixes of the filter step.
    fn chunked(weights: &[f64], chunk: usize) -> (Vec<f64>, Vec<f64>, usize) {
        let mut cum = Vec::with_capacity(weights.len());
        let mut prefix = vec![0.0];
        for c in weights.chunks(chunk) {
            let mut s = 0.0;
            for &w in c {
                s += w;
                cum.push(s);
            }
            prefix.push(prefix[prefix.len() - 1] + s);
        }
        let last = weights.iter().rposition(|&w| w > 0.0).unwrap();
        (cum, prefix, last)
    }

    fn chunked_systematic(weights: &[f64], chunk: usize, u: f64, task: usize) -> Vec<usize> {
        let (cum, prefix, last) = chunked(weights, chunk);
        let c = ChunkedCumulative {
            cum: &cum,
            prefix: &prefix,
            chunk,
            last,
        };
        let step = prefix[prefix.len() - 1] / weights.len() as f64;
        let mut a = vec![usize::MAX; weights.len()];
        for (t, part) in a.chunks_mut(task).enumerate() {
            c.systematic(u * step, step, t * task, part);
        }
        a
    }

    #[test]
    fn chunked_systematic_resampling_is_the_sequential_walk() {
        let mut rng = stream_rng(&[4]);
        // uneven weights with zero runs, a zero chunk and trailing zeros
        let mut w: Vec<f64> = (0..1000)
            .map(|i| {
                let x: f64 = rng.random();
                if i % 7 == 3 || (200..264).contains(&i) || i > 990 {
                    0.0
                } else {
                    x * x * x
                }
            })
            .collect();
        w[5] = 40.0;
        for u in [0.0, 0.37, 1.0 - f64::EPSILON] {
            let whole = chunked_systematic(&w, w.len(), u, w.len());
            // one chunk: the running sums of `walk`
            let mut seq = vec![0; w.len()];
            let step = w.iter().sum::<f64>() / w.len() as f64;
            walk(&w, &mut seq, |j| u * step + j as f64 * step);
            assert_eq!(whole, seq, "u = {u}");
            for chunk in [1, 7, 64, 256] {
                let first = chunked_systematic(&w, chunk, u, w.len());
                // the same draws (no round-off crossing here), whatever
                // the output ranges the tasks walk
                assert_eq!(first, seq, "chunk {chunk}, u = {u}");
                for task in [1, 3, 64, 999] {
                    assert_eq!(chunked_systematic(&w, chunk, u, task), first);
                }
            }
        }
    }

    #[test]
    fn chunked_systematic_points_beyond_the_total_go_to_the_last_weight() {
        let w = [0.1, 0.2, 0.3, 0.0, 0.0];
        let (cum, prefix, last) = chunked(&w, 2);
        let c = ChunkedCumulative {
            cum: &cum,
            prefix: &prefix,
            chunk: 2,
            last,
        };
        let mut a = [0; 3];
        c.systematic(0.5, 0.1, 0, &mut a);
        assert_eq!(a, [2, 2, 2]);
        c.systematic(0.0, 0.25, 0, &mut a);
        assert_eq!(a, [0, 1, 2]);
    }

    #[test]
    fn output_size_may_differ_from_input_size() {
        let mut rng = stream_rng(&[2]);
        let mut a = [0usize; 7];
        for scheme in Resampling::ALL {
            scheme.resample(&[1.0, 3.0], &mut rng, &mut a).unwrap();
            assert!(a.iter().all(|&i| i < 2));
            assert!(a.windows(2).all(|w| w[0] <= w[1]) || scheme == Resampling::Residual);
        }
    }
}
