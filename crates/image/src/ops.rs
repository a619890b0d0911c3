//! Frame differencing and thresholding.

use crate::{Image, ImageError, ImageView, ImageViewMut, Pixel, Result};

/// A binary mask: one `bool` channel.
pub type Mask = Image<bool>;

fn check_out<T: Copy, U: Copy>(
    operation: &'static str,
    a: &ImageView<'_, T>,
    out: &ImageViewMut<'_, U>,
    channels: usize,
) -> Result<()> {
    if out.width() != a.width() || out.height() != a.height() || out.channels() != channels {
        return Err(ImageError::SizeMismatch {
            operation,
            a_width: a.width(),
            a_height: a.height(),
            a_channels: channels,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        });
    }
    Ok(())
}

/// Element-wise `|a - b|` into `out` (same shape for all three). Allocation-free.
///
/// # Errors
/// [`ImageError::SizeMismatch`] if the shapes differ.
pub fn abs_diff_into<T: Pixel>(
    a: ImageView<'_, T>,
    b: ImageView<'_, T>,
    out: &mut ImageViewMut<'_, T>,
) -> Result<()> {
    a.expect_same_shape("abs_diff", &b)?;
    check_out("abs_diff", &a, out, a.channels())?;
    for y in 0..a.height() {
        for ((d, &p), &q) in out.row_mut(y).iter_mut().zip(a.row(y)).zip(b.row(y)) {
            *d = p.abs_diff(q);
        }
    }
    Ok(())
}

/// Element-wise `|a - b|` as a new image.
///
/// # Errors
/// [`ImageError::SizeMismatch`] if the shapes differ.
pub fn abs_diff<T: Pixel>(a: ImageView<'_, T>, b: ImageView<'_, T>) -> Result<Image<T>> {
    a.expect_same_shape("abs_diff", &b)?;
    let mut out = Image::new(a.width(), a.height(), a.channels(), T::default())?;
    abs_diff_into(a, b, &mut out.view_mut())?;
    Ok(out)
}

/// `out = value > threshold` for a 1-channel image. Allocation-free.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 1 channel;
/// [`ImageError::SizeMismatch`] unless `out` has the same size.
pub fn threshold_into<T: Pixel>(
    src: ImageView<'_, T>,
    threshold: T,
    out: &mut ImageViewMut<'_, bool>,
) -> Result<()> {
    src.expect_channels("threshold", 1)?;
    check_out("threshold", &src, out, 1)?;
    for y in 0..src.height() {
        for (d, &v) in out.row_mut(y).iter_mut().zip(src.row(y)) {
            *d = v > threshold;
        }
    }
    Ok(())
}

/// `value > threshold` for a 1-channel image, as a new mask.
///
/// # Errors
/// [`ImageError::Channels`] unless `src` has 1 channel.
pub fn threshold<T: Pixel>(src: ImageView<'_, T>, threshold: T) -> Result<Mask> {
    src.expect_channels("threshold", 1)?;
    let mut out = Image::new(src.width(), src.height(), 1, false)?;
    threshold_into(src, threshold, &mut out.view_mut())?;
    Ok(out)
}

/// Frame differencing in one step: `|a - b| > threshold`, summed over
/// channels for colour images (so a colour threshold is on the sum of
/// channel differences).
///
/// # Errors
/// [`ImageError::SizeMismatch`] if the shapes differ.
pub fn motion_mask<T: Pixel>(
    a: ImageView<'_, T>,
    b: ImageView<'_, T>,
    threshold: f32,
) -> Result<Mask> {
    a.expect_same_shape("motion_mask", &b)?;
    if !threshold.is_finite() {
        return Err(ImageError::NonFinite {
            what: "motion threshold",
        });
    }
    let ch = a.channels();
    let mut out = Image::new(a.width(), a.height(), 1, false)?;
    for y in 0..a.height() {
        let (ra, rb) = (a.row(y), b.row(y));
        for (x, d) in out.row_mut(y).iter_mut().enumerate() {
            let s: f32 = (0..ch)
                .map(|c| ra[x * ch + c].abs_diff(rb[x * ch + c]).to_f32())
                .sum();
            *d = s > threshold;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_and_threshold() {
        let a = Image::from_vec(3, 1, 1, vec![10u8, 200, 50]).unwrap();
        let b = Image::from_vec(3, 1, 1, vec![20u8, 100, 50]).unwrap();
        let d = abs_diff(a.view(), b.view()).unwrap();
        assert_eq!(d.as_slice(), &[10, 100, 0]);
        let m = threshold(d.view(), 10).unwrap();
        assert_eq!(m.as_slice(), &[false, true, false]);
        let mm = motion_mask(a.view(), b.view(), 9.5).unwrap();
        assert_eq!(mm.as_slice(), &[true, true, false]);
        let c = Image::new(2, 1, 1, 0u8).unwrap();
        assert!(matches!(
            abs_diff(a.view(), c.view()),
            Err(ImageError::SizeMismatch { .. })
        ));
        let f = a.to_unit_f32();
        let g = b.to_unit_f32();
        let df = abs_diff(f.view(), g.view()).unwrap();
        assert!((df.as_slice()[1] - 100.0 / 255.0).abs() < 1e-6);
    }
}
