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

use bayestrack_image::simd::{Kernel, Token, dispatch};
use rustfft::{Fft, FftPlanner};

use crate::error::{DcfError, Result};
use crate::features::Fhog;
use crate::fft::C32;
use crate::kcf::{hann, parabola_offset};
use crate::sample::{PatchSampler, Region};

/// How the scale filter is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScaleMethod {
    /// DSST (Danelljan et al. 2014): one filter per feature over the `S`
    /// sampled scales, label peaked at the middle scale of width
    /// `sqrt(S) * sigma_factor` scale steps.
    Dsst,
    /// fDSST (Danelljan et al. 2017, sec. 4.3): the `S` samples are spread
    /// over the range of `interpolated` scales (exponents
    /// `(n - floor((S - 1) / 2)) * interpolated / S` of the step), their
    /// features projected on an orthonormal basis of the learnt sample
    /// matrix (its QR factor: `S` dimensions instead of thousands), the
    /// label `interpolated * sigma_factor` steps wide, and the response
    /// interpolated in the Fourier domain to `interpolated` scales one step
    /// apart (fDSST: 17 sampled, 33 interpolated).
    Fdsst {
        /// Scales of the interpolated response (fDSST: 33).
        interpolated: usize,
    },
}

/// DSST's scale parameters (the paper's published values as defaults;
/// [`ScaleConfig::fdsst`] gives fDSST's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleConfig {
    /// Number of scales `S` sampled (DSST: 33; fDSST: 17).
    pub scales: usize,
    /// Ratio `a` between neighbouring scales (DSST: 1.02).
    pub step: f64,
    /// Label width as a fraction of `sqrt(S)` (DSST: 1/4) or, for fDSST,
    /// of the interpolated scales (fDSST: 1/16).
    pub sigma_factor: f64,
    /// Regularisation `lambda` (DSST: 1e-2).
    pub lambda: f64,
    /// Learning rate (DSST: 0.025).
    pub learning_rate: f64,
    /// Largest area of the resized scale samples, pixels (DSST: 512).
    pub model_max_area: f64,
    /// Cell of the samples' fHOG, pixels (DSST: 4).
    pub cell: usize,
    /// DSST or fDSST.
    pub method: ScaleMethod,
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
            method: ScaleMethod::Dsst,
        }
    }
}

impl ScaleConfig {
    /// fDSST's published parameters (Danelljan et al. 2017, sec. 5.1 and
    /// its code: 17 scales interpolated to 33, step 1.02, label factor
    /// 1/16, lambda 1e-2, learning rate 0.025, samples of at most 512
    /// pixels).
    pub fn fdsst() -> Self {
        Self {
            scales: 17,
            sigma_factor: 1.0 / 16.0,
            method: ScaleMethod::Fdsst { interpolated: 33 },
            ..Self::default()
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
        if let ScaleMethod::Fdsst { interpolated } = self.method
            && !(self.scales..=1023).contains(&interpolated)
        {
            return bad(
                "interpolated scales",
                interpolated as f64,
                "must be at least the sampled scales and at most 1023",
            );
        }
        Ok(())
    }
}

/// The scale filter of one target (its model size fixed at creation).
#[derive(Clone)]
pub struct ScaleFilter {
    config: ScaleConfig,
    /// Relative scale of each sample: DSST `a^(floor(S/2) - n)`, fDSST
    /// `a^((n - floor((S-1)/2)) I / S)`.
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
    /// The raw samples, `S` rows of `dims` features.
    raw: Vec<f32>,
    xs: Vec<C32>,
    /// DSST: per feature `dims x S`; fDSST: per basis vector `S x S`.
    num: Vec<C32>,
    den: Vec<f32>,
    resp: Vec<C32>,
    /// fDSST: the learnt sample matrix (`S x dims`), its orthonormal basis
    /// (`S x dims`, rows), the projected samples' spectra (`S x S`), and
    /// the inverse FFT of the interpolated response.
    snum: Vec<f32>,
    basis: Vec<f32>,
    proj: Vec<C32>,
    gs: Vec<f64>,
    interp_inv: Option<Arc<dyn Fft<f32>>>,
    interp: Vec<C32>,
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

/// `a . b` in eight lanes (vectorises; a fixed order, so the same bits on
/// any machine for a given build).
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
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
        let (factors, ys, interpolated): (Vec<f64>, Vec<f64>, usize) = match config.method {
            ScaleMethod::Dsst => {
                let half = (s / 2) as f64;
                let sigma = (s as f64).sqrt() * config.sigma_factor;
                // label over the scales, peaked at the middle one
                let mid = s / 2;
                (
                    (0..s).map(|n| config.step.powf(half - n as f64)).collect(),
                    (0..s)
                        .map(|n| {
                            let d = n as f64 - mid as f64;
                            (-0.5 * d * d / (sigma * sigma)).exp()
                        })
                        .collect(),
                    0,
                )
            }
            ScaleMethod::Fdsst { interpolated } => {
                let mid = (s - 1) / 2;
                let spread = interpolated as f64 / s as f64;
                let exp = |n: usize| (n as f64 - mid as f64) * spread;
                let sigma = interpolated as f64 * config.sigma_factor;
                (
                    (0..s).map(|n| config.step.powf(exp(n))).collect(),
                    // the label peaks at index 0 (fDSST's circshift)
                    (0..s)
                        .map(|n| {
                            let d = exp((n + mid) % s);
                            (-0.5 * d * d / (sigma * sigma)).exp()
                        })
                        .collect(),
                    interpolated,
                )
            }
        };
        let mut planner = FftPlanner::<f32>::new();
        let fwd = planner.plan_fft_forward(s);
        let inv = planner.plan_fft_inverse(s);
        let interp_inv = (interpolated > 0).then(|| planner.plan_fft_inverse(interpolated));
        let mut scratch_len = fwd
            .get_inplace_scratch_len()
            .max(inv.get_inplace_scratch_len());
        if let Some(p) = &interp_inv {
            scratch_len = scratch_len.max(p.get_inplace_scratch_len());
        }
        let mut scratch = vec![C32::default(); scratch_len];
        let mut ysf: Vec<C32> = ys.iter().map(|&v| C32::new(v as f32, 0.0)).collect();
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
        // hann(S + 1) without its first value for even S; fDSST's hann(S)
        let window = if s < 3 {
            vec![1.0; s]
        } else if s % 2 == 1 || interpolated > 0 {
            hann(s)
        } else {
            hann(s + 1)[1..].to_vec()
        };
        let fdsst = interpolated > 0;
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
            raw: vec![0.0; dims * s],
            hog,
            xs: vec![C32::default(); dims * s],
            num: vec![C32::default(); if fdsst { s * s } else { dims * s }],
            den: vec![0.0; s],
            resp: vec![C32::default(); s],
            snum: if fdsst {
                vec![0.0; dims * s]
            } else {
                Vec::new()
            },
            basis: if fdsst {
                vec![0.0; dims * s]
            } else {
                Vec::new()
            },
            proj: if fdsst {
                vec![C32::default(); s * s]
            } else {
                Vec::new()
            },
            gs: if fdsst { vec![0.0; dims] } else { Vec::new() },
            interp_inv,
            interp: vec![C32::default(); interpolated],
            trained: false,
        })
    }

    /// The relative scales sampled (DSST: largest first; fDSST: smallest
    /// first).
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

    /// Sample `n`'s origin and steps around `(cx, cy)` at `scale`.
    fn origin(&self, n: usize, cx: f64, cy: f64, scale: f64) -> (f64, f64, f64, f64) {
        let f = scale * self.factors[n];
        let (pw, ph) = (self.base.0 * f, self.base.1 * f);
        let (sx, sy) = (pw / self.mw as f64, ph / self.mh as f64);
        let (x0, y0) = (cx + 0.5 - pw / 2.0, cy + 0.5 - ph / 2.0);
        (x0, y0, sx, sy)
    }

    /// The pixels of a `w x h` frame that the scale samples around
    /// `(cx, cy)` at `scale` read (`None` for an empty frame or a
    /// non-finite centre or scale).
    pub fn region(&self, w: usize, h: usize, cx: f64, cy: f64, scale: f64) -> Option<Region> {
        let mut out = Region::default();
        for n in 0..self.config.scales {
            let (x0, y0, sx, sy) = self.origin(n, cx, cy, scale);
            let r = Region::of_sample(w, h, x0, y0, sx, sy, self.mw, self.mh)?;
            out = out.union(&r);
        }
        Some(out)
    }

    /// Samples the scales around `(cx, cy)` at `scale` (0-based pixel
    /// centre; `sampler` holds the frame's gray levels): the raw features
    /// of each, one row per scale.
    fn sample_raw(
        &mut self,
        sampler: &mut PatchSampler,
        cx: f64,
        cy: f64,
        scale: f64,
    ) -> Result<()> {
        let s = self.config.scales;
        let dims = self.hog.len();
        let (w, h) = (sampler.width(), sampler.height());
        for n in 0..s {
            let (x0, y0, sx, sy) = self.origin(n, cx, cy, scale);
            if let Some(r) = Region::of_sample(w, h, x0, y0, sx, sy, self.mw, self.mh)
                && !sampler.holds(&r)
            {
                return Err(DcfError::InvalidParameter {
                    name: "sample region",
                    value: n as f64,
                    reason: "reads outside the region of the frame loaded",
                });
            }
            // the gray levels in [0, 1]
            sampler.sample_scaled(
                0,
                x0,
                y0,
                sx,
                sy,
                &mut self.patch,
                self.mw,
                self.mh,
                1.0 / 255.0,
            )?;
            self.hog
                .compute(&self.patch, &mut self.raw[n * dims..][..dims])?;
        }
        Ok(())
    }

    /// The windowed raw samples' spectra along the scale axis, per feature
    /// (`xs`). The transpose goes eight features at a time (one load of
    /// eight values per scale, eight rows written), the values as before.
    fn spectra(&mut self) {
        let s = self.config.scales;
        let dims = self.hog.len();
        dispatch(Transpose {
            s,
            dims,
            raw: &self.raw[..s * dims],
            window: &self.window[..s],
            xs: &mut self.xs[..dims * s],
        });
        self.fwd
            .process_with_scratch(&mut self.xs, &mut self.scratch);
    }

    /// fDSST: the rows of `src` (`S x dims`) projected on the basis,
    /// windowed, transformed along the scales into `proj` (`S x S`: basis
    /// vector by frequency).
    fn project(&mut self, learnt: bool) {
        let s = self.config.scales;
        let dims = self.hog.len();
        let src = if learnt { &self.snum } else { &self.raw };
        for k in 0..s {
            let q = &self.basis[k * dims..][..dims];
            for n in 0..s {
                let v = dot(q, &src[n * dims..][..dims]) * self.window[n];
                self.proj[k * s + n] = C32::new(v, 0.0);
            }
        }
        self.fwd
            .process_with_scratch(&mut self.proj, &mut self.scratch);
    }

    /// fDSST: an orthonormal basis of the learnt samples' span (modified
    /// Gram-Schmidt in f64 on the rows of `snum`: the QR factor of fDSST's
    /// code up to signs, which cancel in the filter); a row dependent on
    /// the earlier ones gets a zero basis vector.
    fn orthonormalise(&mut self) {
        let s = self.config.scales;
        let dims = self.hog.len();
        for j in 0..s {
            let (done, rest) = self.basis.split_at_mut(j * dims);
            let row = &self.snum[j * dims..][..dims];
            for (g, &v) in self.gs.iter_mut().zip(row) {
                *g = f64::from(v);
            }
            let norm0 = self.gs.iter().map(|v| v * v).sum::<f64>().sqrt();
            for q in done.chunks_exact(dims) {
                let r: f64 = q.iter().zip(&self.gs).map(|(&a, b)| f64::from(a) * b).sum();
                for (g, &a) in self.gs.iter_mut().zip(q) {
                    *g -= r * f64::from(a);
                }
            }
            let norm = self.gs.iter().map(|v| v * v).sum::<f64>().sqrt();
            let out = &mut rest[..dims];
            if norm > 1e-6 * norm0 && norm > 1e-30 {
                for (o, g) in out.iter_mut().zip(&self.gs) {
                    *o = (g / norm) as f32;
                }
            } else {
                out.fill(0.0);
            }
        }
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
        self.sample_raw(sampler, cx, cy, scale)?;
        self.spectra();
        let s = self.config.scales;
        let r = if self.trained { rate as f32 } else { 1.0 };
        let fdsst = self.interp_inv.is_some();
        dispatch(Learn {
            s,
            r,
            xs: &self.xs,
            ysf: &self.ysf[..s],
            den: &mut self.den[..s],
            // DSST learns the numerator in the same pass
            num: (!fdsst).then_some(&mut self.num[..]),
        });
        if fdsst {
            // fDSST: learn the sample matrix, then the filter of its
            // projection on its own basis
            for (m, &x) in self.snum.iter_mut().zip(&self.raw) {
                *m = *m * (1.0 - r) + r * x;
            }
            self.orthonormalise();
            self.project(true);
            for (num, p) in self.num.chunks_exact_mut(s).zip(self.proj.chunks_exact(s)) {
                for n in 0..s {
                    num[n] = self.ysf[n] * p[n].conj();
                }
            }
        }
        self.trained = true;
        Ok(())
    }

    /// The scale change at `(cx, cy)` from `scale`: the relative factor of
    /// the best of the sampled (DSST) or interpolated (fDSST) scales,
    /// refined by a parabola through the neighbouring responses (in log
    /// scale), and the response's peak.
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
        self.sample_raw(sampler, cx, cy, scale)?;
        let s = self.config.scales;
        self.resp.fill(C32::default());
        if self.interp_inv.is_some() {
            self.project(false);
            for (p, num) in self.proj.chunks_exact(s).zip(self.num.chunks_exact(s)) {
                for n in 0..s {
                    self.resp[n] += num[n] * p[n];
                }
            }
        } else {
            self.spectra();
            dispatch(Respond {
                xs: &self.xs,
                num: &self.num,
                resp: &mut self.resp[..s],
            });
        }
        let lambda = self.config.lambda as f32;
        for n in 0..s {
            self.resp[n] /= self.den[n] + lambda;
        }
        if let Some(interp_inv) = &self.interp_inv {
            return self.interpolated(interp_inv.clone());
        }
        self.inv
            .process_with_scratch(&mut self.resp, &mut self.scratch);
        // the label peaks at the middle scale: the response peaks at the
        // index of the sample whose scale matches the model
        let (n, best) = argmax(&self.resp)?;
        let off = if n > 0 && n + 1 < s {
            parabola_offset(self.resp[n - 1].re, best, self.resp[n + 1].re)
        } else {
            0.0
        };
        // sample n has the factor step^(floor(S/2) - n)
        let factor = self.config.step.powf((s / 2) as f64 - (n as f64 + off));
        Ok((factor, best / s as f32))
    }

    /// fDSST: the response's spectrum zero-padded to the interpolated
    /// scales (fDSST's `resizeDFT`), back to scales one step apart; the
    /// peak's index (cyclic, 0 = no change) is the exponent of the step.
    fn interpolated(&mut self, inv: Arc<dyn Fft<f32>>) -> Result<(f64, f32)> {
        let (s, ni) = (self.config.scales, self.interp.len());
        let k = ni as f32 / s as f32;
        let mids = s.div_ceil(2);
        let mide = (s - 1) / 2;
        self.interp.fill(C32::default());
        for i in 0..mids {
            self.interp[i] = self.resp[i] * k;
        }
        for i in 0..mide {
            self.interp[ni - mide + i] = self.resp[s - mide + i] * k;
        }
        inv.process_with_scratch(&mut self.interp, &mut self.scratch);
        let (n, best) = argmax(&self.interp)?;
        let at = |i: usize| self.interp[i % ni].re;
        let off = if ni >= 3 {
            parabola_offset(at(n + ni - 1), best, at(n + 1))
        } else {
            0.0
        };
        let e = if n <= (ni - 1) / 2 {
            n as f64
        } else {
            n as f64 - ni as f64
        };
        Ok((self.config.step.powf(e + off), best / ni as f32))
    }
}

/// The windowed samples transposed into the spectra's rows (`xs`: row
/// `d` holds feature `d` of every scale), eight features at a time (one
/// load of eight values per scale, eight rows written).
struct Transpose<'a> {
    s: usize,
    dims: usize,
    raw: &'a [f32],
    window: &'a [f32],
    xs: &'a mut [C32],
}

impl Kernel for Transpose<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        const B: usize = 8;
        let (s, dims, raw) = (self.s, self.dims, self.raw);
        let window = &self.window[..s];
        let full = dims / B * B;
        let (head, tail) = self.xs.split_at_mut(full * s);
        for (b, block) in head.chunks_exact_mut(B * s).enumerate() {
            let mut rows = block.chunks_exact_mut(s);
            let mut rows: [&mut [C32]; B] =
                std::array::from_fn(|_| rows.next().unwrap_or_default());
            for (n, &w) in window.iter().enumerate() {
                let v = &raw[n * dims + b * B..][..B];
                for (row, &v) in rows.iter_mut().zip(v) {
                    row[n] = C32::new(v * w, 0.0);
                }
            }
        }
        for (k, row) in tail.chunks_exact_mut(s).enumerate() {
            for (n, (o, &w)) in row.iter_mut().zip(window).enumerate() {
                *o = C32::new(raw[n * dims + full + k] * w, 0.0);
            }
        }
    }
}

/// The learning step over the spectra: the denominator decayed by `r` and
/// each row's energy added (in row order), and for DSST the numerator
/// interpolated towards the label times each row's conjugate.
struct Learn<'a> {
    s: usize,
    r: f32,
    xs: &'a [C32],
    ysf: &'a [C32],
    den: &'a mut [f32],
    num: Option<&'a mut [C32]>,
}

impl Kernel for Learn<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let (s, r) = (self.s, self.r);
        let (den, ysf) = (&mut self.den[..s], &self.ysf[..s]);
        for d in den.iter_mut() {
            *d *= 1.0 - r;
        }
        match self.num {
            Some(num) => {
                for (row, num) in self.xs.chunks_exact(s).zip(num.chunks_exact_mut(s)) {
                    for ((d, x), (m, &y)) in den.iter_mut().zip(row).zip(num.iter_mut().zip(ysf)) {
                        *d += r * x.norm_sqr();
                        *m = *m * (1.0 - r) + y * x.conj() * r;
                    }
                }
            }
            None => {
                for row in self.xs.chunks_exact(s) {
                    for (d, x) in den.iter_mut().zip(row) {
                        *d += r * x.norm_sqr();
                    }
                }
            }
        }
    }
}

/// DSST's response spectrum: the sum over the rows of the numerator times
/// the sample's spectrum (row after row, per scale).
struct Respond<'a> {
    xs: &'a [C32],
    num: &'a [C32],
    resp: &'a mut [C32],
}

impl Kernel for Respond<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let s = self.resp.len();
        for (row, num) in self.xs.chunks_exact(s).zip(self.num.chunks_exact(s)) {
            for ((r, &a), &b) in self.resp.iter_mut().zip(num).zip(row) {
                *r += a * b;
            }
        }
    }
}

/// The index and real part of the largest real part.
fn argmax(v: &[C32]) -> Result<(usize, f32)> {
    let mut best = (f32::NEG_INFINITY, 0usize);
    for (n, c) in v.iter().enumerate() {
        if c.re > best.0 {
            best = (c.re, n);
        }
    }
    if !best.0.is_finite() {
        return Err(DcfError::NonFinite {
            what: "scale response",
        });
    }
    Ok((best.1, best.0))
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
    fn fdsst_estimates_a_zoom_within_one_step() {
        let mut f = ScaleFilter::new(ScaleConfig::fdsst(), 40.0, 28.0).unwrap();
        assert_eq!(f.factors().len(), 17);
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
        let mut s1 = sampler(1.04);
        let (factor, _) = f.detect(&mut s1, 79.5, 59.5, 1.04).unwrap();
        assert!((factor - 1.0).abs() < 0.02, "{factor}");
    }

    #[test]
    fn fdsst_basis_is_orthonormal() {
        let mut f = ScaleFilter::new(ScaleConfig::fdsst(), 40.0, 28.0).unwrap();
        let mut s0 = sampler(1.0);
        f.train(&mut s0, 79.5, 59.5, 1.0, 0.025).unwrap();
        let dims = f.hog.len();
        for i in 0..17 {
            for j in 0..17 {
                let d = dot(&f.basis[i * dims..][..dims], &f.basis[j * dims..][..dims]);
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-4, "q{i} . q{j} = {d}");
            }
        }
    }

    /// Pseudo-random values in [-1, 1].
    fn noise(n: usize, seed: u32) -> Vec<f32> {
        crate::fft::tests::signal(n, 1, seed)
    }

    #[test]
    fn kernels_match_the_loops_as_first_written() {
        // feature counts with and without a partial block of eight
        for (dims, s) in [(837, 33), (31, 33), (5, 7), (16, 17)] {
            let raw = noise(dims * s, 1);
            let window = noise(s, 2);
            // the transpose: feature d of scale n at xs[d * s + n]
            let mut got = vec![C32::default(); dims * s];
            dispatch(Transpose {
                s,
                dims,
                raw: &raw,
                window: &window,
                xs: &mut got,
            });
            for d in 0..dims {
                for n in 0..s {
                    let want = raw[n * dims + d] * window[n];
                    let g = got[d * s + n];
                    assert_eq!((g.re.to_bits(), g.im), (want.to_bits(), 0.0), "{d} {n}");
                }
            }
            let xs: Vec<C32> = noise(2 * dims * s, 3)
                .chunks_exact(2)
                .map(|p| C32::new(p[0], p[1]))
                .collect();
            let ysf: Vec<C32> = noise(2 * s, 4)
                .chunks_exact(2)
                .map(|p| C32::new(p[0], p[1]))
                .collect();
            let num0: Vec<C32> = noise(2 * dims * s, 5)
                .chunks_exact(2)
                .map(|p| C32::new(p[0], p[1]))
                .collect();
            let den0: Vec<f32> = noise(s, 6).iter().map(|v| v.abs()).collect();
            let r = 0.025f32;
            // learning: the denominator, then the numerator, as written first
            let mut den = den0.clone();
            for d in den.iter_mut() {
                *d *= 1.0 - r;
            }
            for row in xs.chunks_exact(s) {
                for (d, x) in den.iter_mut().zip(row) {
                    *d += r * x.norm_sqr();
                }
            }
            let mut num = num0.clone();
            for d in 0..dims {
                for n in 0..s {
                    num[d * s + n] = num[d * s + n] * (1.0 - r) + ysf[n] * xs[d * s + n].conj() * r;
                }
            }
            let (mut got_den, mut got_num) = (den0.clone(), num0.clone());
            dispatch(Learn {
                s,
                r,
                xs: &xs,
                ysf: &ysf,
                den: &mut got_den,
                num: Some(&mut got_num),
            });
            let bits = |v: &[C32]| {
                v.iter()
                    .map(|c| (c.re.to_bits(), c.im.to_bits()))
                    .collect::<Vec<_>>()
            };
            let fbits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(fbits(&got_den), fbits(&den));
            assert_eq!(bits(&got_num), bits(&num));
            // fDSST's call: the denominator alone
            let mut only_den = den0.clone();
            dispatch(Learn {
                s,
                r,
                xs: &xs,
                ysf: &ysf,
                den: &mut only_den,
                num: None,
            });
            assert_eq!(fbits(&only_den), fbits(&den));
            // the response: rows summed in order
            let mut resp = vec![C32::default(); s];
            for d in 0..dims {
                for n in 0..s {
                    resp[n] += num[d * s + n] * xs[d * s + n];
                }
            }
            let mut got_resp = vec![C32::default(); s];
            dispatch(Respond {
                xs: &xs,
                num: &num,
                resp: &mut got_resp,
            });
            assert_eq!(bits(&got_resp), bits(&resp));
        }
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
