//! How much to trust a correlation response: the peak-to-sidelobe ratio
//! (Bolme et al. 2010, MOSSE) and the average peak-to-correlation energy
//! (Wang, Liu and Huang 2017, LMCF).

use bayestrack_image::simd::{Kernel, Token, dispatch};

/// Side of the window around the peak that the PSR leaves out of the
/// sidelobe (MOSSE's 11x11).
pub const PSR_EXCLUDE: usize = 11;

/// The maximum of `response` and its index (the first on ties; NaN never
/// wins; `(-inf, 0)` when nothing exceeds -inf).
///
/// The maximum from `Range`'s lanes, then the first value equal to it:
/// the first index at which a running `v > best` would have stopped
/// moving, and its value (`+0` and `-0` are equal, so the first zero of
/// either sign, as the running test keeps it).
pub fn peak(response: &[f32]) -> (f32, usize) {
    let (max, _) = dispatch(Range(response));
    if max == f32::NEG_INFINITY {
        return (max, 0);
    }
    let (chunks, _) = response.as_chunks::<RANGE_LANES>();
    // whole chunks branch-free (one vector compare each), then the values
    let start = chunks
        .iter()
        .position(|c| c.iter().fold(false, |a, &v| a | (v == max)))
        .map_or(chunks.len() * RANGE_LANES, |k| k * RANGE_LANES);
    let i = start
        + response[start..]
            .iter()
            .position(|&v| v == max)
            .unwrap_or(0);
    (response[i], i)
}

/// Values of [`Range`] taken at once (one AVX2 vector of `f32`).
const RANGE_LANES: usize = 8;

/// The largest and the smallest value of a slice (NaN never chosen;
/// `(-inf, +inf)` when there is no other): [`RANGE_LANES`] running
/// maxima and minima side by side (`if v > m { v } else { m }`), then
/// across the lanes. The same values as one running maximum and minimum,
/// in whatever order (but the sign of a zero extreme, which neither
/// [`peak`] nor [`apce`] lets through).
struct Range<'a>(&'a [f32]);

impl Kernel for Range<'_> {
    type Output = (f32, f32);
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> (f32, f32) {
        let up = |m: f32, v: f32| if v > m { v } else { m };
        let down = |m: f32, v: f32| if v < m { v } else { m };
        let mut hi = [f32::NEG_INFINITY; RANGE_LANES];
        let mut lo = [f32::INFINITY; RANGE_LANES];
        let (chunks, tail) = self.0.as_chunks::<RANGE_LANES>();
        for c in chunks {
            for k in 0..RANGE_LANES {
                hi[k] = up(hi[k], c[k]);
                lo[k] = down(lo[k], c[k]);
            }
        }
        for &v in tail {
            hi[0] = up(hi[0], v);
            lo[0] = down(lo[0], v);
        }
        (
            hi.into_iter().fold(f32::NEG_INFINITY, up),
            lo.into_iter().fold(f32::INFINITY, down),
        )
    }
}

/// Peak-to-sidelobe ratio of a `w x h` response: `(F_max - mu) / sigma`
/// over the sidelobe, every value outside the `exclude x exclude` window
/// centred on the peak (wrapping around the edges, as a correlation
/// response does). 0 when the sidelobe is empty or flat.
pub fn psr(response: &[f32], w: usize, h: usize, exclude: usize) -> f64 {
    if response.len() != w * h || w == 0 {
        return 0.0;
    }
    let (max, i) = peak(response);
    let (px, py) = ((i % w) as isize, (i / w) as isize);
    let r = (exclude / 2) as isize;
    let near = |d: isize, n: usize| {
        let n = n as isize;
        let d = d.rem_euclid(n);
        d.min(n - d) <= r
    };
    let (mut n, mut s, mut s2) = (0usize, 0.0f64, 0.0f64);
    for y in 0..h {
        let ny = near(y as isize - py, h);
        for x in 0..w {
            if ny && near(x as isize - px, w) {
                continue;
            }
            let v = response[y * w + x] as f64;
            n += 1;
            s += v;
            s2 += v * v;
        }
    }
    if n == 0 {
        return 0.0;
    }
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean).max(0.0);
    if var <= 0.0 {
        return 0.0;
    }
    (max as f64 - mean) / var.sqrt()
}

/// Average peak-to-correlation energy: `|F_max - F_min|^2 / mean((F - F_min)^2)`.
/// 0 for a flat or empty response.
pub fn apce(response: &[f32]) -> f64 {
    if response.is_empty() {
        return 0.0;
    }
    // (a zero extreme's sign changes neither (max - min)^2 nor any
    // (v - min)^2)
    let (max, min) = dispatch(Range(response));
    let (max, min) = (max as f64, min as f64);
    let energy = dispatch(Spread { response, min }) / response.len() as f64;
    if energy <= 0.0 || !energy.is_finite() {
        return 0.0;
    }
    (max - min) * (max - min) / energy
}

/// `sum (v - min)^2` over a response as one running `f64` sum in value
/// order ([`sum_in_order`]).
struct Spread<'a> {
    response: &'a [f32],
    min: f64,
}

impl Kernel for Spread<'_> {
    type Output = f64;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> f64 {
        let min = self.min;
        // from -0, as `Iterator::sum` (the same bits: no term is -0)
        let mut e = -0.0f64;
        sum_in_order(&mut e, self.response, |v| {
            (v as f64 - min) * (v as f64 - min)
        });
        e
    }
}

/// Terms computed at once by [`sum_in_order`].
const SUM_TERMS: usize = 8;

/// `*e += term(x)` for each `x` of `xs` in turn: the terms of
/// [`SUM_TERMS`] values computed side by side (vector lanes), then added
/// one after the other, the additions and their order those of the plain
/// loop (whose every step waited for its term). In a dispatched kernel.
#[inline(always)]
pub(crate) fn sum_in_order<X: Copy>(e: &mut f64, xs: &[X], term: impl Fn(X) -> f64) {
    let (chunks, tail) = xs.as_chunks::<SUM_TERMS>();
    for c in chunks {
        let terms: [f64; SUM_TERMS] = std::array::from_fn(|i| term(c[i]));
        for t in terms {
            *e += t;
        }
    }
    for &x in tail {
        *e += term(x);
    }
}

/// LMCF's update rule (Wang et al. 2017, sec. 3.3): learn only when both
/// the peak `F_max` and the APCE reach fixed fractions of their means over
/// the frames learnt so far (`beta_1 = 0.7` for the peak, `beta_2 = 0.45`
/// for the APCE, the paper's values).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ApceGate {
    /// Fraction of the mean peak the response needs (LMCF's 0.7).
    pub peak_ratio: f64,
    /// Fraction of the mean APCE the response needs (LMCF's 0.45).
    pub apce_ratio: f64,
    sum_peak: f64,
    sum_apce: f64,
    n: u64,
}

impl Default for ApceGate {
    fn default() -> Self {
        Self::new(0.7, 0.45)
    }
}

impl ApceGate {
    /// A gate with the two ratios and no history.
    pub fn new(peak_ratio: f64, apce_ratio: f64) -> Self {
        Self {
            peak_ratio,
            apce_ratio,
            sum_peak: 0.0,
            sum_apce: 0.0,
            n: 0,
        }
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        *self = Self::new(self.peak_ratio, self.apce_ratio);
    }

    /// Whether a response with this peak and APCE may be learnt; when it
    /// may, it joins the history. The first response always passes.
    pub fn admit(&mut self, peak: f64, apce: f64) -> bool {
        if !(peak.is_finite() && apce.is_finite()) {
            return false;
        }
        let ok = self.n == 0
            || (peak >= self.peak_ratio * self.sum_peak / self.n as f64
                && apce >= self.apce_ratio * self.sum_apce / self.n as f64);
        if ok {
            self.sum_peak += peak;
            self.sum_apce += apce;
            self.n += 1;
        }
        ok
    }

    /// Whether a response would pass, without recording it.
    pub fn would_admit(&self, peak: f64, apce: f64) -> bool {
        peak.is_finite()
            && apce.is_finite()
            && (self.n == 0
                || (peak >= self.peak_ratio * self.sum_peak / self.n as f64
                    && apce >= self.apce_ratio * self.sum_apce / self.n as f64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psr_of_a_known_array() {
        // 20x20 zeros and ones in a checkerboard sidelobe, peak 10 at (3, 4):
        // the sidelobe (outside 11x11 around the peak, wrapped) is the
        // checkerboard: mean 0.5, std 0.5 -> PSR (10 - 0.5) / 0.5 = 19
        // (when the excluded window takes as many ones as zeros).
        let (w, h) = (20, 20);
        let mut r: Vec<f32> = (0..w * h).map(|i| ((i % w + i / w) % 2) as f32).collect();
        r[4 * w + 3] = 10.0;
        let got = psr(&r, w, h, 11);
        // count the sidelobe directly
        let side: Vec<f64> = (0..w * h)
            .filter(|&i| {
                let (x, y) = ((i % w) as i32, (i / w) as i32);
                let d = |a: i32, n: i32| {
                    let d = a.rem_euclid(n);
                    d.min(n - d)
                };
                !(d(x - 3, 20) <= 5 && d(y - 4, 20) <= 5)
            })
            .map(|i| r[i] as f64)
            .collect();
        assert_eq!(side.len(), 400 - 121);
        let m = side.iter().sum::<f64>() / side.len() as f64;
        let s = (side.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / side.len() as f64).sqrt();
        assert!((got - (10.0 - m) / s).abs() < 1e-9, "{got}");
        assert!((got - 19.0).abs() < 0.1, "{got}");
        // flat: 0
        assert_eq!(psr(&[1.0; 400], 20, 20, 11), 0.0);
    }

    #[test]
    fn apce_of_known_arrays() {
        // one spike of 1 among n-1 zeros: (1)^2 / (1/n) = n
        let mut r = vec![0.0f32; 100];
        r[17] = 1.0;
        assert!((apce(&r) - 100.0).abs() < 1e-9);
        // two levels half and half: 1 / 0.5 = 2
        let r: Vec<f32> = (0..10).map(|i| (i % 2) as f32 * 3.0).collect();
        assert!((apce(&r) - 2.0).abs() < 1e-9);
        assert_eq!(apce(&[2.0; 5]), 0.0);
        assert_eq!(apce(&[]), 0.0);
    }

    /// Responses with ties, zeros of both signs, NaNs and infinities at
    /// assorted places, of lengths around the lanes and the trackers' own.
    fn awkward() -> Vec<Vec<f32>> {
        let special = [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3.5,
            -3.5,
        ];
        let mut out = Vec::new();
        let mut x = 0x2545_f491u32;
        for n in (0..=40).chain([63, 64, 65, 640]) {
            for variant in 0..13 {
                let v: Vec<f32> = (0..n)
                    .map(|_| {
                        x ^= x << 13;
                        x ^= x >> 17;
                        x ^= x << 5;
                        match (variant, x % 16) {
                            // few distinct values: many ties
                            (0..=3, r) => (r % 4) as f32 - 2.0,
                            (4..=7, r) if r < 3 => special[(x >> 8) as usize % special.len()],
                            (8, _) => f32::NAN,
                            (9, _) => [-0.0, 0.0][(x >> 9) as usize % 2],
                            (10, _) => f32::NEG_INFINITY,
                            // a zero maximum, its first one of either sign
                            (11, r) => [-1.0, 0.0, -0.0][r as usize % 3],
                            _ => (x >> 8) as f32 / 1e6 - 8.0,
                        }
                    })
                    .collect();
                out.push(v);
            }
        }
        out
    }

    #[test]
    fn peak_and_apce_are_the_running_loops() {
        fn peak_running(r: &[f32]) -> (f32, usize) {
            let mut best = (f32::NEG_INFINITY, 0);
            for (i, &v) in r.iter().enumerate() {
                if v > best.0 {
                    best = (v, i);
                }
            }
            best
        }
        fn apce_running(r: &[f32]) -> f64 {
            if r.is_empty() {
                return 0.0;
            }
            let max = r.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b)) as f64;
            let min = r.iter().fold(f32::INFINITY, |a, &b| a.min(b)) as f64;
            let energy: f64 = r
                .iter()
                .map(|&v| (v as f64 - min) * (v as f64 - min))
                .sum::<f64>()
                / r.len() as f64;
            if energy <= 0.0 || !energy.is_finite() {
                return 0.0;
            }
            (max - min) * (max - min) / energy
        }
        for r in awkward() {
            let (a, b) = (peak(&r), peak_running(&r));
            assert_eq!((a.0.to_bits(), a.1), (b.0.to_bits(), b.1), "{r:?}");
            assert_eq!(apce(&r).to_bits(), apce_running(&r).to_bits(), "{r:?}");
            for level in bayestrack_image::simd::SimdLevel::ALL {
                let (hi, lo) = level.run(Range(&r));
                let hi_running = r.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b));
                let lo_running = r.iter().fold(f32::INFINITY, |a, &b| a.min(b));
                assert!(hi == hi_running && lo == lo_running, "{level:?}: {r:?}");
                let min = 0.37;
                let spread = level.run(Spread { response: &r, min });
                let running: f64 = r.iter().map(|&v| (v as f64 - min) * (v as f64 - min)).sum();
                assert_eq!(spread.to_bits(), running.to_bits(), "{level:?}: {r:?}");
            }
        }
    }

    #[test]
    fn gate_follows_lmcf() {
        let mut g = ApceGate::default();
        assert!(g.admit(1.0, 100.0));
        assert!(g.admit(0.8, 60.0));
        // mean peak 0.9 -> needs 0.63; mean APCE 80 -> needs 36
        assert!(!g.would_admit(0.6, 50.0));
        assert!(!g.would_admit(0.7, 30.0));
        assert!(g.would_admit(0.7, 40.0));
        assert!(!g.admit(f64::NAN, 40.0));
    }
}
