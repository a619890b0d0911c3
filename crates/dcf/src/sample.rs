//! Resampling a frame into fixed-size patches: area averaging when
//! shrinking (an integral image per plane, anti-aliased at every scale),
//! bilinear interpolation when enlarging; edge pixels replicated outside
//! the frame (as KCF's and DSST's patch extraction does).

use bayestrack_image::ImageView;

use crate::error::{DcfError, Result};

/// The planes of one frame, ready to resample.
#[derive(Debug, Clone, Default)]
pub struct PatchSampler {
    w: usize,
    h: usize,
    planes: Vec<Vec<f32>>,
    /// Summed-area table of each plane, `(w + 1) x (h + 1)`.
    sums: Vec<Vec<f64>>,
    /// Scratch: the distinct column edges of a patch.
    xs: Vec<(usize, f64)>,
    /// Scratch: per output column, its edges' indices in `xs` and width
    /// (area averaging), or its two source columns and weight (bilinear).
    spans: Vec<(usize, usize, f64)>,
    /// Scratch: the table interpolated at the column edges of two rows.
    top: Vec<f64>,
    bottom: Vec<f64>,
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
        self.sums.resize_with(c, Vec::new);
        let cols = w + 1;
        for (ch, (plane, sum)) in self.planes.iter_mut().zip(self.sums.iter_mut()).enumerate() {
            // every entry is written below: no clearing
            plane.resize(w * h, 0.0);
            sum.resize(cols * (h + 1), 0.0);
            sum[..cols].fill(0.0);
            for y in 0..h {
                let row = frame.row(y);
                let dst = &mut plane[y * w..][..w];
                let (above, below) = sum[y * cols..][..2 * cols].split_at_mut(cols);
                below[0] = 0.0;
                // the row's running sum is an exact integer, and so is every
                // entry of the table (below 2^53 for any frame of under 2^45
                // pixels): the same values as accumulating in f64, in a
                // fraction of the instructions
                let mut run = 0i64;
                let mut put = |x: usize, v: u8| {
                    dst[x] = f32::from(v);
                    run += i64::from(v);
                    below[x + 1] = above[x + 1] + run as f64;
                };
                if c == 1 {
                    for (x, &v) in row[..w].iter().enumerate() {
                        put(x, v);
                    }
                } else {
                    for (x, p) in row.chunks_exact(c).enumerate() {
                        put(x, p[ch]);
                    }
                }
            }
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
        if sx >= 1.0 && sy >= 1.0 {
            self.area(ch, x0, y0, sx, sy, out, ow);
            return Ok(());
        }
        let (w, h) = (self.w, self.h);
        let plane = &self.planes[ch];
        let split = |c: f64, n: usize| -> (usize, usize, f32) {
            let c = c.clamp(0.0, (n - 1) as f64);
            // c >= 0: truncation is the floor
            let i = (c as usize).min(n - 1);
            let j = (i + 1).min(n - 1);
            (i, j, (c - i as f64) as f32)
        };
        self.spans.clear();
        self.spans.extend((0..ow).map(|u| {
            let (a, b, f) = split(x0 + (u as f64 + 0.5) * sx - 0.5, w);
            (a, b, f64::from(f))
        }));
        for (v, orow) in out.chunks_exact_mut(ow).enumerate() {
            let (ya, yb, fy) = split(y0 + (v as f64 + 0.5) * sy - 0.5, h);
            let (ra, rb) = (&plane[ya * w..(ya + 1) * w], &plane[yb * w..(yb + 1) * w]);
            for (o, &(xa, xb, fx)) in orow.iter_mut().zip(&self.spans) {
                let fx = fx as f32;
                let top = ra[xa] + fx * (ra[xb] - ra[xa]);
                let bot = rb[xa] + fx * (rb[xb] - rb[xa]);
                *o = top + fy * (bot - top);
            }
        }
        Ok(())
    }
}

impl PatchSampler {
    /// Area averaging: each output pixel the mean of the plane over its
    /// rectangle clipped to the frame (the summed-area table interpolated
    /// bilinearly at the rectangle's corners); a rectangle left with no
    /// area reads the nearest pixel (edge replication).
    ///
    /// Neighbouring rectangles share their edges: the table is interpolated
    /// once per distinct edge (about one corner per output pixel instead of
    /// four), the same values bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn area(&mut self, ch: usize, x0: f64, y0: f64, sx: f64, sy: f64, out: &mut [f32], ow: usize) {
        let (w, h) = (self.w, self.h);
        let cols = w + 1;
        let sum = &self.sums[ch];
        let edges = |a: f64, b: f64, n: usize| -> (f64, f64) {
            let (lo, hi) = (a.clamp(0.0, n as f64), b.clamp(0.0, n as f64));
            if hi - lo > 1e-9 {
                (lo, hi)
            } else {
                // lo >= 0: truncation is the floor
                let p = (lo.min(n as f64 - 0.5) as usize) as f64;
                (p, p + 1.0)
            }
        };
        // the distinct column edges (xs: each as its table column and the
        // fraction to the next one) and each column's pair of indices into
        // them with its width
        self.xs.clear();
        self.spans.clear();
        let at = |x: f64| -> (usize, f64) {
            // x >= 0: truncation is the floor
            let i = (x as usize).min(w - 1);
            (i, x - i as f64)
        };
        let mut last = f64::NAN;
        for u in 0..ow {
            let (a, b) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
            let ia = if a == last {
                self.xs.len() - 1
            } else {
                self.xs.push(at(a));
                self.xs.len() - 1
            };
            self.xs.push(at(b));
            last = b;
            self.spans.push((ia, self.xs.len() - 1, b - a));
        }
        // the table at row coordinate y, at every column edge
        let row_at = |y: f64, out: &mut Vec<f64>, xs: &[(usize, f64)]| {
            let j = (y as usize).min(h - 1);
            let f = y - j as f64;
            let (ra, rb) = (&sum[j * cols..][..cols], &sum[(j + 1) * cols..][..cols]);
            out.resize(xs.len(), 0.0);
            for (o, &(i, g)) in out.iter_mut().zip(xs) {
                let [a0, a1]: [f64; 2] = ra[i..i + 2].try_into().unwrap_or_default();
                let [b0, b1]: [f64; 2] = rb[i..i + 2].try_into().unwrap_or_default();
                let a = a0 + g * (a1 - a0);
                let b = b0 + g * (b1 - b0);
                *o = a + f * (b - a);
            }
        };
        // every column's left edge the previous one's right edge (all but
        // patches running off the frame's side)
        let contiguous = self.xs.len() == ow + 1;
        let (mut top, mut bottom) = (
            std::mem::take(&mut self.top),
            std::mem::take(&mut self.bottom),
        );
        let mut bottom_at = f64::NAN;
        for (v, row) in out.chunks_exact_mut(ow).enumerate() {
            let (a, b) = edges(y0 + v as f64 * sy, y0 + (v + 1) as f64 * sy, h);
            if a == bottom_at {
                std::mem::swap(&mut top, &mut bottom);
            } else {
                row_at(a, &mut top, &self.xs);
            }
            row_at(b, &mut bottom, &self.xs);
            bottom_at = b;
            let inv_h = 1.0 / (b - a);
            if contiguous {
                // column u spans edges u and u + 1: no gather
                let (tl, tr) = (&top[..ow], &top[1..=ow]);
                let (bl, br) = (&bottom[..ow], &bottom[1..=ow]);
                for (u, (o, &(_, _, cw))) in row.iter_mut().zip(&self.spans).enumerate() {
                    let s = br[u] - bl[u] - tr[u] + tl[u];
                    *o = (s * inv_h / cw) as f32;
                }
            } else {
                for (o, &(ia, ib, cw)) in row.iter_mut().zip(&self.spans) {
                    let s = bottom[ib] - bottom[ia] - top[ib] + top[ia];
                    *o = (s * inv_h / cw) as f32;
                }
            }
        }
        self.top = top;
        self.bottom = bottom;
    }
}

#[cfg(test)]
mod area_tests {
    use super::*;
    use bayestrack_image::Image;

    /// The area averaging as first written (the table interpolated at
    /// each edge from its coordinate, every column through its two edge
    /// indices): the reference the faster paths must match bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        s: &PatchSampler,
        x0: f64,
        y0: f64,
        sx: f64,
        sy: f64,
        ow: usize,
        oh: usize,
    ) -> Vec<f32> {
        let (w, h) = (s.w, s.h);
        let cols = w + 1;
        let sum = &s.sums[0];
        let edges = |a: f64, b: f64, n: usize| -> (f64, f64) {
            let (lo, hi) = (a.clamp(0.0, n as f64), b.clamp(0.0, n as f64));
            if hi - lo > 1e-9 {
                (lo, hi)
            } else {
                let p = (lo.min(n as f64 - 0.5) as usize) as f64;
                (p, p + 1.0)
            }
        };
        let at = |x: f64, y: f64| -> f64 {
            let j = (y as usize).min(h - 1);
            let f = y - j as f64;
            let (ra, rb) = (&sum[j * cols..][..cols], &sum[(j + 1) * cols..][..cols]);
            let i = (x as usize).min(w - 1);
            let g = x - i as f64;
            let a = ra[i] + g * (ra[i + 1] - ra[i]);
            let b = rb[i] + g * (rb[i + 1] - rb[i]);
            a + f * (b - a)
        };
        let mut out = Vec::with_capacity(ow * oh);
        for v in 0..oh {
            let (ya, yb) = edges(y0 + v as f64 * sy, y0 + (v + 1) as f64 * sy, h);
            for u in 0..ow {
                let (xa, xb) = edges(x0 + u as f64 * sx, x0 + (u + 1) as f64 * sx, w);
                let s = at(xb, yb) - at(xa, yb) - at(xb, ya) + at(xa, ya);
                out.push((s * (1.0 / (yb - ya)) / (xb - xa)) as f32);
            }
        }
        out
    }

    #[test]
    fn area_matches_the_reference_inside_and_off_the_frame() {
        let img = Image::from_fn(37, 23, |x, y| ((x * 37 + y * 101 + x * y) % 251) as u8).unwrap();
        let mut s = PatchSampler::new();
        s.load(img.view()).unwrap();
        // inside (every column contiguous), off each side and corner (the
        // edge-replicating columns), steps of odd fractions
        let cases = [
            (2.3, 1.7, 1.37, 1.21, 13, 11),
            (-5.5, 3.0, 1.5, 1.0, 17, 9),
            (20.25, -4.75, 1.125, 2.5, 19, 12),
            (-40.0, -30.0, 3.3, 2.9, 31, 23),
            (30.9, 19.1, 1.01, 1.9, 7, 5),
            (0.0, 0.0, 37.0, 23.0, 1, 1),
        ];
        for (x0, y0, sx, sy, ow, oh) in cases {
            let mut got = vec![f32::NAN; ow * oh];
            s.sample(0, x0, y0, sx, sy, &mut got, ow, oh).unwrap();
            let want = reference(&s, x0, y0, sx, sy, ow, oh);
            for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "{x0},{y0} {sx}x{sy}: pixel {i}: {a} vs {b}"
                );
            }
        }
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
