//! Particle filters on the affine group Aff(2): the three trackers of
//! paper 002 (Xu, Gao and Yang, "Self-tuning hierarchical Kalman-particle
//! filter for efficient target tracking", Infrared and Laser Engineering,
//! 2015).
//!
//! - [`HkpfTracker`] (`hkpf`): the hierarchical Kalman-particle filter of
//!   Yin et al. (2011) as paper 002 describes it: a constant-acceleration
//!   Kalman filter predicts the global displacement and a local elliptical
//!   region, a fixed number of particles is drawn on the group inside it
//!   (eq. 4-5), the best one is the estimate (eq. 2). No pose tuning.
//! - [`IspfTracker`] (`ispf`): the incremental self-tuning particle filter
//!   of Li et al. (2012): autoregressive dynamics on the group with a wide
//!   spread, particles drawn in batches and each tuned to its best
//!   neighbour by the LWPR pose estimator.
//! - [`StpfTracker`] (`stpf`): the self-tuning hierarchical Kalman-particle
//!   filter of paper 002, Algorithm 1.
//!
//! # Shared machinery
//! A pose `M` maps template coordinates (origin at the template centre,
//! the template being the initial box, `w x h` pixels) to 0-based image
//! coordinates ([`bayestrack_affine::group`]); the tracker starts at
//! `M_0 = T(c_0)`, the initial box centre with the identity linear part.
//! Every frame is converted to gray `f32` in `[0, 1]` (RGB by BT.601), so
//! gray and RGB frames are tracked alike. A pose is observed as the
//! `36 x 36` patch `O(M)` warped through
//! [`bayestrack_affine::PoseEstimator::patch_map`] and scored by the
//! similarity `S = max(0, NCC(O(M), template))` of
//! [`bayestrack_appearance::TargetModel`]. A pose whose patch leaves the
//! frame, or whose scale `sqrt(det A)` leaves [`AppearanceConfig::scale_range`],
//! is not scored (it is rejected).
//!
//! ## Tuning a particle to its best neighbour
//! [`tune`](Core::tune): the pose estimator predicts the increment `Delta`
//! from the features of `O(M)` (one warp gives both the features and the
//! similarity of `M`); the step `M' = M exp(Delta)` is scored, and kept if
//! its similarity is higher; up to [`AppearanceConfig::tune_steps`] steps
//! (default 3). A step is rejected, and tuning stops, when it does not
//! raise the similarity, when its patch leaves the frame, when its scale
//! leaves the allowed range, or when the increment cannot be exponentiated.
//! The tuned particle is the best pose seen. This is
//! [`bayestrack_affine::PoseEstimator::tune`]'s rule, written out here so
//! that the similarity is read from the patch the estimator has just warped
//! (half the warps) and the work is counted.
//!
//! ## Appearance model and its update
//! Template: the patch at `M_0`. TSD `N(mu_T, sigma_T)`: similarities of
//! [`AppearanceConfig::tsd_samples`] perturbations `M_0 exp(delta)`,
//! `delta ~ N(0, (train_sigma / 2)^2)` (half the pose estimator's training
//! spread: about how close tuning brings a particle). BSD
//! `N(mu_B, sigma_B)`: similarities of the patches one box width or height
//! away in the 8 directions (those inside the frame; a prior `N(0.3, 0.15)`
//! when fewer than two fit). At the end of a frame, if the final score
//! passes the update rule ([`UpdateRule`]), the template blends towards
//! `O(M*)` at [`AppearanceConfig::template_rate`], TSD absorbs the score,
//! BSD the scores of the 4 patches one box away from `M*`, and (ISPF,
//! STPF) the pose estimator is trained on
//! [`AppearanceConfig::training_per_update`] perturbations of `M*`.
//!
//! ## Selection
//! ISPF's and STPF's later batches draw their parents among all the
//! particles tuned so far in the frame: those become the particle engine's
//! weighted set ([`bayestrack_particle::ParticleSet`], log-weights
//! `lambda (S_i - S_max)`, unscorable particles at zero weight) and the
//! engine selects the batch's parents by multinomial draws
//! ([`ParticleSet::draw_ancestors`]; a batch has 5, 10, 20, ... particles,
//! not the set's size, so the set is drawn from rather than replaced in
//! place). HKPF draws a fixed number of particles from the dynamics and
//! keeps the best (eq. 2): it selects nothing.
//!
//! # Randomness
//! Initialisation draws from `stream_rng([key, seed, u64::MAX])`, frame `k`
//! from `stream_rng([key, seed, k])`. The trackers run on one thread, so
//! the output is the same for any number of threads.

mod common;
mod hkpf;
mod ispf;
mod stpf;

pub use common::{
    AffineTracker, AppearanceConfig, FrameStats, RegionConfig, ScoredPose, StopRule, TsdInit,
    UpdateRule,
};
pub use hkpf::{HkpfConfig, HkpfCore, HkpfTracker};
pub use ispf::{IspfConfig, IspfCore, IspfTracker};
pub use stpf::{StpfConfig, StpfCore, StpfTracker};
