//! Features of a patch: Felzenszwalb's HOG as computed by Dollár's
//! toolbox (`fhog`, the variant KCF, DSST and Staple use) and a gray
//! intensity channel.
//!
//! # fHOG
//! For a `w x h` gray patch and a cell of `b` pixels ([`Fhog::new`]) the
//! output has `floor(w / b) x floor(h / b)` cells and [`HOG_CHANNELS`] = 31
//! channels, stored channel after channel, each row-major (the layout the
//! FFTs take):
//!
//! 1. **Gradients** by central differences `(I[x+1] - I[x-1]) / 2` inside
//!    the patch, one-sided `I[1] - I[0]` on its border; magnitude `m` and
//!    orientation `theta = atan2(gy, gx)` in `[0, 2 pi)` (y down).
//! 2. **Binning.** Each pixel's orientation goes to the nearest of 18
//!    contrast-sensitive bins (`round(18 theta / 2 pi) mod 18`; the
//!    toolbox's `softBin = -1`), its magnitude divided by `b^2` spread
//!    bilinearly over the four nearest cell centres (pixel `x` sits at
//!    `(x + 0.5) / b - 0.5` in cell units; shares outside the cell grid
//!    are dropped). Pixels beyond the last whole cell are ignored.
//! 3. **Normalisation.** The 9 contrast-insensitive histograms are the
//!    sums of opposite sensitive bins; each 2x2 block of cells gets
//!    `1 / sqrt(energy + eps)` from the insensitive histograms' energy
//!    (`eps = 1e-4 / (4 b^4)`), blocks past the grid's edge replicating
//!    the nearest. A cell's value in each channel is the sum over the four
//!    blocks that contain it of `min(h n_block, 0.2)`, times `0.2357`.
//! 4. **Channels**: 0..18 contrast-sensitive, 18..27 insensitive, 27..31
//!    texture (per block: the clipped normalised sensitive bins summed
//!    over the orientations). The toolbox's 32nd (all-zero truncation)
//!    channel is not produced.
//!
//! A patch of fewer than 2x2 cells has no block: all features are 0.

use bayestrack_image::simd::{Kernel, SimdLevel, Token};

use crate::error::{DcfError, Result};

/// Channels of the fHOG output.
pub const HOG_CHANNELS: usize = 31;

/// Contrast-sensitive orientation bins.
const SENSITIVE: usize = 18;
/// Contrast-insensitive orientation bins.
const INSENSITIVE: usize = 9;
/// Clip of the normalised histogram values (Felzenszwalb's 0.2).
const CLIP: f32 = 0.2;
/// The toolbox's scale of the summed normalisations (about 1/sqrt(18)).
const R: f32 = 0.2357;

/// fHOG of patches of one size, with its scratch buffers (no allocation
/// per patch).
#[derive(Debug, Clone)]
pub struct Fhog {
    w: usize,
    h: usize,
    cell: usize,
    wb: usize,
    hb: usize,
    /// Gradients along x and y, per pixel.
    gx: Vec<f32>,
    gy: Vec<f32>,
    /// Per pixel: its magnitude divided by `b^2` (what its shares split)
    /// and its bin (as wide as the gradients: the vector loop that finds
    /// them keeps its lanes that wide).
    mag: Vec<f32>,
    bin: Vec<u32>,
    sensitive: Vec<f32>,
    /// Per pixel of the whole cells' rows (`hb * cell` rows of `w`): the
    /// offset of its left cells' pair in a bin's plane of a band (see
    /// [`Fhog::histograms`]; 0 past the last whole cell, never read), then
    /// (scratch) that offset plus its bin's plane.
    px_col: Vec<u32>,
    tops: Vec<u32>,
    /// Per column of the whole cells: the weights of its shares in the
    /// order of a band's 2x2 cells (the left cell's two rows, the right
    /// one's): the left cell's twice, the right one's twice (0 for a cell
    /// off the grid).
    col_weights: Vec<[f32; 4]>,
    /// Per row of the whole cells: its band (its upper cell row + 1) and
    /// the weights of its shares in the band's slots (the even one, the
    /// odd one, twice: the upper cell row's slot is the band's parity).
    row_weights: Vec<(usize, [f32; 4])>,
    /// The histograms of a band, `[pad pair][18 planes][pad pair]`.
    band: Vec<f32>,
    /// Per slot, the mask that clears it in [`LANES`] pairs (data rather
    /// than constants: see [`clear`]).
    keep: [[u32; 2 * LANES]; 2],
    insensitive: Vec<f32>,
    block: Vec<f32>,
    /// Per cell: its energy, then the norms of its four blocks and its
    /// four texture sums (channel-major scratch of `normalise`).
    energy: Vec<f32>,
    norms: Vec<f32>,
    texture: Vec<f32>,
}

impl Fhog {
    /// fHOG of `w x h` patches in cells of `cell` pixels.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a zero cell or a patch smaller
    /// than one cell.
    pub fn new(w: usize, h: usize, cell: usize) -> Result<Self> {
        if cell == 0 || w < cell || h < cell || w.saturating_mul(h) > 1 << 24 {
            return Err(DcfError::InvalidParameter {
                name: "hog patch",
                value: (w.min(h)) as f64,
                reason: "the cell must be positive and the patch at least one cell (and at most 2^24 pixels)",
            });
        }
        let (wb, hb) = (w / cell, h / cell);
        let nb = wb * hb;
        let rows = hb * cell;
        let cols: Vec<(usize, f32)> = (0..wb * cell).map(|x| split(x, cell)).collect();
        let mut px_col = vec![0; rows * w];
        for row in px_col.chunks_exact_mut(w) {
            for (p, &(c0, _)) in row.iter_mut().zip(&cols) {
                *p = 2 * c0 as u32;
            }
        }
        // a column off the grid (left of the first cell, right of the last)
        // gets weight 0: its share, +0.0, lands on the neighbouring plane's
        // edge cell (or a pad pair) and changes no value there
        let col_weights = cols
            .iter()
            .map(|&(c0, fx)| {
                let lo = if c0 == 0 { 0.0 } else { 1.0 - fx };
                let hi = if c0 == wb { 0.0 } else { fx };
                [lo, lo, hi, hi]
            })
            .collect();
        let row_weights = (0..rows)
            .map(|y| {
                let (y0, fy) = split(y, cell);
                let (up, down) = (1.0 - fy, fy);
                let (even, odd) = if y0 % 2 == 0 { (up, down) } else { (down, up) };
                (y0, [even, odd, even, odd])
            })
            .collect();
        Ok(Self {
            w,
            h,
            cell,
            wb,
            hb,
            gx: vec![0.0; w * h],
            gy: vec![0.0; w * h],
            mag: vec![0.0; w * h],
            bin: vec![0; w * h],
            sensitive: vec![0.0; SENSITIVE * nb],
            tops: vec![0; px_col.len()],
            px_col,
            col_weights,
            row_weights,
            band: vec![0.0; band_len(wb)],
            keep: std::array::from_fn(|s| std::array::from_fn(|k| if k % 2 == s { 0 } else { !0 })),
            insensitive: vec![0.0; INSENSITIVE * nb],
            block: vec![0.0; wb.saturating_sub(1).max(1) * hb.saturating_sub(1).max(1)],
            energy: vec![0.0; nb],
            norms: vec![0.0; 4 * nb],
            texture: vec![0.0; 4 * nb],
        })
    }

    /// Cells across.
    pub fn cells_x(&self) -> usize {
        self.wb
    }

    /// Cells down.
    pub fn cells_y(&self) -> usize {
        self.hb
    }

    /// Length of the output: `31 * cells_x * cells_y`.
    pub fn len(&self) -> usize {
        HOG_CHANNELS * self.wb * self.hb
    }

    /// Whether the output is empty (never: a patch has at least one cell).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The fHOG of `patch` (`w x h` row-major, any intensity scale; the
    /// trackers use `[0, 1]`) into `out` (see the module docs).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn compute(&mut self, patch: &[f32], out: &mut [f32]) -> Result<()> {
        if patch.len() != self.w * self.h {
            return Err(DcfError::Size {
                what: "hog patch",
                expected: self.w * self.h,
                got: patch.len(),
            });
        }
        if out.len() != self.len() {
            return Err(DcfError::Size {
                what: "hog output",
                expected: self.len(),
                got: out.len(),
            });
        }
        self.compute_at(SimdLevel::Avx512, patch, out);
        Ok(())
    }

    /// [`Fhog::compute`] with its vector kernels compiled for `level` (or
    /// the best level this CPU runs below it): every level gives the same
    /// bits (no fused multiply-add, the same order of every sum).
    fn compute_at(&mut self, level: SimdLevel, patch: &[f32], out: &mut [f32]) {
        self.gradients(level, patch);
        self.histograms(level);
        self.normalise(level, out);
    }

    /// Per pixel: the gradient (one plane of `gx`, one of `gy`), then
    /// its magnitude and bin in one flat pass over the patch (a vector
    /// loop with a single scalar remainder, whatever the row width); both
    /// compiled for `level`.
    #[inline(never)]
    fn gradients(&mut self, level: SimdLevel, p: &[f32]) {
        let n = self.w * self.h;
        level.run(Differences {
            w: self.w,
            h: self.h,
            p: &p[..n],
            gx: &mut self.gx[..n],
            gy: &mut self.gy[..n],
        });
        let inv = 1.0 / self.cell as f32;
        level.run(GradientBins {
            norm: inv * inv,
            gx: &self.gx,
            gy: &self.gy,
            mag: &mut self.mag,
            bin: &mut self.bin,
        });
    }

    /// Each pixel's four shares added into the histograms in pixel order,
    /// band by band. A band is the two cell rows a pixel row adds to (the
    /// pixel rows with the same upper cell row); the band buffer holds, per
    /// bin, one plane of the band's cells with each cell's two rows side
    /// by side, so that a pixel's four shares go to four neighbouring
    /// values (one 4-wide add: the same four sums as four scalar adds).
    /// A cell row keeps its slot (even or odd) of the pairs while it is in
    /// a band: when the pixel rows pass to the next band, the upper row
    /// is complete, copied out and cleared to +0.0, and its slot takes the
    /// new lower row (the other row's sums carry on in place).
    ///
    /// Every pixel's offset (its bin's plane and its column) comes from one
    /// vector pass. The cell rows off the grid (above the first, below the
    /// last) are not copied out; the shares of the columns off the grid
    /// have weight 0 (see [`Fhog::new`]) and land, as +0.0, on a
    /// neighbouring plane's edge cell or a pad pair, which `x + 0.0 = x`
    /// leaves as they are (every sum is +0.0 or positive, for finite
    /// gradients); so each cell's sum is the one on a grid padded on all
    /// four sides.
    #[inline(never)]
    fn histograms(&mut self, level: SimdLevel) {
        let (wb, hb) = (self.wb, self.hb);
        let nb = wb * hb;
        level.run(Histograms {
            w: self.w,
            cells: wb * self.cell,
            wb,
            hb,
            mag: &self.mag,
            bin: &self.bin,
            px_col: &self.px_col,
            tops: &mut self.tops,
            col_weights: &self.col_weights,
            row_weights: &self.row_weights,
            band: &mut self.band,
            keep: &self.keep,
            sensitive: &mut self.sensitive[..SENSITIVE * nb],
            insensitive: &mut self.insensitive[..INSENSITIVE * nb],
        });
    }

    /// Channel-major: the cells' energies, the blocks' norms, each cell's
    /// four norms gathered once, then per channel one contiguous (vector)
    /// loop over the cells, with the per-value arithmetic of the
    /// cell-by-cell definition (the same order of every sum).
    #[inline(never)]
    fn normalise(&mut self, level: SimdLevel, out: &mut [f32]) {
        let (wb, hb, b) = (self.wb, self.hb, self.cell as f32);
        let nb = wb * hb;
        if wb < 2 || hb < 2 {
            out.fill(0.0);
            return;
        }
        let eps = 1e-4 / 4.0 / (b * b * b * b);
        level.run(Normalise {
            wb,
            hb,
            eps,
            sensitive: &self.sensitive[..SENSITIVE * nb],
            insensitive: &self.insensitive[..INSENSITIVE * nb],
            energy: &mut self.energy[..nb],
            block: &mut self.block,
            norms: &mut self.norms[..4 * nb],
            texture: &mut self.texture[..4 * nb],
            out: &mut out[..HOG_CHANNELS * nb],
        });
    }
}

/// The unit vectors of the 9 directions `o * 20` degrees, `o < 9`: those
/// past 90 degrees the mirror images `(-cos, sin)` of those before it
/// (direction `9 - o` of direction `o`, `0 < o < 9`), which [`pixel`]
/// relies on (the same `f32`s as rounding their own cosines and sines).
fn directions() -> [(f32, f32); INSENSITIVE] {
    let first: [(f32, f32); INSENSITIVE] = std::array::from_fn(|o| {
        let a = std::f64::consts::PI * o as f64 / INSENSITIVE as f64;
        (a.cos() as f32, a.sin() as f32)
    });
    std::array::from_fn(|o| {
        if 2 * o > INSENSITIVE {
            let (c, s) = first[INSENSITIVE - o];
            (-c, s)
        } else {
            first[o]
        }
    })
}

/// One pixel's magnitude and bin, branch-free (selects, so that a loop of
/// them vectorises). The nearest of the 18 directions `o * 20` degrees
/// maximises `cos(theta - theta_o)`: the largest `|g . u_o|` over the 9
/// directions of the first half circle, its sign telling the half. This
/// is `round(18 theta / 2 pi) mod 18` without the arc tangent; exact ties
/// go to the lower bin. The bin is carried as a `u32` (as wide as the
/// gradients) so that a vector loop keeps the running best in lanes of
/// the comparisons' width (one blend per direction, no narrowing of each
/// comparison's mask to bytes; the bins narrowed once at the end).
///
/// Direction `9 - o` is direction `o` mirrored, `(-c, s)` ([`directions`]):
/// its `gx (-c) + gy s` is `gy s - gx c`, the same bits from the products
/// of direction `o` (`-(gx c) + gy s` and `gy s - gx c` round alike), so
/// the nine directions take eight products, not sixteen.
#[inline(always)]
fn pixel(gx: f32, gy: f32, dirs: &[(f32, f32); INSENSITIVE]) -> (f32, u32) {
    let dot = |o: usize| {
        let (c, s) = dirs[o];
        let (p, q) = (gx * c, gy * s);
        (p + q, q - p)
    };
    let ((d1, d8), (d2, d7), (d3, d6), (d4, d5)) = (dot(1), dot(2), dot(3), dot(4));
    let (mut best, mut bd, mut ba) = (0u32, gx, gx.abs());
    for (o, d) in [
        (1, d1),
        (2, d2),
        (3, d3),
        (4, d4),
        (5, d5),
        (6, d6),
        (7, d7),
        (8, d8),
    ] {
        let better = d.abs() > ba;
        best = if better { o } else { best };
        bd = if better { d } else { bd };
        ba = if better { d.abs() } else { ba };
    }
    let bin = if bd >= 0.0 {
        best
    } else {
        best + INSENSITIVE as u32
    };
    ((gx * gx + gy * gy).sqrt(), bin)
}

/// The lower cell (+1 for the padding) of pixel `i` on one axis and the
/// upper cell's weight: pixel `i` sits at `(i + 0.5) / b - 0.5` in cell
/// units.
fn split(i: usize, cell: usize) -> (usize, f32) {
    let inv = 1.0 / cell as f32;
    let c = (i as f32 + 0.5) * inv - 0.5 + 1.0;
    let c0 = c as usize; // c >= 0.5 > 0: truncation is floor
    (c0, c - c0 as f32)
}

/// The orientation histograms of the cells (see [`Fhog::histograms`]).
struct Histograms<'a> {
    w: usize,
    /// Pixels across the whole cells.
    cells: usize,
    wb: usize,
    hb: usize,
    mag: &'a [f32],
    bin: &'a [u32],
    px_col: &'a [u32],
    tops: &'a mut [u32],
    col_weights: &'a [[f32; 4]],
    row_weights: &'a [(usize, [f32; 4])],
    band: &'a mut [f32],
    keep: &'a [[u32; 2 * LANES]; 2],
    sensitive: &'a mut [f32],
    insensitive: &'a mut [f32],
}

/// Length of the band buffer for `wb` cells across: a pad pair, the 18
/// bins' planes of `wb` pairs (a cell's two rows), a pad pair.
fn band_len(wb: usize) -> usize {
    2 * SENSITIVE * wb + 4
}

/// One pixel row's shares added into `band`, pixel after pixel (four a
/// step): each pixel's four shares `wx * (wy * m)` (the order of the
/// definition's products) added into the four values from its offset.
#[inline(always)]
fn scatter(band: &mut [f32], tops: &[u32], mag: &[f32], cols: &[[f32; 4]], wy: [f32; 4]) {
    let mut add = |top: u32, m: f32, wx: &[f32; 4]| {
        let top = top as usize;
        let cells = &mut band[top..top + 4];
        for k in 0..4 {
            cells[k] += wx[k] * (wy[k] * m);
        }
    };
    const STEP: usize = 4;
    let (t, m, c) = (
        tops.chunks_exact(STEP),
        mag.chunks_exact(STEP),
        cols.chunks_exact(STEP),
    );
    let rest = (t.remainder(), m.remainder(), c.remainder());
    for ((t, m), c) in t.zip(m).zip(c) {
        for j in 0..STEP {
            add(t[j], m[j], &c[j]);
        }
    }
    for ((&t, &m), c) in rest.0.iter().zip(rest.1).zip(rest.2) {
        add(t, m, c);
    }
}

/// The end of band `band`: its upper cell row (row `band - 1` of the
/// grid, if on it), in slot `band % 2` of the pairs of the band buffer's
/// `planes`, copied out into `sensitive`, and cleared to +0.0.
#[inline(always)]
fn next_band(
    planes: &mut [f32],
    band: usize,
    wb: usize,
    hb: usize,
    sensitive: &mut [f32],
    keep: &[[u32; 2 * LANES]; 2],
) {
    let slot = band % 2;
    let keep = &keep[slot];
    if !(1..=hb).contains(&band) {
        // (in chunks of LANES pairs, the last one ending at the end:
        // clearing a value twice clears it)
        let n = planes.len();
        for pairs in planes.chunks_exact_mut(2 * LANES) {
            clear(pairs, keep);
        }
        if !n.is_multiple_of(2 * LANES) {
            clear(&mut planes[n - 2 * LANES..], keep);
        }
        return;
    }
    let row = (band - 1) * wb;
    if slot == 0 {
        take_rows::<0>(planes, row, wb, hb, sensitive, keep);
    } else {
        take_rows::<1>(planes, row, wb, hb, sensitive, keep);
    }
}

/// Slot `S` of each plane's `wb` pairs copied out to `row` of its bin in
/// `sensitive` and cleared (`keep`: all ones but in slot `S`), in chunks
/// of [`LANES`] cells. A row that is not a multiple of [`LANES`] long
/// takes one more chunk, ending at its end: copied first (the chunk
/// before it clears some of its values), cleared last (clearing a value
/// twice clears it).
#[inline(always)]
fn take_rows<const S: usize>(
    planes: &mut [f32],
    row: usize,
    wb: usize,
    hb: usize,
    sensitive: &mut [f32],
    keep: &[u32; 2 * LANES],
) {
    for (plane, out) in planes
        .chunks_exact_mut(2 * wb)
        .zip(sensitive.chunks_exact_mut(wb * hb))
    {
        let out = &mut out[row..][..wb];
        if wb < LANES {
            for (o, pair) in out.iter_mut().zip(plane.chunks_exact_mut(2)) {
                *o = pair[S];
                pair[S] = 0.0;
            }
            continue;
        }
        let tail = wb - LANES;
        let partial = !wb.is_multiple_of(LANES);
        if partial {
            let pairs = &plane[2 * tail..][..2 * LANES];
            let out = &mut out[tail..][..LANES];
            for k in 0..LANES {
                out[k] = pairs[2 * k + S];
            }
        }
        for (o, pairs) in out
            .chunks_exact_mut(LANES)
            .zip(plane.chunks_exact_mut(2 * LANES))
        {
            take::<S>(pairs, o, keep);
        }
        if partial {
            clear(&mut plane[2 * tail..], keep);
        }
    }
}

/// [`LANES`] pairs: slot `S` copied to `out`, then cleared. (The pairs
/// are loaded whole, once, for both; slot `S` taken from the loaded
/// values by a shuffle, not gathered from memory.)
#[inline(always)]
fn take<const S: usize>(pairs: &mut [f32], out: &mut [f32], keep: &[u32; 2 * LANES]) {
    let (pairs, out) = (&mut pairs[..2 * LANES], &mut out[..LANES]);
    let v: [u32; 2 * LANES] = std::array::from_fn(|k| pairs[k].to_bits());
    for k in 0..2 * LANES {
        pairs[k] = f32::from_bits(v[k] & keep[k]);
    }
    for k in 0..LANES {
        out[k] = f32::from_bits(v[2 * k + S]);
    }
}

/// [`LANES`] pairs masked with `keep` (a mask read from memory, so that
/// the clearing stays two vector stores rather than one store per
/// cleared value).
#[inline(always)]
fn clear(pairs: &mut [f32], keep: &[u32; 2 * LANES]) {
    let pairs = &mut pairs[..2 * LANES];
    for k in 0..2 * LANES {
        pairs[k] = f32::from_bits(pairs[k].to_bits() & keep[k]);
    }
}

impl Kernel for Histograms<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let (w, cells, wb, hb) = (self.w, self.cells, self.wb, self.hb);
        let plane = (2 * wb) as u32;
        let n = self.tops.len();
        for ((t, &b), &c) in self
            .tops
            .iter_mut()
            .zip(&self.bin[..n])
            .zip(&self.px_col[..n])
        {
            *t = b * plane + c;
        }
        let band = self.band;
        band.fill(0.0);
        let planes = 2..2 + 2 * SENSITIVE * wb;
        let mut at = self.row_weights[0].0;
        let cols = &self.col_weights[..cells];
        for (y, &(y0, wy)) in self.row_weights.iter().enumerate() {
            if y0 != at {
                next_band(
                    &mut band[planes.clone()],
                    at,
                    wb,
                    hb,
                    self.sensitive,
                    self.keep,
                );
                at = y0;
            }
            let (tops, mag) = (&self.tops[y * w..][..cells], &self.mag[y * w..][..cells]);
            scatter(band, tops, mag, cols, wy);
        }
        next_band(&mut band[planes], at, wb, hb, self.sensitive, self.keep);
        // the insensitive bins: the sums of opposite sensitive ones
        let nb = wb * hb;
        let (lo_bins, hi_bins) = self.sensitive.split_at(INSENSITIVE * nb);
        for ((a, b), d) in lo_bins
            .chunks_exact(nb)
            .zip(hi_bins.chunks_exact(nb))
            .zip(self.insensitive.chunks_exact_mut(nb))
        {
            for ((d, &a), &b) in d.iter_mut().zip(a).zip(b) {
                *d = a + b;
            }
        }
    }
}

/// The gradients of a `w x h` patch `p` along x and y (see
/// [`Fhog::gradients`]).
struct Differences<'a> {
    w: usize,
    h: usize,
    p: &'a [f32],
    gx: &'a mut [f32],
    gy: &'a mut [f32],
}

impl Kernel for Differences<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self { w, h, p, gx, gy } = self;
        let n = w * h;
        // along y: central differences on the inner rows in one flat pass
        // (row y at index i: rows y - 1 and y + 1 at i - w and i + w),
        // one-sided on the first and last rows
        if h == 1 {
            // rows 0 and 0, weight 0 (as the row-by-row definition)
            for ((g, &a), &b) in gy.iter_mut().zip(p).zip(p) {
                *g = 0.0 * (b - a);
            }
        } else {
            let (first, rest) = gy.split_at_mut(w);
            let (inner, last) = rest.split_at_mut(n - 2 * w);
            for ((g, &a), &b) in first.iter_mut().zip(&p[..w]).zip(&p[w..]) {
                *g = 1.0 * (b - a);
            }
            for ((g, &a), &b) in inner.iter_mut().zip(&p[..n - 2 * w]).zip(&p[2 * w..]) {
                *g = 0.5 * (b - a);
            }
            for ((g, &a), &b) in last.iter_mut().zip(&p[n - 2 * w..]).zip(&p[n - w..]) {
                *g = 1.0 * (b - a);
            }
        }
        // along x: central differences in one flat pass (the values that
        // straddle two rows are overwritten), one-sided at both ends of
        // each row
        if w == 1 {
            gx.fill(0.0);
        } else {
            for ((g, &l), &r) in gx[1..n - 1].iter_mut().zip(p).zip(&p[2..]) {
                *g = 0.5 * (r - l);
            }
            for (g, row) in gx.chunks_exact_mut(w).zip(p.chunks_exact(w)) {
                let last = w - 1;
                g[0] = row[1] - row[0];
                g[last] = row[last] - row[last - 1];
            }
        }
    }
}

/// The magnitude times `norm` and the bin of every pixel of a patch from
/// its gradients.
struct GradientBins<'a> {
    norm: f32,
    gx: &'a [f32],
    gy: &'a [f32],
    mag: &'a mut [f32],
    bin: &'a mut [u32],
}

impl Kernel for GradientBins<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let dirs = directions();
        let n = self.mag.len();
        let (gx, gy, bin) = (&self.gx[..n], &self.gy[..n], &mut self.bin[..n]);
        for (((m, o), &gx), &gy) in self.mag.iter_mut().zip(bin).zip(gx).zip(gy) {
            let (mag, bin) = pixel(gx, gy, &dirs);
            (*m, *o) = (mag * self.norm, bin);
        }
    }
}

/// fHOG's normalisation and channels (see [`Fhog::normalise`]).
struct Normalise<'a> {
    wb: usize,
    hb: usize,
    eps: f32,
    sensitive: &'a [f32],
    insensitive: &'a [f32],
    energy: &'a mut [f32],
    block: &'a mut [f32],
    norms: &'a mut [f32],
    texture: &'a mut [f32],
    out: &'a mut [f32],
}

impl Kernel for Normalise<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let (wb, hb) = (self.wb, self.hb);
        let nb = wb * hb;
        // each cell's energy, the insensitive bins' squares summed in bin
        // order (as `Iterator::sum` from its neutral element)
        let energy = self.energy;
        energy.fill(-0.0);
        for ins in self.insensitive.chunks_exact(nb) {
            for (e, &v) in energy.iter_mut().zip(ins) {
                *e += v * v;
            }
        }
        // each block's 1 / sqrt(sum of its four cells' energies + eps)
        let bw = wb - 1;
        for by in 0..hb - 1 {
            let (r0, r1) = (&energy[by * wb..][..wb], &energy[(by + 1) * wb..][..wb]);
            let dst = &mut self.block[by * bw..][..bw];
            for (bx, d) in dst.iter_mut().enumerate() {
                let e = r0[bx] + r0[bx + 1] + r1[bx] + r1[bx + 1];
                *d = 1.0 / (e + self.eps).sqrt();
            }
        }
        // each cell's four blocks, clamped to the grid
        let (n0, rest) = self.norms.split_at_mut(nb);
        let (n1, rest) = rest.split_at_mut(nb);
        let (n2, n3) = rest.split_at_mut(nb);
        // (row by row: block column min(x, bw - 1) is the block row and its
        // last value again, column min(x - 1, bw - 1) its first value then
        // the block row)
        for y in 0..hb {
            let bys = [y.min(hb - 2), y.saturating_sub(1).min(hb - 2)];
            let (b0, b1) = (
                &self.block[bys[0] * bw..][..bw],
                &self.block[bys[1] * bw..][..bw],
            );
            let r = y * wb..(y + 1) * wb;
            let (r0, r1) = (&mut n0[r.clone()], &mut n1[r.clone()]);
            let (r2, r3) = (&mut n2[r.clone()], &mut n3[r]);
            r0[..bw].copy_from_slice(b0);
            r0[bw] = b0[bw - 1];
            r1[..bw].copy_from_slice(b1);
            r1[bw] = b1[bw - 1];
            r2[0] = b0[0];
            r2[1..].copy_from_slice(b0);
            r3[0] = b1[0];
            r3[1..].copy_from_slice(b1);
        }
        let (n0, n1, n2, n3) = (&n0[..nb], &n1[..nb], &n2[..nb], &n3[..nb]);
        if nb >= LANES {
            // chunks of LANES cells, all 27 channels of a chunk at once
            // (the texture sums stay in registers); the last chunk ends at
            // the last cell and may overlap the one before: every value a
            // chunk writes depends on its cells only, so writing it twice
            // writes the same bits
            let last = nb - LANES;
            for i0 in (0..last).step_by(LANES).chain([last]) {
                cells(
                    i0,
                    nb,
                    [&n0[i0..], &n1[i0..], &n2[i0..], &n3[i0..]],
                    self.sensitive,
                    self.insensitive,
                    self.out,
                );
            }
            return;
        }
        let (t0, rest) = self.texture.split_at_mut(nb);
        let (t1, rest) = rest.split_at_mut(nb);
        let (t2, t3) = rest.split_at_mut(nb);
        let (t0, t1, t2, t3) = (&mut t0[..nb], &mut t1[..nb], &mut t2[..nb], &mut t3[..nb]);
        t0.fill(0.0);
        t1.fill(0.0);
        t2.fill(0.0);
        t3.fill(0.0);
        let (out, out_texture) = self.out.split_at_mut((SENSITIVE + INSENSITIVE) * nb);
        let (out_sensitive, out_insensitive) = out.split_at_mut(SENSITIVE * nb);
        // sensitive channels: the sum of the four clipped values, each also
        // added to its block's texture sum
        for (src, dst) in self
            .sensitive
            .chunks_exact(nb)
            .zip(out_sensitive.chunks_exact_mut(nb))
        {
            let dst = &mut dst[..nb];
            for i in 0..nb {
                let v = src[i];
                let c = [
                    (v * n0[i]).min(CLIP),
                    (v * n1[i]).min(CLIP),
                    (v * n2[i]).min(CLIP),
                    (v * n3[i]).min(CLIP),
                ];
                let mut s = 0.0;
                for c in c {
                    s += c;
                }
                t0[i] += c[0];
                t1[i] += c[1];
                t2[i] += c[2];
                t3[i] += c[3];
                dst[i] = R * s;
            }
        }
        for (src, dst) in self
            .insensitive
            .chunks_exact(nb)
            .zip(out_insensitive.chunks_exact_mut(nb))
        {
            let dst = &mut dst[..nb];
            for i in 0..nb {
                let v = src[i];
                let c = [
                    (v * n0[i]).min(CLIP),
                    (v * n1[i]).min(CLIP),
                    (v * n2[i]).min(CLIP),
                    (v * n3[i]).min(CLIP),
                ];
                let s: f32 = c.iter().sum();
                dst[i] = R * s;
            }
        }
        for (t, dst) in [&*t0, &*t1, &*t2, &*t3]
            .into_iter()
            .zip(out_texture.chunks_exact_mut(nb))
        {
            for (d, &t) in dst.iter_mut().zip(t) {
                *d = R * t;
            }
        }
    }
}

/// Cells per chunk of [`cells`] (one AVX2 vector of `f32`).
const LANES: usize = 8;

/// The 31 channels of the `LANES` cells from `i0`, with the arithmetic of
/// the channel-by-channel loops (the same sums in the same order): the
/// four clipped values of each sensitive channel summed from `0.0` in
/// block order and each added to its block's texture sum (from `0.0`, in
/// channel order), the insensitive ones' summed as `Iterator::sum`.
#[inline(always)]
fn cells(
    i0: usize,
    nb: usize,
    norms: [&[f32]; 4],
    sensitive: &[f32],
    insensitive: &[f32],
    out: &mut [f32],
) {
    // (whole-array steps over the lanes: straight-line code the compiler
    // turns into one vector operation each)
    type V = [f32; LANES];
    let [n0, n1, n2, n3] = norms.map(|n| -> V {
        let n = &n[..LANES];
        std::array::from_fn(|l| n[l])
    });
    let clip = |v: &V, n: &V| -> V { std::array::from_fn(|l| (v[l] * n[l]).min(CLIP)) };
    let (mut t0, mut t1, mut t2, mut t3) =
        ([0.0f32; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
    // (channel after channel as slices of the grid's length: the bounds
    // tests of a chunk do not depend on the channel, so they leave the loop)
    let (out, texture) = out.split_at_mut((SENSITIVE + INSENSITIVE) * nb);
    let (out_sensitive, out_insensitive) = out.split_at_mut(SENSITIVE * nb);
    for (src, dst) in sensitive
        .chunks_exact(nb)
        .zip(out_sensitive.chunks_exact_mut(nb))
    {
        let v = &src[i0..][..LANES];
        let v: V = std::array::from_fn(|l| v[l]);
        let (c0, c1, c2, c3) = (clip(&v, &n0), clip(&v, &n1), clip(&v, &n2), clip(&v, &n3));
        let s: V = std::array::from_fn(|l| {
            let mut s = 0.0;
            for c in [c0[l], c1[l], c2[l], c3[l]] {
                s += c;
            }
            s
        });
        t0 = std::array::from_fn(|l| t0[l] + c0[l]);
        t1 = std::array::from_fn(|l| t1[l] + c1[l]);
        t2 = std::array::from_fn(|l| t2[l] + c2[l]);
        t3 = std::array::from_fn(|l| t3[l] + c3[l]);
        let d = &mut dst[i0..][..LANES];
        for l in 0..LANES {
            d[l] = R * s[l];
        }
    }
    for (src, dst) in insensitive
        .chunks_exact(nb)
        .zip(out_insensitive.chunks_exact_mut(nb))
    {
        let v = &src[i0..][..LANES];
        let v: V = std::array::from_fn(|l| v[l]);
        let (c0, c1, c2, c3) = (clip(&v, &n0), clip(&v, &n1), clip(&v, &n2), clip(&v, &n3));
        let s: V = std::array::from_fn(|l| [c0[l], c1[l], c2[l], c3[l]].iter().sum());
        let d = &mut dst[i0..][..LANES];
        for l in 0..LANES {
            d[l] = R * s[l];
        }
    }
    for (t, dst) in [t0, t1, t2, t3].iter().zip(texture.chunks_exact_mut(nb)) {
        let d = &mut dst[i0..][..LANES];
        for l in 0..LANES {
            d[l] = R * t[l];
        }
    }
}

/// The gray feature of KCF's raw-pixel variant, averaged over cells:
/// cell `(x, y)` of `out` (`floor(w / cell) x floor(h / cell)`,
/// row-major) is the mean of `patch / 255 - 0.5` over its pixels
/// (`patch` in `0..=255`).
///
/// # Errors
/// [`DcfError::Size`] for buffers of another size;
/// [`DcfError::InvalidParameter`] for a zero cell.
pub fn gray_cells(patch: &[f32], w: usize, h: usize, cell: usize, out: &mut [f32]) -> Result<()> {
    if cell == 0 {
        return Err(DcfError::InvalidParameter {
            name: "cell",
            value: 0.0,
            reason: "must be positive",
        });
    }
    let (wb, hb) = (w / cell, h / cell);
    if patch.len() != w * h || out.len() != wb * hb {
        return Err(DcfError::Size {
            what: "gray feature",
            expected: wb * hb,
            got: out.len(),
        });
    }
    out.fill(0.0);
    let k = 1.0 / (255.0 * (cell * cell) as f32);
    for y in 0..hb * cell {
        for x in 0..wb * cell {
            out[(y / cell) * wb + x / cell] += patch[y * w + x] * k;
        }
    }
    for v in out.iter_mut() {
        *v -= 0.5;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hog(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> (Fhog, Vec<f32>) {
        let patch: Vec<f32> = (0..w * h).map(|i| f(i % w, i / w)).collect();
        let mut hog = Fhog::new(w, h, 4).unwrap();
        let mut out = vec![0.0; hog.len()];
        hog.compute(&patch, &mut out).unwrap();
        (hog, out)
    }

    /// The channel with the largest total.
    fn strongest(out: &[f32], nb: usize, channels: std::ops::Range<usize>) -> usize {
        channels
            .max_by(|&a, &b| {
                let sa: f32 = out[a * nb..(a + 1) * nb].iter().sum();
                let sb: f32 = out[b * nb..(b + 1) * nb].iter().sum();
                sa.total_cmp(&sb)
            })
            .unwrap()
    }

    /// The cell-by-cell fHOG as first written (per pixel scatter, per cell
    /// gathers, no vector kernel): the reference the kernels must match
    /// bit for bit.
    impl Fhog {
        fn compute_reference(&mut self, patch: &[f32], out: &mut [f32]) {
            self.gradients_reference(patch);
            self.histograms_reference();
            self.normalise_reference(out);
        }

        fn gradients_reference(&mut self, p: &[f32]) {
            let (w, h) = (self.w, self.h);
            // The nearest of the 18 directions o * 20 degrees maximises
            // cos(theta - theta_o): the largest |g . u_o| over the 9
            // directions of the first half circle, its sign telling the half.
            // This is `round(18 theta / 2 pi) mod 18` without the arc tangent
            // (the profile's largest cost); exact ties go to the lower bin.
            let dirs: [(f32, f32); INSENSITIVE] = std::array::from_fn(|o| {
                let a = std::f64::consts::PI * o as f64 / INSENSITIVE as f64;
                (a.cos() as f32, a.sin() as f32)
            });
            // one pixel: magnitude and bin, branch-free (selects), so that the
            // inner loop vectorises
            #[inline(always)]
            fn pixel_u8(gx: f32, gy: f32, dirs: &[(f32, f32); INSENSITIVE]) -> (f32, u8) {
                let (mut best, mut bd, mut ba) = (0u8, gx, gx.abs());
                for (o, &(c, s)) in dirs.iter().enumerate().skip(1) {
                    let d = gx * c + gy * s;
                    let better = d.abs() > ba;
                    best = if better { o as u8 } else { best };
                    bd = if better { d } else { bd };
                    ba = if better { d.abs() } else { ba };
                }
                let bin = if bd >= 0.0 {
                    best
                } else {
                    best + INSENSITIVE as u8
                };
                ((gx * gx + gy * gy).sqrt(), bin)
            }
            // (the kernels keep the bins as u32)
            fn pixel(gx: f32, gy: f32, dirs: &[(f32, f32); INSENSITIVE]) -> (f32, u32) {
                let (m, b) = pixel_u8(gx, gy, dirs);
                (m, u32::from(b))
            }
            for y in 0..h {
                let (ya, yb, ky) = if h == 1 {
                    (0, 0, 0.0)
                } else if y == 0 {
                    (0, 1, 1.0)
                } else if y == h - 1 {
                    (h - 2, h - 1, 1.0)
                } else {
                    (y - 1, y + 1, 0.5)
                };
                let (ra, rb, row) = (&p[ya * w..][..w], &p[yb * w..][..w], &p[y * w..][..w]);
                let mag = &mut self.mag[y * w..][..w];
                let bins = &mut self.bin[y * w..][..w];
                if w == 1 {
                    (mag[0], bins[0]) = pixel(0.0, ky * (rb[0] - ra[0]), &dirs);
                    continue;
                }
                // one-sided differences at both ends, central inside
                (mag[0], bins[0]) = pixel(row[1] - row[0], ky * (rb[0] - ra[0]), &dirs);
                let last = w - 1;
                (mag[last], bins[last]) =
                    pixel(row[last] - row[last - 1], ky * (rb[last] - ra[last]), &dirs);
                let inner = w - 2;
                let (left, right) = (&row[..inner], &row[2..]);
                let (ra, rb) = (&ra[1..][..inner], &rb[1..][..inner]);
                let (mag, bins) = (&mut mag[1..][..inner], &mut bins[1..][..inner]);
                for x in 0..inner {
                    let gx = 0.5 * (right[x] - left[x]);
                    let gy = ky * (rb[x] - ra[x]);
                    (mag[x], bins[x]) = pixel(gx, gy, &dirs);
                }
            }
        }

        fn histograms_reference(&mut self) {
            let (w, wb, hb, b) = (self.w, self.wb, self.hb, self.cell);
            let nb = wb * hb;
            // binned on a grid padded by one cell on each side (the shares
            // that fall off the grid land there and are dropped), so the inner
            // loop has no bounds tests
            let (pw, ph) = (wb + 2, hb + 2);
            let np = pw * ph;
            let mut padded = vec![0.0f32; SENSITIVE * np];
            let inv = 1.0 / b as f32;
            let norm = inv * inv;
            // per axis: the lower cell (+1 for the padding) and the upper one's
            // weight; pixel i sits at (i + 0.5) / b - 0.5 in cell units
            let split = |i: usize| -> (usize, f32) {
                let c = (i as f32 + 0.5) * inv - 0.5 + 1.0;
                let c0 = c as usize; // c >= 0.5 > 0: truncation is floor
                (c0, c - c0 as f32)
            };
            let cols: Vec<(usize, f32)> = (0..wb * b).map(split).collect();
            for y in 0..hb * b {
                let (y0, fy) = split(y);
                let mag = &self.mag[y * w..][..wb * b];
                let bins = &self.bin[y * w..][..wb * b];
                for ((&m, &o), &(x0, fx)) in mag.iter().zip(bins).zip(&cols) {
                    let m = m * norm;
                    let hist = &mut padded[o as usize * np..][..np];
                    let top = y0 * pw + x0;
                    let (wy1, wy0) = (fy * m, (1.0 - fy) * m);
                    hist[top] += (1.0 - fx) * wy0;
                    hist[top + 1] += fx * wy0;
                    hist[top + pw] += (1.0 - fx) * wy1;
                    hist[top + pw + 1] += fx * wy1;
                }
            }
            for o in 0..SENSITIVE {
                let src = &padded[o * np..][..np];
                let dst = &mut self.sensitive[o * nb..][..nb];
                for cy in 0..hb {
                    dst[cy * wb..][..wb].copy_from_slice(&src[(cy + 1) * pw + 1..][..wb]);
                }
            }
            for o in 0..INSENSITIVE {
                for i in 0..nb {
                    self.insensitive[o * nb + i] =
                        self.sensitive[o * nb + i] + self.sensitive[(o + INSENSITIVE) * nb + i];
                }
            }
        }

        fn normalise_reference(&mut self, out: &mut [f32]) {
            let (wb, hb, b) = (self.wb, self.hb, self.cell as f32);
            let nb = wb * hb;
            if wb < 2 || hb < 2 {
                out.fill(0.0);
                return;
            }
            let eps = 1e-4 / 4.0 / (b * b * b * b);
            let energy = |x: usize, y: usize| -> f32 {
                (0..INSENSITIVE)
                    .map(|o| {
                        let v = self.insensitive[o * nb + y * wb + x];
                        v * v
                    })
                    .sum()
            };
            let bw = wb - 1;
            for by in 0..hb - 1 {
                for bx in 0..bw {
                    let e = energy(bx, by)
                        + energy(bx + 1, by)
                        + energy(bx, by + 1)
                        + energy(bx + 1, by + 1);
                    self.block[by * bw + bx] = 1.0 / (e + eps).sqrt();
                }
            }
            for y in 0..hb {
                for x in 0..wb {
                    // the four blocks that contain cell (x, y), clamped to the grid
                    let bxs = [x.min(bw - 1), x.saturating_sub(1).min(bw - 1)];
                    let bys = [y.min(hb - 2), y.saturating_sub(1).min(hb - 2)];
                    let n = [
                        self.block[bys[0] * bw + bxs[0]],
                        self.block[bys[1] * bw + bxs[0]],
                        self.block[bys[0] * bw + bxs[1]],
                        self.block[bys[1] * bw + bxs[1]],
                    ];
                    let i = y * wb + x;
                    let mut texture = [0.0f32; 4];
                    for o in 0..SENSITIVE {
                        let v = self.sensitive[o * nb + i];
                        let mut s = 0.0;
                        for (t, &nk) in texture.iter_mut().zip(&n) {
                            let c = (v * nk).min(CLIP);
                            s += c;
                            *t += c;
                        }
                        out[o * nb + i] = R * s;
                    }
                    for o in 0..INSENSITIVE {
                        let v = self.insensitive[o * nb + i];
                        let s: f32 = n.iter().map(|&nk| (v * nk).min(CLIP)).sum();
                        out[(SENSITIVE + o) * nb + i] = R * s;
                    }
                    for (k, t) in texture.iter().enumerate() {
                        out[(SENSITIVE + INSENSITIVE + k) * nb + i] = R * t;
                    }
                }
            }
        }
    }

    /// A deterministic pseudo-random patch in [0, 1] with flat stretches
    /// (exact ties between directions and zero gradients) and steps.
    fn random_patch(w: usize, h: usize, seed: u32) -> Vec<f32> {
        let mut s = seed.wrapping_mul(2_654_435_761).max(1);
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        (0..w * h)
            .map(|_| match next() % 4 {
                0 => 0.5,
                1 => (next() % 8) as f32 / 8.0,
                _ => next() as f32 / u32::MAX as f32,
            })
            .collect()
    }

    #[test]
    fn kernels_match_the_reference_bit_for_bit_at_every_level() {
        // odd sizes (partial cells, rows not a multiple of any vector
        // width), a single row or column, grids of 1 and 2 cells
        let sizes = [
            (1, 4, 1),
            (4, 1, 1),
            (3, 3, 1),
            (8, 8, 4),
            (9, 13, 4),
            (23, 17, 4),
            (37, 29, 4),
            (41, 40, 5),
            (17, 31, 3),
            // the trackers' sizes: search windows, scale-filter patches
            (62, 155, 4),
            (64, 160, 4),
            (48, 128, 4),
            (72, 108, 4),
            (14, 36, 4),
            (15, 35, 4),
            // band rows of 8k cells, 8k + 1 (one more, overlapping chunk) and
            // 4k + 2 (a band of 18 (4k + 2) pairs, no whole number of
            // 16-value chunks), several cell sizes
            (129, 19, 4),
            (133, 19, 4),
            (79, 23, 3),
            (34, 21, 1),
            (52, 15, 2),
            (85, 29, 5),
        ];
        for (k, &(w, h, cell)) in sizes.iter().enumerate() {
            let patch = random_patch(w, h, 7 + k as u32);
            let mut reference = Fhog::new(w, h, cell).unwrap();
            let mut want = vec![0.0; reference.len()];
            reference.compute_reference(&patch, &mut want);
            for level in SimdLevel::ALL {
                let mut hog = Fhog::new(w, h, cell).unwrap();
                let mut got = vec![f32::NAN; hog.len()];
                // twice: scratch left by a previous patch changes nothing
                hog.compute_at(level, &random_patch(w, h, 99), &mut got);
                hog.compute_at(level, &patch, &mut got);
                assert_eq!(hog.bin, reference.bin, "{w}x{h}/{cell} {level:?}: bins");
                for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{w}x{h}/{cell} {level:?}: value {i}"
                    );
                }
            }
        }
    }

    /// [`pixel`]'s mirrored directions (eight products) against the
    /// sixteen-product loop with each direction's own rounded cosine and
    /// sine, bit for bit, at every level: signed zeros, ties, the
    /// directions themselves and their bisectors, random gradients.
    #[test]
    fn mirrored_directions_give_the_bins_of_sixteen_products() {
        let own: [(f32, f32); INSENSITIVE] = std::array::from_fn(|o| {
            let a = std::f64::consts::PI * o as f64 / INSENSITIVE as f64;
            (a.cos() as f32, a.sin() as f32)
        });
        let dirs = directions();
        for (d, o) in dirs.iter().zip(&own) {
            assert_eq!(
                (d.0.to_bits(), d.1.to_bits()),
                (o.0.to_bits(), o.1.to_bits())
            );
        }
        let sixteen = |gx: f32, gy: f32| -> (f32, u32) {
            let (mut best, mut bd, mut ba) = (0u32, gx, gx.abs());
            for (o, &(c, s)) in own.iter().enumerate().skip(1) {
                let d = gx * c + gy * s;
                let better = d.abs() > ba;
                best = if better { o as u32 } else { best };
                bd = if better { d } else { bd };
                ba = if better { d.abs() } else { ba };
            }
            let bin = if bd >= 0.0 { best } else { best + 9 };
            ((gx * gx + gy * gy).sqrt(), bin)
        };
        let mut g: Vec<(f32, f32)> = Vec::new();
        let special = [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 0.25, -0.125, 1e-30, -3.0];
        for &a in &special {
            for &b in &special {
                g.push((a, b));
            }
        }
        for k in 0..72 {
            let a = std::f64::consts::PI * k as f64 / 36.0;
            for r in [1.0, 0.37, 255.0] {
                g.push(((r * a.cos()) as f32, (r * a.sin()) as f32));
            }
        }
        let noise = random_patch(2000, 1, 5);
        g.extend(noise.chunks_exact(2).map(|p| (p[0] - 0.5, 0.5 - p[1])));
        let n = g.len();
        let (gx, gy): (Vec<f32>, Vec<f32>) = g.iter().copied().unzip();
        for level in SimdLevel::ALL {
            let (mut mag, mut bin) = (vec![f32::NAN; n], vec![u32::MAX; n]);
            level.run(GradientBins {
                norm: 1.0,
                gx: &gx,
                gy: &gy,
                mag: &mut mag,
                bin: &mut bin,
            });
            for (i, &(x, y)) in g.iter().enumerate() {
                let (m, b) = sixteen(x, y);
                assert_eq!(
                    (mag[i].to_bits(), bin[i]),
                    (m.to_bits(), b),
                    "{level:?}: gradient ({x}, {y})"
                );
            }
        }
    }

    #[test]
    fn constant_image_gives_zeros() {
        let (_, out) = hog(16, 12, |_, _| 0.7);
        assert!(out.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn vertical_edge_goes_to_the_horizontal_gradient_bins() {
        // dark left, bright right: gradient along +x, theta = 0 -> bin 0;
        // the insensitive bin 0 (channel 18) too
        let (h, out) = hog(16, 16, |x, _| if x < 8 { 0.0 } else { 1.0 });
        let nb = h.cells_x() * h.cells_y();
        assert_eq!(strongest(&out, nb, 0..18), 0);
        assert_eq!(strongest(&out, nb, 18..27), 18);
        // bright left, dark right: theta = pi -> bin 9; same insensitive bin
        let (_, out) = hog(16, 16, |x, _| if x < 8 { 1.0 } else { 0.0 });
        assert_eq!(strongest(&out, nb, 0..18), 9);
        assert_eq!(strongest(&out, nb, 18..27), 18);
        // a horizontal edge, bright below: theta = pi/2, halfway between
        // bins 4 and 5 (80 and 100 degrees): either
        let (_, out) = hog(16, 16, |_, y| if y < 8 { 0.0 } else { 1.0 });
        assert!([4, 5].contains(&strongest(&out, nb, 0..18)));
        // a diagonal ramp, theta = 45 degrees -> 18 / 8 = 2.25 -> bin 2
        let (_, out) = hog(16, 16, |x, y| (x + y) as f32 / 32.0);
        assert_eq!(strongest(&out, nb, 0..18), 2);
        // theta = 225 degrees -> 11.25 -> bin 11
        let (_, out) = hog(16, 16, |x, y| (32 - x - y) as f32 / 32.0);
        assert_eq!(strongest(&out, nb, 0..18), 11);
    }

    #[test]
    fn hand_computed_cell_of_a_ramp() {
        // A horizontal ramp I = x/10 on 8x8 pixels, cells of 4 (2x2 cells).
        // Every gradient is (0.1, 0) (the one-sided border differences are
        // 0.1 too): bin 0, magnitude 0.1, m/b^2 = 0.1/16 per pixel. With
        // bilinear weights, each cell receives in total its 16 pixels'
        // worth minus the shares dropped off the grid: for a 2x2 grid each
        // pixel's weight lands entirely inside (the clamped grid absorbs
        // nothing beyond), so cell sums are 4*4*0.1/16 * (share) where the
        // shares of a cell add to 9/16*... - instead check symmetry and
        // the closed form of one cell via a direct sum.
        let (w, b) = (8usize, 4usize);
        let mut expected = [0.0f32; 4];
        for y in 0..w {
            for x in 0..w {
                let c = |i: usize| (i as f32 + 0.5) / b as f32 - 0.5;
                let (cx, cy) = (c(x), c(y));
                for (ix, wx) in [
                    (cx.floor(), 1.0 - (cx - cx.floor())),
                    (cx.floor() + 1.0, cx - cx.floor()),
                ] {
                    for (iy, wy) in [
                        (cy.floor(), 1.0 - (cy - cy.floor())),
                        (cy.floor() + 1.0, cy - cy.floor()),
                    ] {
                        if (0.0..2.0).contains(&ix) && (0.0..2.0).contains(&iy) {
                            expected[iy as usize * 2 + ix as usize] += wx * wy * 0.1 / 16.0;
                        }
                    }
                }
            }
        }
        let mut h = Fhog::new(w, w, b).unwrap();
        let patch: Vec<f32> = (0..w * w).map(|i| (i % w) as f32 / 10.0).collect();
        let mut out = vec![0.0; h.len()];
        h.compute(&patch, &mut out).unwrap();
        for (got, want) in h.sensitive[..4].iter().zip(&expected) {
            assert!((got - want).abs() < 1e-7, "{got} vs {want}");
        }
        // one block: n = 1/sqrt(sum of squares + eps); each cell value is
        // R * 4 min(h n, 0.2)
        let e: f32 = expected.iter().map(|v| v * v).sum();
        let n = 1.0 / (e + 1e-4 / 4.0 / 256.0).sqrt();
        for (i, want) in expected.iter().enumerate() {
            let v = R * 4.0 * (want * n).min(CLIP);
            assert!((out[i] - v).abs() < 1e-6, "cell {i}: {} vs {v}", out[i]);
            // channel 18 (insensitive bin 0) the same; texture 4 x (v / 4)
            assert!((out[18 * 4 + i] - v).abs() < 1e-6);
            assert!((out[27 * 4 + i] - v / 4.0).abs() < 1e-6);
        }
    }

    #[test]
    fn invariant_to_gain_and_offset() {
        let f = |x: usize, y: usize| ((x * 7 + y * 13) % 11) as f32 / 11.0 + 0.1 * (x as f32).sin();
        let (_, a) = hog(20, 16, f);
        let (_, b) = hog(20, 16, |x, y| 3.0 * f(x, y) + 5.0);
        for (p, q) in a.iter().zip(&b) {
            assert!((p - q).abs() < 1e-4, "{p} vs {q}");
        }
        // a horizontal mirror swaps the sensitive bins o <-> (9 - o) mod 18
        let (h, m) = hog(20, 16, |x, y| f(19 - x, y));
        let (wb, nb) = (h.cells_x(), h.cells_x() * h.cells_y());
        for o in 0..18 {
            let mo = (27 - o) % 18;
            for y in 0..h.cells_y() {
                for x in 0..wb {
                    let p = a[o * nb + y * wb + x];
                    let q = m[mo * nb + y * wb + (wb - 1 - x)];
                    assert!((p - q).abs() < 2e-2, "bin {o}: {p} vs {q}");
                }
            }
        }
    }

    #[test]
    fn gray_cells_means() {
        let patch: Vec<f32> = (0..16)
            .map(|i| if i % 4 < 2 { 255.0 } else { 0.0 })
            .collect();
        let mut out = [0.0; 4];
        gray_cells(&patch, 4, 4, 2, &mut out).unwrap();
        assert_eq!(out, [0.5, -0.5, 0.5, -0.5]);
        assert!(gray_cells(&patch, 4, 4, 0, &mut out).is_err());
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(Fhog::new(3, 8, 4).is_err());
        assert!(Fhog::new(8, 8, 0).is_err());
        let mut h = Fhog::new(8, 8, 4).unwrap();
        assert!(h.compute(&[0.0; 10], &mut vec![0.0; h.len()]).is_err());
    }
}
