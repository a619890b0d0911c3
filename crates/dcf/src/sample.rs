//! Resampling a frame into fixed-size patches: area averaging when
//! shrinking (an integral image per plane, anti-aliased at every scale),
//! bilinear interpolation when enlarging; edge pixels replicated outside
//! the frame (as KCF's and DSST's patch extraction does).

use bayestrack_image::{AreaSampler, ImageView, ImageViewMut};

use crate::error::{DcfError, Result};

/// The planes of one frame, ready to resample.
#[derive(Debug, Clone, Default)]
pub struct PatchSampler {
    w: usize,
    h: usize,
    planes: Vec<Vec<f32>>,
    area: Vec<AreaSampler>,
}

impl PatchSampler {
    /// An empty sampler (load a frame first).
    pub fn new() -> Self {
        Self::default()
    }

    /// Loads `frame` (interleaved `u8`): one plane per channel.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for an empty frame.
    pub fn load(&mut self, frame: ImageView<'_, u8>) -> Result<()> {
        let (w, h, c) = (frame.width(), frame.height(), frame.channels());
        if w == 0 || h == 0 || c == 0 {
            return Err(DcfError::InvalidParameter {
                name: "frame",
                value: 0.0,
                reason: "is empty",
            });
        }
        (self.w, self.h) = (w, h);
        self.planes.resize_with(c, Vec::new);
        self.area.resize_with(c, AreaSampler::default);
        for (ch, plane) in self.planes.iter_mut().enumerate() {
            plane.clear();
            for y in 0..h {
                let row = frame.row(y);
                plane.extend(row.chunks_exact(c).map(|p| p[ch] as f32));
            }
        }
        for (plane, area) in self.planes.iter().zip(self.area.iter_mut()) {
            area.compute(ImageView::from_slice(plane, w, h, 1, w)?)?;
        }
        Ok(())
    }

    /// Channels loaded.
    pub fn channels(&self) -> usize {
        self.planes.len()
    }

    /// Frame width.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Frame height.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Fills `out` (`ow x oh`, row-major) from channel `ch`: output pixel
    /// `(u, v)` covers `[x0 + u sx, x0 + (u + 1) sx] x [y0 + v sy, ...]`
    /// in frame coordinates (pixel `i` covers `[i, i + 1]`).
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a channel not loaded;
    /// image errors for non-finite or non-positive steps.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &mut self,
        ch: usize,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        out: &mut [f32],
        ow: usize,
        oh: usize,
    ) -> Result<()> {
        if ch >= self.planes.len() {
            return Err(DcfError::InvalidParameter {
                name: "channel",
                value: ch as f64,
                reason: "not loaded",
            });
        }
        if sx >= 1.0 && sy >= 1.0 {
            let mut view = ImageViewMut::from_slice(out, ow, oh, 1, ow)?;
            self.area[ch].sample_into(x0, y0, sx, sy, &mut view)?;
            return Ok(());
        }
        if ![x0, y0, sx, sy].iter().all(|v| v.is_finite()) || sx <= 0.0 || sy <= 0.0 {
            return Err(DcfError::NonFinite {
                what: "sampling origin or steps",
            });
        }
        if out.len() != ow * oh {
            return Err(DcfError::Size {
                what: "patch",
                expected: ow * oh,
                got: out.len(),
            });
        }
        let (w, h) = (self.w, self.h);
        let plane = &self.planes[ch];
        let split = |c: f64, n: usize| -> (usize, usize, f32) {
            let c = c.clamp(0.0, (n - 1) as f64);
            let i = (c.floor() as usize).min(n - 1);
            let j = (i + 1).min(n - 1);
            (i, j, (c - i as f64) as f32)
        };
        for v in 0..oh {
            let (ya, yb, fy) = split(y0 + (v as f64 + 0.5) * sy - 0.5, h);
            let (ra, rb) = (&plane[ya * w..(ya + 1) * w], &plane[yb * w..(yb + 1) * w]);
            for u in 0..ow {
                let (xa, xb, fx) = split(x0 + (u as f64 + 0.5) * sx - 0.5, w);
                let top = ra[xa] + fx * (ra[xb] - ra[xa]);
                let bot = rb[xa] + fx * (rb[xb] - rb[xa]);
                out[v * ow + u] = top + fy * (bot - top);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn area_and_bilinear() {
        let img = Image::from_fn(4, 4, |x, y| (10 * x + 40 * y) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        let mut out = [0.0f32; 4];
        s.sample(0, 0.0, 0.0, 2.0, 2.0, &mut out, 2, 2).unwrap();
        assert_eq!(out, [25.0, 45.0, 105.0, 125.0]);
        // enlarging by 2 around pixel 1: centres at 0.75, 1.25 -> (0.25, 0.75) of the way
        s.sample(0, 1.0, 1.0, 0.5, 0.5, &mut out, 2, 2).unwrap();
        assert!(
            (out[0] - (10.0 * 0.75 + 40.0 * 0.75)).abs() < 1e-4,
            "{out:?}"
        );
        assert!(
            (out[3] - (10.0 * 1.25 + 40.0 * 1.25)).abs() < 1e-4,
            "{out:?}"
        );
        assert!(s.sample(1, 0.0, 0.0, 1.0, 1.0, &mut out, 2, 2).is_err());
        assert!(
            s.sample(0, f64::NAN, 0.0, 0.5, 1.0, &mut out, 2, 2)
                .is_err()
        );
    }
}
