//! bayestrack: Bayesian filtering and visual object tracking.
//!
//! The umbrella crate re-exports every workspace crate as a module; depend on
//! a single crate (for example `bayestrack-kalman`) when that is all you need.

pub use bayestrack_affine as affine;
pub use bayestrack_appearance as appearance;
pub use bayestrack_eval as eval;
pub use bayestrack_image as image;
pub use bayestrack_kalman as kalman;
pub use bayestrack_particle as particle;
pub use bayestrack_trackers as trackers;
