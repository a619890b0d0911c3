//! The claims of paper 003 (Lee, Jo and Kang 2005) that our quick
//! `condensation` run reproduces, and those it does not (asserted as
//! measured, so that a change that makes them reproduce is noticed). See
//! docs/reproduction.md, section `condensation`. The grid claims read the
//! quick run (2 runs, means over runs and frames); the re-initialisation
//! and crossing claims, whose outcome is all or nothing per run, count
//! over 16 runs. Every bound was checked by breaking the trackers on
//! purpose (listed there).

use std::sync::OnceLock;

use bayestrack_experiments::condensation::{
    CondensationConfig, CondensationExperiment, CondensationResult, CrossingCount, CrossingRun,
    Cue, Done, GridKey, GridSummary, ReinitRun, Representation, SIDE_TRACKERS, run,
};
use bayestrack_experiments::driver::run_jobs;

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
    // N=50 3.63 / 5.25 / 0 % vs IFD N=100 21.5 / 16.1 / 24 %; AND N=100
    // 2.63 / 5.08 / 0 % vs IFD N=200 36.8 / 27.1 / 39 % (before the engine
    // port: 3.11 / 4.12 vs 27.2 / 19.5 / 24 %, 2.28 / 4.06 vs 32.6 / 24.0
    // / 30 %).
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
    // (60 frames, 2 runs) skin N=100 2.92 / 4.24 px beats AND N=50 3.63 /
    // 5.25 px; full (150 frames, 10 runs) skin N=100 8.36 / 9.95 px beats
    // AND N=50 13.61 / 14.43 px, whose mean is one run that loses the face
    // (before the engine port AND won at full scale, 4.70 / 7.53 against
    // 8.04 / 9.35 px: one or two lost runs decide it). Both track: that
    // much is asserted.
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
    // 86.1 px / 88 %, IFD N=50 57.2 / 87 %, AND N=50 4.86 / 0 % (before the
    // engine port 55.6 / 87 %, 81.7 / 92 %, 4.36 / 0 %).
    let or = cell(Representation::Points, Cue::Or, 50);
    let ifd = cell(Representation::Points, Cue::Ifd, 50);
    let and = cell(Representation::Points, Cue::And, 50);
    println!("{or:?}\n{ifd:?}\n{and:?}");
    assert!(or.centre > 30.0 && or.loss > 0.5, "{or:?}");
    assert!(ifd.centre > 30.0 && ifd.loss > 0.5, "{ifd:?}");
    assert!(and.centre <= 7.0 && and.loss <= 0.05, "{and:?}");
}

/// Runs of the re-initialisation and crossing claims: their outcome is
/// all or nothing per run (a set locks on or not, keeps its identity or
/// not), so a claim on two runs hangs on the random streams. 16 runs of
/// the quick scenes (run `r`: scene seed `1 + r`, trackers seeded `r`).
const SIDE_RUNS: usize = 16;

/// The re-initialisation and crossing runs of [`SIDE_RUNS`] runs at quick
/// scale (only those jobs of the experiment, not its grid).
fn side() -> &'static (Vec<ReinitRun>, Vec<CrossingRun>) {
    static CELL: OnceLock<(Vec<ReinitRun>, Vec<CrossingRun>)> = OnceLock::new();
    CELL.get_or_init(|| {
        let config = CondensationConfig {
            runs: SIDE_RUNS,
            ..CondensationConfig::quick()
        };
        // Job order: the grid (key-major), then per run the side trackers'
        // re-initialisation and crossing jobs, then the snapshot.
        let grid = GridKey::all().len() * SIDE_RUNS;
        let jobs: Vec<usize> = (grid..grid + SIDE_TRACKERS.len() * 4 * SIDE_RUNS).collect();
        let mut reinit = Vec::new();
        let mut crossing = Vec::new();
        for d in run_jobs::<CondensationExperiment>(&config, &jobs, None, false).unwrap() {
            match d {
                Done::Reinit(r) => reinit.push(r),
                Done::Crossing(c) => crossing.push(c),
                _ => panic!("not a side job"),
            }
        }
        assert_eq!(reinit.len(), SIDE_TRACKERS.len() * 2 * SIDE_RUNS);
        assert_eq!(crossing.len(), reinit.len());
        (reinit, crossing)
    })
}

/// Lock-on frames per run of one tracker, with or without c-AVQ.
fn lock_on(key: GridKey, avq: bool) -> Vec<Option<usize>> {
    side()
        .0
        .iter()
        .filter(|r| r.key == key && r.avq == avq)
        .map(|r| r.lock_on)
        .collect()
}

/// Crossing counts per run of one tracker, with or without priority.
fn crossings(key: GridKey, priority: bool) -> Vec<CrossingCount> {
    side()
        .1
        .iter()
        .filter(|c| c.key == key && c.priority == priority)
        .map(|c| c.count)
        .collect()
}

/// The counts pooled over runs.
fn pooled(runs: &[CrossingCount]) -> CrossingCount {
    let mut p = CrossingCount::default();
    for c in runs {
        p.kept += c.kept;
        p.swapped += c.swapped;
        p.merged += c.merged;
        p.lost += c.lost;
    }
    p
}

fn share(n: usize, of: &CrossingCount) -> f64 {
    n as f64 / of.total() as f64
}

#[test]
fn cavq_moves_the_set_onto_the_entering_object() {
    // Sec. 4: a set "in pause position has to move and track the new
    // object instantaneously"; c-AVQ shifts it onto the winning cluster of
    // the border stripes. Read over runs, "instantaneously" as within 15
    // frames of the entry (half a second at 30 fps): with c-AVQ at least a
    // quarter of the runs lock on that fast (not most: our c-AVQ misses for
    // the reasons in docs/reproduction.md), and more than without it;
    // without c-AVQ the set stays on the face: at most a quarter of the
    // runs reach the newcomer at all within the 45 quick frames (by
    // diffusion). The OR cloud is already on the distractors (above): not
    // asserted. Per-run numbers: docs/reproduction.md.
    for key in &SIDE_TRACKERS[1..] {
        let with = lock_on(*key, true);
        let without = lock_on(*key, false);
        println!("{}: with {with:?}\n   without {without:?}", key.label());
        let fast = |v: &[Option<usize>]| v.iter().flatten().filter(|&&k| k <= 15).count();
        let locked = without.iter().flatten().count();
        assert!(4 * fast(&with) >= SIDE_RUNS, "{}: {with:?}", key.label());
        assert!(
            fast(&with) > fast(&without),
            "{}: {with:?} {without:?}",
            key.label()
        );
        assert!(4 * locked <= SIDE_RUNS, "{}: {without:?}", key.label());
    }
}

#[test]
fn priority_ifd_keeps_crossing_contours_apart_in_some_runs() {
    // Sec. 5: with the priority-subtracted IFD (eq. 15) two crossing
    // objects are tracked "at different direction". Frames after the
    // crossing (35 a run; kept / swapped / merged / lost per run in
    // docs/reproduction.md). Partly reproduced: a run either keeps both
    // identities for most of those frames or loses them at the crossing,
    // so the claim counts runs. With priority, at least one run in eight
    // keeps both identities in over half of the frames after the crossing;
    // without it no run does, and both sets follow the object in front
    // (pooled: kept <= 5 %, merged >= 80 %). The OR point clouds are lost
    // either way (not reproduced; pooled lost >= 90 %).
    for key in SIDE_TRACKERS {
        println!(
            "{}: with {:?}\n   without {:?}",
            key.label(),
            crossings(key, true),
            crossings(key, false)
        );
    }
    let contour = SIDE_TRACKERS[2];
    let kept_most = |runs: &[CrossingCount]| runs.iter().filter(|c| 2 * c.kept > c.total()).count();
    let (with, without) = (crossings(contour, true), crossings(contour, false));
    let (pooled_with, pooled_without) = (pooled(&with), pooled(&without));
    println!(
        "contour: runs keeping most frames {} with, {} without; pooled with {pooled_with:?}, without {pooled_without:?}",
        kept_most(&with),
        kept_most(&without)
    );
    assert!(8 * kept_most(&with) >= SIDE_RUNS, "{with:?}");
    assert_eq!(kept_most(&without), 0, "{without:?}");
    assert!(
        share(pooled_without.kept, &pooled_without) <= 0.05,
        "{pooled_without:?}"
    );
    assert!(
        share(pooled_without.merged, &pooled_without) >= 0.8,
        "{pooled_without:?}"
    );
    let or = pooled(&crossings(SIDE_TRACKERS[0], true));
    assert!(share(or.lost, &or) >= 0.9, "{or:?}");
}
