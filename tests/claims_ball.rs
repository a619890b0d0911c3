//! The claims of paper 001 (Bocsi and Csato, Tables 1-3) on our quick `ball`
//! run (4 runs of 20 s, the webcam effects on, the KF/UKF also on the
//! paper's evaluation budget): accuracy bounds with stated tolerances, the
//! findings that reproduce, and, asserted as measured, the ones that do not
//! (so a change that makes them reproduce is noticed and
//! docs/reproduction.md updated). See docs/reproduction.md, section `ball`.
//!
//! The bounds are the quick run's measured values plus a stated margin
//! (about 50 % for the particle filters, whose quick errors rest on a few
//! hundred frames; 0.5-1 px for the Kalman trackers); the run is seeded, so
//! the margin is for honest changes (a refactor, another platform's last
//! bits), not for chance.

use std::sync::OnceLock;

use bayestrack::trackers::BallFilter;
use bayestrack_experiments::ball::{BallOptions, BallResult, FrameMode, View, paper_row, run};

fn result() -> &'static BallResult {
    static CELL: OnceLock<BallResult> = OnceLock::new();
    CELL.get_or_init(|| run(&BallOptions::quick(), None, false).unwrap())
}

/// The finding's verdicts in [`View::ALL`] order.
fn finding(id: &str) -> [Option<bool>; 6] {
    result()
        .findings()
        .into_iter()
        .find(|f| f.id == id)
        .unwrap_or_else(|| panic!("no finding {id}"))
        .verdicts
}

const PF10: BallFilter = BallFilter::Pf(10);
const PF30: BallFilter = BallFilter::Pf(30);
const PF70: BallFilter = BallFilter::Pf(70);
const KF: BallFilter = BallFilter::Kf;
const UKF: BallFilter = BallFilter::Ukf;

fn error(f: BallFilter, v: View) -> f64 {
    result().overall(f, v).error
}

#[test]
fn every_tracker_tracks_within_its_stated_error() {
    // (tracker, view, bound px, measured px when the bound was set)
    let offline = View::OFFLINE;
    let realtime = View::REALTIME;
    let bounds = [
        (PF10, offline, 30.0, 20.4),
        // the engine's random streams (session 7): 6.33 here; over seeds
        // 1-5 the quick PF30 error was 2.65, 3.10, 21.46, 6.51, 3.01 with
        // the hand-written loop and 6.33, 12.48, 2.74, 19.46, 12.03 on the
        // engine (the same filter: 30 particles lose this ball in some
        // runs); the old 4 px bound held for seed 1 only
        (PF30, offline, 8.0, 6.33),
        (PF70, offline, 2.5, 1.70),
        (KF, offline, 2.5, 1.89),
        (UKF, offline, 2.2, 1.62),
        (KF, offline.on_budget(), 3.0, 2.37),
        (UKF, offline.on_budget(), 2.5, 1.80),
        (PF70, realtime, 3.0, 2.07),
        (KF, realtime, 3.0, 2.13),
        (UKF, realtime, 2.5, 1.77),
        (KF, realtime.on_budget(), 4.0, 3.19),
        (UKF, realtime.on_budget(), 3.0, 2.29),
    ];
    for (f, v, bound, measured) in bounds {
        let e = error(f, v);
        assert!(
            e <= bound,
            "{} {}: mean centre error {e:.2} px > {bound} px (measured {measured} when set)",
            f.label(),
            v.name()
        );
    }
}

#[test]
fn the_particle_filters_and_the_kalman_trackers_keep_the_ball_offline() {
    // Quick run, offline: PF70, KF, UKF (exhaustive and budgeted) never lose
    // the ball; PF30 at most three times (measured: twice, 15 per 10 min).
    for (f, v) in [
        (PF70, View::OFFLINE),
        (KF, View::OFFLINE),
        (UKF, View::OFFLINE),
        (KF, View::OFFLINE.on_budget()),
        (UKF, View::OFFLINE.on_budget()),
    ] {
        let s = result().overall(f, v);
        assert_eq!(s.losses, 0, "{} {}", f.label(), v.name());
    }
    assert!(result().overall(PF30, View::OFFLINE).losses <= 3);
}

#[test]
fn scored_late_the_kalman_error_is_the_papers_order_of_magnitude() {
    // An estimate becomes available 1 / fps_paper (97 ms, 2.1 camera frames)
    // after its frame: at 3 px/frame the ball has moved on about 6.5 px, so
    // scored late the KF/UKF error is the frame error plus 5-11 px; measured
    // 10.6 / 10.1 px (budgeted 11.2 / 10.3), the paper's Table 1: 8.57 / 8.52.
    for v in [View::REALTIME, View::REALTIME.on_budget()] {
        for k in [KF, UKF] {
            let (now, late) = (error(k, v), error(k, v.scored_late()));
            assert!(
                (5.0..=11.0).contains(&(late - now)),
                "{} {}: late {late:.2} vs {now:.2}",
                k.label(),
                v.name()
            );
            assert!(
                (8.0..=13.0).contains(&late),
                "{} {}: {late}",
                k.label(),
                v.name()
            );
        }
    }
}

#[test]
fn the_budget_is_the_papers_and_costs_accuracy_not_the_ball() {
    for mode in FrameMode::ALL {
        let v = View {
            mode,
            delayed: false,
            budgeted: false,
        };
        for k in [KF, UKF] {
            let (full, cut) = (result().overall(k, v), result().overall(k, v.on_budget()));
            // 6 x 6 grid of the 37 windows the paper's fps allowed
            assert_eq!(cut.evaluations, 36.0, "{}", k.label());
            assert!(full.evaluations > 1000.0, "{}", k.label());
            assert!(cut.error > full.error, "{} {mode:?}", k.label());
            assert_eq!(cut.losses, full.losses, "{} {mode:?}", k.label());
        }
    }
}

#[test]
fn every_tracker_sees_the_papers_frame_rate_in_real_time() {
    for f in BallFilter::PAPER {
        let seen = result().overall(f, View::REALTIME).frames_per_second;
        let paper = paper_row(f).unwrap().fps;
        assert!(
            (seen - paper).abs() < 0.1,
            "{}: {seen} vs {paper}",
            f.label()
        );
        let offline = result().overall(f, View::OFFLINE).frames_per_second;
        assert!(offline > 21.9, "{}: {offline}", f.label());
    }
}

#[test]
fn findings_as_measured() {
    // Columns: offline, realtime, realtime scored late, then the same with
    // the KF/UKF on the budget. If one changes, update docs/reproduction.md.
    let (y, n) = (Some(true), Some(false));
    let expected = [
        ("more_particles_lose_more", [n, n, n, n, n, n]),
        ("pf70_loses_more_than_pf30", [n, n, y, n, n, y]),
        ("more_particles_find_faster", [n, n, n, n, n, n]),
        ("pf10_loses_least", [n, n, n, n, n, n]),
        ("kalman_more_accurate", [n, n, y, n, n, n]),
        ("kalman_find_slower", [n, n, n, n, n, n]),
        ("ukf_loses_less_than_kf", [n, y, y, n, y, y]),
        ("noise_hurts_kalman", [n, n, y, n, n, y]),
        ("nonlinear_hurts_kf_most", [n, y, y, n, y, y]),
    ];
    for (id, verdicts) in expected {
        assert_eq!(finding(id), verdicts, "{id}");
    }
}

#[test]
fn not_reproduced_ten_particles_lose_the_ball_most() {
    // Paper 001: lost PF10 1.25 < PF30 11.75 < PF70 18.25 per experiment.
    // Ours: PF10 loses the ball most in every view; on a webcam frame ten
    // particles cannot cover the 20 px ball's neighbourhood.
    for v in [View::OFFLINE, View::REALTIME] {
        let l10 = result().overall(PF10, v).lost_per_10min;
        for f in [PF30, PF70] {
            assert!(l10 > result().overall(f, v).lost_per_10min, "{}", v.name());
        }
    }
    // Offline the error falls with N (paper: it grows, 11.31, 12.28, 15.69).
    let e: Vec<f64> = [PF10, PF30, PF70]
        .iter()
        .map(|&f| error(f, View::OFFLINE))
        .collect();
    assert!(e[0] > e[1] && e[1] > e[2], "{e:?}");
}
