//! Centroid by image moments (Dong and Chen (paper 004), eq. 14-15).
//!
//! `x = m10 / m00 = sum_i sum_j i f(i, j) / sum_i sum_j f(i, j)`,
//! `y = m01 / m00`, with `f` the gray value (or any non-negative weight map,
//! such as a foreground mask, an IFD map or a skin map).

use bayestrack_image::{ImageView, Pixel, Rect};

use crate::error::check_window;
use crate::{AppearanceError, Result};

/// Raw moments of order 0 and 1.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Moments {
    /// `m00 = sum f`.
    pub m00: f64,
    /// `m10 = sum x f`.
    pub m10: f64,
    /// `m01 = sum y f`.
    pub m01: f64,
}

impl Moments {
    /// `(m10 / m00, m01 / m00)`, or `None` when the mass is zero.
    pub fn centroid(&self) -> Option<(f64, f64)> {
        (self.m00 > 0.0).then(|| (self.m10 / self.m00, self.m01 / self.m00))
    }
}

/// Moments of a 1-channel view, coordinates relative to its top-left pixel.
///
/// # Errors
/// [`bayestrack_image::ImageError::Channels`] unless 1 channel;
/// [`AppearanceError::InvalidParameter`] for a negative or non-finite value.
pub fn moments<T: Pixel>(view: ImageView<'_, T>) -> Result<Moments> {
    view.expect_channels("moments", 1)?;
    let mut m = Moments::default();
    for y in 0..view.height() {
        let mut row_sum = 0f64;
        let mut row_x = 0f64;
        for (x, &v) in view.row(y).iter().enumerate() {
            let f = f64::from(v.to_f32());
            if !(f >= 0.0 && f.is_finite()) {
                return Err(AppearanceError::InvalidParameter {
                    name: "pixel value",
                    value: f.to_string(),
                    reason: "moments need finite, non-negative values",
                });
            }
            row_sum += f;
            row_x += x as f64 * f;
        }
        m.m00 += row_sum;
        m.m10 += row_x;
        m.m01 += y as f64 * row_sum;
    }
    Ok(m)
}

/// Centroid of `window` in frame coordinates (eq. 14-15), or `None` when the
/// window has zero mass.
///
/// # Errors
/// [`AppearanceError::WindowOutside`]; those of [`moments`].
pub fn centroid_in<T: Pixel>(frame: ImageView<'_, T>, window: Rect) -> Result<Option<(f64, f64)>> {
    check_window("centroid", window, frame.width(), frame.height())?;
    let m = moments(frame.crop(window)?)?;
    Ok(m.centroid()
        .map(|(x, y)| (x + window.x as f64, y + window.y as f64)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn hand_computed_centroid() {
        // f = [[0, 1], [2, 3]]: m00 = 6, m10 = 1 + 3 = 4, m01 = 2 + 3 = 5.
        let img = Image::from_vec(2, 2, 1, vec![0u8, 1, 2, 3]).unwrap();
        let m = moments(img.view()).unwrap();
        assert_eq!((m.m00, m.m10, m.m01), (6.0, 4.0, 5.0));
        assert_eq!(m.centroid(), Some((4.0 / 6.0, 5.0 / 6.0)));
        let mut big = Image::new(10, 8, 1, 0u8).unwrap();
        big.set(3, 5, 0, 10);
        big.set(5, 5, 0, 30);
        assert_eq!(
            centroid_in(big.view(), Rect::new(2, 4, 5, 3)).unwrap(),
            Some((4.5, 5.0))
        );
        assert_eq!(
            centroid_in(big.view(), Rect::new(0, 0, 2, 2)).unwrap(),
            None
        );
        assert!(matches!(
            centroid_in(big.view(), Rect::new(8, 0, 3, 2)),
            Err(AppearanceError::WindowOutside { .. })
        ));
        let neg = Image::from_vec(2, 1, 1, vec![1.0f32, -1.0]).unwrap();
        assert!(moments(neg.view()).is_err());
        let rgb = Image::new(2, 2, 3, 0u8).unwrap();
        assert!(moments(rgb.view()).is_err());
    }
}
