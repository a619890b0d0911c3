//! The Rao-Blackwellised (marginalised) particle filter of Schön,
//! Gustafsson and Nordlund (2005), "Marginalized particle filters for
//! mixed linear/nonlinear state-space models", IEEE TSP 53(7), sec. II-IV,
//! for models linear-Gaussian given the nonlinear part:
//!
//! ```text
//! xn_k = fn(xn_{k-1}) + An(xn_{k-1}) xl_{k-1} + wn,   wn ~ N(0, Qn)
//! xl_k = fl(xn_{k-1}) + Al(xn_{k-1}) xl_{k-1} + wl,   wl ~ N(0, Ql)
//! z_k  = h(xn_k)      + C(xn_k) xl_k          + e,    e ~ N(0, R)
//! ```
//!
//! (`wn`, `wl` independent, or correlated by
//! [`ConditionallyLinear::cross_covariance`], the paper's correlated case).
//! Each particle carries a sample of the nonlinear state `xn` and a Gaussian
//! belief over the linear state `xl`, kept by a [`Kf`]. A step draws
//! `xn_k` from its marginal `N(fn + An xl, An P An^T + Qn)` (the paper's
//! eq. 25a), updates `xl_{k-1}` with the pseudo-measurement `xn_k - fn =
//! An xl + wn` (eq. 24b, skipped when `An = 0`), predicts it with `Al, Ql`
//! plus the offset `fl` (eq. 24a) and updates it with `z_k - h = C xl + e`;
//! the particle's weight increment is that update's Gaussian log-likelihood
//! `log N(z_k; h + C xl, C P C^T + R)` (eq. 25b). It is a [`Proposal`], so
//! [`crate::ParticleFilter::step`] runs it with its chunking, resampling
//! and thread-independent bits.
//!
//! Per-particle cost: one `NL`-dimensional KF predict and one update of
//! dimension `M`, plus, when `An != 0`, a second update of dimension `NN`
//! and an `NN x NN` Cholesky factor to draw `xn` (the pieces the model
//! returns are copied, not rechecked; an offset `fl != 0` costs one more
//! check of the predicted belief). On the bench's model (benches/rbpf.rs:
//! `NN = 1`, `NL = 3`, `M = 2`, `An != 0`) about 800 ns per particle-step,
//! 2.5 times the 316 ns of a bootstrap particle of the full 4-state model
//! (criterion on the 2-core development machine; the
//! `rbpf_vs_bootstrap` example measures 572 against 265 ns).

use bayestrack_kalman::{Gaussian, KalmanError, Kf, LinearDynamics, LinearMeasurement, Step};
use nalgebra::{SMatrix, SVector};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::proposal::Proposal;
use crate::set::{Finite, Particle, ParticleSet};

/// A mixed linear/nonlinear model (see [`RaoBlackwellised`]): for each
/// nonlinear state, the affine-Gaussian pieces the Kalman filter of the
/// linear part needs. Every piece sees the time index `k` of the state
/// being drawn or measured; the matrices are returned as the Kalman
/// crate's checked model types, so a model whose matrices do not depend on
/// `xn` builds them once and returns copies.
pub trait ConditionallyLinear<const NN: usize, const NL: usize, const M: usize>: Sync {
    /// `(fn(xn_{k-1}), [An(xn_{k-1}), Qn])`: the nonlinear state's
    /// transition, its linear part written as a measurement of `xl_{k-1}`
    /// (`xn_k - fn = An xl_{k-1} + wn`). `An = 0` and `Qn = 0` make `xn`
    /// deterministic.
    fn nonlinear(
        &self,
        k: usize,
        xn: &SVector<f64, NN>,
    ) -> (SVector<f64, NN>, LinearMeasurement<NL, NN>);
    /// `(fl(xn_{k-1}), [Al(xn_{k-1}), Ql])`: the linear state's transition.
    fn linear(&self, k: usize, xn: &SVector<f64, NN>) -> (SVector<f64, NL>, LinearDynamics<NL>);
    /// `(h(xn_k), [C(xn_k), R])`: the measurement.
    fn measurement(
        &self,
        k: usize,
        xn: &SVector<f64, NN>,
    ) -> (SVector<f64, M>, LinearMeasurement<NL, M>);

    /// The cross-covariance `Qln = E[wl wn^T]` (`NL x NN`, linear noise
    /// first) of the linear and the nonlinear state's process noise at
    /// step `k` (Schön, Gustafsson and Nordlund 2005, the model with
    /// correlated process noise); `None`, the default, for independent
    /// noises. The joint covariance `[[Ql, Qln], [Qln^T,
    /// Qn]]` must be positive semi-definite and `Qn` positive definite
    /// wherever `Qln` is not zero.
    fn cross_covariance(&self, k: usize, xn: &SVector<f64, NN>) -> Option<SMatrix<f64, NL, NN>> {
        let _ = (k, xn);
        None
    }
}

/// A particle of the Rao-Blackwellised filter: a sampled nonlinear state
/// and the Kalman belief over the linear state given its history.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbParticle<const NN: usize, const NL: usize> {
    /// The nonlinear state `xn`.
    pub xn: SVector<f64, NN>,
    /// `p(xl | xn_{0:k}, z_{1:k})`.
    pub xl: Gaussian<NL>,
}

impl<const NN: usize, const NL: usize> Finite for RbParticle<NN, NL> {
    fn is_finite(&self) -> bool {
        Finite::is_finite(&self.xn)
            && Finite::is_finite(self.xl.mean())
            && Finite::is_finite(self.xl.cov())
    }
}

/// The particle's state is its nonlinear part: [`ParticleSet::mean`] is the
/// nonlinear state's estimate ([`ParticleSet::linear_moments`] the linear
/// one's).
impl<const NN: usize, const NL: usize> Particle<NN> for RbParticle<NN, NL> {
    #[inline]
    fn state(&self) -> &SVector<f64, NN> {
        &self.xn
    }
}

impl<const NN: usize, const NL: usize> ParticleSet<RbParticle<NN, NL>> {
    /// Mean and covariance of the linear state under the mixture
    /// `sum_i w_i N(xl_i, P_i)`.
    pub fn linear_moments(&self) -> (SVector<f64, NL>, SMatrix<f64, NL, NL>) {
        let mut m = SVector::<f64, NL>::zeros();
        for (p, &l) in self.particles.iter().zip(&self.log_weights) {
            m.axpy(l.exp(), p.xl.mean(), 1.0);
        }
        let mut c = SMatrix::<f64, NL, NL>::zeros();
        for (p, &l) in self.particles.iter().zip(&self.log_weights) {
            let d = p.xl.mean() - m;
            c += (p.xl.cov() + d * d.transpose()) * l.exp();
        }
        (m, c)
    }
}

/// The Rao-Blackwellised (marginalised) particle filter of Schön,
/// Gustafsson and Nordlund (2005), "Marginalized particle filters for
/// mixed linear/nonlinear state-space models", IEEE TSP 53(7), sec. II-IV,
/// for models linear-Gaussian given the nonlinear part:
///
/// ```text
/// xn_k = fn(xn_{k-1}) + An(xn_{k-1}) xl_{k-1} + wn,   wn ~ N(0, Qn)
/// xl_k = fl(xn_{k-1}) + Al(xn_{k-1}) xl_{k-1} + wl,   wl ~ N(0, Ql)
/// z_k  = h(xn_k)      + C(xn_k) xl_k          + e,    e ~ N(0, R)
/// ```
///
/// (`wn`, `wl` independent, or correlated by
/// [`ConditionallyLinear::cross_covariance`], the paper's correlated case,
/// which conditions `wl` on the `wn` the drawn `xn_k` implies: `Al - D An`,
/// `Ql - D Qln^T` and the offset `fl + D (xn_k - fn)`, `D = Qln Qn^-1`).
/// Each particle carries a sample of the nonlinear state `xn` and a Gaussian
/// belief over the linear state `xl`, kept by a [`Kf`]. A step draws
/// `xn_k` from its marginal `N(fn + An xl, An P An^T + Qn)` (the paper's
/// eq. 25a), updates `xl_{k-1}` with the pseudo-measurement `xn_k - fn =
/// An xl + wn` (eq. 24b, skipped when `An = 0`), predicts it with `Al, Ql`
/// plus the offset `fl` (eq. 24a) and updates it with `z_k - h = C xl + e`;
/// the particle's weight increment is that update's Gaussian log-likelihood
/// `log N(z_k; h + C xl, C P C^T + R)` (eq. 25b). It is a [`Proposal`], so
/// [`crate::ParticleFilter::step`] runs it with its chunking, resampling
/// and thread-independent bits.
///
/// Per-particle cost: one `NL`-dimensional KF predict and one update of
/// dimension `M`, plus, when `An != 0`, a second update of dimension `NN`
/// and an `NN x NN` Cholesky factor to draw `xn` (the pieces the model
/// returns are copied, not rechecked; an offset `fl != 0` costs one more
/// check of the predicted belief). On the bench's model (benches/rbpf.rs:
/// `NN = 1`, `NL = 3`, `M = 2`, `An != 0`) about 800 ns per particle-step,
/// 2.5 times the 316 ns of a bootstrap particle of the full 4-state model
/// (criterion on the 2-core development machine; the
/// `rbpf_vs_bootstrap` example measures 572 against 265 ns).
#[derive(Debug, Clone, Copy)]
pub struct RaoBlackwellised<'a, S> {
    /// The model.
    pub model: &'a S,
    /// The Kalman filter of every particle's linear state.
    pub kf: Kf,
}

impl<'a, S> RaoBlackwellised<'a, S> {
    /// The proposal for `model` with the default (Joseph-form) [`Kf`].
    pub fn new(model: &'a S) -> Self {
        Self {
            model,
            kf: Kf::default(),
        }
    }
}

impl<const NN: usize, const NL: usize, const M: usize, S>
    Proposal<RbParticle<NN, NL>, SVector<f64, M>> for RaoBlackwellised<'_, S>
where
    S: ConditionallyLinear<NN, NL, M>,
{
    type Error = KalmanError;
    type Scratch = ();

    fn propose<R: Rng + ?Sized>(
        &self,
        k: usize,
        parent: &RbParticle<NN, NL>,
        z: &SVector<f64, M>,
        _scratch: &mut (),
        rng: &mut R,
    ) -> Result<(RbParticle<NN, NL>, f64), KalmanError> {
        let (f_n, nonlinear) = self.model.nonlinear(k, &parent.xn);
        let (f_l, linear) = self.model.linear(k, &parent.xn);
        let a_n = nonlinear.matrix();
        let coupled = a_n.iter().any(|&v| v != 0.0);
        // xn_k ~ N(fn + An xl, An P An^T + Qn)
        let mean = f_n + a_n * parent.xl.mean();
        let cov = a_n * parent.xl.cov() * a_n.transpose() + nonlinear.noise();
        let xn = if cov.iter().all(|&v| v == 0.0) {
            mean
        } else {
            let l = match cov.cholesky() {
                Some(c) => c.l(),
                // the typed error (not PSD, non-finite) or a PSD-only factor
                None => *Gaussian::new(mean, cov)?.factor()?.cholesky_l(),
            };
            let e = SVector::<f64, NN>::from_fn(|_, _| StandardNormal.sample(rng));
            mean + l * e
        };
        // p(xl_{k-1} | xn_k): the pseudo-measurement xn_k - fn = An xl + wn
        let xl = if coupled {
            self.kf
                .update(&parent.xl, &nonlinear, Some(&(xn - f_n)))?
                .posterior
        } else {
            parent.xl
        };
        // correlated noise (the paper's correlated case): wl = D wn + wl', D =
        // Qln Qn^-1, wl' ~ N(0, Ql - D Qln^T) independent of wn, and wn =
        // xn_k - fn - An xl_{k-1}, so xl_k = (fl + D (xn_k - fn)) + (Al - D
        // An) xl_{k-1} + wl'
        let (f_l, linear) = match self.model.cross_covariance(k, &parent.xn) {
            Some(q_ln) if q_ln.iter().any(|&v| v != 0.0) => {
                decorrelate(f_l, &linear, &nonlinear, &q_ln, &(xn - f_n))?
            }
            _ => (f_l, linear),
        };
        // p(xl_k | xn_{0:k}, z_{1:k-1}): Al, Ql and the offset fl
        let mut predicted = self.kf.predict(&xl, &linear)?;
        if f_l.iter().any(|&v| v != 0.0) {
            // (the offset's belief is checked again: a cost only models
            // with an fl pay)
            let (mean, cov) = predicted.into_parts();
            predicted = Gaussian::new(mean + f_l, cov)?;
        }
        // weigh by p(z_k | xn_{0:k}, z_{1:k-1}) and update
        let (h, measurement) = self.model.measurement(k, &xn);
        let update = self.kf.update(&predicted, &measurement, Some(&(z - h)))?;
        if update.posterior.cov().diagonal().iter().any(|&v| v < 0.0) {
            // the Kalman update at subnormal variances can round a zero
            // variance to a negative one: refused, not carried on
            return Err(KalmanError::NotPositiveDefinite {
                matrix: "linear-state posterior covariance",
                step: Step::Update,
            });
        }
        let lw = update.innovation.map_or(0.0, |i| i.log_likelihood());
        Ok((
            RbParticle {
                xn,
                xl: update.posterior,
            },
            lw,
        ))
    }
}

/// The linear state's transition given the nonlinear state's noise `wn =
/// dn - An xl` (`dn = xn_k - fn`) when the noises are correlated by `q_ln`:
/// offset `fl + D dn`, matrix `Al - D An`, noise `Ql - D Qln^T`, `D = Qln
/// Qn^-1`.
fn decorrelate<const NN: usize, const NL: usize>(
    f_l: SVector<f64, NL>,
    linear: &LinearDynamics<NL>,
    nonlinear: &LinearMeasurement<NL, NN>,
    q_ln: &SMatrix<f64, NL, NN>,
    d_n: &SVector<f64, NN>,
) -> Result<(SVector<f64, NL>, LinearDynamics<NL>), KalmanError> {
    if !q_ln.iter().all(|v| v.is_finite()) {
        return Err(KalmanError::NonFinite {
            what: "cross-covariance Qln",
            step: Step::Predict,
        });
    }
    let chol = nonlinear
        .noise()
        .cholesky()
        .ok_or(KalmanError::NotPositiveDefinite {
            matrix: "nonlinear-state noise Qn (with a cross-covariance Qln)",
            step: Step::Predict,
        })?;
    // D^T = Qn^-1 Qln^T
    let d = chol.solve(&q_ln.transpose()).transpose();
    let q = linear.noise() - d * q_ln.transpose();
    let q = (q + q.transpose()) * 0.5;
    let a = linear.transition() - d * nonlinear.matrix();
    let dynamics = LinearDynamics::new(a, q).map_err(|e| match e {
        KalmanError::NotPositiveDefinite { step, .. } => KalmanError::NotPositiveDefinite {
            matrix: "conditional linear-state noise Ql - Qln Qn^-1 Qln^T \
                     (the joint process noise is not positive semi-definite)",
            step,
        },
        e => e,
    })?;
    Ok((f_l + d * d_n, dynamics))
}
