//! Bilinear sampling and affine patch warps.
//!
//! A warp fills an output patch: for every patch pixel `(u, v)` (pixel
//! centres at integer coordinates, `0..w` by `0..h`) it samples the source
//! image bilinearly at `(x, y) = M (u, v, 1)`, where `M` is an [`Affine2`]
//! mapping **patch coordinates to image coordinates**. This is the
//! observation `O(M)` of Xu, Gao and Yang 2015 (paper 002): a fixed-size (36x36) patch seen through
//! an affine pose.

use crate::warp_simd::InsideWarp;
use crate::{Image, ImageError, ImageView, ImageViewMut, Pixel, Result, SimdLevel};

/// A 2-D affine map `(u, v) -> (a u + b v + tx, c u + d v + ty)`: the one
/// affine map type of the workspace.
///
/// Stored as the top two rows of the 3x3 homogeneous matrix, row-major:
/// `[a, b, tx, c, d, ty]`. This crate uses it for warps (patch to image
/// coordinates); `bayestrack-affine` adds the group structure of Aff(2)
/// (exp / log in the basis of paper 002, pose parameters) through its
/// `AffineGroup` extension trait, and trackers report it as their pose.
/// Values built by [`Affine2::from_rows`] and friends are finite; only
/// [`Affine2::translation`] takes its offsets unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine2 {
    m: [f64; 6],
}

impl Default for Affine2 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// `a * b` is [`Affine2::compose`]: first `b`, then `a`.
impl std::ops::Mul for Affine2 {
    type Output = Affine2;
    fn mul(self, rhs: Affine2) -> Affine2 {
        self.compose(&rhs)
    }
}

impl Affine2 {
    /// The identity map.
    pub const IDENTITY: Self = Self {
        m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    };

    /// The identity map (as [`Affine2::IDENTITY`]).
    pub const fn identity() -> Self {
        Self::IDENTITY
    }

    /// From the two top rows `[[a, b, tx], [c, d, ty]]`.
    ///
    /// # Errors
    /// [`ImageError::NonFinite`] if any entry is NaN or infinite.
    pub fn from_rows(rows: [[f64; 3]; 2]) -> Result<Self> {
        let m = [
            rows[0][0], rows[0][1], rows[0][2], rows[1][0], rows[1][1], rows[1][2],
        ];
        if m.iter().all(|v| v.is_finite()) {
            Ok(Self { m })
        } else {
            Err(ImageError::NonFinite {
                what: "affine matrix",
            })
        }
    }

    /// From a full 3x3 homogeneous matrix given as rows. The last row must be
    /// `[0, 0, 1]` (to within 1e-9).
    ///
    /// # Errors
    /// [`ImageError::NonFinite`] or [`ImageError::NotAffine`].
    pub fn from_matrix3(rows: [[f64; 3]; 3]) -> Result<Self> {
        let last = rows[2];
        if !last.iter().all(|v| v.is_finite()) {
            return Err(ImageError::NonFinite {
                what: "affine matrix",
            });
        }
        if last[0].abs() > 1e-9 || last[1].abs() > 1e-9 || (last[2] - 1.0).abs() > 1e-9 {
            return Err(ImageError::NotAffine { row: last });
        }
        Self::from_rows([rows[0], rows[1]])
    }

    /// From a 3x3 matrix stored column-major (the layout of
    /// `nalgebra::Matrix3::as_slice()`).
    ///
    /// # Errors
    /// As [`Affine2::from_matrix3`].
    pub fn from_column_major(c: &[f64; 9]) -> Result<Self> {
        Self::from_matrix3([[c[0], c[3], c[6]], [c[1], c[4], c[7]], [c[2], c[5], c[8]]])
    }

    /// A pure translation.
    pub fn translation(tx: f64, ty: f64) -> Self {
        Self {
            m: [1.0, 0.0, tx, 0.0, 1.0, ty],
        }
    }

    /// The map that sends a `patch_w x patch_h` patch onto the 0-based image
    /// rectangle with top-left corner `(x, y)` and size `w x h` (pixel areas,
    /// so patch pixel centres land on the centres of equal sub-cells).
    ///
    /// # Errors
    /// [`ImageError::NonFinite`] for non-finite input, [`ImageError::ZeroSize`]
    /// for an empty patch.
    pub fn patch_to_rect(
        patch_w: usize,
        patch_h: usize,
        x: f64,
        y: f64,
        w: f64,
        h: f64,
    ) -> Result<Self> {
        if patch_w == 0 || patch_h == 0 {
            return Err(ImageError::ZeroSize {
                width: patch_w,
                height: patch_h,
                channels: 1,
            });
        }
        let sx = w / patch_w as f64;
        let sy = h / patch_h as f64;
        Self::from_rows([[sx, 0.0, x + 0.5 * sx - 0.5], [0.0, sy, y + 0.5 * sy - 0.5]])
    }

    /// The 2x3 entries, row-major: `[a, b, tx, c, d, ty]`.
    pub fn as_array(&self) -> [f64; 6] {
        self.m
    }

    /// The full 3x3 homogeneous matrix as rows.
    pub fn to_matrix3(&self) -> [[f64; 3]; 3] {
        let m = self.m;
        [[m[0], m[1], m[2]], [m[3], m[4], m[5]], [0.0, 0.0, 1.0]]
    }

    /// Determinant of the linear part, `a d - b c`.
    pub fn det(&self) -> f64 {
        let m = &self.m;
        m[0] * m[4] - m[1] * m[3]
    }

    /// Applies the map to a point.
    #[inline]
    pub fn apply(&self, u: f64, v: f64) -> (f64, f64) {
        let m = &self.m;
        (m[0] * u + m[1] * v + m[2], m[3] * u + m[4] * v + m[5])
    }

    /// `self * other`: first `other`, then `self`.
    ///
    /// Plain arithmetic: for maps whose entries are near the largest `f64`
    /// the product can overflow to an infinite entry (every warp refuses
    /// such a map with [`ImageError::NonFinite`]);
    /// [`Affine2::checked_compose`] refuses it where it is made.
    pub fn compose(&self, other: &Self) -> Self {
        let a = &self.m;
        let b = &other.m;
        Self {
            m: [
                a[0] * b[0] + a[1] * b[3],
                a[0] * b[1] + a[1] * b[4],
                a[0] * b[2] + a[1] * b[5] + a[2],
                a[3] * b[0] + a[4] * b[3],
                a[3] * b[1] + a[4] * b[4],
                a[3] * b[2] + a[4] * b[5] + a[5],
            ],
        }
    }

    /// `self * other` as [`Affine2::compose`], refused when an entry of the
    /// product overflows.
    ///
    /// # Errors
    /// [`ImageError::NonFinite`] (`"composed affine map"`) when an entry of
    /// the product is infinite or NaN.
    pub fn checked_compose(&self, other: &Self) -> Result<Self> {
        let p = self.compose(other);
        if p.m.iter().all(|v| v.is_finite()) {
            Ok(p)
        } else {
            Err(ImageError::NonFinite {
                what: "composed affine map",
            })
        }
    }

    /// The inverse map, or `None` if the linear part is singular relative
    /// to the size of its entries (`|det| < 1e-14 max(|a|, |b|, |c|, |d|)^2`)
    /// or the inverse overflows.
    pub fn inverse(&self) -> Option<Self> {
        let [a, b, tx, c, d, ty] = self.m;
        let det = self.det();
        let scale = a.abs().max(b.abs()).max(c.abs()).max(d.abs());
        let scale = scale.max(f64::MIN_POSITIVE);
        if det == 0.0 || !det.is_finite() || (det / (scale * scale)).abs() < 1e-14 {
            return None;
        }
        let (ia, ib, ic, id) = (d / det, -b / det, -c / det, a / det);
        let m = [ia, ib, -(ia * tx + ib * ty), ic, id, -(ic * tx + id * ty)];
        m.iter().all(|v| v.is_finite()).then_some(Self { m })
    }
}

/// What a sample outside the frame gets.
///
/// The frame is `[0, width - 1] x [0, height - 1]` in pixel-centre coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[non_exhaustive]
pub enum Border {
    /// Refuse: a patch whose footprint leaves the frame is an
    /// [`ImageError::PatchOutside`].
    #[default]
    Error,
    /// Pixels outside the frame read as this value.
    Constant(f32),
    /// Coordinates are clamped to the frame (edge pixels repeat).
    Replicate,
}

/// Bilinear sample of channel `c` at `(x, y)`, or `None` when the point is
/// outside `[0, w-1] x [0, h-1]` (or `c` is out of range, or `x`/`y` NaN).
#[inline]
pub fn sample_bilinear<T: Pixel>(src: ImageView<'_, T>, x: f64, y: f64, c: usize) -> Option<f32> {
    let (w, h) = (src.width() as f64, src.height() as f64);
    // The negated comparisons also reject NaN.
    if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) || c >= src.channels() {
        return None;
    }
    Some(bilinear_inside(&src, x as f32, y as f32, c))
}

/// Bilinear sample with a border policy.
///
/// # Errors
/// Under [`Border::Error`], [`ImageError::PatchOutside`] (with `u = v = 0`)
/// when the point is outside; [`ImageError::Channels`] when `c` is out of
/// range; [`ImageError::NonFinite`] for NaN coordinates.
pub fn sample_bilinear_border<T: Pixel>(
    src: ImageView<'_, T>,
    x: f64,
    y: f64,
    c: usize,
    border: Border,
) -> Result<f32> {
    if c >= src.channels() {
        return Err(ImageError::Channels {
            operation: "sample_bilinear",
            expected: c + 1,
            got: src.channels(),
        });
    }
    if !x.is_finite() || !y.is_finite() {
        return Err(ImageError::NonFinite {
            what: "sample coordinates",
        });
    }
    if let Some(v) = sample_bilinear(src, x, y, c) {
        return Ok(v);
    }
    match border {
        Border::Error => Err(ImageError::PatchOutside {
            u: 0,
            v: 0,
            x,
            y,
            width: src.width(),
            height: src.height(),
        }),
        Border::Replicate => Ok(bilinear_inside(&src, x as f32, y as f32, c)),
        Border::Constant(k) => Ok(bilinear_constant(&src, x as f32, y as f32, c, k)),
    }
}

/// Bilinear interpolation with coordinates clamped into the frame.
#[inline(always)]
fn bilinear_inside<T: Pixel>(src: &ImageView<'_, T>, x: f32, y: f32, c: usize) -> f32 {
    let (w, h) = (src.width(), src.height());
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let x0 = (x as usize).min(w.saturating_sub(2));
    let y0 = (y as usize).min(h.saturating_sub(2));
    let fx = x - x0 as f32;
    let fy = y - y0 as f32;
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let ch = src.channels();
    let r0 = src.row(y0);
    let r1 = src.row(y1);
    let p00 = r0[x0 * ch + c].to_f32();
    let p01 = r0[x1 * ch + c].to_f32();
    let p10 = r1[x0 * ch + c].to_f32();
    let p11 = r1[x1 * ch + c].to_f32();
    let top = p00 + fx * (p01 - p00);
    let bot = p10 + fx * (p11 - p10);
    top + fy * (bot - top)
}

/// Bilinear interpolation where neighbours outside the frame read `k`.
fn bilinear_constant<T: Pixel>(src: &ImageView<'_, T>, x: f32, y: f32, c: usize, k: f32) -> f32 {
    let xf = x.floor();
    let yf = y.floor();
    let fx = x - xf;
    let fy = y - yf;
    let at = |xi: f32, yi: f32| -> f32 {
        if xi < 0.0 || yi < 0.0 || xi >= src.width() as f32 || yi >= src.height() as f32 {
            k
        } else {
            src.get(xi as usize, yi as usize, c)
                .map_or(k, |v| v.to_f32())
        }
    };
    let top = at(xf, yf) + fx * (at(xf + 1.0, yf) - at(xf, yf));
    let bot = at(xf, yf + 1.0) + fx * (at(xf + 1.0, yf + 1.0) - at(xf, yf + 1.0));
    top + fy * (bot - top)
}

/// Checks that every patch corner maps inside the frame. An affine map sends
/// the patch rectangle to a parallelogram, so the corners decide.
fn check_corners(m: &Affine2, pw: usize, ph: usize, w: usize, h: usize) -> Result<bool> {
    const EPS: f64 = 1e-6;
    let mut inside = true;
    for (u, v) in [(0, 0), (pw - 1, 0), (0, ph - 1), (pw - 1, ph - 1)] {
        let (x, y) = m.apply(u as f64, v as f64);
        if !x.is_finite() || !y.is_finite() {
            return Err(ImageError::NonFinite {
                what: "warped patch coordinates",
            });
        }
        if x < -EPS || y < -EPS || x > (w - 1) as f64 + EPS || y > (h - 1) as f64 + EPS {
            inside = false;
        }
    }
    Ok(inside)
}

fn first_outside_corner(m: &Affine2, pw: usize, ph: usize, w: usize, h: usize) -> ImageError {
    const EPS: f64 = 1e-6;
    for (u, v) in [(0, 0), (pw - 1, 0), (0, ph - 1), (pw - 1, ph - 1)] {
        let (x, y) = m.apply(u as f64, v as f64);
        if x < -EPS || y < -EPS || x > (w - 1) as f64 + EPS || y > (h - 1) as f64 + EPS {
            return ImageError::PatchOutside {
                u,
                v,
                x,
                y,
                width: w,
                height: h,
            };
        }
    }
    unreachable!("called only when a corner is outside")
}

/// Warps `src` through `m` (patch -> image coordinates) into the caller's
/// patch `out`, which fixes the patch size and must have the same channel
/// count as `src`. Allocation-free.
///
/// When the whole patch lies inside the frame (the tracker's case), one to
/// four channels are computed eight patch pixels at a time in SIMD lanes,
/// with run-time CPU dispatch (SSE2, AVX2, AVX-512); the values are bit for
/// bit those of bilinear interpolation pixel by pixel in the order
/// `top = p00 + fx (p01 - p00)`, `bot = p10 + fx (p11 - p10)`,
/// `top + fy (bot - top)`, with the map applied in `f64` and the sample
/// point rounded to `f32`.
///
/// ```
/// use bayestrack_image::{Affine2, Border, Image, ImageViewMut, warp_into};
/// let frame = Image::from_fn(100, 80, |x, y| (x + y) as f32).unwrap();
/// let mut buf = [0f32; 36 * 36];
/// let mut patch = ImageViewMut::from_slice(&mut buf, 36, 36, 1, 36).unwrap();
/// warp_into(frame.view(), &Affine2::translation(10.0, 5.0), Border::Error, &mut patch).unwrap();
/// assert_eq!(buf[0], 15.0);
/// assert_eq!(buf[36 + 2], 18.0); // (u, v) = (2, 1) -> (12, 6)
/// ```
///
/// # Errors
/// [`ImageError::Channels`] on a channel mismatch; [`ImageError::NonFinite`]
/// if the map produces non-finite coordinates; under [`Border::Error`],
/// [`ImageError::PatchOutside`] naming the first patch corner that leaves
/// the frame (nothing is written then).
pub fn warp_into<T: Pixel>(
    src: ImageView<'_, T>,
    m: &Affine2,
    border: Border,
    out: &mut ImageViewMut<'_, f32>,
) -> Result<()> {
    if out.channels() != src.channels() {
        return Err(ImageError::Channels {
            operation: "warp_into",
            expected: src.channels(),
            got: out.channels(),
        });
    }
    let (pw, ph) = (out.width(), out.height());
    let (w, h) = (src.width(), src.height());
    let inside = check_corners(m, pw, ph, w, h)?;
    let ch = src.channels();
    let [a, b, tx, c, d, ty] = m.m;
    if inside && w >= 2 && h >= 2 {
        // Fast path: every sample is inside (to within rounding), so the
        // four neighbours are read straight from the buffer, a patch row
        // eight pixels at a time in vector lanes (see `warp_simd.rs`).
        let p = InsideWarp {
            data: src.as_slice(),
            stride: src.stride(),
            xmax: (w - 2) as f32,
            ymax: (h - 2) as f32,
            m: [a, b, tx, c, d, ty],
        };
        p.run(SimdLevel::detect(), out, ch);
        return Ok(());
    }
    if inside {
        // Degenerate one-pixel-wide or -high frames.
        for v in 0..ph {
            let row = out.row_mut(v);
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            for u in 0..pw {
                let uf = u as f64;
                let x = (a * uf + bx) as f32;
                let y = (c * uf + by) as f32;
                for k in 0..ch {
                    row[u * ch + k] = bilinear_inside(&src, x, y, k);
                }
            }
        }
        return Ok(());
    }
    match border {
        Border::Error => Err(first_outside_corner(m, pw, ph, w, h)),
        Border::Replicate => {
            for v in 0..ph {
                let row = out.row_mut(v);
                for u in 0..pw {
                    let (x, y) = m.apply(u as f64, v as f64);
                    for k in 0..ch {
                        row[u * ch + k] = bilinear_inside(&src, x as f32, y as f32, k);
                    }
                }
            }
            Ok(())
        }
        Border::Constant(value) => {
            for v in 0..ph {
                let row = out.row_mut(v);
                for u in 0..pw {
                    let (x, y) = m.apply(u as f64, v as f64);
                    for k in 0..ch {
                        row[u * ch + k] = bilinear_constant(&src, x as f32, y as f32, k, value);
                    }
                }
            }
            Ok(())
        }
    }
}

/// Allocating convenience over [`warp_into`]: a new `width x height` patch.
///
/// # Errors
/// As [`warp_into`], plus [`ImageError::ZeroSize`] for an empty patch.
pub fn warp<T: Pixel>(
    src: ImageView<'_, T>,
    m: &Affine2,
    width: usize,
    height: usize,
    border: Border,
) -> Result<Image<f32>> {
    let mut out = Image::new(width, height, src.channels(), 0f32)?;
    warp_into(src, m, border, &mut out.view_mut())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Image<f32> {
        Image::from_fn(20, 10, |x, y| (x as f32) + 100.0 * (y as f32)).unwrap()
    }

    #[test]
    fn bilinear_is_exact_on_a_linear_ramp() {
        let img = ramp();
        let v = sample_bilinear(img.view(), 3.25, 4.5, 0).unwrap();
        assert!((v - (3.25 + 450.0)).abs() < 1e-3);
        assert_eq!(sample_bilinear(img.view(), 19.0, 9.0, 0), Some(919.0));
        assert_eq!(sample_bilinear(img.view(), 19.01, 0.0, 0), None);
        assert_eq!(sample_bilinear(img.view(), f64::NAN, 0.0, 0), None);
        assert!(matches!(
            sample_bilinear_border(img.view(), -1.0, 0.0, 0, Border::Error),
            Err(ImageError::PatchOutside { .. })
        ));
        let r = sample_bilinear_border(img.view(), -1.0, 0.0, 0, Border::Replicate).unwrap();
        assert_eq!(r, 0.0);
        let k = sample_bilinear_border(img.view(), -0.5, 0.0, 0, Border::Constant(10.0)).unwrap();
        assert!((k - 5.0).abs() < 1e-6);
    }

    #[test]
    fn warp_with_rotation_and_scale_matches_the_ramp() {
        let img = ramp();
        // 90 degree rotation + scale 0.5 about a point inside.
        let m = Affine2::from_rows([[0.0, -0.5, 10.0], [0.5, 0.0, 2.0]]).unwrap();
        let p = warp(img.view(), &m, 8, 8, Border::Error).unwrap();
        for v in 0..8 {
            for u in 0..8 {
                let (x, y) = m.apply(u as f64, v as f64);
                let want = x + 100.0 * y;
                assert!((f64::from(p.get(u, v, 0).unwrap()) - want).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn warp_outside_is_a_typed_error_or_a_border() {
        let img = ramp();
        let m = Affine2::translation(15.0, 0.0);
        let mut buf = [0f32; 36];
        let mut out = ImageViewMut::from_slice(&mut buf, 6, 6, 1, 6).unwrap();
        match warp_into(img.view(), &m, Border::Error, &mut out) {
            Err(ImageError::PatchOutside { u: 5, v: 0, x, .. }) => assert_eq!(x, 20.0),
            other => panic!("expected PatchOutside, got {other:?}"),
        }
        warp_into(img.view(), &m, Border::Replicate, &mut out).unwrap();
        assert_eq!(buf[5], 19.0);
        let mut out = ImageViewMut::from_slice(&mut buf, 6, 6, 1, 6).unwrap();
        warp_into(img.view(), &m, Border::Constant(-1.0), &mut out).unwrap();
        assert_eq!(buf[4], 19.0);
        assert_eq!(buf[5], -1.0);
        let nan = Affine2::translation(f64::NAN, 0.0);
        let mut out = ImageViewMut::from_slice(&mut buf, 6, 6, 1, 6).unwrap();
        assert!(matches!(
            warp_into(img.view(), &nan, Border::Replicate, &mut out),
            Err(ImageError::NonFinite { .. })
        ));
    }

    #[test]
    fn affine_algebra() {
        let a = Affine2::from_rows([[1.2, 0.3, 4.0], [-0.2, 0.9, -1.0]]).unwrap();
        let i = a.inverse().unwrap();
        let id = a.compose(&i);
        for (x, y) in id.as_array().iter().zip(Affine2::IDENTITY.as_array()) {
            assert!((x - y).abs() < 1e-12);
        }
        assert_eq!(a.det(), 1.2 * 0.9 - 0.3 * -0.2);
        assert_eq!(Affine2::identity(), Affine2::IDENTITY);
        // singular relative to the entries' size, whatever their scale
        for s in [1e-3, 1.0, 1e6] {
            let nearly = Affine2::from_rows([[s, 2.0 * s, 1.0], [s, 2.0 * s + 1e-15 * s, 0.0]]);
            assert_eq!(nearly.unwrap().inverse(), None, "scale {s}");
            let small = Affine2::from_rows([[1e-3 * s, 0.0, 1.0], [0.0, 1e-3 * s, 0.0]]).unwrap();
            assert!(small.inverse().is_some(), "scale {s}");
        }
        let cm = [1.2, -0.2, 0.0, 0.3, 0.9, 0.0, 4.0, -1.0, 1.0];
        assert_eq!(Affine2::from_column_major(&cm).unwrap(), a);
        assert_eq!(Affine2::from_matrix3(a.to_matrix3()).unwrap(), a);
        assert!(matches!(
            Affine2::from_matrix3([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.1, 0.0, 1.0]]),
            Err(ImageError::NotAffine { .. })
        ));
        // A patch onto a rectangle: corners of the pixel grid land inside it.
        let p = Affine2::patch_to_rect(4, 4, 10.0, 20.0, 8.0, 8.0).unwrap();
        assert_eq!(p.apply(0.0, 0.0), (10.5, 20.5));
        assert_eq!(p.apply(3.0, 3.0), (16.5, 26.5));
        let same = Affine2::patch_to_rect(4, 4, 10.0, 20.0, 4.0, 4.0).unwrap();
        assert_eq!(same, Affine2::translation(10.0, 20.0));
    }

    proptest::proptest! {
        /// The fast inside path equals per-sample bilinear interpolation.
        #[test]
        fn warp_matches_sample_bilinear(
            a in 0.3f64..1.5, b in -0.5f64..0.5, c in -0.5f64..0.5, d in 0.3f64..1.5,
            tx in 0.0f64..40.0, ty in 0.0f64..30.0,
        ) {
            let img = Image::from_fn(61, 47, |x, y| ((x * 37 + y * 101) % 251) as u8).unwrap();
            let m = Affine2::from_rows([[a, b, tx], [c, d, ty]]).unwrap();
            let mut buf = [0f32; 12 * 10];
            let mut out = ImageViewMut::from_slice(&mut buf, 12, 10, 1, 12).unwrap();
            match warp_into(img.view(), &m, Border::Error, &mut out) {
                Ok(()) => {
                    for v in 0..10 {
                        for u in 0..12 {
                            let (x, y) = m.apply(u as f64, v as f64);
                            let want = sample_bilinear(img.view(), x.clamp(0.0, 60.0), y.clamp(0.0, 46.0), 0).unwrap();
                            proptest::prop_assert!((buf[v * 12 + u] - want).abs() < 1e-2);
                        }
                    }
                }
                Err(ImageError::PatchOutside { .. }) => {
                    let inside = [(0.0, 0.0), (11.0, 0.0), (0.0, 9.0), (11.0, 9.0)].iter().all(|&(u, v)| {
                        let (x, y) = m.apply(u, v);
                        (0.0..=60.0).contains(&x) && (0.0..=46.0).contains(&y)
                    });
                    proptest::prop_assert!(!inside);
                }
                Err(e) => proptest::prop_assert!(false, "unexpected {e}"),
            }
        }
    }

    #[test]
    fn warp_multichannel_u8() {
        let img = Image::from_vec(2, 2, 2, vec![0u8, 10, 100, 110, 200, 210, 50, 60]).unwrap();
        let m = Affine2::from_rows([[0.5, 0.0, 0.0], [0.0, 0.5, 0.0]]).unwrap();
        let p = warp(img.view(), &m, 3, 3, Border::Error).unwrap();
        assert_eq!(p.pixel(1, 1).unwrap(), &[87.5, 97.5]);
        let mut wrong = Image::new(3, 3, 1, 0f32).unwrap();
        assert!(matches!(
            warp_into(img.view(), &m, Border::Error, &mut wrong.view_mut()),
            Err(ImageError::Channels { .. })
        ));
    }

    /// The inside path as it was before the 1- and 3-channel loops (one
    /// loop over a run-time channel count, unsigned conversions).
    fn reference_inside<T: Pixel>(
        src: ImageView<'_, T>,
        m: &Affine2,
        out: &mut [f32],
        pw: usize,
        ph: usize,
    ) {
        let [a, b, tx, c, d, ty] = m.as_array();
        let (w, h, ch) = (src.width(), src.height(), src.channels());
        let data = src.as_slice();
        let stride = src.stride();
        let (xmax, ymax) = ((w - 2) as f32, (h - 2) as f32);
        for v in 0..ph {
            let vf = v as f64;
            let (bx, by) = (b * vf + tx, d * vf + ty);
            for u in 0..pw {
                let uf = u as f64;
                let x = ((a * uf + bx) as f32).max(0.0);
                let y = ((c * uf + by) as f32).max(0.0);
                let xi = x.min(xmax) as usize;
                let yi = y.min(ymax) as usize;
                let fx = (x - xi as f32).min(1.0);
                let fy = (y - yi as f32).min(1.0);
                let i00 = yi * stride + xi * ch;
                for k in 0..ch {
                    let i = i00 + k;
                    let p00 = data[i].to_f32();
                    let p01 = data[i + ch].to_f32();
                    let p10 = data[i + stride].to_f32();
                    let p11 = data[i + stride + ch].to_f32();
                    let top = p00 + fx * (p01 - p00);
                    let bot = p10 + fx * (p11 - p10);
                    out[(v * pw + u) * ch + k] = top + fy * (bot - top);
                }
            }
        }
    }

    #[test]
    fn channel_specialised_warps_equal_the_generic_loop_bit_for_bit() {
        let mut lcg = bayestrack_testkit::Lcg32(7);
        let mut next = move || lcg.next_u32() >> 8;
        for ch in 1..=4 {
            let big = Image::from_vec(
                70,
                50,
                ch,
                (0..70 * 50 * ch).map(|_| (next() % 256) as u8).collect(),
            )
            .unwrap();
            // A crop: stride wider than the view.
            let src = big.crop(crate::Rect::new(3, 2, 61, 45)).unwrap();
            let srcf = src.to_image().map(|v| f32::from(v) * 0.37 - 11.0);
            for trial in 0..20 {
                let mut r = |n: u32| (next() % n) as f64 / n as f64;
                let m = Affine2::from_rows([
                    [0.4 + r(1000), r(1000) * 0.6 - 0.3, 2.0 + 20.0 * r(1000)],
                    [r(1000) * 0.6 - 0.3, 0.4 + r(1000), 2.0 + 15.0 * r(1000)],
                ])
                .unwrap();
                let (pw, ph) = (17, 13);
                let mut want = vec![0f32; pw * ph * ch];
                let mut got = vec![0f32; pw * ph * ch];
                let mut outv = ImageViewMut::from_slice(&mut got, pw, ph, ch, pw * ch).unwrap();
                if warp_into(src, &m, Border::Error, &mut outv).is_err() {
                    continue;
                }
                reference_inside(src, &m, &mut want, pw, ph);
                assert_eq!(got, want, "u8, {ch} channels, trial {trial}");
                let mut outv = ImageViewMut::from_slice(&mut got, pw, ph, ch, pw * ch).unwrap();
                warp_into(srcf.view(), &m, Border::Error, &mut outv).unwrap();
                reference_inside(srcf.view(), &m, &mut want, pw, ph);
                assert_eq!(got, want, "f32, {ch} channels, trial {trial}");
            }
        }
    }
}
