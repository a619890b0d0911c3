//! CONDENSATION trackers with skin colour and interframe difference (Lee,
//! Jo and Kang 2005; CONDENSATION after Isard and Blake 1998).
//!
//! CONDENSATION is the particle engine of `bayestrack-particle` (a
//! `ParticleFilter` run through the trackers' `CueFilter`) configured by
//! [`Condensation::filter`]: selection at the start of a step, adaptive on
//! eq. 16, a measurement with no evidence anywhere ignored. One step
//! (Lee, Jo and Kang 2005, sec. 2):
//!
//! 1. **select** (sec. 2.1): roulette-wheel selection from the cumulative
//!    weights, i.e. the multinomial resampler of `bayestrack-particle`,
//!    done adaptively: only when the effective particle size of eq. 16,
//!    `N_eff = 1 / sum pi_i^2`, shows the weights have degenerated. The
//!    paper gives the threshold "on pi" as `2/N` (point cloud) and `1.5/N`
//!    (contours); `sum pi_i^2` is the weight a particle drawn by weight
//!    carries on average (`1/N` when all are equal), so we read it as
//!    *select when `sum pi_i^2 > c / N`*, i.e. when `N_eff < N / c`
//!    (`c` = [`Condensation::pi_threshold`]). Sec. 5 also mentions
//!    resampling when `N_eff` is very *large*; with equal weights that only
//!    shuffles the set, so we do not.
//! 2. **predict** (sec. 2.2, eq. 5 and 10): deterministic drift plus
//!    stochastic diffusion, the second-order dynamics
//!    `X_t = A X_{t-1} + B v_t` on `X = [q_t, q_{t-1}]` with
//!
//!    ```text
//!    A = [ (1 + rho) I   -rho I ]      B = [ Sigma ]
//!        [      I          0    ]          [   0   ]
//!    ```
//!
//!    i.e. `q_t = q_{t-1} + rho (q_{t-1} - q_{t-2}) + Sigma v_t`,
//!    `v_t ~ N(0, I)`, `Sigma = diag(sigma_i)` the paper's diffusion
//!    deviations. `rho` ([`PointCloudConfig::velocity_damping`]) is our
//!    choice, 1/2 by default: `rho = 0` drops the previous state (a first
//!    order random walk, not the second-order model of eq. 10), and
//!    `rho = 1` (constant velocity) makes the velocity a random walk whose
//!    spread grows without bound between selections, because `B` injects
//!    the diffusion into the position and so into the next velocity;
//!    `rho = 1/2` keeps the velocity a stationary AR(1) process whose
//!    spread, `sigma / sqrt(1 - rho^2) = 1.15 sigma`, stays that of the
//!    diffusion, while still carrying half of the last displacement.
//! 3. **measure** (sec. 2.3-2.4, eq. 3, 6, 9, 11): each particle's weight
//!    is multiplied by its likelihood (the cues of [`CueSet`], through the
//!    `Cue` trait and the OR / AND `Fusion` of `bayestrack-appearance`, in
//!    the log domain), then normalised; a particle in an impossible
//!    configuration (its centre off the image, sec. 2.3) gets zero weight.
//!    The estimate is the weighted mean of eq. 4.
//!
//! Two representations: point clouds ([`PointCloudTracker`], sec. 3.1)
//! and deformable B-spline contours ([`ContourTracker`], sec. 3.2-3.3);
//! c-AVQ re-initialisation from the border stripes ([`CAvq`], sec. 4);
//! several objects by the priority-subtracted IFD ([`MultiCondensation`],
//! sec. 5).
//!
//! Randomness: the engine's keyed streams. An object's filter is seeded
//! `stream_seed([key, s])` for a tracker seeded `s` (`[key, s, id]` for
//! object `id` of [`MultiCondensation`]), and its step `k` draws from the
//! streams keyed `[seed, k]` (one per chunk of particles, the selection
//! its own), so the output is the same bits on any thread count. The
//! initial particles draw from `stream_rng([key, s, u64::MAX])`
//! (`[key, s, id, u64::MAX]`).

mod avq;
mod common;
mod contour;
mod multi;
mod points;

pub use avq::{CAvq, CAvqConfig};
pub use common::{Condensation, CondensationReport, CueSet, LOST_LOG_LIKELIHOOD};
pub use contour::{
    ContourConfig, ContourCore, ContourDynamics, ContourTracker, CurveCue, CurveCueKind,
};
pub use multi::{MultiCondensation, MultiConfig, ObjectConfig, ObjectEstimate};
pub use points::{PointCloudConfig, PointCloudCore, PointCloudTracker};
