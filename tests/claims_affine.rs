//! The claims of paper 002 (Xu, Gao and Yang 2015) that our quick `affine`
//! run reproduces, and those it does not (asserted as measured, so that a
//! change that makes them reproduce is noticed). See docs/reproduction.md,
//! section `affine`.
//!
//! The run is the quick configuration (80 frames, one run per setting, the
//! golden file's numbers), so every bound below can be read off
//! `cargo xtask reproduce-table affine`.

use std::sync::OnceLock;

use bayestrack_experiments::affine::{AffineConfig, AffineResult, Filter, Setting, Summary, run};

fn result() -> &'static AffineResult {
    static CELL: OnceLock<AffineResult> = OnceLock::new();
    CELL.get_or_init(|| run(&AffineConfig::quick(), false).unwrap())
}

fn summary(setting: Setting, filter: Filter) -> Summary {
    result().summary(setting, filter)
}

#[test]
fn the_self_tuning_filter_follows_abrupt_motion_and_pose_change_to_a_pixel() {
    // Paper: "our PF achieves best performance" on Cock and "could follow
    // the target very tightly" on Sylvester. Ours: mean RMS 0.50 px (Cock)
    // and 0.76 px (Sylvester), no frame lost.
    for setting in [Setting::Cock, Setting::Sylvester] {
        let s = summary(setting, Filter::Stpf);
        assert!(s.rms[0] <= 1.5, "{s:?}");
        assert!(s.rms[2] <= 2.0, "{s:?}");
        assert_eq!(s.lost_frames, 0.0, "{s:?}");
    }
}

#[test]
fn the_self_tuning_filter_needs_fewer_particles_than_ispf_at_comparable_rms() {
    // Paper: 9.7 against ISPF's 13.2 (Sylvester, 0.73x), 8.6 against 15.5
    // (Dudek, 0.55x). Ours: 3.3 vs 6.8 (Cock), 3.4 vs 7.0 (Sylvester):
    // about half, at RMS within 1.1x of ISPF's.
    for setting in [Setting::Cock, Setting::Sylvester] {
        let (s, i) = (
            summary(setting, Filter::Stpf),
            summary(setting, Filter::Ispf),
        );
        assert!(s.particles <= 0.7 * i.particles, "{s:?} {i:?}");
        assert!(s.rms[0] <= 1.5 * i.rms[0], "{s:?} {i:?}");
        // Fewer pose-estimator calls too (the paper's "less calculation of
        // our PF even with the same number of particles").
        assert!(
            s.pose_estimator_calls <= 0.7 * i.pose_estimator_calls,
            "{s:?} {i:?}"
        );
    }
}

#[test]
fn hkpf_without_tuning_is_less_accurate_under_pose_change() {
    // Paper: HKPF's box misses orientation and scale (Sylvester #76, Dudek
    // #689/#880/#1010) even with 100 and 50 particles. Ours: mean RMS 4.23
    // vs 0.76 px (5.6x) on Sylvester, 28.3 vs 11.8 px (2.4x) on Dudek.
    for (setting, factor) in [(Setting::Sylvester, 3.0), (Setting::Dudek, 2.0)] {
        let (h, s) = (
            summary(setting, Filter::Hkpf),
            summary(setting, Filter::Stpf),
        );
        assert!(h.rms[0] >= factor * s.rms[0], "{h:?} {s:?}");
    }
    // On Sylvester it drifts but is not lost within 80 frames (the paper's
    // HKPF fails at frame 269).
    let h = summary(Setting::Sylvester, Filter::Hkpf);
    assert!(h.rms[0] >= 2.0 && h.lost_frames == 0.0, "{h:?}");
}

#[test]
fn not_reproduced_ispf_does_not_lose_the_target_under_abrupt_motion() {
    // Paper: ISPF is trapped in the background near Cock frame 148 while
    // the self-tuning filter is not. Ours: with jumps inside the region
    // ISPF searches (15 px, 3 sigma of its 5 px shift spread) ISPF's wide
    // spread keeps the target as well as the self-tuning filter does (mean
    // RMS 0.59 px, no frame lost); HKPF without tuning loses it at some
    // jump frames (4 frames).
    let i = summary(Setting::Cock, Filter::Ispf);
    assert!(i.rms[0] <= 1.5 && i.lost_frames == 0.0, "{i:?}");
    let h = summary(Setting::Cock, Filter::Hkpf);
    assert!(h.lost_frames >= 1.0 && h.rms[0] >= 3.0, "{h:?}");
}

#[test]
fn not_reproduced_the_self_tuning_filter_and_ispf_lose_dudek_jumps() {
    // Paper: ISPF and the self-tuning filter track Dudek precisely. Ours:
    // Dudek's 20 px jumps are beyond every filter's region, and both lose
    // the face for a third or more of the frames (self-tuning 30 of 79,
    // ISPF 44 of 79), the self-tuning filter with fewer particles (10.7 vs
    // 35.3) and a lower mean RMS (11.8 vs 13.9 px).
    let (s, i) = (
        summary(Setting::Dudek, Filter::Stpf),
        summary(Setting::Dudek, Filter::Ispf),
    );
    assert!(
        s.lost_frames >= 15.0 && i.lost_frames >= 15.0,
        "{s:?} {i:?}"
    );
    assert!(s.particles <= 0.5 * i.particles, "{s:?} {i:?}");
}
