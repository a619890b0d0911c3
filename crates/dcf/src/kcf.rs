//! The kernelized correlation filter of Henriques et al. 2015 (KCF): the
//! cosine window, the Gaussian label map, linear and Gaussian kernel
//! correlation of multi-channel features in the Fourier domain, the
//! closed-form ridge regression and its detection response.
//!
//! With `x` the (windowed) training features, `y` the label map and `k`
//! a kernel, KCF learns `alpha_hat = y_hat / (k_hat^{xx} + lambda)` and
//! scores new features `z` at every cyclic shift by
//! `f(z) = F^-1(k_hat^{xz} . alpha_hat)`; the model is interpolated from
//! frame to frame with a learning rate.

use bayestrack_image::simd::{Kernel as SimdKernel, SimdLevel, Token, dispatch};

use crate::confidence::sum_in_order;
use crate::error::{DcfError, Result, check_rate};
use crate::fft::{C32, Fft2};

/// The Hann window of length `n` as KCF builds it (`hann(n)` of MATLAB:
/// `0.5 (1 - cos(2 pi k / (n - 1)))`, zero at both ends); 1 for `n = 1`.
pub fn hann(n: usize) -> Vec<f32> {
    if n == 1 {
        return vec![1.0];
    }
    (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / (n - 1) as f64;
            (0.5 * (1.0 - t.cos())) as f32
        })
        .collect()
}

/// The `w x h` cosine window (outer product of Hann windows), row-major.
pub fn cosine_window(w: usize, h: usize) -> Vec<f32> {
    let (hx, hy) = (hann(w), hann(h));
    hy.iter()
        .flat_map(|&a| hx.iter().map(move |&b| a * b))
        .collect()
}

/// The signed cyclic offset of index `i` in `0..n` from 0: `i` for
/// `i <= n / 2`, else `i - n`.
pub fn wrapped(i: usize, n: usize) -> isize {
    if i <= n / 2 {
        i as isize
    } else {
        i as isize - n as isize
    }
}

/// KCF's regression target: a Gaussian of standard deviation `sigma`
/// (cells) with its peak (1) at the origin and wrapping around the edges,
/// `w x h` row-major.
pub fn gaussian_labels(w: usize, h: usize, sigma: f64) -> Vec<f32> {
    let k = -0.5 / (sigma * sigma);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let dy = wrapped(y, h) as f64;
        for x in 0..w {
            let dx = wrapped(x, w) as f64;
            out.push((k * (dx * dx + dy * dy)).exp() as f32);
        }
    }
    out
}

/// The kernel of the correlation filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// `k(x, z) = x . z / (n c)`: the linear kernel, i.e. a multi-channel
    /// MOSSE/DCF in the dual.
    Linear,
    /// `k(x, z) = exp(-|x - z|^2 / (sigma^2 n c))` (KCF's normalisation by
    /// the number of samples `n c`); KCF's HOG default `sigma = 0.5`.
    Gaussian {
        /// Bandwidth.
        sigma: f64,
    },
}

/// Kernel correlation of multi-channel spectra: the Fourier transform of
/// `k(x, P^d z)` for every cyclic shift `d`, with its scratch buffers.
#[derive(Debug, Clone)]
pub struct Correlator {
    fft: Fft2,
    channels: usize,
    spatial: Vec<f32>,
    /// The Gaussian kernel's values at every shift.
    values: Vec<f32>,
    accum: Vec<C32>,
}

impl Correlator {
    /// For `channels` channels of `w x h` features.
    ///
    /// # Errors
    /// As [`Fft2::new`]; zero channels.
    pub fn new(w: usize, h: usize, channels: usize) -> Result<Self> {
        if channels == 0 {
            return Err(DcfError::InvalidParameter {
                name: "channels",
                value: 0.0,
                reason: "must be positive",
            });
        }
        let fft = Fft2::new(w, h)?;
        let s = fft.spectrum_len();
        Ok(Self {
            spatial: vec![0.0; w * h],
            values: vec![0.0; w * h],
            accum: vec![C32::default(); s],
            fft,
            channels,
        })
    }

    /// The FFT plans (to transform features).
    pub fn fft(&mut self) -> &mut Fft2 {
        &mut self.fft
    }

    /// Bins per channel spectrum.
    pub fn spectrum_len(&self) -> usize {
        self.fft.spectrum_len()
    }

    /// Transforms every channel of `features` (`channels` planes of
    /// `w x h`) into `spectra` (`channels` half spectra), returning the
    /// total energy `sum x^2`.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn transform(&mut self, features: &[f32], spectra: &mut [C32]) -> Result<f64> {
        let (n, s) = (self.fft.real_len(), self.fft.spectrum_len());
        if features.len() != n * self.channels || spectra.len() != s * self.channels {
            return Err(DcfError::Size {
                what: "feature channels",
                expected: n * self.channels,
                got: features.len(),
            });
        }
        self.fft.forward_many(features, spectra)?;
        Ok(dispatch(Energy(features)))
    }

    /// `k_hat^{xz}` into `out`: `xf`, `zf` the channels' spectra,
    /// `xx`, `zz` their energies.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn correlate(
        &mut self,
        kernel: Kernel,
        xf: &[C32],
        xx: f64,
        zf: &[C32],
        zz: f64,
        out: &mut [C32],
    ) -> Result<()> {
        let s = self.fft.spectrum_len();
        if xf.len() != s * self.channels || zf.len() != xf.len() || out.len() != s {
            return Err(DcfError::Size {
                what: "kernel correlation",
                expected: s * self.channels,
                got: xf.len(),
            });
        }
        let numel = (self.fft.real_len() * self.channels) as f64;
        // sum over channels of z_hat . conj(x_hat): the cross-correlation
        // whose value at d is sum_p z(p + d) x(p)
        self.accum.fill(C32::default());
        dispatch(ChannelSum {
            xf,
            zf,
            accum: &mut self.accum,
        });
        match kernel {
            Kernel::Linear => {
                let k = (1.0 / numel) as f32;
                for (o, a) in out.iter_mut().zip(&self.accum) {
                    *o = a * k;
                }
            }
            Kernel::Gaussian { sigma } => {
                self.fft.inverse(&mut self.accum, &mut self.spatial)?;
                let inv = 1.0 / (sigma * sigma * numel);
                gaussian_values(
                    SimdLevel::Avx512,
                    xx,
                    zz,
                    inv,
                    &self.spatial,
                    &mut self.values,
                );
                self.fft.forward(&self.values, out)?;
            }
        }
        Ok(())
    }

    /// The real response `F^-1(kf . alphaf)` into `out` (`w x h`).
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn respond(&mut self, kf: &[C32], alphaf: &[C32], out: &mut [f32]) -> Result<()> {
        if kf.len() != self.accum.len() || alphaf.len() != kf.len() {
            return Err(DcfError::Size {
                what: "response spectra",
                expected: self.accum.len(),
                got: kf.len(),
            });
        }
        for ((a, k), al) in self.accum.iter_mut().zip(kf).zip(alphaf) {
            *a = k * al;
        }
        self.fft.inverse(&mut self.accum, out)
    }
}

/// `accum += sum over channels of z_hat . conj(x_hat)`, bin by bin, the
/// channels in order: the same sums as the scalar loop, compiled for the
/// machine's vector width (each bin's products and additions stay in the
/// same order, so every level gives the same bits). [`SUM_BINS`] bins at
/// a time go through every channel with their sums held in registers
/// (not loaded and stored again for each channel).
struct ChannelSum<'a> {
    xf: &'a [C32],
    zf: &'a [C32],
    accum: &'a mut [C32],
}

impl SimdKernel for ChannelSum<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        let s = self.accum.len();
        // blocks of SUM_BINS bins summed over every channel in registers
        // (each bin's sum in channel order, as below), the rest channel
        // by channel
        let (blocks, _) = self.accum.as_chunks_mut::<SUM_BINS>();
        for (b, acc) in blocks.iter_mut().enumerate() {
            let mut t = *acc;
            for (xc, zc) in self.xf.chunks_exact(s).zip(self.zf.chunks_exact(s)) {
                let (x, z) = (
                    &xc[b * SUM_BINS..][..SUM_BINS],
                    &zc[b * SUM_BINS..][..SUM_BINS],
                );
                for ((a, x), z) in t.iter_mut().zip(x).zip(z) {
                    *a += z * x.conj();
                }
            }
            *acc = t;
        }
        let done = blocks.len() * SUM_BINS;
        for (xc, zc) in self.xf.chunks_exact(s).zip(self.zf.chunks_exact(s)) {
            for ((a, x), z) in self.accum[done..]
                .iter_mut()
                .zip(&xc[done..])
                .zip(&zc[done..])
            {
                *a += z * x.conj();
            }
        }
    }
}

/// The Gaussian kernel's exponent at a shift whose cross-correlation is
/// `c`: `-max(xx + zz - 2 c, 0) inv`.
#[inline(always)]
fn gaussian_exponent(xx: f64, zz: f64, inv: f64, c: f32) -> f64 {
    -(xx + zz - 2.0 * c as f64).max(0.0) * inv
}

/// The Gaussian kernel's values `exp(gaussian_exponent(..))` of the
/// cross-correlations `corr` into `out`: libm's `exp` in `f64` rounded to
/// `f32`, bit for bit. A vector pass ([`GaussianValues`]) gives every value
/// whose rounding it can prove; the rest (about one in three thousand, none
/// on most windows) are libm's own call.
fn gaussian_values(level: SimdLevel, xx: f64, zz: f64, inv: f64, corr: &[f32], out: &mut [f32]) {
    let left = level.run(GaussianValues {
        xx,
        zz,
        inv,
        corr,
        out: &mut *out,
    });
    if left {
        for (o, &c) in out.iter_mut().zip(corr) {
            if o.is_nan() {
                *o = gaussian_exponent(xx, zz, inv, c).exp() as f32;
            }
        }
    }
}

/// [`gaussian_values`]' vector pass: each value through
/// [`exp_to_f32_or_nan`], NaN where libm must decide; returns whether any
/// value was left.
struct GaussianValues<'a> {
    xx: f64,
    zz: f64,
    inv: f64,
    corr: &'a [f32],
    out: &'a mut [f32],
}

impl SimdKernel for GaussianValues<'_> {
    type Output = bool;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> bool {
        let Self {
            xx,
            zz,
            inv,
            corr,
            out,
        } = self;
        let mut left = 0u32;
        for (o, &c) in out.iter_mut().zip(corr) {
            let e = exp_to_f32_or_nan(gaussian_exponent(xx, zz, inv, c));
            left |= e.is_nan() as u32;
            *o = e;
        }
        left != 0
    }
}

/// `exp(t)` rounded to `f32` (round to nearest) where the rounding is
/// certain to be that of libm's `t.exp() as f32`, NaN otherwise and for
/// `t` outside `[-700, 700]` or NaN: a branch-free evaluation that
/// vectorises.
///
/// [`exp_approx`]'s `y` is within `2^-40` of `exp(t)` relative to it, and
/// libm's `exp` within an ulp of `f64` (`2^-52`): both lie in
/// `[y (1 - 2^-36), y (1 + 2^-36)]`. When the two ends round to the same
/// `f32`, so does every value between them (rounding is monotonic), libm's
/// included. Otherwise (`y` within `2^-36` of halfway between two `f32`s)
/// NaN hands the value to libm.
#[inline(always)]
fn exp_to_f32_or_nan(t: f64) -> f32 {
    const DELTA: f64 = 1.0 / (1u64 << 36) as f64;
    let y = exp_approx(t);
    let (lo, hi) = ((y * (1.0 - DELTA)) as f32, (y * (1.0 + DELTA)) as f32);
    if (-700.0..=700.0).contains(&t) && lo.to_bits() == hi.to_bits() {
        lo
    } else {
        f32::NAN
    }
}

/// `exp(t)` within `2^-40` relative for `t` in `[-700, 700]`, branch-free:
/// range reduction `t = n ln 2 + r`, `|r| <= ln 2 / 2`, with fdlibm's
/// two-part `ln 2` (`r`'s rounding under `2^-43` relative to `exp(t)`
/// for `|t| <= 700`); the Taylor polynomial of degree 10 (remainder under
/// `2^-41`, Horner's roundings a few `2^-53`); `2^n` from its exponent
/// bits. (Measured: test `exp_approx_is_within_its_bound`.)
#[inline(always)]
fn exp_approx(t: f64) -> f64 {
    // adding 1.5 2^52 rounds to an integer, held in the low mantissa bits
    const SHIFT: f64 = 6755399441055744.0;
    // fdlibm's ln 2 in two parts (the first with 21 trailing zero bits:
    // `n LN2_HI` is exact for |n| < 2^21)
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    let s = t * std::f64::consts::LOG2_E + SHIFT;
    let n = s - SHIFT;
    let r = (t - n * LN2_HI) - n * LN2_LO;
    // 1 + r + r^2/2! + ... + r^10/10!, Horner's scheme
    let mut p = 1.0 / 3_628_800.0;
    for f in [
        362_880.0, 40_320.0, 5_040.0, 720.0, 120.0, 24.0, 6.0, 2.0, 1.0, 1.0,
    ] {
        p = p * r + 1.0 / f;
    }
    // 2^n from its exponent bits (n is the integer in s's low bits)
    let k = (s.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64);
    p * f64::from_bits((k.wrapping_add(1023) as u64) << 52)
}

/// Bins of [`ChannelSum`] summed over the channels at once (four AVX2
/// vectors of `C32`).
const SUM_BINS: usize = 16;

/// Parseval's `sum |X|^2` over half spectra of `w x h` arrays
/// (column-major, `w / 2 + 1` columns of `h` bins, one spectrum after the
/// other), the columns other than the first and (for even `w`) the last
/// counted twice: one running `f64` sum in bin order
/// ([`sum_in_order`]: the terms `k |X|^2` of eight bins side by side in
/// vector lanes, added one after the other as in the plain loop).
struct SpectrumEnergy<'a> {
    spectra: &'a [C32],
    w: usize,
    h: usize,
}

impl SimdKernel for SpectrumEnergy<'_> {
    type Output = f64;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> f64 {
        let Self { spectra, w, h } = self;
        let wc = w / 2 + 1;
        let mut e = 0.0f64;
        for c in spectra.chunks_exact(wc * h) {
            for (u, col) in c.chunks_exact(h).enumerate() {
                let twice = u != 0 && !(w % 2 == 0 && u == wc - 1);
                let k = if twice { 2.0 } else { 1.0 };
                sum_in_order(&mut e, col, |v| k * v.norm_sqr() as f64);
            }
        }
        e
    }
}

/// `sum x^2` over `x` in `f64` (each square exact) as [`ENERGY_LANES`]
/// interleaved partial sums, value `i` into sum `i mod ENERGY_LANES`, added
/// pairwise at the end: as many chains of additions side by side instead
/// of one, which ran at the latency of an addition per value (a tenth of
/// a detection's time on 16 x 40 x 31 features). Every level gives the
/// same bits (lane-wise additions in the same order).
struct Energy<'a>(&'a [f32]);

/// Partial sums of [`Energy`] (two AVX2 vectors of `f64`).
const ENERGY_LANES: usize = 8;

impl SimdKernel for Energy<'_> {
    type Output = f64;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> f64 {
        let mut acc = [0.0f64; ENERGY_LANES];
        let (chunks, tail) = self.0.as_chunks::<ENERGY_LANES>();
        for c in chunks {
            for (a, &v) in acc.iter_mut().zip(c) {
                *a += v as f64 * v as f64;
            }
        }
        for (a, &v) in acc.iter_mut().zip(tail) {
            *a += v as f64 * v as f64;
        }
        let [a0, a1, a2, a3, a4, a5, a6, a7] = acc;
        ((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7))
    }
}

/// Sub-cell offset of a peak from its two neighbours, in `[-0.5, 0.5]`:
/// the vertex of the parabola through `(-1, ln a)`, `(0, ln b)`,
/// `(1, ln c)` when all three are positive (exact for a Gaussian peak,
/// which is what the filter is trained to produce), else through the
/// values themselves; 0 when they are not concave.
pub fn parabola_offset(a: f32, b: f32, c: f32) -> f64 {
    let (a, b, c) = (a as f64, b as f64, c as f64);
    let (a, b, c) = if a > 0.0 && b > 0.0 && c > 0.0 {
        (a.ln(), b.ln(), c.ln())
    } else {
        (a, b, c)
    };
    let d = a - 2.0 * b + c;
    if d < 0.0 {
        (0.5 * (a - c) / d).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// The peak of a `w x h` cyclic response: its value and its displacement
/// from the origin in cells, sub-cell by a parabola along each axis.
pub fn subcell_peak(response: &[f32], w: usize, h: usize) -> (f32, f64, f64) {
    let (max, i) = crate::confidence::peak(response);
    let (px, py) = (i % w, i / w);
    let at = |x: usize, y: usize| response[y * w + x];
    let dx = if w >= 3 {
        parabola_offset(at((px + w - 1) % w, py), max, at((px + 1) % w, py))
    } else {
        0.0
    };
    let dy = if h >= 3 {
        parabola_offset(at(px, (py + h - 1) % h), max, at(px, (py + 1) % h))
    } else {
        0.0
    };
    (max, wrapped(px, w) as f64 + dx, wrapped(py, h) as f64 + dy)
}

/// KCF's closed-form model: the features' spectra `x_hat` and the dual
/// coefficients `alpha_hat`, interpolated with a learning rate.
#[derive(Debug, Clone)]
pub struct KcfModel {
    /// The kernel.
    pub kernel: Kernel,
    /// Ridge regularisation `lambda` (KCF: 1e-4).
    pub lambda: f64,
    w: usize,
    h: usize,
    channels: usize,
    corr: Correlator,
    yf: Vec<C32>,
    xf: Vec<C32>,
    xx: f64,
    alphaf: Vec<C32>,
    // scratch
    zf: Vec<C32>,
    kf: Vec<C32>,
    trained: bool,
}

impl KcfModel {
    /// A model for `channels` channels of `w x h` cells with labels of
    /// standard deviation `sigma` cells.
    ///
    /// # Errors
    /// As [`Correlator::new`]; a non-positive `sigma` or negative `lambda`.
    pub fn new(
        w: usize,
        h: usize,
        channels: usize,
        sigma: f64,
        kernel: Kernel,
        lambda: f64,
    ) -> Result<Self> {
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(DcfError::InvalidParameter {
                name: "label sigma",
                value: sigma,
                reason: "must be positive",
            });
        }
        if !(lambda.is_finite() && lambda >= 0.0) {
            return Err(DcfError::InvalidParameter {
                name: "lambda",
                value: lambda,
                reason: "must be finite and >= 0",
            });
        }
        if let Kernel::Gaussian { sigma } = kernel
            && !(sigma.is_finite() && sigma > 0.0)
        {
            return Err(DcfError::InvalidParameter {
                name: "kernel sigma",
                value: sigma,
                reason: "must be positive",
            });
        }
        let mut corr = Correlator::new(w, h, channels)?;
        let s = corr.spectrum_len();
        let y = gaussian_labels(w, h, sigma);
        let mut yf = vec![C32::default(); s];
        corr.fft().forward(&y, &mut yf)?;
        Ok(Self {
            kernel,
            lambda,
            w,
            h,
            channels,
            corr,
            yf,
            xf: vec![C32::default(); s * channels],
            xx: 0.0,
            alphaf: vec![C32::default(); s],
            zf: vec![C32::default(); s * channels],
            kf: vec![C32::default(); s],
            trained: false,
        })
    }

    /// Cells across.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Cells down.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Whether the model has been trained at least once.
    pub fn is_trained(&self) -> bool {
        self.trained
    }

    /// Trains on `features` (already windowed) and moves the model towards
    /// the result by `rate` (the first training takes it whole).
    ///
    /// # Errors
    /// [`DcfError::Size`] for features of another size;
    /// [`DcfError::InvalidParameter`] for a rate outside `[0, 1]`.
    pub fn train(&mut self, features: &[f32], rate: f64) -> Result<()> {
        check_rate("learning rate", rate)?;
        let zz = self.corr.transform(features, &mut self.zf)?;
        self.learn(zz, rate)
    }

    /// The spectra of the features the last [`KcfModel::detect`] (or
    /// training) transformed, as [`KcfModel::train_moved`] takes them.
    pub fn detected(&self) -> &[C32] {
        &self.zf
    }

    /// Trains on a sample given by its spectra `zf` (as
    /// [`KcfModel::detected`] gives them) moved by `(dx, dy)` cells: the
    /// sample's value at cell `(x + dx, y + dy)` is learnt at `(x, y)`, so
    /// a target found `(dx, dy)` cells from the window's centre is learnt
    /// at the centre (ECO's and C-COT's reuse of the detection's features,
    /// Danelljan et al. 2017, instead of sampling a new window). A
    /// sub-cell move is the phase ramp `e^(2 pi i (u dx / w + v dy / h))`
    /// over the signed frequencies; the Nyquist column and row (even sizes)
    /// take the cosine of their phase, the mean of the two frequencies
    /// they stand for, so the spectrum stays that of a real sample.
    ///
    /// # Errors
    /// [`DcfError::Size`] for spectra of another size;
    /// [`DcfError::InvalidParameter`] for a rate outside `[0, 1]` or a
    /// move that is not finite.
    pub fn train_moved(&mut self, zf: &[C32], moved: (f64, f64), rate: f64) -> Result<()> {
        check_rate("learning rate", rate)?;
        if !(moved.0.is_finite() && moved.1.is_finite()) {
            return Err(DcfError::InvalidParameter {
                name: "move",
                value: if moved.0.is_finite() {
                    moved.1
                } else {
                    moved.0
                },
                reason: "must be finite",
            });
        }
        let s = self.kf.len();
        if zf.len() != self.zf.len() {
            return Err(DcfError::Size {
                what: "moved spectra",
                expected: self.zf.len(),
                got: zf.len(),
            });
        }
        let (w, h) = (self.w, self.h);
        // the ramp along each axis: frequency k of n, signed
        let ramp = |k: usize, n: usize, d: f64| -> (f64, f64) {
            if 2 * k == n {
                ((std::f64::consts::PI * d).cos(), 0.0)
            } else {
                let f = if 2 * k < n {
                    k as f64
                } else {
                    k as f64 - n as f64
                };
                let t = std::f64::consts::TAU * f * d / n as f64;
                (t.cos(), t.sin())
            }
        };
        // bin (u, v) at u * h + v: the phases into `kf` (scratch until the
        // correlation below fills it), the ramp along y into its first
        // column first (column 0's own phases, as along x it is 1)
        let (first, rest) = self.kf.split_at_mut(h);
        for (v, p) in first.iter_mut().enumerate() {
            let (c, d) = ramp(v, h, moved.1);
            *p = C32::new(c as f32, d as f32);
        }
        for (u, col) in rest.chunks_exact_mut(h).enumerate() {
            let (a, b) = ramp(u + 1, w, moved.0);
            let a = C32::new(a as f32, b as f32);
            for (p, y) in col.iter_mut().zip(first.iter()) {
                *p = a * y;
            }
        }
        for (out, z) in self.zf.chunks_exact_mut(s).zip(zf.chunks_exact(s)) {
            for ((o, z), p) in out.iter_mut().zip(z).zip(&self.kf) {
                *o = z * p;
            }
        }
        let zz = dispatch(SpectrumEnergy {
            spectra: &self.zf,
            w,
            h,
        }) / (w * h) as f64;
        self.learn(zz, rate)
    }

    /// The training step after the sample's spectra are in `zf` (energy
    /// `zz`).
    fn learn(&mut self, zz: f64, rate: f64) -> Result<()> {
        self.corr
            .correlate(self.kernel, &self.zf, zz, &self.zf, zz, &mut self.kf)?;
        let lambda = self.lambda as f32;
        let r = if self.trained { rate as f32 } else { 1.0 };
        for ((a, y), k) in self.alphaf.iter_mut().zip(&self.yf).zip(&self.kf) {
            let new = y / (k + lambda);
            *a = *a * (1.0 - r) + new * r;
        }
        for (m, z) in self.xf.iter_mut().zip(&self.zf) {
            *m = *m * (1.0 - r) + z * r;
        }
        // the model's energy is that of the interpolated features, not the
        // interpolated energies: recompute it from the spectrum (Parseval)
        self.xx = self.energy_of_model();
        self.trained = true;
        Ok(())
    }

    fn energy_of_model(&self) -> f64 {
        let (w, h) = (self.w, self.h);
        dispatch(SpectrumEnergy {
            spectra: &self.xf,
            w,
            h,
        }) / (w * h) as f64
    }

    /// The response to `features` (already windowed) at every cyclic
    /// shift, into `out` (`w x h` cells): its peak is at the features'
    /// displacement from the training patch.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] before any training; [`DcfError::Size`].
    pub fn detect(&mut self, features: &[f32], out: &mut [f32]) -> Result<()> {
        if !self.trained {
            return Err(DcfError::NotInitialised);
        }
        let zz = self.corr.transform(features, &mut self.zf)?;
        self.corr
            .correlate(self.kernel, &self.xf, self.xx, &self.zf, zz, &mut self.kf)?;
        self.corr.respond(&self.kf, &self.alphaf, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: usize, h: usize, c: usize, seed: u64) -> Vec<f32> {
        // smooth random multi-channel texture: sums of sinusoids
        let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        let mut next = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((s >> 33) as f64 / (1u64 << 31) as f64) * 2.0 - 1.0
        };
        let waves: Vec<(f64, f64, f64)> = (0..6 * c)
            .map(|_| (next() * 0.9, next() * 0.9, next() * 3.0))
            .collect();
        let mut out = vec![0.0; w * h * c];
        for ch in 0..c {
            for y in 0..h {
                for x in 0..w {
                    let v: f64 = waves[ch * 6..ch * 6 + 6]
                        .iter()
                        .map(|(a, b, p)| (a * x as f64 + b * y as f64 + p).sin())
                        .sum();
                    out[ch * w * h + y * w + x] = v as f32;
                }
            }
        }
        out
    }

    /// Cyclically shifts every channel by (dx, dy): out(p) = in(p - d).
    fn shift(x: &[f32], w: usize, h: usize, dx: isize, dy: isize) -> Vec<f32> {
        let mut out = vec![0.0; x.len()];
        for (ci, co) in x.chunks_exact(w * h).zip(out.chunks_exact_mut(w * h)) {
            for y in 0..h {
                for xx in 0..w {
                    let sx = (xx as isize - dx).rem_euclid(w as isize) as usize;
                    let sy = (y as isize - dy).rem_euclid(h as isize) as usize;
                    co[y * w + xx] = ci[sy * w + sx];
                }
            }
        }
        out
    }

    #[test]
    fn labels_peak_at_the_origin_and_wrap() {
        let y = gaussian_labels(8, 6, 1.0);
        assert_eq!(y[0], 1.0);
        assert!((y[1] - y[7]).abs() < 1e-7 && (y[8] - y[5 * 8]).abs() < 1e-7);
        assert!((y[1] as f64 - (-0.5f64).exp()).abs() < 1e-6);
        let hw = hann(5);
        assert_eq!(hw[0], 0.0);
        assert!((hw[2] - 1.0).abs() < 1e-7 && (hw[1] - 0.5).abs() < 1e-7);
        assert_eq!(cosine_window(5, 3)[5 + 2], 1.0);
    }

    #[test]
    fn finds_integer_shifts_with_both_kernels() {
        let (w, h, c) = (24, 20, 3);
        let x = texture(w, h, c, 1);
        for kernel in [Kernel::Linear, Kernel::Gaussian { sigma: 0.5 }] {
            let mut m = KcfModel::new(w, h, c, 1.5, kernel, 1e-4).unwrap();
            m.train(&x, 0.02).unwrap();
            let mut r = vec![0.0; w * h];
            for (dx, dy) in [(0, 0), (3, -2), (-5, 4), (7, 6)] {
                let z = shift(&x, w, h, dx, dy);
                m.detect(&z, &mut r).unwrap();
                let (_, px, py) = subcell_peak(&r, w, h);
                assert!(
                    (px - dx as f64).abs() < 0.2 && (py - dy as f64).abs() < 0.2,
                    "{kernel:?} ({dx},{dy}): found ({px:.2},{py:.2})"
                );
            }
        }
    }

    #[test]
    fn finds_sub_cell_shifts() {
        // a smooth texture shifted by fractions of a cell: the sub-cell
        // peak lands within 0.2 cells (the integer peak alone is off by
        // 0.25 to 0.5 on these shifts; the fixed cosine window pulls the
        // estimate slightly towards 0, a known bias of windowed filters)
        let (w, h) = (32, 28);
        let f = |x: f64, y: f64, ch: usize| {
            let k = ch as f64;
            ((0.31 + 0.1 * k) * x + 0.17 * y).sin() + (0.23 * x - (0.29 - 0.05 * k) * y + k).cos()
        };
        let sample = |ox: f64, oy: f64| -> Vec<f32> {
            let mut out = vec![0.0; w * h * 2];
            let win = cosine_window(w, h);
            for ch in 0..2 {
                for y in 0..h {
                    for x in 0..w {
                        out[ch * w * h + y * w + x] =
                            (f(x as f64 - ox, y as f64 - oy, ch) * win[y * w + x] as f64) as f32;
                    }
                }
            }
            out
        };
        let mut m = KcfModel::new(w, h, 2, 2.0, Kernel::Gaussian { sigma: 0.5 }, 1e-4).unwrap();
        m.train(&sample(0.0, 0.0), 1.0).unwrap();
        let mut r = vec![0.0; w * h];
        for (ox, oy) in [(0.4, -0.3), (-0.6, 0.45), (-1.3, 0.5)] {
            m.detect(&sample(ox, oy), &mut r).unwrap();
            let (_, px, py) = subcell_peak(&r, w, h);
            assert!(
                (px - ox).abs() < 0.2 && (py - oy).abs() < 0.2,
                "({ox},{oy}): ({px:.3},{py:.3})"
            );
        }
    }

    /// `train_moved` learns a detection's features moved to the target:
    /// a texture moved by whole cells and then moved back gives the model
    /// trained on the texture itself (responses equal to 1e-4 of the
    /// peak), and a periodic texture moved by fractions of a cell (pure
    /// frequencies, so the phase ramp is its exact translation) too (to
    /// 2e-3 of the peak, the peaks within 1e-3 cells); with the ramp's
    /// sign flipped (the mutation) both fail.
    #[test]
    fn a_moved_detection_trains_as_the_target_itself() {
        let compare = |a: &mut KcfModel, b: &mut KcfModel, probe: &[f32], w: usize, h: usize| {
            let (mut ra, mut rb) = (vec![0.0; w * h], vec![0.0; w * h]);
            a.detect(probe, &mut ra).unwrap();
            b.detect(probe, &mut rb).unwrap();
            let peak = ra.iter().fold(0.0f32, |m, &v| m.max(v));
            let diff = ra
                .iter()
                .zip(&rb)
                .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
            (
                diff / peak,
                subcell_peak(&ra, w, h),
                subcell_peak(&rb, w, h),
            )
        };
        // whole cells
        let (w, h, c) = (24, 20, 3);
        let x = texture(w, h, c, 1);
        for kernel in [Kernel::Linear, Kernel::Gaussian { sigma: 0.5 }] {
            for (dx, dy) in [(3, -2), (-5, 4), (0, 7)] {
                let mut a = KcfModel::new(w, h, c, 1.5, kernel, 1e-4).unwrap();
                a.train(&x, 1.0).unwrap();
                let mut b = KcfModel::new(w, h, c, 1.5, kernel, 1e-4).unwrap();
                b.train(&texture(w, h, c, 9), 1.0).unwrap();
                let mut r = vec![0.0; w * h];
                b.detect(&shift(&x, w, h, dx, dy), &mut r).unwrap();
                let kept = b.detected().to_vec();
                b.train_moved(&kept, (dx as f64, dy as f64), 1.0).unwrap();
                let (rel, _, _) = compare(&mut a, &mut b, &shift(&x, w, h, 2, 1), w, h);
                assert!(rel < 1e-4, "{kernel:?} ({dx},{dy}): {rel:e}");
            }
        }
        // fractions of a cell, a periodic texture
        let (w, h) = (32, 24);
        let tau = std::f64::consts::TAU;
        let sample = |ox: f64, oy: f64| -> Vec<f32> {
            let mut out = vec![0.0; w * h * 2];
            for ch in 0..2 {
                let k = ch as f64;
                for y in 0..h {
                    for xx in 0..w {
                        let (u, v) = ((xx as f64 - ox) / w as f64, (y as f64 - oy) / h as f64);
                        out[ch * w * h + y * w + xx] = ((tau * (2.0 * u + v)).sin()
                            + (tau * (u - 3.0 * v) + k).cos()
                            + 0.5 * (tau * (5.0 * u + 2.0 * v) - k).sin())
                            as f32;
                    }
                }
            }
            out
        };
        for (ox, oy) in [(1.5, -0.75), (-2.25, 0.4), (0.3, 3.6)] {
            let kernel = Kernel::Gaussian { sigma: 0.5 };
            let mut a = KcfModel::new(w, h, 2, 2.0, kernel, 1e-4).unwrap();
            a.train(&sample(0.0, 0.0), 1.0).unwrap();
            let mut b = KcfModel::new(w, h, 2, 2.0, kernel, 1e-4).unwrap();
            b.train(&sample(5.0, 5.0), 1.0).unwrap();
            let mut r = vec![0.0; w * h];
            b.detect(&sample(ox, oy), &mut r).unwrap();
            let kept = b.detected().to_vec();
            b.train_moved(&kept, (ox, oy), 1.0).unwrap();
            let (rel, pa, pb) = compare(&mut a, &mut b, &sample(0.7, -1.2), w, h);
            // (a texture of a few frequencies leaves most of the kernel's
            // spectrum near zero, where lambda's division magnifies f32
            // rounding: measured 5e-4 to 9e-4)
            assert!(rel < 2e-3, "({ox},{oy}): {rel:e}");
            assert!(
                (pa.1 - pb.1).abs() < 1e-3 && (pa.2 - pb.2).abs() < 1e-3,
                "({ox},{oy}): peaks {pa:?} {pb:?}"
            );
        }
        // bad input
        let mut m = KcfModel::new(8, 8, 1, 1.0, Kernel::Linear, 1e-4).unwrap();
        let kept = m.detected().to_vec();
        assert!(m.train_moved(&kept, (f64::NAN, 0.0), 1.0).is_err());
        assert!(m.train_moved(&kept, (0.0, 0.0), 1.5).is_err());
        assert!(m.train_moved(&kept[1..], (0.0, 0.0), 1.0).is_err());
    }

    #[test]
    fn linear_kernel_is_multichannel_correlation() {
        // k^{xz}(d) = sum_c sum_p z_c(p + d) x_c(p) / (n c), computed directly
        let (w, h, c) = (9, 7, 2);
        let x = texture(w, h, c, 2);
        let z = texture(w, h, c, 3);
        let mut corr = Correlator::new(w, h, c).unwrap();
        let s = corr.spectrum_len();
        let (mut xf, mut zf) = (vec![C32::default(); s * c], vec![C32::default(); s * c]);
        let xx = corr.transform(&x, &mut xf).unwrap();
        let zz = corr.transform(&z, &mut zf).unwrap();
        let mut kf = vec![C32::default(); s];
        corr.correlate(Kernel::Linear, &xf, xx, &zf, zz, &mut kf)
            .unwrap();
        let mut k = vec![0.0; w * h];
        corr.fft().inverse(&mut kf, &mut k).unwrap();
        // and the Gaussian kernel is exp(-(|x|^2 + |z|^2 - 2 k_lin n c) / (s^2 n c))
        let mut kg = vec![C32::default(); s];
        corr.correlate(Kernel::Gaussian { sigma: 2.0 }, &xf, xx, &zf, zz, &mut kg)
            .unwrap();
        let mut g = vec![0.0; w * h];
        corr.fft().inverse(&mut kg, &mut g).unwrap();
        let nc = (w * h * c) as f64;
        for dy in 0..h {
            for dx in 0..w {
                let mut sum = 0.0f64;
                let mut dist = 0.0f64;
                for ch in 0..c {
                    for y in 0..h {
                        for xx_ in 0..w {
                            let zv = z[ch * w * h + ((y + dy) % h) * w + (xx_ + dx) % w] as f64;
                            let xv = x[ch * w * h + y * w + xx_] as f64;
                            sum += zv * xv;
                            dist += (zv - xv) * (zv - xv);
                        }
                    }
                }
                let got = k[dy * w + dx] as f64;
                assert!(
                    (got - sum / nc).abs() < 1e-5,
                    "linear ({dx},{dy}): {got} vs {}",
                    sum / nc
                );
                let want = (-dist / (4.0 * nc)).exp();
                let got = g[dy * w + dx] as f64;
                assert!(
                    (got - want).abs() < 1e-4,
                    "gaussian ({dx},{dy}): {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn response_on_the_training_patch_is_the_label() {
        // lambda -> 0: f(x) = F^-1(k_xx . y / k_xx) = y, peak 1 at the origin
        let (w, h, c) = (16, 12, 2);
        let x = texture(w, h, c, 4);
        let mut m = KcfModel::new(w, h, c, 1.0, Kernel::Gaussian { sigma: 0.5 }, 1e-9).unwrap();
        m.train(&x, 1.0).unwrap();
        let mut r = vec![0.0; w * h];
        m.detect(&x, &mut r).unwrap();
        let y = gaussian_labels(w, h, 1.0);
        assert!((r[0] - 1.0).abs() < 1e-3, "peak {}", r[0]);
        for (a, b) in r.iter().zip(&y) {
            assert!((a - b).abs() < 1e-3, "{a} vs {b}");
        }
    }

    #[test]
    fn interpolation_and_errors() {
        let (w, h) = (8, 8);
        let mut m = KcfModel::new(w, h, 1, 1.0, Kernel::Linear, 1e-4).unwrap();
        let mut r = vec![0.0; w * h];
        assert!(matches!(
            m.detect(&[0.0; 64], &mut r),
            Err(DcfError::NotInitialised)
        ));
        assert!(m.train(&[0.0; 64], 1.5).is_err());
        assert!(m.train(&[0.0; 63], 0.5).is_err());
        assert!(KcfModel::new(w, h, 1, 0.0, Kernel::Linear, 1e-4).is_err());
        assert!(KcfModel::new(w, h, 1, 1.0, Kernel::Gaussian { sigma: f64::NAN }, 1e-4).is_err());
        // rate 0 after the first training keeps the model
        let x = texture(w, h, 1, 5);
        m.train(&x, 0.5).unwrap();
        let before = m.alphaf.clone();
        m.train(&texture(w, h, 1, 6), 0.0).unwrap();
        assert_eq!(before, m.alphaf);
    }

    #[test]
    fn energy_is_the_partial_sums_at_every_level_and_near_the_running_sum() {
        use bayestrack_image::simd::SimdLevel;
        // lengths below, at and past the lanes, with a remainder; values
        // over eight orders of magnitude, so that the sums round at almost
        // every addition and another order of them gives other bits
        let scales = [1e-4f32, 3e-3, 0.1, 1.0, 7.0, 300.0];
        for (n, seed) in [0, 1, 7, 8, 9, 31, 640 * 31 + 5]
            .into_iter()
            .flat_map(|n| (6..9).map(move |s| (n, s)))
        {
            let x: Vec<f32> = crate::fft::tests::signal(n, 1, seed)
                .iter()
                .enumerate()
                .map(|(i, &v)| v * scales[i * 7 % scales.len()])
                .collect();
            // the definition: value i into sum i mod 8, added pairwise
            let mut acc = [0.0f64; ENERGY_LANES];
            for (i, &v) in x.iter().enumerate() {
                acc[i % ENERGY_LANES] += f64::from(v) * f64::from(v);
            }
            let want =
                ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
            let running: f64 = x.iter().map(|&v| f64::from(v) * f64::from(v)).sum();
            assert!(
                (want - running).abs() <= 1e-12 * running,
                "{n}: {want} {running}"
            );
            for level in SimdLevel::ALL {
                let got = level.run(Energy(&x));
                assert_eq!(got.to_bits(), want.to_bits(), "{n} values, {level:?}");
            }
        }
    }

    /// `n` pseudo-random `u64`s (xorshift64*), for the `exp` tests.
    fn bits(n: usize, seed: u64) -> Vec<u64> {
        let mut x = seed | 1;
        (0..n)
            .map(|_| {
                x ^= x >> 12;
                x ^= x << 25;
                x ^= x >> 27;
                x.wrapping_mul(0x2545_f491_4f6c_dd1d)
            })
            .collect()
    }

    /// Uniform in `[a, b)`.
    fn uniform(n: usize, seed: u64, a: f64, b: f64) -> Vec<f64> {
        let unit = |u: u64| (u >> 11) as f64 / (1u64 << 53) as f64;
        bits(n, seed)
            .into_iter()
            .map(|u| a + (b - a) * unit(u))
            .collect()
    }

    #[test]
    fn exp_approx_is_within_its_bound() {
        let mut worst = 0.0f64;
        for t in uniform(400_000, 1, -700.0, 700.0)
            .into_iter()
            .chain(uniform(400_000, 2, -1.0, 1.0))
            .chain([-700.0, 700.0, 0.0, -0.0, -0.5 * std::f64::consts::LN_2])
        {
            let want = t.exp();
            worst = worst.max(((exp_approx(t) - want) / want).abs());
        }
        // libm's own error (half an ulp, 2^-53) included
        assert!(worst < 2f64.powi(-40), "worst relative error {worst:e}");
    }

    /// `exp_to_f32_or_nan` over a slice, compiled for each level.
    struct Exps<'a>(&'a [f64], &'a mut [f32]);

    impl SimdKernel for Exps<'_> {
        type Output = ();
        #[inline(always)]
        fn run<T: Token>(self, _: T) {
            for (o, &t) in self.1.iter_mut().zip(self.0) {
                *o = exp_to_f32_or_nan(t);
            }
        }
    }

    #[test]
    fn exp_to_f32_is_libms_rounding() {
        // the kernel's exponents ([-104, 0]: below, every f32 is 0), the
        // whole range, the edges and past them
        let mut ts: Vec<f64> = uniform(100_000, 3, -110.0, 0.0);
        ts.extend(uniform(20_000, 4, -700.0, 700.0));
        ts.extend([
            0.0,
            -0.0,
            -5e-324,
            1e-300,
            -87.3,
            -103.97,
            -103.98,
            88.72,
            88.73,
            -700.0,
            700.0,
            -700.1,
            700.1,
            -745.2,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NAN,
        ]);
        // near halfway between neighbouring f32s (subnormal ones too):
        // t = ln m, exp(t) within about |t| 2^-53 of m
        let halfway = bits(30_000, 5).into_iter().map(|u| {
            let f = f32::from_bits(1 + (u as u32) % 0x3f80_0000);
            ((f as f64 + f.next_up() as f64) / 2.0).ln()
        });
        let near = ts.len();
        ts.extend(halfway);
        let want: Vec<u32> = ts.iter().map(|t| (t.exp() as f32).to_bits()).collect();
        for level in SimdLevel::ALL {
            let mut got = vec![0.0f32; ts.len()];
            level.run(Exps(&ts, &mut got));
            let mut left = [0usize; 2];
            for (i, (g, &w)) in got.iter().zip(&want).enumerate() {
                if g.is_nan() {
                    left[usize::from(i >= near)] += 1;
                } else {
                    assert_eq!(g.to_bits(), w, "{level:?}: t = {:e}", ts[i]);
                }
            }
            // the halfway values are left to libm, few others (6 out of
            // range, about one in 3,000 within 2^-36 of halfway)
            assert!(left[0] <= 6 + near / 1_000, "{level:?}: {left:?}");
            assert!(left[1] >= 29_000, "{level:?}: {left:?}");
        }
    }

    #[test]
    fn gaussian_values_are_libms_at_every_level() {
        // cross-correlations around their energies, so that the exponents
        // cover [-30, 0] and some differences clamp to 0
        let n = 16 * 40 + 3;
        let (xx, zz) = (412.5, 377.25);
        let inv = 1.0 / (0.25 * 16.0 * 40.0 * 31.0) * 25.0;
        let corr: Vec<f32> = uniform(n, 6, 0.0, 450.0)
            .iter()
            .map(|&v| v as f32)
            .collect();
        let want: Vec<u32> = corr
            .iter()
            .map(|&c| {
                let d = (xx + zz - 2.0 * c as f64).max(0.0);
                ((-d * inv).exp() as f32).to_bits()
            })
            .collect();
        for level in SimdLevel::ALL {
            let mut got = vec![0.0f32; n];
            gaussian_values(level, xx, zz, inv, &corr, &mut got);
            let got: Vec<u32> = got.iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, want, "{level:?}");
        }
    }

    #[test]
    fn spectrum_energy_is_the_running_sum_at_every_level() {
        // odd and even widths, heights below, at and past the lanes with
        // a remainder; values over many orders of magnitude, so that
        // another order of the additions gives other bits
        for (w, h, channels) in [
            (1, 1, 1),
            (2, 3, 2),
            (5, 8, 1),
            (16, 40, 31),
            (15, 27, 3),
            (12, 9, 4),
        ] {
            let wc = w / 2 + 1;
            let n = wc * h * channels;
            let v = crate::fft::tests::signal(2 * n, 1, 9);
            let xf: Vec<C32> = v
                .chunks_exact(2)
                .enumerate()
                .map(|(i, p)| C32::new(p[0], p[1]) * [1e-3f32, 1.0, 40.0, 3e4][i % 4])
                .collect();
            let mut want = 0.0f64;
            for c in xf.chunks_exact(wc * h) {
                for u in 0..wc {
                    let twice = u != 0 && !(w % 2 == 0 && u == wc - 1);
                    let k = if twice { 2.0 } else { 1.0 };
                    for v in &c[u * h..(u + 1) * h] {
                        want += k * v.norm_sqr() as f64;
                    }
                }
            }
            for level in SimdLevel::ALL {
                let got = level.run(SpectrumEnergy { spectra: &xf, w, h });
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "{w} x {h} x {channels}, {level:?}"
                );
            }
        }
    }

    #[test]
    fn channel_sum_is_the_scalar_loop_at_every_level() {
        use bayestrack_image::simd::SimdLevel;
        // bin counts that are not a multiple of any vector width, one
        // channel and many; the accumulator starts non-zero
        // (and whole blocks of bins only, the trackers' 9 x 40 bins)
        for (s, channels) in [(1, 1), (7, 3), (33, 31), (131, 5), (16, 2), (360, 31)] {
            let c32 = |v: Vec<f32>| -> Vec<C32> {
                v.chunks_exact(2).map(|p| C32::new(p[0], p[1])).collect()
            };
            let xf = c32(crate::fft::tests::signal(2 * s, channels, 3));
            let zf = c32(crate::fft::tests::signal(2 * s, channels, 4));
            let start = c32(crate::fft::tests::signal(2 * s, 1, 5));
            let mut want = start.clone();
            for (xc, zc) in xf.chunks_exact(s).zip(zf.chunks_exact(s)) {
                for ((a, x), z) in want.iter_mut().zip(xc).zip(zc) {
                    *a += z * x.conj();
                }
            }
            for level in SimdLevel::ALL {
                let mut got = start.clone();
                level.run(ChannelSum {
                    xf: &xf,
                    zf: &zf,
                    accum: &mut got,
                });
                for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        (a.re.to_bits(), a.im.to_bits()),
                        (b.re.to_bits(), b.im.to_bits()),
                        "{s} bins, {channels} channels, {level:?}: bin {i}"
                    );
                }
            }
        }
    }
}
