#![doc = include_str!("../README.md")]

mod batch;
mod belief;
mod ckf;
mod closure;
mod consistency;
mod error;
mod filter;
mod gaussian;
mod hybrid;
mod imm;
mod kf;
mod linalg;
mod model;
mod motion;
mod sigma;
mod smoother;
mod srkf;
mod srukf;
mod ukf;
mod update;

pub use batch::{Batch, batch_filter};
pub use belief::{Belief, FilterBelief, ModeBelief};
pub use ckf::Ckf;
pub use closure::{FnDynamics, FnMeasurement, NoJacobian};
pub use consistency::{ChiSquareBand, chi_square_cdf, chi_square_quantile, nees};
pub use error::{KalmanError, Result, Step};
pub use filter::{KalmanFilter, KalmanPredict, KalmanUpdate};
pub use gaussian::{FactoredGaussian, Gaussian};
pub use hybrid::{HybridPrior, HybridStep, HybridUkfIekf};
pub use imm::{Imm, ImmBelief, ImmModel, ImmStep, Mode};
pub use kf::{Ekf, Iekf, Kf};
pub use model::{
    Additive, Angles, Dynamics, DynamicsJacobian, Euclidean, LinearDynamics, LinearMeasurement,
    Manifold, Measurement, MeasurementJacobian, NoiseCovariance, NoisyDynamics, NoisyMeasurement,
};
pub use motion::{NoiseModel, white_noise};
pub use smoother::{RtsSmoother, batch_smooth, fixed_lag_smooth};
pub use srkf::SrKf;
pub use srukf::{SqrtGaussian, SqrtUpdate, SrUkf};
pub use ukf::{NoiseForm, Ukf, UkfStep};
pub use update::{CovarianceUpdate, Innovation, Update};

/// Re-exported so users name the same `nalgebra` as the crate.
pub use nalgebra;
