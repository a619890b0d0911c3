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
use nalgebra::SVector;
use rand::Rng;

use crate::set::KalmanParticle;

/// What a bootstrap particle filter needs of a state-space model: a way
/// to draw from the transition `p(x_k | x_{k-1})` and the likelihood
/// `p(z_k | x_k)` (Nagy, Ahmed and Zayed (paper 000) eq. 7-9 with `q` the
/// transition prior). Both see the time index `k` of the state being drawn
/// or weighed: the set starts at `k = 0`, the first step draws `x_1`.
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
pub trait Model<const N: usize, const M: usize>: Sync {
    /// Draws `x_k ~ p(. | x_{k-1})`.
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        k: usize,
        x_prev: &SVector<f64, N>,
        rng: &mut R,
    ) -> SVector<f64, N>;
    /// `log p(z_k | x_k)` (an unnormalised log density is enough: the
    /// weights are normalised, only the log evidence of a step moves).
    fn log_likelihood(&self, k: usize, x: &SVector<f64, N>, z: &SVector<f64, M>) -> f64;
}

/// The transition density `log p(x_k | x_{k-1})` of a [`Model`]: the
/// `p(x_k | x_{k-1})` of the incremental weight (paper 000 eq. 9) of every
/// proposal that is not the transition prior.
pub trait TransitionDensity<const N: usize, const M: usize>: Model<N, M> {
    /// `log p(x_k | x_{k-1})` (minus infinity outside the support).
    fn log_transition(&self, k: usize, x_prev: &SVector<f64, N>, x: &SVector<f64, N>) -> f64;
}

/// A time-invariant model with its transition density, in one trait: the
/// first form of the particle API, kept for the code written against it.
/// Every `StateSpaceModel` is a [`Model`] and a [`TransitionDensity`] that
/// ignore the time index; new models implement [`Model`] (and
/// [`TransitionDensity`] only when a proposal needs it).
pub trait StateSpaceModel<const N: usize, const M: usize>: Sync {
    /// Draws `x_k ~ p(. | x_{k-1})`.
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        x_prev: &SVector<f64, N>,
        rng: &mut R,
    ) -> SVector<f64, N>;
    /// `log p(x_k | x_{k-1})` (minus infinity outside the support).
    fn log_transition(&self, x_prev: &SVector<f64, N>, x: &SVector<f64, N>) -> f64;
    /// `log p(z_k | x_k)`.
    fn log_likelihood(&self, x: &SVector<f64, N>, z: &SVector<f64, M>) -> f64;
}

impl<const N: usize, const M: usize, S: StateSpaceModel<N, M>> Model<N, M> for S {
    #[inline(always)]
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x_prev: &SVector<f64, N>,
        rng: &mut R,
    ) -> SVector<f64, N> {
        StateSpaceModel::sample_transition(self, x_prev, rng)
    }
    #[inline(always)]
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, N>, z: &SVector<f64, M>) -> f64 {
        StateSpaceModel::log_likelihood(self, x, z)
    }
}

impl<const N: usize, const M: usize, S: StateSpaceModel<N, M>> TransitionDensity<N, M> for S {
    #[inline(always)]
    fn log_transition(&self, _k: usize, x_prev: &SVector<f64, N>, x: &SVector<f64, N>) -> f64 {
        StateSpaceModel::log_transition(self, x_prev, x)
    }
}

/// An importance proposal for particles of type `T` and measurements `Z`.
pub trait Proposal<T, Z: ?Sized>: Sync {
    /// Draws a child of `parent` at time `k` given `z`; returns it with the
    /// log incremental weight.
    ///
    /// # Errors
    /// The local filter's error, for Kalman proposals.
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &T,
        z: &Z,
        rng: &mut R,
    ) -> Result<(T, f64), KalmanError>;
}

/// The transition prior as proposal (bootstrap / SIR filter): needs only a
/// [`Model`].
#[derive(Debug, Clone, Copy)]
pub struct Bootstrap<'a, S>(pub &'a S);

impl<const N: usize, const M: usize, S: Model<N, M>> Proposal<SVector<f64, N>, SVector<f64, M>>
    for Bootstrap<'_, S>
{
    #[inline(always)]
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &SVector<f64, N>,
        z: &SVector<f64, M>,
        rng: &mut R,
    ) -> Result<(SVector<f64, N>, f64), KalmanError> {
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
        let step = self.step_augmented(prior, &Additive(model), &Additive(model), Some(z))?;
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
    S: TransitionDensity<N, M>,
    D: Sync,
    F: LocalFilter<N, M, D>,
{
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &KalmanParticle<N>,
        z: &SVector<f64, M>,
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
