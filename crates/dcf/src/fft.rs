//! Cached real 2-D FFTs of one fixed size, and FFT-friendly sizes.
//!
//! [`Fft2`] transforms a real `w x h` row-major array into its half
//! spectrum: a real-to-complex FFT along each row (`w / 2 + 1` complex
//! outputs, [`realfft`]) and a complex FFT along each of those columns
//! ([`rustfft`]). The spectrum is stored **column-major**: bin `(u, v)`
//! (`u < w / 2 + 1` horizontal frequency, `v < h` vertical) is at
//! `u * h + v`, so that every column transform is one contiguous call.
//! Element-wise products of spectra (all a correlation filter does) do not
//! care about the layout.
//!
//! The plans and every scratch buffer are made once, by [`Fft2::new`]; the
//! transforms then allocate nothing.
//!
//! **Float type: `f32`.** The filters' inputs are 8-bit pixels and
//! features clipped at 0.2 (fHOG), with about 3 significant digits; `f32`
//! keeps 7, halves the memory traffic and doubles the SIMD width of the
//! FFT kernels. The round trip is exact to about `1e-6` relative (tested
//! at `1e-5`).

use std::sync::Arc;

use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};

use crate::error::{DcfError, Result};

/// The complex type of the spectra.
pub type C32 = Complex32;

/// Whether `n` has no prime factor above 5 (a fast size for the mixed
/// radix FFTs).
pub fn is_smooth(mut n: usize) -> bool {
    if n == 0 {
        return false;
    }
    for p in [2, 3, 5] {
        while n.is_multiple_of(p) {
            n /= p;
        }
    }
    n == 1
}

/// The smallest 2,3,5-smooth size at least `n` (1 for 0).
pub fn next_smooth(n: usize) -> usize {
    let mut m = n.max(1);
    while !is_smooth(m) {
        m += 1;
    }
    m
}

/// Real 2-D FFT plans of one size, with their scratch buffers.
#[derive(Clone)]
pub struct Fft2 {
    w: usize,
    h: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    col_fwd: Arc<dyn Fft<f32>>,
    col_inv: Arc<dyn Fft<f32>>,
    row_in: Vec<f32>,
    rows: Vec<C32>,
    real_scratch: Vec<C32>,
    col_scratch: Vec<C32>,
}

impl std::fmt::Debug for Fft2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fft2")
            .field("w", &self.w)
            .field("h", &self.h)
            .finish_non_exhaustive()
    }
}

impl Fft2 {
    /// Plans for `w x h` real arrays.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a zero side or more than 2^24
    /// samples.
    pub fn new(w: usize, h: usize) -> Result<Self> {
        if w == 0 || h == 0 || w.saturating_mul(h) > 1 << 24 {
            return Err(DcfError::InvalidParameter {
                name: "fft size",
                value: (w * h) as f64,
                reason: "each side must be positive and w*h at most 2^24",
            });
        }
        let mut real = RealFftPlanner::<f32>::new();
        let r2c = real.plan_fft_forward(w);
        let c2r = real.plan_fft_inverse(w);
        let mut cplx = FftPlanner::<f32>::new();
        let col_fwd = cplx.plan_fft_forward(h);
        let col_inv = cplx.plan_fft_inverse(h);
        let wc = w / 2 + 1;
        let real_scratch_len = r2c.get_scratch_len().max(c2r.get_scratch_len());
        let col_scratch_len = col_fwd
            .get_inplace_scratch_len()
            .max(col_inv.get_inplace_scratch_len());
        Ok(Self {
            w,
            h,
            r2c,
            c2r,
            col_fwd,
            col_inv,
            row_in: vec![0.0; w],
            rows: vec![C32::default(); wc * h],
            real_scratch: vec![C32::default(); real_scratch_len],
            col_scratch: vec![C32::default(); col_scratch_len],
        })
    }

    /// Width of the real arrays.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Height of the real arrays.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Number of real samples, `w h`.
    pub fn real_len(&self) -> usize {
        self.w * self.h
    }

    /// Number of complex bins of the half spectrum, `(w / 2 + 1) h`.
    pub fn spectrum_len(&self) -> usize {
        (self.w / 2 + 1) * self.h
    }

    fn check(&self, real: usize, spectrum: usize) -> Result<()> {
        if real != self.real_len() || spectrum != self.spectrum_len() {
            return Err(DcfError::Size {
                what: "fft buffers",
                expected: self.real_len(),
                got: real,
            });
        }
        Ok(())
    }

    /// The half spectrum of `input` (`w x h` row-major) into `out`
    /// (column-major, see the module docs). Unnormalised.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn forward(&mut self, input: &[f32], out: &mut [C32]) -> Result<()> {
        self.check(input.len(), out.len())?;
        let (w, h, wc) = (self.w, self.h, self.w / 2 + 1);
        for (y, row) in input.chunks_exact(w).enumerate() {
            self.row_in.copy_from_slice(row);
            let dst = &mut self.rows[y * wc..(y + 1) * wc];
            self.r2c
                .process_with_scratch(&mut self.row_in, dst, &mut self.real_scratch)
                .map_err(|_| DcfError::Fft)?;
        }
        // transpose rows (h x wc) into columns (wc x h): each column
        // written in order, read down the rows with a stride
        for (u, col) in out.chunks_exact_mut(h).enumerate() {
            for (o, &v) in col.iter_mut().zip(self.rows[u..].iter().step_by(wc)) {
                *o = v;
            }
        }
        self.col_fwd
            .process_with_scratch(out, &mut self.col_scratch);
        Ok(())
    }

    /// The real array of the half spectrum `spectrum` into `out`,
    /// normalised (`inverse(forward(x)) == x`). `spectrum` is used as
    /// scratch and left changed.
    ///
    /// # Errors
    /// [`DcfError::Size`] for buffers of another size.
    pub fn inverse(&mut self, spectrum: &mut [C32], out: &mut [f32]) -> Result<()> {
        self.check(out.len(), spectrum.len())?;
        let (w, h, wc) = (self.w, self.h, self.w / 2 + 1);
        self.col_inv
            .process_with_scratch(spectrum, &mut self.col_scratch);
        for (u, col) in spectrum.chunks_exact(h).enumerate() {
            for (o, &v) in self.rows[u..].iter_mut().step_by(wc).zip(col) {
                *o = v;
            }
        }
        let norm = 1.0 / (w * h) as f32;
        for (y, row) in out.chunks_exact_mut(w).enumerate() {
            let src = &mut self.rows[y * wc..(y + 1) * wc];
            // a Hermitian spectrum has real DC (and Nyquist) bins; rounding
            // leaves a tiny imaginary part that the real transform refuses
            src[0].im = 0.0;
            if w % 2 == 0 {
                src[wc - 1].im = 0.0;
            }
            self.c2r
                .process_with_scratch(src, row, &mut self.real_scratch)
                .map_err(|_| DcfError::Fft)?;
            for v in row.iter_mut() {
                *v *= norm;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signal(w: usize, h: usize, seed: u32) -> Vec<f32> {
        // a deterministic pseudo-random signal in [-1, 1]
        let mut s = seed.wrapping_mul(2_654_435_761).max(1);
        (0..w * h)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                (s as f32 / u32::MAX as f32) * 2.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn smooth_sizes() {
        assert!(is_smooth(1) && is_smooth(30) && is_smooth(64) && is_smooth(45));
        assert!(!is_smooth(7) && !is_smooth(0) && !is_smooth(33));
        assert_eq!(next_smooth(31), 32);
        assert_eq!(next_smooth(37), 40);
        assert_eq!(next_smooth(49), 50);
        assert_eq!(next_smooth(0), 1);
    }

    #[test]
    fn round_trip_and_parseval() {
        for (w, h) in [(8, 8), (7, 5), (12, 9), (40, 30), (1, 6), (6, 1)] {
            let mut f = Fft2::new(w, h).unwrap();
            let x = signal(w, h, (w * 31 + h) as u32);
            let mut spec = vec![C32::default(); f.spectrum_len()];
            f.forward(&x, &mut spec).unwrap();
            // Parseval on the half spectrum: the columns u in 1..ceil(w/2)
            // stand for their mirror images too
            let wc = w / 2 + 1;
            let mut energy = 0.0f64;
            for u in 0..wc {
                let twice = u != 0 && !(w % 2 == 0 && u == wc - 1);
                let k = if twice { 2.0 } else { 1.0 };
                for v in 0..h {
                    energy += k * spec[u * h + v].norm_sqr() as f64;
                }
            }
            let direct: f64 = x.iter().map(|&v| (v as f64) * (v as f64)).sum();
            let rel = (energy / (w * h) as f64 - direct).abs() / direct;
            assert!(rel < 1e-5, "{w}x{h}: Parseval off by {rel}");
            let mut back = vec![0.0; w * h];
            f.inverse(&mut spec, &mut back).unwrap();
            for (a, b) in x.iter().zip(&back) {
                assert!((a - b).abs() < 1e-5, "{w}x{h}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn correlation_theorem() {
        // ifft(fft(a) conj(fft(b)))[d] = sum_p a[p + d] b[p] (circular)
        let (w, h) = (10, 6);
        let a = signal(w, h, 3);
        let b = signal(w, h, 4);
        let mut f = Fft2::new(w, h).unwrap();
        let mut fa = vec![C32::default(); f.spectrum_len()];
        let mut fb = fa.clone();
        f.forward(&a, &mut fa).unwrap();
        f.forward(&b, &mut fb).unwrap();
        let mut prod: Vec<C32> = fa.iter().zip(&fb).map(|(x, y)| x * y.conj()).collect();
        let mut corr = vec![0.0; w * h];
        f.inverse(&mut prod, &mut corr).unwrap();
        for dy in 0..h {
            for dx in 0..w {
                let mut s = 0.0f64;
                for y in 0..h {
                    for x in 0..w {
                        let ya = (y + dy) % h;
                        let xa = (x + dx) % w;
                        s += a[ya * w + xa] as f64 * b[y * w + x] as f64;
                    }
                }
                let got = corr[dy * w + dx] as f64;
                assert!((got - s).abs() < 1e-4, "({dx},{dy}): {got} vs {s}");
            }
        }
    }

    #[test]
    fn wrong_sizes_are_errors() {
        assert!(Fft2::new(0, 4).is_err());
        let mut f = Fft2::new(4, 4).unwrap();
        let mut spec = vec![C32::default(); 3];
        assert!(matches!(
            f.forward(&[0.0; 16], &mut spec),
            Err(DcfError::Size { .. })
        ));
    }
}
