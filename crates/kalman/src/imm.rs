//! The interacting multiple model (IMM) estimator (Blom and Bar-Shalom
//! 1988; Bar-Shalom, Li and Kirubarajan 2001, sec. 11.6) over any mix of
//! the crate's filters, each model mixed in its own belief form.

use nalgebra::SVector;

use crate::belief::{Belief, ModeBelief};
use crate::error::{KalmanError, Result};
use crate::filter::KalmanFilter;
use crate::gaussian::Gaussian;
use crate::update::Innovation;

/// One model of an [`Imm`]: mixes the mode beliefs into its own form,
/// predicts and updates. [`Mode`] implements it for every filter of the
/// crate; it is object safe, so an IMM holds models of different filter,
/// dynamics and measurement types.
pub trait ImmModel<const N: usize, const M: usize> {
    /// The mixed prior `sum_i weights[i] beliefs[i]` in this model's belief
    /// form ([`Belief::mix`]), predicted and updated with `z`: the
    /// posterior and the innovation (`None` when `z` is missing).
    ///
    /// # Errors
    /// As [`Belief::mix`] and the filter's `predict` and `update`.
    fn step(
        &self,
        weights: &[f64],
        beliefs: &[ModeBelief<N>],
        z: Option<&SVector<f64, M>>,
    ) -> Result<(ModeBelief<N>, Option<Innovation<M>>)>;
}

/// A filter with its dynamics and measurement models: one model of an
/// [`Imm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode<F, D, H> {
    /// The filter (any of the crate's, in its own belief form).
    pub filter: F,
    /// The dynamics of this mode.
    pub dynamics: D,
    /// The measurement model of this mode.
    pub measurement: H,
}

impl<F, D, H> Mode<F, D, H> {
    /// A mode from its filter and models.
    pub fn new(filter: F, dynamics: D, measurement: H) -> Self {
        Self {
            filter,
            dynamics,
            measurement,
        }
    }
}

impl<const N: usize, const M: usize, F, D, H> ImmModel<N, M> for Mode<F, D, H>
where
    F: KalmanFilter<N, M, D, H>,
{
    fn step(
        &self,
        weights: &[f64],
        beliefs: &[ModeBelief<N>],
        z: Option<&SVector<f64, M>>,
    ) -> Result<(ModeBelief<N>, Option<Innovation<M>>)> {
        let mixed = F::Belief::mix(weights, beliefs)?;
        let predicted = self.filter.predict(&mixed, &self.dynamics)?;
        let update = self.filter.update(&predicted, &self.measurement, z)?;
        Ok((update.posterior.into_mode(), update.innovation))
    }
}

/// The belief of an [`Imm`]: the mode probabilities and each model's
/// belief in its own form.
#[derive(Debug, Clone, PartialEq)]
pub struct ImmBelief<const N: usize> {
    probabilities: Vec<f64>,
    modes: Vec<ModeBelief<N>>,
}

impl<const N: usize> ImmBelief<N> {
    /// The mode probabilities (summing to 1).
    pub fn probabilities(&self) -> &[f64] {
        &self.probabilities
    }

    /// Each model's belief, in its own form.
    pub fn modes(&self) -> &[ModeBelief<N>] {
        &self.modes
    }

    /// The combined estimate: the moment-matched mixture of the mode
    /// beliefs with the mode probabilities.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`] when the mixture overflows.
    pub fn estimate(&self) -> Result<Gaussian<N>> {
        Gaussian::mix(&self.probabilities, &self.modes)
    }
}

/// What [`Imm::step`] returns ([`Imm::step_into`] fills one; the default
/// is empty, its buffers to be grown by the first step).
#[derive(Debug, Clone, PartialEq)]
pub struct ImmStep<const N: usize, const M: usize> {
    /// The belief after the step.
    pub belief: ImmBelief<N>,
    /// Each model's innovation (`None` for a missing measurement).
    pub innovations: Vec<Option<Innovation<M>>>,
    /// `ln p(z_k | z_{1:k-1})` of the mixture, `ln sum_j cbar_j L_j`
    /// (`None` for a missing measurement).
    pub log_likelihood: Option<f64>,
}

impl<const N: usize, const M: usize> Default for ImmStep<N, M> {
    fn default() -> Self {
        Self {
            belief: ImmBelief {
                probabilities: Vec::new(),
                modes: Vec::new(),
            },
            innovations: Vec::new(),
            log_likelihood: None,
        }
    }
}

/// The interacting multiple model estimator: `r` models (any mix of KF,
/// EKF, IEKF, UKF, CKF and SR-UKF [`Mode`]s, or any [`ImmModel`]) and a
/// Markov chain over them with transition matrix `p[i][j] = P(mode j at k
/// | mode i at k - 1)`.
///
/// One [`Imm::step`] is filterpy's `IMMEstimator.predict` then `update`:
/// 1. predicted mode probabilities `cbar_j = sum_i p_ij mu_i` and mixing
///    weights `w_{i|j} = p_ij mu_i / cbar_j`;
/// 2. each model `j` mixes the mode beliefs with `w_{.|j}` in its own
///    belief form (a square-root model mixes factors by rotations), then
///    predicts and updates;
/// 3. `mu_j = cbar_j L_j / sum_l cbar_l L_l` with the models' measurement
///    likelihoods `L_j`, in the log domain (no underflow to 0/0 when every
///    likelihood is tiny); a missing measurement leaves `mu = cbar`.
///
/// The combined estimate is [`ImmBelief::estimate`].
///
/// ```
/// use bayestrack_kalman::{
///     Gaussian, Imm, Kf, LinearDynamics, LinearMeasurement, Mode, NoiseModel, SrUkf,
/// };
/// use nalgebra::{Matrix2, Vector2, Vector4};
///
/// let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25)?;
/// let quiet = LinearDynamics::<4>::constant_velocity(0.1, 0.01, NoiseModel::Discrete)?;
/// let agile = LinearDynamics::<4>::constant_velocity(0.1, 5.0, NoiseModel::Discrete)?;
/// let imm = Imm::new(
///     vec![
///         Box::new(Mode::new(Kf::default(), quiet, sensor)),
///         // a square-root model beside it, mixed as a factor
///         Box::new(Mode::new(SrUkf::new(1.0, 2.0, 0.0)?, agile, sensor)),
///     ],
///     &[0.95, 0.05, 0.05, 0.95],
/// )?;
/// let start = Gaussian::diagonal(Vector4::zeros(), Vector4::repeat(1.0))?;
/// let mut belief = imm.start(&[0.5, 0.5], &start)?;
/// for k in 0..10 {
///     let z = Vector2::new(0.1 * k as f64, 0.0);
///     belief = imm.step(&belief, Some(&z))?.belief;
/// }
/// assert!(belief.probabilities()[0] > 0.5);
/// let estimate = belief.estimate()?;
/// assert!((estimate.mean()[0] - 0.9).abs() < 0.2);
/// # Ok::<(), bayestrack_kalman::KalmanError>(())
/// ```
pub struct Imm<'a, const N: usize, const M: usize> {
    models: Vec<Box<dyn ImmModel<N, M> + 'a>>,
    /// Row-major `r x r`.
    transition: Vec<f64>,
}

impl<const N: usize, const M: usize> core::fmt::Debug for Imm<'_, N, M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Imm")
            .field("models", &self.models.len())
            .field("transition", &self.transition)
            .finish()
    }
}

/// Checks a probability vector (finite, non-negative, summing to 1 within
/// 1e-9).
fn check_probabilities(p: &[f64], name: &'static str) -> Result<()> {
    let mut total = 0.0;
    for &x in p {
        if !(x.is_finite() && x >= 0.0) {
            return Err(KalmanError::InvalidParameter {
                name,
                value: x,
                reason: "probabilities must be finite and non-negative",
            });
        }
        total += x;
    }
    if (total - 1.0).abs() > 1e-9 {
        return Err(KalmanError::InvalidParameter {
            name,
            value: total,
            reason: "probabilities must sum to 1 (each row of the transition matrix)",
        });
    }
    Ok(())
}

impl<'a, const N: usize, const M: usize> Imm<'a, N, M> {
    /// An IMM over `models` with the row-major `r x r` Markov transition
    /// matrix `transition` (`r` models; row `i` the probabilities of the
    /// next mode given mode `i`).
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] naming "models" when there are
    /// none, or "transition matrix" when it is not `r x r` or a row is not
    /// a probability vector (finite, non-negative, summing to 1 within
    /// 1e-9).
    pub fn new(models: Vec<Box<dyn ImmModel<N, M> + 'a>>, transition: &[f64]) -> Result<Self> {
        let r = models.len();
        if r == 0 {
            return Err(KalmanError::InvalidParameter {
                name: "models",
                value: 0.0,
                reason: "an IMM needs at least one model",
            });
        }
        if transition.len() != r * r {
            return Err(KalmanError::InvalidParameter {
                name: "transition matrix",
                value: transition.len() as f64,
                reason: "must have r x r entries (r: the number of models)",
            });
        }
        for row in transition.chunks(r) {
            check_probabilities(row, "transition matrix")?;
        }
        Ok(Self {
            models,
            transition: transition.to_vec(),
        })
    }

    /// The number of models.
    pub fn len(&self) -> usize {
        self.models.len()
    }

    /// Always false (an IMM has at least one model).
    pub fn is_empty(&self) -> bool {
        self.models.is_empty()
    }

    /// The belief with mode probabilities `probabilities` and every model
    /// starting from `start` (in its own form at the first mixing).
    ///
    /// # Errors
    /// As [`Imm::belief`].
    pub fn start(&self, probabilities: &[f64], start: &Gaussian<N>) -> Result<ImmBelief<N>> {
        self.belief(probabilities, vec![ModeBelief::Full(*start); self.len()])
    }

    /// The belief with mode probabilities `probabilities` and the models'
    /// beliefs `modes` (one per model, in any form).
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] naming "mode probabilities" when
    /// there is not one per model or they are not a probability vector, or
    /// "mode beliefs" when there is not one per model.
    pub fn belief(&self, probabilities: &[f64], modes: Vec<ModeBelief<N>>) -> Result<ImmBelief<N>> {
        self.check_belief(probabilities, modes.len())?;
        Ok(ImmBelief {
            probabilities: probabilities.to_vec(),
            modes,
        })
    }

    /// One IMM cycle: mixing, each model's predict and update, mode
    /// probabilities (see [`Imm`]).
    ///
    /// # Errors
    /// As [`Imm::belief`] for a belief of another IMM; the first error of a
    /// model's mixing, predict or update.
    pub fn step(
        &self,
        belief: &ImmBelief<N>,
        z: Option<&SVector<f64, M>>,
    ) -> Result<ImmStep<N, M>> {
        let mut out = ImmStep::default();
        self.step_into(belief, z, &mut out)?;
        Ok(out)
    }

    /// [`Imm::step`] into `out`, reusing its buffers: once they have grown
    /// to the number of models (after the first call), a step allocates
    /// nothing on the heap (with up to 16 models; more take one buffer of
    /// mixing weights per step), given models whose own steps do not (the
    /// crate's filters do not). Alternate two [`ImmStep`]s to run a filter
    /// in place:
    ///
    /// ```
    /// # use bayestrack_kalman::{Gaussian, Imm, ImmStep, Kf, LinearDynamics, LinearMeasurement, Mode, NoiseModel};
    /// # use nalgebra::{Matrix2, Vector2, Vector4};
    /// # let sensor = LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25)?;
    /// # let quiet = LinearDynamics::<4>::constant_velocity(0.1, 0.01, NoiseModel::Discrete)?;
    /// # let agile = LinearDynamics::<4>::constant_velocity(0.1, 5.0, NoiseModel::Discrete)?;
    /// let imm = Imm::new(
    ///     vec![
    ///         Box::new(Mode::new(Kf::default(), quiet, sensor)),
    ///         Box::new(Mode::new(Kf::default(), agile, sensor)),
    ///     ],
    ///     &[0.95, 0.05, 0.05, 0.95],
    /// )?;
    /// let start = Gaussian::diagonal(Vector4::zeros(), Vector4::repeat(1.0))?;
    /// let mut now = ImmStep { belief: imm.start(&[0.5, 0.5], &start)?, ..ImmStep::default() };
    /// let mut next = ImmStep::default();
    /// for k in 0..10 {
    ///     let z = Vector2::new(0.1 * k as f64, 0.0);
    ///     imm.step_into(&now.belief, Some(&z), &mut next)?;
    ///     std::mem::swap(&mut now, &mut next);
    /// }
    /// assert_eq!(now.belief, {
    ///     let mut b = imm.start(&[0.5, 0.5], &start)?;
    ///     for k in 0..10 {
    ///         b = imm.step(&b, Some(&Vector2::new(0.1 * k as f64, 0.0)))?.belief;
    ///     }
    ///     b
    /// });
    /// # Ok::<(), bayestrack_kalman::KalmanError>(())
    /// ```
    ///
    /// # Errors
    /// As [`Imm::step`]; `out` then holds a partial step.
    pub fn step_into(
        &self,
        belief: &ImmBelief<N>,
        z: Option<&SVector<f64, M>>,
        out: &mut ImmStep<N, M>,
    ) -> Result<()> {
        let r = self.len();
        self.check_belief(&belief.probabilities, belief.modes.len())?;
        let mu = &belief.probabilities;
        let p = |i: usize, j: usize| self.transition[i * r + j];
        let mut stack = [0.0; 16];
        let mut heap = Vec::new();
        let weights: &mut [f64] = if r <= stack.len() {
            &mut stack[..r]
        } else {
            heap.resize(r, 0.0);
            &mut heap
        };
        let ImmStep {
            belief: ImmBelief {
                probabilities,
                modes,
            },
            innovations,
            log_likelihood,
        } = out;
        probabilities.clear();
        modes.clear();
        innovations.clear();
        for (j, model) in self.models.iter().enumerate() {
            let cbar: f64 = (0..r).map(|i| p(i, j) * mu[i]).sum();
            if cbar > 0.0 {
                for (i, w) in weights.iter_mut().enumerate() {
                    *w = p(i, j) * mu[i] / cbar;
                }
            } else {
                // unreachable mode: its probability stays 0; it keeps its
                // own belief
                weights.fill(0.0);
                weights[j] = 1.0;
            }
            let (posterior, innovation) = model.step(weights, &belief.modes, z)?;
            // the predicted probability, until the likelihoods are in
            probabilities.push(cbar);
            modes.push(posterior);
            innovations.push(innovation);
        }
        *log_likelihood = if z.is_some() {
            // ln cbar_j + ln L_j, normalised by log-sum-exp
            for (l, i) in probabilities.iter_mut().zip(innovations.iter()) {
                *l = l.ln() + i.as_ref().map_or(0.0, |i| i.log_likelihood());
            }
            let top = probabilities
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let sum: f64 = probabilities.iter().map(|l| (l - top).exp()).sum();
            let log_norm = top + sum.ln();
            for l in probabilities.iter_mut() {
                *l = (*l - log_norm).exp();
            }
            Some(log_norm)
        } else {
            None
        };
        Ok(())
    }

    /// The checks of [`Imm::belief`] on a belief's probabilities and number
    /// of mode beliefs.
    fn check_belief(&self, probabilities: &[f64], modes: usize) -> Result<()> {
        if probabilities.len() != self.len() {
            return Err(KalmanError::InvalidParameter {
                name: "mode probabilities",
                value: probabilities.len() as f64,
                reason: "one per model",
            });
        }
        check_probabilities(probabilities, "mode probabilities")?;
        if modes != self.len() {
            return Err(KalmanError::InvalidParameter {
                name: "mode beliefs",
                value: modes as f64,
                reason: "one per model",
            });
        }
        Ok(())
    }
}
