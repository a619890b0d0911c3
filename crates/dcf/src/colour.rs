//! Staple's colour model (Bertinetto et al. 2016): foreground and
//! background colour histograms, a per-pixel object likelihood, and its
//! mean over a target-sized box at every candidate position (an integral
//! image), merged with the correlation response.
//!
//! - **Histograms.** Joint RGB histograms of 32 bins per channel
//!   (`32^3` bins; 32 bins for gray), normalised to sum 1: the foreground
//!   from the target box shrunk by `inner_padding * (w + h) / 2` (Staple's
//!   0.2), the background from the patch outside the target box. Both are
//!   interpolated with Staple's learning rate 0.04.
//! - **Likelihood.** `P(object | pixel) = f(b) / (f(b) + g(b))` of its bin
//!   `b` (0 where both are 0).
//! - **Box score.** The mean likelihood over a target-sized box centred at
//!   each candidate displacement; merged as `(1 - m) f_cf + m f_pwp` with
//!   Staple's `m = 0.3`.

use crate::error::{DcfError, Result};

/// Bins per colour channel (Staple: 2^5).
pub const BINS: usize = 32;

/// Foreground/background colour histograms.
#[derive(Debug, Clone)]
pub struct ColourModel {
    channels: usize,
    fg: Vec<f32>,
    bg: Vec<f32>,
    new_fg: Vec<f32>,
    new_bg: Vec<f32>,
    bins: Vec<u32>,
    integral: Vec<f64>,
    trained: bool,
}

impl ColourModel {
    /// A model for 1 (gray) or 3 (RGB) channels.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for another channel count.
    pub fn new(channels: usize) -> Result<Self> {
        if channels != 1 && channels != 3 {
            return Err(DcfError::InvalidParameter {
                name: "colour channels",
                value: channels as f64,
                reason: "must be 1 or 3",
            });
        }
        let n = BINS.pow(channels as u32);
        Ok(Self {
            channels,
            fg: vec![0.0; n],
            bg: vec![0.0; n],
            new_fg: vec![0.0; n],
            new_bg: vec![0.0; n],
            bins: Vec::new(),
            integral: Vec::new(),
            trained: false,
        })
    }

    /// Whether the model has learnt at least once.
    pub fn is_trained(&self) -> bool {
        self.trained
    }

    /// The bin of every pixel of `planes` (`channels` planes of `n`
    /// pixels, values `0..=255`), into the model's scratch.
    fn bin_pixels(&mut self, planes: &[f32], n: usize) -> Result<()> {
        if planes.len() != n * self.channels {
            return Err(DcfError::Size {
                what: "colour planes",
                expected: n * self.channels,
                got: planes.len(),
            });
        }
        let q = |v: f32| ((v.clamp(0.0, 255.0) as usize) * BINS / 256) as u32;
        self.bins.clear();
        if self.channels == 1 {
            self.bins.extend(planes.iter().map(|&v| q(v)));
        } else {
            let (r, rest) = planes.split_at(n);
            let (g, b) = rest.split_at(n);
            self.bins.extend(
                r.iter()
                    .zip(g)
                    .zip(b)
                    .map(|((&r, &g), &b)| q(r) + BINS as u32 * (q(g) + BINS as u32 * q(b))),
            );
        }
        Ok(())
    }

    /// Learns from a `w x h` patch (`planes`, channel after channel) whose
    /// target box is `[x0, x1) x [y0, y1)` (patch pixels): the foreground
    /// from the box shrunk by `shrink` pixels on each side, the background
    /// from outside the box; moves the histograms by `rate` (the first
    /// call takes them whole). A region with no pixel leaves its histogram
    /// unchanged.
    ///
    /// # Errors
    /// [`DcfError::Size`] for planes of another size.
    #[allow(clippy::too_many_arguments)]
    pub fn learn(
        &mut self,
        planes: &[f32],
        w: usize,
        h: usize,
        (x0, y0, x1, y1): (usize, usize, usize, usize),
        shrink: usize,
        rate: f64,
    ) -> Result<()> {
        self.bin_pixels(planes, w * h)?;
        self.new_fg.fill(0.0);
        self.new_bg.fill(0.0);
        let (fx0, fy0) = (x0 + shrink, y0 + shrink);
        let (fx1, fy1) = (x1.saturating_sub(shrink), y1.saturating_sub(shrink));
        let (mut nf, mut nbk) = (0usize, 0usize);
        for y in 0..h {
            for x in 0..w {
                let b = self.bins[y * w + x] as usize;
                let inside = (x0..x1).contains(&x) && (y0..y1).contains(&y);
                if !inside {
                    self.new_bg[b] += 1.0;
                    nbk += 1;
                } else if (fx0..fx1).contains(&x) && (fy0..fy1).contains(&y) {
                    self.new_fg[b] += 1.0;
                    nf += 1;
                }
            }
        }
        let r = if self.trained { rate as f32 } else { 1.0 };
        for (hist, new, n) in [
            (&mut self.fg, &self.new_fg, nf),
            (&mut self.bg, &self.new_bg, nbk),
        ] {
            if n == 0 {
                continue;
            }
            let k = 1.0 / n as f32;
            for (a, &b) in hist.iter_mut().zip(new.iter()) {
                *a = (1.0 - r) * *a + r * b * k;
            }
        }
        self.trained = true;
        Ok(())
    }

    /// The object likelihood of every pixel of a `w x h` patch into `out`.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn likelihood(
        &mut self,
        planes: &[f32],
        w: usize,
        h: usize,
        out: &mut [f32],
    ) -> Result<()> {
        self.bin_pixels(planes, w * h)?;
        if out.len() != w * h {
            return Err(DcfError::Size {
                what: "likelihood map",
                expected: w * h,
                got: out.len(),
            });
        }
        for (o, &b) in out.iter_mut().zip(&self.bins) {
            let (f, g) = (self.fg[b as usize], self.bg[b as usize]);
            *o = if f + g > 0.0 { f / (f + g) } else { 0.0 };
        }
        Ok(())
    }

    /// Box scores on a cell grid: for every cyclic displacement `d` of a
    /// `nx x ny` grid of `cell`-pixel cells (`d` wrapped as in a
    /// correlation response), the mean of `map` (`w x h`) over the
    /// `bw x bh` box centred at the patch centre plus `d cell`; 0 where
    /// the box leaves the patch. Into `out` (`nx x ny`).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    #[allow(clippy::too_many_arguments)]
    pub fn box_scores(
        &mut self,
        map: &[f32],
        w: usize,
        h: usize,
        (bw, bh): (usize, usize),
        (nx, ny, cell): (usize, usize, usize),
        out: &mut [f32],
    ) -> Result<()> {
        if map.len() != w * h || out.len() != nx * ny {
            return Err(DcfError::Size {
                what: "box scores",
                expected: nx * ny,
                got: out.len(),
            });
        }
        let cols = w + 1;
        self.integral.clear();
        self.integral.resize(cols * (h + 1), 0.0);
        for y in 0..h {
            let mut run = 0.0f64;
            for x in 0..w {
                run += map[y * w + x] as f64;
                self.integral[(y + 1) * cols + x + 1] = self.integral[y * cols + x + 1] + run;
            }
        }
        let (bw, bh) = (bw.clamp(1, w), bh.clamp(1, h));
        let inv = 1.0 / (bw * bh) as f64;
        for j in 0..ny {
            let dy = crate::kcf::wrapped(j, ny) * cell as isize;
            let top = (h as isize - bh as isize) / 2 + dy;
            for i in 0..nx {
                let dx = crate::kcf::wrapped(i, nx) * cell as isize;
                let left = (w as isize - bw as isize) / 2 + dx;
                out[j * nx + i] =
                    if left < 0 || top < 0 || left as usize + bw > w || top as usize + bh > h {
                        0.0
                    } else {
                        let (l, t) = (left as usize, top as usize);
                        let (r, b) = (l + bw, t + bh);
                        let s = self.integral[b * cols + r]
                            - self.integral[t * cols + r]
                            - self.integral[b * cols + l]
                            + self.integral[t * cols + l];
                        (s * inv) as f32
                    };
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_a_red_target_from_a_green_background() {
        // 20x20 patch: red 8x8 box in the middle on green
        let (w, h) = (20, 20);
        let mut planes = vec![0.0f32; 3 * w * h];
        for y in 0..h {
            for x in 0..w {
                let inside = (6..14).contains(&x) && (6..14).contains(&y);
                let i = y * w + x;
                if inside {
                    planes[i] = 220.0;
                    planes[w * h + i] = 30.0;
                } else {
                    planes[w * h + i] = 200.0;
                }
                planes[2 * w * h + i] = 40.0;
            }
        }
        let mut m = ColourModel::new(3).unwrap();
        m.learn(&planes, w, h, (6, 6, 14, 14), 1, 0.04).unwrap();
        let mut p = vec![0.0; w * h];
        m.likelihood(&planes, w, h, &mut p).unwrap();
        assert_eq!(p[10 * w + 10], 1.0);
        assert_eq!(p[0], 0.0);
        // box scores on a 5x5 grid of 4-px cells: 1 at no displacement,
        // 0.5 one cell (4 px of an 8 px box) to the side
        let mut out = vec![0.0; 25];
        m.box_scores(&p, w, h, (8, 8), (5, 5, 4), &mut out).unwrap();
        assert!((out[0] - 1.0).abs() < 1e-6, "{out:?}");
        assert!(
            (out[1] - 0.5).abs() < 1e-6 && (out[4] - 0.5).abs() < 1e-6,
            "{out:?}"
        );
        assert!((out[5] - 0.5).abs() < 1e-6, "{out:?}");
        // two cells away the box leaves the 20 px patch: 0 (6 + 8 + 8 > 20)
        assert_eq!(out[2], 0.0);
    }

    #[test]
    fn gray_and_errors() {
        assert!(ColourModel::new(2).is_err());
        let mut m = ColourModel::new(1).unwrap();
        let planes: Vec<f32> = (0..16)
            .map(|i| if i % 4 < 2 { 250.0 } else { 5.0 })
            .collect();
        m.learn(&planes, 4, 4, (0, 0, 2, 4), 0, 1.0).unwrap();
        let mut p = vec![0.0; 16];
        m.likelihood(&planes, 4, 4, &mut p).unwrap();
        assert_eq!(&p[..4], &[1.0, 1.0, 0.0, 0.0]);
        assert!(m.likelihood(&planes[..8], 4, 4, &mut p).is_err());
    }
}
