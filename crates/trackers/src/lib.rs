//! The trackers of the bayestrack papers, each a composition of a filter
//! (`bayestrack-kalman`, `bayestrack-particle`) and an appearance model
//! (`bayestrack-appearance`), behind one [`Tracker`] trait so that the CLI,
//! the OTB evaluation and the experiments treat them alike.

mod affine_pf;
mod condensation;
mod dcf;
mod engine;
mod error;
mod hist_pf_scale;
mod histogram_filters;
mod mad_correlation;
mod multi_target;
mod ncc_scale;
mod pf_dcf;
mod registry;
mod shell;
mod tracker;

pub use affine_pf::{
    AffineTracker, AppearanceConfig, FrameStats, HkpfConfig, HkpfCore, HkpfTracker, IspfConfig,
    IspfCore, IspfTracker, RegionConfig, ScoredPose, StopRule, StpfConfig, StpfCore, StpfTracker,
    TsdInit, UpdateRule,
};
pub use condensation::{
    CAvq, CAvqConfig, Condensation, CondensationReport, ContourConfig, ContourCore,
    ContourDynamics, ContourTracker, CueSet, CurveCue, CurveCueKind, LOST_LOG_LIKELIHOOD,
    MultiCondensation, MultiConfig, ObjectConfig, ObjectEstimate, PointCloudConfig, PointCloudCore,
    PointCloudTracker,
};
pub use dcf::{
    DcfCore, DcfTracker, DcfTrackerConfig, GateOptions, GateResponse, KcfOptions, ScaleOptions,
    StapleCore, StapleTracker, StapleTrackerConfig,
};
pub use engine::{CueFilter, CueProposal, StateModel, select_predict_measure};
pub use error::{Result, TrackerError};
pub use hist_pf_scale::{HistPfConfig, HistPfCore, HistPfTracker};
pub use histogram_filters::{BallConfig, BallCore, BallFilter, BallTracker, MotionModel};
pub use mad_correlation::{
    ArpCodec, ArpMotion, MadCore, MadTracker, MadTrackerConfig, PairCodec, PfCorrelationConfig,
    PfCorrelationCore, PfCorrelationTracker, ResamplingCodec, SearchArea, SearchAreaCodec,
};
pub use multi_target::{
    Association, Detection, Feature, MultiTargetConfig, MultiTargetTracker, Track,
    measurement_matrix, transition_matrix,
};
pub use ncc_scale::{NccScaleConfig, NccScaleCore, NccScaleTracker};
pub use pf_dcf::{
    LookScale, OuterScales, PfDcfConfig, PfDcfCore, PfDcfDiagnostics, PfDcfTracker,
    RedetectFeatures, UpdateFeatures,
};
pub use registry::{REGISTRY, TrackerInfo, build_tracker, tracker_info};
pub use shell::{ChannelPolicy, InitialBox, Needs, PlaneBuffers, Planes, Shell, TrackerCore};
pub use tracker::{Estimate, FrameGuard, Tracker, check_initial_box};
