//! The hybrid UKF -> IEKF step of the HIKPF proposal (Nagy, Ahmed and Zayed (paper 000) sec. 3.3,
//! steps (a)-(b)).
//!
//! (a) An augmented UKF step (`x_a = [x, v, n]`, one sigma-point set through
//! `f` then `h`) gives the UKF estimate `x_uf`. (b) An IEKF measurement
//! update refines it, relinearising `h` about its latest iterate, starting
//! from `x_uf`.
//!
//! The paper's step (b) also re-predicts `f(x_uf)` before the IEKF update.
//! Read literally that advances the state a second time step (the UKF step
//! already predicted to time `k`), so it is not offered. What remains
//! ambiguous is the prior of the IEKF update, which is a named choice
//! ([`HybridPrior`]).

use nalgebra::SVector;

use crate::error::Result;
use crate::gaussian::Gaussian;
use crate::kf::Iekf;
use crate::model::{Additive, MeasurementJacobian, NoisyDynamics};
use crate::ukf::{Ukf, UkfStep};
use crate::update::Update;

/// Which belief the IEKF refinement of step (b) takes as its prior.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum HybridPrior {
    /// The UKF's predicted belief `x_{k|k-1}`, linearised first about the
    /// UKF posterior `x_uf`: the measurement is used once, and the UKF only
    /// supplies the starting point of the Gauss-Newton iterations.
    #[default]
    UkfPredicted,
    /// The UKF posterior `(x_uf, P_uf)` itself, as the paper's wording
    /// ("update the estimations obtained through the UKF") reads: the
    /// measurement is used twice, so the result is over-confident.
    UkfPosterior,
}

/// The hybrid UKF -> IEKF step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HybridUkfIekf {
    /// The unscented filter of step (a).
    pub ukf: Ukf,
    /// The iterated filter of step (b); its `max_iterations` is Nagy, Ahmed and Zayed's (paper 000) `c`.
    pub iekf: Iekf,
    /// Prior of step (b).
    pub prior: HybridPrior,
}

/// Output of [`HybridUkfIekf::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HybridStep<const N: usize, const M: usize> {
    /// Step (a): the UKF's prediction and update.
    pub ukf: UkfStep<N, M>,
    /// Step (b): the IEKF refinement, the final belief.
    pub update: Update<N, M>,
}

impl HybridUkfIekf {
    /// Combines the two filters with the default prior choice.
    pub fn new(ukf: Ukf, iekf: Iekf) -> Self {
        Self {
            ukf,
            iekf,
            prior: HybridPrior::default(),
        }
    }

    /// One step from the belief at `k-1` to the belief at `k`. The process
    /// noise may be non-additive and non-zero-mean (augmented UKF); the
    /// measurement noise is additive (the IEKF needs `H = dh/dx`).
    ///
    /// # Errors
    /// Any error of [`Ukf::step_augmented`] or [`Iekf::update_from`].
    pub fn step<
        const N: usize,
        const V: usize,
        const M: usize,
        D: NoisyDynamics<N, V>,
        H: MeasurementJacobian<N, M>,
    >(
        &self,
        prior: &Gaussian<N>,
        dynamics: &D,
        measurement: &H,
        z: Option<&SVector<f64, M>>,
    ) -> Result<HybridStep<N, M>> {
        let ukf = self
            .ukf
            .step_augmented(prior, dynamics, &Additive(measurement), z)?;
        let x_uf = ukf.update.posterior.mean();
        let update = match self.prior {
            HybridPrior::UkfPredicted => {
                self.iekf
                    .update_from(&ukf.predicted, x_uf, measurement, z)?
            }
            HybridPrior::UkfPosterior => {
                self.iekf
                    .update_from(&ukf.update.posterior, x_uf, measurement, z)?
            }
        };
        Ok(HybridStep { ukf, update })
    }
}
