#![doc = include_str!("../README.md")]

pub mod displacement;
pub mod dynamics;
pub mod error;
pub mod group;

pub use displacement::DisplacementPredictor;
pub use dynamics::BrownianDynamics;
pub use error::{AffineError, Result};
pub use group::{Affine2, AffineParams, AlgebraVector, BBox, basis, hat, vee};
pub mod lwpr;

pub use lwpr::{Kernel, Lwpr, LwprConfig, Prediction};
pub mod pose;

pub use pose::{FeatureKind, PoseConfig, PoseEstimator, pose_error};
pub mod shape_space;

pub use shape_space::{ShapeSpace, ShapeVector};
pub mod bspline;

pub use bspline::{BSplineDegree, ClosedBSpline, shape_affine};
