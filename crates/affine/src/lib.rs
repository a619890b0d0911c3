#![doc = include_str!("../README.md")]

mod displacement;
mod dynamics;
mod error;
mod group;

/// The workspace's one affine map type (from `bayestrack-image`; the group
/// operations are [`AffineGroup`]'s).
pub use bayestrack_image::Affine2;
pub use displacement::DisplacementPredictor;
pub use dynamics::BrownianDynamics;
pub use error::{AffineError, Result};
pub use group::{AffineGroup, AffineParams, AlgebraVector, basis, hat, vee};
mod lwpr;

pub use lwpr::{Kernel, Lwpr, LwprConfig, Prediction};
mod pose;

pub use pose::{FeatureKind, PoseConfig, PoseEstimator, pose_error};
mod shape_space;

pub use shape_space::{ShapeSpace, ShapeVector};
mod bspline;

pub use bspline::{BSplineDegree, ClosedBSpline, shape_affine};
