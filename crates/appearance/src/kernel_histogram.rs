//! Kernel-weighted colour histograms for real video: the HSV binning of
//! Pérez, Hue, Vermaak and Gangnet ("Color-based probabilistic tracking",
//! ECCV 2002) with the Epanechnikov kernel of Comaniciu, Ramesh and Meer
//! ("Kernel-based object tracking", PAMI 2003), compared with the
//! Bhattacharyya coefficient.
//!
//! **Binning** ([`HsvBinning`]): a pixel with saturation above `s_min` and
//! value above `v_min` falls in one of `hs_bins x hs_bins` hue-saturation
//! bins; every other pixel (grey, dark, or any pixel of a gray frame) falls
//! in one of `v_bins` value bins. So one model serves colour frames (where
//! hue and saturation carry most of it, robust to shading) and gray frames
//! (where only the value bins fill). Pérez et al. use 10 bins each,
//! `s_min = 0.1`, `v_min = 0.2`.
//!
//! **Bin map** ([`BinMap`]): the bin of every pixel of a frame region,
//! computed once per frame through a lookup table (RGB quantised to 5 bits
//! per channel, 32 KiB entries), so that each of many candidate windows
//! costs only the kernel-weighted counting.
//!
//! **Kernel histogram** ([`KernelHistogram`]): inside the ellipse inscribed
//! in a box with centre `(cx, cy)` and half-axes `(a, b)`, a pixel at
//! `(x, y)` counts `k = 1 - ((x - cx)/a)^2 - ((y - cy)/b)^2` (Epanechnikov
//! profile): the border pixels, most likely background, count least. The
//! [`KernelHistogram::ring`] histogram counts the rectangular ring around a
//! box uniformly (the local background). Histograms are normalised to sum 1;
//! the similarity of two is the Bhattacharyya coefficient
//! `rho = sum_u sqrt(p_u q_u)` in `[0, 1]`.

use bayestrack_image::simd::{Kernel, Token};
use bayestrack_image::{Hsv, ImageView, Rect, Rgb, SimdLevel};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// The HSV binning of Pérez et al. (2002), with a lookup table.
#[derive(Clone, Debug, PartialEq)]
pub struct HsvBinning {
    hs_bins: usize,
    v_bins: usize,
    s_min: f32,
    v_min: f32,
    /// Bin of each RGB colour quantised to 5 bits per channel (the first
    /// 2^15 entries; a fixed array of 2^16, so that any `u16` index needs
    /// no bounds test or mask).
    rgb_lut: Box<[u16; 1 << 16]>,
    /// Bin of each gray level (always a value bin).
    gray_lut: Box<[u16; 256]>,
}

impl HsvBinning {
    /// Pérez et al.'s binning: 10 x 10 hue-saturation bins, 10 value bins,
    /// `s_min = 0.1`, `v_min = 0.2`.
    pub fn perez() -> Self {
        Self::new(10, 10, 0.1, 0.2).expect("Pérez et al.'s parameters are valid")
    }

    /// A binning with `hs_bins x hs_bins` hue-saturation bins and `v_bins`
    /// value bins; pixels with saturation `> s_min` and value `> v_min` go
    /// to the hue-saturation bins.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] for `hs_bins` outside
    /// `1..=64`, `v_bins` outside `1..=256`, thresholds outside `[0, 1]`.
    pub fn new(hs_bins: usize, v_bins: usize, s_min: f32, v_min: f32) -> Result<Self> {
        let bad = |name, value: String, reason| {
            Err(AppearanceError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(1..=64).contains(&hs_bins) {
            return bad("hs_bins", hs_bins.to_string(), "must be in 1..=64");
        }
        if !(1..=256).contains(&v_bins) {
            return bad("v_bins", v_bins.to_string(), "must be in 1..=256");
        }
        for (name, v) in [("s_min", s_min), ("v_min", v_min)] {
            if !(0.0..=1.0).contains(&v) {
                return bad(name, v.to_string(), "must be in [0, 1]");
            }
        }
        let mut b = Self {
            hs_bins,
            v_bins,
            s_min,
            v_min,
            rgb_lut: vec![0; 1 << 16]
                .into_boxed_slice()
                .try_into()
                .expect("2^16 entries"),
            gray_lut: Box::new([0; 256]),
        };
        for v in 0..256u32 {
            b.gray_lut[v as usize] = b.value_bin(v as f32 / 255.0);
        }
        for q in 0..1u32 << 15 {
            let level = |s: u32| (((q >> s) & 31) << 3 | 4) as u8;
            b.rgb_lut[q as usize] = b.bin_exact(Rgb::new(level(10), level(5), level(0)));
        }
        Ok(b)
    }

    /// Number of bins: `hs_bins^2 + v_bins`.
    pub fn len(&self) -> usize {
        self.hs_bins * self.hs_bins + self.v_bins
    }

    /// Never true; here for API completeness.
    pub fn is_empty(&self) -> bool {
        false
    }

    fn value_bin(&self, v: f32) -> u16 {
        let nv = self.v_bins;
        (self.hs_bins * self.hs_bins + ((v * nv as f32) as usize).min(nv - 1)) as u16
    }

    /// The bin of an RGB colour, computed exactly (no table).
    pub fn bin_exact(&self, rgb: Rgb) -> u16 {
        let Hsv { h, s, v } = Hsv::from_rgb(rgb);
        if s > self.s_min && v > self.v_min {
            let n = self.hs_bins;
            let hb = ((h * n as f32) as usize).min(n - 1);
            let sb = ((s * n as f32) as usize).min(n - 1);
            (hb * n + sb) as u16
        } else {
            self.value_bin(v)
        }
    }

    /// The bin of an RGB pixel through the table (5 bits per channel).
    #[inline]
    pub fn bin_rgb(&self, r: u8, g: u8, b: u8) -> u16 {
        self.rgb_lut[usize::from(rgb_index(r, g, b))]
    }

    /// The bin of a gray pixel (a value bin).
    #[inline]
    pub fn bin_gray(&self, v: u8) -> u16 {
        self.gray_lut[usize::from(v)]
    }

    /// Fills `map` with the bin of every pixel of the frame region `rect`.
    ///
    /// # Errors
    /// [`bayestrack_image::ImageError::Channels`] unless the frame has 1 or
    /// 3 channels; [`AppearanceError::WindowOutside`] unless `rect` is
    /// inside the frame.
    pub fn bin_map_into(
        &self,
        frame: ImageView<'_, u8>,
        rect: Rect,
        map: &mut BinMap,
    ) -> Result<()> {
        self.bin_map_at(SimdLevel::Avx512, frame, rect, map)
    }

    /// [`HsvBinning::bin_map_into`] with its RGB kernel run at `level` (or
    /// the best this CPU has below it; every level gives the same bins).
    fn bin_map_at(
        &self,
        level: SimdLevel,
        frame: ImageView<'_, u8>,
        rect: Rect,
        map: &mut BinMap,
    ) -> Result<()> {
        let ch = frame.channels();
        if ch != 1 && ch != 3 {
            return Err(bayestrack_image::ImageError::Channels {
                operation: "bin map",
                expected: 3,
                got: ch,
            }
            .into());
        }
        check_window("bin map", rect, frame.width(), frame.height())?;
        map.rect = rect;
        map.limit = self.len();
        // Every entry is written below: no zeroing beyond a growth.
        map.bins.resize(rect.area(), 0);
        if rect.width == 0 {
            return Ok(());
        }
        let rows = map.bins.chunks_exact_mut(rect.width);
        for (y, out) in (rect.y..rect.bottom()).zip(rows) {
            let row = &frame.row(y)[rect.x * ch..rect.right() * ch];
            if ch == 1 {
                for (o, &v) in out.iter_mut().zip(row) {
                    *o = self.bin_gray(v);
                }
            } else {
                level.run(RgbBins {
                    lut: &self.rgb_lut,
                    row,
                    out,
                });
            }
        }
        Ok(())
    }
}

/// The index of an RGB colour in [`HsvBinning`]'s table: 5 bits a channel,
/// red highest (`u16` arithmetic, which vectorises).
#[inline(always)]
fn rgb_index(r: u8, g: u8, b: u8) -> u16 {
    let (r, g, b) = (u16::from(r), u16::from(g), u16::from(b));
    ((r >> 3) << 10) | ((g >> 3) << 5) | (b >> 3)
}

/// [`HsvBinning::bin_rgb`] of each pixel of an RGB row into `out`, in two
/// passes: the table indices of the whole row first (a loop the compiler
/// vectorises), then the lookups. The same bins at every level.
struct RgbBins<'a> {
    lut: &'a [u16; 1 << 16],
    row: &'a [u8],
    out: &'a mut [u16],
}

impl Kernel for RgbBins<'_> {
    type Output = ();
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let RgbBins { lut, row, out } = self;
        for (o, p) in out.iter_mut().zip(row.chunks_exact(3)) {
            *o = rgb_index(p[0], p[1], p[2]);
        }
        for o in out.iter_mut() {
            *o = lut[usize::from(*o)];
        }
    }
}

/// The bin of every pixel of a frame region (see [`HsvBinning::bin_map_into`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BinMap {
    rect: Rect,
    bins: Vec<u16>,
    /// Every bin of `bins` is below this (the binning's bin count).
    limit: usize,
}

/// Most bins of the unchecked fast paths of [`KernelHistogram`]: their
/// tables are fixed arrays indexed by a `u8`, so no bounds test.
const FAST_BINS: usize = 256;

impl BinMap {
    /// Whether every bin of the map is below `bins` and `bins` fits the
    /// fixed tables: a histogram of `bins` bins may then count it without
    /// a bin check per pixel (the bin as a `u8` is the bin).
    fn fits(&self, bins: usize) -> bool {
        self.limit <= bins && bins <= FAST_BINS
    }
}

impl BinMap {
    /// An empty map (covers nothing).
    pub fn new() -> Self {
        Self::default()
    }

    /// The frame region covered (0-based).
    pub fn rect(&self) -> Rect {
        self.rect
    }

    /// The bin of frame pixel `(x, y)`, `None` outside the region.
    pub fn get(&self, x: usize, y: usize) -> Option<u16> {
        let r = self.rect;
        (x >= r.x && y >= r.y && x < r.right() && y < r.bottom())
            .then(|| self.bins[(y - r.y) * r.width + (x - r.x)])
    }

    /// The covered index range `[lo, hi)` of frame coordinates in
    /// `[c - half, c + half]` along one axis, sampled every `step`
    /// starting at the first pixel inside the interval.
    fn span(c: f64, half: f64, start: usize, len: usize) -> (f64, i64, i64) {
        let first = (c - half).ceil();
        let last = (c + half).floor();
        let lo = (start as f64).max(first);
        let hi = ((start + len) as f64 - 1.0).min(last);
        (first, lo as i64, hi as i64)
    }
}

/// A normalised histogram over the bins of an [`HsvBinning`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KernelHistogram {
    weights: Vec<f32>,
    total: f32,
    /// Scratch: squared normalised column offsets of the ellipse.
    dx2: Vec<f32>,
    /// Scratch: the uniform histograms' integer counts, four tables one
    /// after the other.
    counts: Vec<u32>,
}

impl KernelHistogram {
    /// An empty histogram of `bins` bins.
    pub fn new(bins: usize) -> Self {
        Self {
            weights: vec![0.0; bins],
            total: 0.0,
            dx2: Vec::new(),
            counts: Vec::new(),
        }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// Whether it has no bins.
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// The normalised bin weights (all zero when nothing was counted).
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// The total (kernel) weight counted before normalisation; 0 when the
    /// window was entirely outside the map.
    pub fn total(&self) -> f32 {
        self.total
    }

    fn check_params(cx: f64, cy: f64, a: f64, b: f64, step: usize) -> Result<()> {
        if ![cx, cy, a, b].iter().all(|v| v.is_finite()) {
            return Err(AppearanceError::NonFinite {
                what: "histogram window",
            });
        }
        if a <= 0.0 || b <= 0.0 || step == 0 {
            return Err(AppearanceError::InvalidParameter {
                name: "half axes / step",
                value: format!("({a}, {b}, {step})"),
                reason: "half axes must be > 0 and the step >= 1",
            });
        }
        Ok(())
    }

    fn finish(&mut self) {
        if self.total > 0.0 {
            let inv = 1.0 / self.total;
            self.weights.iter_mut().for_each(|w| *w *= inv);
        }
    }

    /// The Epanechnikov-weighted histogram of the ellipse centred at
    /// `(cx, cy)` (0-based, pixel centres at integers) with half-axes
    /// `(a, b)`, counting every `step`-th pixel in each direction; pixels
    /// outside the map's region are skipped.
    ///
    /// # Errors
    /// [`AppearanceError::NonFinite`] for a non-finite centre or axis;
    /// [`AppearanceError::InvalidParameter`] for non-positive half-axes or a
    /// zero step; [`AppearanceError::Incompatible`] when the map holds a bin
    /// this histogram does not have.
    pub fn ellipse(
        &mut self,
        map: &BinMap,
        cx: f64,
        cy: f64,
        a: f64,
        b: f64,
        step: usize,
    ) -> Result<()> {
        self.ellipse_at(SimdLevel::Avx512, map, (cx, cy), (a, b), step)
    }

    /// [`KernelHistogram::ellipse`] with its kernel run at `level` (or the
    /// best this CPU has below it; every level gives the same bits).
    fn ellipse_at(
        &mut self,
        level: SimdLevel,
        map: &BinMap,
        (cx, cy): (f64, f64),
        (a, b): (f64, f64),
        step: usize,
    ) -> Result<()> {
        Self::check_params(cx, cy, a, b, step)?;
        self.weights.fill(0.0);
        self.total = 0.0;
        let r = map.rect;
        let (fx, x_lo, x_hi) = BinMap::span(cx, a, r.x, r.width);
        let (fy, y_lo, y_hi) = BinMap::span(cy, b, r.y, r.height);
        // Align the sampling grid to the window, not to the map.
        let align = |first: f64, lo: i64| -> i64 {
            let off = (lo as f64 - first) as i64;
            lo + (step as i64 - off.rem_euclid(step as i64)) % step as i64
        };
        let (x_start, y_start) = (align(fx, x_lo), align(fy, y_lo));
        if x_start > x_hi || y_start > y_hi {
            return Ok(());
        }
        let (ia2, ib2) = (1.0 / (a * a), 1.0 / (b * b));
        // The columns x_start, x_start + step, ..= x_hi (no push: the
        // length is known).
        self.dx2.resize((x_hi - x_start) as usize / step + 1, 0.0);
        let mut x = x_start;
        for d in self.dx2.iter_mut() {
            *d = ((x as f64 - cx).powi(2) * ia2) as f32;
            x += step as i64;
        }
        let nbins = self.weights.len();
        let dx2 = &self.dx2;
        // `dx2` falls to its smallest entry and rises after it (`(x - cx)^2`
        // is monotone on either side of `cx`, and so is each rounding), so
        // the columns of a row with `w = (1 - dy2) - dx2 > 0`, that is
        // `dx2 < 1 - dy2`, are one span, found by two binary searches: no
        // pixel outside the ellipse is visited.
        let kmin = dx2
            .iter()
            .enumerate()
            .fold(0, |m, (k, &d)| if d < dx2[m] { k } else { m });
        if map.fits(nbins) && unimodal(dx2, kmin) {
            let rows = Rows {
                y: (y_start, y_hi),
                cy,
                ib2,
                start: (y_start as usize - r.y) * r.width + x_start as usize - r.x,
                stride: r.width * step,
            };
            self.total = level.run(EllipseFast {
                bins: &map.bins,
                rows,
                dx2,
                kmin,
                step,
                weights: &mut self.weights,
            });
            return Ok(());
        }
        let mut total = 0f32;
        for y in (y_start..=y_hi).step_by(step) {
            let dy2 = ((y as f64 - cy).powi(2) * ib2) as f32;
            if dy2 >= 1.0 {
                continue;
            }
            let t = 1.0 - dy2;
            let lo = dx2[..=kmin].partition_point(|&d| d >= t);
            let hi = kmin + dx2[kmin..].partition_point(|&d| d < t);
            if lo >= hi {
                continue;
            }
            let row = (y as usize - r.y) * r.width + x_start as usize - r.x;
            let bins = &map.bins[row + lo * step..];
            let dxs = &dx2[lo..hi];
            // The weights' bounds test is the bin check: the first bad bin
            // in pixel order is the error, as pixel by pixel. (`w > 0`
            // holds on the whole span; the test is kept as a guard.)
            let weights = &mut self.weights[..];
            let mut add = |bin: u16, d: f32| {
                let w = t - d;
                if w > 0.0 {
                    match weights.get_mut(usize::from(bin)) {
                        Some(v) => *v += w,
                        None => return Err(incompatible(usize::from(bin), nbins)),
                    }
                    total += w;
                }
                Ok(())
            };
            if step == 1 {
                for (&bin, &d) in bins[..dxs.len()].iter().zip(dxs) {
                    add(bin, d)?;
                }
            } else {
                for (&bin, &d) in bins.iter().step_by(step).zip(dxs) {
                    add(bin, d)?;
                }
            }
        }
        self.total = total;
        self.finish();
        Ok(())
    }

    /// The uniform histogram of the box with centre `(cx, cy)` and
    /// half-sizes `(a, b)` (pixel centres inside, every `step`-th pixel);
    /// [`KernelHistogram::total`] is then the number of pixels counted.
    ///
    /// # Errors
    /// As [`KernelHistogram::ellipse`].
    pub fn rect(
        &mut self,
        map: &BinMap,
        cx: f64,
        cy: f64,
        a: f64,
        b: f64,
        step: usize,
    ) -> Result<()> {
        Self::check_params(cx, cy, a, b, step)?;
        self.uniform(map, (cx, cy), (a, b), None, step)
    }

    /// The uniform histogram of the rectangular ring between the box with
    /// centre `(cx, cy)` and half-sizes `(a, b)` and the same box grown by
    /// `outer` (> 1) about its centre, counting every `step`-th pixel;
    /// pixels outside the map's region are skipped.
    ///
    /// # Errors
    /// As [`KernelHistogram::ellipse`], and
    /// [`AppearanceError::InvalidParameter`] for `outer <= 1`.
    #[allow(clippy::too_many_arguments)]
    pub fn ring(
        &mut self,
        map: &BinMap,
        cx: f64,
        cy: f64,
        a: f64,
        b: f64,
        outer: f64,
        step: usize,
    ) -> Result<()> {
        Self::check_params(cx, cy, a, b, step)?;
        if !(outer.is_finite() && outer > 1.0) {
            return Err(AppearanceError::InvalidParameter {
                name: "outer",
                value: outer.to_string(),
                reason: "the ring's outer box must be larger than the inner (> 1)",
            });
        }
        let hole = [cx - a, cx + a, cy - b, cy + b];
        self.uniform(map, (cx, cy), (a * outer, b * outer), Some(hole), step)
    }

    /// The uniform histogram of every `step`-th pixel of the box with
    /// centre `c` and half-sizes `half` that lies in the map's region and
    /// outside `hole` (`[x0, x1, y0, y1]`, inclusive, if any).
    fn uniform(
        &mut self,
        map: &BinMap,
        c: (f64, f64),
        half: (f64, f64),
        hole: Option<[f64; 4]>,
        step: usize,
    ) -> Result<()> {
        self.total = 0.0;
        let r = map.rect;
        let (_, x_lo, x_hi) = BinMap::span(c.0, half.0, r.x, r.width);
        let (_, y_lo, y_hi) = BinMap::span(c.1, half.1, r.y, r.height);
        if x_lo > x_hi || y_lo > y_hi {
            self.weights.fill(0.0);
            return Ok(());
        }
        let nbins = self.weights.len();
        // The counted columns x_lo + k step, k < n; on the hole's rows the
        // ks of the hole's integer columns ceil(x0)..=floor(x1) are left
        // out, so each row is at most two spans and no pixel is tested.
        let n = (x_hi - x_lo) as usize / step + 1;
        let (first, last) = (x_lo as f64, (x_lo + ((n - 1) * step) as i64) as f64);
        let skip = hole.map(|h| {
            // Clamped to the counted columns before the (then exact) casts.
            let a = h[0].ceil().clamp(first, last + 1.0) as i64 - x_lo;
            let b = h[1].floor().clamp(first - 1.0, last) as i64 - x_lo;
            let ka = (a as usize).div_ceil(step);
            let kb = if b < 0 { 0 } else { b as usize / step + 1 };
            (h[2], h[3], ka, kb.max(ka))
        });
        let rows = UniformRows {
            y: (y_lo, y_hi),
            step,
            start: (y_lo as usize - r.y) * r.width + x_lo as usize - r.x,
            stride: r.width * step,
            len: (n - 1) * step + 1,
            n,
            skip,
        };
        // Integer counts in four tables, one per pixel position mod 4, so
        // that runs of one bin do not wait on each other's stores. Counting
        // is exact and order-free, so the weights equal the `+= 1.0` of a
        // pixel-by-pixel loop: `min(count, 2^24)`, where adding one in
        // `f32` stops.
        let lane = nbins.max(FAST_BINS);
        if self.counts.len() < 4 * lane {
            self.counts.clear();
            self.counts.resize(4 * lane, 0);
        }
        let tables = &mut self.counts[..4 * lane];
        for t in tables.chunks_exact_mut(lane) {
            t[..nbins].fill(0);
        }
        let count = if map.fits(nbins) {
            // No bin check: every bin of the map is a bin of the tables.
            let (t01, t23) = tables.split_at_mut(2 * lane);
            let (t0, t1) = t01.split_at_mut(lane);
            let (t2, t3) = t23.split_at_mut(lane);
            let mut t = [fixed(t0), fixed(t1), fixed(t2), fixed(t3)];
            // Counting is order-free: the rows above and below the hole,
            // then the strips left and right of it, each a block of rows
            // with one span.
            let m = (y_hi - y_lo) as usize / step + 1;
            let (ja, jb, ka, kb) = match skip {
                Some((y0, y1, ka, kb)) => {
                    let y = |j: usize| (y_lo + (j * step) as i64) as f64;
                    let lo = partition(m, |j| y(j) < y0);
                    let hi = partition(m, |j| y(j) <= y1).max(lo);
                    (lo, hi, ka, kb)
                }
                None => (m, m, n, n),
            };
            let block = |t: &mut _, j0: usize, j1: usize, k0: usize, k1: usize| {
                let rows = Block {
                    start: rows.start + j0 * rows.stride,
                    stride: rows.stride,
                    rows: j1.max(j0) - j0,
                };
                count_block(t, &map.bins, rows, k0, k1, step)
            };
            block(&mut t, 0, ja, 0, n)
                + block(&mut t, jb, m, 0, n)
                + block(&mut t, ja, jb, 0, ka)
                + block(&mut t, ja, jb, kb, n)
        } else {
            let mut count = 0usize;
            rows.each(&map.bins, |row| {
                for (j, &b) in row.iter().enumerate() {
                    // The table's bounds test is the bin check: the first
                    // bad bin in pixel order is the error, as pixel by
                    // pixel.
                    match tables.get_mut((j & 3) * lane + usize::from(b)) {
                        Some(c) if usize::from(b) < nbins => *c += 1,
                        _ => return Err(incompatible(usize::from(b), nbins)),
                    }
                }
                count += row.len();
                Ok(())
            })?;
            count
        };
        self.total_counts(nbins, lane, count);
        Ok(())
    }

    /// The weights from the integer tables of [`KernelHistogram::uniform`]
    /// (each `lane` entries) and `count` pixels, normalised.
    fn total_counts(&mut self, nbins: usize, lane: usize, count: usize) {
        let c = &self.counts;
        let (c0, c1, c2, c3) = (
            &c[..nbins],
            &c[lane..lane + nbins],
            &c[2 * lane..2 * lane + nbins],
            &c[3 * lane..3 * lane + nbins],
        );
        self.total = count as f32;
        let scale = if self.total > 0.0 {
            1.0 / self.total
        } else {
            1.0
        };
        if count < 1 << 24 {
            // Every bin's count is below 2^24: its four parts add in `u32`
            // and convert to `f32` exactly, no clamp (vector lanes); times
            // `1 / total` as `finish` would (a kernel: vector lanes of the
            // best level, exact at every one).
            SimdLevel::Avx512.run(CountWeights {
                counts: [c0, c1, c2, c3],
                scale,
                weights: &mut self.weights,
            });
        } else {
            for (u, w) in self.weights.iter_mut().enumerate() {
                let c = [c0[u], c1[u], c2[u], c3[u]]
                    .iter()
                    .map(|&v| u64::from(v))
                    .sum::<u64>();
                *w = c.min(1 << 24) as f32 * scale;
            }
        }
    }

    /// The background weights of Ning, Zhang, Zhang and Wu ("Robust
    /// mean-shift tracking with corrected background-weighted histogram",
    /// IET Computer Vision 2012) from a background histogram `o` (`self`):
    /// `v_u = min(o* / o_u, 1)`, `o*` the smallest non-zero bin; bins absent
    /// from the background weigh 1. Colours common around the target then
    /// count little in the target model (see [`KernelHistogram::reweight`]).
    pub fn background_weights(&self) -> Vec<f32> {
        let floor = self
            .weights
            .iter()
            .copied()
            .filter(|&o| o > 0.0)
            .fold(f32::INFINITY, f32::min);
        self.weights
            .iter()
            .map(|&o| if o > 0.0 { (floor / o).min(1.0) } else { 1.0 })
            .collect()
    }

    /// Multiplies bin `u` by `v[u]` and renormalises (an all-zero result
    /// leaves the histogram empty).
    ///
    /// # Errors
    /// [`AppearanceError::Incompatible`] for a different length;
    /// [`AppearanceError::InvalidParameter`] for negative or non-finite
    /// weights.
    pub fn reweight(&mut self, v: &[f32]) -> Result<()> {
        if v.len() != self.weights.len() {
            return Err(AppearanceError::Incompatible {
                operation: "reweight",
                detail: format!("{} weights for {} bins", v.len(), self.weights.len()),
            });
        }
        if !v.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(AppearanceError::InvalidParameter {
                name: "bin weights",
                value: format!("{v:?}"),
                reason: "must be finite and >= 0",
            });
        }
        let s: f32 = self.weights.iter().zip(v).map(|(&w, &k)| w * k).sum();
        if (f32::MIN_POSITIVE..=f32::MAX).contains(&s) {
            for (w, &k) in self.weights.iter_mut().zip(v) {
                *w = *w * k / s;
            }
        } else if s == 0.0 {
            self.weights.fill(0.0);
            self.total = 0.0;
        } else {
            // the f32 sum is subnormal (bin weights of 1e-44 turned a
            // 0.75 / 0.25 split into 0.71 / 0.29) or overflowed:
            // products (exact) and sum in f64
            let s: f64 = self
                .weights
                .iter()
                .zip(v)
                .map(|(&w, &k)| f64::from(w) * f64::from(k))
                .sum();
            for (w, &k) in self.weights.iter_mut().zip(v) {
                *w = (f64::from(*w) * f64::from(k) / s) as f32;
            }
        }
        Ok(())
    }

    /// The Bhattacharyya coefficient `sum sqrt(p_u q_u)` in `[0, 1]`
    /// (0 when either histogram is empty).
    ///
    /// # Errors
    /// [`AppearanceError::Incompatible`] for different bin counts.
    pub fn bhattacharyya(&self, other: &Self) -> Result<f64> {
        if self.weights.len() != other.weights.len() {
            return Err(AppearanceError::Incompatible {
                operation: "bhattacharyya",
                detail: format!("{} vs {} bins", self.weights.len(), other.weights.len()),
            });
        }
        let rho = SimdLevel::Avx512.run(Bhattacharyya {
            p: &self.weights,
            q: &other.weights,
        });
        Ok(f64::from(rho).min(1.0))
    }

    /// `self = (1 - alpha) self + alpha other` (model update), renormalised.
    ///
    /// # Errors
    /// [`AppearanceError::Incompatible`] for different bin counts;
    /// [`AppearanceError::InvalidParameter`] for `alpha` outside `[0, 1]`.
    pub fn blend(&mut self, other: &Self, alpha: f64) -> Result<()> {
        if self.weights.len() != other.weights.len() {
            return Err(AppearanceError::Incompatible {
                operation: "blend",
                detail: format!("{} vs {} bins", self.weights.len(), other.weights.len()),
            });
        }
        if !(0.0..=1.0).contains(&alpha) {
            return Err(AppearanceError::InvalidParameter {
                name: "alpha",
                value: alpha.to_string(),
                reason: "must be in [0, 1]",
            });
        }
        if other.total <= 0.0 {
            return Ok(());
        }
        let a = alpha as f32;
        for (w, o) in self.weights.iter_mut().zip(&other.weights) {
            *w = (1.0 - a) * *w + a * o;
        }
        let s: f32 = self.weights.iter().sum();
        if s > 0.0 {
            self.weights.iter_mut().for_each(|w| *w /= s);
            self.total = self.total.max(1.0);
        }
        Ok(())
    }
}

/// The weights `(c0 + c1 + c2 + c3) as f32 * scale` of four count tables
/// (each sum below 2^24: exact in `f32` at every level).
struct CountWeights<'a> {
    counts: [&'a [u32]; 4],
    scale: f32,
    weights: &'a mut [f32],
}

impl Kernel for CountWeights<'_> {
    type Output = ();
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let [c0, c1, c2, c3] = self.counts;
        let parts = c0.iter().zip(c1).zip(c2).zip(c3);
        for (w, (((&a, &b), &c), &d)) in self.weights.iter_mut().zip(parts) {
            *w = (a + b + c + d) as f32 * self.scale;
        }
    }
}

/// `sum_u sqrt(p_u q_u)` over the bins with `p_u > 0`, in bin order.
struct Bhattacharyya<'a> {
    p: &'a [f32],
    q: &'a [f32],
}

impl Kernel for Bhattacharyya<'_> {
    type Output = f32;
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> f32 {
        // The terms `sqrt(p_u q_u)` of the bins with `p_u > 0` summed in bin
        // order; a left-out bin's term is -0, which adds nothing to any sum
        // (`x + -0 == x`, zeros included), so the terms come in blocks
        // (vector lanes of the level; a square root is exact in every
        // lane) and the sum is that of the filtered terms, bit for bit.
        let mut terms = [0f32; 64];
        let mut rho = std::iter::empty::<f32>().sum::<f32>();
        for (p, q) in self.p.chunks(64).zip(self.q.chunks(64)) {
            let terms = &mut terms[..p.len()];
            for ((t, &p), &q) in terms.iter_mut().zip(p).zip(q) {
                let term = (p * q).sqrt();
                *t = if p > 0.0 { term } else { -0.0 };
            }
            for &t in terms.iter() {
                rho += t;
            }
        }
        rho
    }
}

/// Whether `dx2` does not rise up to `kmin` and does not fall after it
/// (false with a NaN): the span of a row is then exactly the entries below
/// its threshold, and every one of them has a positive weight.
fn unimodal(dx2: &[f32], kmin: usize) -> bool {
    dx2[..=kmin].windows(2).all(|p| p[0] >= p[1]) && dx2[kmin..].windows(2).all(|p| p[0] <= p[1])
}

/// The sampled rows of an ellipse in a bin map: rows `y.0, y.0 + step,
/// ..= y.1` (frame coordinates), each with `dy2 = ((y - cy)^2 ib2) as
/// f32`; the first one's first sampled column at `start` in the map's bins,
/// the next row's `stride` further.
struct Rows {
    y: (i64, i64),
    cy: f64,
    ib2: f64,
    start: usize,
    stride: usize,
}

/// [`KernelHistogram::ellipse`] on a map whose bins all fit `weights`
/// (`BinMap::fits`) with unimodal column offsets (`unimodal`). The same
/// weights added in the same order as the checked loop (so the same bits),
/// into a fixed table with no bin check; each row's span is found by
/// moving the previous row's ends, out where the threshold `1 - dy2`
/// rises and in where it falls. Leaves the normalised weights in `weights` and returns the
/// total weight. A [`Kernel`]: the same scalar operations at every level
/// (no vectors, no fused multiply-add), compiled with the level's
/// instruction encoding (AVX's three-operand forms save a copy a pixel).
struct EllipseFast<'a> {
    bins: &'a [u16],
    rows: Rows,
    dx2: &'a [f32],
    kmin: usize,
    step: usize,
    weights: &'a mut [f32],
}

impl Kernel for EllipseFast<'_> {
    type Output = f32;
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> f32 {
        // A copy of the loop for step 1 (the common one), its step a
        // constant.
        if self.step == 1 {
            ellipse_fast::<true>(self)
        } else {
            ellipse_fast::<false>(self)
        }
    }
}

/// The loop of [`EllipseFast`]; `STEP1`: `k.step` is 1.
#[inline(always)]
fn ellipse_fast<const STEP1: bool>(k: EllipseFast<'_>) -> f32 {
    let EllipseFast {
        bins,
        rows,
        dx2,
        kmin,
        step,
        weights,
    } = k;
    let step = if STEP1 { 1 } else { step };
    let mut acc = [0f32; FAST_BINS];
    let mut total = 0f32;
    // The empty span, inside every row's.
    let (mut lo, mut hi, mut t_span) = (kmin + 1, kmin, f32::NEG_INFINITY);
    let left = &dx2[..=kmin];
    let Rows {
        y: (mut y, y_end),
        cy,
        ib2,
        mut start,
        stride,
    } = rows;
    while y <= y_end {
        let row = start;
        let dy2 = ((y as f64 - cy).powi(2) * ib2) as f32;
        y += step as i64;
        start += stride;
        // A NaN row is skipped too: the checked loop refuses its (NaN)
        // weights one by one.
        if dy2.is_nan() || dy2 >= 1.0 {
            continue;
        }
        let t = 1.0 - dy2;
        // lo: the first k <= kmin with dx2[k] < t (kmin + 1 if none);
        // hi: the first k >= kmin with dx2[k] >= t (the length if none).
        // The span of the last row counted (threshold `t_span`) lies
        // inside this row's when `t >= t_span` (the ends only move out)
        // and holds it otherwise (they only move in).
        // (`get` is the bound test: `lo - 1` wraps past the end at 0.)
        if t >= t_span {
            while let Some(&d) = dx2.get(lo.wrapping_sub(1))
                && d < t
            {
                lo -= 1;
            }
            while let Some(&d) = dx2.get(hi)
                && d < t
            {
                hi += 1;
            }
        } else {
            while let Some(&d) = left.get(lo)
                && d >= t
            {
                lo += 1;
            }
            while hi > kmin
                && let Some(&d) = dx2.get(hi - 1)
                && d >= t
            {
                hi -= 1;
            }
        }
        t_span = t;
        if lo >= hi {
            continue;
        }
        let dxs = &dx2[lo..hi];
        let first = row + lo * step;
        let mut add = |bin: u16, d: f32| {
            let w = t - d;
            acc[usize::from(bin as u8)] += w;
            total += w;
        };
        if STEP1 {
            for (&bin, &d) in bins[first..first + dxs.len()].iter().zip(dxs) {
                add(bin, d);
            }
        } else {
            let span = &bins[first..first + (dxs.len() - 1) * step + 1];
            let mut i = 0;
            for &d in dxs {
                add(span[i], d);
                i += step;
            }
        }
    }
    let acc = &acc[..weights.len()];
    if total > 0.0 {
        let inv = 1.0 / total;
        for (w, &a) in weights.iter_mut().zip(acc) {
            *w = a * inv;
        }
    } else {
        weights.copy_from_slice(acc);
    }
    total
}

/// The sampled rows of a uniform box or ring in a bin map: rows `y.0,
/// y.0 + step, ..= y.1` (frame coordinates), the first one's counted
/// columns from `start` in the map's bins (`len` entries, every `step`-th
/// one counted: `n`), the next row's `stride` further; `skip` the hole's
/// rows `[y0, y1]` and counted-column range `ka..kb`.
struct UniformRows {
    y: (i64, i64),
    step: usize,
    start: usize,
    stride: usize,
    len: usize,
    n: usize,
    skip: Option<(f64, f64, usize, usize)>,
}

impl UniformRows {
    /// Calls `f(pixels)` for every counted span of every row in pixel
    /// order with the bins of its counted pixels (copied when `step > 1`,
    /// at most 64 at a time). Stops at the first error.
    fn each(&self, bins: &[u16], mut f: impl FnMut(&[u16]) -> Result<()>) -> Result<()> {
        let (n, step) = (self.n, self.step);
        let mut gathered = [0u16; 64];
        let mut span = |row: &[u16], k0: usize, k1: usize| -> Result<()> {
            if k0 >= k1 {
                return Ok(());
            }
            if step == 1 {
                return f(&row[k0..k1]);
            }
            // Gather every step-th bin, 64 at a time.
            let mut k = k0;
            while k < k1 {
                let m = (k1 - k).min(gathered.len());
                for (g, &b) in gathered[..m]
                    .iter_mut()
                    .zip(row[k * step..].iter().step_by(step))
                {
                    *g = b;
                }
                f(&gathered[..m])?;
                k += m;
            }
            Ok(())
        };
        let (mut y, mut start) = (self.y.0, self.start);
        while y <= self.y.1 {
            let row = &bins[start..start + self.len];
            let (ka, kb) = match self.skip {
                Some((y0, y1, ka, kb)) if (y as f64) >= y0 && (y as f64) <= y1 => (ka, kb),
                _ => (n, n),
            };
            span(row, 0, ka)?;
            span(row, kb, n)?;
            y += step as i64;
            start += self.stride;
        }
        Ok(())
    }
}

/// One of the four count tables as a fixed array (indexed by a `u8`, no
/// bounds test).
fn fixed(t: &mut [u32]) -> &mut [u32; FAST_BINS] {
    (&mut t[..FAST_BINS])
        .try_into()
        .expect("each table has FAST_BINS entries")
}

/// Rows of a bin map: `rows` rows, the first at `start`, each `stride`
/// after the previous.
#[derive(Clone, Copy)]
struct Block {
    start: usize,
    stride: usize,
    rows: usize,
}

/// Counts the counted pixels `k0..k1` (every `step`-th bin) of each row of
/// `b` into the four tables with no bin check (`BinMap::fits`); returns
/// the number counted. Rows go four at a time, row `i` of a group into
/// table `i` (pixels next to each other, along a row or down a column,
/// never wait on each other's stores; one loop of any step and width, no
/// remainder per row); the last `rows % 4` rows one by one.
#[inline(never)]
fn count_block(
    t: &mut [&mut [u32; FAST_BINS]; 4],
    bins: &[u16],
    b: Block,
    k0: usize,
    k1: usize,
    step: usize,
) -> usize {
    if b.rows == 0 || k0 >= k1 {
        return 0;
    }
    let (first, len) = (b.start + k0 * step, (k1 - k0 - 1) * step + 1);
    let block = &bins[first..first + (b.rows - 1) * b.stride + len];
    let stride = b.stride;
    let quads = b.rows / 4;
    for g in 0..quads {
        let at = 4 * g * stride;
        let rows = &block[at..at + 3 * stride + len];
        let (r0, rows) = rows.split_at(stride);
        let (r1, rows) = rows.split_at(stride);
        let (r2, r3) = rows.split_at(stride);
        let (r0, r1, r2, r3) = (&r0[..len], &r1[..len], &r2[..len], &r3[..len]);
        let [t0, t1, t2, t3] = &mut *t;
        let mut i = 0;
        while i < len {
            t0[usize::from(r0[i] as u8)] += 1;
            t1[usize::from(r1[i] as u8)] += 1;
            t2[usize::from(r2[i] as u8)] += 1;
            t3[usize::from(r3[i] as u8)] += 1;
            i += step;
        }
    }
    for r in 4 * quads..b.rows {
        let row = &block[r * stride..r * stride + len];
        count_span(t, row, 0, k1 - k0, step);
    }
    b.rows * (k1 - k0)
}

/// The first `j < m` with `!below(j)` (`m` if none), `below` true then
/// false over `0..m`.
fn partition(m: usize, below: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (0, m);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if below(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Counts the counted pixels `k0..k1` of `row` (every `step`-th bin)
/// into the four tables with no bin check (`BinMap::fits`).
#[inline(always)]
fn count_span(t: &mut [&mut [u32; FAST_BINS]; 4], row: &[u16], k0: usize, k1: usize, step: usize) {
    if k0 >= k1 {
        return;
    }
    if step == 1 {
        count_unchecked(t, &row[k0..k1]);
    } else {
        let bins = row[k0 * step..].iter().step_by(step).take(k1 - k0);
        for (j, &b) in bins.enumerate() {
            t[j & 3][usize::from(b as u8)] += 1;
        }
    }
}

/// Counts the bins of `row` into the four tables (pixel `j` of the span
/// into table `j % 4`: neighbours never wait on each other's stores), with
/// no bin check (`BinMap::fits`).
#[inline(always)]
fn count_unchecked(t: &mut [&mut [u32; FAST_BINS]; 4], row: &[u16]) {
    let mut quads = row.chunks_exact(4);
    for q in &mut quads {
        t[0][usize::from(q[0] as u8)] += 1;
        t[1][usize::from(q[1] as u8)] += 1;
        t[2][usize::from(q[2] as u8)] += 1;
        t[3][usize::from(q[3] as u8)] += 1;
    }
    for (j, &b) in quads.remainder().iter().enumerate() {
        t[j][usize::from(b as u8)] += 1;
    }
}

fn incompatible(bin: usize, bins: usize) -> AppearanceError {
    AppearanceError::Incompatible {
        operation: "kernel histogram",
        detail: format!("bin {bin} in the map, the histogram has {bins} bins"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    fn rgb(w: usize, h: usize, f: impl Fn(usize, usize) -> [u8; 3]) -> Image<u8> {
        let mut data = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                data.extend(f(x, y));
            }
        }
        Image::from_vec(w, h, 3, data).unwrap()
    }

    #[test]
    fn perez_binning() {
        let b = HsvBinning::perez();
        assert_eq!(b.len(), 110);
        // saturated red: hue 0, saturation 1 -> bin 0 * 10 + 9
        assert_eq!(b.bin_exact(Rgb::new(255, 0, 0)), 9);
        assert_eq!(b.bin_rgb(255, 0, 0), 9);
        // grey and dark pixels go to the value bins
        assert_eq!(b.bin_exact(Rgb::new(128, 128, 128)), 100 + 5);
        assert_eq!(b.bin_rgb(20, 0, 0), 100);
        assert_eq!(b.bin_gray(255), 109);
        assert_eq!(b.bin_gray(128), b.bin_rgb(128, 128, 128));
        // the table is exact at the centres of its 5-bit cells, and agrees
        // with the exact bins for most colours
        let mut agree = 0;
        for q in 0..4096u32 {
            let level = |s: u32| ((q >> s) & 15) as u8 * 16 + 8;
            let c = Rgb::new(level(8), level(4), level(0));
            let centre = Rgb::new(c.r >> 3 << 3 | 4, c.g >> 3 << 3 | 4, c.b >> 3 << 3 | 4);
            assert_eq!(b.bin_rgb(c.r, c.g, c.b), b.bin_exact(centre));
            agree += usize::from(b.bin_exact(c) == b.bin_rgb(c.r, c.g, c.b));
        }
        assert!(agree > 3400, "{agree}");
        assert!(HsvBinning::new(0, 10, 0.1, 0.2).is_err());
        assert!(HsvBinning::new(10, 0, 0.1, 0.2).is_err());
        assert!(HsvBinning::new(10, 10, 1.5, 0.2).is_err());
    }

    #[test]
    fn kernel_weights_favour_the_centre() {
        // left half red, right half green; a box centred on the red half's
        // right edge sees more red the further left its centre.
        let img = rgb(
            40,
            20,
            |x, _| if x < 20 { [220, 20, 20] } else { [20, 220, 20] },
        );
        let b = HsvBinning::perez();
        let mut map = BinMap::new();
        b.bin_map_into(img.view(), Rect::new(0, 0, 40, 20), &mut map)
            .unwrap();
        let mut h = KernelHistogram::new(b.len());
        h.ellipse(&map, 19.5, 9.5, 10.0, 8.0, 1).unwrap();
        let red = usize::from(b.bin_rgb(220, 20, 20));
        let green = usize::from(b.bin_rgb(20, 220, 20));
        assert!(
            (h.weights()[red] - 0.5).abs() < 0.02,
            "{:?}",
            h.weights()[red]
        );
        assert!((h.weights()[red] + h.weights()[green] - 1.0).abs() < 1e-5);
        h.ellipse(&map, 17.5, 9.5, 10.0, 8.0, 1).unwrap();
        let left = h.weights()[red];
        assert!(left > 0.6, "{left}");
        // subsampling keeps the picture
        h.ellipse(&map, 17.5, 9.5, 10.0, 8.0, 2).unwrap();
        assert!((h.weights()[red] - left).abs() < 0.05);
        // Bhattacharyya: 1 with itself, 0 with a disjoint histogram
        let mut g = KernelHistogram::new(b.len());
        g.ellipse(&map, 30.0, 9.5, 5.0, 5.0, 1).unwrap();
        assert!((h.bhattacharyya(&h).unwrap() - 1.0).abs() < 1e-5);
        let mut r = KernelHistogram::new(b.len());
        r.ellipse(&map, 8.0, 9.5, 5.0, 5.0, 1).unwrap();
        assert_eq!(r.bhattacharyya(&g).unwrap(), 0.0);
        // blend
        r.blend(&g, 0.25).unwrap();
        assert!((r.weights()[red] - 0.75).abs() < 1e-5 && (r.weights()[green] - 0.25).abs() < 1e-5);
    }

    #[test]
    fn background_weights_suppress_background_colours() {
        let b = HsvBinning::perez();
        let (red, green, blue) = (
            usize::from(b.bin_rgb(220, 20, 20)),
            usize::from(b.bin_rgb(20, 220, 20)),
            usize::from(b.bin_rgb(20, 20, 220)),
        );
        // background: 75 % green, 25 % blue
        let img = rgb(
            40,
            1,
            |x, _| if x < 30 { [20, 220, 20] } else { [20, 20, 220] },
        );
        let mut map = BinMap::new();
        b.bin_map_into(img.view(), Rect::new(0, 0, 40, 1), &mut map)
            .unwrap();
        let mut bg = KernelHistogram::new(b.len());
        bg.ring(&map, 100.0, 0.0, 1.0, 1.0, 200.0, 1).unwrap();
        let v = bg.background_weights();
        assert!((v[green] - 1.0 / 3.0).abs() < 1e-5 && v[blue] == 1.0 && v[red] == 1.0);
        // a target of half red, half green: green is down-weighted
        let img = rgb(
            20,
            1,
            |x, _| if x < 10 { [220, 20, 20] } else { [20, 220, 20] },
        );
        b.bin_map_into(img.view(), Rect::new(0, 0, 20, 1), &mut map)
            .unwrap();
        let mut t = KernelHistogram::new(b.len());
        t.ring(&map, 100.0, 0.0, 1.0, 1.0, 200.0, 1).unwrap();
        t.reweight(&v).unwrap();
        assert!(
            (t.weights()[red] - 0.75).abs() < 1e-5,
            "{}",
            t.weights()[red]
        );
        assert!((t.weights()[green] - 0.25).abs() < 1e-5);
        assert!(t.reweight(&v[..3]).is_err());
        let mut bad = v.clone();
        bad[0] = f32::NAN;
        assert!(t.reweight(&bad).is_err());
        // issue 28: subnormal bin weights lost the histogram's ratios
        // (a uniform reweighting leaves the 0.75 / 0.25 split as it is)
        for scale in [f32::MAX, 1e-44, 1e-40] {
            let mut u = t.clone();
            u.reweight(&vec![scale; b.len()]).unwrap();
            let w = u.weights();
            let sum: f32 = w.iter().sum();
            assert!(w.iter().all(|x| x.is_finite()), "{scale}");
            assert!((sum - 1.0).abs() < 1e-5, "{scale}: {sum}");
            assert!((w[red] - 0.75).abs() < 1e-5, "{scale}: {}", w[red]);
        }
        t.reweight(&vec![0.0; b.len()]).unwrap();
        assert_eq!(t.total(), 0.0);
    }

    /// The Epanechnikov histogram pixel by pixel over the bounding box,
    /// each pixel tested (the code before row spans): weights before
    /// normalisation, total.
    fn ellipse_reference(
        map: &BinMap,
        (cx, cy): (f64, f64),
        (a, b): (f64, f64),
        step: usize,
        nbins: usize,
    ) -> (Vec<f32>, f32) {
        let mut weights = vec![0f32; nbins];
        let r = map.rect;
        let (fx, x_lo, x_hi) = BinMap::span(cx, a, r.x, r.width);
        let (fy, y_lo, y_hi) = BinMap::span(cy, b, r.y, r.height);
        let align = |first: f64, lo: i64| -> i64 {
            let off = (lo as f64 - first) as i64;
            lo + (step as i64 - off.rem_euclid(step as i64)) % step as i64
        };
        let (x_start, y_start) = (align(fx, x_lo), align(fy, y_lo));
        let mut total = 0f32;
        if x_start > x_hi || y_start > y_hi {
            return (weights, total);
        }
        let (ia2, ib2) = (1.0 / (a * a), 1.0 / (b * b));
        let dx2: Vec<f32> = (x_start..=x_hi)
            .step_by(step)
            .map(|x| ((x as f64 - cx).powi(2) * ia2) as f32)
            .collect();
        for y in (y_start..=y_hi).step_by(step) {
            let dy2 = ((y as f64 - cy).powi(2) * ib2) as f32;
            if dy2 >= 1.0 {
                continue;
            }
            let row = (y as usize - r.y) * r.width;
            for (k, &d) in dx2.iter().enumerate() {
                let w = 1.0 - dy2 - d;
                if w > 0.0 {
                    let x = x_start as usize + k * step - r.x;
                    weights[usize::from(map.bins[row + x])] += w;
                    total += w;
                }
            }
        }
        if total > 0.0 {
            let inv = 1.0 / total;
            weights.iter_mut().for_each(|v| *v *= inv);
        }
        (weights, total)
    }

    /// The uniform histogram pixel by pixel with the hole tested on each
    /// (the code before row spans): weights before normalisation, count.
    fn uniform_reference(
        map: &BinMap,
        c: (f64, f64),
        half: (f64, f64),
        hole: Option<[f64; 4]>,
        step: usize,
        nbins: usize,
    ) -> (Vec<f32>, f32) {
        let mut w = vec![0f32; nbins];
        let r = map.rect;
        let (_, x_lo, x_hi) = BinMap::span(c.0, half.0, r.x, r.width);
        let (_, y_lo, y_hi) = BinMap::span(c.1, half.1, r.y, r.height);
        let mut count = 0usize;
        if x_lo <= x_hi && y_lo <= y_hi {
            for y in (y_lo..=y_hi).step_by(step) {
                for x in (x_lo..=x_hi).step_by(step) {
                    let (xf, yf) = (x as f64, y as f64);
                    if hole.is_some_and(|h| xf >= h[0] && xf <= h[1] && yf >= h[2] && yf <= h[3]) {
                        continue;
                    }
                    let row = (y as usize - r.y) * r.width;
                    w[usize::from(map.bins[row + x as usize - r.x])] += 1.0;
                    count += 1;
                }
            }
        }
        let total = count as f32;
        if total > 0.0 {
            let inv = 1.0 / total;
            w.iter_mut().for_each(|v| *v *= inv);
        }
        (w, total)
    }

    /// A 36 x 28 noise frame; `blocky`: in blocks of 5 x 3 pixels of one
    /// colour (runs of one bin, as in real video).
    fn test_image(seed: u32, blocky: bool) -> Image<u8> {
        let n = bayestrack_testkit::noise(36, 28, 3, seed);
        let d = if blocky { (5, 3) } else { (1, 1) };
        rgb(36, 28, |x, y| {
            let (x, y) = (x / d.0 * d.0, y / d.1 * d.1);
            [0, 1, 2].map(|c| n.get(x, y, c).unwrap())
        })
    }

    /// The Bhattacharyya coefficient as first written (filtered terms,
    /// summed by `Sum`).
    fn bhattacharyya_reference(p: &[f32], q: &[f32]) -> f64 {
        let rho: f32 = p
            .iter()
            .zip(q)
            .filter(|(p, _)| **p > 0.0)
            .map(|(p, q)| (p * q).sqrt())
            .sum();
        f64::from(rho).min(1.0)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(128))]
        /// The bin map of an RGB region at every SIMD level is the table
        /// lookup pixel by pixel: regions of every width (odd, below and
        /// above a vector) and place.
        #[test]
        fn rgb_bin_map_matches_the_per_pixel_lookup(
            seed in 0u32..1000,
            x in 0usize..36,
            y in 0usize..28,
            w in 1usize..37,
            h in 1usize..29,
        ) {
            let img = test_image(seed, false);
            let (w, h) = (w.min(36 - x), h.min(28 - y));
            let rect = Rect::new(x, y, w, h);
            let binning = HsvBinning::perez();
            let mut map = BinMap::new();
            let other = test_image(seed + 1, false);
            for level in SimdLevel::ALL {
                // a map that held another frame first: every entry rewritten
                binning.bin_map_into(other.view(), Rect::new(0, 0, 36, 28), &mut map).unwrap();
                binning.bin_map_at(level, img.view(), rect, &mut map).unwrap();
                proptest::prop_assert_eq!(map.rect(), rect);
                proptest::prop_assert_eq!(map.bins.len(), w * h);
                for v in y..y + h {
                    for u in x..x + w {
                        let p = img.view().pixel(u, v).unwrap();
                        let want = binning.bin_rgb(p[0], p[1], p[2]);
                        proptest::prop_assert_eq!(map.get(u, v), Some(want), "{:?} at {} {}", level, u, v);
                    }
                }
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// The count and Bhattacharyya kernels at every SIMD level give the
        /// plain loops' bits: lengths below, at and above a vector and a
        /// block, empty and zero bins, sums of 0 and -0.
        #[test]
        fn count_and_bhattacharyya_kernels_match_at_every_level(
            seed in 0u32..1000,
            n in 0usize..140,
            sparse in proptest::bool::ANY,
        ) {
            let bytes = bayestrack_testkit::noise_bytes(16 * n, seed);
            // bytes 0..8n: the counts (two bytes each); 8n..: p and q
            let byte = |k: usize| u32::from(bytes[k]);
            let counts: Vec<Vec<u32>> = (0..4)
                .map(|t| {
                    (0..n)
                        .map(|u| {
                            let k = 2 * (t * n + u);
                            if sparse && byte(k) % 3 > 0 { 0 } else { byte(k) * 20 + byte(k + 1) }
                        })
                        .collect()
                })
                .collect();
            let p: Vec<f32> = (0..n)
                .map(|u| {
                    let b = byte(8 * n + u);
                    if sparse && b % 2 > 0 { 0.0 } else { b as f32 / 997.0 }
                })
                .collect();
            let q: Vec<f32> = (0..n).map(|u| byte(12 * n + u) as f32 / 991.0).collect();
            let scale = 1.0 / 12345.0f32;
            let want_w: Vec<f32> = (0..n)
                .map(|u| (counts[0][u] + counts[1][u] + counts[2][u] + counts[3][u]) as f32 * scale)
                .collect();
            let want_rho = bhattacharyya_reference(&p, &q);
            for level in SimdLevel::ALL {
                let mut w = vec![f32::NAN; n];
                level.run(CountWeights {
                    counts: [&counts[0], &counts[1], &counts[2], &counts[3]],
                    scale,
                    weights: &mut w,
                });
                proptest::prop_assert!(w.iter().zip(&want_w).all(|(a, b)| a.to_bits() == b.to_bits()), "{:?}", level);
                let rho = level.run(Bhattacharyya { p: &p, q: &q });
                proptest::prop_assert_eq!(f64::from(rho).min(1.0).to_bits(), want_rho.to_bits(), "{:?}", level);
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// The Bhattacharyya coefficient in blocks of terms is the filtered
        /// sum bit for bit: empty and sparse histograms, more bins than a
        /// block, sums of 0 and -0.
        #[test]
        fn bhattacharyya_blocks_match_the_filtered_sum(
            seed in 0u32..1000,
            cx in -10.0f64..45.0,
            a in 0.3f64..8.0,
            wide in proptest::bool::ANY,
        ) {
            let img = test_image(seed, false);
            let binning = if wide { HsvBinning::new(17, 10, 0.1, 0.2).unwrap() } else { HsvBinning::perez() };
            let mut map = BinMap::new();
            binning.bin_map_into(img.view(), Rect::new(0, 0, 36, 28), &mut map).unwrap();
            let mut p = KernelHistogram::new(binning.len());
            let mut q = KernelHistogram::new(binning.len());
            p.ellipse(&map, cx, 14.0, a, a, 1).unwrap();
            q.ellipse(&map, 18.0, 14.0, 12.0, 9.0, 1).unwrap();
            for (p, q) in [(&p, &q), (&q, &p), (&p, &p)] {
                let got = p.bhattacharyya(q).unwrap();
                let want = bhattacharyya_reference(p.weights(), q.weights());
                proptest::prop_assert_eq!(got.to_bits(), want.to_bits());
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Rings and boxes by row spans give the per-pixel histograms bit
        /// for bit: every step, boxes partly or wholly off the map, holes
        /// on fractional and integer edges, noise and runs of one bin.
        #[test]
        fn uniform_spans_match_the_per_pixel_reference(
            seed in 0u32..1000,
            cx in -6.0f64..40.0,
            cy in -6.0f64..30.0,
            a in 0.5f64..12.0,
            b in 0.5f64..12.0,
            outer in 1.01f64..3.0,
            step in 1usize..5,
            integer_edges in proptest::bool::ANY,
            wide in proptest::bool::ANY,
            blocky in proptest::bool::ANY,
        ) {
            let img = test_image(seed, blocky);
            // wide: 299 bins, more than the unchecked table's 256 (the
            // checked loop)
            let binning = if wide { HsvBinning::new(17, 10, 0.1, 0.2).unwrap() } else { HsvBinning::perez() };
            let mut map = BinMap::new();
            binning.bin_map_into(img.view(), Rect::new(3, 2, 30, 24), &mut map).unwrap();
            // integer_edges: the hole's edges on pixel centres
            let (cx, cy) = if integer_edges { (cx.round(), cy.round() + 0.5) } else { (cx, cy) };
            let (a, b) = if integer_edges { (a.round().max(1.0), b.round().max(1.0) + 0.5) } else { (a, b) };
            let mut h = KernelHistogram::new(binning.len());
            h.ring(&map, cx, cy, a, b, outer, step).unwrap();
            let hole = [cx - a, cx + a, cy - b, cy + b];
            let (w, total) =
                uniform_reference(&map, (cx, cy), (a * outer, b * outer), Some(hole), step, binning.len());
            proptest::prop_assert_eq!(h.total().to_bits(), total.to_bits());
            proptest::prop_assert!(h.weights().iter().zip(&w).all(|(p, q)| p.to_bits() == q.to_bits()));
            h.rect(&map, cx, cy, a, b, step).unwrap();
            let (w, total) = uniform_reference(&map, (cx, cy), (a, b), None, step, binning.len());
            proptest::prop_assert_eq!(h.total().to_bits(), total.to_bits());
            proptest::prop_assert!(h.weights().iter().zip(&w).all(|(p, q)| p.to_bits() == q.to_bits()));
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]
        /// Ellipses by row spans give the per-pixel histograms bit for bit:
        /// every step, ellipses partly or wholly off the map, centres on
        /// pixel centres and between them, thin and round ones, noise and
        /// runs of one bin (summed in a register); the kernel at every
        /// SIMD level.
        #[test]
        fn ellipse_spans_match_the_per_pixel_reference(
            seed in 0u32..1000,
            cx in -8.0f64..42.0,
            cy in -8.0f64..32.0,
            a in 0.3f64..25.0,
            b in 0.3f64..25.0,
            step in 1usize..5,
            on_grid in 0u8..3,
            wide in proptest::bool::ANY,
            blocky in proptest::bool::ANY,
        ) {
            let img = test_image(seed, blocky);
            // wide: 299 bins, more than the unchecked table's 256 (the
            // checked loop)
            let binning = if wide { HsvBinning::new(17, 10, 0.1, 0.2).unwrap() } else { HsvBinning::perez() };
            let mut map = BinMap::new();
            binning.bin_map_into(img.view(), Rect::new(3, 2, 30, 24), &mut map).unwrap();
            // on_grid: centres on pixel centres or halfway, integer axes
            let (cx, cy, a, b) = match on_grid {
                0 => (cx, cy, a, b),
                1 => (cx.round(), cy.round(), a.round().max(1.0), b.round().max(1.0)),
                _ => (cx.round() + 0.5, cy.round() + 0.5, a.round() + 0.5, b.round() + 0.5),
            };
            let (w, total) = ellipse_reference(&map, (cx, cy), (a, b), step, binning.len());
            let mut h = KernelHistogram::new(binning.len());
            h.ellipse(&map, cx, cy, a, b, step).unwrap();
            proptest::prop_assert_eq!(h.total().to_bits(), total.to_bits());
            proptest::prop_assert!(h.weights().iter().zip(&w).all(|(p, q)| p.to_bits() == q.to_bits()));
            // the kernel at every level (each this CPU runs; the others run
            // at the best it has)
            for level in SimdLevel::ALL {
                let mut h = KernelHistogram::new(binning.len());
                h.ellipse_at(level, &map, (cx, cy), (a, b), step).unwrap();
                proptest::prop_assert_eq!(h.total().to_bits(), total.to_bits(), "{:?}", level);
                proptest::prop_assert!(h.weights().iter().zip(&w).all(|(p, q)| p.to_bits() == q.to_bits()), "{:?}", level);
            }
        }
    }

    #[test]
    fn ring_sees_the_surroundings_only() {
        // a red 10x10 square in a green field
        let img = rgb(40, 40, |x, y| {
            if (15..25).contains(&x) && (15..25).contains(&y) {
                [220, 20, 20]
            } else {
                [20, 220, 20]
            }
        });
        let b = HsvBinning::perez();
        let mut map = BinMap::new();
        b.bin_map_into(img.view(), Rect::new(0, 0, 40, 40), &mut map)
            .unwrap();
        let mut ring = KernelHistogram::new(b.len());
        ring.ring(&map, 19.5, 19.5, 5.0, 5.0, 1.6, 1).unwrap();
        let green = usize::from(b.bin_rgb(20, 220, 20));
        assert!((ring.weights()[green] - 1.0).abs() < 1e-6);
        // a too-small box: its ring lies on the target
        ring.ring(&map, 19.5, 19.5, 2.5, 2.5, 1.6, 1).unwrap();
        assert_eq!(ring.weights()[green], 0.0);
        // the box itself: all red, 10 x 10 pixels
        ring.rect(&map, 19.5, 19.5, 5.0, 5.0, 1).unwrap();
        assert_eq!(ring.total(), 100.0);
        assert!((ring.weights()[usize::from(b.bin_rgb(220, 20, 20))] - 1.0).abs() < 1e-6);
        // windows entirely outside the map count nothing
        ring.ellipse(&map, 100.0, 100.0, 3.0, 3.0, 1).unwrap();
        assert_eq!(ring.total(), 0.0);
    }

    #[test]
    fn gray_frames_fill_the_value_bins() {
        let img = Image::from_fn(20, 10, |x, _| (x * 12) as u8).unwrap();
        let b = HsvBinning::perez();
        let mut map = BinMap::new();
        b.bin_map_into(img.view(), Rect::new(2, 1, 16, 8), &mut map)
            .unwrap();
        assert_eq!(map.get(0, 0), None);
        assert_eq!(map.get(10, 5), Some(b.bin_gray(120)));
        let mut h = KernelHistogram::new(b.len());
        h.ellipse(&map, 9.5, 4.5, 6.0, 3.0, 1).unwrap();
        assert!(h.weights()[..100].iter().all(|&w| w == 0.0));
        assert!((h.weights().iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn bad_input_is_an_error() {
        let b = HsvBinning::perez();
        let mut map = BinMap::new();
        let two = Image::new(4, 4, 2, 0u8).unwrap();
        assert!(
            b.bin_map_into(two.view(), Rect::new(0, 0, 2, 2), &mut map)
                .is_err()
        );
        let gray = Image::new(4, 4, 1, 0u8).unwrap();
        assert!(matches!(
            b.bin_map_into(gray.view(), Rect::new(3, 0, 2, 2), &mut map),
            Err(AppearanceError::WindowOutside { .. })
        ));
        b.bin_map_into(gray.view(), Rect::new(0, 0, 4, 4), &mut map)
            .unwrap();
        let mut h = KernelHistogram::new(b.len());
        assert!(h.ellipse(&map, f64::NAN, 1.0, 1.0, 1.0, 1).is_err());
        assert!(h.ellipse(&map, 1.0, 1.0, 0.0, 1.0, 1).is_err());
        assert!(h.ellipse(&map, 1.0, 1.0, 1.0, 1.0, 0).is_err());
        assert!(h.ring(&map, 1.0, 1.0, 1.0, 1.0, 1.0, 1).is_err());
        let mut small = KernelHistogram::new(5);
        assert!(matches!(
            small.ellipse(&map, 1.5, 1.5, 2.0, 2.0, 1),
            Err(AppearanceError::Incompatible { .. })
        ));
        assert!(h.bhattacharyya(&small).is_err());
        assert!(h.blend(&small, 0.5).is_err());
        let h2 = h.clone();
        assert!(h.blend(&h2, 1.5).is_err());
    }
}
