//! Every tracker by name, so that the CLI (`bayestrack track`,
//! `bayestrack trackers`) and the OTB evaluation (`cargo xtask otb`) run
//! any of them alike. A tracker added to [`REGISTRY`] joins both.

use crate::affine_pf::{HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StpfConfig, StpfTracker};
use crate::condensation::{ContourConfig, ContourTracker, PointCloudConfig, PointCloudTracker};
use crate::dcf::{DcfTracker, DcfTrackerConfig, StapleTracker, StapleTrackerConfig};
use crate::error::{Result, TrackerError};
use crate::hist_pf_scale::{HistPfConfig, HistPfTracker};
use crate::histogram_filters::{BallConfig, BallParticles, BallTracker};
use crate::mad_correlation::{
    MadTracker, MadTrackerConfig, PfCorrelationConfig, PfCorrelationTracker,
};
use crate::ncc_scale::{NccScaleConfig, NccScaleTracker};
use crate::pf_dcf::{PfDcfConfig, PfDcfTracker};
use crate::tracker::Tracker;
use bayestrack_options::{Options, Spec, options};

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
    options: fn() -> Vec<Spec>,
    build: Build,
}

/// A registry entry's constructor: seed and `key=value` options.
type Build = fn(u64, &[(String, String)]) -> Result<Box<dyn Tracker>>;

impl TrackerInfo {
    /// A fresh tracker with its default options, seeded with `seed`
    /// (deterministic trackers ignore it).
    ///
    /// # Errors
    /// Whatever the tracker's constructor reports.
    pub fn build(&self, seed: u64) -> Result<Box<dyn Tracker>> {
        (self.build)(seed, &[])
    }

    /// A fresh tracker with the `key=value` options `set` (applied in
    /// order over the defaults, as `bayestrack track --set` gives them).
    ///
    /// # Errors
    /// [`TrackerError::BadOption`] naming the key and listing the valid
    /// ones; whatever the tracker's constructor reports.
    pub fn build_with(&self, seed: u64, set: &[(String, String)]) -> Result<Box<dyn Tracker>> {
        (self.build)(seed, set)
    }

    /// Every option the tracker takes: key, type, domain, default (this
    /// entry's, presets included) and documentation.
    pub fn options(&self) -> Vec<Spec> {
        (self.options)()
    }
}

/// Options `O` at their defaults, then the entry's `preset`, then the
/// user's `set`.
fn options_of<O: Options + Default>(
    tracker: &'static str,
    preset: &[(&str, &str)],
    set: &[(String, String)],
) -> Result<O> {
    let mut o = O::default();
    let pairs = preset
        .iter()
        .map(|&(k, v)| (k, v))
        .chain(set.iter().map(|(k, v)| (k.as_str(), v.as_str())));
    for (k, v) in pairs {
        o.set(k, v)
            .map_err(|source| TrackerError::BadOption { tracker, source })?;
    }
    Ok(o)
}

/// The specs of `O` with the defaults of the entry's `preset`.
fn specs_of<O: Options + Default>(preset: &[(&str, &str)]) -> Vec<Spec> {
    let mut o = O::default();
    for (k, v) in preset {
        // presets are ours and tested (every entry builds)
        let _ = o.set(k, v);
    }
    let values = o.values();
    let mut specs = O::specs();
    for (spec, (_, v)) in specs.iter_mut().zip(values) {
        spec.default = v;
    }
    specs
}

options! {
    /// The options of a tracker that takes none yet.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct NoOptions {}
}

/// A tracker that takes no options: refuses any `--set`.
fn fixed<T: Tracker + 'static>(
    name: &'static str,
    set: &[(String, String)],
    t: impl FnOnce() -> Result<T>,
) -> Result<Box<dyn Tracker>> {
    options_of::<NoOptions>(name, &[], set)?;
    boxed(t())
}

/// The ball particle filter with `preset` then `set` applied.
fn ball_pf(
    name: &'static str,
    preset: &[(&str, &str)],
    seed: u64,
    set: &[(String, String)],
) -> Result<Box<dyn Tracker>> {
    let (n, config) = options_of::<(BallParticles, BallConfig)>(name, preset, set)?;
    boxed(BallTracker::named_pf(name, config, n.particles, seed))
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
        options: MadTrackerConfig::specs,
        build: |_, set| boxed(MadTracker::new(options_of("mad", &[], set)?)),
    },
    TrackerInfo {
        name: "pf-correlation",
        summary: "paper 004 sec. 3: 15-particle correlation PF, ARP on the displacement (adaptive drift), MAD likelihood of eq. 7 as printed, translation only",
        handles_scale: false,
        options: PfCorrelationConfig::specs,
        build: |seed, set| {
            let seed = seed.to_string();
            let preset = [("seed", seed.as_str())];
            boxed(PfCorrelationTracker::new(options_of(
                "pf-correlation",
                &preset,
                set,
            )?))
        },
    },
    TrackerInfo {
        name: "ball-kf",
        summary: "paper 001: constant-velocity KF, measurement = best RGB-histogram match near the prediction, translation only",
        handles_scale: false,
        options: BallConfig::specs,
        build: |_, set| boxed(BallTracker::kf(options_of("ball-kf", &[], set)?)),
    },
    TrackerInfo {
        name: "ball-ukf",
        summary: "paper 001: the same with a UKF (alpha 1, beta 2, kappa 0), translation only",
        handles_scale: false,
        options: BallConfig::specs,
        build: |_, set| boxed(BallTracker::ukf(options_of("ball-ukf", &[], set)?)),
    },
    TrackerInfo {
        name: "ball-pf",
        summary: "paper 001: PF (30 particles; --set particles=N) weighted by RGB-histogram L2 distance, translation only",
        handles_scale: false,
        options: || specs_of::<(BallParticles, BallConfig)>(&[]),
        build: |seed, set| ball_pf("ball-pf", &[], seed, set),
    },
    TrackerInfo {
        name: "ball-pf10",
        summary: "paper 001's PF10: ball-pf with particles=10",
        handles_scale: false,
        options: || specs_of::<(BallParticles, BallConfig)>(&[("particles", "10")]),
        build: |seed, set| ball_pf("ball-pf10", &[("particles", "10")], seed, set),
    },
    TrackerInfo {
        name: "ball-pf30",
        summary: "paper 001's PF30: ball-pf with particles=30",
        handles_scale: false,
        options: || specs_of::<(BallParticles, BallConfig)>(&[("particles", "30")]),
        build: |seed, set| ball_pf("ball-pf30", &[("particles", "30")], seed, set),
    },
    TrackerInfo {
        name: "ball-pf70",
        summary: "paper 001's PF70: ball-pf with particles=70",
        handles_scale: false,
        options: || specs_of::<(BallParticles, BallConfig)>(&[("particles", "70")]),
        build: |seed, set| ball_pf("ball-pf70", &[("particles", "70")], seed, set),
    },
    TrackerInfo {
        name: "ncc-scale",
        summary: "real video: centre-weighted gray NCC template searched around a constant-velocity prediction at 3 scales (x/1.03, 1, x1.03; scale judged by the first frame's template), wide second look on weak matches, guarded template update; deterministic",
        handles_scale: true,
        options: NccScaleConfig::specs,
        build: |_, set| boxed(NccScaleTracker::new(options_of("ncc-scale", &[], set)?)),
    },
    TrackerInfo {
        name: "dcf",
        summary: "real video: KCF (Henriques et al. 2015) Gaussian-kernel correlation filter on 31-channel fHOG, window 2.5x the target, DSST 33-scale filter (Danelljan et al. 2014), updates gated by LMCF's APCE rule (Wang et al. 2017); published defaults, deterministic",
        handles_scale: true,
        options: DcfTrackerConfig::specs,
        build: |_, set| boxed(DcfTracker::new(options_of("dcf", &[], set)?)),
    },
    TrackerInfo {
        name: "dcf-staple",
        summary: "real video: Staple (Bertinetto et al. 2016): linear fHOG correlation filter merged 0.7/0.3 with a colour-histogram (32^3 RGB or 32 gray bins) box score, DSST scale filter, LMCF-gated updates; published defaults, deterministic",
        handles_scale: true,
        options: StapleTrackerConfig::specs,
        build: |_, set| boxed(StapleTracker::new(options_of("dcf-staple", &[], set)?)),
    },
    TrackerInfo {
        name: "pf-dcf",
        summary: "real video: 200 particles over (x, y, vx, vy, ln s) (constant velocity, 10 % jumps) weighed by exp(20 R / mean peak), R the KCF fHOG response (dcf's filter) at 3 scales 1.0375 apart; LMCF gate: a refused frame freezes the model and the next search spreads 3x wider over a 3x3 window grid until the response passes again",
        handles_scale: true,
        options: PfDcfConfig::specs,
        build: |seed, set| boxed(PfDcfTracker::new(options_of("pf-dcf", &[], set)?, seed)),
    },
    TrackerInfo {
        name: "hist-pf-scale",
        summary: "real video: paper 001's PF with scale in the state (x, y, vx, vy, ln s), 200 particles, kernel-weighted HSV histogram (Pérez et al.), Bhattacharyya likelihood with a background-ring term, slow guarded model update",
        handles_scale: true,
        options: HistPfConfig::specs,
        build: |seed, set| {
            boxed(HistPfTracker::new(
                options_of("hist-pf-scale", &[], set)?,
                seed,
            ))
        },
    },
    TrackerInfo {
        name: "hkpf",
        summary: "paper 002 (Yin et al. 2011): constant-acceleration KF region, 100 particles on the affine group (eq. 4-5), best-particle NCC estimate, no pose tuning; gray",
        handles_scale: true,
        options: Vec::new,
        build: |seed, set| {
            fixed("hkpf", set, || {
                HkpfTracker::new(HkpfConfig::default(), seed)
            })
        },
    },
    TrackerInfo {
        name: "ispf",
        summary: "paper 002 (Li et al. 2012): autoregressive dynamics on the affine group, batches of 5 LWPR-tuned particles up to 50, stop above mu_T - sigma_T; gray",
        handles_scale: true,
        options: Vec::new,
        build: |seed, set| {
            fixed("ispf", set, || {
                IspfTracker::new(IspfConfig::default(), seed)
            })
        },
    },
    TrackerInfo {
        name: "stpf",
        summary: "paper 002 Algorithm 1: KF region + self-tuning particles (N_max 50, dN_0 5, alpha_inc 2, 36x36 NCC, LWPR pose estimator), stop above mu_T - sigma_T; gray",
        handles_scale: true,
        options: Vec::new,
        build: |seed, set| {
            fixed("stpf", set, || {
                StpfTracker::new(StpfConfig::default(), seed)
            })
        },
    },
    TrackerInfo {
        name: "condensation-points",
        summary: "paper 003 sec. 3.1: CONDENSATION, 50 point particles (eq. 10 dynamics, 30 px diffusion), interframe difference OR skin colour (eq. 9, lambda = 1/N), translation only; RGB only (skin)",
        handles_scale: false,
        options: Vec::new,
        build: |seed, set| {
            fixed("condensation-points", set, || {
                PointCloudTracker::new(PointCloudConfig::default(), seed)
            })
        },
    },
    TrackerInfo {
        name: "condensation-contour",
        summary: "paper 003 sec. 3.3: CONDENSATION, 100 quadratic B-spline contours (21 control points, affine shape space: position, rotation, scale), interframe difference AND skin colour along the curve (eq. 11); RGB only (skin)",
        handles_scale: true,
        options: Vec::new,
        build: |seed, set| {
            fixed("condensation-contour", set, || {
                ContourTracker::new(ContourConfig::default(), seed)
            })
        },
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

    fn set(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn options_reach_the_tracker() {
        use bayestrack_image::{BBox, Image};
        let frame = Image::from_vec(
            64,
            48,
            3,
            (0..64 * 48 * 3).map(|i| ((i * 37) % 251) as u8).collect(),
        )
        .unwrap();
        let particles = |name: &str, pairs: &[(&str, &str)]| {
            let mut t = tracker_info(name)
                .unwrap()
                .build_with(1, &set(pairs))
                .unwrap();
            t.init(frame.view(), BBox::new(20.0, 15.0, 10.0, 10.0))
                .unwrap();
            (t.name(), t.step(frame.view()).unwrap().particles)
        };
        assert_eq!(
            particles("ball-pf", &[("particles", "70")]),
            ("ball-pf", 70)
        );
        assert_eq!(particles("ball-pf", &[]), ("ball-pf", 30));
        assert_eq!(particles("ball-pf10", &[]), ("ball-pf10", 10));
        // a preset is a starting point, not a lock
        assert_eq!(particles("ball-pf10", &[("particles", "12")]).1, 12);
        assert_eq!(
            particles("hist-pf-scale", &[("particles", "50")]),
            ("hist-pf-scale", 50)
        );
        let pf = &[("particles", "40"), ("motion", "constant-drift:2,2,8")];
        assert_eq!(particles("pf-correlation", pf), ("pf-correlation", 40));
    }

    #[test]
    fn a_bad_option_names_the_tracker_and_the_domain_or_lists_the_keys() {
        let info = tracker_info("ball-pf").unwrap();
        for (pairs, says) in [
            (
                [("particles", "0")],
                "bad value `0` for `particles`: expected 1..=1000000",
            ),
            ([("particle", "7")], "particles (1..=1000000)"),
            ([("motion", "wobbly")], "bad value `wobbly` for `motion`"),
        ] {
            let err = info.build_with(0, &set(&pairs)).err().unwrap().to_string();
            assert!(err.contains("ball-pf") && err.contains(says), "{err}");
        }
        // a tracker without options refuses every key
        let err = tracker_info("hkpf")
            .unwrap()
            .build_with(0, &set(&[("particles", "7")]))
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("hkpf") && err.contains("particles"), "{err}");
        // rules between options are checked when set
        let err = tracker_info("ncc-scale")
            .unwrap()
            .build_with(0, &set(&[("max_scale", "0.5")]))
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("ncc-scale") && err.contains("max_scale"),
            "{err}"
        );
    }

    #[test]
    fn every_listed_default_reads_back() {
        // what `trackers --options` prints is what `--set` takes
        for info in REGISTRY {
            let pairs: Vec<(String, String)> = info
                .options()
                .into_iter()
                .map(|s| (s.key.to_string(), s.default))
                .collect();
            assert!(
                info.build_with(3, &pairs).is_ok(),
                "{}: {pairs:?}",
                info.name
            );
        }
        let bad = |name: &str, k: &str, v: &str| {
            let r = tracker_info(name).unwrap().build_with(0, &set(&[(k, v)]));
            assert!(r.is_err(), "{name} took {k}={v}");
        };
        bad("mad", "search", "region:1,2,0,5");
        bad("mad", "search", "window:-3");
        bad("pf-correlation", "motion", "drift:1,1,1.5");
        bad("pf-correlation", "motion", "position:1,nan,1,1");
        bad("pf-correlation", "spread", "1");
        bad("pf-correlation", "resampling", "best");
    }

    #[test]
    fn presets_show_their_own_defaults() {
        let default = |name: &str| {
            tracker_info(name)
                .unwrap()
                .options()
                .into_iter()
                .find(|s| s.key == "particles")
                .map(|s| s.default)
        };
        assert_eq!(default("ball-pf").as_deref(), Some("30"));
        assert_eq!(default("ball-pf70").as_deref(), Some("70"));
        assert_eq!(default("ball-kf"), None);
        assert!(
            tracker_info("ball-kf")
                .unwrap()
                .options()
                .iter()
                .any(|s| s.key == "search_margin")
        );
    }
}
