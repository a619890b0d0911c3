//! MAD template matching (paper 004, eq. 1 and eq. 7).
//!
//! `MAD(i, j) = 1/(M N) sum_m sum_n |T(m, n) - F(m + i, n + j)|`, the mean
//! absolute difference between the template `T` and the frame window whose
//! top-left corner is `(i, j)` (averaged over channels too). The
//! observation likelihood is `p(z | x) = exp(-MAD / (2 sigma^2))` (eq. 7),
//! evaluated here in the log domain.

use bayestrack_image::{ImageError, ImageView, ImageViewMut, Pixel, Rect};

use crate::error::{check_window, positive};
use crate::{AppearanceError, Result};

/// Scalars MAD can be computed on, with a fast row kernel.
pub trait MadPixel: Pixel {
    /// `sum |a_k - b_k|` over two rows of equal length.
    fn sad_row(a: &[Self], b: &[Self]) -> f64;
}

impl MadPixel for u8 {
    #[inline]
    fn sad_row(a: &[u8], b: &[u8]) -> f64 {
        f64::from(sad_u8(a, b))
    }
}

impl MadPixel for f32 {
    #[inline]
    fn sad_row(a: &[f32], b: &[f32]) -> f64 {
        let mut acc = [0f32; 8];
        let mut ca = a.chunks_exact(8);
        let mut cb = b.chunks_exact(8);
        for (x, y) in (&mut ca).zip(&mut cb) {
            for k in 0..8 {
                acc[k] += (x[k] - y[k]).abs();
            }
        }
        let tail: f32 = ca
            .remainder()
            .iter()
            .zip(cb.remainder())
            .map(|(x, y)| (x - y).abs())
            .sum();
        f64::from(acc.iter().sum::<f32>() + tail)
    }
}

/// Sum of absolute differences of two byte rows; written so that the
/// compiler vectorises it (16-byte blocks into 16-bit lanes).
#[inline]
fn sad_u8(a: &[u8], b: &[u8]) -> u32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut total = 0u32;
    let mut ca = a.chunks_exact(16);
    let mut cb = b.chunks_exact(16);
    let mut lanes = [0u16; 16];
    let mut blocks = 0u32;
    for (x, y) in (&mut ca).zip(&mut cb) {
        for k in 0..16 {
            lanes[k] += u16::from(x[k].abs_diff(y[k]));
        }
        blocks += 1;
        // 255 * 257 < 2^16: flush before a lane can overflow.
        if blocks == 257 {
            total += lanes.iter().map(|&v| u32::from(v)).sum::<u32>();
            lanes = [0; 16];
            blocks = 0;
        }
    }
    total += lanes.iter().map(|&v| u32::from(v)).sum::<u32>();
    total
        + ca.remainder()
            .iter()
            .zip(cb.remainder())
            .map(|(x, y)| u32::from(x.abs_diff(*y)))
            .sum::<u32>()
}

fn check_template<T: Pixel>(frame: &ImageView<'_, T>, template: &ImageView<'_, T>) -> Result<()> {
    if frame.channels() != template.channels() {
        return Err(ImageError::Channels {
            operation: "mad",
            expected: frame.channels(),
            got: template.channels(),
        }
        .into());
    }
    Ok(())
}

/// MAD between `template` and the frame window with top-left `(x, y)` (eq. 1).
///
/// # Errors
/// [`AppearanceError::WindowOutside`] if the window leaves the frame;
/// [`ImageError::Channels`] if the channel counts differ.
pub fn mad<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    x: usize,
    y: usize,
) -> Result<f64> {
    check_template(&frame, &template)?;
    let window = Rect::new(x, y, template.width(), template.height());
    check_window("mad", window, frame.width(), frame.height())?;
    Ok(mad_unchecked(&frame, &template, x, y))
}

#[inline]
fn mad_unchecked<T: MadPixel>(
    frame: &ImageView<'_, T>,
    template: &ImageView<'_, T>,
    x: usize,
    y: usize,
) -> f64 {
    let ch = template.channels();
    let n = template.width() * ch;
    let mut sum = 0.0;
    for r in 0..template.height() {
        let fr = &frame.row(y + r)[x * ch..x * ch + n];
        sum += T::sad_row(template.row(r), fr);
    }
    sum / (n * template.height()) as f64
}

/// The best match of an exhaustive search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MadMatch {
    /// Left column of the best window in the frame (0-based).
    pub x: usize,
    /// Top row of the best window in the frame (0-based).
    pub y: usize,
    /// Its MAD (eq. 1).
    pub mad: f64,
}

impl MadMatch {
    /// The matched window.
    pub fn window(&self, template_width: usize, template_height: usize) -> Rect {
        Rect::new(self.x, self.y, template_width, template_height)
    }
}

fn check_region<T: Pixel>(
    frame: &ImageView<'_, T>,
    template: &ImageView<'_, T>,
    region: Rect,
) -> Result<()> {
    check_template(frame, template)?;
    check_window("mad_search", region, frame.width(), frame.height())?;
    if template.width() > region.width || template.height() > region.height {
        return Err(AppearanceError::TemplateLargerThanRegion {
            template_width: template.width(),
            template_height: template.height(),
            region,
        });
    }
    Ok(())
}

/// Exhaustive MAD search: the window inside `region` (template fully
/// inside) with the smallest MAD; ties go to the first in raster order.
///
/// Exact, with early termination: a candidate is abandoned as soon as its
/// partial sum exceeds the best full sum so far (successive elimination),
/// which does not change the result.
///
/// # Errors
/// [`AppearanceError::WindowOutside`] if `region` leaves the frame;
/// [`AppearanceError::TemplateLargerThanRegion`]; [`ImageError::Channels`].
pub fn mad_search<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    region: Rect,
) -> Result<MadMatch> {
    check_region(&frame, &template, region)?;
    let (tw, th, ch) = (template.width(), template.height(), template.channels());
    let n = tw * ch;
    let mut best = MadMatch {
        x: region.x,
        y: region.y,
        mad: f64::INFINITY,
    };
    let mut best_sum = f64::INFINITY;
    for y in region.y..=region.bottom() - th {
        for x in region.x..=region.right() - tw {
            let mut sum = 0.0;
            let mut abandoned = false;
            for r in 0..th {
                let fr = &frame.row(y + r)[x * ch..x * ch + n];
                sum += T::sad_row(template.row(r), fr);
                if sum >= best_sum {
                    abandoned = true;
                    break;
                }
            }
            if !abandoned {
                best_sum = sum;
                best = MadMatch { x, y, mad: 0.0 };
            }
        }
    }
    best.mad = best_sum / (n * th) as f64;
    Ok(best)
}

/// The full MAD surface over `region`: `out(i, j) = MAD(region.x + i,
/// region.y + j)`. `out` must be 1-channel, `(region.width - tw + 1) x
/// (region.height - th + 1)`. Allocation-free.
///
/// # Errors
/// As [`mad_search`], plus [`ImageError::SizeMismatch`] for a wrong `out`.
pub fn mad_map_into<T: MadPixel>(
    frame: ImageView<'_, T>,
    template: ImageView<'_, T>,
    region: Rect,
    out: &mut ImageViewMut<'_, f32>,
) -> Result<()> {
    check_region(&frame, &template, region)?;
    let (tw, th) = (template.width(), template.height());
    let (ow, oh) = (region.width - tw + 1, region.height - th + 1);
    if out.width() != ow || out.height() != oh || out.channels() != 1 {
        return Err(ImageError::SizeMismatch {
            operation: "mad_map_into",
            a_width: ow,
            a_height: oh,
            a_channels: 1,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        }
        .into());
    }
    for j in 0..oh {
        let row = out.row_mut(j);
        for (i, v) in row.iter_mut().enumerate() {
            *v = mad_unchecked(&frame, &template, region.x + i, region.y + j) as f32;
        }
    }
    Ok(())
}

/// The MAD likelihood of eq. 7, `p = exp(-MAD / (2 sigma^2))`, kept in logs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MadLikelihood {
    sigma: f64,
}

impl MadLikelihood {
    /// With spread `sigma` (in the MAD's own units, e.g. gray levels).
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] unless `sigma` is finite and > 0.
    pub fn new(sigma: f64) -> Result<Self> {
        Ok(Self {
            sigma: positive("sigma", sigma)?,
        })
    }

    /// The spread sigma.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// `ln p = -MAD / (2 sigma^2)`.
    ///
    /// # Errors
    /// [`AppearanceError::NonFinite`] for a NaN or infinite MAD.
    pub fn log_likelihood(&self, mad: f64) -> Result<f64> {
        if !mad.is_finite() {
            return Err(AppearanceError::NonFinite { what: "MAD" });
        }
        Ok(-mad / (2.0 * self.sigma * self.sigma))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn hand_computed_mad() {
        // Frame 4x3, template 2x2.
        let f = Image::from_vec(4, 3, 1, vec![1u8, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]).unwrap();
        let t = Image::from_vec(2, 2, 1, vec![2u8, 2, 6, 9]).unwrap();
        // Window (1, 1): [6 7; 10 11]; |2-6|+|2-7|+|6-10|+|9-11| = 4+5+4+2 = 15.
        assert_eq!(mad(f.view(), t.view(), 1, 1).unwrap(), 15.0 / 4.0);
        // Window (0, 0): [1 2; 5 6]: 1+0+1+3 = 5.
        assert_eq!(mad(f.view(), t.view(), 0, 0).unwrap(), 5.0 / 4.0);
        let ff = f.map(f32::from);
        let tf = t.map(f32::from);
        assert_eq!(mad(ff.view(), tf.view(), 1, 1).unwrap(), 15.0 / 4.0);
        // Window (1, 0): [2 3; 6 7]: 0+1+0+2 = 3, the minimum of the six sums
        // (5, 3, 5 on the top row of positions; 11, 15, 19 below).
        let m = mad_search(f.view(), t.view(), Rect::new(0, 0, 4, 3)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (1, 0, 0.75));
        let mut out = Image::new(3, 2, 1, 0f32).unwrap();
        mad_map_into(
            f.view(),
            t.view(),
            Rect::new(0, 0, 4, 3),
            &mut out.view_mut(),
        )
        .unwrap();
        assert_eq!(out.get(1, 1, 0), Some(3.75));
        assert_eq!(out.get(0, 0, 0), Some(1.25));
        assert_eq!(out.get(1, 0, 0), Some(0.75));
    }

    #[test]
    fn sad_kernel_matches_naive_on_long_rows() {
        let a: Vec<u8> = (0..5000u32).map(|i| (i * 37 % 256) as u8).collect();
        let b: Vec<u8> = (0..5000u32).map(|i| (i * 91 % 256) as u8).collect();
        let naive: u32 = a
            .iter()
            .zip(&b)
            .map(|(x, y)| u32::from(x.abs_diff(*y)))
            .sum();
        assert_eq!(sad_u8(&a, &b), naive);
        assert_eq!(sad_u8(&[255; 9000], &[0; 9000]), 255 * 9000);
    }

    fn textured(w: usize, h: usize, seed: u32) -> Image<u8> {
        let mut s = seed;
        Image::from_fn(w, h, |_, _| {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 24) as u8
        })
        .unwrap()
    }

    #[test]
    fn search_finds_a_pasted_template() {
        let mut frame = textured(120, 90, 1);
        let tpl = textured(30, 20, 2);
        let (px, py) = (71, 43);
        for y in 0..20 {
            for x in 0..30 {
                frame.set(px + x, py + y, 0, tpl.get(x, y, 0).unwrap());
            }
        }
        let m = mad_search(frame.view(), tpl.view(), Rect::new(0, 0, 120, 90)).unwrap();
        assert_eq!((m.x, m.y, m.mad), (px, py, 0.0));
        // Restricted region that still contains it, and one that does not.
        let m = mad_search(frame.view(), tpl.view(), Rect::new(60, 40, 50, 30)).unwrap();
        assert_eq!((m.x, m.y), (px, py));
        let m = mad_search(frame.view(), tpl.view(), Rect::new(0, 0, 60, 60)).unwrap();
        assert!(m.mad > 50.0);
        // Brute force agrees with early termination.
        let region = Rect::new(5, 7, 70, 50);
        let mut best = (f64::INFINITY, 0, 0);
        for y in region.y..=region.bottom() - 20 {
            for x in region.x..=region.right() - 30 {
                let v = mad(frame.view(), tpl.view(), x, y).unwrap();
                if v < best.0 {
                    best = (v, x, y);
                }
            }
        }
        let m = mad_search(frame.view(), tpl.view(), region).unwrap();
        assert_eq!((m.mad, m.x, m.y), best);
    }

    #[test]
    fn bad_inputs() {
        let f = textured(40, 30, 3);
        let t = textured(10, 10, 4);
        assert!(matches!(
            mad(f.view(), t.view(), 35, 0),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert!(matches!(
            mad_search(f.view(), t.view(), Rect::new(0, 0, 9, 30)),
            Err(AppearanceError::TemplateLargerThanRegion { .. })
        ));
        assert!(matches!(
            mad_search(f.view(), t.view(), Rect::new(20, 0, 30, 30)),
            Err(AppearanceError::WindowOutside { .. })
        ));
        let big = textured(50, 10, 5);
        assert!(matches!(
            mad_search(f.view(), big.view(), Rect::new(0, 0, 40, 30)),
            Err(AppearanceError::TemplateLargerThanRegion { .. })
        ));
        let rgb = Image::new(10, 10, 3, 0u8).unwrap();
        assert!(matches!(
            mad(f.view(), rgb.view(), 0, 0),
            Err(AppearanceError::Image(ImageError::Channels { .. }))
        ));
        let mut wrong = Image::new(3, 3, 1, 0f32).unwrap();
        assert!(
            mad_map_into(
                f.view(),
                t.view(),
                Rect::new(0, 0, 40, 30),
                &mut wrong.view_mut()
            )
            .is_err()
        );
    }

    #[test]
    fn likelihood_in_log_domain() {
        let l = MadLikelihood::new(2.0).unwrap();
        assert_eq!(l.log_likelihood(4.0).unwrap(), -0.5);
        // A MAD that would underflow exp() is still ordered correctly.
        let a = l.log_likelihood(1e4).unwrap();
        let b = l.log_likelihood(2e4).unwrap();
        assert!(a > b && (a.exp() == 0.0));
        assert!(MadLikelihood::new(0.0).is_err());
        assert!(MadLikelihood::new(f64::NAN).is_err());
        assert!(l.log_likelihood(f64::NAN).is_err());
    }
}
