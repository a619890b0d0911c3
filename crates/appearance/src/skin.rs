//! HSV skin-colour cue (Lee, Jo and Kang (paper 003), eq. 8).
//!
//! `C(x, y) = exp(-((h - h_R)^2 + (s - s_R)^2) / (2 sigma_hs^2))`, with hue
//! in turns (`[0, 1)`) and saturation in `[0, 1]`. Hue is an angle, so
//! `h - h_R` is the shortest way round the circle: a reference hue of 0.99
//! and a pixel hue of 0.01 are 0.02 apart. The paper uses `sigma_hs = 0.05`.

use bayestrack_image::{Hsv, ImageError, ImageView, ImageViewMut, Rect, Rgb, hue_distance};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// A skin-colour reference (hue, saturation) with its spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinModel {
    hue: f32,
    saturation: f32,
    sigma: f32,
    /// `-1 / (2 sigma^2)`.
    k: f32,
}

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
        Ok(Self {
            hue: hue.rem_euclid(1.0) as f32,
            saturation: saturation as f32,
            sigma,
            k: -1.0 / (2.0 * sigma * sigma),
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
    /// same size. Allocation-free.
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
        for y in 0..rgb.height() {
            let row = rgb.row(y);
            for (d, p) in out.row_mut(y).iter_mut().zip(row.chunks_exact(3)) {
                *d = self.score_rgb(Rgb::new(p[0], p[1], p[2]));
            }
        }
        Ok(())
    }

    /// The skin map of a 3-channel HSV frame (as made by
    /// `bayestrack_image::rgb_to_hsv`). Allocation-free.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `hsv` has 3 channels;
    /// [`ImageError::SizeMismatch`] for a wrong `out`.
    pub fn map_hsv_into(
        &self,
        hsv: ImageView<'_, f32>,
        out: &mut ImageViewMut<'_, f32>,
    ) -> Result<()> {
        hsv.expect_channels("skin map", 3)?;
        check_out(&hsv, out)?;
        for y in 0..hsv.height() {
            let row = hsv.row(y);
            for (d, p) in out.row_mut(y).iter_mut().zip(row.chunks_exact(3)) {
                *d = self.score_hsv(p[0], p[1]);
            }
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
        let mut s = 0f64;
        for y in window.y..window.bottom() {
            for p in rgb.row(y)[window.x * 3..window.right() * 3].chunks_exact(3) {
                s += f64::from(self.score_rgb(Rgb::new(p[0], p[1], p[2])));
            }
        }
        Ok(s / window.area() as f64)
    }
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
        assert_eq!(a, b);
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
}
