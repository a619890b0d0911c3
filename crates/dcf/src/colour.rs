//! Staple's colour model (Bertinetto et al. 2016): foreground and
//! background colour histograms, a per-pixel object likelihood, and its
//! mean over a target-sized box at every candidate position (an integral
//! image), merged with the correlation response.
//!
//! - **Histograms.** Joint RGB histograms of 32 bins per channel
//!   (`32^3` bins; 32 bins for gray), normalised to sum 1: the foreground
//!   from the target box shrunk by `inner_padding * (w + h) / 2` (Staple's
//!   0.2), the background from the patch outside the target box. Both are
//!   interpolated with Staple's learning rate 0.04.
//! - **Likelihood.** `P(object | pixel) = f(b) / (f(b) + g(b))` of its bin
//!   `b` (0 where both are 0).
//! - **Box score.** The mean likelihood over a target-sized box centred at
//!   each candidate displacement; merged as `(1 - m) f_cf + m f_pwp` with
//!   Staple's `m = 0.3`.

use crate::error::{DcfError, Result};

/// Bins per colour channel (Staple: 2^5).
pub const BINS: usize = 32;

/// Foreground/background colour histograms.
///
/// The work per call is proportional to the patch and to the bins that
/// hold mass, not to the `32^3` bins of the table: each bin's likelihood
/// is kept with the histograms (recomputed for the bins a learning step
/// moves), a learning step counts into integer counters that it resets
/// bin by bin, and moves only the bins that are non-zero in either
/// histogram or in the new counts (a zero bin stays zero: `(1 - r) 0 +
/// r 0 k = 0`). The numbers are those of the whole-table computation, bit
/// for bit: every bin's update is the same expression on the same values.
#[derive(Debug, Clone)]
pub struct ColourModel {
    channels: usize,
    fg: Vec<f32>,
    bg: Vec<f32>,
    /// `fg / (fg + bg)` of each bin (0 where both are 0).
    lik: Vec<f32>,
    /// Scratch: the new foreground and background counts of each bin,
    /// interleaved; all 0 between calls.
    counts: Vec<u32>,
    /// The bins non-zero in either histogram (in any order), and whether
    /// each bin is in that list.
    active: Vec<u32>,
    listed: Vec<bool>,
    bins: Vec<u32>,
    integral: Vec<f64>,
    trained: bool,
}

/// The bin of a channel value: `0..=255` in `BINS` equal steps (values
/// outside are clamped; NaN reads as 0): `(v.clamp(0, 255) as usize)
/// BINS / 256`, without a float-to-integer conversion (which the compiler
/// leaves scalar), so that a loop of it vectorises.
#[inline(always)]
// max then min, not clamp: NaN must read as 0, not stay NaN
#[allow(clippy::manual_clamp)]
fn quantise(v: f32) -> u32 {
    const MAGIC: f32 = 8_388_608.0; // 2^23
    // NaN.max(0) is 0: NaN falls in the first bin, as `clamp` then `as`
    // (NaN to 0) would put it. The scaling is exact (a power of two).
    let c = v.max(0.0).min(255.0) * (BINS as f32 / 256.0);
    // c + 2^23 is c rounded to the nearest integer (c < 2^22), that
    // integer in its low mantissa bits; one less where it rounded up: the
    // floor
    let t = c + MAGIC;
    (t.to_bits() - MAGIC.to_bits()) - u32::from(t - MAGIC > c)
}

impl ColourModel {
    /// A model for 1 (gray) or 3 (RGB) channels.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for another channel count.
    pub fn new(channels: usize) -> Result<Self> {
        if channels != 1 && channels != 3 {
            return Err(DcfError::InvalidParameter {
                name: "colour channels",
                value: channels as f64,
                reason: "must be 1 or 3",
            });
        }
        let n = BINS.pow(channels as u32);
        Ok(Self {
            channels,
            fg: vec![0.0; n],
            bg: vec![0.0; n],
            lik: vec![0.0; n],
            counts: vec![0; 2 * n],
            active: Vec::new(),
            listed: vec![false; n],
            bins: Vec::new(),
            integral: Vec::new(),
            trained: false,
        })
    }

    /// Whether the model has learnt at least once.
    pub fn is_trained(&self) -> bool {
        self.trained
    }

    /// The bin of every pixel of `planes` (`channels` planes of `n`
    /// pixels, values `0..=255`), into the model's scratch.
    fn bin_pixels(&mut self, planes: &[f32], n: usize) -> Result<()> {
        if planes.len() != n * self.channels {
            return Err(DcfError::Size {
                what: "colour planes",
                expected: n * self.channels,
                got: planes.len(),
            });
        }
        self.bins.resize(n, 0);
        if self.channels == 1 {
            for (o, &v) in self.bins.iter_mut().zip(planes) {
                *o = quantise(v);
            }
        } else {
            let (r, rest) = planes.split_at(n);
            let (g, b) = rest.split_at(n);
            const K: u32 = BINS as u32;
            for (((o, &r), &g), &b) in self.bins.iter_mut().zip(r).zip(g).zip(b) {
                *o = quantise(r) + K * (quantise(g) + K * quantise(b));
            }
        }
        Ok(())
    }

    /// Counts the bins of `bins[range]` into the foreground (`k = 0`) or
    /// background (`k = 1`) counts, listing bins not listed yet.
    fn count(&mut self, range: std::ops::Range<usize>, k: usize) {
        let (counts, listed, active) = (&mut self.counts, &mut self.listed, &mut self.active);
        for &b in &self.bins[range] {
            let b = b as usize;
            counts[2 * b + k] += 1;
            if !listed[b] {
                listed[b] = true;
                active.push(b as u32);
            }
        }
    }

    /// Learns from a `w x h` patch (`planes`, channel after channel) whose
    /// target box is `[x0, x1) x [y0, y1)` (patch pixels): the foreground
    /// from the box shrunk by `shrink` pixels on each side, the background
    /// from outside the box; moves the histograms by `rate` (the first
    /// call takes them whole). A region with no pixel leaves its histogram
    /// unchanged.
    ///
    /// # Errors
    /// [`DcfError::Size`] for planes of another size.
    #[allow(clippy::too_many_arguments)]
    pub fn learn(
        &mut self,
        planes: &[f32],
        w: usize,
        h: usize,
        (x0, y0, x1, y1): (usize, usize, usize, usize),
        shrink: usize,
        rate: f64,
    ) -> Result<()> {
        self.bin_pixels(planes, w * h)?;
        // the box and the foreground inside it, clipped to the patch (an
        // empty box: every pixel is background)
        let boxed = x0 < x1 && y0 < y1;
        let (bx0, bx1) = (x0.min(w), x1.min(w));
        let (fx0, fy0) = (x0 + shrink, y0 + shrink);
        let (fx1, fy1) = (x1.saturating_sub(shrink), y1.saturating_sub(shrink));
        let (fx0, fx1) = (fx0.min(w), fx1.min(w));
        let (mut nf, mut nbk) = (0usize, 0usize);
        for y in 0..h {
            let row = y * w;
            if !(boxed && (y0..y1).contains(&y)) {
                self.count(row..row + w, 1);
                nbk += w;
                continue;
            }
            self.count(row..row + bx0, 1);
            self.count(row + bx1..row + w, 1);
            nbk += bx0 + (w - bx1);
            if (fy0..fy1).contains(&y) && fx0 < fx1 {
                self.count(row + fx0..row + fx1, 0);
                nf += fx1 - fx0;
            }
        }
        let r = if self.trained { rate as f32 } else { 1.0 };
        // the same expression as over the whole table, bin by bin
        let kf = (nf > 0).then(|| 1.0 / nf as f32);
        let kb = (nbk > 0).then(|| 1.0 / nbk as f32);
        let mut i = 0;
        while i < self.active.len() {
            let b = self.active[i] as usize;
            let [cf, cb]: [u32; 2] = [self.counts[2 * b], self.counts[2 * b + 1]];
            self.counts[2 * b] = 0;
            self.counts[2 * b + 1] = 0;
            if let Some(k) = kf {
                let a = &mut self.fg[b];
                *a = (1.0 - r) * *a + r * cf as f32 * k;
            }
            if let Some(k) = kb {
                let a = &mut self.bg[b];
                *a = (1.0 - r) * *a + r * cb as f32 * k;
            }
            let (f, g) = (self.fg[b], self.bg[b]);
            self.lik[b] = if f + g > 0.0 { f / (f + g) } else { 0.0 };
            if f == 0.0 && g == 0.0 {
                // both underflowed (or never held mass): off the list
                self.listed[b] = false;
                self.active.swap_remove(i);
            } else {
                i += 1;
            }
        }
        self.trained = true;
        Ok(())
    }

    /// The object likelihood of every pixel of a `w x h` patch into `out`.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn likelihood(
        &mut self,
        planes: &[f32],
        w: usize,
        h: usize,
        out: &mut [f32],
    ) -> Result<()> {
        self.bin_pixels(planes, w * h)?;
        if out.len() != w * h {
            return Err(DcfError::Size {
                what: "likelihood map",
                expected: w * h,
                got: out.len(),
            });
        }
        for (o, &b) in out.iter_mut().zip(&self.bins) {
            *o = self.lik[b as usize];
        }
        Ok(())
    }

    /// Box scores on a cell grid: for every cyclic displacement `d` of a
    /// `nx x ny` grid of `cell`-pixel cells (`d` wrapped as in a
    /// correlation response), the mean of `map` (`w x h`) over the
    /// `bw x bh` box centred at the patch centre plus `d cell`; 0 where
    /// the box leaves the patch. Into `out` (`nx x ny`).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    #[allow(clippy::too_many_arguments)]
    pub fn box_scores(
        &mut self,
        map: &[f32],
        w: usize,
        h: usize,
        (bw, bh): (usize, usize),
        (nx, ny, cell): (usize, usize, usize),
        out: &mut [f32],
    ) -> Result<()> {
        if map.len() != w * h || out.len() != nx * ny {
            return Err(DcfError::Size {
                what: "box scores",
                expected: nx * ny,
                got: out.len(),
            });
        }
        if w == 0 || h == 0 {
            return Err(DcfError::Size {
                what: "box scores map (empty)",
                expected: 1,
                got: 0,
            });
        }
        let cols = w + 1;
        // every entry is written below but the first row and column
        self.integral.resize(cols * (h + 1), 0.0);
        self.integral[..cols].fill(0.0);
        for (y, row) in map.chunks_exact(w).enumerate() {
            let (upper, lower) = self.integral[y * cols..][..2 * cols].split_at_mut(cols);
            lower[0] = 0.0;
            let mut run = 0.0f64;
            for ((l, &u), &m) in lower[1..].iter_mut().zip(&upper[1..]).zip(row) {
                run += m as f64;
                *l = u + run;
            }
        }
        let (bw, bh) = (bw.clamp(1, w), bh.clamp(1, h));
        let inv = 1.0 / (bw * bh) as f64;
        for j in 0..ny {
            let dy = crate::kcf::wrapped(j, ny) * cell as isize;
            let top = (h as isize - bh as isize) / 2 + dy;
            for i in 0..nx {
                let dx = crate::kcf::wrapped(i, nx) * cell as isize;
                let left = (w as isize - bw as isize) / 2 + dx;
                out[j * nx + i] =
                    if left < 0 || top < 0 || left as usize + bw > w || top as usize + bh > h {
                        0.0
                    } else {
                        let (l, t) = (left as usize, top as usize);
                        let (r, b) = (l + bw, t + bh);
                        let s = self.integral[b * cols + r]
                            - self.integral[t * cols + r]
                            - self.integral[b * cols + l]
                            + self.integral[t * cols + l];
                        (s * inv) as f32
                    };
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_a_red_target_from_a_green_background() {
        // 20x20 patch: red 8x8 box in the middle on green
        let (w, h) = (20, 20);
        let mut planes = vec![0.0f32; 3 * w * h];
        for y in 0..h {
            for x in 0..w {
                let inside = (6..14).contains(&x) && (6..14).contains(&y);
                let i = y * w + x;
                if inside {
                    planes[i] = 220.0;
                    planes[w * h + i] = 30.0;
                } else {
                    planes[w * h + i] = 200.0;
                }
                planes[2 * w * h + i] = 40.0;
            }
        }
        let mut m = ColourModel::new(3).unwrap();
        m.learn(&planes, w, h, (6, 6, 14, 14), 1, 0.04).unwrap();
        let mut p = vec![0.0; w * h];
        m.likelihood(&planes, w, h, &mut p).unwrap();
        assert_eq!(p[10 * w + 10], 1.0);
        assert_eq!(p[0], 0.0);
        // box scores on a 5x5 grid of 4-px cells: 1 at no displacement,
        // 0.5 one cell (4 px of an 8 px box) to the side
        let mut out = vec![0.0; 25];
        m.box_scores(&p, w, h, (8, 8), (5, 5, 4), &mut out).unwrap();
        assert!((out[0] - 1.0).abs() < 1e-6, "{out:?}");
        assert!(
            (out[1] - 0.5).abs() < 1e-6 && (out[4] - 0.5).abs() < 1e-6,
            "{out:?}"
        );
        assert!((out[5] - 0.5).abs() < 1e-6, "{out:?}");
        // two cells away the box leaves the 20 px patch: 0 (6 + 8 + 8 > 20)
        assert_eq!(out[2], 0.0);
    }

    /// A small deterministic generator for the tests (xorshift64*).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() >> 33) as usize % n
        }
    }

    /// The model as first written: whole-table histograms, new counts in
    /// zeroed f32 tables, a per-pixel box test, the likelihood divided per
    /// pixel. The reference the model must match bit for bit.
    struct Reference {
        channels: usize,
        fg: Vec<f32>,
        bg: Vec<f32>,
        trained: bool,
    }

    impl Reference {
        fn new(channels: usize) -> Self {
            let n = BINS.pow(channels as u32);
            Self {
                channels,
                fg: vec![0.0; n],
                bg: vec![0.0; n],
                trained: false,
            }
        }

        fn bins(&self, planes: &[f32], n: usize) -> Vec<usize> {
            let q = |v: f32| (v.clamp(0.0, 255.0) as usize) * BINS / 256;
            (0..n)
                .map(|i| {
                    (0..self.channels)
                        .rev()
                        .fold(0, |acc, ch| acc * BINS + q(planes[ch * n + i]))
                })
                .collect()
        }

        #[allow(clippy::too_many_arguments)]
        fn learn(
            &mut self,
            planes: &[f32],
            w: usize,
            h: usize,
            (x0, y0, x1, y1): (usize, usize, usize, usize),
            shrink: usize,
            rate: f64,
        ) {
            let bins = self.bins(planes, w * h);
            let mut new_fg = vec![0.0f32; self.fg.len()];
            let mut new_bg = vec![0.0f32; self.fg.len()];
            let (fx0, fy0) = (x0 + shrink, y0 + shrink);
            let (fx1, fy1) = (x1.saturating_sub(shrink), y1.saturating_sub(shrink));
            let (mut nf, mut nbk) = (0usize, 0usize);
            for y in 0..h {
                for x in 0..w {
                    let b = bins[y * w + x];
                    let inside = (x0..x1).contains(&x) && (y0..y1).contains(&y);
                    if !inside {
                        new_bg[b] += 1.0;
                        nbk += 1;
                    } else if (fx0..fx1).contains(&x) && (fy0..fy1).contains(&y) {
                        new_fg[b] += 1.0;
                        nf += 1;
                    }
                }
            }
            let r = if self.trained { rate as f32 } else { 1.0 };
            for (hist, new, n) in [(&mut self.fg, &new_fg, nf), (&mut self.bg, &new_bg, nbk)] {
                if n == 0 {
                    continue;
                }
                let k = 1.0 / n as f32;
                for (a, &b) in hist.iter_mut().zip(new.iter()) {
                    *a = (1.0 - r) * *a + r * b * k;
                }
            }
            self.trained = true;
        }

        fn likelihood(&self, planes: &[f32], n: usize) -> Vec<f32> {
            self.bins(planes, n)
                .into_iter()
                .map(|b| {
                    let (f, g) = (self.fg[b], self.bg[b]);
                    if f + g > 0.0 { f / (f + g) } else { 0.0 }
                })
                .collect()
        }
    }

    /// Learning steps on random patches (a small palette, so that bins
    /// recur from patch to patch, and values off `0..=255`), random boxes
    /// (inside, across the edge, empty, shrunk to nothing) and rates
    /// (0, Staple's, 1: every bin not seen dropped): the histograms, the
    /// per-bin likelihood and the likelihood map are the whole-table
    /// model's, bit for bit, and every bin with mass is listed.
    #[test]
    fn learning_matches_the_whole_table_model_bit_for_bit() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for channels in [3, 1] {
            let mut m = ColourModel::new(channels).unwrap();
            let mut reference = Reference::new(channels);
            for step in 0..40 {
                let (w, h) = (1 + rng.below(30), 1 + rng.below(30));
                let palette: Vec<f32> = (0..6)
                    .map(|_| rng.below(300) as f32 - 20.0 + 0.25 * rng.below(4) as f32)
                    .collect();
                let planes: Vec<f32> = (0..channels * w * h)
                    .map(|_| palette[rng.below(palette.len())])
                    .collect();
                let x0 = rng.below(w + 3);
                let y0 = rng.below(h + 3);
                let bx = (x0, y0, x0 + rng.below(w + 2), y0 + rng.below(h + 2));
                let shrink = rng.below(6);
                let rate = [0.04, 1.0, 0.0, 0.5][step % 4];
                m.learn(&planes, w, h, bx, shrink, rate).unwrap();
                reference.learn(&planes, w, h, bx, shrink, rate);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&m.fg), bits(&reference.fg), "fg, step {step}");
                assert_eq!(bits(&m.bg), bits(&reference.bg), "bg, step {step}");
                for (b, (&f, &g)) in m.fg.iter().zip(&m.bg).enumerate() {
                    assert_eq!(m.listed[b], f != 0.0 || g != 0.0, "bin {b} listed");
                }
                assert!(m.counts.iter().all(|&c| c == 0));
                let mut p = vec![0.0; w * h];
                m.likelihood(&planes, w, h, &mut p).unwrap();
                assert_eq!(
                    bits(&p),
                    bits(&reference.likelihood(&planes, w * h)),
                    "likelihood, step {step}"
                );
            }
            assert!(!m.active.is_empty());
        }
    }

    /// The box scores as first written (a zeroed table, filled pixel by
    /// pixel): the same scores bit for bit.
    #[test]
    fn box_scores_match_the_first_integral_bit_for_bit() {
        let mut rng = Rng(7);
        let mut m = ColourModel::new(3).unwrap();
        for (w, h, bw, bh, nx, ny, cell) in [
            (20, 20, 8, 8, 5, 5, 4),
            (37, 23, 11, 5, 9, 6, 4),
            (9, 30, 30, 2, 3, 8, 3),
            (5, 4, 1, 1, 5, 4, 1),
        ] {
            let map: Vec<f32> = (0..w * h)
                .map(|_| (rng.next() >> 40) as f32 / (1u64 << 24) as f32)
                .collect();
            let mut out = vec![0.0; nx * ny];
            m.box_scores(&map, w, h, (bw, bh), (nx, ny, cell), &mut out)
                .unwrap();
            let cols = w + 1;
            let mut integral = vec![0.0f64; cols * (h + 1)];
            for y in 0..h {
                let mut run = 0.0f64;
                for x in 0..w {
                    run += map[y * w + x] as f64;
                    integral[(y + 1) * cols + x + 1] = integral[y * cols + x + 1] + run;
                }
            }
            let (bw, bh) = (bw.clamp(1, w), bh.clamp(1, h));
            let inv = 1.0 / (bw * bh) as f64;
            for j in 0..ny {
                let top =
                    (h as isize - bh as isize) / 2 + crate::kcf::wrapped(j, ny) * cell as isize;
                for i in 0..nx {
                    let left =
                        (w as isize - bw as isize) / 2 + crate::kcf::wrapped(i, nx) * cell as isize;
                    let want =
                        if left < 0 || top < 0 || left as usize + bw > w || top as usize + bh > h {
                            0.0
                        } else {
                            let (l, t) = (left as usize, top as usize);
                            let (r, b) = (l + bw, t + bh);
                            let s = integral[b * cols + r]
                                - integral[t * cols + r]
                                - integral[b * cols + l]
                                + integral[t * cols + l];
                            (s * inv) as f32
                        };
                    assert_eq!(
                        out[j * nx + i].to_bits(),
                        want.to_bits(),
                        "{w}x{h} ({i}, {j})"
                    );
                }
            }
        }
        let mut out = vec![0.0; 1];
        assert!(
            m.box_scores(&[], 0, 0, (1, 1), (1, 1, 1), &mut out)
                .is_err()
        );
    }

    #[test]
    fn quantise_is_the_truncating_formula() {
        let direct = |v: f32| ((v.clamp(0.0, 255.0) as usize) * BINS / 256) as u32;
        let mut values = vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            -1e-30,
            -3.5,
            255.5,
            256.0,
            1e9,
            f32::MAX,
            f32::MIN_POSITIVE,
        ];
        for i in 0..=256 * 64 {
            let x = i as f32 / 64.0;
            values.extend([x, f32::from_bits(x.to_bits().wrapping_sub(1)), x.next_up()]);
        }
        for v in values {
            assert_eq!(quantise(v), direct(v), "{v:e}");
        }
    }

    #[test]
    fn gray_and_errors() {
        assert!(ColourModel::new(2).is_err());
        let mut m = ColourModel::new(1).unwrap();
        let planes: Vec<f32> = (0..16)
            .map(|i| if i % 4 < 2 { 250.0 } else { 5.0 })
            .collect();
        m.learn(&planes, 4, 4, (0, 0, 2, 4), 0, 1.0).unwrap();
        let mut p = vec![0.0; 16];
        m.likelihood(&planes, 4, 4, &mut p).unwrap();
        assert_eq!(&p[..4], &[1.0, 1.0, 0.0, 0.0]);
        assert!(m.likelihood(&planes[..8], 4, 4, &mut p).is_err());
    }
}
