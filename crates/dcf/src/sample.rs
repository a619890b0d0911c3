//! Resampling a frame into fixed-size patches: area averaging when
//! shrinking (an integral image per plane, anti-aliased at every scale),
//! bilinear interpolation when enlarging; edge pixels replicated outside
//! the frame (as KCF's and DSST's patch extraction does).

use bayestrack_image::simd::{Kernel, SimdLevel, Token};
use bayestrack_image::{ImageView, gray_level};

use crate::error::{DcfError, Result};

/// The planes of one frame, ready to resample.
#[derive(Debug, Clone, Default)]
pub struct PatchSampler {
    w: usize,
    h: usize,
    planes: Vec<Vec<f32>>,
    /// Summed-area table of each plane, `(w + 1) x (h + 1)`.
    sums: Vec<Vec<f64>>,
    /// Scratch: the distinct column edges of a patch.
    xs: Vec<(usize, f64)>,
    /// Scratch: the edges' fractions, the runs of edges on consecutive
    /// table columns, and the chunks and single edges they are read by
    /// (see [`Chunks`]).
    gs: Vec<f64>,
    runs: Vec<(usize, usize, usize)>,
    chunks: Vec<(usize, usize)>,
    singles: Vec<usize>,
    /// Scratch (area averaging): per output column, its edges' indices in
    /// `xs` ...
    spans: Vec<(usize, usize)>,
    /// ... and its width.
    widths: Vec<f64>,
    /// Scratch (bilinear): per output column its two source columns and
    /// weight; two source rows interpolated along x.
    columns: Vec<(usize, usize, f32)>,
    lines: [Vec<f32>; 2],
    /// Scratch: the table interpolated at the column edges of two rows.
    top: Vec<f64>,
    bottom: Vec<f64>,
    /// Scratch: rows of the table interpolated at the column edges.
    rows: [Vec<f64>; SLOTS],
    /// The loaded region (empty before a load).
    region: Region,
    /// Scratch for loading: one row's values, the column sums above the
    /// region.
    line: Vec<u8>,
    above: Vec<u64>,
    /// Scratch for loading: partial column sums; a row's running sums in
    /// groups ([`table_row`]).
    part: Vec<u32>,
    grouped: Vec<u16>,
}

/// What a plane's values are, per pixel of a frame row.
#[derive(Debug, Clone, Copy)]
enum Columns {
    /// The row's bytes: a one-channel frame.
    Bytes,
    /// One channel of an interleaved frame.
    Channel(usize),
    /// The gray level of an RGB frame.
    Gray,
}

impl Columns {
    /// Plane `k`'s values on a frame of `c` channels: the gray level of an
    /// RGB frame if `gray`, else channel `k` (a gray frame's bytes as they
    /// are).
    fn of(gray: bool, k: usize, c: usize) -> Self {
        match (gray, c) {
            (true, 3) => Self::Gray,
            (_, 1) => Self::Bytes,
            _ => Self::Channel(k),
        }
    }

    /// The values of pixels `0..n` of a frame row of `c` channels: the
    /// row's own bytes, or converted into `line`.
    #[inline(always)]
    fn values<'a>(self, row: &'a [u8], c: usize, n: usize, line: &'a mut [u8]) -> &'a [u8] {
        let line = &mut line[..n];
        match self {
            Self::Bytes => return &row[..n],
            Self::Channel(ch) => {
                for (o, p) in line.iter_mut().zip(row[..n * c].chunks_exact(c)) {
                    *o = p[ch];
                }
            }
            Self::Gray => {
                for (o, p) in line.iter_mut().zip(row[..3 * n].chunks_exact(3)) {
                    *o = gray_level(p);
                }
            }
        }
        line
    }
}

/// Rows or values added up in `u32` at a time (below 2^32: 255 * 2^24 <
/// 2^32).
const PART: usize = 1 << 24;

/// The sum of some bytes (exact: partial sums in `u32` over at most
/// [`PART`] bytes at a time, added in `u64`).
#[inline(always)]
fn byte_sum(v: &[u8]) -> u64 {
    v.chunks(PART)
        .map(|b| u64::from(b.iter().map(|&p| u32::from(p)).sum::<u32>()))
        .sum()
}

/// The column sums of rows `0..rows` of `frame` over the columns of
/// `above`, added into it: of the gray levels of an RGB frame if `gray`,
/// else of the row's bytes (every channel of an interleaved frame in
/// place). Exact integers: partial sums in `u32` over at most [`PART`]
/// rows at a time, then added to the `u64`s.
struct ColumnSums<'a> {
    frame: ImageView<'a, u8>,
    rows: usize,
    gray: bool,
    above: &'a mut [u64],
    part: &'a mut [u32],
}

impl Kernel for ColumnSums<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let n = self.above.len();
        let part = &mut self.part[..n];
        let mut y = 0;
        while y < self.rows {
            let end = self.rows.min(y + PART);
            part.fill(0);
            for y in y..end {
                let row = self.frame.row(y);
                if self.gray {
                    for (a, p) in part.iter_mut().zip(row[..3 * n].chunks_exact(3)) {
                        *a += u32::from(gray_level(p));
                    }
                } else {
                    for (a, &p) in part.iter_mut().zip(&row[..n]) {
                        *a += u32::from(p);
                    }
                }
            }
            for (a, &p) in self.above.iter_mut().zip(&*part) {
                *a += u64::from(p);
            }
            y = end;
        }
    }
}

/// Values per group of [`table_row`]'s running sums.
const GROUP: usize = 8;

/// The four bytes of `x` (lowest first) each in the low byte of a
/// 16-bit lane of a `u64`.
#[inline(always)]
fn spread(x: u32) -> u64 {
    let t = u64::from(x);
    let t = (t | t << 16) & 0x0000_ffff_0000_ffff;
    (t | t << 8) & 0x00ff_00ff_00ff_00ff
}

/// One row of a plane and of its summed-area table in a region: the
/// values `v` as `f32`, and each table entry the one above (`upper`, from
/// the region's first column to one past its last) plus the row's sum up
/// to it (`left`, the sum left of the region, plus the running sum of
/// `v`), into `lower`; `sums`: scratch, as long as `v`.
///
/// Every entry is an exact integer below 2^53 (for any frame of under
/// 2^45 pixels), so any way of adding it up gives the same bits. Each
/// group of [`GROUP`] values is summed up to each of its values in the
/// 16-bit lanes of two `u64`s (at most 8 * 255: no carry between lanes),
/// the values spread one a lane and multiplied by `0x0001_0001_0001_0001`
/// (each lane the sum of the lanes up to it), the first four's total
/// added to the last four: one pass over the row with no dependence from
/// group to group (the compiler vectorises it across groups). Then each
/// table entry is the one above plus the row's sum before the group (in
/// `f64`) plus its sum in the group, in vector lanes.
#[inline(always)]
fn table_row(
    left: u64,
    v: &[u8],
    upper: &[f64],
    lower: &mut [f64],
    dst: &mut [f32],
    sums: &mut [u16],
) {
    const ONES: u64 = 0x0001_0001_0001_0001;
    let n = v.len();
    let (upper, lower) = (&upper[..=n], &mut lower[..=n]);
    let (dst, sums) = (&mut dst[..n], &mut sums[..n]);
    for (d, &p) in dst.iter_mut().zip(v) {
        *d = f32::from(p);
    }
    let (groups, rest) = v.as_chunks::<GROUP>();
    let (sums, _) = sums.as_chunks_mut::<GROUP>();
    for (s, &p) in sums.iter_mut().zip(groups) {
        let p = u64::from_le_bytes(p);
        let a = spread(p as u32).wrapping_mul(ONES);
        let b = (spread((p >> 32) as u32) + (a >> 48)).wrapping_mul(ONES);
        *s = std::array::from_fn(|l| ((if l < 4 { a } else { b }) >> (16 * (l % 4))) as u16);
    }
    // (through i64: the same value, u64 -> f64 has no one-instruction form
    // before AVX-512)
    let mut run = left as i64 as f64;
    lower[0] = upper[0] + run;
    let (outs, outs_rest) = lower[1..].as_chunks_mut::<GROUP>();
    let (ups, ups_rest) = upper[1..].as_chunks::<GROUP>();
    for ((o, u), s) in outs.iter_mut().zip(ups).zip(&*sums) {
        *o = std::array::from_fn(|l| u[l] + (run + f64::from(s[l])));
        run += f64::from(s[GROUP - 1]);
    }
    for ((o, &u), &p) in outs_rest.iter_mut().zip(ups_rest).zip(rest) {
        run += f64::from(p);
        *o = u + run;
    }
}

/// Rows `y0..y1` of a region of `frame` into every plane and its
/// summed-area table (the tables' row `y0` filled before): per row and
/// plane, the values up to the region's right edge ([`Columns::values`]),
/// their sum left of the region, then [`table_row`]; all the rows in one
/// dispatch.
struct FillRows<'a> {
    frame: ImageView<'a, u8>,
    region: Region,
    /// Planes of gray levels (see [`Columns::of`]).
    gray: bool,
    planes: &'a mut [Vec<f32>],
    sums: &'a mut [Vec<f64>],
    line: &'a mut [u8],
    /// Scratch for [`table_row`].
    grouped: &'a mut [u16],
}

impl Kernel for FillRows<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self {
            frame,
            region: r,
            gray,
            planes,
            sums,
            line,
            grouped,
        } = self;
        let (w, c) = (frame.width(), frame.channels());
        let cols = w + 1;
        for y in r.y0..r.y1 {
            let row = frame.row(y);
            for (k, (plane, sum)) in planes.iter_mut().zip(sums.iter_mut()).enumerate() {
                let v = Columns::of(gray, k, c).values(row, c, r.x1, line);
                let (upper, lower) = sum[y * cols..][..2 * cols].split_at_mut(cols);
                table_row(
                    byte_sum(&v[..r.x0]),
                    &v[r.x0..],
                    &upper[r.x0..=r.x1],
                    &mut lower[r.x0..=r.x1],
                    &mut plane[y * w..][r.x0..r.x1],
                    grouped,
                );
            }
        }
    }
}

/// A pixel rectangle `[x0, x1) x [y0, y1)` of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Region {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Region {
    /// The whole of a `w x h` frame.
    pub fn whole(w: usize, h: usize) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        }
    }

    /// Whether it has no pixel.
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// Whether `other` lies inside (an empty region lies nowhere).
    pub fn contains(&self, other: &Region) -> bool {
        !other.is_empty()
            && self.x0 <= other.x0
            && self.y0 <= other.y0
            && other.x1 <= self.x1
            && other.y1 <= self.y1
    }

    /// The smallest region holding both (an empty one adds nothing).
    pub fn union(&self, other: &Region) -> Region {
        if self.is_empty() {
            return *other;
        }
        if other.is_empty() {
            return *self;
        }
        Region {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
    }

    /// Grown by `m` pixels on each side, clipped to a `w x h` frame.
    pub fn grown(&self, m: usize, w: usize, h: usize) -> Region {
        Region {
            x0: self.x0.saturating_sub(m),
            y0: self.y0.saturating_sub(m),
            x1: self.x1.saturating_add(m).min(w),
            y1: self.y1.saturating_add(m).min(h),
        }
    }

    /// The pixels that [`PatchSampler::sample`] reads on a `w x h` frame
    /// for an `ow x oh` patch from `(x0, y0)` in steps `(sx, sy)`, with two
    /// pixels to spare on each side, clipped to the frame (outside it,
    /// edge replication reads the frame's edge) and at least two pixels
    /// wide and high where the frame is; `None` for an empty frame or
    /// arguments that `sample` refuses.
    #[allow(clippy::too_many_arguments)]
    pub fn of_sample(
        w: usize,
        h: usize,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        ow: usize,
        oh: usize,
    ) -> Option<Region> {
        let finite = [x0, y0, sx, sy].iter().all(|v| v.is_finite());
        if w == 0 || h == 0 || !finite || sx <= 0.0 || sy <= 0.0 {
            return None;
        }
        // every edge (area) or sample point (bilinear) lies in [a, a + n s];
        // the table is read at floor(edge) and the next column
        let span = |a: f64, s: f64, n: usize, size: usize| -> (usize, usize) {
            let lo = (a.floor() - 2.0).clamp(0.0, size.saturating_sub(2) as f64) as usize;
            let hi = ((a + n as f64 * s).ceil() + 2.0).clamp(0.0, size as f64) as usize;
            (lo, hi.max(lo + 2).min(size))
        };
        let (rx0, rx1) = span(x0, sx, ow, w);
        let (ry0, ry1) = span(y0, sy, oh, h);
        Some(Region {
            x0: rx0,
            y0: ry0,
            x1: rx1,
            y1: ry1,
        })
    }
}

impl PatchSampler {
    /// An empty sampler (load a frame first).
    pub fn new() -> Self {
        Self::default()
    }

    /// Loads `frame` (interleaved `u8`): one plane per channel, the whole
    /// frame.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for an empty frame.
    pub fn load(&mut self, frame: ImageView<'_, u8>) -> Result<()> {
        let whole = Region::whole(frame.width(), frame.height());
        self.load_region(frame, whole)
    }

    /// Loads the pixels of `region` of `frame` (interleaved `u8`), one plane
    /// per channel: afterwards [`PatchSampler::sample`] returns the same
    /// values, bit for bit, as after [`PatchSampler::load`] for every call
    /// whose footprint ([`Region::of_sample`]) lies inside `region` (the
    /// summed-area table keeps the whole frame's values: the sums above and
    /// left of the region are added in, exact integers). Reads outside it
    /// are not defined: check with [`PatchSampler::holds`].
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for an empty frame or a region that
    /// is empty or not inside the frame.
    pub fn load_region(&mut self, frame: ImageView<'_, u8>, region: Region) -> Result<()> {
        self.load_at(SimdLevel::Avx512, frame, region, false)
    }

    /// Loads the gray levels of `region` of `frame` as one plane: a gray
    /// frame as it is, an RGB frame converted exactly as
    /// `bayestrack_image::rgb_to_gray_into` converts it (BT.601, 16-bit
    /// fixed point, rounded), only in `region` and above and left of it;
    /// otherwise as [`PatchSampler::load_region`].
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for an empty frame, a frame of other
    /// than 1 or 3 channels, or a region that is empty or not inside the
    /// frame.
    pub fn load_gray_region(&mut self, frame: ImageView<'_, u8>, region: Region) -> Result<()> {
        self.load_at(SimdLevel::Avx512, frame, region, true)
    }

    /// [`PatchSampler::load_gray_region`] if `gray`, else
    /// [`PatchSampler::load_region`], with the kernels at `level` (or the
    /// best level below it this CPU runs): the same bits at every level.
    fn load_at(
        &mut self,
        level: SimdLevel,
        frame: ImageView<'_, u8>,
        region: Region,
        gray: bool,
    ) -> Result<()> {
        let c = frame.channels();
        if gray && c != 1 && c != 3 {
            return Err(DcfError::InvalidParameter {
                name: "frame channels",
                value: c as f64,
                reason: "gray levels are read from 1- or 3-channel frames",
            });
        }
        self.prepare(frame, region, if gray { 1 } else { c })?;
        self.fill(level, frame, gray);
        Ok(())
    }

    /// The region loaded last (empty before any load).
    pub fn region(&self) -> Region {
        self.region
    }

    /// Whether the loaded region holds `region`.
    pub fn holds(&self, region: &Region) -> bool {
        self.region.contains(region)
    }

    /// Checks the frame and region, sizes the buffers for `planes` planes.
    fn prepare(&mut self, frame: ImageView<'_, u8>, region: Region, planes: usize) -> Result<()> {
        let (w, h, c) = (frame.width(), frame.height(), frame.channels());
        if w == 0 || h == 0 || c == 0 {
            return Err(DcfError::InvalidParameter {
                name: "frame",
                value: 0.0,
                reason: "is empty",
            });
        }
        let r = region;
        if !(r.x0 < r.x1 && r.y0 < r.y1 && r.x1 <= w && r.y1 <= h) {
            return Err(DcfError::InvalidParameter {
                name: "region",
                value: r.x1.max(r.y1) as f64,
                reason: "must be a non-empty rectangle inside the frame",
            });
        }
        (self.w, self.h) = (w, h);
        // nothing is readable until the planes are filled
        self.region = Region::default();
        self.planes.resize_with(planes, Vec::new);
        self.sums.resize_with(planes, Vec::new);
        for (plane, sum) in self.planes.iter_mut().zip(self.sums.iter_mut()) {
            // entries outside the region keep what they held: never read
            plane.resize(w * h, 0.0);
            sum.resize((w + 1) * (h + 1), 0.0);
        }
        self.line.resize(r.x1, 0);
        self.above.resize(r.x1 * c, 0);
        self.part.resize(r.x1 * c, 0);
        self.grouped.resize(r.x1 - r.x0, 0);
        self.region = r;
        Ok(())
    }

    /// Fills every plane and its summed-area table in the loaded region:
    /// gray levels if `gray` (one plane), else one plane per channel (see
    /// [`Columns::of`]); the kernels at `level` (or the best level below
    /// it this CPU runs): the same bits at every level.
    fn fill(&mut self, level: SimdLevel, frame: ImageView<'_, u8>, gray: bool) {
        let (w, r, c) = (self.w, self.region, frame.channels());
        let cols = w + 1;
        // every entry of the table is an exact integer (below 2^53 for any
        // frame of under 2^45 pixels): integer sums in any order give the
        // whole frame's values bit for bit (converted through i64, the
        // same value: u64 -> f64 has no one-instruction form before
        // AVX-512). Column sums of the rows above the region (u64: any
        // height), of the gray levels or of every channel in place:
        let stride = if gray { 1 } else { c };
        let above = &mut self.above[..r.x1 * stride];
        above.fill(0);
        level.run(ColumnSums {
            frame,
            rows: r.y0,
            gray: gray && c == 3,
            above: &mut *above,
            part: &mut self.part,
        });
        // each table's row y0 at columns x0..=x1
        for (k, sum) in self.sums.iter_mut().enumerate() {
            let top = &mut sum[r.y0 * cols..][..cols];
            let mut t: u64 = above[..r.x0 * stride].iter().skip(k).step_by(stride).sum();
            top[r.x0] = t as i64 as f64;
            for x in r.x0..r.x1 {
                t += above[x * stride + k];
                top[x + 1] = t as i64 as f64;
            }
        }
        level.run(FillRows {
            frame,
            region: r,
            gray,
            planes: &mut self.planes,
            sums: &mut self.sums,
            line: &mut self.line,
            grouped: &mut self.grouped,
        });
    }

    /// Channels loaded.
    pub fn channels(&self) -> usize {
        self.planes.len()
    }

    /// Frame width.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Frame height.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Fills `out` (`ow x oh`, row-major) from channel `ch`: output pixel
    /// `(u, v)` covers `[x0 + u sx, x0 + (u + 1) sx] x [y0 + v sy, ...]`
    /// in frame coordinates (pixel `i` covers `[i, i + 1]`).
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a channel not loaded;
    /// image errors for non-finite or non-positive steps.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &mut self,
        ch: usize,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        out: &mut [f32],
        ow: usize,
        oh: usize,
    ) -> Result<()> {
        self.sample_scaled(ch, x0, y0, sx, sy, out, ow, oh, 1.0)
    }

    /// [`PatchSampler::sample`] with every output value times `gain` (in
    /// `f32`, as the same multiplication in a pass over the patch
    /// afterwards gives, bit for bit; a gain of 1 changes nothing).
    ///
    /// # Errors
    /// As [`PatchSampler::sample`].
    #[allow(clippy::too_many_arguments)]
    pub fn sample_scaled(
        &mut self,
        ch: usize,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        out: &mut [f32],
        ow: usize,
        oh: usize,
        gain: f32,
    ) -> Result<()> {
        self.sample_at(SimdLevel::Avx512, ch, (x0, y0, sx, sy), out, ow, oh, gain)
    }

    /// [`PatchSampler::sample_scaled`] with the kernels at `level` (or the
    /// best level below it this CPU runs): the same bits at every level.
    #[allow(clippy::too_many_arguments)]
    fn sample_at(
        &mut self,
        level: SimdLevel,
        ch: usize,
        at: (f64, f64, f64, f64),
        out: &mut [f32],
        ow: usize,
        oh: usize,
        gain: f32,
    ) -> Result<()> {
        let (x0, y0, sx, sy) = at;
        if ch >= self.planes.len() {
            return Err(DcfError::InvalidParameter {
                name: "channel",
                value: ch as f64,
                reason: "not loaded",
            });
        }
        if ![x0, y0, sx, sy].iter().all(|v| v.is_finite()) || sx <= 0.0 || sy <= 0.0 {
            return Err(DcfError::NonFinite {
                what: "sampling origin or steps",
            });
        }
        if out.len() != ow * oh {
            return Err(DcfError::Size {
                what: "patch",
                expected: ow * oh,
                got: out.len(),
            });
        }
        if sx >= 1.0 && sy >= 1.0 {
            self.area(level, ch, at, out, ow, gain);
            return Ok(());
        }
        let (w, h) = (self.w, self.h);
        self.columns.clear();
        self.columns
            .extend((0..ow).map(|u| split(x0 + (u as f64 + 0.5) * sx - 0.5, w)));
        let [top, bottom] = &mut self.lines;
        level.run(BilinearRows {
            plane: &self.planes[ch],
            w,
            h,
            y0,
            sy,
            columns: &self.columns,
            top,
            bottom,
            out,
            ow,
            gain,
        });
        Ok(())
    }
}

/// A sample coordinate `c` on an axis of `n` pixels: the pixels either
/// side (the edge pixel twice outside) and the fraction between them.
#[inline(always)]
fn split(c: f64, n: usize) -> (usize, usize, f32) {
    let c = c.clamp(0.0, (n - 1) as f64);
    // c >= 0: truncation is the floor
    let i = (c as usize).min(n - 1);
    let j = (i + 1).min(n - 1);
    (i, j, (c - i as f64) as f32)
}

/// A source row interpolated along x at every output column.
#[inline(always)]
fn along_columns(row: &[f32], columns: &[(usize, usize, f32)], out: &mut [f32]) {
    for (o, &(xa, xb, fx)) in out.iter_mut().zip(columns) {
        *o = row[xa] + fx * (row[xb] - row[xa]);
    }
}

/// The rows of a bilinearly interpolated patch: each source row
/// interpolated along x at every output column, kept while output rows
/// read it (the same values: each is interpolated the same way), then
/// each output row between two of them.
struct BilinearRows<'a> {
    plane: &'a [f32],
    w: usize,
    h: usize,
    y0: f64,
    sy: f64,
    columns: &'a [(usize, usize, f32)],
    top: &'a mut Vec<f32>,
    bottom: &'a mut Vec<f32>,
    out: &'a mut [f32],
    ow: usize,
    gain: f32,
}

impl Kernel for BilinearRows<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self {
            plane,
            w,
            h,
            y0,
            sy,
            columns,
            top,
            bottom,
            out,
            ow,
            gain,
        } = self;
        top.resize(ow, 0.0);
        bottom.resize(ow, 0.0);
        let (mut at_top, mut at_bottom) = (usize::MAX, usize::MAX);
        for (v, orow) in out.chunks_exact_mut(ow).enumerate() {
            let (ya, yb, fy) = split(y0 + (v as f64 + 0.5) * sy - 0.5, h);
            if at_top != ya {
                if at_bottom == ya {
                    std::mem::swap(top, bottom);
                    std::mem::swap(&mut at_top, &mut at_bottom);
                } else {
                    along_columns(&plane[ya * w..][..w], columns, top);
                    at_top = ya;
                }
            }
            if at_bottom != yb {
                along_columns(&plane[yb * w..][..w], columns, bottom);
                at_bottom = yb;
            }
            for ((o, &top), &bot) in orow.iter_mut().zip(&top[..ow]).zip(&bottom[..ow]) {
                *o = (top + fy * (bot - top)) * gain;
            }
        }
    }
}

/// A rectangle's edges `[a, b]` along an axis of `n` pixels: clipped to
/// it, or, with no area left, the nearest pixel (edge replication).
#[inline(always)]
fn edges(a: f64, b: f64, n: usize) -> (f64, f64) {
    let (lo, hi) = (a.clamp(0.0, n as f64), b.clamp(0.0, n as f64));
    if hi - lo > 1e-9 {
        (lo, hi)
    } else {
        // lo >= 0: truncation is the floor
        let p = (lo.min(n as f64 - 0.5) as usize) as f64;
        (p, p + 1.0)
    }
}

/// Two rows of a summed-area table interpolated along x at the column
/// edges `xs`, in one pass (the same values as [`along_edges`] on each).
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn along_edges2(rows: [&[f64]; 2], xs: &[(usize, f64)], out: [&mut [f64]; 2]) {
    let [ra, rb] = rows;
    let [oa, ob] = out;
    // (one length for both rows, one for the edges and outputs, and an
    // index loop: fewer bounds tests and live pointers than zipped
    // iterators, a tenth fewer instructions)
    let len = ra.len().min(rb.len());
    let (ra, rb) = (&ra[..len], &rb[..len]);
    let n = xs.len().min(oa.len()).min(ob.len());
    let (oa, ob, xs) = (&mut oa[..n], &mut ob[..n], &xs[..n]);
    for k in 0..n {
        let (i, g) = xs[k];
        let (a, b) = (&ra[i..][..2], &rb[i..][..2]);
        oa[k] = a[0] + g * (a[1] - a[0]);
        ob[k] = b[0] + g * (b[1] - b[0]);
    }
}

/// Row `j` of a summed-area table interpolated along x at the column
/// edges `xs` (each its table column and the fraction to the next).
#[inline(always)]
fn along_edges(row: &[f64], xs: &[(usize, f64)], out: &mut [f64]) {
    for (o, &(i, g)) in out.iter_mut().zip(xs) {
        let [a0, a1]: [f64; 2] = row[i..i + 2].try_into().unwrap_or_default();
        *o = a0 + g * (a1 - a0);
    }
}

/// Edges per chunk of [`along_chunks`] (one AVX2 vector of `f64`).
const LANES: usize = 4;

/// The column edges read along x in chunks of [`LANES`] edges on
/// consecutive table columns: chunk `(k, i)` is edges `k..k + LANES`, read
/// from table columns `i..=i + LANES`, with every edge's fraction in `gs`
/// (`LANES - 1` more entries after the last edge's); `singles` are edges
/// read one by one, from `xs`.
///
/// A patch's steps are at least 1 along x, so when they are under 2 most
/// edges sit one table column after the one before: each run of such
/// edges reads its table row and the row shifted by one as contiguous
/// slices (vector loads, no gather), in one flat list of chunks for the
/// whole row (no per-run setup). A run of `LANES` edges or more is cut
/// into chunks, its last chunk ending at its last edge (overlapping the one
/// before: an edge written twice gets the same bits). A shorter run is one
/// chunk writing past its last edge, onto edges of later runs, whose own
/// chunks come after it in the list and write them again (and onto the
/// `LANES - 1` spare entries after the last edge); where that chunk would
/// read past the end of the table row, the run's edges are singles,
/// read after every chunk.
#[derive(Clone, Copy)]
struct Chunks<'a> {
    chunks: &'a [(usize, usize)],
    singles: &'a [usize],
    xs: &'a [(usize, f64)],
    gs: &'a [f64],
}

impl Chunks<'_> {
    /// The edges `xs` as runs on consecutive table columns, into `runs`:
    /// each run `(k0, k1, i)` the edges `k0..k1`, edge `k` on table column
    /// `i + k - k0`.
    fn find_runs(xs: &[(usize, f64)], runs: &mut Vec<(usize, usize, usize)>) {
        runs.clear();
        for (k, &(i, _)) in xs.iter().enumerate() {
            match runs.last_mut() {
                Some((k0, k1, i0)) if *k1 == k && *i0 + (k - *k0) == i => *k1 = k + 1,
                _ => runs.push((k, k + 1, i)),
            }
        }
    }

    /// The chunks and singles of the runs `runs` of the edges `xs` on a
    /// table of `cols` columns, into `chunks` and `singles`, and the
    /// edges' fractions into `gs`.
    fn cut(
        xs: &[(usize, f64)],
        runs: &[(usize, usize, usize)],
        cols: usize,
        chunks: &mut Vec<(usize, usize)>,
        singles: &mut Vec<usize>,
        gs: &mut Vec<f64>,
    ) {
        gs.clear();
        gs.extend(xs.iter().map(|&(_, g)| g));
        gs.resize(xs.len() + LANES - 1, 0.0);
        chunks.clear();
        singles.clear();
        for &(k0, k1, i) in runs {
            let len = k1 - k0;
            if len < LANES && i + LANES + 1 > cols {
                singles.extend(k0..k1);
                continue;
            }
            let mut t = 0;
            while t + LANES < len {
                chunks.push((k0 + t, i + t));
                t += LANES;
            }
            let t = len.max(LANES) - LANES;
            chunks.push((k0 + t, i + t));
        }
    }
}

/// `R` rows of a summed-area table interpolated along x at the edges of
/// `c`, into `out` (each at least `LANES - 1` entries longer than the
/// edges): the same values as [`along_edges`] on each (the same arithmetic
/// on each edge), [`LANES`] edges at a time.
#[inline(always)]
fn along_chunks<const R: usize>(rows: [&[f64]; R], c: Chunks<'_>, out: [&mut [f64]; R]) {
    // every chunk lies in the rows and the outputs (as cut); its indices
    // clamped to them all the same, so that the compiler sees it (no test
    // per chunk)
    let cols = rows.iter().map(|r| r.len()).min().unwrap_or(0);
    let len = out.iter().map(|o| o.len()).fold(c.gs.len(), usize::min);
    if cols < LANES + 1 || len < LANES {
        return;
    }
    let (last_i, last_k) = (cols - LANES - 1, len - LANES);
    // (one length for the rows, one for the outputs: one test each)
    let rows = rows.map(|r| &r[..cols]);
    let mut out = out.map(|o| &mut o[..len]);
    for &(k, i) in c.chunks {
        let (k, i) = (k.min(last_k), i.min(last_i));
        // (whole arrays: the loads and stores of a chunk are vector ones)
        let g: &[f64; LANES] = c.gs[k..k + LANES].try_into().unwrap_or(&[0.0; LANES]);
        for (row, o) in rows.iter().zip(out.iter_mut()) {
            let a: &[f64; LANES + 1] = row[i..i + LANES + 1]
                .try_into()
                .unwrap_or(&[0.0; LANES + 1]);
            let o: &mut [f64; LANES] = match (&mut o[k..k + LANES]).try_into() {
                Ok(o) => o,
                Err(_) => continue,
            };
            *o = std::array::from_fn(|l| a[l] + g[l] * (a[l + 1] - a[l]));
        }
    }
    for &k in c.singles {
        let (i, g) = c.xs[k];
        for (row, o) in rows.iter().zip(out.iter_mut()) {
            let [a0, a1]: [f64; 2] = row[i..i + 2].try_into().unwrap_or_default();
            o[k] = a0 + g * (a1 - a0);
        }
    }
}

/// Table rows interpolated along x kept at once: row `j` in slot
/// `j % SLOTS` (a row edge reads rows `j` and `j + 1`, and interpolating
/// `j + 2` in the same pass needs a third slot; a power of two).
const SLOTS: usize = 4;

/// A summed-area table read at the column edges `xs`, along x by `chunks`
/// if `CHUNKS` (a path compiled for each: the edge-by-edge one as before
/// chunks were looked for).
struct Table<'a, const CHUNKS: bool> {
    sum: &'a [f64],
    cols: usize,
    h: usize,
    xs: &'a [(usize, f64)],
    chunks: Chunks<'a>,
}

impl<const CHUNKS: bool> Table<'_, CHUNKS> {
    /// Row `j` of the table.
    #[inline(always)]
    fn row(&self, j: usize) -> &[f64] {
        &self.sum[j * self.cols..][..self.cols]
    }

    /// Table row `j` interpolated along x at every column edge, into `o`.
    #[inline(always)]
    fn along(&self, j: usize, o: &mut [f64]) {
        if CHUNKS {
            along_chunks([self.row(j)], self.chunks, [o]);
        } else {
            along_edges(self.row(j), self.xs, o);
        }
    }

    /// Table rows `j` and `j + 1` interpolated along x at every column
    /// edge, into `out` (the same values as [`Table::along`] on each).
    #[inline(always)]
    fn along2(&self, j: usize, out: [&mut [f64]; 2]) {
        if CHUNKS {
            along_chunks([self.row(j), self.row(j + 1)], self.chunks, out);
        } else {
            along_edges2([self.row(j), self.row(j + 1)], self.xs, out);
        }
    }

    /// The table at row coordinate `y` at every column edge, into `o`,
    /// from table rows interpolated along x kept in `rows` (row `j` in
    /// slot `j % SLOTS`; `held`: which row each slot holds): the same
    /// values as interpolating both rows along x for each edge (each table
    /// row is interpolated the same way whichever edge reads it). Where
    /// the row below is missing and `ahead`, the one after it is
    /// interpolated in the same pass (the next edge reads it when the step
    /// is under 2).
    #[inline(always)]
    fn row_at(
        &self,
        y: f64,
        ahead: bool,
        rows: &mut [Vec<f64>; SLOTS],
        held: &mut [usize; SLOTS],
        o: &mut [f64],
    ) {
        // y >= 0 (an edge clamped to the frame) and below 2^53: through
        // i64 the same integers as through u64, one conversion instruction
        // each way (u64 <-> f64 takes several before AVX-512)
        let j = (y as i64 as usize).min(self.h - 1);
        let f = y - j as i64 as f64;
        let (a, b, c) = (j % SLOTS, (j + 1) % SLOTS, (j + 2) % SLOTS);
        if held[b] != j + 1 {
            if let Ok([ra, rb, rc]) = rows.get_disjoint_mut([a, b, c]) {
                if held[a] != j {
                    self.along2(j, [ra, rb]);
                    held[a] = j;
                } else if ahead && j + 2 <= self.h {
                    self.along2(j + 1, [rb, rc]);
                    held[c] = j + 2;
                } else {
                    self.along(j + 1, rb);
                }
            }
            held[b] = j + 1;
        } else if held[a] != j {
            self.along(j, &mut rows[a]);
            held[a] = j;
        }
        let n = self.xs.len();
        let (ra, rb) = (&rows[a][..n], &rows[b][..n]);
        for ((o, &a), &b) in o[..n].iter_mut().zip(ra).zip(rb) {
            *o = a + f * (b - a);
        }
    }
}

/// The rows of an area-averaged patch (see [`PatchSampler::area`]): the
/// table interpolated along x at the column edges once per table row
/// (kept while the next edge reads it), then along y at each row edge,
/// then each output pixel from its four corners (the table read along x
/// by chunks of edges if `CHUNKS`).
struct AreaRows<'a, const CHUNKS: bool> {
    sum: &'a [f64],
    w: usize,
    h: usize,
    y0: f64,
    sy: f64,
    xs: &'a [(usize, f64)],
    chunks: Chunks<'a>,
    spans: &'a [(usize, usize)],
    widths: &'a [f64],
    /// The table at the row edges above and below an output row.
    top: &'a mut Vec<f64>,
    bottom: &'a mut Vec<f64>,
    /// Table rows interpolated along x.
    rows: &'a mut [Vec<f64>; SLOTS],
    out: &'a mut [f32],
    ow: usize,
    gain: f32,
}

impl<const CHUNKS: bool> Kernel for AreaRows<'_, CHUNKS> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self {
            sum,
            w,
            h,
            y0,
            sy,
            xs,
            chunks,
            spans,
            widths,
            top,
            bottom,
            rows,
            out,
            ow,
            gain,
        } = self;
        let cols = w + 1;
        let n = xs.len();
        top.resize(n, 0.0);
        bottom.resize(n, 0.0);
        for r in rows.iter_mut() {
            // (the chunks' spare entries after the last edge)
            r.resize(n + LANES - 1, 0.0);
        }
        // the table rows held in `rows`
        let mut held = [usize::MAX; SLOTS];
        // consecutive row edges a step under 2 apart read the table row
        // after the one below the first
        let ahead = sy < 2.0;
        let table = Table::<CHUNKS> {
            sum,
            cols,
            h,
            xs,
            chunks,
        };
        // every column's left edge the previous one's right edge (all but
        // patches running off the frame's side)
        let contiguous = n == ow + 1;
        let mut bottom_at = f64::NAN;
        // the output row's index as f64, counted (exact integers: the same
        // values as converting it, without a u64 conversion per row)
        let mut v = 0.0;
        for row in out.chunks_exact_mut(ow) {
            let (a, b) = edges(y0 + v * sy, y0 + (v + 1.0) * sy, h);
            v += 1.0;
            if a == bottom_at {
                std::mem::swap(top, bottom);
            } else {
                table.row_at(a, ahead, rows, &mut held, top);
            }
            table.row_at(b, ahead, rows, &mut held, bottom);
            bottom_at = b;
            let inv_h = 1.0 / (b - a);
            if contiguous {
                // column u spans edges u and u + 1: no gather
                let (tl, tr) = (&top[..ow], &top[1..=ow]);
                let (bl, br) = (&bottom[..ow], &bottom[1..=ow]);
                let corners = tl.iter().zip(tr).zip(bl.iter().zip(br));
                for ((o, ((&tl, &tr), (&bl, &br))), &cw) in row.iter_mut().zip(corners).zip(widths)
                {
                    let s = br - bl - tr + tl;
                    *o = (s * inv_h / cw) as f32 * gain;
                }
            } else {
                for ((o, &(ia, ib)), &cw) in row.iter_mut().zip(spans).zip(widths) {
                    let s = bottom[ib] - bottom[ia] - top[ib] + top[ia];
                    *o = (s * inv_h / cw) as f32 * gain;
                }
            }
        }
    }
}

impl PatchSampler {
    /// Area averaging: each output pixel the mean of the plane over its
    /// rectangle clipped to the frame (the summed-area table interpolated
    /// bilinearly at the rectangle's corners); a rectangle left with no
    /// area reads the nearest pixel (edge replication).
    ///
    /// Neighbouring rectangles share their edges: the table is interpolated
    /// once per distinct edge (about one corner per output pixel instead of
    /// four), and along x once per table row, the same values bit for bit;
    /// along x in vector chunks over the runs of edges on consecutive
    /// table columns where they average 3 edges or more on rows of 24
    /// edges or more ([`Chunks`]: steps under 4/3), edge by edge otherwise.
    fn area(
        &mut self,
        level: SimdLevel,
        ch: usize,
        at: (f64, f64, f64, f64),
        out: &mut [f32],
        ow: usize,
        gain: f32,
    ) {
        let (x0, y0, sx, sy) = at;
        let (w, h) = (self.w, self.h);
        // the distinct column edges (xs: each as its table column and the
        // fraction to the next one) and each column's pair of indices into
        // them with its width
        self.xs.clear();
        self.spans.clear();
        self.widths.clear();
        let at = |x: f64| -> (usize, f64) {
            // x >= 0: truncation is the floor
            let i = (x as usize).min(w - 1);
            (i, x - i as f64)
        };
        let mut last = f64::NAN;
        for u in 0..ow {
            let (a, b) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
            let ia = if a == last {
                self.xs.len() - 1
            } else {
                self.xs.push(at(a));
                self.xs.len() - 1
            };
            self.xs.push(at(b));
            last = b;
            self.spans.push((ia, self.xs.len() - 1));
            self.widths.push(b - a);
        }
        // the edges as runs on consecutive table columns (vector loads
        // along x), where the runs average at least `MIN_RUN` edges; not
        // even looked for on rows of under `MIN_EDGES` edges or steps of
        // 4/3 or more (runs of under 3 edges), where they would not pay
        const MIN_RUN: usize = 3;
        const MIN_EDGES: usize = 24;
        self.runs.clear();
        let wanted = self.xs.len() >= MIN_EDGES && 3.0 * sx < 4.0;
        if wanted {
            Chunks::find_runs(&self.xs, &mut self.runs);
        }
        let use_chunks = wanted && MIN_RUN * self.runs.len() <= self.xs.len();
        if use_chunks {
            let (chunks, singles) = (&mut self.chunks, &mut self.singles);
            Chunks::cut(&self.xs, &self.runs, w + 1, chunks, singles, &mut self.gs);
        } else {
            self.chunks.clear();
            self.singles.clear();
        }
        let chunks = Chunks {
            chunks: &self.chunks,
            singles: &self.singles,
            xs: &self.xs,
            gs: &self.gs,
        };
        // (one macro for the two kernels' fields)
        macro_rules! rows {
            ($chunks:literal) => {
                level.run(AreaRows::<$chunks> {
                    sum: &self.sums[ch],
                    w,
                    h,
                    y0,
                    sy,
                    xs: &self.xs,
                    chunks,
                    spans: &self.spans,
                    widths: &self.widths,
                    top: &mut self.top,
                    bottom: &mut self.bottom,
                    rows: &mut self.rows,
                    out,
                    ow,
                    gain,
                })
            };
        }
        if use_chunks {
            rows!(true);
        } else {
            rows!(false);
        }
    }
}

#[cfg(test)]
mod area_tests {
    use super::*;
    use bayestrack_image::Image;

    /// Asserts `got` is `want` bit for bit, pixel by pixel (`what` says
    /// which case and path).
    pub(super) fn assert_bits(got: &[f32], want: &[f32], what: &str) {
        assert_eq!(got.len(), want.len(), "{what}: length");
        for (i, (a, b)) in got.iter().zip(want).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "{what}: pixel {i}: {a} vs {b}");
        }
    }

    /// The area averaging as first written (the table interpolated at
    /// each edge from its coordinate, every column through its two edge
    /// indices): the reference the faster paths must match bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        s: &PatchSampler,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        ow: usize,
        oh: usize,
    ) -> Vec<f32> {
        let (w, h) = (s.w, s.h);
        let cols = w + 1;
        let sum = &s.sums[0];
        let edges = |a: f64, b: f64, n: usize| -> (f64, f64) {
            let (lo, hi) = (a.clamp(0.0, n as f64), b.clamp(0.0, n as f64));
            if hi - lo > 1e-9 {
                (lo, hi)
            } else {
                let p = (lo.min(n as f64 - 0.5) as usize) as f64;
                (p, p + 1.0)
            }
        };
        let at = |x: f64, y: f64| -> f64 {
            let j = (y as usize).min(h - 1);
            let f = y - j as f64;
            let (ra, rb) = (&sum[j * cols..][..cols], &sum[(j + 1) * cols..][..cols]);
            let i = (x as usize).min(w - 1);
            let g = x - i as f64;
            let a = ra[i] + g * (ra[i + 1] - ra[i]);
            let b = rb[i] + g * (rb[i + 1] - rb[i]);
            a + f * (b - a)
        };
        let mut out = Vec::with_capacity(ow * oh);
        for v in 0..oh {
            let (ya, yb) = edges(y0 + v as f64 * sy, y0 + (v + 1) as f64 * sy, h);
            for u in 0..ow {
                let (xa, xb) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
                let s = at(xb, yb) - at(xa, yb) - at(xb, ya) + at(xa, ya);
                out.push((s * (1.0 / (yb - ya)) / (xb - xa)) as f32);
            }
        }
        out
    }

    #[test]
    fn area_matches_the_reference_inside_and_off_the_frame() {
        let img = Image::from_fn(37, 23, |x, y| ((x * 37 + y * 101 + x * y) % 251) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        // inside (every column contiguous), off each side and corner (the
        // edge-replicating columns), steps of odd fractions
        let cases = [
            (2.3, 1.7, 1.37, 1.21, 13, 11),
            (-5.5, 3.0, 1.5, 1.0, 17, 9),
            (20.25, -4.75, 1.125, 2.5, 19, 12),
            (-40.0, -30.0, 3.3, 2.9, 31, 23),
            (30.9, 19.1, 1.01, 1.9, 7, 5),
            (0.0, 0.0, 37.0, 23.0, 1, 1),
            // steps near 1 (table rows shared by consecutive edges), and
            // unit steps running off the bottom (edges in one table row)
            (3.6, 2.2, 1.0375, 1.0375, 25, 17),
            (-2.5, 5.5, 1.0, 1.0, 20, 21),
            (4.25, 0.75, 1.0, 1.0 / 1.0375 + 0.05, 30, 20),
            // the scale filter's small patches, steps either side of 2
            (5.3, -1.2, 1.8, 1.6, 14, 36),
            (11.7, 2.4, 2.2, 1.45, 9, 14),
            // column edges in runs on consecutive table columns (vector
            // loads along x): long runs, runs of exactly 4 and of under 4,
            // runs cut by the frame's left and right edges
            (1.7, 1.2, 1.0375, 1.05, 33, 15),
            (2.0, 0.5, 1.25, 1.3, 27, 13),
            (0.4, 3.3, 1.28, 1.1, 26, 11),
            (-6.3, 1.1, 1.0375, 1.1, 41, 9),
            (14.1, 2.0, 1.2, 1.7, 24, 10),
        ];
        let mut with_runs = 0;
        for (x0, y0, sx, sy, ow, oh) in cases {
            let want = reference(&s, x0, y0, sx, sy, ow, oh);
            let mut got = vec![f32::NAN; ow * oh];
            // the kernels at every level (the public call at the best)
            for level in SimdLevel::ALL {
                got.fill(f32::NAN);
                s.sample_at(level, 0, (x0, y0, sx, sy), &mut got, ow, oh, 1.0)
                    .unwrap();
                assert_bits(&got, &want, &format!("{level:?} {x0},{y0} {sx}x{sy}"));
            }
            s.sample(0, x0, y0, sx, sy, &mut got, ow, oh).unwrap();
            assert_bits(&got, &want, &format!("{x0},{y0} {sx}x{sy}"));
            // a gain: the same values times it, as a pass afterwards
            let gain = 1.0f32 / 255.0;
            s.sample_scaled(0, x0, y0, sx, sy, &mut got, ow, oh, gain)
                .unwrap();
            let scaled: Vec<f32> = want.iter().map(|b| b * gain).collect();
            assert_bits(&got, &scaled, &format!("gain {x0},{y0} {sx}x{sy}"));
            // (the last call's edges: read as runs or edge by edge)
            if !s.chunks.is_empty() {
                with_runs += 1;
            }
        }
        // both ways of reading the table along x are checked
        assert!(
            with_runs >= 5 && cases.len() - with_runs >= 5,
            "{with_runs} of {}",
            cases.len()
        );
    }

    /// Rows of a table read along x by chunks at a level: one row, or two
    /// in one pass if `both`.
    struct AlongChunks<'a> {
        rows: [&'a [f64]; 2],
        c: Chunks<'a>,
        out: [&'a mut [f64]; 2],
        both: bool,
    }

    impl Kernel for AlongChunks<'_> {
        type Output = ();
        #[inline(always)]
        fn run<T: Token>(self, _: T) {
            let [oa, ob] = self.out;
            if self.both {
                along_chunks(self.rows, self.c, [oa, ob]);
            } else {
                along_chunks([self.rows[0]], self.c, [oa]);
            }
        }
    }

    #[test]
    fn chunks_read_the_table_as_edge_by_edge() {
        let cols = 61;
        let row = |r: usize| -> Vec<f64> {
            (0..cols)
                .map(|x| ((x * 7919 + r * 104_729) % 100_003 * 255 + x) as f64)
                .collect()
        };
        let rows = [row(1), row(2)];
        // run lengths (each run's edges on consecutive columns, a gap of
        // one to three columns after it): under, at and over a chunk's
        // edges, short runs last (singles at the row's end)
        let patterns: [&[usize]; 7] = [
            &[1, 1, 1],
            &[2, 5, 3, 1, 4],
            &[4],
            &[9, 1, 8, 2],
            &[3, 3, 3, 3],
            &[7, 12, 6, 4, 3],
            &[5, 4, 8, 1],
        ];
        let (mut runs, mut chunks, mut singles, mut gs) = (vec![], vec![], vec![], vec![]);
        let mut with_singles = 0;
        for (p, lens) in patterns.iter().enumerate() {
            let gap = |r: usize| 1 + (r + p) % 3;
            let span: usize = lens.iter().enumerate().map(|(r, &l)| l + gap(r)).sum();
            // from the row's first column, and ending at its last edge
            // column (`cols - 2`: an edge reads its column and the next)
            for start in [0, cols - 1 - span + gap(lens.len() - 1)] {
                let mut xs = vec![];
                let mut c = start;
                for (r, &l) in lens.iter().enumerate() {
                    for t in 0..l {
                        let g = ((xs.len() * 37 + 11) % 64) as f64 / 64.0 + 1.0 / 3.0;
                        xs.push((c + t, g.fract()));
                    }
                    c += l + gap(r);
                }
                Chunks::find_runs(&xs, &mut runs);
                assert_eq!(runs.len(), lens.len());
                Chunks::cut(&xs, &runs, cols, &mut chunks, &mut singles, &mut gs);
                with_singles += usize::from(!singles.is_empty());
                let c = Chunks {
                    chunks: &chunks,
                    singles: &singles,
                    xs: &xs,
                    gs: &gs,
                };
                let n = xs.len();
                let want: Vec<Vec<f64>> = rows
                    .iter()
                    .map(|r| {
                        let mut o = vec![f64::NAN; n];
                        along_edges(r, &xs, &mut o);
                        o
                    })
                    .collect();
                for level in SimdLevel::ALL {
                    for both in [false, true] {
                        let mut out =
                            [vec![f64::NAN; n + LANES - 1], vec![f64::NAN; n + LANES - 1]];
                        let [oa, ob] = &mut out;
                        level.run(AlongChunks {
                            rows: [&rows[0], &rows[1]],
                            c,
                            out: [oa, ob],
                            both,
                        });
                        for (r, (got, want)) in out
                            .iter()
                            .zip(&want)
                            .enumerate()
                            .take(1 + usize::from(both))
                        {
                            let bits =
                                |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                            assert_eq!(
                                bits(&got[..n]),
                                bits(want),
                                "{level:?} {lens:?} from {start} row {r} of {}",
                                1 + usize::from(both)
                            );
                        }
                    }
                }
            }
        }
        // runs that would read past the row's end were read edge by edge
        assert!(with_singles >= 3, "{with_singles}");
    }

    #[test]
    fn area_matches_the_reference_at_every_step_and_side() {
        // a frame larger than the patches, which are larger than the
        // sequences' own (64 x 160 at steps near 1.1), at steps from 0.5
        // (bilinear) to 3, inside the frame and running off each side and
        // corner
        let (w, h) = (157, 113);
        let img =
            Image::from_fn(w, h, |x, y| ((x * 73 + y * 151 + x * y * 7) % 256) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        let steps = [
            0.5,
            1.0,
            1.0125,
            1.1,
            1.1234,
            1.25,
            4.0 / 3.0,
            1.5,
            1.9,
            2.0,
            2.6,
            3.0,
        ];
        let (ow, oh) = (72, 40);
        let mut by_chunks = 0;
        for (n, &sx) in steps.iter().enumerate() {
            let sy = steps[(n * 5 + 3) % steps.len()];
            let (pw, ph) = (ow as f64 * sx, oh as f64 * sy);
            // inside; off the left, right, top and bottom; the corners
            let places = [
                (7.3, 5.6),
                (-pw / 3.0, 20.2),
                (w as f64 - 2.0 * pw / 3.0, 9.9),
                (11.1, -ph / 2.0),
                (3.4, h as f64 - ph / 4.0),
                (-pw / 2.0, -ph / 2.0),
                (w as f64 - pw / 2.0, h as f64 - ph / 3.0),
                (-2.0 * pw, 4.5),
            ];
            for (x0, y0) in places {
                let mut got = vec![f32::NAN; ow * oh];
                let want = if sx >= 1.0 && sy >= 1.0 {
                    reference(&s, x0, y0, sx, sy, ow, oh)
                } else {
                    s.sample_at(
                        SimdLevel::Scalar,
                        0,
                        (x0, y0, sx, sy),
                        &mut got,
                        ow,
                        oh,
                        1.0,
                    )
                    .unwrap();
                    got.clone()
                };
                for level in SimdLevel::ALL {
                    got.fill(f32::NAN);
                    s.sample_at(level, 0, (x0, y0, sx, sy), &mut got, ow, oh, 1.0)
                        .unwrap();
                    assert_bits(&got, &want, &format!("{level:?} {x0},{y0} {sx}x{sy}"));
                }
                by_chunks += usize::from(!s.chunks.is_empty());
            }
        }
        assert!(by_chunks >= 15, "{by_chunks}");
    }
}

#[cfg(test)]
mod bilinear_tests {
    use super::area_tests::assert_bits;
    use super::*;
    use bayestrack_image::Image;

    /// Bilinear interpolation as first written (both source rows
    /// interpolated along x for every output pixel): the reference the
    /// row-caching path must match bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        s: &PatchSampler,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        ow: usize,
        oh: usize,
        gain: f32,
    ) -> Vec<f32> {
        let (w, h) = (s.w, s.h);
        let plane = &s.planes[0];
        let split = |c: f64, n: usize| -> (usize, usize, f32) {
            let c = c.clamp(0.0, (n - 1) as f64);
            let i = (c as usize).min(n - 1);
            let j = (i + 1).min(n - 1);
            (i, j, (c - i as f64) as f32)
        };
        let mut out = Vec::with_capacity(ow * oh);
        for v in 0..oh {
            let (ya, yb, fy) = split(y0 + (v as f64 + 0.5) * sy - 0.5, h);
            let (ra, rb) = (&plane[ya * w..(ya + 1) * w], &plane[yb * w..(yb + 1) * w]);
            for u in 0..ow {
                let (xa, xb, fx) = split(x0 + (u as f64 + 0.5) * sx - 0.5, w);
                let top = ra[xa] + fx * (ra[xb] - ra[xa]);
                let bot = rb[xa] + fx * (rb[xb] - rb[xa]);
                out.push(top + fy * (bot - top));
            }
        }
        for v in &mut out {
            *v *= gain;
        }
        out
    }

    #[test]
    fn bilinear_matches_the_reference_inside_and_off_the_frame() {
        let img = Image::from_fn(37, 23, |x, y| ((x * 37 + y * 101 + x * y) % 251) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        // enlarging (rows read by several output rows), one axis only,
        // across each edge and far off the frame, a single row or column
        let cases = [
            (2.3, 1.7, 0.37, 0.21, 13, 11),
            (-5.5, 3.0, 0.5, 1.0, 17, 9),
            (20.25, -4.75, 1.125, 0.5, 19, 12),
            (-40.0, -30.0, 0.3, 0.9, 31, 23),
            (30.9, 19.1, 0.61, 0.19, 7, 25),
            (10.0, 5.0, 0.25, 0.25, 1, 9),
            (10.0, 5.0, 0.25, 3.5, 9, 1),
            (-3.0, 20.0, 0.8, 0.8, 50, 30),
            (3.6, 2.2, 1.0 / 1.0375, 1.0 / 1.0375, 25, 21),
        ];
        for (x0, y0, sx, sy, ow, oh) in cases {
            for gain in [1.0, 1.0 / 255.0] {
                let want = reference(&s, x0, y0, sx, sy, ow, oh, gain);
                let mut got = vec![f32::NAN; ow * oh];
                s.sample_scaled(0, x0, y0, sx, sy, &mut got, ow, oh, gain)
                    .unwrap();
                let what = format!("{x0},{y0} {sx}x{sy} gain {gain}");
                assert_bits(&got, &want, &what);
                // the kernels at every level
                for level in SimdLevel::ALL {
                    got.fill(f32::NAN);
                    s.sample_at(level, 0, (x0, y0, sx, sy), &mut got, ow, oh, gain)
                        .unwrap();
                    assert_bits(&got, &want, &format!("{level:?} {what}"));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn area_and_bilinear() {
        let img = Image::from_fn(4, 4, |x, y| (10 * x + 40 * y) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        let mut out = [0.0f32; 4];
        s.sample(0, 0.0, 0.0, 2.0, 2.0, &mut out, 2, 2).unwrap();
        assert_eq!(out, [25.0, 45.0, 105.0, 125.0]);
        // enlarging by 2 around pixel 1: centres at 0.75, 1.25 -> (0.25, 0.75) of the way
        s.sample(0, 1.0, 1.0, 0.5, 0.5, &mut out, 2, 2).unwrap();
        assert!(
            (out[0] - (10.0 * 0.75 + 40.0 * 0.75)).abs() < 1e-4,
            "{out:?}"
        );
        assert!(
            (out[3] - (10.0 * 1.25 + 40.0 * 1.25)).abs() < 1e-4,
            "{out:?}"
        );
        assert!(s.sample(1, 0.0, 0.0, 1.0, 1.0, &mut out, 2, 2).is_err());
        assert!(
            s.sample(0, f64::NAN, 0.0, 0.5, 1.0, &mut out, 2, 2)
                .is_err()
        );
    }

    /// A frame of `c` channels with varied levels.
    fn noisy(w: usize, h: usize, c: usize, seed: usize) -> Image<u8> {
        let data = (0..w * h * c)
            .map(|i| ((i * 2_654_435_761 + seed * 97) >> 7 & 0xff) as u8)
            .collect();
        Image::from_vec(w, h, c, data).unwrap()
    }

    /// Sample calls of every kind on a 37 x 29 frame: shrinking and
    /// enlarging, across each edge and off the frame.
    fn calls() -> Vec<(f64, f64, f64, f64, usize, usize)> {
        let mut v = Vec::new();
        for &(x0, y0) in &[
            (3.3, 4.7),
            (-6.2, 11.1),
            (20.9, -3.4),
            (30.25, 22.6),
            (-40.0, -40.0),
            (50.5, 12.0),
        ] {
            for &(sx, sy) in &[(1.0, 1.0), (1.37, 2.05), (0.6, 0.45), (2.5, 0.8)] {
                v.push((x0, y0, sx, sy, 9, 7));
            }
        }
        v
    }

    #[test]
    fn a_region_samples_as_the_whole_frame_bit_for_bit() {
        let (w, h) = (37, 29);
        for c in [1, 3, 5] {
            let f = noisy(w, h, c, c);
            let mut whole = PatchSampler::new();
            whole.load(f.view()).unwrap();
            let mut part = PatchSampler::new();
            // a previous frame's values everywhere, then a region
            part.load(noisy(w, h, c, 9).view()).unwrap();
            for (x0, y0, sx, sy, ow, oh) in calls() {
                let r = Region::of_sample(w, h, x0, y0, sx, sy, ow, oh).unwrap();
                part.load_region(f.view(), r).unwrap();
                assert!(part.holds(&r));
                // the table holds the whole frame's values in the region
                // (a missing sum above or left of it mostly cancels in
                // the samples: check the entries themselves)
                let cols = w + 1;
                for ch in 0..c {
                    for y in r.y0..=r.y1 {
                        let at = |s: &PatchSampler| {
                            s.sums[ch][y * cols + r.x0..=y * cols + r.x1].to_vec()
                        };
                        assert_eq!(at(&part), at(&whole), "{c} ch {ch} row {y} of {r:?}");
                    }
                    for y in r.y0..r.y1 {
                        let at =
                            |s: &PatchSampler| s.planes[ch][y * w + r.x0..y * w + r.x1].to_vec();
                        assert_eq!(at(&part), at(&whole), "{c} ch {ch} row {y} of {r:?}");
                    }
                }
                for ch in 0..c {
                    let (mut a, mut b) = (vec![0.0; ow * oh], vec![0.0; ow * oh]);
                    whole.sample(ch, x0, y0, sx, sy, &mut a, ow, oh).unwrap();
                    part.sample(ch, x0, y0, sx, sy, &mut b, ow, oh).unwrap();
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a), bits(&b), "{c} ch {ch} at {x0} {y0} {sx} {sy}");
                }
            }
        }
    }

    #[test]
    fn a_gray_region_is_the_image_crates_gray() {
        let (w, h) = (37, 29);
        let rgb = noisy(w, h, 3, 4);
        let gray = bayestrack_image::rgb_to_gray(rgb.view()).unwrap();
        let mut want = PatchSampler::new();
        want.load(gray.view()).unwrap();
        let mut got = PatchSampler::new();
        for (x0, y0, sx, sy, ow, oh) in calls() {
            let r = Region::of_sample(w, h, x0, y0, sx, sy, ow, oh).unwrap();
            got.load_gray_region(rgb.view(), r).unwrap();
            for y in r.y0..=r.y1 {
                let at =
                    |s: &PatchSampler| s.sums[0][y * (w + 1) + r.x0..=y * (w + 1) + r.x1].to_vec();
                assert_eq!(at(&got), at(&want), "row {y} of {r:?}");
            }
            let (mut a, mut b) = (vec![0.0; ow * oh], vec![0.0; ow * oh]);
            want.sample(0, x0, y0, sx, sy, &mut a, ow, oh).unwrap();
            got.sample(0, x0, y0, sx, sy, &mut b, ow, oh).unwrap();
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "at {x0} {y0} {sx} {sy}");
        }
        // a gray frame is read as it is
        got.load_gray_region(gray.view(), Region::whole(w, h))
            .unwrap();
        assert_eq!(got.planes[0], want.planes[0]);
        assert_eq!(got.sums[0], want.sums[0]);
    }

    #[test]
    fn bad_regions_and_frames_are_errors() {
        let f = noisy(8, 6, 3, 1);
        let mut s = PatchSampler::new();
        let r = |x0, y0, x1, y1| Region { x0, y0, x1, y1 };
        for bad in [r(0, 0, 9, 6), r(0, 0, 8, 7), r(3, 2, 3, 5), r(5, 4, 2, 6)] {
            assert!(matches!(
                s.load_region(f.view(), bad),
                Err(DcfError::InvalidParameter { name: "region", .. })
            ));
            assert!(s.load_gray_region(f.view(), bad).is_err());
        }
        let two = noisy(8, 6, 2, 1);
        assert!(s.load_gray_region(two.view(), r(0, 0, 2, 2)).is_err());
        // the footprint of refused arguments is none; off the frame it
        // is the nearest edge
        assert_eq!(Region::of_sample(8, 6, f64::NAN, 0.0, 1.0, 1.0, 2, 2), None);
        assert_eq!(Region::of_sample(8, 6, 0.0, 0.0, 0.0, 1.0, 2, 2), None);
        assert_eq!(
            Region::of_sample(8, 6, -50.0, 100.0, 1.0, 1.0, 2, 2),
            Some(r(0, 4, 2, 6))
        );
        // nothing loaded holds nothing
        assert!(!PatchSampler::new().holds(&r(0, 0, 1, 1)));
    }
}

#[cfg(test)]
mod table_row_tests {
    use super::*;
    use bayestrack_image::{Image, Rect};

    /// [`table_row`] as a kernel, to run it at each level.
    struct Row<'a> {
        left: u64,
        v: &'a [u8],
        upper: &'a [f64],
        lower: &'a mut [f64],
        dst: &'a mut [f32],
        sums: &'a mut [u16],
    }

    impl Kernel for Row<'_> {
        type Output = ();
        #[inline(always)]
        fn run<T: Token>(self, _: T) {
            let Self {
                left,
                v,
                upper,
                lower,
                dst,
                sums,
            } = self;
            table_row(left, v, upper, lower, dst, sums);
        }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn table_rows_are_the_u64_running_sums_at_every_level() {
        let len = 1001;
        let v: Vec<u8> = (0..len)
            .map(|i| {
                if i % 5 == 0 {
                    255
                } else {
                    ((i * 2_654_435_761usize) >> 9) as u8
                }
            })
            .collect();
        let upper: Vec<f64> = (0..=len)
            .map(|i| (i * 1_000_003 % 7919) as f64 * 255.0)
            .collect();
        // a tail alone, whole groups, groups and a tail, groups in vector
        // lanes (4 at a time) and alone; lefts up to 2^40
        for n in [0, 1, 7, 8, 9, 15, 16, 17, 31, 32, 33, 40, 64, 300, 1001] {
            for left in [0u64, 255, 123_456_789, (1 << 40) + 17] {
                // the plain running sum
                let mut want = vec![upper[0] + left as f64];
                let mut run = left;
                for (&p, &u) in v[..n].iter().zip(&upper[1..]) {
                    run += u64::from(p);
                    want.push(u + run as f64);
                }
                let values: Vec<f32> = v[..n].iter().map(|&p| f32::from(p)).collect();
                for level in SimdLevel::ALL {
                    let (mut lower, mut dst) = (vec![f64::NAN; n + 1], vec![f32::NAN; n]);
                    level.run(Row {
                        left,
                        v: &v[..n],
                        upper: &upper[..=n],
                        lower: &mut lower,
                        dst: &mut dst,
                        sums: &mut vec![0; n],
                    });
                    assert_eq!(bits(&lower), bits(&want), "{level:?} {n} left {left}");
                    assert_eq!(dst, values, "{level:?} {n}");
                }
            }
        }
    }

    /// A frame of `c` channels with varied levels, 255s in runs.
    fn frame(w: usize, h: usize, c: usize) -> Image<u8> {
        let data = (0..w * h * c)
            .map(|i| {
                if (i / 7) % 11 == 0 {
                    255
                } else {
                    ((i * 2_654_435_761) >> 11) as u8
                }
            })
            .collect();
        Image::from_vec(w, h, c, data).unwrap()
    }

    /// The planes (`gray`: the gray level of an RGB frame, else each
    /// channel) and their summed-area tables, plainly: u64 sums converted.
    fn reference(f: ImageView<'_, u8>, gray: bool) -> Vec<(Vec<f32>, Vec<f64>)> {
        let (w, h, c) = (f.width(), f.height(), f.channels());
        let planes: Vec<Vec<u8>> = if gray && c == 3 {
            let mut g = Image::new(w, h, 1, 0u8).unwrap();
            bayestrack_image::rgb_to_gray_into(f, &mut g.view_mut()).unwrap();
            vec![g.as_slice().to_vec()]
        } else {
            (0..c)
                .map(|ch| {
                    (0..h)
                        .flat_map(|y| (0..w).map(move |x| f.row(y)[x * c + ch]))
                        .collect()
                })
                .collect()
        };
        planes
            .into_iter()
            .map(|p| {
                let mut sum = vec![0u64; (w + 1) * (h + 1)];
                for y in 0..h {
                    for x in 0..w {
                        sum[(y + 1) * (w + 1) + x + 1] = sum[y * (w + 1) + x + 1]
                            + sum[(y + 1) * (w + 1) + x]
                            - sum[y * (w + 1) + x]
                            + u64::from(p[y * w + x]);
                    }
                }
                let values = p.iter().map(|&v| f32::from(v)).collect();
                (values, sum.iter().map(|&s| s as f64).collect())
            })
            .collect()
    }

    #[test]
    fn loads_are_the_plain_tables_at_every_level() {
        // larger than the sequences' frames (320 x 240, 360 x 240) and
        // their regions; a crop of a wider frame (rows apart by more than
        // their width)
        let (w, h) = (411, 263);
        let r = |x0, y0, x1, y1| Region { x0, y0, x1, y1 };
        // the whole frame, at each side and corner, inside, one pixel,
        // one column, one row, odd widths either side of whole blocks
        let regions = [
            r(0, 0, w, h),
            r(0, 0, 70, 50),
            r(w - 83, 0, w, 61),
            r(0, h - 40, 99, h),
            r(w - 9, h - 17, w, h),
            r(37, 51, 358, 209),
            r(200, 100, 201, 101),
            r(5, 0, 6, h),
            r(0, 130, w, 131),
            r(100, 7, 117, 250),
            r(1, 1, w - 1, h - 1),
        ];
        for c in [1, 2, 3, 4, 5] {
            let wide = frame(w + 13, h + 2, c);
            let rect = Rect {
                x: 5,
                y: 1,
                width: w,
                height: h,
            };
            let f = wide.crop(rect).unwrap();
            for gray in [false, true] {
                if gray && c != 1 && c != 3 {
                    continue;
                }
                let want = reference(f, gray);
                let mut s = PatchSampler::new();
                for (n, &reg) in regions.iter().enumerate() {
                    for level in SimdLevel::ALL {
                        // a previous load elsewhere: every value read is
                        // this load's
                        let other = regions[(n + 3) % regions.len()];
                        s.load_at(level, frame(w, h, c).view(), other, gray)
                            .unwrap();
                        s.load_at(level, f, reg, gray).unwrap();
                        assert_eq!(s.channels(), want.len());
                        let cols = w + 1;
                        for (k, (plane, sum)) in want.iter().enumerate() {
                            for y in reg.y0..=reg.y1 {
                                let at =
                                    |t: &[f64]| bits(&t[y * cols + reg.x0..=y * cols + reg.x1]);
                                let what = format!(
                                    "{level:?} {c} ch gray {gray} plane {k} {reg:?} row {y}"
                                );
                                assert_eq!(at(&s.sums[k]), at(sum), "{what}");
                                if y < reg.y1 {
                                    let at = |p: &[f32]| p[y * w + reg.x0..y * w + reg.x1].to_vec();
                                    assert_eq!(at(&s.planes[k]), at(plane), "{what}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
