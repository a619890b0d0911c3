//! Interframe difference (Lee, Jo and Kang (paper 003), eq. 7) and the priority-subtracted IFD
//! potential field for several objects (Lee, Jo and Kang (paper 003), eq. 15).
//!
//! `dP_t(x, y) = |I_t(x, y) - I_{t-D}(x, y)|` with intensities in `[0, 1]`.
//!
//! Eq. 15 is garbled in the paper's text (`V^0 = dP`, `V^k = dP . V^{k-1}`);
//! the prose describes subtracting, in priority order, what each tracked
//! object has already claimed from the IFD buffer, "like subtractive
//! clustering". We implement `V^0 = dP`, `V^k = V^{k-1} (1 - K_{k-1})`,
//! where `K_{k-1}` in `[0, 1]` is a suppression kernel centred on object
//! `k-1`'s estimate (a hard window, or a Gaussian bump as in subtractive
//! clustering). Object `k` is weighted against `V^k`, so two objects that
//! cross do not both lock onto the same motion blob.

use bayestrack_image::simd::{Kernel, Token, dispatch};
use bayestrack_image::{Image, ImageError, ImageView, ImageViewMut, LUMA_WEIGHTS, Pixel, Rect};

use crate::{AppearanceError, Result};

/// Eq. 7 into a caller buffer: 1-channel `f32` in `[0, 1]`. Colour inputs
/// (3 channels) are compared on BT.601 luma. Allocation-free.
///
/// # Errors
/// [`ImageError::SizeMismatch`] if the frames or `out` differ in size;
/// [`ImageError::Channels`] for inputs that are not 1- or 3-channel;
/// [`AppearanceError::NonFinite`] when a float frame holds NaN or infinite
/// pixels (the difference is then not a number; `out` holds it).
pub fn interframe_difference_into<T: Pixel>(
    current: ImageView<'_, T>,
    previous: ImageView<'_, T>,
    out: &mut ImageViewMut<'_, f32>,
) -> Result<()> {
    current.expect_same_shape("interframe_difference", &previous)?;
    if out.width() != current.width() || out.height() != current.height() || out.channels() != 1 {
        return Err(ImageError::SizeMismatch {
            operation: "interframe_difference",
            a_width: current.width(),
            a_height: current.height(),
            a_channels: 1,
            b_width: out.width(),
            b_height: out.height(),
            b_channels: out.channels(),
        }
        .into());
    }
    let scale = 1.0 / T::FULL_SCALE;
    match current.channels() {
        1 => {
            for y in 0..current.height() {
                let (a, b) = (current.row(y), previous.row(y));
                let d = out.row_mut(y);
                dispatch(AbsDiffRow {
                    a,
                    b,
                    out: d,
                    scale,
                });
            }
        }
        3 => {
            let w = LUMA_WEIGHTS.map(|w| w * scale);
            for y in 0..current.height() {
                let (a, b) = (current.row(y), previous.row(y));
                dispatch(LumaDifferenceRow {
                    w,
                    a,
                    b,
                    out: out.row_mut(y),
                });
            }
        }
        got => {
            return Err(ImageError::Channels {
                operation: "interframe_difference",
                expected: 1,
                got,
            }
            .into());
        }
    }
    // only a scalar that holds NaN (a float) can give a non-finite
    // difference; for integer pixels this folds away
    if T::from_f32(f32::NAN).to_f32().is_nan() {
        let finite = (0..out.height()).all(|y| {
            out.row_mut(y)
                .iter()
                .fold(true, |ok, &v| ok & (v.abs() <= f32::MAX))
        });
        if !finite {
            return Err(AppearanceError::NonFinite {
                what: "interframe difference (NaN or infinite pixels in a frame)",
            });
        }
    }
    Ok(())
}

/// Refuses an IFD map with a NaN or infinite value (it weights particles).
fn check_finite_field(ifd: &ImageView<'_, f32>) -> Result<()> {
    for y in 0..ifd.height() {
        if !ifd.row(y).iter().all(|v| v.is_finite()) {
            return Err(AppearanceError::NonFinite {
                what: "IFD map of PriorityIfd",
            });
        }
    }
    Ok(())
}

/// `|a - b| scale` of two gray rows into `out`.
struct AbsDiffRow<'a, T> {
    a: &'a [T],
    b: &'a [T],
    out: &'a mut [f32],
    scale: f32,
}

impl<T: Pixel> Kernel for AbsDiffRow<'_, T> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        for ((d, &p), &q) in self.out.iter_mut().zip(self.a).zip(self.b) {
            *d = p.abs_diff(q).to_f32() * self.scale;
        }
    }
}

/// `|luma(a) - luma(b)|` of two interleaved RGB rows into `out`, with the
/// luma weights `w` (scaled to `[0, 1]`).
struct LumaDifferenceRow<'a, T> {
    w: [f32; 3],
    a: &'a [T],
    b: &'a [T],
    out: &'a mut [f32],
}

impl<T: Pixel> Kernel for LumaDifferenceRow<'_, T> {
    type Output = ();
    #[inline(always)]
    fn run<K: Token>(self, _: K) {
        let Self { w, a, b, out } = self;
        // Blocks of LUMA_BLOCK pixels, de-interleaved into
        // channel arrays so that the compiler vectorises across
        // pixels; the same operations in the same order per pixel
        // as the one-pixel tail, so every path gives the same bits.
        let mut pa = a.chunks_exact(3 * LUMA_BLOCK);
        let mut pb = b.chunks_exact(3 * LUMA_BLOCK);
        let mut po = out.chunks_exact_mut(LUMA_BLOCK);
        for ((p, q), d) in (&mut pa).zip(&mut pb).zip(&mut po) {
            let la = luma_block(w, p);
            let lb = luma_block(w, q);
            for ((d, x), y) in d.iter_mut().zip(la).zip(lb) {
                *d = (x - y).abs();
            }
        }
        let tail = pa
            .remainder()
            .chunks_exact(3)
            .zip(pb.remainder().chunks_exact(3));
        for (d, (p, q)) in po.into_remainder().iter_mut().zip(tail) {
            *d = (luma(w, p) - luma(w, q)).abs();
        }
    }
}

/// Pixels per block of the colour path of [`interframe_difference_into`].
const LUMA_BLOCK: usize = 16;

/// `w . p` for one pixel, in the order `(w0 p0 + w1 p1) + w2 p2`.
#[inline(always)]
fn luma<T: Pixel>(w: [f32; 3], p: &[T]) -> f32 {
    w[0] * p[0].to_f32() + w[1] * p[1].to_f32() + w[2] * p[2].to_f32()
}

/// [`luma`] of [`LUMA_BLOCK`] interleaved pixels.
#[inline(always)]
fn luma_block<T: Pixel>(w: [f32; 3], px: &[T]) -> [f32; LUMA_BLOCK] {
    let mut ch = [[0f32; LUMA_BLOCK]; 3];
    for (i, p) in px.chunks_exact(3).take(LUMA_BLOCK).enumerate() {
        for c in 0..3 {
            ch[c][i] = p[c].to_f32();
        }
    }
    let mut l = [0f32; LUMA_BLOCK];
    for i in 0..LUMA_BLOCK {
        l[i] = w[0] * ch[0][i] + w[1] * ch[1][i] + w[2] * ch[2][i];
    }
    l
}

/// Eq. 7 as a new image.
///
/// # Errors
/// As [`interframe_difference_into`].
pub fn interframe_difference<T: Pixel>(
    current: ImageView<'_, T>,
    previous: ImageView<'_, T>,
) -> Result<Image<f32>> {
    let mut out = Image::new(current.width(), current.height(), 1, 0f32)?;
    interframe_difference_into(current, previous, &mut out.view_mut())?;
    Ok(out)
}

/// What an object claims from the IFD field.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Suppression {
    /// Zero the field inside this window (clipped to the frame).
    Window(Rect),
    /// Multiply by `1 - exp(-d^2 / (2 sigma^2))` around `(cx, cy)`
    /// (pixel coordinates), evaluated within 4 sigma.
    Gaussian {
        /// Centre x.
        cx: f64,
        /// Centre y.
        cy: f64,
        /// Radius sigma (pixels).
        sigma: f64,
    },
}

/// The priority-subtracted IFD potential field of eq. 15, kept in one
/// reusable buffer.
#[derive(Clone, Debug)]
pub struct PriorityIfd {
    field: Image<f32>,
    level: usize,
}

impl PriorityIfd {
    /// `V^0 = dP` (a copy of the 1-channel IFD map).
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `ifd` has 1 channel;
    /// [`AppearanceError::NonFinite`] for a NaN or infinite value.
    pub fn new(ifd: ImageView<'_, f32>) -> Result<Self> {
        ifd.expect_channels("PriorityIfd", 1)?;
        check_finite_field(&ifd)?;
        Ok(Self {
            field: ifd.to_image(),
            level: 0,
        })
    }

    /// Restarts from a new IFD map, reusing the buffer when the size is unchanged.
    ///
    /// # Errors
    /// [`ImageError::Channels`] unless `ifd` has 1 channel;
    /// [`AppearanceError::NonFinite`] for a NaN or infinite value (the
    /// field is then unchanged).
    pub fn reset(&mut self, ifd: ImageView<'_, f32>) -> Result<()> {
        ifd.expect_channels("PriorityIfd", 1)?;
        check_finite_field(&ifd)?;
        self.field.reshape(ifd.width(), ifd.height(), 1, 0.0)?;
        for y in 0..ifd.height() {
            self.field.row_mut(y).copy_from_slice(ifd.row(y));
        }
        self.level = 0;
        Ok(())
    }

    /// The current field `V^k`, to weight the particles of object `k`.
    pub fn field(&self) -> ImageView<'_, f32> {
        self.field.view()
    }

    /// `k`: how many objects have been subtracted.
    pub fn level(&self) -> usize {
        self.level
    }

    /// `V^{k+1} = V^k (1 - K)`: removes what the object with priority `k`
    /// claimed.
    ///
    /// # Errors
    /// [`AppearanceError::NonFinite`] / [`AppearanceError::InvalidParameter`]
    /// for a bad Gaussian.
    pub fn subtract(&mut self, claim: Suppression) -> Result<()> {
        let (w, h) = (self.field.width(), self.field.height());
        match claim {
            Suppression::Window(r) => {
                let x1 = r.right().min(w);
                let y1 = r.bottom().min(h);
                for y in r.y.min(h)..y1 {
                    let row = self.field.row_mut(y);
                    if r.x < x1 {
                        row[r.x..x1].fill(0.0);
                    }
                }
            }
            Suppression::Gaussian { cx, cy, sigma } => {
                if !cx.is_finite() || !cy.is_finite() {
                    return Err(AppearanceError::NonFinite {
                        what: "suppression centre",
                    });
                }
                let sigma = crate::error::spread("sigma", sigma)?;
                let reach = 4.0 * sigma;
                let lo = |c: f64| (c - reach).floor().max(0.0) as usize;
                let hi =
                    |c: f64, n: usize| ((c + reach).ceil().max(-1.0) + 1.0).min(n as f64) as usize;
                let k = -1.0 / (2.0 * sigma * sigma);
                for y in lo(cy)..hi(cy, h) {
                    let dy = y as f64 - cy;
                    let row = self.field.row_mut(y);
                    for (x, v) in row.iter_mut().enumerate().take(hi(cx, w)).skip(lo(cx)) {
                        let dx = x as f64 - cx;
                        *v *= (1.0 - (k * (dx * dx + dy * dy)).exp()) as f32;
                    }
                }
            }
        }
        self.level += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_ifd() {
        let a = Image::from_vec(3, 1, 1, vec![0u8, 255, 100]).unwrap();
        let b = Image::from_vec(3, 1, 1, vec![255u8, 255, 151]).unwrap();
        let d = interframe_difference(a.view(), b.view()).unwrap();
        assert_eq!(d.as_slice()[0], 1.0);
        assert_eq!(d.as_slice()[1], 0.0);
        assert!((d.as_slice()[2] - 0.2).abs() < 1e-6);
        // Colour frames compare luma: pure red vs black = 0.299.
        let c = Image::from_vec(1, 1, 3, vec![255u8, 0, 0]).unwrap();
        let k = Image::from_vec(1, 1, 3, vec![0u8, 0, 0]).unwrap();
        let d = interframe_difference(c.view(), k.view()).unwrap();
        assert!((d.as_slice()[0] - 0.299).abs() < 1e-6);
        // f32 frames are already in [0, 1].
        let f = interframe_difference(a.to_unit_f32().view(), b.to_unit_f32().view()).unwrap();
        assert!((f.as_slice()[2] - 0.2).abs() < 1e-6);
        let small = Image::new(2, 1, 1, 0u8).unwrap();
        assert!(interframe_difference(a.view(), small.view()).is_err());
        let two = Image::new(3, 1, 2, 0u8).unwrap();
        assert!(interframe_difference(two.view(), two.view()).is_err());
    }

    #[test]
    fn priority_subtraction_separates_two_objects() {
        // Two motion blobs, the left one stronger.
        let ifd = Image::from_fn(40, 10, |x, _| match x {
            5..=9 => 1.0,
            25..=29 => 0.6,
            _ => 0.0,
        })
        .unwrap();
        let argmax = |v: ImageView<'_, f32>| {
            let row = v.row(5);
            (0..row.len()).fold(0, |b, i| if row[i] > row[b] { i } else { b })
        };
        let mut p = PriorityIfd::new(ifd.view()).unwrap();
        assert_eq!(argmax(p.field()), 5);
        // Object 0 claims the left blob: object 1 now sees the right one.
        p.subtract(Suppression::Window(Rect::new(4, 0, 7, 10)))
            .unwrap();
        assert_eq!(p.level(), 1);
        assert_eq!(argmax(p.field()), 25);
        assert_eq!(p.field().get(7, 3, 0), Some(0.0));
        assert_eq!(p.field().get(27, 3, 0), Some(0.6));
        // A Gaussian claim on the right blob: 1 - exp(0) = 0 at the centre,
        // 1 - exp(-1/2) one sigma away.
        p.subtract(Suppression::Gaussian {
            cx: 27.0,
            cy: 5.0,
            sigma: 2.0,
        })
        .unwrap();
        assert_eq!(p.field().get(27, 5, 0), Some(0.0));
        let one_sigma = p.field().get(29, 5, 0).unwrap();
        assert!((one_sigma - 0.6 * (1.0 - (-0.5f32).exp())).abs() < 1e-6);
        // Claims partly or fully outside the frame are clipped.
        p.subtract(Suppression::Window(Rect::new(38, 8, 10, 10)))
            .unwrap();
        p.subtract(Suppression::Window(Rect::new(100, 100, 1, 1)))
            .unwrap();
        p.subtract(Suppression::Gaussian {
            cx: -50.0,
            cy: -50.0,
            sigma: 1.0,
        })
        .unwrap();
        assert!(
            p.subtract(Suppression::Gaussian {
                cx: 1.0,
                cy: 1.0,
                sigma: 0.0
            })
            .is_err()
        );
        p.reset(ifd.view()).unwrap();
        assert_eq!((p.level(), argmax(p.field())), (0, 5));
    }

    #[test]
    fn colour_blocks_match_the_per_pixel_formula_bit_for_bit() {
        let mut lcg = bayestrack_testkit::Lcg32(11);
        let mut next = move || lcg.byte();
        for w in [1, 15, 16, 17, 40, 53] {
            let mut a = Image::new(w, 3, 3, 0u8).unwrap();
            let mut b = Image::new(w, 3, 3, 0u8).unwrap();
            for v in a.as_mut_slice().iter_mut().chain(b.as_mut_slice()) {
                *v = next();
            }
            let d = interframe_difference(a.view(), b.view()).unwrap();
            let (af, bf) = (a.to_unit_f32(), b.to_unit_f32());
            let df = interframe_difference(af.view(), bf.view()).unwrap();
            let [wr, wg, wb] = LUMA_WEIGHTS.map(|w| w * (1.0 / 255.0));
            for y in 0..3 {
                for x in 0..w {
                    let (p, q) = (a.pixel(x, y).unwrap(), b.pixel(x, y).unwrap());
                    let l = |p: &[u8]| {
                        wr * f32::from(p[0]) + wg * f32::from(p[1]) + wb * f32::from(p[2])
                    };
                    let want = (l(p) - l(q)).abs();
                    assert_eq!(d.get(x, y, 0).unwrap().to_bits(), want.to_bits(), "{w} {x}");
                    let (p, q) = (af.pixel(x, y).unwrap(), bf.pixel(x, y).unwrap());
                    let [vr, vg, vb] = LUMA_WEIGHTS;
                    let l = |p: &[f32]| vr * p[0] + vg * p[1] + vb * p[2];
                    let want = (l(p) - l(q)).abs();
                    assert_eq!(
                        df.get(x, y, 0).unwrap().to_bits(),
                        want.to_bits(),
                        "{w} {x}"
                    );
                }
            }
        }
    }
}
