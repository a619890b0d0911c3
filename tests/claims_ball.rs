//! The claims of paper 001 (Bocsi and Csato, Tables 1-3) on our quick `ball`
//! run: the one that reproduces, and, asserted as measured, the ones that do
//! not (so a change that makes them reproduce is noticed and
//! docs/reproduction.md updated). See docs/reproduction.md, section `ball`.

use std::sync::OnceLock;

use bayestrack::trackers::BallFilter;
use bayestrack_experiments::ball::{BallOptions, BallResult, FrameMode, run};

fn result() -> &'static BallResult {
    static CELL: OnceLock<BallResult> = OnceLock::new();
    CELL.get_or_init(|| run(&BallOptions::quick(), None, false).unwrap())
}

fn finding(id: &str) -> (bool, bool) {
    let f = result()
        .findings()
        .into_iter()
        .find(|f| f.id == id)
        .unwrap_or_else(|| panic!("no finding {id}"));
    (f.offline, f.realtime)
}

const PF: [BallFilter; 3] = [BallFilter::Pf(10), BallFilter::Pf(30), BallFilter::Pf(70)];

#[test]
fn kalman_trackers_are_more_accurate_than_every_particle_filter() {
    // Paper 001: "The KF and UKF offer a more reliable estimation about the
    // position" (Table 1 error: 8.5 px vs 11-16 px). Reproduced in both modes.
    assert_eq!(finding("kalman_more_accurate"), (true, true));
    for mode in FrameMode::ALL {
        for k in [BallFilter::Kf, BallFilter::Ukf] {
            let e = result().overall(k, mode).error;
            assert!(e < 2.0, "{} {mode:?}: {e} px", k.label());
        }
    }
}

#[test]
fn every_tracker_sees_the_papers_frame_rate_in_real_time() {
    for f in BallFilter::PAPER {
        let seen = result().overall(f, FrameMode::RealTime).frames_per_second;
        let paper = bayestrack_experiments::ball::paper_row(f).unwrap().fps;
        assert!(
            (seen - paper).abs() < 0.1,
            "{}: {seen} vs {paper}",
            f.label()
        );
        let offline = result().overall(f, FrameMode::Offline).frames_per_second;
        assert!(offline > 21.9, "{}: {offline}", f.label());
    }
}

#[test]
fn not_reproduced_more_particles_do_not_lose_the_ball_more_often() {
    // Paper 001: lost PF10 1.25 < PF30 11.75 < PF70 18.25 per experiment.
    // Ours: PF10 loses the ball most in both modes; dropping frames at the
    // paper's fps (real time) does not reverse the order. If this fails, the
    // claim may now reproduce: update docs/reproduction.md.
    assert_eq!(finding("more_particles_lose_more"), (false, false));
    assert_eq!(finding("pf10_loses_least"), (false, false));
    for mode in FrameMode::ALL {
        let l10 = result().overall(BallFilter::Pf(10), mode).lost_per_10min;
        for f in &PF[1..] {
            assert!(l10 > result().overall(*f, mode).lost_per_10min, "{mode:?}");
        }
    }
}

#[test]
fn not_reproduced_particle_filter_error_falls_with_more_particles() {
    // Paper 001 Table 1: error grows with N (11.31, 12.28, 15.69 px). Ours
    // falls: 10 particles cannot cover the 20 px ball's neighbourhood.
    for mode in FrameMode::ALL {
        let e: Vec<f64> = PF
            .iter()
            .map(|&f| result().overall(f, mode).error)
            .collect();
        assert!(e[0] > e[1] && e[1] > e[2], "{mode:?}: {e:?}");
    }
}

#[test]
fn not_reproduced_kalman_trackers_do_not_lose_the_ball_in_the_quick_run() {
    // Paper 001: KF 7.5 and UKF 4.0 losses per experiment, more with noise
    // and (KF) with non-linear motion. Ours: the windowed histogram search
    // on a white screen never loses the ball in the quick run, so the
    // KF-vs-UKF, noise and non-linearity findings cannot show.
    for mode in FrameMode::ALL {
        for k in [BallFilter::Kf, BallFilter::Ukf] {
            assert_eq!(
                result().overall(k, mode).losses,
                0,
                "{} {mode:?}",
                k.label()
            );
        }
    }
    for id in [
        "ukf_loses_less_than_kf",
        "noise_hurts_kalman",
        "nonlinear_hurts_kf_most",
    ] {
        assert_eq!(finding(id), (false, false), "{id}");
    }
}
