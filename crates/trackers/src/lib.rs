//! The trackers of the bayestrack papers, each a composition of a filter
//! (`bayestrack-kalman`, `bayestrack-particle`) and an appearance model
//! (`bayestrack-appearance`), behind one [`Tracker`] trait so that the CLI,
//! the OTB evaluation and the experiments treat them alike.

mod ball;
mod correlation;
mod error;
mod hist_pf;
mod multi_target;
mod ncc_scale;
mod registry;
mod tracker;

pub use ball::{BallConfig, BallFilter, BallTracker, MotionModel};
pub use correlation::{
    ArpMotion, MadTracker, MadTrackerConfig, PfCorrelationConfig, PfCorrelationTracker, SearchArea,
};
pub use error::{Result, TrackerError};
pub use hist_pf::{HistPfConfig, HistPfTracker};
pub use multi_target::{
    Association, Detection, Feature, MultiTargetConfig, MultiTargetTracker, Track,
    measurement_matrix, transition_matrix,
};
pub use ncc_scale::{NccScaleConfig, NccScaleTracker};
pub use registry::{REGISTRY, TrackerInfo, build_tracker, tracker_info};
pub use tracker::{Estimate, FrameGuard, Tracker, check_initial_box};
