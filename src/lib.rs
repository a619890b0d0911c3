#![doc = include_str!("../README.md")]

pub use bayestrack_affine as affine;
pub use bayestrack_appearance as appearance;
pub use bayestrack_image as image;
pub use bayestrack_kalman as kalman;
pub use bayestrack_otb as otb;
pub use bayestrack_particle as particle;
pub use bayestrack_trackers as trackers;
