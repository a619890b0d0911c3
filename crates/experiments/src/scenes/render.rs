//! Small deterministic rasterisation helpers shared by the scenes.
//!
//! Shapes are anti-aliased by area coverage: a pixel `i` covers
//! `[i - 0.5, i + 0.5]`; a rectangle's coverage is the product of its
//! interval overlaps, an ellipse's is `clamp(0.5 - d, 0, 1)` with `d` the
//! (first-order) signed distance of the pixel centre to the outline.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// Length of `[i - 0.5, i + 0.5] ∩ [lo, hi]`.
#[inline]
pub(crate) fn interval_cov(i: f64, lo: f64, hi: f64) -> f64 {
    ((i + 0.5).min(hi) - (i - 0.5).max(lo)).clamp(0.0, 1.0)
}

/// Coverage of the pixel centred at `(x, y)` by the axis-aligned rectangle
/// `[x0, x1] x [y0, y1]`.
#[inline]
pub(crate) fn rect_cov(x: f64, y: f64, x0: f64, y0: f64, x1: f64, y1: f64) -> f64 {
    interval_cov(x, x0, x1) * interval_cov(y, y0, y1)
}

/// Coverage of a pixel at offset `(dx, dy)` from the centre of an
/// axis-aligned ellipse with semi-axes `a`, `b`.
#[inline]
pub(crate) fn ellipse_cov(dx: f64, dy: f64, a: f64, b: f64) -> f64 {
    let (ua, vb) = (dx / a, dy / b);
    let rho = (ua * ua + vb * vb).sqrt();
    if rho < 0.5 {
        return if a.min(b) >= 1.0 { 1.0 } else { 0.5 };
    }
    let grad = ((ua / a).powi(2) + (vb / b).powi(2)).sqrt() / rho;
    let d = (rho - 1.0) / grad;
    (0.5 - d).clamp(0.0, 1.0)
}

/// Pixel indices whose cells meet the continuous interval `[lo, hi]`,
/// unclipped (may be negative or past the frame).
#[inline]
pub(crate) fn pixel_span(lo: f64, hi: f64) -> std::ops::RangeInclusive<i64> {
    let a = (lo + 0.5).floor() as i64;
    let b = (hi - 0.5).ceil() as i64;
    a..=b
}

/// The same span clipped to `0..n`.
#[inline]
pub(crate) fn clipped_span(lo: f64, hi: f64, n: usize) -> std::ops::Range<usize> {
    let s = pixel_span(lo, hi);
    let a = (*s.start()).clamp(0, n as i64) as usize;
    let b = (*s.end() + 1).clamp(0, n as i64) as usize;
    a..b.max(a)
}

/// Linear blend of `dst` towards `src` by `alpha` in `[0, 1]`.
#[inline]
pub(crate) fn blend(dst: f64, src: f64, alpha: f64) -> f64 {
    dst + (src - dst) * alpha
}

/// Rounds and clamps to 8 bits.
#[inline]
pub(crate) fn to_u8(v: f64) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// Adds i.i.d. Gaussian noise of standard deviation `sigma` (grey levels)
/// to every element, rounding and clamping to 8 bits. Nothing is drawn
/// when `sigma == 0`.
pub(crate) fn add_noise<R: Rng + ?Sized>(buf: &mut [u8], sigma: f64, rng: &mut R) {
    if sigma <= 0.0 {
        return;
    }
    let s = sigma as f32;
    for v in buf {
        let z: f32 = StandardNormal.sample(rng);
        *v = (f32::from(*v) + s * z).round().clamp(0.0, 255.0) as u8;
    }
}

/// A smooth value-noise texture: a `gw x gh` grid of random values in
/// `[-1, 1]` interpolated bilinearly (with smoothstep) over a `w x h` area.
#[derive(Debug, Clone)]
pub(crate) struct ValueNoise {
    grid: Vec<f64>,
    gw: usize,
    gh: usize,
    sx: f64,
    sy: f64,
}

impl ValueNoise {
    /// A grid with one node every `cell` pixels over a `w x h` area.
    pub(crate) fn new<R: Rng + ?Sized>(w: f64, h: f64, cell: f64, rng: &mut R) -> Self {
        use rand::RngExt;
        let gw = (w / cell).ceil().max(1.0) as usize + 2;
        let gh = (h / cell).ceil().max(1.0) as usize + 2;
        let grid = (0..gw * gh).map(|_| rng.random_range(-1.0..1.0)).collect();
        Self {
            grid,
            gw,
            gh,
            sx: 1.0 / cell,
            sy: 1.0 / cell,
        }
    }

    /// The texture value at `(x, y)` (clamped to the grid), in `[-1, 1]`.
    #[inline]
    pub(crate) fn at(&self, x: f64, y: f64) -> f64 {
        let gx = (x * self.sx).clamp(0.0, (self.gw - 1) as f64);
        let gy = (y * self.sy).clamp(0.0, (self.gh - 1) as f64);
        let (ix, iy) = (
            (gx.floor() as usize).min(self.gw - 2),
            (gy.floor() as usize).min(self.gh - 2),
        );
        let smooth = |t: f64| t * t * (3.0 - 2.0 * t);
        let (fx, fy) = (smooth(gx - ix as f64), smooth(gy - iy as f64));
        let g = |i: usize, j: usize| self.grid[j * self.gw + i];
        let top = blend(g(ix, iy), g(ix + 1, iy), fx);
        let bottom = blend(g(ix, iy + 1), g(ix + 1, iy + 1), fx);
        blend(top, bottom, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_by_hand() {
        assert_eq!(interval_cov(0.0, -0.5, 0.5), 1.0);
        assert_eq!(interval_cov(0.0, 0.0, 3.0), 0.5);
        assert_eq!(interval_cov(3.0, 0.0, 3.0), 0.5);
        assert_eq!(interval_cov(5.0, 0.0, 3.0), 0.0);
        assert_eq!(rect_cov(0.0, 0.0, 0.0, 0.0, 2.0, 2.0), 0.25);
        // Circle of radius 5: centre pixel fully inside, far pixel outside,
        // pixel centre on the outline half covered.
        assert_eq!(ellipse_cov(0.0, 0.0, 5.0, 5.0), 1.0);
        assert_eq!(ellipse_cov(8.0, 0.0, 5.0, 5.0), 0.0);
        assert!((ellipse_cov(5.0, 0.0, 5.0, 5.0) - 0.5).abs() < 1e-12);
        assert!((ellipse_cov(0.0, 3.0, 8.0, 3.0) - 0.5).abs() < 1e-12);
        assert_eq!(pixel_span(-0.5, 9.5), 0..=9);
        assert_eq!(pixel_span(0.2, 0.8), 0..=1);
        assert_eq!(clipped_span(-5.0, 3.2, 10), 0..4);
        assert_eq!(clipped_span(20.0, 30.0, 10), 10..10);
    }
}
