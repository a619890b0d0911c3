//! Importance proposals `q(x_k | x_{k-1}, z_k)` (Nagy, Ahmed and Zayed (paper 000) eq. 7-10).
//!
//! A proposal draws a new particle from its parent and returns it with the
//! log of the incremental importance weight
//!
//! `log p(z_k | x_k) + log p(x_k | x_{k-1}) - log q(x_k | x_{k-1}, z_k)`.
//!
//! - [`Bootstrap`]: `q` is the transition prior (SIR); the weight is the
//!   likelihood alone.
//! - [`KalmanProposal`]: each particle carries its own Gaussian, which a
//!   [`LocalFilter`] (EKF, UKF, IEKF or the hybrid UKF -> IEKF of HIKPF, all
//!   from `bayestrack-kalman`) moves to `N(mu_k, P_k)` using `z_k`; the
//!   particle is drawn from it and keeps `P_k`.

use bayestrack_kalman::Additive;
use bayestrack_kalman::{
    Dynamics, DynamicsJacobian, Ekf, Gaussian, HybridUkfIekf, Iekf, KalmanError, Measurement,
    MeasurementJacobian, Ukf,
};
use std::convert::Infallible;

use nalgebra::SVector;
use rand::Rng;

use crate::set::KalmanParticle;

/// What a bootstrap particle filter needs of a state-space model: a way
/// to draw from the transition `p(x_k | x_{k-1})` and the likelihood
/// `p(z_k | x_k)` of an observation (Nagy, Ahmed and Zayed (paper 000) eq.
/// 7-9 with `q` the transition prior). Both see the time index `k` of the
/// state being drawn or weighed: the set starts at `k = 0`, the first step
/// draws `x_1`.
///
/// The observation is the model's own type: a measurement vector
/// (`SVector<f64, M>`, what the Kalman proposals need), a scalar, or
/// anything else the likelihood reads. A likelihood that can fail (an
/// image window leaving the frame, say) implements [`Proposal`] itself,
/// with an error type of its own.
///
/// The density of the transition is not needed here: proposals other than
/// the transition prior ([`KalmanProposal`]) ask for it through
/// [`TransitionDensity`].
///
/// The filter step calls `sample_transition` and `log_likelihood` once per
/// particle in a tight loop. Mark them `#[inline]`, and a sampler that draws
/// several variables `#[inline(always)]`: inlined, the generator's state stays
/// in registers across the loop. On the `hikpf` model (three exponential
/// draws per particle) an out-of-line `sample_transition` makes the whole
/// step about a third slower.
pub trait Model<const N: usize>: Sync {
    /// What the likelihood weighs a state against (`z_k`).
    type Observation: ?Sized + Sync;
    /// Draws `x_k ~ p(. | x_{k-1})`.
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x_prev: &SVector<f64, N>,
        rng: &mut R,
    ) -> SVector<f64, N>;
    /// `log p(z_k | x_k)` (an unnormalised log density is enough: the
    /// weights are normalised, only the log evidence of a step moves).
    fn log_likelihood(&self, k: usize, x: &SVector<f64, N>, z: &Self::Observation) -> f64;
}

/// The transition density `log p(x_k | x_{k-1})` of a [`Model`]: the
/// `p(x_k | x_{k-1})` of the incremental weight (paper 000 eq. 9) of every
/// proposal that is not the transition prior.
pub trait TransitionDensity<const N: usize>: Model<N> {
    /// `log p(x_k | x_{k-1})` (minus infinity outside the support).
    fn log_transition(&self, k: usize, x_prev: &SVector<f64, N>, x: &SVector<f64, N>) -> f64;
}

/// A [`Model`] of a scalar state, written on `f64` rather than on a
/// 1-vector: every `ScalarModel` is a `Model<1>` (its particles are
/// `Vector1<f64>`, `set.mean()[0]` the estimate), so it runs in every
/// filter of the crate.
///
/// ```
/// use bayestrack_particle::{Bootstrap, ParticleFilter, ParticleSet, ScalarModel, Smc};
/// use bayestrack_particle::nalgebra::Vector1;
/// use bayestrack_particle::rand::Rng;
/// use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
///
/// /// x_k = 0.9 x_{k-1} + v, z_k = x_k + n, v ~ N(0, 1), n ~ N(0, 0.25).
/// struct Ar1;
/// impl ScalarModel for Ar1 {
///     type Observation = f64;
///     fn sample_transition<R: Rng + ?Sized>(&self, _k: usize, x: f64, rng: &mut R) -> f64 {
///         let v: f64 = StandardNormal.sample(rng);
///         0.9 * x + v
///     }
///     fn log_likelihood(&self, _k: usize, x: f64, z: &f64) -> f64 {
///         -0.5 * (z - x).powi(2) / 0.25
///     }
/// }
///
/// let set = ParticleSet::new(vec![Vector1::new(0.0); 500])?;
/// let mut pf = Smc::new(ParticleFilter::default(), set, 7)?;
/// let report = pf.step(&Bootstrap(&Ar1), &1.0)?;
/// assert!((report.mean[0] - 0.8).abs() < 0.2);
/// # Ok::<(), bayestrack_particle::ParticleError>(())
/// ```
pub trait ScalarModel: Sync {
    /// What the likelihood weighs a state against (`z_k`).
    type Observation: ?Sized + Sync;
    /// Draws `x_k ~ p(. | x_{k-1})`.
    fn sample_transition<R: Rng + ?Sized>(&self, k: usize, x_prev: f64, rng: &mut R) -> f64;
    /// `log p(z_k | x_k)` (unnormalised is enough, as [`Model::log_likelihood`]).
    fn log_likelihood(&self, k: usize, x: f64, z: &Self::Observation) -> f64;
}

impl<S: ScalarModel> Model<1> for S {
    type Observation = S::Observation;
    #[inline(always)]
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x_prev: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        SVector::<f64, 1>::new(ScalarModel::sample_transition(self, k, x_prev[0], rng))
    }
    #[inline(always)]
    fn log_likelihood(&self, k: usize, x: &SVector<f64, 1>, z: &S::Observation) -> f64 {
        ScalarModel::log_likelihood(self, k, x[0], z)
    }
}

/// The transition density of a [`ScalarModel`], on `f64`: every
/// `ScalarTransitionDensity` is a [`TransitionDensity<1>`].
pub trait ScalarTransitionDensity: ScalarModel {
    /// `log p(x_k | x_{k-1})` (minus infinity outside the support).
    fn log_transition(&self, k: usize, x_prev: f64, x: f64) -> f64;
}

impl<S: ScalarTransitionDensity> TransitionDensity<1> for S {
    #[inline(always)]
    fn log_transition(&self, k: usize, x_prev: &SVector<f64, 1>, x: &SVector<f64, 1>) -> f64 {
        ScalarTransitionDensity::log_transition(self, k, x_prev[0], x[0])
    }
}

/// An importance proposal for particles of type `T` and observations `Z`.
///
/// The filter calls [`Proposal::propose`] once per particle, chunk by
/// chunk ([`crate::ParticleFilter::chunk_size`]); each chunk has its own
/// random stream and its own [`Proposal::Scratch`], so a proposal that
/// needs buffers (a patch to warp into, a histogram to fill) allocates
/// them once per chunk, or never when the caller keeps them between steps
/// ([`crate::ParticleFilter::step_with`]).
pub trait Proposal<T, Z: ?Sized>: Sync {
    /// Why a proposal can fail: the local filter's [`KalmanError`] for
    /// [`KalmanProposal`], an image likelihood's error, or
    /// [`Infallible`] for [`Bootstrap`]. The step reports it as
    /// [`crate::ParticleError::Proposal`] with the particle's index.
    type Error: std::error::Error + Send + Sync + 'static;
    /// Per-chunk working memory (`()` when none is needed).
    type Scratch: Default + Send;
    /// Draws a child of `parent` at time `k` given `z`; returns it with the
    /// log incremental weight.
    ///
    /// # Errors
    /// [`Proposal::Error`].
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &T,
        z: &Z,
        scratch: &mut Self::Scratch,
        rng: &mut R,
    ) -> Result<(T, f64), Self::Error>;
}

/// The transition prior as proposal (bootstrap / SIR filter): needs only a
/// [`Model`].
#[derive(Debug, Clone, Copy)]
pub struct Bootstrap<'a, S>(pub &'a S);

impl<const N: usize, S: Model<N>> Proposal<SVector<f64, N>, S::Observation> for Bootstrap<'_, S> {
    type Error = Infallible;
    type Scratch = ();
    #[inline(always)]
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &SVector<f64, N>,
        z: &S::Observation,
        _scratch: &mut (),
        rng: &mut R,
    ) -> Result<(SVector<f64, N>, f64), Infallible> {
        let x = self.0.sample_transition(k, parent, rng);
        let lw = self.0.log_likelihood(k, &x, z);
        Ok((x, lw))
    }
}

/// A Kalman step that turns a particle's Gaussian and the measurement into
/// the proposal `N(mu_k, P_k)`, with local model `D`.
pub trait LocalFilter<const N: usize, const M: usize, D>: Sync {
    /// The proposal Gaussian for the particle belief `prior`.
    ///
    /// # Errors
    /// Whatever the filter reports (a non-positive-definite matrix, ...).
    fn proposal(
        &self,
        prior: &Gaussian<N>,
        model: &D,
        z: &SVector<f64, M>,
    ) -> Result<Gaussian<N>, KalmanError>;
}

impl<const N: usize, const M: usize, D, F: LocalFilter<N, M, D>> LocalFilter<N, M, D> for &F {
    fn proposal(
        &self,
        prior: &Gaussian<N>,
        model: &D,
        z: &SVector<f64, M>,
    ) -> Result<Gaussian<N>, KalmanError> {
        (**self).proposal(prior, model, z)
    }
}

/// The EKF and IEKF proposals: predict, then update with `z_k`.
macro_rules! linearised_local_filter {
    ($filter:ty) => {
        impl<const N: usize, const M: usize, D> LocalFilter<N, M, D> for $filter
        where
            D: DynamicsJacobian<N> + MeasurementJacobian<N, M>,
        {
            fn proposal(
                &self,
                prior: &Gaussian<N>,
                model: &D,
                z: &SVector<f64, M>,
            ) -> Result<Gaussian<N>, KalmanError> {
                let predicted = self.predict(prior, model)?;
                Ok(self.update(&predicted, model, Some(z))?.posterior)
            }
        }
    };
}

linearised_local_filter!(Ekf);
linearised_local_filter!(Iekf);

/// The unscented particle filter's local step: the augmented-state UKF of
/// Nagy, Ahmed and Zayed (paper 000) sec. 3.3 (a), one sigma-point set of `[x, v, n]` through `f`
/// and `h` (additive noise).
impl<const N: usize, const M: usize, D> LocalFilter<N, M, D> for Ukf
where
    D: Dynamics<N> + Measurement<N, M> + Sync,
{
    fn proposal(
        &self,
        prior: &Gaussian<N>,
        model: &D,
        z: &SVector<f64, M>,
    ) -> Result<Gaussian<N>, KalmanError> {
        // the filter's own noise form decides (`Ukf::with_noise_form`): the
        // unscented particle filter of van der Merwe et al. uses the
        // augmented one
        let step = self.step(prior, model, model, Some(z))?;
        Ok(step.update.posterior)
    }
}

/// HIKPF's local step: augmented UKF, then IEKF refinement.
impl<const N: usize, const M: usize, D> LocalFilter<N, M, D> for HybridUkfIekf
where
    D: Dynamics<N> + MeasurementJacobian<N, M> + Sync,
{
    fn proposal(
        &self,
        prior: &Gaussian<N>,
        model: &D,
        z: &SVector<f64, M>,
    ) -> Result<Gaussian<N>, KalmanError> {
        Ok(self
            .step(prior, &Additive(model), model, Some(z))?
            .update
            .posterior)
    }
}

/// A particle filter proposal from a bank of local Kalman filters, one per
/// particle: `model` gives the true densities of the weight (its
/// likelihood and its [`TransitionDensity`]), `local` the Gaussian model the
/// filters use (their `Q` and `R` may differ from the truth: a wider
/// proposal is often better), `filter` the kind of filter.
#[derive(Debug, Clone, Copy)]
pub struct KalmanProposal<'a, S, D, F> {
    /// The target model.
    pub model: &'a S,
    /// The local filters' Gaussian model.
    pub local: &'a D,
    /// The local filter.
    pub filter: F,
}

impl<const N: usize, const M: usize, S, D, F> Proposal<KalmanParticle<N>, SVector<f64, M>>
    for KalmanProposal<'_, S, D, F>
where
    S: TransitionDensity<N, Observation = SVector<f64, M>>,
    D: Sync,
    F: LocalFilter<N, M, D>,
{
    type Error = KalmanError;
    type Scratch = ();
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &KalmanParticle<N>,
        z: &SVector<f64, M>,
        _scratch: &mut (),
        rng: &mut R,
    ) -> Result<(KalmanParticle<N>, f64), KalmanError> {
        let prior = Gaussian::new(parent.x, parent.cov)?;
        let q = self.filter.proposal(&prior, self.local, z)?;
        let fq = q.factor()?;
        let x = fq.sample(rng);
        let lw = self.model.log_likelihood(k, &x, z) + self.model.log_transition(k, &parent.x, &x)
            - fq.log_pdf(&x)?;
        Ok((KalmanParticle { x, cov: *q.cov() }, lw))
    }
}
