//! HSV skin-colour cue (Lee, Jo and Kang (paper 003), eq. 8).
//!
//! `C(x, y) = exp(-((h - h_R)^2 + (s - s_R)^2) / (2 sigma_hs^2))`, with hue
//! in turns (`[0, 1)`) and saturation in `[0, 1]`. Hue is an angle, so
//! `h - h_R` is the shortest way round the circle: a reference hue of 0.99
//! and a pixel hue of 0.01 are 0.02 apart. The paper uses `sigma_hs = 0.05`.

use bayestrack_image::{Hsv, ImageError, ImageView, ImageViewMut, Rect, Rgb, hue_distance};

use crate::error::check_window;
use crate::{AppearanceError, Result};
use bayestrack_image::simd::{Kernel, Token, dispatch};

/// A skin-colour reference (hue, saturation) with its spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinModel {
    hue: f32,
    saturation: f32,
    sigma: f32,
    /// `-1 / (2 sigma^2)`.
    k: f32,
    /// The batch kernel's constants (see [`SkinLanes`]).
    lanes: SkinLanes,
}

/// Constants of the batch kernel behind [`SkinModel::map_rgb_into`], which
/// evaluates eq. 8 for [`LANES`] pixels
/// at a time in straight-line `f32` code the compiler vectorises.
///
/// With `M = max(r, g, b)`, `m = min(r, g, b)`, `d = M - m`, the hexcone hue
/// in sixths of a turn is `6 h = o + n / d` (`o = 0, 2, 4` and
/// `n = g - b, b - r, r - g` as `M` is `r`, `g` or `b`). The kernel forms
/// `6 (h - h_R) = (n / d + c_hi[o]) + c_lo[o]` with
/// `c[o] = o - 6 h_R` split into two `f32`s, so the only rounding that
/// grows with the hue is that of `n / d`: evaluating `6 h` first and then
/// subtracting would round `6 h` (up to 6) to 2.4e-7 and, at the steepest
/// point of eq. 8 with `sigma = 0.05`, move the cue by 5e-7.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SkinLanes {
    c_hi: [f32; 3],
    c_lo: [f32; 3],
    /// `k / 36`: the exponent's weight on `(6 dh)^2`.
    k36: f32,
}

/// Pixels per step of the batch kernel.
const LANES: usize = 16;

impl SkinModel {
    /// The paper's spread, `sigma_hs = 0.05`.
    pub const PAPER_SIGMA: f64 = 0.05;

    /// A model with reference hue (turns; taken modulo 1), saturation
    /// (`[0, 1]`) and spread `sigma > 0`.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] / [`AppearanceError::NonFinite`].
    pub fn new(hue: f64, saturation: f64, sigma: f64) -> Result<Self> {
        if !hue.is_finite() || !saturation.is_finite() {
            return Err(AppearanceError::NonFinite {
                what: "skin reference",
            });
        }
        if !(0.0..=1.0).contains(&saturation) {
            return Err(AppearanceError::InvalidParameter {
                name: "saturation",
                value: saturation.to_string(),
                reason: "must be in [0, 1]",
            });
        }
        let sigma =
            crate::error::spread_at_least("sigma", sigma, crate::error::MIN_SIGMA_F32)? as f32;
        let hue = hue.rem_euclid(1.0) as f32;
        let k = -1.0 / (2.0 * sigma * sigma);
        let c = [0.0, 2.0, 4.0].map(|o| o - 6.0 * f64::from(hue));
        let c_hi = c.map(|c| c as f32);
        let mut c_lo = [0f32; 3];
        for i in 0..3 {
            c_lo[i] = (c[i] - f64::from(c_hi[i])) as f32;
        }
        Ok(Self {
            hue,
            saturation: saturation as f32,
            sigma,
            k,
            lanes: SkinLanes {
                c_hi,
                c_lo,
                k36: (f64::from(k) / 36.0) as f32,
            },
        })
    }

    /// Learns the reference from an RGB window (the "initial particle
    /// subset" of the paper): circular mean of the hue, mean saturation.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless the frame has 3 channels;
    /// [`AppearanceError::WindowOutside`]; [`AppearanceError::InvalidParameter`]
    /// for a bad sigma or a window whose hues cancel out (no mean hue).
    pub fn from_window(frame: ImageView<'_, u8>, window: Rect, sigma: f64) -> Result<Self> {
        frame.expect_channels("SkinModel::from_window", 3)?;
        check_window(
            "SkinModel::from_window",
            window,
            frame.width(),
            frame.height(),
        )?;
        let (mut sx, mut sy, mut ss) = (0f64, 0f64, 0f64);
        for y in window.y..window.bottom() {
            for p in frame.row(y)[window.x * 3..window.right() * 3].chunks_exact(3) {
                let hsv = Hsv::from_rgb(Rgb::new(p[0], p[1], p[2]));
                let a = f64::from(hsv.h) * std::f64::consts::TAU;
                // Weight the hue by saturation: gray pixels have no hue.
                sx += f64::from(hsv.s) * a.cos();
                sy += f64::from(hsv.s) * a.sin();
                ss += f64::from(hsv.s);
            }
        }
        let n = window.area() as f64;
        if sx.hypot(sy) < 1e-9 * n {
            return Err(AppearanceError::InvalidParameter {
                name: "window",
                value: window.to_string(),
                reason: "has no dominant hue (gray, or hues cancel out)",
            });
        }
        let hue = sy.atan2(sx) / std::f64::consts::TAU;
        Self::new(hue, (ss / n).clamp(0.0, 1.0), sigma)
    }

    /// Reference hue in turns.
    pub fn hue(&self) -> f64 {
        f64::from(self.hue)
    }

    /// Reference saturation.
    pub fn saturation(&self) -> f64 {
        f64::from(self.saturation)
    }

    /// The spread sigma_hs.
    pub fn sigma(&self) -> f64 {
        f64::from(self.sigma)
    }

    /// Eq. 8 for one HSV pixel, in `(0, 1]`.
    #[inline]
    pub fn score_hsv(&self, h: f32, s: f32) -> f32 {
        let mut dh = h - self.hue;
        if !(-0.5..=0.5).contains(&dh) {
            // Across the wrap (or a hue outside [0, 1)): the circular distance.
            dh = hue_distance(h, self.hue);
        }
        let ds = s - self.saturation;
        (self.k * (dh * dh + ds * ds)).exp()
    }

    /// Eq. 8 for one RGB pixel.
    #[inline]
    pub fn score_rgb(&self, p: Rgb) -> f32 {
        let hsv = Hsv::from_rgb(p);
        self.score_hsv(hsv.h, hsv.s)
    }

    /// The skin map of a whole RGB frame into a 1-channel `f32` buffer of the
    /// same size. Allocation-free. A batch kernel, vectorised for the CPU
    /// at run time: every value is within 1e-6 of eq. 8 evaluated in `f64`
    /// (checked over all 2^24 colours for sigma 0.05; it may differ from
    /// [`SkinModel::score_rgb`] by as much).
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `rgb` has 3 channels;
    /// [`ImageError::SizeMismatch`] for a wrong `out`.
    pub fn map_rgb_into(
        &self,
        rgb: ImageView<'_, u8>,
        out: &mut ImageViewMut<'_, f32>,
    ) -> Result<()> {
        rgb.expect_channels("skin map", 3)?;
        check_out(&rgb, out)?;
        let w = rgb.width();
        for y in 0..rgb.height() {
            self.score_row(&rgb.row(y)[..3 * w], &mut out.row_mut(y)[..w]);
        }
        Ok(())
    }

    /// The skin map of a 3-channel HSV frame (as made by
    /// `bayestrack_image::rgb_to_hsv`). Allocation-free.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `hsv` has 3 channels;
    /// [`ImageError::SizeMismatch`] for a wrong `out`;
    /// [`AppearanceError::NonFinite`] for a NaN or infinite hue or
    /// saturation (its score was NaN; `out` holds the map computed).
    pub fn map_hsv_into(
        &self,
        hsv: ImageView<'_, f32>,
        out: &mut ImageViewMut<'_, f32>,
    ) -> Result<()> {
        hsv.expect_channels("skin map", 3)?;
        check_out(&hsv, out)?;
        // `|v| <= MAX` fails for NaN and +-inf: one compare per value
        let mut finite = true;
        for y in 0..hsv.height() {
            let row = hsv.row(y);
            for (d, p) in out.row_mut(y).iter_mut().zip(row.chunks_exact(3)) {
                finite &= p[0].abs() <= f32::MAX && p[1].abs() <= f32::MAX;
                *d = self.score_hsv(p[0], p[1]);
            }
        }
        if !finite {
            return Err(AppearanceError::NonFinite {
                what: "HSV frame of the skin map",
            });
        }
        Ok(())
    }

    /// Mean of eq. 8 over an RGB window.
    ///
    /// # Errors
    /// [`ImageError::Channels`]; [`AppearanceError::WindowOutside`].
    pub fn window_mean(&self, rgb: ImageView<'_, u8>, window: Rect) -> Result<f64> {
        rgb.expect_channels("skin window", 3)?;
        check_window("skin window", window, rgb.width(), rgb.height())?;
        // The scalar path, one pixel at a time: the paper 003 trackers'
        // pinned numbers (tests/golden/condensation.csv) were made with it,
        // and the batch kernel moves the cue by up to 6e-7.
        let mut s = 0f64;
        for y in window.y..window.bottom() {
            for p in rgb.row(y)[window.x * 3..window.right() * 3].chunks_exact(3) {
                s += f64::from(self.score_rgb(Rgb::new(p[0], p[1], p[2])));
            }
        }
        Ok(s / window.area() as f64)
    }

    /// Eq. 8 for the RGB pixels of `rgb` (`3 x out.len()` bytes) into `out`,
    /// [`LANES`] at a time; a short tail goes through a zero-padded block.
    fn score_row(&self, rgb: &[u8], out: &mut [f32]) {
        dispatch(ScoreRow {
            model: self,
            rgb,
            out,
        });
    }

    #[inline(always)]
    fn score_row_inline(&self, rgb: &[u8], out: &mut [f32]) {
        let mut px = rgb.chunks_exact(3 * LANES);
        let mut o = out.chunks_exact_mut(LANES);
        for (p, d) in (&mut px).zip(&mut o) {
            let (Ok(p), Ok(d)) = (p.try_into(), d.try_into()) else {
                unreachable!("chunks_exact gives whole blocks")
            };
            self.lanes.score(self.saturation, self.k, p, d);
        }
        let (p, d) = (px.remainder(), o.into_remainder());
        if !d.is_empty() {
            let mut block = [0u8; 3 * LANES];
            let mut res = [0f32; LANES];
            block[..p.len()].copy_from_slice(p);
            self.lanes.score(self.saturation, self.k, &block, &mut res);
            d.copy_from_slice(&res[..d.len()]);
        }
    }
}

/// [`SkinModel::score_row`] as a [`Kernel`].
struct ScoreRow<'a> {
    model: &'a SkinModel,
    rgb: &'a [u8],
    out: &'a mut [f32],
}

impl Kernel for ScoreRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        self.model.score_row_inline(self.rgb, self.out);
    }
}

impl SkinLanes {
    /// Eq. 8 for [`LANES`] interleaved RGB pixels.
    #[inline(always)]
    fn score(&self, s_ref: f32, k: f32, rgb: &[u8; 3 * LANES], out: &mut [f32; LANES]) {
        // De-interleave first: the vectoriser gives up on stride-3 bytes.
        let (mut rr, mut gg, mut bb) = ([0u8; LANES], [0u8; LANES], [0u8; LANES]);
        for (i, p) in rgb.chunks_exact(3).enumerate() {
            rr[i] = p[0];
            gg[i] = p[1];
            bb[i] = p[2];
        }
        // Values, not indexed loads: selecting between them stays a blend.
        let ([h0, h1, h2], [l0, l1, l2]) = (self.c_hi, self.c_lo);
        let mut arg = [0f32; LANES];
        for i in 0..LANES {
            let (r, g, b) = (rr[i], gg[i], bb[i]);
            let max = r.max(g).max(b);
            let min = r.min(g).min(b);
            let d = i32::from(max - min);
            // The sector as in `bayestrack_image::Hsv::from_rgb`: red
            // first, then green (ties, gray pixels included, go to red).
            let (n, c_hi, c_lo) = if max == r {
                (i32::from(g) - i32::from(b), h0, l0)
            } else if max == g {
                (i32::from(b) - i32::from(r), h1, l1)
            } else {
                (i32::from(r) - i32::from(g), h2, l2)
            };
            // A gray pixel has n = d = 0: hue 0, saturation 0.
            let q = n as f32 / d.max(1) as f32;
            let mut dh6 = q + c_hi;
            // Into [-3, 3]: both corrections are exact (Sterbenz).
            if dh6 > 3.0 {
                dh6 -= 6.0;
            } else if dh6 < -3.0 {
                dh6 += 6.0;
            }
            dh6 += c_lo;
            let ds = d as f32 / i32::from(max).max(1) as f32 - s_ref;
            arg[i] = self.k36 * (dh6 * dh6) + k * (ds * ds);
        }
        for (o, &a) in out.iter_mut().zip(&arg) {
            *o = exp_nonpositive(a);
        }
    }
}

/// `e^x` for `x <= 0` (`x` is never NaN here), relative error below 2e-7;
/// `e^-87` (1.6e-38) for any `x < -87`. Cody and Waite's
/// reduction `x = n ln 2 + r`, `|r| <= ln 2 / 2`, Cephes' degree-6
/// polynomial for `e^r`, and `2^n` built in the exponent bits, all
/// branch-free so that a loop over it vectorises.
#[inline(always)]
fn exp_nonpositive(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    // 1.5 x 2^23: adding it rounds to an integer, kept in the low mantissa bits.
    const ROUND: f32 = 12_582_912.0;
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    let x = x.max(-87.0);
    let t = x * LOG2E + ROUND;
    let n = t - ROUND;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = ((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r
        + 1.666_666_5e-1)
        * r
        + 0.5;
    let e = p * (r * r) + r + 1.0;
    // n in [-126, 0]: the biased exponent n + 127 is in [1, 127].
    let bits = (t.to_bits() as i32 - ROUND.to_bits() as i32 + 127) as u32;
    let scale = f32::from_bits(bits << 23);
    e * scale
}

fn check_out<T: Copy>(src: &ImageView<'_, T>, out: &ImageViewMut<'_, f32>) -> Result<()> {
    if out.width() != src.width() || out.height() != src.height() || out.channels() != 1 {
        return Err(ImageError::SizeMismatch {
            operation: "skin map",
            a_width: src.width(),
            a_height: src.height(),
            a_channels: 1,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        }
        .into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn peaks_on_the_reference_hue() {
        let skin = Rgb::new(220, 160, 130);
        let ref_hsv = skin.to_hsv();
        let m = SkinModel::new(f64::from(ref_hsv.h), f64::from(ref_hsv.s), 0.05).unwrap();
        assert!((m.score_rgb(skin) - 1.0).abs() < 1e-6);
        // Sweep the hue round the circle at the reference saturation and value.
        let mut best = (0.0f32, -1.0f32);
        for k in 0..360 {
            let h = k as f32 / 360.0;
            let p = Hsv {
                h,
                s: ref_hsv.s,
                v: ref_hsv.v,
            }
            .to_rgb();
            let c = m.score_rgb(p);
            if c > best.1 {
                best = (h, c);
            }
        }
        assert!(hue_distance(best.0, ref_hsv.h).abs() <= 1.0 / 360.0 + 1e-4);
        // Hand value: hue off by sigma, same saturation -> exp(-1/2).
        let c = m.score_hsv(ref_hsv.h + 0.05, ref_hsv.s);
        assert!((c - (-0.5f32).exp()).abs() < 1e-5);
        // Blue is not skin.
        assert!(m.score_rgb(Rgb::new(20, 40, 200)) < 1e-6);
    }

    #[test]
    fn hue_wrap_around() {
        // Reference just below a full turn (a magenta-red).
        let m = SkinModel::new(0.98, 0.8, 0.05).unwrap();
        // 0.02 is 0.04 away across the wrap, 0.90 is 0.08 away: 0.02 scores higher.
        let across = m.score_hsv(0.02, 0.8);
        let same_side = m.score_hsv(0.90, 0.8);
        assert!((across - (-0.04f32 * 0.04 / (2.0 * 0.0025)).exp()).abs() < 1e-5);
        assert!(across > same_side);
        // A reference hue given as -0.02 is the same model.
        let m2 = SkinModel::new(-0.02, 0.8, 0.05).unwrap();
        assert!((m2.hue() - 0.98).abs() < 1e-6);
        // Learnt from a window whose hues straddle 0: the circular mean is ~0,
        // not ~0.5 (which an arithmetic mean of 0.99 and 0.01 would give).
        let mut img = Image::new(2, 1, 3, 0u8).unwrap();
        let a = Hsv {
            h: 0.99,
            s: 0.8,
            v: 0.9,
        }
        .to_rgb();
        let b = Hsv {
            h: 0.01,
            s: 0.8,
            v: 0.9,
        }
        .to_rgb();
        for (c, (va, vb)) in a.to_array().iter().zip(b.to_array()).enumerate() {
            img.set(0, 0, c, *va);
            img.set(1, 0, c, vb);
        }
        let learnt = SkinModel::from_window(img.view(), Rect::new(0, 0, 2, 1), 0.05).unwrap();
        assert!(
            hue_distance(learnt.hue() as f32, 0.0).abs() < 0.005,
            "{}",
            learnt.hue()
        );
        assert!((learnt.saturation() - 0.8).abs() < 0.01);
        // The map over the frame peaks at both pixels equally.
        let mut out = Image::new(2, 1, 1, 0f32).unwrap();
        learnt
            .map_rgb_into(img.view(), &mut out.view_mut())
            .unwrap();
        assert!((out.as_slice()[0] - out.as_slice()[1]).abs() < 0.02);
        assert!(out.as_slice()[0] > 0.9);
    }

    #[test]
    fn maps_agree_and_bad_inputs() {
        let m = SkinModel::new(0.05, 0.4, 0.05).unwrap();
        let mut img = Image::new(8, 4, 3, 0u8).unwrap();
        for (i, v) in img.as_mut_slice().iter_mut().enumerate() {
            *v = (i * 37 % 256) as u8;
        }
        let hsv = bayestrack_image::rgb_to_hsv(img.view()).unwrap();
        let mut a = Image::new(8, 4, 1, 0f32).unwrap();
        let mut b = Image::new(8, 4, 1, 0f32).unwrap();
        m.map_rgb_into(img.view(), &mut a.view_mut()).unwrap();
        m.map_hsv_into(hsv.view(), &mut b.view_mut()).unwrap();
        // The batch kernel and score_hsv are each within 1e-6 of eq. 8.
        for (x, y) in a.as_slice().iter().zip(b.as_slice()) {
            assert!((x - y).abs() <= 2e-6, "{x} {y}");
        }
        let mean = m.window_mean(img.view(), Rect::new(0, 0, 8, 4)).unwrap();
        let want: f64 = a.as_slice().iter().map(|&v| f64::from(v)).sum::<f64>() / 32.0;
        assert!((mean - want).abs() < 1e-6);
        assert!(SkinModel::new(0.1, 1.5, 0.05).is_err());
        assert!(SkinModel::new(0.1, 0.5, 0.0).is_err());
        assert!(SkinModel::new(f64::NAN, 0.5, 0.1).is_err());
        let gray = Image::new(4, 4, 1, 0u8).unwrap();
        assert!(m.window_mean(gray.view(), Rect::new(0, 0, 2, 2)).is_err());
        assert!(matches!(
            m.window_mean(img.view(), Rect::new(7, 0, 2, 2)),
            Err(AppearanceError::WindowOutside { .. })
        ));
        let gray3 = Image::new(4, 4, 3, 128u8).unwrap();
        assert!(SkinModel::from_window(gray3.view(), Rect::new(0, 0, 4, 4), 0.05).is_err());
        let mut wrong = Image::new(3, 3, 1, 0f32).unwrap();
        assert!(m.map_rgb_into(img.view(), &mut wrong.view_mut()).is_err());
    }
    /// Eq. 8 in `f64` from the exact hexcone hue and saturation of an 8-bit
    /// RGB colour, with the model's reference and spread.
    fn eq8(m: &SkinModel, r: u8, g: u8, b: u8) -> f64 {
        let (rf, gf, bf) = (f64::from(r), f64::from(g), f64::from(b));
        let max = rf.max(gf).max(bf);
        let d = max - rf.min(gf).min(bf);
        let s = if max > 0.0 { d / max } else { 0.0 };
        let h6 = if d == 0.0 {
            0.0
        } else if max == rf {
            (gf - bf) / d
        } else if max == gf {
            (bf - rf) / d + 2.0
        } else {
            (rf - gf) / d + 4.0
        };
        let mut dh = (h6 / 6.0 - m.hue()).rem_euclid(1.0);
        if dh > 0.5 {
            dh -= 1.0;
        }
        let ds = s - m.saturation();
        (-(dh * dh + ds * ds) / (2.0 * m.sigma() * m.sigma())).exp()
    }

    /// The largest `|C - eq8|` of the batch kernel (through the map, in
    /// rows of 256 blues) over the RGB colours with `r, g` on a grid of
    /// `step`, and of the scalar `score_rgb` on the same colours.
    fn max_errors(m: &SkinModel, step: usize) -> (f64, f64) {
        let mut row = Image::new(256, 1, 3, 0u8).unwrap();
        let mut out = Image::new(256, 1, 1, 0f32).unwrap();
        let (mut fast, mut scalar) = (0f64, 0f64);
        for r in (0..256).step_by(step) {
            for g in (0..256).step_by(step) {
                for (b, p) in row.as_mut_slice().chunks_exact_mut(3).enumerate() {
                    p.copy_from_slice(&[r as u8, g as u8, b as u8]);
                }
                m.map_rgb_into(row.view(), &mut out.view_mut()).unwrap();
                for (b, &c) in out.as_slice().iter().enumerate() {
                    let want = eq8(m, r as u8, g as u8, b as u8);
                    fast = fast.max((f64::from(c) - want).abs());
                    let sc = m.score_rgb(Rgb::new(r as u8, g as u8, b as u8));
                    scalar = scalar.max((f64::from(sc) - want).abs());
                }
            }
        }
        (fast, scalar)
    }

    #[test]
    fn batch_kernel_matches_eq8_to_1e6() {
        // The full cube (step 1) with SKIN_FULL_CUBE=1; CI checks every
        // third red and green level, all blues (1.4 M colours per model).
        let step = if std::env::var_os("SKIN_FULL_CUBE").is_some() {
            1
        } else {
            3
        };
        let skin = Rgb::new(220, 160, 130).to_hsv();
        for (h, s, sigma) in [
            (f64::from(skin.h), f64::from(skin.s), SkinModel::PAPER_SIGMA),
            (0.0, 0.5, SkinModel::PAPER_SIGMA),
            (0.98, 0.8, SkinModel::PAPER_SIGMA),
            (0.5, 0.2, SkinModel::PAPER_SIGMA),
            (0.7, 1.0, 0.2),
        ] {
            let m = SkinModel::new(h, s, sigma).unwrap();
            let (fast, scalar) = max_errors(&m, step);
            eprintln!("h {h:.4} s {s:.3} sigma {sigma}: batch {fast:.3e}, score_rgb {scalar:.3e}");
            assert!(
                fast <= 1e-6,
                "batch kernel off eq. 8 by {fast:e} ({h}, {s}, {sigma})"
            );
        }
    }

    #[test]
    fn window_mean_and_map_agree_on_odd_widths() {
        // Widths around the block size exercise the padded tail.
        let m = SkinModel::new(0.05, 0.4, 0.05).unwrap();
        let mut lcg = bayestrack_testkit::Lcg32(7);
        for w in [1, 5, 15, 16, 17, 33, 70] {
            let mut img = Image::new(w, 3, 3, 0u8).unwrap();
            for v in img.as_mut_slice() {
                *v = lcg.byte();
            }
            let mut out = Image::new(w, 3, 1, 0f32).unwrap();
            m.map_rgb_into(img.view(), &mut out.view_mut()).unwrap();
            let mut sum = 0f64;
            for y in 0..3 {
                for x in 0..w {
                    let p = img.pixel(x, y).unwrap();
                    let want = eq8(&m, p[0], p[1], p[2]);
                    let got = f64::from(out.get(x, y, 0).unwrap());
                    assert!(
                        (got - want).abs() <= 1e-6,
                        "{w} ({x}, {y}): {got} vs {want}"
                    );
                    sum += got;
                }
            }
            // window_mean is the scalar path: within 1e-6 of eq. 8 as well.
            let mean = m.window_mean(img.view(), Rect::new(0, 0, w, 3)).unwrap();
            assert!((mean - sum / (3 * w) as f64).abs() < 2e-6);
            let inner = m
                .window_mean(img.view(), Rect::new(w / 2, 1, w - w / 2, 2))
                .unwrap();
            let mut s2 = 0f64;
            for y in 1..3 {
                for x in w / 2..w {
                    s2 += f64::from(out.get(x, y, 0).unwrap());
                }
            }
            assert!((inner - s2 / (2 * (w - w / 2)) as f64).abs() < 2e-6);
        }
    }

    #[test]
    fn exp_nonpositive_is_accurate() {
        let mut worst = 0f64;
        let mut x = 0f32;
        while x > -90.0 {
            let got = f64::from(exp_nonpositive(x));
            let want = f64::from(x).exp();
            if x > -87.0 {
                worst = worst.max((got - want).abs() / want);
            } else {
                assert!(got < 2e-38);
            }
            x -= 0.001_3;
        }
        assert!(worst < 2e-7, "{worst:e}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
    }
}
