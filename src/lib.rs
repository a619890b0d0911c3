//! bayestrack: Bayesian filtering and visual object tracking.
//!
//! The umbrella crate re-exports every workspace crate as a module; depend on
//! a single crate (for example `bayestrack-kalman`) when that is all you need.

pub use bayestrack_kalman as kalman;
