//! The claims of paper 004 that our quick `correlation` run reproduces, and
//! those it does not (asserted as measured, so that a change that makes them
//! reproduce is noticed). See docs/reproduction.md, section `correlation`.

use std::sync::OnceLock;

use bayestrack_experiments::correlation::{
    CorrelationConfig, CorrelationResult, Variant, VariantSummary, run,
};

fn result() -> &'static CorrelationResult {
    static CELL: OnceLock<CorrelationResult> = OnceLock::new();
    CELL.get_or_init(|| run(&CorrelationConfig::quick()).unwrap())
}

fn summary(v: Variant) -> VariantSummary {
    result()
        .summary()
        .into_iter()
        .find(|s| s.variant == v)
        .unwrap()
}

#[test]
fn the_mad_tracker_follows_the_visible_car_and_stalls_at_the_billboard() {
    // Table 1: exact while the car is visible, stuck near the billboard
    // (Table 1 stalls from frame 13 on).
    let s = summary(Variant::MadWindow);
    assert!(s.phases.before < 1.0, "{s:?}");
    assert!(s.phases.after > 100.0, "{s:?}");
    assert_eq!(s.recovered, 0.0);
    // From frame 13 on it never comes within 30 px of the car again
    // (behind and after the billboard it wanders over the road texture
    // near where it lost the car).
    for r in &result().runs {
        let c = &r.tracks[0].centres;
        for (p, t) in c.iter().zip(&r.truth).skip(12) {
            assert!((p[0] - t[0]).hypot(p[1] - t[1]) > 30.0, "{p:?} {t:?}");
        }
    }
}

#[test]
fn a_whole_frame_search_re_finds_the_car_after_the_billboard() {
    // Not in the paper: the stall needs a local search window (or a
    // template that drifts); the exhaustive search over the frame finds the
    // unchanged car again as soon as it is fully visible.
    let s = summary(Variant::MadFrame);
    assert!(s.phases.before < 1.0 && s.phases.after < 1.0, "{s:?}");
    assert_eq!(s.recovered, 1.0);
}

#[test]
fn not_reproduced_the_pf_of_eq_5_to_7_does_not_keep_the_uniform_motion() {
    // Table 2 claims the PF tracker moves on with the car through the
    // occlusion. With eq. 6 as printed (a random walk) or on the
    // displacement, and eq. 7 as printed, ours is dragged onto the
    // billboard like the MAD tracker.
    for v in [Variant::PfPrinted, Variant::PfDrift] {
        let s = summary(v);
        assert!(s.phases.before < 5.0, "{s:?}");
        assert!(s.phases.after > 100.0, "{s:?}");
        assert_eq!(s.recovered, 0.0, "{s:?}");
    }
}

#[test]
fn with_a_capped_mad_the_pf_coasts_through_the_occlusion() {
    // Our extension (eq. 7 with min(MAD, 40)): flat weights where nothing
    // matches let the particles move on. After the occlusion the MAD
    // tracker's error exceeds this PF's by 4x or more (not the 10x one
    // might read into Tables 1-2).
    let (mad, pf) = (summary(Variant::MadWindow), summary(Variant::PfDriftCap));
    assert!(mad.phases.after >= 4.0 * pf.phases.after, "{mad:?} {pf:?}");
    assert!(pf.phases.during < mad.phases.during / 2.0, "{mad:?} {pf:?}");
    assert!(pf.recovered > 0.0);
}

#[test]
fn accuracy_of_the_particle_filters_on_the_visible_car() {
    // Mean centre error (px) over the 8 quick runs while the car is fully
    // visible before the billboard; bounds are the measured values (in the
    // comments) plus about 30 %, not the paper's (which gives positions,
    // not errors). A loss of accuracy fails here even after `cargo xtask
    // bless`.
    for (v, bound) in [
        (Variant::PfPrinted, 4.2),    // 3.22
        (Variant::PfDrift, 3.2),      // 2.42
        (Variant::PfDriftCap, 3.2),   // 2.43
        (Variant::PfConstDrift, 1.0), // 0.48
    ] {
        let s = summary(v);
        assert!(s.phases.before <= bound, "{s:?}");
    }
    // The capped MAD's coasting, measured 14.3 px during and 25.5 px after.
    let s = summary(Variant::PfDriftCap);
    assert!(s.phases.during <= 20.0 && s.phases.after <= 35.0, "{s:?}");
}

#[test]
fn with_the_constant_drift_of_sec_3_2_the_pf_keeps_the_uniform_motion() {
    // Sec. 3.2 read as a constant drift measured by the MAD match between
    // frames 1 and 2, the PF from frame 3 on (`x_t = x_t-1 + c + B w`,
    // B = 1 px), eq. 7 as printed: the particles coast behind the
    // billboard and the car is re-found in most runs. Measured: 0.48 px
    // before, 2.82 during, 3.71 after, 6 of 8 runs recovered (200 runs:
    // 0.72, 3.18, 3.96, 70 %).
    let s = summary(Variant::PfConstDrift);
    assert!(s.phases.during <= 5.0, "{s:?}");
    assert!(s.phases.after <= 6.0, "{s:?}");
    assert!(s.recovered >= 0.5, "{s:?}");
    // far better than the adaptive drift of the same eq. 7 after the
    // billboard (129 px)
    let adaptive = summary(Variant::PfDrift);
    assert!(
        s.phases.after * 10.0 < adaptive.phases.after,
        "{adaptive:?}"
    );
    // Run 0 against the paper's Table 2 (every third frame): within 5 px
    // of the car at each of the paper's frames.
    let r0 = &result().runs[0];
    let i = Variant::ALL
        .iter()
        .position(|&v| v == Variant::PfConstDrift)
        .unwrap();
    for (frame, _, _) in bayestrack_experiments::correlation::PAPER_TABLE2 {
        let (p, t) = (r0.tracks[i].centres[frame - 1], r0.truth[frame - 1]);
        assert!(
            (p[0] - t[0]).hypot(p[1] - t[1]) < 5.0,
            "frame {frame}: {p:?} {t:?}"
        );
    }
}

#[test]
fn the_multi_target_tracker_keeps_two_cars_with_stable_ids() {
    // Table 3: two tracks (ids 0 and 1) in every frame; centroid within
    // half a pixel, window within 1.5 px of the car's size (the rendered
    // car's anti-aliased edge adds up to one pixel).
    let m = &result().multi;
    for (k, ids) in m.ids.iter().enumerate() {
        assert_eq!(ids, &vec![0, 1], "frame {k}");
        for i in 0..2 {
            let t = m.tracks[k][i].unwrap();
            let truth = m.truth[k][i];
            assert!(
                (t[0] - truth[0]).hypot(t[1] - truth[1]) < 0.5,
                "{t:?} {truth:?}"
            );
            assert!((t[2] - truth[2]).abs() <= 1.5 && (t[3] - truth[3]).abs() <= 1.5);
        }
    }
}
