//! Gray, RGB and HSV pixels and image conversions.
//!
//! Conventions: RGB images are `u8` with 3 interleaved channels `r, g, b`;
//! gray images have 1 channel; HSV images are `f32` with 3 channels
//! `h, s, v`, hue in `[0, 1)` (a full turn is 1, so 0.5 is cyan),
//! saturation and value in `[0, 1]`.

use crate::simd::{Kernel, Token, dispatch};
use crate::{Image, ImageError, ImageView, ImageViewMut, Result};

/// BT.601 luma weights used by every gray conversion here.
pub const LUMA_WEIGHTS: [f32; 3] = [0.299, 0.587, 0.114];

/// An 8-bit RGB pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Rgb {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
}

impl Rgb {
    /// A pixel from its components.
    pub const fn new(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// BT.601 luma, rounded.
    pub fn luma(self) -> u8 {
        let [wr, wg, wb] = LUMA_WEIGHTS;
        (wr * f32::from(self.r) + wg * f32::from(self.g) + wb * f32::from(self.b)).round() as u8
    }

    /// The same colour in HSV.
    pub fn to_hsv(self) -> Hsv {
        Hsv::from_rgb(self)
    }

    /// As a `[r, g, b]` array.
    pub const fn to_array(self) -> [u8; 3] {
        [self.r, self.g, self.b]
    }
}

/// An HSV pixel: hue in `[0, 1)` turns, saturation and value in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Hsv {
    /// Hue in turns, `[0, 1)`.
    pub h: f32,
    /// Saturation, `[0, 1]`.
    pub s: f32,
    /// Value, `[0, 1]`.
    pub v: f32,
}

impl Hsv {
    /// Converts an RGB pixel (hexcone model; gray pixels get hue 0 and saturation 0).
    #[inline]
    pub fn from_rgb(p: Rgb) -> Self {
        let (h, s, v) = rgb_to_hsv_f32(
            f32::from(p.r) / 255.0,
            f32::from(p.g) / 255.0,
            f32::from(p.b) / 255.0,
        );
        Self { h, s, v }
    }

    /// Converts back to 8-bit RGB (hue taken modulo one turn, s and v clamped).
    pub fn to_rgb(self) -> Rgb {
        let h = self.h.rem_euclid(1.0) * 6.0;
        let s = self.s.clamp(0.0, 1.0);
        let v = self.v.clamp(0.0, 1.0);
        let sector = (h.floor() as i32).rem_euclid(6);
        let f = h - h.floor();
        let p = v * (1.0 - s);
        let q = v * (1.0 - s * f);
        let t = v * (1.0 - s * (1.0 - f));
        let (r, g, b) = match sector {
            0 => (v, t, p),
            1 => (q, v, p),
            2 => (p, v, t),
            3 => (p, q, v),
            4 => (t, p, v),
            _ => (v, p, q),
        };
        let q8 = |x: f32| (x * 255.0).round() as u8;
        Rgb::new(q8(r), q8(g), q8(b))
    }
}

/// Hexcone RGB -> HSV on unit-range components.
#[inline]
fn rgb_to_hsv_f32(r: f32, g: f32, b: f32) -> (f32, f32, f32) {
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    let v = max;
    let s = if max > 0.0 { d / max } else { 0.0 };
    if d <= 0.0 {
        return (0.0, s, v);
    }
    let h6 = if max == r {
        (g - b) / d
    } else if max == g {
        (b - r) / d + 2.0
    } else {
        (r - g) / d + 4.0
    };
    let mut h = h6 / 6.0;
    if h < 0.0 {
        h += 1.0;
    }
    if h >= 1.0 {
        h -= 1.0;
    }
    (h, s, v)
}

/// Shortest signed distance between two hues in turns, in `[-0.5, 0.5]`.
///
/// Hue is circular: 0.98 and 0.02 are 0.04 apart, not 0.96. Hues come
/// from the colour conversions of this crate, which are finite; a NaN or
/// infinite argument gives NaN (there is no distance to give).
#[inline]
pub fn hue_distance(a: f32, b: f32) -> f32 {
    let d = a - b;
    // `d.rem_euclid(1.0)` without the call to `fmodf` where it is the
    // identity: `d % 1.0` is `d` (sign and all) when `|d| < 1`, which two
    // hues in [0, 1) always are
    let r = if d.abs() < 1.0 { d } else { d % 1.0 };
    let d = if r < 0.0 { r + 1.0 } else { r };
    if d > 0.5 { d - 1.0 } else { d }
}

fn check_out<T: Copy, U: Copy>(
    operation: &'static str,
    src: &ImageView<'_, T>,
    out: &ImageViewMut<'_, U>,
    out_channels: usize,
) -> Result<()> {
    if out.width() != src.width() || out.height() != src.height() || out.channels() != out_channels
    {
        return Err(ImageError::SizeMismatch {
            operation,
            a_width: src.width(),
            a_height: src.height(),
            a_channels: out_channels,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        });
    }
    Ok(())
}

/// RGB (3 channels) to gray (1 channel), BT.601, into a caller buffer.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 3 channels;
/// [`ImageError::SizeMismatch`] unless `out` is 1-channel of the same size.
pub fn rgb_to_gray_into(src: ImageView<'_, u8>, out: &mut ImageViewMut<'_, u8>) -> Result<()> {
    src.expect_channels("rgb_to_gray", 3)?;
    check_out("rgb_to_gray", &src, out, 1)?;
    dispatch(GrayRows { src, out });
    Ok(())
}

/// One RGB pixel's (`p[..3]`) gray level as [`rgb_to_gray_into`] gives
/// it, in fixed point: the weights times 2^16, rounded (`(19595 r + 38470
/// g + 7471 b + 2^15) >> 16`, exact integers), for loops that convert
/// pixels on their own way.
#[inline(always)]
pub fn gray_level(p: &[u8]) -> u8 {
    ((luma_fixed(p) + (1 << 15)) >> 16) as u8
}

/// One RGB pixel's (`p[..3]`) luma times 2^16, unrounded: `19595 r +
/// 38470 g + 7471 b`, an exact integer below 2^24 (the sum of
/// [`gray_level`] and of `gray_region_into`).
#[inline(always)]
pub(crate) fn luma_fixed(p: &[u8]) -> u32 {
    const W: [u32; 3] = [19595, 38470, 7471];
    W[0] * u32::from(p[0]) + W[1] * u32::from(p[1]) + W[2] * u32::from(p[2])
}

/// The rows of [`rgb_to_gray_into`] (3 channels, checked) as a dispatched
/// kernel: integer arithmetic, so the same bytes at every level; compiled
/// for AVX2 the compiler converts the pixels in vector lanes (320x240 in
/// 29 us on Zen 3; its SSE2 loop took 128 us, a fifth of `bayestrack
/// track`'s time with `mad` on Crossing).
struct GrayRows<'a, 'b> {
    src: ImageView<'a, u8>,
    out: &'a mut ImageViewMut<'b, u8>,
}

impl Kernel for GrayRows<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self { src, out } = self;
        for y in 0..src.height() {
            for (d, p) in out.row_mut(y).iter_mut().zip(src.row(y).chunks_exact(3)) {
                *d = gray_level(p);
            }
        }
    }
}

/// RGB (3 channels) to a new gray image, BT.601.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 3 channels.
pub fn rgb_to_gray(src: ImageView<'_, u8>) -> Result<Image<u8>> {
    src.expect_channels("rgb_to_gray", 3)?;
    let mut out = Image::new(src.width(), src.height(), 1, 0u8)?;
    rgb_to_gray_into(src, &mut out.view_mut())?;
    Ok(out)
}

/// Gray (1 channel) to RGB (3 equal channels).
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 1 channel.
pub fn gray_to_rgb(src: ImageView<'_, u8>) -> Result<Image<u8>> {
    src.expect_channels("gray_to_rgb", 1)?;
    let mut out = Image::new(src.width(), src.height(), 3, 0u8)?;
    for y in 0..src.height() {
        for (d, &g) in out.row_mut(y).chunks_exact_mut(3).zip(src.row(y)) {
            d.fill(g);
        }
    }
    Ok(out)
}

/// Any 8-bit image (1 or 3 channels) to gray `f32` in `[0, 1]`, into a caller buffer.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 1 or 3 channels;
/// [`ImageError::SizeMismatch`] unless `out` is 1-channel of the same size.
pub fn to_gray_unit_into(src: ImageView<'_, u8>, out: &mut ImageViewMut<'_, f32>) -> Result<()> {
    check_out("to_gray_unit", &src, out, 1)?;
    match src.channels() {
        1 | 3 => {
            dispatch(GrayUnitRows { src, out });
            Ok(())
        }
        got => Err(ImageError::Channels {
            operation: "to_gray_unit",
            expected: 3,
            got,
        }),
    }
}

/// The rows of [`to_gray_unit_into`] (1 or 3 channels, checked) as a
/// dispatched kernel: compiled for AVX2 the compiler converts eight RGB
/// pixels at a time (its SSE2 loop assembled four from single bytes); the
/// same operations per pixel at every level, so the same bits.
struct GrayUnitRows<'a, 'b> {
    src: ImageView<'a, u8>,
    out: &'a mut ImageViewMut<'b, f32>,
}

impl Kernel for GrayUnitRows<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let Self { src, out } = self;
        if src.channels() == 1 {
            for y in 0..src.height() {
                for (d, &s) in out.row_mut(y).iter_mut().zip(src.row(y)) {
                    *d = f32::from(s) / 255.0;
                }
            }
        } else {
            let [wr, wg, wb] = LUMA_WEIGHTS.map(|w| w / 255.0);
            for y in 0..src.height() {
                for (d, p) in out.row_mut(y).iter_mut().zip(src.row(y).chunks_exact(3)) {
                    *d = wr * f32::from(p[0]) + wg * f32::from(p[1]) + wb * f32::from(p[2]);
                }
            }
        }
    }
}

/// Any 8-bit image (1 or 3 channels) to a new gray `f32` image in `[0, 1]`.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 1 or 3 channels.
pub fn to_gray_unit(src: ImageView<'_, u8>) -> Result<Image<f32>> {
    let mut out = Image::new(src.width(), src.height(), 1, 0f32)?;
    to_gray_unit_into(src, &mut out.view_mut())?;
    Ok(out)
}

/// RGB (3 channels, `u8`) to HSV (3 channels, `f32`) into a caller buffer.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 3 channels;
/// [`ImageError::SizeMismatch`] unless `out` is 3-channel of the same size.
pub fn rgb_to_hsv_into(src: ImageView<'_, u8>, out: &mut ImageViewMut<'_, f32>) -> Result<()> {
    src.expect_channels("rgb_to_hsv", 3)?;
    check_out("rgb_to_hsv", &src, out, 3)?;
    for y in 0..src.height() {
        let s = src.row(y);
        let o = out.row_mut(y);
        for (d, p) in o.chunks_exact_mut(3).zip(s.chunks_exact(3)) {
            let (h, sat, v) = rgb_to_hsv_f32(
                f32::from(p[0]) / 255.0,
                f32::from(p[1]) / 255.0,
                f32::from(p[2]) / 255.0,
            );
            d[0] = h;
            d[1] = sat;
            d[2] = v;
        }
    }
    Ok(())
}

/// RGB (3 channels, `u8`) to a new HSV image (3 channels, `f32`).
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 3 channels.
pub fn rgb_to_hsv(src: ImageView<'_, u8>) -> Result<Image<f32>> {
    src.expect_channels("rgb_to_hsv", 3)?;
    let mut out = Image::new(src.width(), src.height(), 3, 0f32)?;
    rgb_to_hsv_into(src, &mut out.view_mut())?;
    Ok(out)
}

/// HSV (3 channels, `f32`) to a new RGB image (3 channels, `u8`).
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 3 channels.
pub fn hsv_to_rgb(src: ImageView<'_, f32>) -> Result<Image<u8>> {
    src.expect_channels("hsv_to_rgb", 3)?;
    let mut out = Image::new(src.width(), src.height(), 3, 0u8)?;
    for y in 0..src.height() {
        for (d, p) in out
            .row_mut(y)
            .chunks_exact_mut(3)
            .zip(src.row(y).chunks_exact(3))
        {
            let rgb = Hsv {
                h: p[0],
                s: p[1],
                v: p[2],
            }
            .to_rgb();
            d.copy_from_slice(&rgb.to_array());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rect;
    use crate::simd::SimdLevel;

    /// `to_gray_unit_into`'s rows at every SIMD level equal the plain
    /// per-pixel loop bit for bit, for 1 and 3 channels, widths around the
    /// vector widths and cropped views (rows apart by more than a width).
    #[test]
    fn gray_unit_rows_equal_the_plain_loop_at_every_level() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for ch in [1, 3] {
            for w in (1..=18).chain([31, 32, 33, 63, 64, 65, 321]) {
                let (fw, h) = (w + 3, 5);
                let data: Vec<u8> = (0..fw * h * ch)
                    .map(|_| {
                        seed ^= seed << 13;
                        seed ^= seed >> 7;
                        seed ^= seed << 17;
                        (seed >> 24) as u8
                    })
                    .collect();
                let frame = Image::from_vec(fw, h, ch, data).unwrap();
                let rect = Rect {
                    x: 2,
                    y: 1,
                    width: w,
                    height: h - 1,
                };
                let src = frame.crop(rect).unwrap();
                let [wr, wg, wb] = LUMA_WEIGHTS.map(|v| v / 255.0);
                let mut want = Vec::new();
                for y in 0..src.height() {
                    for p in src.row(y).chunks_exact(ch) {
                        want.push(if ch == 1 {
                            f32::from(p[0]) / 255.0
                        } else {
                            wr * f32::from(p[0]) + wg * f32::from(p[1]) + wb * f32::from(p[2])
                        });
                    }
                }
                let want: Vec<u32> = want.iter().map(|v| v.to_bits()).collect();
                for level in SimdLevel::ALL {
                    let mut out = Image::new(w, h - 1, 1, f32::NAN).unwrap();
                    level.run(GrayUnitRows {
                        src,
                        out: &mut out.view_mut(),
                    });
                    let got: Vec<u32> = out.as_slice().iter().map(|v| v.to_bits()).collect();
                    assert_eq!(got, want, "{level:?}, {ch} channels, width {w}");
                }
                let mut out = Image::new(w, h - 1, 1, f32::NAN).unwrap();
                to_gray_unit_into(src, &mut out.view_mut()).unwrap();
                let got: Vec<u32> = out.as_slice().iter().map(|v| v.to_bits()).collect();
                assert_eq!(got, want, "dispatched, {ch} channels, width {w}");
            }
        }
    }

    #[test]
    fn primary_hues() {
        let h = |r, g, b| Hsv::from_rgb(Rgb::new(r, g, b));
        assert_eq!(h(255, 0, 0).h, 0.0);
        assert!((h(0, 255, 0).h - 1.0 / 3.0).abs() < 1e-6);
        assert!((h(0, 0, 255).h - 2.0 / 3.0).abs() < 1e-6);
        assert!((h(255, 0, 255).h - 5.0 / 6.0).abs() < 1e-6);
        let gray = h(128, 128, 128);
        assert_eq!((gray.h, gray.s), (0.0, 0.0));
        assert!((gray.v - 128.0 / 255.0).abs() < 1e-6);
        // Slightly bluish red wraps to just below 1.
        assert!(h(255, 0, 10).h > 0.99);
    }

    #[test]
    fn hsv_round_trip_all_cube_corners_and_more() {
        for r in (0..=255).step_by(17) {
            for g in (0..=255).step_by(17) {
                for b in (0..=255).step_by(17) {
                    let p = Rgb::new(r as u8, g as u8, b as u8);
                    assert_eq!(p.to_hsv().to_rgb(), p);
                }
            }
        }
    }

    #[test]
    fn hue_distance_wraps() {
        // the same bits as through `rem_euclid`, on hues of every 8-bit
        // colour against hues across [0, 1) and beyond, and the edges
        let reference = |a: f32, b: f32| {
            let d = (a - b).rem_euclid(1.0);
            if d > 0.5 { d - 1.0 } else { d }
        };
        let mut hues: Vec<f32> = (0..=255u8)
            .flat_map(|r| {
                (0..=255u8)
                    .step_by(5)
                    .map(move |g| Hsv::from_rgb(Rgb::new(r, g, 17)).h)
            })
            .collect();
        hues.extend([
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            2.75,
            -3.25,
            1e-30,
            f32::MAX,
            f32::NAN,
        ]);
        for &b in &[
            0.0f32,
            0.02,
            0.5,
            0.98,
            0.999_999_9,
            1.5,
            -0.25,
            f32::INFINITY,
        ] {
            for &a in &hues {
                let (got, want) = (hue_distance(a, b), reference(a, b));
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{a} {b}"
                );
            }
        }
        assert!((hue_distance(0.98, 0.02) + 0.04).abs() < 1e-6);
        assert!((hue_distance(0.02, 0.98) - 0.04).abs() < 1e-6);
        assert!((hue_distance(0.3, 0.1) - 0.2).abs() < 1e-6);
    }

    /// `rgb_to_gray_into`'s rows at every SIMD level give the fixed-point
    /// formula's byte (computed here in `u64`) for every colour whose
    /// components are multiples of 3 or 255 (so every extreme), in cropped
    /// views of widths around the vector widths.
    #[test]
    fn gray_rows_equal_the_fixed_point_formula_at_every_level() {
        let comps: Vec<u8> = (0..=255u8).step_by(3).chain([254, 255]).collect();
        let mut colours = Vec::new();
        for &r in &comps {
            for &g in &comps {
                for &b in &comps {
                    colours.push([r, g, b]);
                }
            }
        }
        let want = |[r, g, b]: [u8; 3]| {
            ((19595 * u64::from(r) + 38470 * u64::from(g) + 7471 * u64::from(b) + 32768) >> 16)
                as u8
        };
        for w in [1, 15, 16, 17, 33, 321] {
            let h = colours.len().div_ceil(w);
            let fw = w + 2;
            let mut data = vec![0u8; fw * (h + 1) * 3];
            for (i, c) in colours.iter().enumerate() {
                let at = ((i / w + 1) * fw + i % w + 2) * 3;
                data[at..at + 3].copy_from_slice(c);
            }
            let frame = Image::from_vec(fw, h + 1, 3, data).unwrap();
            let rect = Rect {
                x: 2,
                y: 1,
                width: w,
                height: h,
            };
            let src = frame.crop(rect).unwrap();
            for level in SimdLevel::ALL {
                let mut out = Image::new(w, h, 1, 0u8).unwrap();
                level.run(GrayRows {
                    src,
                    out: &mut out.view_mut(),
                });
                for (i, c) in colours.iter().enumerate() {
                    let got = out.as_slice()[i];
                    assert_eq!(got, want(*c), "{level:?}, width {w}, colour {c:?}");
                }
            }
        }
    }

    #[test]
    fn gray_conversions() {
        let img = Image::from_vec(2, 1, 3, vec![255, 255, 255, 255, 0, 0]).unwrap();
        let g = rgb_to_gray(img.view()).unwrap();
        assert_eq!(g.as_slice(), &[255, 76]);
        assert_eq!(Rgb::new(255, 0, 0).luma(), 76);
        let u = to_gray_unit(img.view()).unwrap();
        assert!((u.as_slice()[0] - 1.0).abs() < 1e-6);
        assert!(matches!(
            rgb_to_gray(g.view()),
            Err(ImageError::Channels {
                expected: 3,
                got: 1,
                ..
            })
        ));
        let back = gray_to_rgb(g.view()).unwrap();
        assert_eq!(back.as_slice(), &[255, 255, 255, 76, 76, 76]);
        let hsv = rgb_to_hsv(img.view()).unwrap();
        assert_eq!(hsv_to_rgb(hsv.view()).unwrap(), img);
    }
}
