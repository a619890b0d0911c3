//! Weighted particle sets with weights kept in the log domain.

use nalgebra::{SMatrix, SVector};
use rand::Rng;

use crate::error::{ParticleError, Result};
use crate::resample::Resampler;

/// Whether every number a particle carries is finite: checked by
/// [`ParticleSet::new`], so a NaN or infinite state is refused where it
/// enters rather than turning the weighted mean into NaN later.
pub trait Finite {
    /// `true` when every component is finite.
    fn is_finite(&self) -> bool;
}

impl Finite for f64 {
    #[inline]
    fn is_finite(&self) -> bool {
        f64::is_finite(*self)
    }
}

/// Integers are always finite (particles that are labels or indices).
macro_rules! finite_integers {
    ($($t:ty),*) => {$(
        impl Finite for $t {
            #[inline]
            fn is_finite(&self) -> bool {
                true
            }
        }
    )*};
}
finite_integers!(u8, u16, u32, u64, usize, i8, i16, i32, i64, isize);

impl<const R: usize, const C: usize> Finite for SMatrix<f64, R, C> {
    #[inline]
    fn is_finite(&self) -> bool {
        self.iter().all(|v| v.is_finite())
    }
}

impl<const N: usize> Finite for KalmanParticle<N> {
    #[inline]
    fn is_finite(&self) -> bool {
        Finite::is_finite(&self.x) && Finite::is_finite(&self.cov)
    }
}

/// A particle: anything with a state vector (a plain state, or a state with
/// its own Gaussian for Kalman proposals).
pub trait Particle<const N: usize>: Clone + Send + Sync + Finite {
    /// The state `x`.
    fn state(&self) -> &SVector<f64, N>;
}

impl<const N: usize> Particle<N> for SVector<f64, N> {
    #[inline]
    fn state(&self) -> &SVector<f64, N> {
        self
    }
}

/// A particle that carries the covariance of its own Gaussian, for the
/// Kalman-proposal filters (Nagy, Ahmed and Zayed (paper 000) sec. 2.3.2: each particle is the mean
/// of an EKF/UKF/IEKF whose covariance it keeps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KalmanParticle<const N: usize> {
    /// The sampled state.
    pub x: SVector<f64, N>,
    /// The covariance of the particle's Gaussian.
    pub cov: SMatrix<f64, N, N>,
}

impl<const N: usize> Particle<N> for KalmanParticle<N> {
    #[inline]
    fn state(&self) -> &SVector<f64, N> {
        &self.x
    }
}

/// `exp(d)` for `d <= 0`, flushed to zero where the result would be
/// subnormal (`d < -708`): such weights are invisible next to the largest one
/// (which is 1), and the flush avoids libm's slow underflow path, which sharp
/// likelihoods (the `hikpf` model's variance is 1e-5) hit for most particles.
#[inline]
pub(crate) fn exp_flushed(d: f64) -> f64 {
    if d < -708.0 { 0.0 } else { d.exp() }
}

/// `log sum exp` of finite-or-minus-infinity values, shifted by the maximum.
///
/// # Errors
/// [`ParticleError::Empty`], [`ParticleError::NonFiniteWeight`] for NaN or
/// plus infinity, [`ParticleError::AllWeightsZero`] when every value is minus
/// infinity.
pub fn log_sum_exp(log_w: &[f64]) -> Result<f64> {
    let (max, ln_s) = shifted_log_sum_exp(log_w)?;
    Ok(max + ln_s)
}

/// [`log_sum_exp`] as its two parts `(max, ln sum exp(l - max))`, so that
/// normalising computes `(l - max) - ln_s`: at large magnitudes (all
/// log-weights near -1e15 or beyond) `max + ln_s` rounds to `max`, and
/// `l - (max + ln_s)` would lose the normalising constant entirely.
pub(crate) fn shifted_log_sum_exp(log_w: &[f64]) -> Result<(f64, f64)> {
    if log_w.is_empty() {
        return Err(ParticleError::Empty);
    }
    let mut max = f64::NEG_INFINITY;
    for (index, &l) in log_w.iter().enumerate() {
        if l.is_nan() || l == f64::INFINITY {
            return Err(ParticleError::NonFiniteWeight { index, value: l });
        }
        max = max.max(l);
    }
    if max == f64::NEG_INFINITY {
        return Err(ParticleError::AllWeightsZero { count: log_w.len() });
    }
    let s: f64 = log_w.iter().map(|&l| exp_flushed(l - max)).sum();
    Ok((max, s.ln()))
}

/// A weighted particle set `{x_i, w_i}` with `log w_i` stored.
///
/// The set also keeps the buffers of [`crate::ParticleFilter::step`]
/// (increments, weights, ancestors, the particles being gathered), so a step
/// allocates nothing once the set has been stepped; they take no part in
/// equality, cloning or `Debug`.
pub struct ParticleSet<T> {
    pub(crate) particles: Vec<T>,
    pub(crate) log_weights: Vec<f64>,
    /// The time index: filter steps taken since the set was made.
    pub(crate) k: usize,
    /// The stream seed of the latest filter step (none before the first).
    pub(crate) last_seed: Option<u64>,
    pub(crate) scratch: Scratch<T>,
}

/// Step buffers, reused from step to step (contents meaningless between
/// steps).
pub(crate) struct Scratch<T> {
    /// Log incremental weights of the latest proposal.
    pub(crate) increments: Vec<f64>,
    /// Linear weights relative to the largest, or their running sums within
    /// each chunk (systematic resampling).
    pub(crate) weights: Vec<f64>,
    /// Drawn ancestor indices.
    pub(crate) ancestors: Vec<usize>,
    /// The resampled particles, swapped with the set's afterwards.
    pub(crate) spare: Vec<T>,
    /// The particles before the proposal (for the MCMC move).
    pub(crate) parents: Vec<T>,
}

impl<T> Default for Scratch<T> {
    fn default() -> Self {
        Self {
            increments: Vec::new(),
            weights: Vec::new(),
            ancestors: Vec::new(),
            spare: Vec::new(),
            parents: Vec::new(),
        }
    }
}

impl<T: Clone> Clone for ParticleSet<T> {
    fn clone(&self) -> Self {
        Self {
            particles: self.particles.clone(),
            log_weights: self.log_weights.clone(),
            k: self.k,
            last_seed: self.last_seed,
            scratch: Scratch::default(),
        }
    }
}

impl<T: PartialEq> PartialEq for ParticleSet<T> {
    fn eq(&self, other: &Self) -> bool {
        self.particles == other.particles && self.log_weights == other.log_weights
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for ParticleSet<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParticleSet")
            .field("particles", &self.particles)
            .field("log_weights", &self.log_weights)
            .field("k", &self.k)
            .finish()
    }
}

impl<T> ParticleSet<T> {
    /// The time index `k` of the particles: the number of
    /// [`crate::ParticleFilter::step`]s the set has taken (0 for a new set;
    /// the next step draws `x_{k+1}` and shows its models `k + 1`).
    pub fn k(&self) -> usize {
        self.k
    }
}

impl<T: Clone> ParticleSet<T> {
    /// Equally weighted particles.
    ///
    /// # Errors
    /// [`ParticleError::Empty`] for no particles,
    /// [`ParticleError::NonFiniteState`] naming the first particle with a
    /// NaN or infinite component.
    pub fn new(particles: Vec<T>) -> Result<Self>
    where
        T: Finite,
    {
        if particles.is_empty() {
            return Err(ParticleError::Empty);
        }
        if let Some(index) = particles.iter().position(|p| !p.is_finite()) {
            return Err(ParticleError::NonFiniteState { index });
        }
        let lw = -(particles.len() as f64).ln();
        let log_weights = vec![lw; particles.len()];
        Ok(Self {
            particles,
            log_weights,
            k: 0,
            last_seed: None,
            scratch: Scratch::default(),
        })
    }

    /// Particles with (unnormalised) log-weights; normalised here.
    ///
    /// # Errors
    /// As [`log_sum_exp`], [`ParticleError::LengthMismatch`], and
    /// [`ParticleError::NonFiniteState`] as [`ParticleSet::new`].
    pub fn from_log_weights(particles: Vec<T>, log_weights: Vec<f64>) -> Result<Self>
    where
        T: Finite,
    {
        if particles.len() != log_weights.len() {
            return Err(ParticleError::LengthMismatch {
                particles: particles.len(),
                weights: log_weights.len(),
            });
        }
        if let Some(index) = particles.iter().position(|p| !p.is_finite()) {
            return Err(ParticleError::NonFiniteState { index });
        }
        let mut set = Self {
            particles,
            log_weights,
            k: 0,
            last_seed: None,
            scratch: Scratch::default(),
        };
        set.normalize()?;
        Ok(set)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Never true for a constructed set; here for API completeness.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// The particles.
    pub fn particles(&self) -> &[T] {
        &self.particles
    }

    /// The normalised log-weights.
    pub fn log_weights(&self) -> &[f64] {
        &self.log_weights
    }

    /// Particles and log-weights for in-place updates; call
    /// [`ParticleSet::normalize`] afterwards.
    pub fn parts_mut(&mut self) -> (&mut [T], &mut [f64]) {
        (&mut self.particles, &mut self.log_weights)
    }

    /// Normalises the log-weights (max-shifted log-sum-exp) and returns the
    /// log of their previous sum (the log marginal-likelihood increment when
    /// the previous weights were normalised).
    ///
    /// # Errors
    /// As [`log_sum_exp`]; the set is unchanged on error.
    pub fn normalize(&mut self) -> Result<f64> {
        let (max, ln_s) = shifted_log_sum_exp(&self.log_weights)?;
        for l in &mut self.log_weights {
            *l = (*l - max) - ln_s;
        }
        Ok(max + ln_s)
    }

    /// The normalised weights into `out` (resized).
    pub fn weights_into(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.log_weights.iter().map(|&l| exp_flushed(l)));
    }

    /// The normalised weights.
    pub fn weights(&self) -> Vec<f64> {
        let mut w = Vec::new();
        self.weights_into(&mut w);
        w
    }

    /// Effective sample size `1 / sum w_i^2` (Lee, Jo and Kang (paper 003) eq. 16).
    pub fn ess(&self) -> f64 {
        1.0 / self
            .log_weights
            .iter()
            .map(|&l| exp_flushed(2.0 * l))
            .sum::<f64>()
    }

    /// Kong-Liu effective sample size `N / (1 + cv^2)` with `cv^2` the sample
    /// variance (divisor `N - 1`) of `N w_i` (Bócsi and Csató (paper 001)). With divisor `N`
    /// it would equal [`ParticleSet::ess`] exactly.
    pub fn ess_kong_liu(&self) -> f64 {
        let n = self.len() as f64;
        if self.len() < 2 {
            return n;
        }
        let ss: f64 = self
            .log_weights
            .iter()
            .map(|l| {
                let d = n * l.exp() - 1.0;
                d * d
            })
            .sum();
        n / (1.0 + ss / (n - 1.0))
    }

    /// Resamples with `scheme`: particles are replaced by their drawn
    /// ancestors and weights reset to `1/N`. `ancestors` is a caller buffer
    /// (resized to `N`) that holds the drawn indices afterwards.
    ///
    /// # Errors
    /// As [`Resampler::resample`].
    pub fn resample<S: Resampler, R: Rng + ?Sized>(
        &mut self,
        scheme: &S,
        rng: &mut R,
        ancestors: &mut Vec<usize>,
    ) -> Result<()> {
        let mut weights = std::mem::take(&mut self.scratch.weights);
        self.weights_into(&mut weights);
        ancestors.resize(self.len(), 0);
        let drawn = scheme.resample(&weights, rng, ancestors);
        self.scratch.weights = weights;
        drawn?;
        self.gather(ancestors);
        Ok(())
    }

    /// Replaces the particles by `ancestors` (one index per new particle)
    /// and resets the weights to `1/N`.
    fn gather(&mut self, ancestors: &[usize]) {
        let n = self.len();
        let spare = &mut self.scratch.spare;
        spare.clear();
        spare.extend(ancestors.iter().map(|&a| self.particles[a].clone()));
        std::mem::swap(&mut self.particles, spare);
        self.log_weights.fill(-(n as f64).ln());
    }

    /// Resamples only when the ESS falls below `threshold * N` (adaptive
    /// resampling); returns whether it did.
    ///
    /// # Errors
    /// [`ParticleError::InvalidParameter`] for a threshold outside [0, 1],
    /// and as [`ParticleSet::resample`].
    pub fn resample_if<S: Resampler, R: Rng + ?Sized>(
        &mut self,
        threshold: f64,
        scheme: &S,
        rng: &mut R,
        ancestors: &mut Vec<usize>,
    ) -> Result<bool> {
        check_threshold(threshold)?;
        if self.ess() < threshold * self.len() as f64 {
            self.resample(scheme, rng, ancestors)?;
            Ok(true)
        } else {
            Ok(false)
        }
    }

    /// Weighted mean `sum w_i x_i`; finite, since the states are (a
    /// component whose sum rounds past the largest `f64` is summed again
    /// over halved states and clamped into the states' range).
    pub fn mean<const N: usize>(&self) -> SVector<f64, N>
    where
        T: Particle<N>,
    {
        let terms = || {
            self.particles
                .iter()
                .zip(&self.log_weights)
                .map(|(p, l)| (p.state(), l.exp()))
        };
        let mean = terms().fold(SVector::zeros(), |acc, (x, w)| acc + x * w);
        finite_mean(mean, terms)
    }

    /// Weighted covariance `sum w_i (x_i - m)(x_i - m)^T`.
    ///
    /// The states are finite (every constructor checks them), but an entry
    /// whose square passes the largest `f64` (a spread beyond about 1e154)
    /// is infinite here, as in any `f64` arithmetic; check
    /// `is_finite()` on the result where states can be that far apart.
    pub fn covariance<const N: usize>(&self) -> SMatrix<f64, N, N>
    where
        T: Particle<N>,
    {
        let m = self.mean();
        self.particles
            .iter()
            .zip(&self.log_weights)
            .fold(SMatrix::zeros(), |acc, (p, l)| {
                let d = p.state() - m;
                acc + d * d.transpose() * l.exp()
            })
    }

    /// The highest-weight particle (the MAP estimate among the particles).
    pub fn map(&self) -> &T {
        let best = self
            .log_weights
            .iter()
            .enumerate()
            .fold(0, |b, (i, &l)| if l > self.log_weights[b] { i } else { b });
        &self.particles[best]
    }
}

/// Checks an ESS threshold fraction.
pub(crate) fn check_threshold(threshold: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&threshold) {
        return Err(ParticleError::InvalidParameter {
            name: "ess threshold",
            value: threshold,
            reason: "must be a fraction of N in [0, 1]",
        });
    }
    Ok(())
}

/// `mean`, a weighted mean `sum w_i x_i` of the finite states of `terms`
/// (`(x_i, w_i)`, weights summing to one up to round-off), returned as it
/// is when finite. A component that rounded past the largest `f64` (states
/// within a rounding of it, or weights summing to `1 + 1e-16`) is summed
/// again over halved states, doubled and clamped into the states' range: a
/// weighted mean of finite states is finite.
#[inline]
pub(crate) fn finite_mean<'a, const N: usize, I>(
    mean: SVector<f64, N>,
    terms: impl Fn() -> I,
) -> SVector<f64, N>
where
    I: Iterator<Item = (&'a SVector<f64, N>, f64)>,
{
    if mean.iter().all(|v| v.is_finite()) {
        return mean;
    }
    redo_mean(mean, terms)
}

#[cold]
#[inline(never)]
fn redo_mean<'a, const N: usize, I>(
    mut mean: SVector<f64, N>,
    terms: impl Fn() -> I,
) -> SVector<f64, N>
where
    I: Iterator<Item = (&'a SVector<f64, N>, f64)>,
{
    for j in 0..N {
        if mean[j].is_finite() {
            continue;
        }
        let (mut half, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
        for (x, w) in terms() {
            half += w * (x[j] * 0.5);
            lo = lo.min(x[j]);
            hi = hi.max(x[j]);
        }
        mean[j] = (2.0 * half).max(lo).min(hi);
    }
    mean
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    fn set(xs: &[f64], lw: &[f64]) -> ParticleSet<Vector1<f64>> {
        ParticleSet::from_log_weights(xs.iter().map(|&x| Vector1::new(x)).collect(), lw.to_vec())
            .unwrap()
    }

    #[test]
    fn a_non_finite_state_is_refused_by_every_constructor() {
        // issue 28: from_log_weights took NaN and infinite states that
        // `new` refuses
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let xs = vec![Vector1::new(0.0), Vector1::new(bad)];
            assert_eq!(
                ParticleSet::from_log_weights(xs.clone(), vec![0.0, 0.0]),
                Err(ParticleError::NonFiniteState { index: 1 })
            );
            assert_eq!(
                ParticleSet::new(xs),
                Err(ParticleError::NonFiniteState { index: 1 })
            );
        }
    }

    #[test]
    fn normalisation_survives_extreme_log_weights() {
        // linear-domain weights would underflow to 0 here
        let s = set(
            &[0.0, 1.0, 2.0],
            &[-2000.0, -2000.0 + 2f64.ln(), f64::NEG_INFINITY],
        );
        let w = s.weights();
        assert!((w[0] - 1.0 / 3.0).abs() < 1e-12 && (w[1] - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(w[2], 0.0);
        assert!((s.mean()[0] - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.covariance()[(0, 0)] - 2.0 / 9.0).abs() < 1e-12);
        assert_eq!(s.map()[0], 1.0);
    }

    #[test]
    fn normalisation_holds_at_every_magnitude() {
        // all log-weights near -1e15 or beyond: `max + ln(sum)` rounds to
        // `max`, so subtracting it whole left weights that summed to N
        for m in [1.0, 1e3, 1e10, 1e15, 1e16, 1e50, 1e100, 1e200, 1e300] {
            for sign in [-1.0, 1.0] {
                let l = sign * m;
                let s = set(&[1.0, 2.0, 3.0, 4.0], &[l, l, l, f64::NEG_INFINITY]);
                let sum: f64 = s.weights().iter().sum();
                assert!((sum - 1.0).abs() < 1e-12, "m = {l:e}: sum {sum}");
                assert!((s.mean()[0] - 2.0).abs() < 1e-12, "m = {l:e}");
                assert!((s.ess() - 3.0).abs() < 1e-9, "m = {l:e}: ess {}", s.ess());
                let mut raw = s.clone();
                raw.parts_mut()
                    .1
                    .copy_from_slice(&[l, l, l, f64::NEG_INFINITY]);
                let lse = raw.normalize().unwrap();
                assert_eq!(lse, l + 3f64.ln(), "m = {l:e}");
                assert_eq!(raw.log_weights(), s.log_weights());
            }
        }
    }

    #[test]
    fn a_non_finite_state_is_refused_where_it_enters() {
        assert_eq!(
            ParticleSet::new(vec![Vector1::new(0.0), Vector1::new(f64::NAN)]).map(|_| ()),
            Err(ParticleError::NonFiniteState { index: 1 })
        );
        assert_eq!(
            ParticleSet::new(vec![f64::INFINITY]).map(|_| ()),
            Err(ParticleError::NonFiniteState { index: 0 })
        );
        let p = KalmanParticle {
            x: Vector1::new(0.0),
            cov: nalgebra::Matrix1::new(f64::NAN),
        };
        assert_eq!(
            ParticleSet::new(vec![p]).map(|_| ()),
            Err(ParticleError::NonFiniteState { index: 0 })
        );
    }

    #[test]
    fn bad_weights_name_the_particle() {
        let xs: Vec<Vector1<f64>> = vec![Vector1::new(0.0); 3];
        assert!(matches!(
            ParticleSet::from_log_weights(xs.clone(), vec![0.0, f64::NAN, 0.0]),
            Err(ParticleError::NonFiniteWeight { index: 1, .. })
        ));
        assert!(matches!(
            ParticleSet::from_log_weights(xs.clone(), vec![0.0, 0.0, f64::INFINITY]),
            Err(ParticleError::NonFiniteWeight { index: 2, .. })
        ));
        assert_eq!(
            ParticleSet::from_log_weights(xs.clone(), vec![f64::NEG_INFINITY; 3]).map(|_| ()),
            Err(ParticleError::AllWeightsZero { count: 3 })
        );
        assert_eq!(
            ParticleSet::<Vector1<f64>>::new(vec![]).map(|_| ()),
            Err(ParticleError::Empty)
        );
        assert_eq!(
            ParticleSet::from_log_weights(xs, vec![0.0; 2]).map(|_| ()),
            Err(ParticleError::LengthMismatch {
                particles: 3,
                weights: 2
            })
        );
    }

    #[test]
    fn ess_bounds_and_kong_liu() {
        let uniform = set(&[0.0, 1.0, 2.0, 3.0], &[0.0; 4]);
        assert!((uniform.ess() - 4.0).abs() < 1e-12);
        assert!((uniform.ess_kong_liu() - 4.0).abs() < 1e-12);
        let one = set(
            &[0.0, 1.0, 2.0, 3.0],
            &[0.0, f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY],
        );
        assert!((one.ess() - 1.0).abs() < 1e-12);
        // w = (0.4, 0.4, 0.1, 0.1): sum w^2 = 0.34, N w - 1 = (0.6, 0.6, -0.6, -0.6)
        let s = set(
            &[0.0; 4],
            &[0.4f64.ln(), 0.4f64.ln(), 0.1f64.ln(), 0.1f64.ln()],
        );
        assert!((s.ess() - 1.0 / 0.34).abs() < 1e-12);
        assert!((s.ess_kong_liu() - 4.0 / (1.0 + 1.44 / 3.0)).abs() < 1e-12);
    }

    #[test]
    fn adaptive_resampling_threshold() {
        let mut rng = crate::seed::stream_rng(&[3]);
        let mut anc = vec![];
        let mut s = set(&[0.0, 1.0], &[0.0, -10.0]);
        assert!(
            s.resample_if(1.5, &crate::Resampling::Systematic, &mut rng, &mut anc)
                .is_err()
        );
        assert!(
            !s.resample_if(0.1, &crate::Resampling::Systematic, &mut rng, &mut anc)
                .unwrap()
        );
        assert!(
            s.resample_if(0.9, &crate::Resampling::Systematic, &mut rng, &mut anc)
                .unwrap()
        );
        assert_eq!(anc.len(), 2);
        assert!((s.ess() - 2.0).abs() < 1e-12);
    }
}
