#![doc = include_str!("../README.md")]

pub use bayestrack_affine as affine;
pub use bayestrack_appearance as appearance;
pub use bayestrack_dcf as dcf;
pub use bayestrack_image as image;
pub use bayestrack_kalman as kalman;
pub use bayestrack_otb as otb;
pub use bayestrack_particle as particle;
pub use bayestrack_trackers as trackers;

/// Re-exported so a program that depends on `bayestrack` alone names the
/// same `nalgebra` as the filters (states are `nalgebra::SVector`s).
pub use bayestrack_kalman::nalgebra;
/// Re-exported: models and proposals draw from a `rand::Rng`.
pub use bayestrack_particle::rand;
/// Re-exported: the distributions a model samples its noise from.
pub use bayestrack_particle::rand_distr;
/// Re-exported: the generator of [`particle::stream_rng`].
pub use bayestrack_particle::rand_xoshiro;
