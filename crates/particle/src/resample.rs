//! Resampling: draw `M` ancestor indices with probabilities proportional to
//! the weights. All four schemes are O(N + M) and unbiased: the expected
//! number of copies of particle `i` is `M w_i`.
//!
//! - multinomial: `M` independent draws (sorted uniforms from exponential
//!   spacings, then one pass over the cumulative weights; Bócsi and Csató (paper 001)
//!   footnote 2, Lee, Jo and Kang's (paper 003) "roulette wheel");
//! - residual: `floor(M w_i)` copies, the remainder multinomial on the
//!   residual weights (Liu and Chen 1998; Nagy, Ahmed and Zayed (paper 000) uses it);
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

/// The smallest weight total resampled as given: the points
/// `(u + j) total / M` stay normal floats (full precision) for any `M` up
/// to `2^64`. Smaller totals are resampled as the ratios to the largest
/// weight.
const MIN_TOTAL: f64 = 1e-280;

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

/// Cumulative weights kept chunk by chunk, so that one parallel pass can
/// build them and resampling can start anywhere. Each chunk has its own
/// scale (its weights are relative to its own largest one): `cum[i]` is the
/// running sum of the weights of `i`'s chunk up to `i` (inclusive) on that
/// chunk's scale, `scale[c]` the factor onto the common scale, `prefix[c]`
/// the total of the chunks before chunk `c` on the common scale (`prefix[0]
/// = 0`, one entry per chunk plus the grand total,
/// `prefix[c + 1] = prefix[c] + scale[c] cum[last of c]`), all summed in
/// particle order. Particle `i` of chunk `c` owns the points in
/// `[B_{i-1}, B_i)`, `B_i = prefix[c] + scale[c] cum[i]`; the last `B` of a
/// chunk is the next chunk's prefix, so the `B_i` never decrease and each
/// point has one owner, whichever range of points a task walks. With a
/// single chunk of scale 1 `B_i` is the running sum of [`walk`].
pub(crate) struct ChunkedCumulative<'a> {
    cum: &'a [f64],
    scale: &'a [f64],
    prefix: &'a [f64],
    chunk: usize,
    /// The last particle that owns points: points at or beyond the total
    /// (round-off) are its.
    last: usize,
}

impl<'a> ChunkedCumulative<'a> {
    /// The running sums `cum` in chunks of `chunk` particles, with their
    /// scales and prefixes (see the type); the total `prefix[last]` must be
    /// positive.
    pub(crate) fn new(cum: &'a [f64], scale: &'a [f64], prefix: &'a [f64], chunk: usize) -> Self {
        let mut c = Self {
            cum,
            scale,
            prefix,
            chunk,
            last: 0,
        };
        // the last chunk that adds to the total, and in it the last bound
        // above its predecessor
        if let Some(k) = (0..scale.len()).rev().find(|&k| prefix[k + 1] > prefix[k]) {
            let start = k * chunk;
            c.last = (start + 1..c.chunk_end(k))
                .rev()
                .find(|&i| c.bound(k, i) > c.bound(k, i - 1))
                .unwrap_or(start);
        }
        c
    }

    /// `B_i` for particle `i` of chunk `c`.
    #[inline(always)]
    fn bound(&self, c: usize, i: usize) -> f64 {
        self.prefix[c] + self.scale[c] * self.cum[i]
    }

    /// The owner of point `p >= 0`: the first particle with `B_i > p`, or
    /// `last` when there is none.
    fn owner(&self, p: f64) -> usize {
        let c = self.prefix[1..].partition_point(|&b| b <= p);
        if c + 1 == self.prefix.len() {
            return self.last;
        }
        let (start, end) = (c * self.chunk, self.chunk_end(c));
        let (base, scale) = (self.prefix[c], self.scale[c]);
        let k = self.cum[start..end].partition_point(|&l| base + scale * l <= p);
        (start + k).min(self.last)
    }

    /// One past the last particle of chunk `c`.
    fn chunk_end(&self, c: usize) -> usize {
        ((c + 1) * self.chunk).min(self.cum.len())
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
        let mut end = self.chunk_end(c);
        let (mut base, mut scale, mut next) = (self.prefix[c], self.scale[c], self.prefix[c + 1]);
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
                (base, scale, next) = (self.prefix[c], self.scale[c], self.prefix[c + 1]);
                i = c * self.chunk;
                end = self.chunk_end(c);
            }
            // ends inside chunk c: its last bound is `next > p`. The bounds
            // never decrease (sums of non-negative weights, and rounding is
            // monotone), so when the eighth one ahead is still `<= p` the
            // seven before it are too: runs of negligible weights are
            // crossed eight at a time, with the same result
            while base + scale * self.cum[i] <= p {
                i += 1;
                while i + 8 <= end && base + scale * self.cum[i + 7] <= p {
                    i += 8;
                }
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
        if (MIN_TOTAL..f64::INFINITY).contains(&total) {
            self.resample_checked(weights, total, rng, ancestors);
        } else {
            // finite weights whose sum overflows (1e308 each), or so small
            // that the points `total j / M` round to a few values (5e-324
            // each: every point was 0, every draw particle 0): relative to
            // the largest they sum to between 1 and N
            let max = weights.iter().copied().fold(0.0, f64::max);
            let scaled: Vec<f64> = weights.iter().map(|&w| w / max).collect();
            let total = scaled.iter().sum();
            self.resample_checked(&scaled, total, rng, ancestors);
        }
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
    fn weights_whose_sum_overflows_are_resampled_as_their_ratios() {
        // 1e308 each: the total overflowed to infinity and every point
        // landed on one particle
        let mut rng = stream_rng(&[2]);
        let mut a = [0usize; 1000];
        for scheme in Resampling::ALL {
            scheme
                .resample(&[1e308, 1e308, 0.0, 1e308], &mut rng, &mut a)
                .unwrap();
            let mut counts = [0usize; 4];
            a.iter().for_each(|&i| counts[i] += 1);
            assert_eq!(counts[2], 0, "{scheme:?}");
            for i in [0, 1, 3] {
                assert!(
                    (counts[i] as f64 - 1000.0 / 3.0).abs() < 60.0,
                    "{scheme:?}: {counts:?}"
                );
            }
        }
    }

    #[test]
    fn subnormal_weights_are_resampled_as_their_ratios() {
        // issue 28: weights of 5e-324 summed to a subnormal total whose
        // points all rounded to 0: every draw went to particle 0
        let mut rng = stream_rng(&[3]);
        let mut a = [0usize; 1000];
        let tiny = 5e-324;
        for scheme in Resampling::ALL {
            scheme
                .resample(&[tiny, tiny, 0.0, tiny, tiny], &mut rng, &mut a)
                .unwrap();
            let mut counts = [0usize; 5];
            a.iter().for_each(|&i| counts[i] += 1);
            assert_eq!(counts[2], 0, "{scheme:?}");
            for i in [0, 1, 3, 4] {
                assert!(
                    (counts[i] as f64 - 250.0).abs() < 60.0,
                    "{scheme:?}: {counts:?}"
                );
            }
        }
    }

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

    /// The running sums, scales and prefixes of the filter step, each
    /// chunk's weights divided by `2^e` (exact) with `e` of the chunk from
    /// `exponents` (cycled), its scale `2^e`.
    fn chunked(weights: &[f64], chunk: usize, exponents: &[i32]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut cum = Vec::with_capacity(weights.len());
        let mut scale = Vec::new();
        let mut prefix = vec![0.0];
        for (k, c) in weights.chunks(chunk).enumerate() {
            let f = 2f64.powi(exponents[k % exponents.len()]);
            let mut s = 0.0;
            for &w in c {
                s += w / f;
                cum.push(s);
            }
            scale.push(f);
            prefix.push(prefix[prefix.len() - 1] + f * s);
        }
        (cum, scale, prefix)
    }

    fn chunked_systematic(
        weights: &[f64],
        chunk: usize,
        exponents: &[i32],
        u: f64,
        task: usize,
    ) -> Vec<usize> {
        let (cum, scale, prefix) = chunked(weights, chunk, exponents);
        let c = ChunkedCumulative::new(&cum, &scale, &prefix, chunk);
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
            let whole = chunked_systematic(&w, w.len(), &[0], u, w.len());
            // one chunk: the running sums of `walk`
            let mut seq = vec![0; w.len()];
            let step = w.iter().sum::<f64>() / w.len() as f64;
            walk(&w, &mut seq, |j| u * step + j as f64 * step);
            assert_eq!(whole, seq, "u = {u}");
            for chunk in [1, 7, 64, 256] {
                let first = chunked_systematic(&w, chunk, &[0], u, w.len());
                // the same draws (no round-off crossing here), whatever
                // the output ranges the tasks walk
                assert_eq!(first, seq, "chunk {chunk}, u = {u}");
                for task in [1, 3, 64, 999] {
                    assert_eq!(chunked_systematic(&w, chunk, &[0], u, task), first);
                }
                // chunks on scales of their own (powers of two: the same
                // bounds), whatever the tasks
                for task in [1, 64, 999] {
                    let scaled = chunked_systematic(&w, chunk, &[3, -40, 0, 700], u, task);
                    assert_eq!(scaled, first, "chunk {chunk}, u = {u}, task {task}");
                }
            }
        }
    }

    #[test]
    fn chunked_systematic_points_beyond_the_total_go_to_the_last_owner() {
        let w = [0.1, 0.2, 0.3, 0.0, 0.0];
        let (cum, scale, prefix) = chunked(&w, 2, &[0, 5]);
        let c = ChunkedCumulative::new(&cum, &scale, &prefix, 2);
        let mut a = [0; 3];
        c.systematic(0.5, 0.1, 0, &mut a);
        assert_eq!(a, [2, 2, 2]);
        c.systematic(0.0, 0.25, 0, &mut a);
        assert_eq!(a, [0, 1, 2]);
        // a weight too small to move the running sum owns no point: the
        // last owner is the one before it
        let w = [0.5, 1.0, 1e-30, 0.0];
        let (cum, scale, prefix) = chunked(&w, 4, &[0]);
        let c = ChunkedCumulative::new(&cum, &scale, &prefix, 4);
        c.systematic(1.5, 0.1, 0, &mut a);
        assert_eq!(a, [1, 1, 1]);
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
