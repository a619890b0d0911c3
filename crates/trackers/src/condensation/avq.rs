//! c-AVQ re-initialisation (Lee, Jo and Kang 2005, sec. 4).
//!
//! A particle set that rests on a paused object has to jump to a new object
//! entering the image. The paper watches the *border stripes* `P_B` of the
//! image; when the share of IFD pixels there passes a threshold (3-4 %),
//! the IFD pixels `p(k)` of the stripes are clustered by competitive
//! adaptive vector quantisation (winner take all):
//!
//! ```text
//! i* = argmin_j || w_j - p(k) ||,      w_i*(k + 1) = w_i*(k) + mu (p(k) - w_i*(k))
//! ```
//!
//! and the set's mean is shifted onto the winning cluster's centre
//! `E[x_t] = w_i*`.
//!
//! Our reading of the unstated parts, each a named field of [`CAvqConfig`]:
//! a pixel is "IFD data" when `dP > ifd_threshold`; the threshold applies
//! to each side's stripe on its own (an object enters through one side, and
//! a uniform object's IFD is only its edge band, far below 3 % of all four
//! stripes together); the IFD pixels of all stripes are clustered; the
//! clusters start
//! equally spaced along the stripes' mid-line (so each border side has its
//! own), the stripe pixels are presented in a fixed scrambled order (a
//! golden-ratio stride through the raster list) for `epochs` passes, and the winner is the cluster that won the most pixels in the
//! last pass (the largest moving region at the border). A winner closer
//! than `min_shift` to the current estimate is the tracked object itself
//! crossing the stripes and leaves the set alone.

use bayestrack_image::ImageView;

use crate::error::{Result, TrackerError};

/// The constants of c-AVQ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CAvqConfig {
    /// Width of the border stripes in pixels (8).
    pub stripe_width: usize,
    /// A stripe pixel is IFD data when `dP` exceeds this (0.05 on `[0, 1]`,
    /// 13 grey levels: well above a webcam's frame-to-frame noise of a few
    /// levels).
    pub ifd_threshold: f32,
    /// Re-initialise when more than this share of one side's stripe pixels
    /// are IFD data (0.035: the paper's 3-4 %).
    pub trigger_fraction: f64,
    /// Number of clusters (4: one per border side to start with).
    pub clusters: usize,
    /// `mu`, the winner's learning rate (0.05).
    pub learning_rate: f64,
    /// Passes over the IFD pixels (3).
    pub epochs: usize,
    /// A winning centre closer than this to the estimate (pixels) does not
    /// move the set (20).
    pub min_shift: f64,
}

impl Default for CAvqConfig {
    fn default() -> Self {
        Self {
            stripe_width: 8,
            ifd_threshold: 0.05,
            trigger_fraction: 0.035,
            clusters: 4,
            learning_rate: 0.05,
            epochs: 3,
            min_shift: 20.0,
        }
    }
}

impl CAvqConfig {
    /// Checks every field.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f64, reason| {
            Err(TrackerError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if self.stripe_width == 0 {
            return bad("stripe_width", 0.0, "must be at least 1");
        }
        if !(self.ifd_threshold.is_finite() && self.ifd_threshold >= 0.0) {
            return bad(
                "ifd_threshold",
                f64::from(self.ifd_threshold),
                "must be finite and >= 0",
            );
        }
        if !(0.0..1.0).contains(&self.trigger_fraction) {
            return bad(
                "trigger_fraction",
                self.trigger_fraction,
                "must be in [0, 1)",
            );
        }
        if self.clusters == 0 {
            return bad("clusters", 0.0, "must be at least 1");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate <= 1.0) {
            return bad("learning_rate", self.learning_rate, "must be in (0, 1]");
        }
        if self.epochs == 0 {
            return bad("epochs", 0.0, "must be at least 1");
        }
        if !(self.min_shift.is_finite() && self.min_shift >= 0.0) {
            return bad("min_shift", self.min_shift, "must be finite and >= 0");
        }
        Ok(())
    }
}

/// A stride near `0.618 n` with no factor in common with `n`.
fn coprime_stride(n: usize) -> usize {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 { a } else { gcd(b, a % b) }
    }
    let mut s = ((n as f64 * 0.618_033_988_75).round() as usize).max(1);
    while gcd(s, n) != 1 {
        s += 1;
    }
    s
}

/// c-AVQ with its buffers (reused from frame to frame).
#[derive(Debug, Clone)]
pub struct CAvq {
    config: CAvqConfig,
    active: Vec<[f64; 2]>,
    centres: Vec<[f64; 2]>,
    wins: Vec<usize>,
    fraction: f64,
    winner: Option<[f64; 2]>,
}

impl CAvq {
    /// c-AVQ with `config`.
    ///
    /// # Errors
    /// As [`CAvqConfig::validate`].
    pub fn new(config: CAvqConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            active: Vec::new(),
            centres: Vec::new(),
            wins: Vec::new(),
            fraction: 0.0,
            winner: None,
        })
    }

    /// The settings.
    pub fn config(&self) -> &CAvqConfig {
        &self.config
    }

    /// The largest share of IFD pixels among the four side stripes in the
    /// last call.
    pub fn last_fraction(&self) -> f64 {
        self.fraction
    }

    /// The winning cluster's centre in the last call that clustered.
    pub fn last_winner(&self) -> Option<(f64, f64)> {
        self.winner.map(|[x, y]| (x, y))
    }

    /// Collects the stripe pixels above the IFD threshold; returns the
    /// largest share of IFD pixels among the four side stripes (each side
    /// is the full `stripe_width`-wide band along that border, corners
    /// counted in both sides they touch).
    fn collect(&mut self, ifd: ImageView<'_, f32>) -> f64 {
        let (w, h) = (ifd.width(), ifd.height());
        let s = self
            .config
            .stripe_width
            .min(w.div_ceil(2))
            .min(h.div_ceil(2));
        let t = self.config.ifd_threshold;
        self.active.clear();
        // Active pixels per side: top, bottom, left, right.
        let mut count = [0usize; 4];
        for y in 0..h {
            let row = ifd.row(y);
            let (top, bottom) = (y < s, y + s >= h);
            for (x, &v) in row.iter().enumerate() {
                let (left, right) = (x < s, x + s >= w);
                if !(top || bottom || left || right) {
                    continue;
                }
                if v > t {
                    self.active.push([x as f64, y as f64]);
                    for (c, on) in count.iter_mut().zip([top, bottom, left, right]) {
                        *c += usize::from(on);
                    }
                }
            }
        }
        let sizes = [s * w, s * w, s * h, s * h];
        count
            .iter()
            .zip(sizes)
            .map(|(&c, n)| if n == 0 { 0.0 } else { c as f64 / n as f64 })
            .fold(0.0, f64::max)
    }

    /// The clusters' starting centres: equally spaced along the mid-line of
    /// the stripes, starting at the middle of the top side.
    fn seed_centres(&mut self, w: usize, h: usize) {
        let half = self.config.stripe_width as f64 / 2.0;
        let (x0, y0) = (half - 0.5, half - 0.5);
        let (x1, y1) = (w as f64 - half - 0.5, h as f64 - half - 0.5);
        let (lw, lh) = ((x1 - x0).max(0.0), (y1 - y0).max(0.0));
        let perimeter = (2.0 * (lw + lh)).max(1.0);
        let k = self.config.clusters;
        self.centres.clear();
        for i in 0..k {
            // Arc length from the top-left corner, clockwise.
            let mut d = (i as f64 / k as f64 * perimeter + lw / 2.0) % perimeter;
            let p = if d < lw {
                [x0 + d, y0]
            } else {
                d -= lw;
                if d < lh {
                    [x1, y0 + d]
                } else {
                    d -= lh;
                    if d < lw {
                        [x1 - d, y1]
                    } else {
                        [x0, y1 - (d - lw)]
                    }
                }
            };
            self.centres.push(p);
        }
    }

    /// Competitive AVQ over the collected pixels; returns the centre of the
    /// cluster that won the most pixels in the last pass.
    fn cluster(&mut self, w: usize, h: usize) -> Option<[f64; 2]> {
        if self.active.is_empty() {
            return None;
        }
        self.seed_centres(w, h);
        let mu = self.config.learning_rate;
        self.wins.clear();
        self.wins.resize(self.centres.len(), 0);
        // Present the pixels in a scrambled but fixed order (a golden-ratio
        // stride through the raster list): with a constant mu the centre is
        // an exponential average of the latest pixels, which in raster order
        // would lag towards the bottom of a region.
        let n = self.active.len();
        let stride = coprime_stride(n);
        for epoch in 0..self.config.epochs {
            let last = epoch + 1 == self.config.epochs;
            for i in 0..n {
                let p = &self.active[(i * stride) % n];
                let mut best = (0, f64::INFINITY);
                for (j, c) in self.centres.iter().enumerate() {
                    let d = (c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2);
                    if d < best.1 {
                        best = (j, d);
                    }
                }
                let c = &mut self.centres[best.0];
                c[0] += mu * (p[0] - c[0]);
                c[1] += mu * (p[1] - c[1]);
                if last {
                    self.wins[best.0] += 1;
                }
            }
        }
        let best =
            (0..self.wins.len()).fold(0, |b, j| if self.wins[j] > self.wins[b] { j } else { b });
        Some(self.centres[best])
    }

    /// Sec. 4 for one frame: when the stripes' IFD share passes the
    /// trigger, clusters their IFD pixels and returns the shift `(dx, dy)`
    /// that moves `estimate` (the set's mean) onto the winning centre;
    /// `None` when nothing entered or the winner is the estimate itself.
    pub fn reinitialise(
        &mut self,
        ifd: ImageView<'_, f32>,
        estimate: (f64, f64),
    ) -> Option<(f64, f64)> {
        self.fraction = self.collect(ifd);
        if self.fraction <= self.config.trigger_fraction {
            return None;
        }
        let winner = self.cluster(ifd.width(), ifd.height())?;
        self.winner = Some(winner);
        let (dx, dy) = (winner[0] - estimate.0, winner[1] - estimate.1);
        if dx.hypot(dy) < self.config.min_shift || !(dx.is_finite() && dy.is_finite()) {
            return None;
        }
        Some((dx, dy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn a_blob_in_the_left_stripe_wins_and_quiet_stripes_do_not_trigger() {
        let mut avq = CAvq::new(CAvqConfig::default()).unwrap();
        // 100 x 80: the left stripe of 8 px holds 640 pixels.
        let quiet = Image::new(100, 80, 1, 0.0f32).unwrap();
        assert_eq!(avq.reinitialise(quiet.view(), (50.0, 40.0)), None);
        assert_eq!(avq.last_fraction(), 0.0);
        // Motion in the left stripe, rows 30..50, columns 0..8 (160 px,
        // 25 %), plus a few pixels of noise on the right (below 1 %).
        let ifd = Image::from_fn(100, 80, |x, y| {
            if (x < 8 && (30..50).contains(&y)) || (x == 99 && y < 5) {
                0.5f32
            } else {
                0.0
            }
        })
        .unwrap();
        let (dx, dy) = avq.reinitialise(ifd.view(), (50.0, 40.0)).unwrap();
        let (wx, wy) = avq.last_winner().unwrap();
        assert!(
            (wx - 3.5).abs() < 2.0 && (wy - 39.5).abs() < 3.0,
            "{wx} {wy}"
        );
        assert!(((50.0 + dx) - wx).abs() < 1e-9 && ((40.0 + dy) - wy).abs() < 1e-9);
        // The estimate already there: no shift.
        assert_eq!(avq.reinitialise(ifd.view(), (5.0, 40.0)), None);
        // Below the trigger: 20 px of 2624 (0.8 %).
        let small = Image::from_fn(100, 80, |x, y| {
            if x < 2 && (30..40).contains(&y) {
                0.5f32
            } else {
                0.0
            }
        })
        .unwrap();
        assert_eq!(avq.reinitialise(small.view(), (50.0, 40.0)), None);
        for bad in [
            CAvqConfig {
                stripe_width: 0,
                ..Default::default()
            },
            CAvqConfig {
                trigger_fraction: 1.5,
                ..Default::default()
            },
            CAvqConfig {
                learning_rate: 0.0,
                ..Default::default()
            },
            CAvqConfig {
                clusters: 0,
                ..Default::default()
            },
        ] {
            assert!(CAvq::new(bad).is_err());
        }
    }
}
