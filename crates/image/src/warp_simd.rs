//! The inside fast path of [`warp_into`](crate::warp_into), vectorised
//! across patch rows with run-time CPU dispatch.
//!
//! Along a patch row `v` the sample coordinates are affine in `u`:
//! `x = a u + (b v + tx)`, `y = c u + (d v + ty)`. The kernel takes a row
//! [`LANES`] (8) pixels at a time:
//!
//! 1. **Cells.** The coordinates of the eight pixels in `f64` lanes,
//!    `a * u + bx` with `u` formed as `u0 + j` (exact: small integers),
//!    rounded to `f32` and clamped at 0; the cell `(xi, yi)` by truncation
//!    (floor, as `x, y >= 0`) after clamping to the last cell; the
//!    fractions `fx = min(x - xi, 1)`, `fy = min(y - yi, 1)`; the buffer
//!    index `yi * stride + xi * ch` in `i32` lanes. With AVX2 (and AVX-512)
//!    in intrinsics; otherwise in plain array code with an exact
//!    magic-number floor ([`floor_small`]) that the compiler vectorises.
//! 2. **Neighbours.** Scalar loads (the workspace forbids `unsafe`, so no
//!    gather instructions) into small arrays laid out like the output
//!    (pixel-major, channels interleaved). One channel: each neighbour by
//!    itself, converted to `f32` on the way. Two to four channels: each
//!    neighbour pixel copied whole (three channels as overlapping
//!    four-element copies, one load and one store each), then converted as
//!    vectors. The arrays pass through `core::hint::black_box`, which keeps
//!    them in memory: the compiler then reads them back with vector loads
//!    instead of assembling the vectors in registers with long chains of
//!    byte and lane shuffles, which all queue on the one shuffle port
//!    (measured: the gray `u8` warp takes half the time this way).
//!    One channel with AVX2 picks them from source rows loaded as vectors
//!    instead, when a batch's cells fit such a window
//!    (`InsideWarp::window_avx2`: at most 7 cell columns and 13 cell rows).
//! 3. **Lerps.** `top = p00 + fx (p01 - p00)`, `bot = p10 + fx (p11 - p10)`,
//!    `top + fy (bot - top)` in vector lanes (`fx`, `fy` repeated over the
//!    channels), and one contiguous store into the patch row.
//!
//! Every lane does the same IEEE operations in the same order as the scalar
//! loop (Rust never fuses a multiply and an add on its own, and nothing here
//! asks for a fused one), so the patch is bit-for-bit that of the per-pixel
//! loop at every level; the tests compare them on random maps. The last
//! batch of a row overlaps the previous one when the width is not a multiple
//! of [`LANES`] (a pixel's value depends only on its own `u`, so recomputing
//! it changes nothing); rows narrower than [`LANES`] take the per-pixel
//! loop, and so do more than four channels and frames of 2^23 pixels a side
//! or 2^31 elements.
//!
//! The instruction sets are chosen at run time through [`crate::simd`]
//! (the `pulp` crate's tokens, as for the SAD kernels in `sad.rs`): the
//! same generic body is compiled for SSE2, AVX2 (x86-64-v3) and AVX-512
//! (x86-64-v4), and the best one the CPU runs is called.

use crate::simd::{Kernel, SimdLevel, Token};
use crate::{ImageViewMut, Pixel};

/// Patch pixels per batch.
pub(crate) const LANES: usize = 8;

/// `j as f64` for each lane.
const LANE_OFFSETS: [f64; LANES] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];

/// `2^23`: adding it to an `f32` in `[0, 2^23)` rounds to an integer.
const MAGIC: f32 = 8_388_608.0;

/// `floor(v)` as an integer and as an `f32`, for `0 <= v < 2^23`: the same
/// values as `v as i32` and `(v as i32) as f32` there, but in plain float
/// and integer lane operations (`as i32` saturates, which the compiler does
/// not vectorise well). `v + 2^23` is `2^23 + round(v)` exactly (the ulp
/// there is 1), whose low mantissa bits are `round(v)`; one down-step when
/// the rounding went up.
#[inline(always)]
fn floor_small(v: f32) -> (i32, f32) {
    let r = v + MAGIC;
    let rf = r - MAGIC;
    let down = rf > v;
    let n = (r.to_bits() as i32).wrapping_sub(MAGIC.to_bits() as i32) - i32::from(down);
    (n, if down { rf - 1.0 } else { rf })
}

/// `top + fy (bot - top)` with `top = p00 + fx (p01 - p00)` and
/// `bot = p10 + fx (p11 - p10)`, lane by lane over the shortest input.
#[inline(always)]
fn lerp(
    p00: &[f32],
    p01: &[f32],
    p10: &[f32],
    p11: &[f32],
    fx: &[f32],
    fy: &[f32],
    dst: &mut [f32],
) {
    let n = dst.len().min(p00.len()).min(fx.len());
    let (p00, p01, p10, p11) = (&p00[..n], &p01[..n], &p10[..n], &p11[..n]);
    let (fx, fy) = (&fx[..n], &fy[..n]);
    for l in 0..n {
        let top = p00[l] + fx[l] * (p01[l] - p00[l]);
        let bot = p10[l] + fx[l] * (p11[l] - p10[l]);
        dst[l] = top + fy[l] * (bot - top);
    }
}

/// Most cell rows past the first a batch of [`InsideWarp::window_avx2`]
/// may span (its window then holds `MAX_WINDOW_SPAN + 2` source rows):
/// beyond it the row-by-row blends cost more than the one-by-one loads.
const MAX_WINDOW_SPAN: usize = 12;

/// Most channels with a vectorised instance.
const MAX_CH: usize = 4;

/// The inside fast path of [`warp_into`](crate::warp_into): every sample's
/// cell is in the frame, so no border checks.
pub(crate) struct InsideWarp<'a, T> {
    /// The source buffer from its first pixel.
    pub(crate) data: &'a [T],
    /// Elements between source rows.
    pub(crate) stride: usize,
    /// Last cell column (`width - 2`) and row (`height - 2`).
    pub(crate) xmax: f32,
    /// See `xmax`.
    pub(crate) ymax: f32,
    /// The map `[a, b, tx, c, d, ty]`, patch to image coordinates.
    pub(crate) m: [f64; 6],
}

/// Every row of an [`InsideWarp`] of `CH` channels as a [`Kernel`]: the
/// cells in AVX2 intrinsics where the level has them (AVX2 and AVX-512,
/// the rest of the body compiled for the level), else in plain array code.
struct Rows<'a, 'b, 'c, T, const CH: usize> {
    warp: &'a InsideWarp<'b, T>,
    out: &'a mut ImageViewMut<'c, f32>,
}

impl<T: Pixel, const CH: usize> Kernel for Rows<'_, '_, '_, T, CH> {
    type Output = ();
    /// AVX2 at most: measured slower with AVX-512 (see [`Kernel::WIDEST`]).
    const WIDEST: SimdLevel = SimdLevel::Avx2;
    #[inline(always)]
    fn run<K: Token>(self, token: K) {
        let Rows { warp, out } = self;
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = token.avx2() {
            if CH == 1 {
                return warp.rows_window_avx2(v3, out);
            }
            return warp.rows::<CH>(
                out,
                #[inline(always)]
                |bx, by, u0| warp.cells_avx2::<CH>(v3, bx, by, u0),
            );
        }
        let _ = token;
        warp.rows::<CH>(
            out,
            #[inline(always)]
            |bx, by, u0| warp.cells::<CH>(bx, by, u0),
        )
    }
}

/// The cells and fractions of one batch of [`LANES`] patch pixels.
struct Cells {
    /// Horizontal fractions `min(x - xi, 1)`.
    fx: [f32; LANES],
    /// Vertical fractions.
    fy: [f32; LANES],
    /// Buffer index of each top-left neighbour, `yi * stride + xi * ch`.
    idx: [i32; LANES],
}

/// A batch's eight cells in registers, `(xi, yi, fx, fy)`: the integer
/// corners and the fractional offsets.
#[cfg(target_arch = "x86_64")]
type CellLanes = (
    core::arch::x86_64::__m256i,
    core::arch::x86_64::__m256i,
    core::arch::x86_64::__m256,
    core::arch::x86_64::__m256,
);

impl<T: Pixel> InsideWarp<'_, T> {
    /// Fills `out` (same channel count as the source, `ch`) at `level`
    /// (the best available one if `level` is not).
    pub(crate) fn run(&self, level: SimdLevel, out: &mut ImageViewMut<'_, f32>, ch: usize) {
        // The lanes index the buffer in `i32` and floor coordinates below
        // 2^23; frames beyond that (none a tracker sees) go pixel by pixel.
        let fits = self.data.len() <= i32::MAX as usize
            && self.data.len() >= self.stride + 2 * ch
            && self.xmax < MAGIC
            && self.ymax < MAGIC;
        if !fits {
            self.rows_per_pixel(out, ch);
            return;
        }
        match ch {
            1 => self.dispatch::<1>(level, out),
            2 => self.dispatch::<2>(level, out),
            3 => self.dispatch::<3>(level, out),
            4 => self.dispatch::<4>(level, out),
            _ => self.rows_per_pixel(out, ch),
        }
    }

    fn dispatch<const CH: usize>(&self, level: SimdLevel, out: &mut ImageViewMut<'_, f32>) {
        level.run(Rows::<T, CH> { warp: self, out });
    }

    /// Every patch row, [`LANES`] pixels at a time, the cells of a batch
    /// from `cells(bx, by, u0)`.
    #[inline(always)]
    fn rows<const CH: usize>(
        &self,
        out: &mut ImageViewMut<'_, f32>,
        cells: impl Fn(f64, f64, usize) -> Cells,
    ) {
        let [_, b, tx, _, d, ty] = self.m;
        let pw = out.width();
        for v in 0..out.height() {
            let row = &mut out.row_mut(v)[..pw * CH];
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            if pw < LANES {
                for (u, px) in row.chunks_exact_mut(CH).enumerate() {
                    self.pixel(bx, by, u, px);
                }
                continue;
            }
            let mut u0 = 0;
            loop {
                let s = u0.min(pw - LANES);
                let dst: &mut [f32; LANES * MAX_CH] = &mut [0.0; LANES * MAX_CH];
                self.interpolate::<CH>(&cells(bx, by, s), dst);
                row[s * CH..(s + LANES) * CH].copy_from_slice(&dst[..LANES * CH]);
                if s == pw - LANES {
                    break;
                }
                u0 += LANES;
            }
        }
    }

    /// The cells of pixels `u0..u0 + LANES` of the row with offsets
    /// `(bx, by)`, in plain array code (vectorised by the compiler).
    #[inline(always)]
    fn cells<const CH: usize>(&self, bx: f64, by: f64, u0: usize) -> Cells {
        let [a, _, _, c, _, _] = self.m;
        let u0f = u0 as f64;
        let mut out = Cells {
            fx: [0.0; LANES],
            fy: [0.0; LANES],
            idx: [0; LANES],
        };
        for (j, &off) in LANE_OFFSETS.iter().enumerate() {
            let uf = u0f + off;
            let x = at_least_zero((a * uf + bx) as f32);
            let y = at_least_zero((c * uf + by) as f32);
            let (xi, xf) = floor_small(x.min(self.xmax));
            let (yi, yf) = floor_small(y.min(self.ymax));
            out.fx[j] = (x - xf).min(1.0);
            out.fy[j] = (y - yf).min(1.0);
            out.idx[j] = yi
                .wrapping_mul(self.stride as i32)
                .wrapping_add(xi.wrapping_mul(CH as i32));
        }
        out
    }

    /// [`Self::cells`] in AVX2 intrinsics: `f64` lanes for the map, `f32`
    /// and `i32` lanes for the cells. `max_ps(x, 0)` returns its second
    /// operand (+0) when `x` is 0 of either sign, as [`at_least_zero`]
    /// does; `min_ps(xmax, x)` returns its second (`x`) on ties and
    /// `min_ps(d, 1)` its second: the same bits as the scalar
    /// `x.min(xmax)` and `d.min(1.0)` whichever operand those return on
    /// ties (equal values, both non-negative; no NaN reaches them).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cells_avx2<const CH: usize>(
        &self,
        simd: pulp::x86::V3,
        bx: f64,
        by: f64,
        u0: usize,
    ) -> Cells {
        use pulp::bytemuck::cast;
        let (f, i) = (simd.avx, simd.avx2);
        let (xi, yi, fx, fy) = self.cell_lanes_avx2(simd, bx, by, u0);
        let row = i._mm256_mullo_epi32(yi, f._mm256_set1_epi32(self.stride as i32));
        let col = i._mm256_mullo_epi32(xi, f._mm256_set1_epi32(CH as i32));
        Cells {
            fx: cast(fx),
            fy: cast(fy),
            idx: cast(i._mm256_add_epi32(row, col)),
        }
    }

    /// The cells of [`Self::cells_avx2`] left in registers: `(xi, yi, fx,
    /// fy)`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cell_lanes_avx2(&self, simd: pulp::x86::V3, bx: f64, by: f64, u0: usize) -> CellLanes {
        use pulp::bytemuck::cast;
        let f = simd.avx;
        let [a, _, _, c, _, _] = self.m;
        let u = f._mm256_set1_pd(u0 as f64);
        let lo = f._mm256_add_pd(u, cast([0.0f64, 1.0, 2.0, 3.0]));
        let hi = f._mm256_add_pd(u, cast([4.0f64, 5.0, 6.0, 7.0]));
        let (a, c) = (f._mm256_set1_pd(a), f._mm256_set1_pd(c));
        let au = [f._mm256_mul_pd(a, lo), f._mm256_mul_pd(a, hi)];
        let cu = [f._mm256_mul_pd(c, lo), f._mm256_mul_pd(c, hi)];
        self.cell_lanes_from_avx2(simd, bx, by, au, cu)
    }

    /// [`Self::cell_lanes_avx2`] from the products `a u` and `c u` of the
    /// batch's eight `u` (in two halves).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cell_lanes_from_avx2(
        &self,
        simd: pulp::x86::V3,
        bx: f64,
        by: f64,
        au: [core::arch::x86_64::__m256d; 2],
        cu: [core::arch::x86_64::__m256d; 2],
    ) -> CellLanes {
        let f = simd.avx;
        // `max(p + o, 0)` in eight `f32` lanes (`p + o` in `f64`, then
        // rounded, as the scalar loop).
        let shift = |p: [core::arch::x86_64::__m256d; 2], o: f64| {
            let o = f._mm256_set1_pd(o);
            let l = f._mm256_cvtpd_ps(f._mm256_add_pd(p[0], o));
            let h = f._mm256_cvtpd_ps(f._mm256_add_pd(p[1], o));
            f._mm256_max_ps(f._mm256_set_m128(h, l), f._mm256_setzero_ps())
        };
        let x = shift(au, bx);
        let y = shift(cu, by);
        let one = f._mm256_set1_ps(1.0);
        let xi = f._mm256_cvttps_epi32(f._mm256_min_ps(f._mm256_set1_ps(self.xmax), x));
        let yi = f._mm256_cvttps_epi32(f._mm256_min_ps(f._mm256_set1_ps(self.ymax), y));
        let fx = f._mm256_min_ps(f._mm256_sub_ps(x, f._mm256_cvtepi32_ps(xi)), one);
        let fy = f._mm256_min_ps(f._mm256_sub_ps(y, f._mm256_cvtepi32_ps(yi)), one);
        (xi, yi, fx, fy)
    }

    /// One channel with AVX2: every patch row [`LANES`] pixels at a time,
    /// the neighbours of a batch picked from source windows in registers
    /// ([`Self::window_avx2`]) when its cells fit in one, else loaded one
    /// by one as [`Self::rows`] does.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn rows_window_avx2(&self, simd: pulp::x86::V3, out: &mut ImageViewMut<'_, f32>) {
        let [a, _, _, c, _, _] = self.m;
        let pw = out.width();
        // `a u` and `c u` for every `u` of a patch row (the same in every
        // row), when the row is at most `MAX_PW` wide.
        const MAX_PW: usize = 64;
        let mut au = [0f64; MAX_PW];
        let mut cu = [0f64; MAX_PW];
        if pw <= MAX_PW {
            for (u, (x, y)) in au.iter_mut().zip(cu.iter_mut()).enumerate().take(pw) {
                let uf = u as f64;
                (*x, *y) = (a * uf, c * uf);
            }
        }
        // The lanes of the smallest `xi` and `yi` of a batch (see
        // `window_avx2`).
        let first = [a, c].map(|m| simd.avx._mm256_set1_epi32(if m < 0.0 { 7 } else { 0 }));
        #[inline(always)]
        fn half(p: &[f64], k: usize) -> core::arch::x86_64::__m256d {
            pulp::bytemuck::cast::<[f64; 4], _>(p[k..k + 4].try_into().expect("four lanes"))
        }
        // Two instances of the loop (not a test of the width every batch).
        if pw <= MAX_PW {
            self.window_rows(
                simd,
                out,
                first,
                #[inline(always)]
                |bx, by, s| {
                    let ap = [half(&au, s), half(&au, s + 4)];
                    let cp = [half(&cu, s), half(&cu, s + 4)];
                    self.cell_lanes_from_avx2(simd, bx, by, ap, cp)
                },
            );
        } else {
            self.window_rows(
                simd,
                out,
                first,
                #[inline(always)]
                |bx, by, s| self.cell_lanes_avx2(simd, bx, by, s),
            );
        }
    }

    /// The rows of [`Self::rows_window_avx2`], the cells of a batch from
    /// `cells(bx, by, u0)`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn window_rows(
        &self,
        simd: pulp::x86::V3,
        out: &mut ImageViewMut<'_, f32>,
        first: [core::arch::x86_64::__m256i; 2],
        cells: impl Fn(f64, f64, usize) -> CellLanes,
    ) {
        use pulp::bytemuck::cast;
        let [_, b, tx, _, d, ty] = self.m;
        let pw = out.width();
        for v in 0..out.height() {
            let row = &mut out.row_mut(v)[..pw];
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            if pw < LANES {
                for (u, px) in row.chunks_exact_mut(1).enumerate() {
                    self.pixel(bx, by, u, px);
                }
                continue;
            }
            let mut u0 = 0;
            loop {
                let s = u0.min(pw - LANES);
                let (xi, yi, fx, fy) = cells(bx, by, s);
                let dst = &mut row[s..s + LANES];
                if let Some(p) = self.window_avx2(simd, (xi, yi, fx, fy), first) {
                    dst.copy_from_slice(&cast::<_, [f32; LANES]>(p));
                } else {
                    let i = simd.avx2;
                    let idx = i._mm256_add_epi32(
                        i._mm256_mullo_epi32(yi, simd.avx._mm256_set1_epi32(self.stride as i32)),
                        xi,
                    );
                    let cells = Cells {
                        fx: cast(fx),
                        fy: cast(fy),
                        idx: cast(idx),
                    };
                    let buf: &mut [f32; LANES * MAX_CH] = &mut [0.0; LANES * MAX_CH];
                    self.interpolate::<1>(&cells, buf);
                    dst.copy_from_slice(&buf[..LANES]);
                }
                if s == pw - LANES {
                    break;
                }
                u0 += LANES;
            }
        }
    }

    /// The bilinear values of one batch of one-channel pixels from source
    /// windows, or `None` when the batch does not fit them.
    ///
    /// Along a batch the cells move monotonically (the map is affine in
    /// `u`, and rounding, clamping and truncation keep the order): `xi`
    /// and `yi` are smallest in the first lane where `a`, resp. `c`, is
    /// at least 0 (or NaN: every coordinate is then clamped to 0), in the
    /// last where it is negative, the lanes of `first` (set by
    /// [`Self::rows_window_avx2`] once a warp). So `xlo`, `ylo` are those
    /// lanes' values and `dx = xi - xlo`, `dy = yi - ylo` at least 0 in
    /// every lane. When the columns span at most 7 (`dx` at most 6, so that
    /// `xi + 1 <= xlo + 7`) and the rows at most [`MAX_WINDOW_SPAN`] + 1
    /// (`dy` at most `MAX_WINDOW_SPAN`), the eight source values
    /// `xlo..xlo + 8` of rows `ylo`, `ylo + 1`, ... are loaded as vectors
    /// and each neighbour picked by a lane permutation (`vpermps`, by `dx`
    /// and `dx + 1`). Over several rows, row by row (`r = 1, 2, ...` while
    /// some lane has `dy >= r`), the lanes with `dy >= r` take row
    /// `ylo + r` on top and row `ylo + r + 1` at the bottom (blends), so
    /// that each lane ends with its own rows `yi` and `yi + 1` (a patch
    /// turned across the frame's rows, as a rotated target's is, spans
    /// several rows a batch). The values are the buffer's own, converted by
    /// `to_f32` as the scalar loads do; the lerps are the same operations
    /// in the same order, so the result is bit for bit that of
    /// [`Self::rows`]. A window running past the end of the buffer (a cell
    /// at the bottom right of a frame narrower than 8) falls back too.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn window_avx2(
        &self,
        simd: pulp::x86::V3,
        (xi, yi, fx, fy): CellLanes,
        first: [core::arch::x86_64::__m256i; 2],
    ) -> Option<core::arch::x86_64::__m256> {
        use pulp::bytemuck::cast;
        let (f, i) = (simd.avx, simd.avx2);
        let (xlo, ylo) = (
            i._mm256_permutevar8x32_epi32(xi, first[0]),
            i._mm256_permutevar8x32_epi32(yi, first[1]),
        );
        let dx = i._mm256_sub_epi32(xi, xlo);
        let dy = i._mm256_sub_epi32(yi, ylo);
        let wide = i._mm256_or_si256(
            i._mm256_cmpgt_epi32(dx, f._mm256_set1_epi32(6)),
            i._mm256_cmpgt_epi32(dy, f._mm256_set1_epi32(MAX_WINDOW_SPAN as i32)),
        );
        if f._mm256_testz_si256(wide, wide) == 0 {
            return None;
        }
        let (xlo, ylo) = (i._mm256_cvtsi256_si32(xlo), i._mm256_cvtsi256_si32(ylo));
        let base = ylo as usize * self.stride + xlo as usize;
        // The first two rows with one bounds check, the others one each.
        let two = self.data.get(base..base + self.stride + LANES)?;
        let vector = |w: &[T]| -> Option<core::arch::x86_64::__m256> {
            let w: &[T; LANES] = w.try_into().ok()?;
            Some(cast::<[f32; LANES], _>(w.map(|v| v.to_f32())))
        };
        let dx1 = i._mm256_add_epi32(dx, f._mm256_set1_epi32(1));
        let pick = |w, d| i._mm256_permutevar8x32_ps(w, d);
        let w0 = vector(&two[..LANES])?;
        let (mut p00, mut p01) = (pick(w0, dx), pick(w0, dx1));
        let mut o = base + self.stride;
        let w1 = vector(&two[self.stride..])?;
        let (mut a, mut b) = (pick(w1, dx), pick(w1, dx1));
        let (mut p10, mut p11) = (a, b);
        // `r - 1 - dy` in each lane while placing row `ylo + r`: its sign
        // bit (all that `blendv` and `testz_ps` read) is set in the lanes
        // with `dy >= r`. (A subtraction rather than a comparison: the
        // compiler keeps a comparison's mask across the loop as packed
        // bits, unpacked again every round.)
        let mut lower = f._mm256_castsi256_ps(i._mm256_sub_epi32(f._mm256_setzero_si256(), dy));
        while f._mm256_testz_ps(lower, lower) == 0 {
            p00 = f._mm256_blendv_ps(p00, a, lower);
            p01 = f._mm256_blendv_ps(p01, b, lower);
            o += self.stride;
            let w = vector(self.data.get(o..o + LANES)?)?;
            (a, b) = (pick(w, dx), pick(w, dx1));
            p10 = f._mm256_blendv_ps(p10, a, lower);
            p11 = f._mm256_blendv_ps(p11, b, lower);
            lower = f._mm256_castsi256_ps(
                i._mm256_add_epi32(f._mm256_castps_si256(lower), f._mm256_set1_epi32(1)),
            );
        }
        let top = f._mm256_add_ps(p00, f._mm256_mul_ps(fx, f._mm256_sub_ps(p01, p00)));
        let bot = f._mm256_add_ps(p10, f._mm256_mul_ps(fx, f._mm256_sub_ps(p11, p10)));
        Some(f._mm256_add_ps(top, f._mm256_mul_ps(fy, f._mm256_sub_ps(bot, top))))
    }

    /// The four neighbours of every pixel and channel of a batch, and the
    /// lerps, into `dst[..LANES * CH]` (pixel-major, channels interleaved).
    #[inline(always)]
    fn interpolate<const CH: usize>(&self, cells: &Cells, dst: &mut [f32; LANES * MAX_CH]) {
        // Row `yi` and row `yi + 1` as two equal-length windows of the
        // buffer, and the cell index clamped to the last one that fits:
        // the clamp never moves an index (the cell is in the frame), but it
        // lets the compiler drop most bounds checks.
        let n = self.data.len() - self.stride;
        let (d0, d1) = (&self.data[..n], &self.data[self.stride..]);
        let last = n - 2 * CH;
        if CH == 1 {
            // Scalar loads, converted to `f32` on the way (one load and for
            // narrow pixels one conversion each), into arrays that
            // `black_box` keeps in memory, so that the compiler reads them
            // back as vectors rather than assembling the vectors with long
            // shuffle chains (all on one shuffle port).
            let mut q = [[0f32; LANES]; 4];
            for (j, &idx) in cells.idx.iter().enumerate() {
                let i = (idx as usize).min(last);
                q[0][j] = d0[i].to_f32();
                q[1][j] = d0[i + 1].to_f32();
                q[2][j] = d1[i].to_f32();
                q[3][j] = d1[i + 1].to_f32();
            }
            let q = core::hint::black_box(q);
            lerp(&q[0], &q[1], &q[2], &q[3], &cells.fx, &cells.fy, dst);
        } else {
            // The four neighbours as they lie in the buffer (pixel-major,
            // channels interleaved, as the output): whole-pixel copies, then
            // converted to `f32` as vectors.
            let mut q = [[T::default(); LANES * MAX_CH + 1]; 4];
            // Where pixel 0's channels start in each array.
            let mut first = [0; 4];
            if CH == 3 {
                // Three-element copies take two loads and two stores (for
                // `u8` and `f32` alike); four-element ones one. Left
                // neighbours: copy the pixel and one element more, left to
                // right, each extra element overwritten by the next pixel.
                // Right neighbours: copy one element more on the left,
                // right to left, into arrays shifted by one, each extra
                // element overwritten by the previous pixel.
                for (j, &idx) in cells.idx.iter().enumerate() {
                    let i = (idx as usize).min(last);
                    q[0][j * CH..j * CH + CH + 1].copy_from_slice(&d0[i..i + CH + 1]);
                    q[2][j * CH..j * CH + CH + 1].copy_from_slice(&d1[i..i + CH + 1]);
                }
                for (j, &idx) in cells.idx.iter().enumerate().rev() {
                    let i = (idx as usize).min(last);
                    q[1][j * CH..j * CH + CH + 1].copy_from_slice(&d0[i + CH - 1..i + 2 * CH]);
                    q[3][j * CH..j * CH + CH + 1].copy_from_slice(&d1[i + CH - 1..i + 2 * CH]);
                }
                first = [0, 1, 0, 1];
            } else {
                for (j, &idx) in cells.idx.iter().enumerate() {
                    let i = (idx as usize).min(last);
                    let (r0, r1) = (&d0[i..i + 2 * CH], &d1[i..i + 2 * CH]);
                    let o = j * CH..(j + 1) * CH;
                    q[0][o.clone()].copy_from_slice(&r0[..CH]);
                    q[1][o.clone()].copy_from_slice(&r0[CH..]);
                    q[2][o.clone()].copy_from_slice(&r1[..CH]);
                    q[3][o].copy_from_slice(&r1[CH..]);
                }
            }
            let q = core::hint::black_box(q);
            let mut p = [[0f32; LANES * MAX_CH]; 4];
            for ((pn, qn), f) in p.iter_mut().zip(&q).zip(first) {
                for (pv, qv) in pn[..LANES * CH].iter_mut().zip(&qn[f..]) {
                    *pv = qv.to_f32();
                }
            }
            let mut fxe = [0f32; LANES * MAX_CH];
            let mut fye = [0f32; LANES * MAX_CH];
            for j in 0..LANES {
                for k in 0..CH {
                    fxe[j * CH + k] = cells.fx[j];
                    fye[j * CH + k] = cells.fy[j];
                }
            }
            lerp(
                &p[0],
                &p[1],
                &p[2],
                &p[3],
                &fxe,
                &fye,
                &mut dst[..LANES * CH],
            );
        }
    }

    /// One pixel, the scalar loop's body (rows narrower than [`LANES`]).
    #[inline(always)]
    fn pixel(&self, bx: f64, by: f64, u: usize, px: &mut [f32]) {
        let ch = px.len();
        let [a, _, _, c, _, _] = self.m;
        let uf = u as f64;
        let x = at_least_zero((a * uf + bx) as f32);
        let y = at_least_zero((c * uf + by) as f32);
        // Cells are [x0, x0 + 1] with x0 <= w - 2; on the right edge fx = 1.
        // Truncation is floor here (x, y >= 0).
        let xi = x.min(self.xmax) as i32;
        let yi = y.min(self.ymax) as i32;
        let fx = (x - xi as f32).min(1.0);
        let fy = (y - yi as f32).min(1.0);
        let i00 = yi as usize * self.stride + xi as usize * ch;
        let r0 = &self.data[i00..i00 + 2 * ch];
        let r1 = &self.data[i00 + self.stride..i00 + self.stride + 2 * ch];
        for k in 0..ch {
            let p00 = r0[k].to_f32();
            let p01 = r0[k + ch].to_f32();
            let p10 = r1[k].to_f32();
            let p11 = r1[k + ch].to_f32();
            let top = p00 + fx * (p01 - p00);
            let bot = p10 + fx * (p11 - p10);
            px[k] = top + fy * (bot - top);
        }
    }

    /// Every row pixel by pixel (more than [`MAX_CH`] channels).
    fn rows_per_pixel(&self, out: &mut ImageViewMut<'_, f32>, ch: usize) {
        let [_, b, tx, _, d, ty] = self.m;
        let pw = out.width();
        for v in 0..out.height() {
            let row = &mut out.row_mut(v)[..pw * ch];
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            for (u, px) in row.chunks_exact_mut(ch).enumerate() {
                self.pixel(bx, by, u, px);
            }
        }
    }
}

/// `x` where it is above 0, else +0 (also for -0 and NaN): `maxss(x, 0)`
/// and `max_ps(x, 0)` bit for bit. Not `x.max(0.0)`, whose result for
/// -0 is unspecified and did differ between builds (the release scalar
/// loop returned -0 where the vector kernels return +0).
#[inline(always)]
fn at_least_zero(x: f32) -> f32 {
    if x > 0.0 { x } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Image, ImageView, Rect};

    /// The inside path as it was before this kernel (commit 3f89b52),
    /// verbatim: one pixel at a time, `CH` the channel count or 0 for any.
    fn today<T: Pixel, const CH: usize>(
        w: &InsideWarp<'_, T>,
        out: &mut ImageViewMut<'_, f32>,
        ch: usize,
    ) {
        let ch = if CH == 0 { ch } else { CH };
        let [a, b, tx, c, d, ty] = w.m;
        let (data, stride) = (w.data, w.stride);
        let pw = out.width();
        for v in 0..out.height() {
            let row = &mut out.row_mut(v)[..pw * ch];
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            for (u, px) in row.chunks_exact_mut(ch).enumerate() {
                let uf = u as f64;
                let x = at_least_zero((a * uf + bx) as f32);
                let y = at_least_zero((c * uf + by) as f32);
                let xi = x.min(w.xmax) as i32;
                let yi = y.min(w.ymax) as i32;
                let fx = (x - xi as f32).min(1.0);
                let fy = (y - yi as f32).min(1.0);
                let i00 = yi as usize * stride + xi as usize * ch;
                let r0 = &data[i00..i00 + 2 * ch];
                let r1 = &data[i00 + stride..i00 + stride + 2 * ch];
                for k in 0..ch {
                    let p00 = r0[k].to_f32();
                    let p01 = r0[k + ch].to_f32();
                    let p10 = r1[k].to_f32();
                    let p11 = r1[k + ch].to_f32();
                    let top = p00 + fx * (p01 - p00);
                    let bot = p10 + fx * (p11 - p10);
                    px[k] = top + fy * (bot - top);
                }
            }
        }
    }

    fn today_any<T: Pixel>(w: &InsideWarp<'_, T>, out: &mut ImageViewMut<'_, f32>, ch: usize) {
        match ch {
            1 => today::<T, 1>(w, out, 1),
            3 => today::<T, 3>(w, out, 3),
            _ => today::<T, 0>(w, out, ch),
        }
    }

    /// One channel at `level`, or by the per-pixel loop (`None`).
    fn warp_at<T: Pixel>(
        w: &InsideWarp<'_, T>,
        level: Option<SimdLevel>,
        out: &mut ImageViewMut<'_, f32>,
    ) {
        match level {
            None => today_any(w, out, 1),
            Some(l) => w.run(l, out, 1),
        }
    }

    use bayestrack_testkit::Lcg64 as Lcg;

    /// A map sending the `pw x ph` patch inside `[0, w-1] x [0, h-1]`:
    /// rotation, anisotropic scale and shear, then a translation that puts
    /// the footprint anywhere in the frame, or flush against an edge (exact,
    /// or up to 5e-7 past it, as `check_corners` lets through), so that `x`
    /// or `y` lands exactly on 0 or on the last column/row (`fx = 1`).
    fn inside_map(
        rng: &mut Lcg,
        (pw, ph): (usize, usize),
        (w, h): (usize, usize),
        scale: (f64, f64),
    ) -> Option<[f64; 6]> {
        let th = rng.range(-3.2, 3.2);
        let (s1, s2) = (rng.range(scale.0, scale.1), rng.range(scale.0, scale.1));
        let sh = rng.range(-0.4, 0.4);
        let (cs, sn) = (th.cos(), th.sin());
        let (mut a, mut b, mut c, mut d) = (cs * s1, -sn * s2 + sh, sn * s1, cs * s2);
        if rng.unit() < 0.15 {
            // Axis-aligned scales: whole columns share one `x`.
            (a, b, c, d) = (s1, 0.0, 0.0, s2);
        }
        let (pu, pv) = ((pw - 1) as f64, (ph - 1) as f64);
        let xs = [0.0, a * pu, b * pv, a * pu + b * pv];
        let ys = [0.0, c * pu, d * pv, c * pu + d * pv];
        let (x0, x1) = (
            xs.iter().copied().fold(f64::INFINITY, f64::min),
            xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let (y0, y1) = (
            ys.iter().copied().fold(f64::INFINITY, f64::min),
            ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let (wx, wy) = ((w - 1) as f64 - (x1 - x0), (h - 1) as f64 - (y1 - y0));
        if wx < 0.0 || wy < 0.0 {
            return None;
        }
        let place = |rng: &mut Lcg, lo: f64, room: f64| -> f64 {
            match (rng.unit() * 6.0) as u32 {
                0 => -lo,
                1 => -lo + room,
                2 => -lo - 5e-7,
                3 => -lo + room + 5e-7,
                _ => -lo + rng.range(0.0, room),
            }
        };
        let tx = place(rng, x0, wx);
        let ty = place(rng, y0, wy);
        Some([a, b, tx, c, d, ty])
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Compares every level with `today` on `src` for `trials` random maps
    /// and a few patch sizes.
    fn check_levels<T: Pixel>(
        src: ImageView<'_, T>,
        rng: &mut Lcg,
        trials: usize,
        scale: (f64, f64),
        what: &str,
    ) {
        let (w, h, ch) = (src.width(), src.height(), src.channels());
        let mut done = 0;
        for trial in 0..trials {
            let (pw, ph) = [(36, 36), (8, 3), (17, 5), (5, 4), (1, 2), (16, 2)][trial % 6];
            let Some(m) = inside_map(rng, (pw, ph), (w, h), scale) else {
                continue;
            };
            let iw = InsideWarp {
                data: src.as_slice(),
                stride: src.stride(),
                xmax: (w - 2) as f32,
                ymax: (h - 2) as f32,
                m,
            };
            let mut want = vec![0f32; pw * ph * ch];
            today_any(
                &iw,
                &mut ImageViewMut::from_slice(&mut want, pw, ph, ch, pw * ch).unwrap(),
                ch,
            );
            for level in crate::sad::tests::levels() {
                // A strided output: padding between rows stays untouched.
                let stride = pw * ch + 3;
                let mut got = vec![-7f32; stride * ph];
                let mut out = ImageViewMut::from_slice(&mut got, pw, ph, ch, stride).unwrap();
                iw.run(level, &mut out, ch);
                let rows: Vec<f32> = got
                    .chunks(stride)
                    .flat_map(|r| r[..pw * ch].iter().copied())
                    .collect();
                assert_eq!(
                    bits(&rows),
                    bits(&want),
                    "{what}, {ch} channels, {level:?}, trial {trial}, map {m:?}, patch {pw}x{ph}"
                );
                assert!(
                    got.chunks(stride)
                        .all(|r| r[pw * ch..].iter().all(|&p| p == -7.0))
                );
            }
            done += 1;
        }
        assert!(done * 2 > trials, "{what}: too few maps fit ({done})");
    }

    fn random_u8(w: usize, h: usize, ch: usize, rng: &mut Lcg) -> Image<u8> {
        Image::from_vec(
            w,
            h,
            ch,
            (0..w * h * ch)
                .map(|_| (rng.unit() * 256.0) as u8)
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn every_level_equals_the_per_pixel_loop_bit_for_bit() {
        let mut rng = Lcg(19);
        for ch in 1..=5 {
            // A crop: stride wider than the view, the view not at the
            // buffer's start.
            let big = random_u8(83, 61, ch, &mut rng);
            let src = big.crop(Rect::new(4, 3, 71, 52)).unwrap();
            check_levels(src, &mut rng, 60, (0.3, 1.6), "u8");
            let srcf = src.to_image().map(|v| f32::from(v) * 0.37 - 11.0);
            check_levels(srcf.view(), &mut rng, 60, (0.3, 1.6), "f32");
            let src16 = src.to_image().map(|v| u16::from(v) * 257);
            check_levels(src16.view(), &mut rng, 24, (0.3, 1.6), "u16");
        }
        // Frames of two columns or rows (the last cell is the first one).
        for (w, h) in [(2, 40), (40, 2), (2, 2)] {
            let img = random_u8(w, h, 3, &mut rng);
            check_levels(img.view(), &mut rng, 30, (0.001, 0.02), "u8 thin");
        }
    }

    /// One channel with AVX2 picks the neighbours from source windows
    /// when a batch's cells span at most 7 columns and
    /// `MAX_WINDOW_SPAN + 1` rows: maps that mostly do (horizontal scales
    /// up to 1.2, spans of 7 and more included, small vertical slopes and
    /// every other map steep ones, spans of more rows included, mirrored
    /// and sloping either way, so that the smallest cell is in the first
    /// lane or the last), placed anywhere or flush with the right and
    /// bottom edges (where a window would run past the buffer's end),
    /// patch rows narrower and wider than the 64 whose products are
    /// precomputed.
    #[test]
    fn window_batches_equal_the_per_pixel_loop_bit_for_bit() {
        let mut rng = Lcg(23);
        let big = random_u8(90, 40, 1, &mut rng);
        for src in [big.view(), big.crop(Rect::new(3, 2, 80, 35)).unwrap()] {
            let srcf = src.to_image().map(|v| f32::from(v) * 0.37 - 11.0);
            let (w, h) = (src.width(), src.height());
            for trial in 0..300 {
                let (pw, ph) = [(36, 36), (9, 4), (17, 5), (8, 3), (70, 2)][trial % 5];
                let a = rng.range(0.05, 1.2) * if trial % 7 == 0 { -1.0 } else { 1.0 };
                // Every other map steep: a batch across up to 15 rows
                // (more than `MAX_WINDOW_SPAN` + 1 in the narrow patches).
                let steep = (2.0f64).min(30.0 / (pw - 1) as f64);
                let c = if trial % 2 == 0 {
                    rng.range(-0.16, 0.16)
                } else {
                    rng.range(-steep, steep)
                };
                let (b, d) = (rng.range(-0.2, 0.2), rng.range(0.1, 0.8));
                let (pu, pv) = ((pw - 1) as f64, (ph - 1) as f64);
                let xs = [0.0, a * pu, b * pv, a * pu + b * pv];
                let ys = [0.0, c * pu, d * pv, c * pu + d * pv];
                let lo = |v: &[f64; 4]| v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = |v: &[f64; 4]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let (wx, wy) = (
                    (w - 1) as f64 - (hi(&xs) - lo(&xs)),
                    (h - 1) as f64 - (hi(&ys) - lo(&ys)),
                );
                if wx < 0.0 || wy < 0.0 {
                    continue;
                }
                let tx = -lo(&xs)
                    + if trial % 3 == 0 {
                        wx
                    } else {
                        rng.range(0.0, wx)
                    };
                let ty = -lo(&ys)
                    + if trial % 4 == 0 {
                        wy
                    } else {
                        rng.range(0.0, wy)
                    };
                let m = [a, b, tx, c, d, ty];
                for (what, iw) in [("u8", None), ("f32", Some(&srcf))] {
                    let mut want = vec![0f32; pw * ph];
                    let mut got = vec![0f32; pw * ph];
                    let run = |level: Option<SimdLevel>, out: &mut [f32]| {
                        let mut view = ImageViewMut::from_slice(out, pw, ph, 1, pw).unwrap();
                        let (xmax, ymax) = ((w - 2) as f32, (h - 2) as f32);
                        match iw {
                            None => warp_at(
                                &InsideWarp {
                                    data: src.as_slice(),
                                    stride: src.stride(),
                                    xmax,
                                    ymax,
                                    m,
                                },
                                level,
                                &mut view,
                            ),
                            Some(f) => warp_at(
                                &InsideWarp {
                                    data: f.as_slice(),
                                    stride: f.stride(),
                                    xmax,
                                    ymax,
                                    m,
                                },
                                level,
                                &mut view,
                            ),
                        }
                    };
                    run(None, &mut want);
                    for level in crate::sad::tests::levels() {
                        run(Some(level), &mut got);
                        assert_eq!(
                            bits(&got),
                            bits(&want),
                            "{what}, {level:?}, trial {trial}, map {m:?}, {pw}x{ph}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn signed_zero_coordinates_and_pixels_match() {
        // `x = -0.0` (from `tx = -0.0`, `a < 0` at `u = 0`) on a frame of
        // negative zeros: the sign of `fx` decides the sign of the output.
        let img = Image::from_fn(20, 12, |x, y| {
            if (x + y) % 3 == 0 {
                -0.0f32
            } else {
                (x * y) as f32
            }
        })
        .unwrap();
        let iw = InsideWarp {
            data: img.as_slice(),
            stride: img.stride(),
            xmax: 18.0,
            ymax: 10.0,
            m: [-0.0, -0.0, -0.0, -0.0, -0.0, -0.0],
        };
        let mut want = vec![0f32; 9 * 2];
        today_any(
            &iw,
            &mut ImageViewMut::from_slice(&mut want, 9, 2, 1, 9).unwrap(),
            1,
        );
        for level in crate::sad::tests::levels() {
            let mut got = vec![0f32; 9 * 2];
            iw.run(
                level,
                &mut ImageViewMut::from_slice(&mut got, 9, 2, 1, 9).unwrap(),
                1,
            );
            assert_eq!(bits(&got), bits(&want), "{level:?}");
        }
    }

    #[test]
    fn floor_small_is_truncation() {
        let mut rng = Lcg(5);
        let mut values: Vec<f32> = (0..200_000)
            .map(|_| rng.range(0.0, 4096.0) as f32)
            .collect();
        for k in [0u32, 1, 2, 7, 255, 4095, 1 << 20, (1 << 23) - 1] {
            let k = k as f32;
            for v in [k, k + 0.5, k + 0.25, k + 0.75] {
                values.extend([
                    v,
                    f32::from_bits(v.to_bits() + 1),
                    f32::from_bits(v.to_bits().saturating_sub(1)),
                ]);
            }
        }
        values.extend([
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-30,
            0.49999997,
            0.5,
            8_388_607.5,
        ]);
        for v in values.into_iter().filter(|v| *v < MAGIC && *v >= 0.0) {
            let (n, f) = floor_small(v);
            assert_eq!((n, f), (v as i32, (v as i32) as f32), "{v}");
        }
    }
}
