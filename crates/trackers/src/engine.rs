//! The particle engine of the trackers: `bayestrack-particle`'s
//! [`ParticleFilter`] stepping a set of states whose likelihood is an
//! appearance [`Cue`].
//!
//! A particle tracker supplies a [`StateModel`] (how a state moves, and
//! the window or pose it is scored as) and a cue; [`CueProposal`] makes the
//! two a bootstrap [`Proposal`] (draw from the dynamics, weigh by the cue),
//! and [`CueFilter`] runs it: keyed random streams (the same bits on any
//! number of threads), log-domain weights, any of the four resamplers,
//! resampling before or after the weights ([`ResampleTiming`]), and the
//! cue's per-chunk [`Scratch`] kept from frame to frame, so that a step
//! allocates nothing once warm.
//!
//! ```
//! use bayestrack_appearance::{Candidate, Frame};
//! use bayestrack_image::Rect;
//! use bayestrack_particle::rand::Rng;
//! use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
//! use bayestrack_trackers::StateModel;
//! use nalgebra::{SVector, Vector2};
//!
//! /// A 9 x 9 window whose centre takes a Gaussian random walk.
//! struct Walk {
//!     sigma: f64,
//!     frame: (usize, usize),
//! }
//!
//! impl StateModel<2> for Walk {
//!     fn predict<R: Rng + ?Sized>(&self, _k: usize, x: &SVector<f64, 2>, rng: &mut R) -> SVector<f64, 2> {
//!         let n: [f64; 2] = [StandardNormal.sample(rng), StandardNormal.sample(rng)];
//!         x + self.sigma * Vector2::new(n[0], n[1])
//!     }
//!     fn candidate(&self, x: &SVector<f64, 2>) -> Option<Candidate> {
//!         let (x0, y0) = (x[0].round() - 4.0, x[1].round() - 4.0);
//!         let inside = x0 >= 0.0 && y0 >= 0.0
//!             && x0 + 9.0 <= self.frame.0 as f64 && y0 + 9.0 <= self.frame.1 as f64;
//!         // a window off the frame is an impossible state: zero likelihood
//!         inside.then(|| Candidate::Window(Rect::new(x0 as usize, y0 as usize, 9, 9)))
//!     }
//! }
//! # let _ = Walk { sigma: 1.0, frame: (32, 32) };
//! ```

use bayestrack_appearance::{AppearanceError, Candidate, Cue, Frame, Scratch};
use bayestrack_particle::{ParticleFilter, ParticleSet, Proposal, ResampleTiming, Smc, StepReport};
use nalgebra::SVector;
use rand::Rng;

use crate::error::Result;

/// How a tracker's particle states move, and what each is scored as.
pub trait StateModel<const D: usize>: Sync {
    /// Draws `x_k ~ p(x_k | x_{k-1})` (drift and diffusion) for frame `k`.
    fn predict<R: Rng + ?Sized>(
        &self,
        k: usize,
        x: &SVector<f64, D>,
        rng: &mut R,
    ) -> SVector<f64, D>;

    /// The window or pose the cue scores state `x` as; `None` for an
    /// impossible state (off the frame, say), which gets zero likelihood.
    fn candidate(&self, x: &SVector<f64, D>) -> Option<Candidate>;
}

/// The bootstrap proposal of a particle tracker: draw from the
/// [`StateModel`], weigh by the [`Cue`] (a candidate that leaves the frame
/// weighs zero, [`Cue::log_likelihood_or_zero`]; any other cue error
/// fails the step, naming the particle).
#[derive(Debug)]
pub struct CueProposal<'a, M: ?Sized, C: ?Sized> {
    /// The dynamics and the state-to-candidate map.
    pub model: &'a M,
    /// The likelihood.
    pub cue: &'a C,
}

impl<'f, const D: usize, M, C> Proposal<SVector<f64, D>, Frame<'f>> for CueProposal<'_, M, C>
where
    M: StateModel<D> + ?Sized,
    C: Cue + Sync + ?Sized,
{
    type Error = AppearanceError;
    type Scratch = Scratch;

    #[inline]
    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &SVector<f64, D>,
        frame: &Frame<'f>,
        scratch: &mut Scratch,
        rng: &mut R,
    ) -> std::result::Result<(SVector<f64, D>, f64), AppearanceError> {
        let x = self.model.predict(k, parent, rng);
        let l = match self.model.candidate(&x) {
            Some(c) => self.cue.log_likelihood_or_zero(frame, &c, scratch)?,
            None => f64::NEG_INFINITY,
        };
        Ok((x, l))
    }
}

/// A running particle filter over `D`-dimensional states weighed by a
/// cue: a [`Smc`] (configuration, set, seed; frame `k` keyed `[seed, k]`)
/// and the cue's per-chunk working memory.
#[derive(Debug, Clone)]
pub struct CueFilter<const D: usize> {
    smc: Smc<SVector<f64, D>>,
    scratch: Vec<Scratch>,
}

impl<const D: usize> CueFilter<D> {
    /// A filter that starts from `particles` (equally weighted); `seed`
    /// keys its random streams (mix in the tracker's own key with
    /// [`bayestrack_particle::stream_seed`]).
    ///
    /// # Errors
    /// [`TrackerError::Particle`](crate::TrackerError::Particle) for no
    /// particles, a non-finite one or a bad configuration.
    pub fn new(filter: ParticleFilter, particles: Vec<SVector<f64, D>>, seed: u64) -> Result<Self> {
        Ok(Self {
            smc: Smc::new(filter, ParticleSet::new(particles)?, seed)?,
            scratch: Vec::new(),
        })
    }

    /// One step on `frame`: (select,) predict, measure, normalise.
    ///
    /// # Errors
    /// [`TrackerError::Particle`](crate::TrackerError::Particle): the
    /// cue's error naming the particle, all weights zero (unless the
    /// configuration ignores such a measurement), a non-finite weight.
    pub fn step<M, C>(&mut self, model: &M, cue: &C, frame: &Frame<'_>) -> Result<StepReport<D>>
    where
        M: StateModel<D> + ?Sized,
        C: Cue + Sync + ?Sized,
    {
        let proposal = CueProposal { model, cue };
        Ok(self.smc.step_with(&proposal, frame, &mut self.scratch)?)
    }

    /// The particles and their weights.
    pub fn set(&self) -> &ParticleSet<SVector<f64, D>> {
        &self.smc.set
    }

    /// Moves every state in place with `f`, the weights left as they are
    /// (a re-initialisation that moves the set, such as the c-AVQ shift of
    /// CONDENSATION).
    pub fn move_states(&mut self, mut f: impl FnMut(&mut SVector<f64, D>)) {
        let (states, _) = self.smc.set.parts_mut();
        states.iter_mut().for_each(&mut f);
    }

    /// Adds `log_increments[i]` to particle `i`'s log weight and normalises
    /// the weights: a measurement that needs the whole set before it can
    /// weigh one particle (a cue normalised over the particles), applied
    /// after a [`CueFilter::step`] with a flat cue. Returns the effective
    /// sample size afterwards.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`](crate::TrackerError::InvalidParameter)
    /// when the increments are not one per particle or one is NaN or
    /// `+inf`; [`TrackerError::Particle`](crate::TrackerError::Particle)
    /// when every weight would be zero. The set is unchanged on error.
    pub fn reweigh(&mut self, log_increments: &[f64]) -> Result<f64> {
        let n = self.smc.set.len();
        if log_increments.len() != n {
            return Err(crate::TrackerError::InvalidParameter {
                name: "log_increments",
                value: log_increments.len() as f64,
                reason: "must hold one increment per particle",
            });
        }
        if let Some(&bad) = log_increments
            .iter()
            .find(|l| l.is_nan() || **l == f64::INFINITY)
        {
            return Err(crate::TrackerError::InvalidParameter {
                name: "log_increments",
                value: bad,
                reason: "must be finite or -inf (zero likelihood)",
            });
        }
        let saved = self.smc.set.log_weights().to_vec();
        let (_, log_w) = self.smc.set.parts_mut();
        for (l, d) in log_w.iter_mut().zip(log_increments) {
            *l += d;
        }
        if let Err(e) = self.smc.set.normalize() {
            let (_, log_w) = self.smc.set.parts_mut();
            log_w.copy_from_slice(&saved);
            return Err(e.into());
        }
        Ok(self.smc.set.ess())
    }

    /// The configuration.
    pub fn filter(&self) -> &ParticleFilter {
        &self.smc.filter
    }

    /// The weighted mean of the states. After a step with
    /// [`ResampleTiming::BeforeProposal`] it is the frame's weighted
    /// estimate; after [`ResampleTiming::AfterWeighing`] the mean of the
    /// resampled set.
    pub fn mean(&self) -> SVector<f64, D> {
        self.smc.set.mean()
    }

    /// The number of particles.
    pub fn len(&self) -> usize {
        self.smc.set.len()
    }

    /// Whether the set is empty (never, once built).
    pub fn is_empty(&self) -> bool {
        self.smc.set.is_empty()
    }
}

/// The SIR filter of the trackers: resample (the given scheme, every
/// frame) before the proposal, so a step leaves the weighted set.
pub fn select_predict_measure(resampling: bayestrack_particle::Resampling) -> ParticleFilter {
    ParticleFilter {
        resampling,
        timing: ResampleTiming::BeforeProposal,
        ..ParticleFilter::default()
    }
}
