//! The claims of paper 003 (Lee, Jo and Kang 2005) that our quick
//! `condensation` run reproduces, and those it does not (asserted as
//! measured, so that a change that makes them reproduce is noticed). See
//! docs/reproduction.md, section `condensation`. Every bound was checked by
//! breaking the trackers on purpose (listed there).

use std::sync::OnceLock;

use bayestrack_experiments::condensation::{
    CondensationConfig, CondensationResult, Cue, GridSummary, Representation, SIDE_TRACKERS, run,
};

fn result() -> &'static CondensationResult {
    static CELL: OnceLock<CondensationResult> = OnceLock::new();
    CELL.get_or_init(|| {
        let r = run(&CondensationConfig::quick(), false).unwrap();
        for t in r.tables() {
            println!("{}", t.title);
        }
        r
    })
}

fn cell(representation: Representation, cue: Cue, n: usize) -> GridSummary {
    result().cell(representation, cue, n)
}

#[test]
fn both_cues_with_half_the_contours_beat_the_ifd_alone() {
    // Sec. 3.3: AND (IFD x skin, eq. 11) with N/2 contours tracks better
    // than one cue with N. Measured (quick), centre / outline / lost: AND
    // N=50 3.11 / 4.12 / 0 % vs IFD N=100 27.2 / 19.5 / 24 %; AND N=100
    // 2.28 / 4.06 / 0 % vs IFD N=200 32.6 / 24.0 / 30 %.
    for n in [100, 200] {
        let and = cell(Representation::Contour, Cue::And, n / 2);
        let ifd = cell(Representation::Contour, Cue::Ifd, n);
        println!("N={n}: {and:?}\n      {ifd:?}");
        assert!(and.centre <= 5.0, "AND N={}: {and:?}", n / 2);
        assert!(and.outline <= 6.0, "AND N={}: {and:?}", n / 2);
        assert_eq!(and.loss, 0.0, "AND N={}: {and:?}", n / 2);
        assert!(and.centre <= 0.5 * ifd.centre, "{and:?} vs {ifd:?}");
        assert!(and.outline <= 0.5 * ifd.outline, "{and:?} vs {ifd:?}");
        assert!(and.loss < ifd.loss, "{and:?} vs {ifd:?}");
    }
}

#[test]
fn against_the_skin_alone_the_claim_is_printed_not_asserted() {
    // Against the skin cue alone at N the comparison goes either way: quick
    // (60 frames, 2 runs) skin N=100 2.95 / 2.66 px beats AND N=50 3.11 /
    // 4.12 px, full (150 frames, 10 runs) AND N=50 4.70 / 7.53 px beats
    // skin N=100 8.04 / 9.35 px (the static skin distractors catch the
    // skin-only contour later in the scene). Both track: that much is
    // asserted.
    for n in [100, 200] {
        let and = cell(Representation::Contour, Cue::And, n / 2);
        let skin = cell(Representation::Contour, Cue::Skin, n);
        println!("N={n}: {and:?}\n      {skin:?}");
        assert!(skin.centre <= 8.0 && and.centre <= 8.0, "{and:?} {skin:?}");
    }
}

#[test]
fn not_reproduced_the_or_point_cloud_follows_the_moving_distractors() {
    // Sec. 3.1 tracks a face with points weighted by OR (eq. 9) with
    // lambda = 1/N: IFD + skin / N is the IFD to within 2 %, and the IFD
    // alone follows whatever moves. In our clutter (two moving non-skin
    // boxes) the OR cloud is off the face most of the time, like the IFD
    // cloud; the AND cloud tracks. Measured (quick), centre / lost: OR N=50
    // 55.6 px / 87 %, IFD N=50 81.7 / 92 %, AND N=50 4.36 / 0 %.
    let or = cell(Representation::Points, Cue::Or, 50);
    let ifd = cell(Representation::Points, Cue::Ifd, 50);
    let and = cell(Representation::Points, Cue::And, 50);
    println!("{or:?}\n{ifd:?}\n{and:?}");
    assert!(or.centre > 30.0 && or.loss > 0.5, "{or:?}");
    assert!(ifd.centre > 30.0 && ifd.loss > 0.5, "{ifd:?}");
    assert!(and.centre <= 7.0 && and.loss <= 0.05, "{and:?}");
}

#[test]
fn cavq_locks_onto_the_entering_object_and_nothing_else_does() {
    // Sec. 4: with c-AVQ the set jumps to a newcomer entering through the
    // border. Measured (quick, 2 runs), frames from the entry to lock-on:
    // points AND N=50 13 / never, contour AND N=100 7 / never with c-AVQ;
    // never without. The OR cloud is already on the distractors (above):
    // never either way. Bound: some run locks on within 15 frames with
    // c-AVQ, none does within 45 frames without.
    let summary = result().reinit_summary();
    for key in &SIDE_TRACKERS[1..] {
        let with = summary.iter().find(|s| s.key == *key && s.avq).unwrap();
        let without = summary.iter().find(|s| s.key == *key && !s.avq).unwrap();
        println!(
            "{}: with {:?}, without {:?}",
            key.label(),
            with.lock_on,
            without.lock_on
        );
        assert!(
            with.lock_on.iter().flatten().any(|&k| k <= 15),
            "{}: {:?}",
            key.label(),
            with.lock_on
        );
        assert_eq!(
            without.locked(),
            0,
            "{}: {:?}",
            key.label(),
            without.lock_on
        );
    }
}

#[test]
fn priority_ifd_keeps_crossing_contours_apart_some_of_the_time() {
    // Sec. 5: with the priority-subtracted IFD (eq. 15) two crossing
    // objects keep their identities. Measured (quick, frames after the
    // crossing pooled over 2 runs), kept / swapped / merged / lost: contour
    // AND N=100 34 / 0 / 50 / 16 % with priority, 0 / 0 / 100 / 0 %
    // without (both sets follow the object in front). Partly reproduced:
    // priority keeps the sets apart, but half the time the second set
    // still lands on the first object. The point clouds are lost either way
    // (not reproduced).
    let summary = result().crossing_summary();
    let get = |i: usize, priority: bool| {
        *summary
            .iter()
            .find(|s| s.key == SIDE_TRACKERS[i] && s.priority == priority)
            .unwrap()
    };
    for (i, key) in SIDE_TRACKERS.iter().enumerate() {
        println!(
            "{}: with {:?}\n   without {:?}",
            key.label(),
            get(i, true),
            get(i, false)
        );
    }
    let share = |s: &bayestrack_experiments::condensation::CrossingSummary, n: usize| {
        n as f64 / s.count.total() as f64
    };
    let (with, without) = (get(2, true), get(2, false));
    assert!(share(&with, with.count.kept) >= 0.25, "{with:?}");
    assert!(share(&without, without.count.kept) <= 0.05, "{without:?}");
    assert!(share(&without, without.count.merged) >= 0.8, "{without:?}");
    let or = get(0, true);
    assert!(share(&or, or.count.lost) >= 0.9, "{or:?}");
}
