//! RGB colour histograms (Bócsi and Csató (paper 001), section 3) and their distances.
//!
//! A window is represented by three per-channel histograms of `bins` bins
//! each (`3 x 256` in the paper), normalised so that each channel sums to
//! one. Distances: L2 (the paper's choice, footnote 3) and Bhattacharyya.

use bayestrack_image::simd::{Kernel, Token, dispatch};
use bayestrack_image::{ImageError, ImageView, Rect};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// Which histogram distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum HistogramDistance {
    /// `sqrt(sum_c sum_b (p_cb - q_cb)^2)` (Bócsi and Csató (paper 001), footnote 3).
    #[default]
    L2,
    /// `sqrt(1 - BC)`, `BC = (1/3) sum_c sum_b sqrt(p_cb q_cb)`, in `[0, 1]`.
    Bhattacharyya,
}

/// Three per-channel histograms over an RGB window.
#[derive(Clone)]
pub struct RgbHistogram {
    bins: usize,
    counts: Vec<u32>,
    pixels: u32,
    /// Scratch for [`RgbHistogram::compute`]: [`SUB`] interleaved
    /// sub-histograms per channel (`sub[l * 3 + c]`), indexed by a `u8` bin
    /// so the increments need no bounds check; empty until first needed.
    sub: Vec<[u32; 256]>,
    /// Scratch: the bins of one window row (bin counts below 256).
    row_bins: Vec<u8>,
}

/// Sub-histograms per channel in [`RgbHistogram::compute`]: pixel `i` of a
/// row counts into sub-histogram `i % SUB`, so runs of equal values (every
/// smooth image region) increment different counters instead of waiting
/// on the previous increment of the same one.
const SUB: usize = 4;

/// Windows with fewer pixels than `SMALL_WINDOW_PER_BIN x bins` are
/// counted directly: clearing and merging the sub-histograms would cost
/// more than the serialised increments save.
const SMALL_WINDOW_PER_BIN: usize = 2;

impl PartialEq for RgbHistogram {
    fn eq(&self, other: &Self) -> bool {
        self.bins == other.bins && self.pixels == other.pixels && self.counts == other.counts
    }
}

impl Eq for RgbHistogram {}

impl std::fmt::Debug for RgbHistogram {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RgbHistogram")
            .field("bins", &self.bins)
            .field("pixels", &self.pixels)
            .field("counts", &self.counts)
            .finish()
    }
}

impl RgbHistogram {
    /// The paper's resolution: 256 bins per channel.
    pub const FULL_BINS: usize = 256;

    /// An empty histogram with `bins` bins per channel (1..=256; a value
    /// `v` falls in bin `v * bins / 256`).
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] for 0 or more than 256 bins.
    pub fn new(bins: usize) -> Result<Self> {
        if bins == 0 || bins > 256 {
            return Err(AppearanceError::InvalidParameter {
                name: "bins",
                value: bins.to_string(),
                reason: "must be in 1..=256",
            });
        }
        Ok(Self {
            bins,
            counts: vec![0; 3 * bins],
            pixels: 0,
            sub: Vec::new(),
            row_bins: Vec::new(),
        })
    }

    /// The histogram of `window` in a 3-channel frame.
    ///
    /// # Errors
    /// As [`RgbHistogram::new`] and [`RgbHistogram::compute`].
    pub fn from_window(frame: ImageView<'_, u8>, window: Rect, bins: usize) -> Result<Self> {
        let mut h = Self::new(bins)?;
        h.compute(frame, window)?;
        Ok(h)
    }

    /// Bins per channel.
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Pixels counted.
    pub fn pixels(&self) -> u32 {
        self.pixels
    }

    /// Raw counts, channel-major: `counts[c * bins + b]`.
    pub fn counts(&self) -> &[u32] {
        &self.counts
    }

    /// Normalised value of bin `b` of channel `c` (count / pixels), 0 if empty.
    pub fn probability(&self, c: usize, b: usize) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            f64::from(self.counts[c * self.bins + b]) / f64::from(self.pixels)
        }
    }

    /// Empties the histogram.
    pub fn clear(&mut self) {
        self.counts.fill(0);
        self.pixels = 0;
    }

    #[inline]
    fn bin(&self, v: u8) -> usize {
        (usize::from(v) * self.bins) >> 8
    }

    /// Adds one RGB pixel.
    #[inline]
    pub fn add(&mut self, rgb: [u8; 3]) {
        let b = self.bins;
        for (c, &v) in rgb.iter().enumerate() {
            let k = c * b + self.bin(v);
            self.counts[k] += 1;
        }
        self.pixels += 1;
    }

    /// Replaces the contents with the histogram of `window` (allocation-free).
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless the frame has 3 channels;
    /// [`AppearanceError::WindowOutside`] unless the window is inside.
    pub fn compute(&mut self, frame: ImageView<'_, u8>, window: Rect) -> Result<()> {
        frame.expect_channels("RgbHistogram", 3)?;
        check_window("RgbHistogram", window, frame.width(), frame.height())?;
        let b = self.bins;
        let rows =
            (window.y..window.bottom()).map(|y| &frame.row(y)[window.x * 3..window.right() * 3]);
        if window.area() < SMALL_WINDOW_PER_BIN * b {
            self.clear();
            count_direct(&mut self.counts, b, rows);
        } else {
            if self.sub.len() != 3 * SUB {
                self.sub = vec![[0; 256]; 3 * SUB];
            }
            for s in &mut self.sub {
                s[..b].fill(0);
            }
            if b == 256 {
                count_interleaved(&mut self.sub, rows, |v| v);
            } else {
                // The bins of a whole row first, in a pass the compiler
                // vectorises (`v * bins / 256` < bins <= 256 fits a `u8`,
                // the product a `u16`), then the counting.
                let bins = b as u16;
                let row_bins = &mut self.row_bins;
                row_bins.resize(3 * window.width, 0);
                for row in rows {
                    dispatch(BinRow {
                        row,
                        out: &mut row_bins[..],
                        bins,
                    });
                    count_interleaved(&mut self.sub, std::iter::once(&row_bins[..]), |v| v);
                }
            }
            for (c, out) in self.counts.chunks_exact_mut(b).enumerate() {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = (0..SUB).map(|l| self.sub[l * 3 + c][k]).sum();
                }
            }
        }
        self.pixels = u32::try_from(window.area()).unwrap_or(u32::MAX);
        Ok(())
    }

    /// Replaces the contents with the histogram of a 3-channel `f32` patch
    /// whose values are on the 0..=255 scale (for example a warped patch);
    /// values are rounded and clamped.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless the patch has 3 channels;
    /// [`AppearanceError::NonFinite`] for a NaN or infinite value (NaN was
    /// counted in bin 0); the histogram is then empty.
    pub fn compute_f32(&mut self, patch: ImageView<'_, f32>) -> Result<()> {
        patch.expect_channels("RgbHistogram", 3)?;
        self.clear();
        // `|v| <= MAX` fails for NaN and +-inf: one compare per value
        let mut finite = true;
        for y in 0..patch.height() {
            for p in patch.row(y).chunks_exact(3) {
                finite &=
                    p[0].abs() <= f32::MAX && p[1].abs() <= f32::MAX && p[2].abs() <= f32::MAX;
                let q = |v: f32| v.round().clamp(0.0, 255.0) as u8;
                self.add([q(p[0]), q(p[1]), q(p[2])]);
            }
        }
        if !finite {
            self.clear();
            return Err(AppearanceError::NonFinite {
                what: "f32 patch of an RGB histogram",
            });
        }
        Ok(())
    }

    fn check_pair(&self, other: &Self, operation: &'static str) -> Result<()> {
        if self.bins != other.bins {
            return Err(AppearanceError::Incompatible {
                operation,
                detail: format!("{} vs {} bins", self.bins, other.bins),
            });
        }
        if self.pixels == 0 || other.pixels == 0 {
            return Err(AppearanceError::Incompatible {
                operation,
                detail: "empty histogram".to_string(),
            });
        }
        Ok(())
    }

    /// L2 distance between normalised histograms (Bócsi and Csató (paper 001), footnote 3).
    ///
    /// # Errors
    /// [`AppearanceError::Incompatible`] for different bin counts or an empty histogram.
    pub fn l2_distance(&self, other: &Self) -> Result<f64> {
        self.check_pair(other, "l2_distance")?;
        // sum (a/na - b/nb)^2 = sum (a nb - b na)^2 / (na nb)^2: integer
        // products, exact in f64 while |a nb - b na| < 2^26.5 and the sum
        // stays below 2^53 (any two windows of up to 5,000 pixels each), so
        // then the sum is exact in any order and the result is
        // `sqrt(S) / (na nb)` rounded twice.
        let (na, nb) = (f64::from(self.pixels), f64::from(other.pixels));
        let s = dispatch(CountSum {
            a: (&self.counts, self.pixels),
            b: (&other.counts, other.pixels),
            kind: HistogramDistance::L2,
        });
        Ok(s.sqrt() / (na * nb))
    }

    /// Bhattacharyya distance `sqrt(1 - BC)` with the coefficient averaged
    /// over the three channels.
    ///
    /// # Errors
    /// [`AppearanceError::Incompatible`] for different bin counts or an empty histogram.
    pub fn bhattacharyya_distance(&self, other: &Self) -> Result<f64> {
        self.check_pair(other, "bhattacharyya_distance")?;
        // `a b` is exact in f64 for counts below 2^26.5; one square root per
        // bin, one division at the end.
        let s = dispatch(CountSum {
            a: (&self.counts, self.pixels),
            b: (&other.counts, other.pixels),
            kind: HistogramDistance::Bhattacharyya,
        });
        let bc = s / (3.0 * (f64::from(self.pixels) * f64::from(other.pixels)).sqrt());
        Ok((1.0 - bc).max(0.0).sqrt())
    }

    /// The distance chosen by `kind`.
    ///
    /// # Errors
    /// As the individual distances.
    pub fn distance(&self, other: &Self, kind: HistogramDistance) -> Result<f64> {
        match kind {
            HistogramDistance::L2 => self.l2_distance(other),
            HistogramDistance::Bhattacharyya => self.bhattacharyya_distance(other),
        }
    }
}

/// Counts the pixels of `rows` straight into `counts` (channel-major).
fn count_direct<'a>(counts: &mut [u32], bins: usize, rows: impl Iterator<Item = &'a [u8]>) {
    let (r, rest) = counts.split_at_mut(bins);
    let (g, bl) = rest.split_at_mut(bins);
    let bin = |v: u8| (usize::from(v) * bins) >> 8;
    for row in rows {
        for p in row.chunks_exact(3) {
            r[bin(p[0])] += 1;
            g[bin(p[1])] += 1;
            bl[bin(p[2])] += 1;
        }
    }
}

/// Counts the pixels of `rows` into [`SUB`] interleaved sub-histograms per
/// channel (`sub[l * 3 + c]`, pixel `i` of a row in `l = i % SUB`).
#[inline(always)]
fn count_interleaved<'a>(
    sub: &mut [[u32; 256]],
    rows: impl Iterator<Item = &'a [u8]>,
    bin: impl Fn(u8) -> u8,
) {
    let Ok::<&mut [[u32; 256]; 3 * SUB], _>(s) = sub.try_into() else {
        unreachable!("RgbHistogram::compute sizes the scratch")
    };
    let [r0, g0, b0, r1, g1, b1, r2, g2, b2, r3, g3, b3] = s;
    for row in rows {
        let mut quads = row.chunks_exact(3 * SUB);
        for p in &mut quads {
            r0[usize::from(bin(p[0]))] += 1;
            g0[usize::from(bin(p[1]))] += 1;
            b0[usize::from(bin(p[2]))] += 1;
            r1[usize::from(bin(p[3]))] += 1;
            g1[usize::from(bin(p[4]))] += 1;
            b1[usize::from(bin(p[5]))] += 1;
            r2[usize::from(bin(p[6]))] += 1;
            g2[usize::from(bin(p[7]))] += 1;
            b2[usize::from(bin(p[8]))] += 1;
            r3[usize::from(bin(p[9]))] += 1;
            g3[usize::from(bin(p[10]))] += 1;
            b3[usize::from(bin(p[11]))] += 1;
        }
        for p in quads.remainder().chunks_exact(3) {
            r0[usize::from(bin(p[0]))] += 1;
            g0[usize::from(bin(p[1]))] += 1;
            b0[usize::from(bin(p[2]))] += 1;
        }
    }
}

/// `v * bins / 256` for a row of bytes (`bins < 256`: the product fits a
/// `u16`, the bin a `u8`).
struct BinRow<'a> {
    row: &'a [u8],
    out: &'a mut [u8],
    bins: u16,
}

impl Kernel for BinRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        for (o, &v) in self.out.iter_mut().zip(self.row) {
            *o = ((u16::from(v) * self.bins) >> 8) as u8;
        }
    }
}

/// The per-bin sum of a distance between two histograms' counts (with
/// their pixel counts): `sum (a nb - b na)^2` for L2, `sum sqrt(a b)` for
/// Bhattacharyya.
struct CountSum<'a> {
    a: (&'a [u32], u32),
    b: (&'a [u32], u32),
    kind: HistogramDistance,
}

impl Kernel for CountSum<'_> {
    type Output = f64;
    #[inline(always)]
    fn run<K: Token>(self, _: K) -> f64 {
        match self.kind {
            HistogramDistance::L2 => {
                let (na, nb) = (f64::from(self.a.1), f64::from(self.b.1));
                sum_lanes(self.a, self.b, |x, y| {
                    let d = x * nb - y * na;
                    d * d
                })
            }
            HistogramDistance::Bhattacharyya => sum_lanes(self.a, self.b, |x, y| (x * y).sqrt()),
        }
    }
}

/// `sum_k f(a_k, b_k)` over two count vectors, in four interleaved partial
/// sums (so the compiler vectorises it), added pairwise at the end.
#[inline(always)]
fn sum_lanes(
    (a, pixels_a): (&[u32], u32),
    (b, pixels_b): (&[u32], u32),
    f: impl Fn(f64, f64) -> f64,
) -> f64 {
    // Every count is at most its histogram's pixel count, so below 2^31
    // (every window of fewer pixels) the counts convert as `i32`, which
    // every x86-64 vector unit converts to f64 in one instruction.
    if pixels_a <= i32::MAX as u32 && pixels_b <= i32::MAX as u32 {
        sum_lanes_with(a, b, |v| f64::from(v as i32), f)
    } else {
        sum_lanes_with(a, b, f64::from, f)
    }
}

#[inline(always)]
fn sum_lanes_with(
    a: &[u32],
    b: &[u32],
    to_f64: impl Fn(u32) -> f64,
    f: impl Fn(f64, f64) -> f64,
) -> f64 {
    let mut acc = [0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] += f(to_f64(x[l]), to_f64(y[l]));
        }
    }
    for (l, (&x, &y)) in ra.iter().zip(rb).enumerate() {
        acc[l] += f(to_f64(x), to_f64(y));
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// The best window of a histogram search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HistogramMatch {
    /// Left column of the best window (0-based).
    pub x: usize,
    /// Top row of the best window (0-based).
    pub y: usize,
    /// Its distance to the reference.
    pub distance: f64,
}

/// Incremental distance between a sliding window's counts `c` and a fixed
/// reference distribution `q` (per bin), updated in O(1) per count change.
struct Running<'a> {
    q: &'a [f64],
    n: f64,
    kind: HistogramDistance,
    acc: f64,
}

impl Running<'_> {
    #[inline]
    fn term(&self, c: u32, k: usize) -> f64 {
        match self.kind {
            HistogramDistance::L2 => {
                let d = f64::from(c) / self.n - self.q[k];
                d * d
            }
            _ => (f64::from(c) * self.q[k]).sqrt(),
        }
    }
    fn reset(&mut self, counts: &[u32]) {
        self.acc = counts
            .iter()
            .enumerate()
            .map(|(k, &c)| self.term(c, k))
            .sum();
    }
    #[inline]
    fn bump(&mut self, counts: &mut [u32], k: usize, up: bool) {
        let old = counts[k];
        let new = if up { old + 1 } else { old - 1 };
        self.acc += self.term(new, k) - self.term(old, k);
        counts[k] = new;
    }
    fn distance(&self) -> f64 {
        match self.kind {
            HistogramDistance::L2 => self.acc.max(0.0).sqrt(),
            _ => {
                let bc = self.acc / (3.0 * self.n.sqrt());
                (1.0 - bc).max(0.0).sqrt()
            }
        }
    }
}

/// Exhaustive search for the `width x height` window inside `region` whose
/// histogram is closest to `reference`. Ties go to the first window in
/// raster order.
///
/// L2 is searched exactly in integers: with window counts `c_k` of `n`
/// pixels and reference counts `r_k` of `R` pixels, `e_k = c_k R - r_k n`
/// and `S = sum_k e_k^2 = (n R)^2 d^2`, so windows compare by `S` without
/// rounding. The window snakes through the region one pixel at a time
/// (down one column of positions, one step right, up the next; or along
/// rows for a wide window), always moving across its shorter side, and a
/// pixel leaving bin `a` while one enters bin `b` changes `S` by the closed
/// form `2R (e_b - e_a + R [a != b])`; a step costs O(min(width, height)).
/// The distance returned is the best window's [`RgbHistogram::distance`].
/// Bhattacharyya slides along rows with a running floating-point sum.
///
/// # Errors
/// [`ImageError::Channels`] unless the frame has 3 channels;
/// [`AppearanceError::WindowOutside`] if the region leaves the frame;
/// [`AppearanceError::TemplateLargerThanRegion`] if the window does not fit;
/// [`AppearanceError::Incompatible`] for an empty reference.
pub fn histogram_search(
    frame: ImageView<'_, u8>,
    reference: &RgbHistogram,
    width: usize,
    height: usize,
    region: Rect,
    kind: HistogramDistance,
) -> Result<HistogramMatch> {
    frame.expect_channels("histogram_search", 3)?;
    check_window("histogram_search", region, frame.width(), frame.height())?;
    if width == 0 || height == 0 {
        return Err(ImageError::ZeroSize {
            width,
            height,
            channels: 3,
        }
        .into());
    }
    if width > region.width || height > region.height {
        return Err(AppearanceError::TemplateLargerThanRegion {
            template_width: width,
            template_height: height,
            region,
        });
    }
    if reference.pixels == 0 {
        return Err(AppearanceError::Incompatible {
            operation: "histogram_search",
            detail: "empty reference histogram".to_string(),
        });
    }
    let bins = reference.bins;
    if kind == HistogramDistance::L2 {
        // |e_k| <= n R and S <= 2 (n R)^2 per channel: a type holds every
        // intermediate while it holds 8 (n R)^2.
        let bound = (width as u128)
            .checked_mul(height as u128)
            .and_then(|n| n.checked_mul(u128::from(reference.pixels)))
            .and_then(|nr| nr.checked_mul(nr))
            .and_then(|nr2| nr2.checked_mul(8));
        let best = match bound {
            Some(b) if b <= i64::MAX as u128 => {
                Some(l2_search::<i64>(frame, reference, width, height, region))
            }
            Some(b) if b <= i128::MAX as u128 => {
                Some(l2_search::<i128>(frame, reference, width, height, region))
            }
            _ => None,
        };
        if let Some((x, y)) = best {
            let mut hist = RgbHistogram::new(bins)?;
            hist.compute(frame, Rect::new(x, y, width, height))?;
            let distance = hist.distance(reference, kind)?;
            return Ok(HistogramMatch { x, y, distance });
        }
    }
    let q: Vec<f64> = (0..3 * bins)
        .map(|k| f64::from(reference.counts[k]) / f64::from(reference.pixels))
        .collect();
    let mut hist = RgbHistogram::new(bins)?;
    let mut run = Running {
        q: &q,
        n: (width * height) as f64,
        kind,
        acc: 0.0,
    };
    let mut best = HistogramMatch {
        x: region.x,
        y: region.y,
        distance: f64::INFINITY,
    };
    let bin = |v: u8| (usize::from(v) * bins) >> 8;
    for y in region.y..=region.bottom() - height {
        hist.compute(frame, Rect::new(region.x, y, width, height))?;
        run.reset(&hist.counts);
        let mut x = region.x;
        loop {
            let d = run.distance();
            if d < best.distance {
                best = HistogramMatch { x, y, distance: d };
            }
            if x + width >= region.right() {
                break;
            }
            for yy in y..y + height {
                let row = frame.row(yy);
                let out = &row[x * 3..x * 3 + 3];
                let inn = &row[(x + width) * 3..(x + width) * 3 + 3];
                for c in 0..3 {
                    run.bump(&mut hist.counts, c * bins + bin(out[c]), false);
                    run.bump(&mut hist.counts, c * bins + bin(inn[c]), true);
                }
            }
            x += 1;
        }
    }
    Ok(best)
}

/// The integer type of [`l2_search`]'s sum: `i64`, or `i128` for windows
/// and references so large that `8 (n R)^2` overflows `i64`.
trait ExactSum:
    Copy
    + Ord
    + From<i64>
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
{
}

impl ExactSum for i64 {}
impl ExactSum for i128 {}

/// The exact L2 state of [`histogram_search`]'s sliding window:
/// `e[c][k] = c_k R - r_k n` per channel `c` and bin `k`, and `t`, the
/// change of `s = sum e^2` since the first window in units of `2R`.
///
/// A pixel leaving bin `a` while one enters bin `b` changes `s` by
/// `2R (e_b - e_a) + 2R^2`, so `t` by `e_b - e_a + R`, an integer: windows
/// compare by `t` exactly as by `s`, without the multiplication. The
/// tables are indexed by `u8` (bins below 256 per channel), so no index
/// is checked against a length in the loop.
struct ExactL2<'a, A> {
    e: [[A; 256]; 3],
    t: A,
    /// `R`, the reference's pixel count.
    r: A,
    /// `bin[v]`: the bin of value `v` (every channel alike).
    bin: [u8; 256],
    frame: ImageView<'a, u8>,
}

impl<A: ExactSum> ExactL2<'_, A> {
    /// A pixel `out` leaves the window and `inn` enters it:
    /// `t += e_b - e_a + R` (nothing when the bins agree), then
    /// `e_a -= R`, `e_b += R`.
    #[inline(always)]
    fn swap(&mut self, out: &[u8], inn: &[u8]) {
        for (c, e) in self.e.iter_mut().enumerate() {
            let a = usize::from(self.bin[usize::from(out[c])]);
            let b = usize::from(self.bin[usize::from(inn[c])]);
            if a != b {
                let (ea, eb) = (e[a], e[b]);
                self.t += eb - ea + self.r;
                e[a] = ea - self.r;
                e[b] = eb + self.r;
            }
        }
    }

    /// The window at `(x, y)` moves one column: `out` leaves and `inn`
    /// enters on rows `y..y + height`.
    fn move_column(&mut self, out: usize, inn: usize, y: usize, height: usize) {
        for yy in y..y + height {
            let row = self.frame.row(yy);
            self.swap(&row[out * 3..out * 3 + 3], &row[inn * 3..inn * 3 + 3]);
        }
    }

    /// The window at `(x, y)` moves one row: row `out` leaves and `inn`
    /// enters on columns `x..x + width`.
    fn move_row(&mut self, out: usize, inn: usize, x: usize, width: usize) {
        let frame = self.frame;
        let po = &frame.row(out)[x * 3..(x + width) * 3];
        let pi = &frame.row(inn)[x * 3..(x + width) * 3];
        for (o, i) in po.chunks_exact(3).zip(pi.chunks_exact(3)) {
            self.swap(o, i);
        }
    }
}

/// The best L2 window of [`histogram_search`] (arguments checked there), by
/// the exact sum of [`ExactL2`]: the smallest `s`, ties to the first window
/// in raster order.
fn l2_search<A: ExactSum>(
    frame: ImageView<'_, u8>,
    reference: &RgbHistogram,
    width: usize,
    height: usize,
    region: Rect,
) -> (usize, usize) {
    let bins = reference.bins;
    let n = (width * height) as i64;
    let r = i64::from(reference.pixels);
    let mut bin = [0u8; 256];
    for (v, slot) in bin.iter_mut().enumerate() {
        // below 256: bins <= 256 and v < 256
        *slot = ((v * bins) >> 8) as u8;
    }
    // The first window's counts.
    let mut counts = [[0i64; 256]; 3];
    for yy in region.y..region.y + height {
        let row = &frame.row(yy)[region.x * 3..(region.x + width) * 3];
        for p in row.chunks_exact(3) {
            for (c, counts) in counts.iter_mut().enumerate() {
                counts[usize::from(bin[usize::from(p[c])])] += 1;
            }
        }
    }
    let mut e = [[A::from(0); 256]; 3];
    for ((e, counts), q) in e
        .iter_mut()
        .zip(&counts)
        .zip(reference.counts.chunks_exact(bins))
    {
        for ((e, &c), &q) in e.iter_mut().zip(counts).zip(q) {
            *e = A::from(c * r) - A::from(i64::from(q)) * A::from(n);
        }
    }
    let mut st = ExactL2 {
        e,
        t: A::from(0),
        r: A::from(r),
        bin,
        frame,
    };
    let (nx, ny) = (region.width - width + 1, region.height - height + 1);
    let mut best = (st.t, region.y, region.x);
    let mut consider = |s: A, x: usize, y: usize| {
        if (s, y, x) < best {
            best = (s, y, x);
        }
    };
    let (mut x, mut y) = (region.x, region.y);
    if height > width {
        // Down and up columns of positions; a vertical step moves a row
        // of `width` pixels, a step right a column of `height`.
        for ix in 0..nx {
            if ix > 0 {
                st.move_column(x, x + width, y, height);
                x += 1;
            }
            for iy in 0..ny {
                if iy > 0 {
                    if ix % 2 == 0 {
                        st.move_row(y, y + height, x, width);
                        y += 1;
                    } else {
                        st.move_row(y + height - 1, y - 1, x, width);
                        y -= 1;
                    }
                }
                consider(st.t, x, y);
            }
        }
    } else {
        for iy in 0..ny {
            if iy > 0 {
                st.move_row(y, y + height, x, width);
                y += 1;
            }
            for ix in 0..nx {
                if ix > 0 {
                    if iy % 2 == 0 {
                        st.move_column(x, x + width, y, height);
                        x += 1;
                    } else {
                        st.move_column(x + width - 1, x - 1, y, height);
                        x -= 1;
                    }
                }
                consider(st.t, x, y);
            }
        }
    }
    (best.2, best.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    fn rgb(w: usize, h: usize, f: impl Fn(usize, usize) -> [u8; 3]) -> Image<u8> {
        let mut img = Image::new(w, h, 3, 0u8).unwrap();
        for y in 0..h {
            for x in 0..w {
                for (c, v) in f(x, y).into_iter().enumerate() {
                    img.set(x, y, c, v);
                }
            }
        }
        img
    }

    #[test]
    fn histogram_of_a_known_image() {
        // 2x2: red, red, white, black.
        let img = rgb(2, 2, |x, y| match (x, y) {
            (_, 0) => [255, 0, 0],
            (0, 1) => [255, 255, 255],
            _ => [0, 0, 0],
        });
        let h = RgbHistogram::from_window(img.view(), Rect::new(0, 0, 2, 2), 256).unwrap();
        assert_eq!(h.pixels(), 4);
        assert_eq!(h.counts()[255], 3); // red channel: 3 x 255
        assert_eq!(h.counts()[0], 1);
        assert_eq!(h.counts()[256], 3); // green: 0, 0, 0 (black) ...
        assert_eq!(h.counts()[256 + 255], 1);
        assert_eq!(h.probability(2, 255), 0.25);
        let coarse = RgbHistogram::from_window(img.view(), Rect::new(0, 0, 2, 2), 4).unwrap();
        assert_eq!(coarse.counts(), &[1, 0, 0, 3, 3, 0, 0, 1, 3, 0, 0, 1]);
        // Black window vs red window: per channel p = e_0 vs e_255 in R only.
        let red = RgbHistogram::from_window(img.view(), Rect::new(0, 0, 1, 1), 256).unwrap();
        let black = RgbHistogram::from_window(img.view(), Rect::new(1, 1, 1, 1), 256).unwrap();
        assert!((red.l2_distance(&black).unwrap() - 2f64.sqrt()).abs() < 1e-12);
        // BC = (0 + 1 + 1) / 3.
        let bd = red.bhattacharyya_distance(&black).unwrap();
        assert!((bd - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(h.l2_distance(&h).unwrap(), 0.0);
        assert!(h.bhattacharyya_distance(&h).unwrap() < 1e-7);
        // The mixed window vs red: R p = (1/4 @0, 3/4 @255) vs (1 @255): (1/4)^2 + (1/4)^2;
        // G and B: (3/4 @0, 1/4 @255) vs (1 @0): 2 x ((1/4)^2 + (1/4)^2).
        let want = (6.0 * 0.0625f64).sqrt();
        assert!((h.l2_distance(&red).unwrap() - want).abs() < 1e-12);
    }

    #[test]
    fn bad_histogram_inputs() {
        assert!(RgbHistogram::new(0).is_err());
        assert!(RgbHistogram::new(257).is_err());
        let img = Image::new(10, 10, 3, 0u8).unwrap();
        assert!(matches!(
            RgbHistogram::from_window(img.view(), Rect::new(5, 5, 6, 2), 16),
            Err(AppearanceError::WindowOutside { .. })
        ));
        let gray = Image::new(10, 10, 1, 0u8).unwrap();
        assert!(matches!(
            RgbHistogram::from_window(gray.view(), Rect::new(0, 0, 2, 2), 16),
            Err(AppearanceError::Image(ImageError::Channels { .. }))
        ));
        let a = RgbHistogram::from_window(img.view(), Rect::new(0, 0, 2, 2), 16).unwrap();
        let b = RgbHistogram::from_window(img.view(), Rect::new(0, 0, 2, 2), 8).unwrap();
        assert!(a.l2_distance(&b).is_err());
        assert!(a.l2_distance(&RgbHistogram::new(16).unwrap()).is_err());
        assert!(matches!(
            histogram_search(
                img.view(),
                &a,
                11,
                2,
                Rect::new(0, 0, 10, 10),
                HistogramDistance::L2
            ),
            Err(AppearanceError::TemplateLargerThanRegion { .. })
        ));
    }

    #[test]
    fn sliding_search_matches_direct_computation() {
        let mut lcg = bayestrack_testkit::Lcg32(99);
        let mut next = move || lcg.byte();
        let mut img = rgb(60, 40, |_, _| [0, 0, 0]);
        for v in img.as_mut_slice() {
            *v = next() / 2; // dark noise
        }
        // A bright orange patch at (37, 12), 8x6.
        for y in 12..18 {
            for x in 37..45 {
                img.set(x, y, 0, 250);
                img.set(x, y, 1, 140);
                img.set(x, y, 2, 20);
            }
        }
        for bins in [256, 16] {
            let reference =
                RgbHistogram::from_window(img.view(), Rect::new(37, 12, 8, 6), bins).unwrap();
            for kind in [HistogramDistance::L2, HistogramDistance::Bhattacharyya] {
                let region = Rect::new(3, 2, 55, 37);
                let m = histogram_search(img.view(), &reference, 8, 6, region, kind).unwrap();
                assert_eq!((m.x, m.y), (37, 12), "{bins} {kind:?}");
                assert!(m.distance < 1e-6);
                // Spot-check the running distance against direct computation.
                let h =
                    RgbHistogram::from_window(img.view(), Rect::new(20, 30, 8, 6), bins).unwrap();
                let direct = h.distance(&reference, kind).unwrap();
                let r =
                    histogram_search(img.view(), &reference, 8, 6, Rect::new(20, 30, 8, 6), kind)
                        .unwrap();
                assert!(
                    (r.distance - direct).abs() < 1e-9,
                    "{direct} {}",
                    r.distance
                );
                let r =
                    histogram_search(img.view(), &reference, 8, 6, Rect::new(10, 30, 18, 6), kind)
                        .unwrap();
                assert!(r.distance <= direct + 1e-12);
            }
        }
    }

    /// A random RGB image from a linear congruential stream; `levels`
    /// distinct values per channel (few levels make long runs of equal bins).
    fn random_rgb(w: usize, h: usize, seed: u32, levels: u32) -> Image<u8> {
        bayestrack_testkit::noise(w, h, 3, seed)
            .map(|v| (u32::from(v) % levels * (256 / levels)) as u8)
    }

    /// The histogram pixel by pixel through `add` (the scalar reference).
    fn by_pixel(img: &Image<u8>, window: Rect, bins: usize) -> RgbHistogram {
        let mut h = RgbHistogram::new(bins).unwrap();
        for y in window.y..window.bottom() {
            for x in window.x..window.right() {
                let p = img.pixel(x, y).unwrap();
                h.add([p[0], p[1], p[2]]);
            }
        }
        h
    }

    /// The L2 search by brute force: every window's histogram counted
    /// afresh, `S = sum_k (c_k R - r_k n)^2` in `i128`, the smallest `S`
    /// first in raster order.
    fn l2_reference(
        img: &Image<u8>,
        reference: &RgbHistogram,
        w: usize,
        h: usize,
        region: Rect,
    ) -> (usize, usize) {
        let (n, r) = ((w * h) as i128, i128::from(reference.pixels()));
        let mut best = (i128::MAX, 0, 0);
        for y in region.y..=region.bottom() - h {
            for x in region.x..=region.right() - w {
                let hist = by_pixel(img, Rect::new(x, y, w, h), reference.bins());
                let s: i128 = hist
                    .counts()
                    .iter()
                    .zip(reference.counts())
                    .map(|(&c, &q)| (i128::from(c) * r - i128::from(q) * n).pow(2))
                    .sum();
                if s < best.0 {
                    best = (s, x, y);
                }
            }
        }
        (best.1, best.2)
    }

    /// The floating-point sliding L2 search that the exact one replaced
    /// (a running sum of per-bin term changes, row by row).
    fn float_l2_search(
        img: &Image<u8>,
        reference: &RgbHistogram,
        w: usize,
        h: usize,
        region: Rect,
    ) -> (usize, usize) {
        let bins = reference.bins;
        let q: Vec<f64> = (0..3 * bins)
            .map(|k| f64::from(reference.counts[k]) / f64::from(reference.pixels))
            .collect();
        let mut hist = RgbHistogram::new(bins).unwrap();
        let mut run = Running {
            q: &q,
            n: (w * h) as f64,
            kind: HistogramDistance::L2,
            acc: 0.0,
        };
        let mut best = (f64::INFINITY, region.x, region.y);
        let bin = |v: u8| (usize::from(v) * bins) >> 8;
        for y in region.y..=region.bottom() - h {
            hist.compute(img.view(), Rect::new(region.x, y, w, h))
                .unwrap();
            run.reset(&hist.counts);
            for x in region.x..=region.right() - w {
                let d = run.distance();
                if d < best.0 {
                    best = (d, x, y);
                }
                if x + w >= region.right() {
                    break;
                }
                for yy in y..y + h {
                    let row = img.row(yy);
                    for c in 0..3 {
                        run.bump(&mut hist.counts, c * bins + bin(row[x * 3 + c]), false);
                        run.bump(&mut hist.counts, c * bins + bin(row[(x + w) * 3 + c]), true);
                    }
                }
            }
        }
        (best.1, best.2)
    }

    /// Where the exact search and the floating-point one it replaced pick
    /// different windows (on the ball experiment's kind of frame: a dark
    /// disc on a light screen, a few grey levels of noise, so that many
    /// windows tie), the exact pick is never worse: a smaller exact sum,
    /// or the same sum earlier in raster order. The float search's running
    /// sum drifts by rounding along a row, which reorders ties and near
    /// ties.
    #[test]
    fn exact_l2_search_is_never_worse_than_the_float_search() {
        // The ball experiment's screen: colours (20, 20, 24) and
        // (245, 245, 240), sensor noise of about 3 grey levels (a sum of
        // three uniforms), a 21x21 window, a margin of 20 px.
        let (fw, fh, r, side) = (200usize, 160usize, 10.0f64, 21usize);
        let render = |frame: u32, bx: f64, by: f64| {
            let noise = bayestrack_testkit::noise(fw, fh, 9, 100 + frame);
            rgb(fw, fh, |x, y| {
                let inside = (x as f64 - bx).hypot(y as f64 - by) <= r;
                let base: [i32; 3] = if inside {
                    [20, 20, 24]
                } else {
                    [245, 245, 240]
                };
                let n = |c: usize| {
                    (0..3)
                        .map(|k| i32::from(noise.get(x, y, 3 * k + c).unwrap() % 7) - 3)
                        .sum::<i32>()
                };
                [0, 1, 2].map(|c| (base[c] + n(c)).clamp(0, 255) as u8)
            })
        };
        let exact_sum = |img: &Image<u8>, reference: &RgbHistogram, x: usize, y: usize| {
            let hist = by_pixel(img, Rect::new(x, y, side, side), reference.bins());
            let (n, rr) = ((side * side) as i128, i128::from(reference.pixels()));
            hist.counts()
                .iter()
                .zip(reference.counts())
                .map(|(&c, &q)| (i128::from(c) * rr - i128::from(q) * n).pow(2))
                .sum::<i128>()
        };
        let first = render(0, 60.0, 50.0);
        let reference =
            RgbHistogram::from_window(first.view(), Rect::new(50, 40, side, side), 256).unwrap();
        let (mut differ, mut ties) = (0, 0);
        for frame in 1..60u32 {
            let (bx, by) = (60.0 + 2.4 * f64::from(frame), 50.0 + 1.3 * f64::from(frame));
            let img = render(frame, bx, by);
            let x0 = (bx as usize - 10).saturating_sub(20);
            let y0 = (by as usize - 10).saturating_sub(20);
            let region = Rect::new(x0, y0, (side + 40).min(fw - x0), (side + 40).min(fh - y0));
            let m = histogram_search(
                img.view(),
                &reference,
                side,
                side,
                region,
                HistogramDistance::L2,
            )
            .unwrap();
            let old = float_l2_search(&img, &reference, side, side, region);
            if (m.x, m.y) != old {
                differ += 1;
                let (s_new, s_old) = (
                    exact_sum(&img, &reference, m.x, m.y),
                    exact_sum(&img, &reference, old.0, old.1),
                );
                assert!(s_new <= s_old, "frame {frame}: {s_new} > {s_old}");
                if s_new == s_old {
                    ties += 1;
                    assert!((m.y, m.x) < (old.1, old.0), "frame {frame}");
                }
            }
        }
        eprintln!("float and exact searches differ on {differ} of 59 frames ({ties} exact ties)");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// The exact sliding L2 search finds the brute-force window (ties
        /// included: few levels make many equal windows), tall and wide
        /// windows alike, and reports that window's own distance.
        #[test]
        fn exact_l2_search_matches_brute_force(
            seed in 0u32..1000,
            levels in proptest::sample::select(vec![2u32, 3, 256]),
            bins in proptest::sample::select(vec![1usize, 4, 16, 256]),
            w in 1usize..9,
            h in 1usize..9,
            rw in 0usize..9,
            rh in 0usize..9,
            rx in 0usize..4,
            ry in 0usize..4,
            refw in 1usize..6,
        ) {
            let img = random_rgb(24, 24, seed, levels);
            let reference =
                RgbHistogram::from_window(img.view(), Rect::new(7, 3, refw, refw + 1), bins)
                    .unwrap();
            let region = Rect::new(rx, ry, w + rw, h + rh);
            let m = histogram_search(img.view(), &reference, w, h, region, HistogramDistance::L2)
                .unwrap();
            proptest::prop_assert_eq!((m.x, m.y), l2_reference(&img, &reference, w, h, region));
            let own = RgbHistogram::from_window(img.view(), Rect::new(m.x, m.y, w, h), bins)
                .unwrap()
                .l2_distance(&reference)
                .unwrap();
            proptest::prop_assert_eq!(m.distance.to_bits(), own.to_bits());
        }
    }

    #[test]
    fn interleaved_counting_matches_the_scalar_reference() {
        let img = random_rgb(70, 50, 5, 256);
        let runs = random_rgb(70, 50, 6, 3);
        for bins in [1, 2, 7, 16, 100, 255, 256] {
            let mut h = RgbHistogram::new(bins).unwrap();
            // Small windows take the direct path, large ones the
            // interleaved one; odd widths leave a remainder per row.
            for window in [
                Rect::new(0, 0, 1, 1),
                Rect::new(3, 4, 5, 3),
                Rect::new(1, 2, 41, 37),
                Rect::new(0, 0, 70, 50),
                Rect::new(9, 1, 4, 48),
            ] {
                for frame in [&img, &runs] {
                    h.compute(frame.view(), window).unwrap();
                    assert_eq!(h, by_pixel(frame, window, bins), "{bins} {window}");
                    let sums: Vec<u32> = h.counts().chunks(bins).map(|c| c.iter().sum()).collect();
                    assert_eq!(sums, vec![window.area() as u32; 3]);
                }
            }
        }
    }

    /// The L2 distance from an exact integer sum of squares (`u128`).
    fn l2_exact(a: &RgbHistogram, b: &RgbHistogram) -> f64 {
        let (na, nb) = (u128::from(a.pixels()), u128::from(b.pixels()));
        let s: u128 = a
            .counts()
            .iter()
            .zip(b.counts())
            .map(|(&x, &y)| {
                let d = (u128::from(x) * nb).abs_diff(u128::from(y) * na);
                d * d
            })
            .sum();
        (s as f64).sqrt() / (na * nb) as f64
    }

    #[test]
    fn distances_match_the_per_bin_formulas_to_round_off() {
        let img = random_rgb(90, 60, 8, 256);
        let smooth = random_rgb(90, 60, 9, 4);
        for bins in [16, 256] {
            for (wa, wb) in [
                (Rect::new(0, 0, 40, 40), Rect::new(30, 10, 40, 40)),
                (Rect::new(2, 3, 7, 5), Rect::new(50, 20, 40, 40)),
                (Rect::new(0, 0, 90, 60), Rect::new(1, 1, 3, 3)),
            ] {
                for (fa, fb) in [(&img, &img), (&img, &smooth), (&smooth, &smooth)] {
                    let a = RgbHistogram::from_window(fa.view(), wa, bins).unwrap();
                    let b = RgbHistogram::from_window(fb.view(), wb, bins).unwrap();
                    // The per-bin formulas, summed in order.
                    let (na, nb) = (f64::from(a.pixels()), f64::from(b.pixels()));
                    let mut l2 = 0f64;
                    let mut bc = 0f64;
                    for (&x, &y) in a.counts().iter().zip(b.counts()) {
                        let d = f64::from(x) / na - f64::from(y) / nb;
                        l2 += d * d;
                        bc += (f64::from(x) / na * f64::from(y) / nb).sqrt();
                    }
                    let l2 = l2.sqrt();
                    let got = a.l2_distance(&b).unwrap();
                    // Sums of squares below 2^53 are exact: two roundings.
                    assert_eq!(got, l2_exact(&a, &b), "{bins} {wa} {wb}");
                    assert!((got - l2).abs() <= 1e-14 * l2, "{got} {l2}");
                    let bd = a.bhattacharyya_distance(&b).unwrap();
                    let want = (1.0 - bc / 3.0).max(0.0);
                    assert!((bd * bd - want).abs() <= 1e-14, "{bd} {want}");
                }
            }
        }
    }
}
