//! Every tracker by name, so that the CLI (`bayestrack track`,
//! `bayestrack trackers`) and the OTB evaluation (`cargo xtask otb`) run
//! any of them alike. A tracker added to [`REGISTRY`] joins both.

use crate::affine_pf::{HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StpfConfig, StpfTracker};
use crate::condensation::{ContourConfig, ContourTracker, PointCloudConfig, PointCloudTracker};
use crate::error::{Result, TrackerError};
use crate::hist_pf_scale::{HistPfConfig, HistPfTracker};
use crate::histogram_filters::{BallConfig, BallTracker};
use crate::mad_correlation::{
    MadTracker, MadTrackerConfig, PfCorrelationConfig, PfCorrelationTracker,
};
use crate::ncc_scale::{NccScaleConfig, NccScaleTracker};
use crate::tracker::Tracker;

/// One registered tracker.
#[derive(Debug, Clone, Copy)]
pub struct TrackerInfo {
    /// The name given to `--tracker`.
    pub name: &'static str,
    /// One line: what it is and where it comes from.
    pub summary: &'static str,
    /// Whether it estimates the target's scale (box size or affine pose);
    /// position-only trackers keep the initial box size.
    pub handles_scale: bool,
    build: fn(u64) -> Result<Box<dyn Tracker>>,
}

impl TrackerInfo {
    /// A fresh tracker seeded with `seed` (deterministic trackers ignore it).
    ///
    /// # Errors
    /// Whatever the tracker's constructor reports.
    pub fn build(&self, seed: u64) -> Result<Box<dyn Tracker>> {
        (self.build)(seed)
    }
}

fn boxed<T: Tracker + 'static>(t: Result<T>) -> Result<Box<dyn Tracker>> {
    Ok(Box::new(t?))
}

/// Every tracker, in the order `bayestrack trackers` lists them.
pub const REGISTRY: &[TrackerInfo] = &[
    TrackerInfo {
        name: "mad",
        summary: "paper 004 sec. 2: exhaustive MAD template search in a 16 px window, fixed template, translation only",
        handles_scale: false,
        build: |_| boxed(MadTracker::new(MadTrackerConfig::default())),
    },
    TrackerInfo {
        name: "pf-correlation",
        summary: "paper 004 sec. 3: 15-particle correlation PF, ARP on the displacement (adaptive drift), MAD likelihood of eq. 7 as printed, translation only",
        handles_scale: false,
        build: |seed| {
            boxed(PfCorrelationTracker::new(PfCorrelationConfig {
                seed,
                ..PfCorrelationConfig::default()
            }))
        },
    },
    TrackerInfo {
        name: "ball-kf",
        summary: "paper 001: constant-velocity KF, measurement = best RGB-histogram match near the prediction, translation only",
        handles_scale: false,
        build: |_| boxed(BallTracker::kf(BallConfig::default())),
    },
    TrackerInfo {
        name: "ball-ukf",
        summary: "paper 001: the same with a UKF (alpha 1, beta 2, kappa 0), translation only",
        handles_scale: false,
        build: |_| boxed(BallTracker::ukf(BallConfig::default())),
    },
    TrackerInfo {
        name: "ball-pf30",
        summary: "paper 001: 30-particle PF weighted by RGB-histogram L2 distance, translation only",
        handles_scale: false,
        build: |seed| boxed(BallTracker::pf(BallConfig::default(), 30, seed)),
    },
    TrackerInfo {
        name: "ncc-scale",
        summary: "real video: centre-weighted gray NCC template searched around a constant-velocity prediction at 3 scales (x/1.03, 1, x1.03; scale judged by the first frame's template), wide second look on weak matches, guarded template update; deterministic",
        handles_scale: true,
        build: |_| boxed(NccScaleTracker::new(NccScaleConfig::default())),
    },
    TrackerInfo {
        name: "hist-pf-scale",
        summary: "real video: paper 001's PF with scale in the state (x, y, vx, vy, ln s), 200 particles, kernel-weighted HSV histogram (Pérez et al.), Bhattacharyya likelihood with a background-ring term, slow guarded model update",
        handles_scale: true,
        build: |seed| boxed(HistPfTracker::new(HistPfConfig::default(), seed)),
    },
    TrackerInfo {
        name: "hkpf",
        summary: "paper 002 (Yin et al. 2011): constant-acceleration KF region, 100 particles on the affine group (eq. 4-5), best-particle NCC estimate, no pose tuning; gray",
        handles_scale: true,
        build: |seed| boxed(HkpfTracker::new(HkpfConfig::default(), seed)),
    },
    TrackerInfo {
        name: "ispf",
        summary: "paper 002 (Li et al. 2012): autoregressive dynamics on the affine group, batches of 5 LWPR-tuned particles up to 50, stop above mu_T - sigma_T; gray",
        handles_scale: true,
        build: |seed| boxed(IspfTracker::new(IspfConfig::default(), seed)),
    },
    TrackerInfo {
        name: "stpf",
        summary: "paper 002 Algorithm 1: KF region + self-tuning particles (N_max 50, dN_0 5, alpha_inc 2, 36x36 NCC, LWPR pose estimator), stop above mu_T - sigma_T; gray",
        handles_scale: true,
        build: |seed| boxed(StpfTracker::new(StpfConfig::default(), seed)),
    },
    TrackerInfo {
        name: "condensation-points",
        summary: "paper 003 sec. 3.1: CONDENSATION, 50 point particles (eq. 10 dynamics, 30 px diffusion), interframe difference OR skin colour (eq. 9, lambda = 1/N), translation only; RGB only (skin)",
        handles_scale: false,
        build: |seed| boxed(PointCloudTracker::new(PointCloudConfig::default(), seed)),
    },
    TrackerInfo {
        name: "condensation-contour",
        summary: "paper 003 sec. 3.3: CONDENSATION, 100 quadratic B-spline contours (21 control points, affine shape space: position, rotation, scale), interframe difference AND skin colour along the curve (eq. 11); RGB only (skin)",
        handles_scale: true,
        build: |seed| boxed(ContourTracker::new(ContourConfig::default(), seed)),
    },
];

/// The tracker called `name`.
///
/// # Errors
/// [`TrackerError::UnknownTracker`] listing the known names.
pub fn tracker_info(name: &str) -> Result<&'static TrackerInfo> {
    REGISTRY
        .iter()
        .find(|t| t.name == name)
        .ok_or_else(|| TrackerError::UnknownTracker {
            name: name.to_string(),
            known: REGISTRY
                .iter()
                .map(|t| t.name)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// A fresh tracker called `name`, seeded with `seed`.
///
/// # Errors
/// [`TrackerError::UnknownTracker`], or the tracker's constructor's error.
pub fn build_tracker(name: &str, seed: u64) -> Result<Box<dyn Tracker>> {
    tracker_info(name)?.build(seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_entry_builds_under_its_own_name() {
        for info in REGISTRY {
            let t = info.build(7).unwrap();
            assert_eq!(t.name(), info.name, "registry entry {}", info.name);
        }
        let names: std::collections::HashSet<_> = REGISTRY.iter().map(|t| t.name).collect();
        assert_eq!(names.len(), REGISTRY.len(), "duplicate names");
    }

    #[test]
    fn unknown_names_list_the_known_ones() {
        let err = build_tracker("csrt", 0).err().unwrap().to_string();
        assert!(err.contains("csrt") && err.contains("mad"), "{err}");
    }
}
