//! DSST's one-dimensional scale filter (Danelljan et al. 2014, 2017).
//!
//! Around the current centre the frame is sampled at `S` scales
//! `a^n` (`n = floor(S/2) ... -floor(S/2)` around the current size), each
//! sample resized to a fixed model size (area at most
//! [`ScaleConfig::model_max_area`] pixels) and described by fHOG; the
//! `d` features of each scale, times a Hann window over the scales, form
//! a `d x S` array. The filter is learnt along the scale axis, per
//! feature, in the Fourier domain (`H = conj(F) G / (sum F conj(F) +
//! lambda)`, numerator and denominator interpolated separately), against
//! a Gaussian label over the scales of standard deviation
//! `sqrt(S) * scale_sigma_factor`. The scale of the new frame is the one
//! with the highest response.

use std::sync::Arc;

use rustfft::{Fft, FftPlanner};

use crate::error::{DcfError, Result};
use crate::features::Fhog;
use crate::fft::C32;
use crate::kcf::{hann, parabola_offset};
use crate::sample::PatchSampler;

/// DSST's scale parameters (the paper's published values as defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleConfig {
    /// Number of scales `S` (DSST: 33).
    pub scales: usize,
    /// Ratio `a` between neighbouring scales (DSST: 1.02).
    pub step: f64,
    /// Label width as a fraction of `sqrt(S)` (DSST: 1/4).
    pub sigma_factor: f64,
    /// Regularisation `lambda` (DSST: 1e-2).
    pub lambda: f64,
    /// Learning rate (DSST: 0.025).
    pub learning_rate: f64,
    /// Largest area of the resized scale samples, pixels (DSST: 512).
    pub model_max_area: f64,
    /// Cell of the samples' fHOG, pixels (DSST: 4).
    pub cell: usize,
}

impl Default for ScaleConfig {
    fn default() -> Self {
        Self {
            scales: 33,
            step: 1.02,
            sigma_factor: 0.25,
            lambda: 1e-2,
            learning_rate: 0.025,
            model_max_area: 512.0,
            cell: 4,
        }
    }
}

impl ScaleConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f64, reason| {
            Err(DcfError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(1..=255).contains(&self.scales) {
            return bad("scales", self.scales as f64, "must be in 1..=255");
        }
        if !(self.step.is_finite() && self.step > 1.0 && self.step <= 2.0) {
            return bad("scale step", self.step, "must be in (1, 2]");
        }
        if !(self.sigma_factor.is_finite() && self.sigma_factor > 0.0) {
            return bad("scale sigma factor", self.sigma_factor, "must be positive");
        }
        if !(self.lambda.is_finite() && self.lambda > 0.0) {
            return bad("scale lambda", self.lambda, "must be positive");
        }
        if !(0.0..=1.0).contains(&self.learning_rate) {
            return bad(
                "scale learning rate",
                self.learning_rate,
                "must be in [0, 1]",
            );
        }
        if !(self.model_max_area.is_finite() && self.model_max_area >= 64.0) {
            return bad(
                "scale model area",
                self.model_max_area,
                "must be at least 64",
            );
        }
        if !(1..=16).contains(&self.cell) {
            return bad("scale cell", self.cell as f64, "must be in 1..=16");
        }
        Ok(())
    }
}

/// The scale filter of one target (its model size fixed at creation).
#[derive(Clone)]
pub struct ScaleFilter {
    config: ScaleConfig,
    /// Relative scale of each sample, `a^(floor(S/2) - n)`.
    factors: Vec<f64>,
    window: Vec<f32>,
    ysf: Vec<C32>,
    /// Model sample size, pixels.
    mw: usize,
    mh: usize,
    /// The target size (frame pixels) at scale 1.
    base: (f64, f64),
    fwd: Arc<dyn Fft<f32>>,
    inv: Arc<dyn Fft<f32>>,
    scratch: Vec<C32>,
    hog: Fhog,
    patch: Vec<f32>,
    feat: Vec<f32>,
    xs: Vec<C32>,
    num: Vec<C32>,
    den: Vec<f32>,
    resp: Vec<C32>,
    trained: bool,
}

impl std::fmt::Debug for ScaleFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScaleFilter")
            .field("config", &self.config)
            .field("model", &(self.mw, self.mh))
            .finish_non_exhaustive()
    }
}

impl ScaleFilter {
    /// A filter for a target of `w x h` frame pixels at scale 1.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for bad parameters or a target size
    /// that is not finite and positive.
    pub fn new(config: ScaleConfig, w: f64, h: f64) -> Result<Self> {
        config.validate()?;
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
            return Err(DcfError::InvalidParameter {
                name: "target size",
                value: w.min(h),
                reason: "must be finite and positive",
            });
        }
        let s = config.scales;
        let half = (s / 2) as f64;
        let factors: Vec<f64> = (0..s).map(|n| config.step.powf(half - n as f64)).collect();
        let sigma = (s as f64).sqrt() * config.sigma_factor;
        // label over the scales, peaked at the middle one
        let mid = s / 2;
        let ys: Vec<C32> = (0..s)
            .map(|n| {
                let d = n as f64 - mid as f64;
                C32::new((-0.5 * d * d / (sigma * sigma)).exp() as f32, 0.0)
            })
            .collect();
        let mut planner = FftPlanner::<f32>::new();
        let fwd = planner.plan_fft_forward(s);
        let inv = planner.plan_fft_inverse(s);
        let mut scratch = vec![
            C32::default();
            fwd.get_inplace_scratch_len()
                .max(inv.get_inplace_scratch_len())
        ];
        let mut ysf = ys;
        fwd.process_with_scratch(&mut ysf, &mut scratch);
        // model size: the target shrunk to at most model_max_area pixels,
        // and at least 2x2 cells
        let k = (config.model_max_area / (w * h)).sqrt().min(1.0);
        let min_side = (2 * config.cell) as f64;
        let mw = (w * k).floor().max(min_side) as usize;
        let mh = (h * k).floor().max(min_side) as usize;
        let hog = Fhog::new(mw, mh, config.cell)?;
        let dims = hog.len();
        // DSST's window: hann(S) for odd S (zero at the extreme scales),
        // hann(S + 1) without its first value for even S
        let window = if s < 3 {
            vec![1.0; s]
        } else if s % 2 == 1 {
            hann(s)
        } else {
            hann(s + 1)[1..].to_vec()
        };
        Ok(Self {
            config,
            factors,
            window,
            ysf,
            mw,
            mh,
            base: (w, h),
            fwd,
            inv,
            scratch,
            patch: vec![0.0; mw * mh],
            feat: vec![0.0; dims],
            hog,
            xs: vec![C32::default(); dims * s],
            num: vec![C32::default(); dims * s],
            den: vec![0.0; s],
            resp: vec![C32::default(); s],
            trained: false,
        })
    }

    /// The relative scales searched, largest first.
    pub fn factors(&self) -> &[f64] {
        &self.factors
    }

    /// The model sample size, pixels.
    pub fn model_size(&self) -> (usize, usize) {
        (self.mw, self.mh)
    }

    /// Whether the filter has been trained.
    pub fn is_trained(&self) -> bool {
        self.trained
    }

    /// Samples the scales around `(cx, cy)` at `scale` (0-based pixel
    /// centre; `sampler` holds the frame's gray levels) into the spectra
    /// along the scale axis.
    fn sample(&mut self, sampler: &mut PatchSampler, cx: f64, cy: f64, scale: f64) -> Result<()> {
        let s = self.config.scales;
        for n in 0..s {
            let f = scale * self.factors[n];
            let (pw, ph) = (self.base.0 * f, self.base.1 * f);
            let (sx, sy) = (pw / self.mw as f64, ph / self.mh as f64);
            let (x0, y0) = (cx + 0.5 - pw / 2.0, cy + 0.5 - ph / 2.0);
            sampler.sample(0, x0, y0, sx, sy, &mut self.patch, self.mw, self.mh)?;
            for v in self.patch.iter_mut() {
                *v *= 1.0 / 255.0;
            }
            self.hog.compute(&self.patch, &mut self.feat)?;
            let w = self.window[n];
            for (d, &v) in self.feat.iter().enumerate() {
                self.xs[d * s + n] = C32::new(v * w, 0.0);
            }
        }
        self.fwd
            .process_with_scratch(&mut self.xs, &mut self.scratch);
        Ok(())
    }

    /// Learns the scale model at `(cx, cy)` and `scale` with `rate` (the
    /// first call takes the sample whole).
    ///
    /// # Errors
    /// Image errors from the sampler (an empty frame).
    pub fn train(
        &mut self,
        sampler: &mut PatchSampler,
        cx: f64,
        cy: f64,
        scale: f64,
        rate: f64,
    ) -> Result<()> {
        self.sample(sampler, cx, cy, scale)?;
        let s = self.config.scales;
        let r = if self.trained { rate as f32 } else { 1.0 };
        for n in 0..s {
            self.den[n] *= 1.0 - r;
        }
        for (d, row) in self.xs.chunks_exact(s).enumerate() {
            let num = &mut self.num[d * s..(d + 1) * s];
            for n in 0..s {
                let x = row[n];
                num[n] = num[n] * (1.0 - r) + self.ysf[n] * x.conj() * r;
                self.den[n] += r * x.norm_sqr();
            }
        }
        self.trained = true;
        Ok(())
    }

    /// The scale change at `(cx, cy)` from `scale`: the relative factor of
    /// the best of the sampled scales, refined by a parabola through the
    /// neighbouring responses (in log scale), and the response's peak.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] before any training; sampler errors.
    pub fn detect(
        &mut self,
        sampler: &mut PatchSampler,
        cx: f64,
        cy: f64,
        scale: f64,
    ) -> Result<(f64, f32)> {
        if !self.trained {
            return Err(DcfError::NotInitialised);
        }
        self.sample(sampler, cx, cy, scale)?;
        let s = self.config.scales;
        self.resp.fill(C32::default());
        for (row, num) in self.xs.chunks_exact(s).zip(self.num.chunks_exact(s)) {
            for n in 0..s {
                self.resp[n] += num[n] * row[n];
            }
        }
        let lambda = self.config.lambda as f32;
        for n in 0..s {
            self.resp[n] /= self.den[n] + lambda;
        }
        self.inv
            .process_with_scratch(&mut self.resp, &mut self.scratch);
        // the label peaks at the middle scale: the response peaks at the
        // index of the sample whose scale matches the model
        let mut best = (f32::NEG_INFINITY, 0usize);
        for (n, v) in self.resp.iter().enumerate() {
            if v.re > best.0 {
                best = (v.re, n);
            }
        }
        if !best.0.is_finite() {
            return Err(DcfError::NonFinite {
                what: "scale response",
            });
        }
        let n = best.1;
        let off = if n > 0 && n + 1 < s {
            parabola_offset(self.resp[n - 1].re, best.0, self.resp[n + 1].re)
        } else {
            0.0
        };
        // sample n has the factor step^(floor(S/2) - n)
        let factor = self.config.step.powf((s / 2) as f64 - (n as f64 + off));
        Ok((factor, best.0 / s as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    fn sampler(z: f64) -> PatchSampler {
        let mut s = PatchSampler::new();
        s.load(frame(z).view()).unwrap();
        s
    }

    /// A textured blob centred at (80, 60) with a size factor `z`.
    fn frame(z: f64) -> Image<u8> {
        Image::from_fn(160, 120, |x, y| {
            let (u, v) = ((x as f64 - 80.0) / z, (y as f64 - 60.0) / z);
            let inside = u.abs() < 20.0 && v.abs() < 14.0;
            let t = if inside {
                128.0 + 60.0 * (0.5 * u).sin() * (0.4 * v).cos() + 40.0 * (0.21 * (u + v)).sin()
            } else {
                100.0 + 20.0 * ((x as f64) * 0.37).sin() + 20.0 * ((y as f64) * 0.23).cos()
            };
            t.clamp(0.0, 255.0) as u8
        })
        .unwrap()
    }

    #[test]
    fn estimates_a_zoom_within_one_step() {
        let mut f = ScaleFilter::new(ScaleConfig::default(), 40.0, 28.0).unwrap();
        let mut s0 = sampler(1.0);
        f.train(&mut s0, 79.5, 59.5, 1.0, 0.025).unwrap();
        for zoom in [1.04, 1.0 / 1.04, 1.0, 1.1] {
            let mut s1 = sampler(zoom);
            let (factor, _) = f.detect(&mut s1, 79.5, 59.5, 1.0).unwrap();
            let err = (factor.ln() - zoom.ln()).abs() / 1.02f64.ln();
            assert!(
                err < 1.0,
                "zoom {zoom}: factor {factor:.4}, {err:.2} steps off"
            );
        }
        // at the right scale already: no change
        let mut s1 = sampler(1.04);
        let (factor, _) = f.detect(&mut s1, 79.5, 59.5, 1.04).unwrap();
        assert!((factor - 1.0).abs() < 0.02, "{factor}");
    }

    #[test]
    fn errors() {
        assert!(ScaleFilter::new(ScaleConfig::default(), 0.0, 10.0).is_err());
        let bad = ScaleConfig {
            step: 1.0,
            ..ScaleConfig::default()
        };
        assert!(ScaleFilter::new(bad, 10.0, 10.0).is_err());
        let mut f = ScaleFilter::new(ScaleConfig::default(), 20.0, 20.0).unwrap();
        let mut s = sampler(1.0);
        assert!(matches!(
            f.detect(&mut s, 50.0, 50.0, 1.0),
            Err(DcfError::NotInitialised)
        ));
    }
}
