//! The claims of paper 003 (Lee, Jo and Kang 2005) under the readings of
//! its text that `CondensationConfig`'s defaults take (no moving object
//! but the target, eq. 9 summed over the subtracted pixels), and under the
//! readings that decide them (`condensation::READINGS`): which hold, which
//! do not, each with two-sided bounds, so that a change that moves a
//! verdict is noticed. See docs/reproduction.md, section `condensation`.
//! The grid claims read the quick run (2 runs, means over runs and
//! frames) and the few grid jobs of a reading they need; the
//! re-initialisation and crossing claims, whose outcome is all or nothing
//! per run, count over 16 runs. Every bound was checked by breaking the
//! trackers on purpose (listed there).

use std::sync::OnceLock;

use bayestrack_experiments::condensation::{
    Claim, CondensationConfig, CondensationExperiment, CondensationResult, CrossingCount,
    CrossingRun, Cue, Done, GridKey, GridSummary, HandSummary, READINGS, ReinitRun, Representation,
    SIDE_TRACKERS, TrackRun, run,
};
use bayestrack_experiments::driver::run_jobs;
use bayestrack_experiments::scenes::{SceneStream, WebcamScene};
use bayestrack_trackers::{CueSet, PointCloudConfig, PointCloudTracker, Tracker};

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

/// The quick configuration under reading `name`.
fn reading(name: &str) -> CondensationConfig {
    READINGS
        .iter()
        .find(|r| r.name == name)
        .unwrap()
        .config(&CondensationConfig::quick())
        .unwrap()
}

/// Grid cells (and the hand runs when `hand`) of `config`, only those
/// jobs: per key, its runs' centre / outline / lost means.
fn grid_of(
    config: &CondensationConfig,
    keys: &[GridKey],
    hand: bool,
) -> (Vec<GridSummary>, Vec<TrackRun>) {
    let all = GridKey::all();
    let runs = config.runs;
    let mut jobs = Vec::new();
    for k in keys {
        let i = all.iter().position(|a| a == k).unwrap();
        jobs.extend(i * runs..(i + 1) * runs);
    }
    let side = all.len() * runs + SIDE_TRACKERS.len() * 4 * runs;
    if hand {
        jobs.extend(side..side + runs);
    }
    let done = run_jobs::<CondensationExperiment>(config, &jobs, None, false).unwrap();
    let mut grid = Vec::new();
    let mut hands = Vec::new();
    for (n, d) in done.into_iter().enumerate() {
        match d {
            Done::Grid(t) => grid.push((keys[n / runs], t)),
            Done::Hand(t) => hands.push(t),
            _ => panic!("not a grid or hand job"),
        }
    }
    let summary = keys
        .iter()
        .map(|k| {
            let runs: Vec<&TrackRun> = grid
                .iter()
                .filter(|(g, _)| g == k)
                .map(|(_, t)| t)
                .collect();
            let m = |f: fn(&TrackRun) -> &Vec<f64>| {
                let v: Vec<f64> = runs.iter().flat_map(|r| f(r).iter().copied()).collect();
                if v.is_empty() {
                    f64::NAN
                } else {
                    v.iter().sum::<f64>() / v.len() as f64
                }
            };
            let lost: Vec<bool> = runs.iter().flat_map(|r| r.lost.iter().copied()).collect();
            GridSummary {
                key: *k,
                centre: m(|r| &r.centre),
                outline: m(|r| &r.outline),
                loss: lost.iter().filter(|&&l| l).count() as f64 / lost.len() as f64,
                fps: f64::NAN,
            }
        })
        .collect();
    (summary, hands)
}

/// The OR point cloud (N = 50) of the quick scale under reading `name`.
fn or_cloud_under(name: &str) -> GridSummary {
    let (cells, _) = grid_of(
        &reading(name),
        &[key(Representation::Points, Cue::Or, 50)],
        false,
    );
    println!("{name}: {:?}", cells[0]);
    cells[0]
}

fn key(representation: Representation, cue: Cue, particles: usize) -> GridKey {
    GridKey {
        representation,
        cue,
        particles,
    }
}

#[test]
fn sec31_the_or_point_cloud_tracks_when_eq9_sums_the_subtracted_pixels() {
    // Sec. 3.1: points, OR (eq. 9), N = 50, lambda = 1/N, 30 px diffusion.
    // Summed over the subtracted pixels (the default reading) the cloud
    // tracks the face; over the whole window (`or-raw`) the IFD of the
    // textured wall under the 30 px diffusion pulls it off in about half
    // the frames. Measured (quick, the turning face): subtracted 6.15 px,
    // 0 % lost; raw 42.5 px, 55 % lost (upright: 5.3 px; 37.3 px, 49 %).
    let or = cell(Representation::Points, Cue::Or, 50);
    println!("{or:?}");
    assert!(or.centre >= 1.0 && or.centre <= 9.0, "{or:?}");
    assert!(or.loss <= 0.05, "{or:?}");
    assert!(result().verdict(Claim::PointsOrTracks).holds);
    let raw = or_cloud_under("or-raw");
    assert!(raw.centre >= 20.0 && raw.centre <= 80.0, "{raw:?}");
    assert!(raw.loss >= 0.3 && raw.loss <= 0.8, "{raw:?}");
    // Each cue normalised over the set before the sum (`or-normalised`):
    // the wall's IFD is back in every window and, with `lambda = 1/N`, the
    // skin term weighs 1/N of the IFD's on average: the cloud wanders like
    // the raw and the IFD-alone clouds. Measured: quick 28.8 px, 41 %
    // lost (raw 42.5 px, 55 %); 8 quick runs (a probe of the trackers)
    // normalised 23.5 px, 39 %; raw 32.3 px, 50 %; IFD alone 24.9 px, 45
    // %. Bound: centre in [10, 60] px, lost in [15 %, 70 %].
    let norm = or_cloud_under("or-normalised");
    assert!(norm.centre >= 10.0 && norm.centre <= 60.0, "{norm:?}");
    assert!(norm.loss >= 0.15 && norm.loss <= 0.7, "{norm:?}");
}

/// Runs of the skin-term claim (8 quick runs: one OR cloud's accuracy
/// varies by about 1 px from run to run).
const SKIN_RUNS: usize = 8;

/// One frame of an OR-cloud run: the estimated centre, the true centre
/// and the face's smaller side (px).
type CloudFrame = ([f64; 2], [f64; 2], f64);

/// The point cloud of sec. 3.1 (`N = 50`, eq. 9 over the subtracted
/// pixels at `subtracted_threshold`) with balancing coefficient `lambda`
/// through the tracking scene of `config`, run `r` on scene seed
/// `scene_seed + r` with tracker seed `r` (the experiment's seeds): per
/// run, the estimated centres and the true ones.
fn or_cloud(config: &CondensationConfig, lambda: f64) -> Vec<Vec<CloudFrame>> {
    let scene = config.posed(WebcamScene {
        frames: config.frames,
        ..WebcamScene::default()
    });
    (0..config.runs)
        .map(|r| {
            let mut stream = scene.stream(config.scene_seed + r as u64).unwrap();
            let mut t = PointCloudTracker::new(
                PointCloudConfig {
                    cues: CueSet::OrSubtracted {
                        lambda,
                        threshold: config.subtracted_threshold,
                    },
                    ..PointCloudConfig::paper(50)
                },
                r as u64,
            )
            .unwrap();
            let first = stream.next_frame().unwrap();
            t.init(first.image.view(), first.truth.target().unwrap().bbox)
                .unwrap();
            let mut out = Vec::new();
            while let Some(f) = stream.next_frame() {
                let e = t.step(f.image.view()).unwrap();
                let o = f.truth.target().unwrap();
                let (x, y) = e.bbox.center();
                let side = o.bbox.width.min(o.bbox.height);
                out.push(([x - 1.0, y - 1.0], o.center0(), side));
            }
            out
        })
        .collect()
}

#[test]
fn sec31_the_skin_term_of_eq9_moves_the_cloud_but_not_its_accuracy() {
    // Sec. 3.1 (Fig. 2) weighs the cloud with "both subtracted images and
    // skin colors": eq. 9's `lambda C` with `lambda = 1/N`. Over the
    // subtracted pixels (the default reading) the skin term adds at most
    // 1/N = 0.02 to a pixel whose IFD passes 0.05, and the subtracted
    // pixels of the default scene are all the face's: with or without it
    // (`lambda = 0`, the thresholded IFD alone) the cloud tracks equally
    // well. Measured (8 quick runs): 5.63 px, 0 % lost with the skin term,
    // 5.72 px, 0 % without; 4 runs of 150 frames 5.54 vs 5.47 px. It
    // does not help in any other scene tried either (docs/reproduction.md:
    // faster or slower face, no static skin distractors; with one or two
    // moving non-skin boxes the cloud is lost in about half the frames
    // either way, which run is lost decided by the random streams). What
    // the term does do is move the weights, so the two clouds part: their
    // estimates are 6.0 px apart per frame on average, as far as either is
    // from the face. Bound: both track (0 % lost, centre in [1, 9] px),
    // centres within 1 px of each other; the estimates 0.5-10 px apart on
    // average (0 when the skin term is dropped: the mutation fails here).
    let config = CondensationConfig {
        runs: SKIN_RUNS,
        ..CondensationConfig::quick()
    };
    let with = or_cloud(&config, 1.0 / 50.0);
    let without = or_cloud(&config, 0.0);
    let score = |runs: &[Vec<CloudFrame>]| {
        let (mut err, mut lost, mut n) = (0.0, 0usize, 0usize);
        for (e, t, side) in runs.iter().flatten() {
            let d = (e[0] - t[0]).hypot(e[1] - t[1]);
            err += d;
            lost += usize::from(d > config.lost_fraction * side);
            n += 1;
        }
        (err / n as f64, lost as f64 / n as f64)
    };
    let (cw, lw) = score(&with);
    let (cwo, lwo) = score(&without);
    let apart: Vec<f64> = with
        .iter()
        .flatten()
        .zip(without.iter().flatten())
        .map(|(a, b)| (a.0[0] - b.0[0]).hypot(a.0[1] - b.0[1]))
        .collect();
    let apart = apart.iter().sum::<f64>() / apart.len() as f64;
    println!(
        "OR with skin {cw:.2} px, lost {lw:.3}; without {cwo:.2} px, lost {lwo:.3}; \
         estimates {apart:.2} px apart"
    );
    assert!((1.0..=9.0).contains(&cw) && lw == 0.0, "{cw} {lw}");
    assert!((1.0..=9.0).contains(&cwo) && lwo == 0.0, "{cwo} {lwo}");
    assert!((cw - cwo).abs() <= 1.0, "{cw} vs {cwo}");
    assert!((0.5..=10.0).contains(&apart), "{apart}");
}

/// Runs of the full-length hand test, and its two-sided bounds: half and
/// twice the measured centre error and outline distance (6 runs x 150
/// frames: 9.69 / 5.50 px, 3.1 % lost; about 7 s in the test profile).
/// Freezing the contour's rotation and scale does not fail it (10.09 /
/// 5.84 px, 4.8 %): `sec33_the_contours_turn_and_scale_with_the_face`
/// catches that.
const HAND_RUNS: usize = 6;
const HAND_CENTRE: (f64, f64) = (4.8, 19.4);
const HAND_OUTLINE: (f64, f64) = (2.75, 11.0);

#[test]
fn sec32_the_hand_contour_on_the_ifd_alone_tracks_the_hand_at_full_length() {
    // Sec. 3.2: contour, IFD only, N = 200, 45 control points, sigma 5 px /
    // 3 deg / 0.05; our template the ellipse in the hand's first box, the
    // hand turning and changing size (`pose_motion`). Judged at the
    // paper-scale length (150 frames; `--full`, 10 runs: 10.42 px centre,
    // 6.32 px outline, 4 % lost): the hand is tracked. The quick scale's two
    // 60-frame runs lose 14 %, which is why this test runs its own jobs.
    // With two moving boxes (`movers-2`, quick) it is lost: 86 px, 80 %.
    let config = CondensationConfig {
        frames: 150,
        runs: HAND_RUNS,
        ..CondensationConfig::quick()
    };
    let (_, hands) = grid_of(&config, &[], true);
    let HandSummary {
        centre,
        outline,
        loss: lost,
    } = HandSummary::of(&hands);
    println!("hand, {HAND_RUNS} runs x 150 frames: {centre:.2} / {outline:.2} px, lost {lost:.3}");
    assert!(
        (HAND_CENTRE.0..=HAND_CENTRE.1).contains(&centre),
        "{centre}"
    );
    assert!(
        (HAND_OUTLINE.0..=HAND_OUTLINE.1).contains(&outline),
        "{outline}"
    );
    assert!(lost <= 0.05, "{lost}");
    let (_, hands) = grid_of(&reading("movers-2"), &[], true);
    let lost = HandSummary::of(&hands).loss;
    println!("movers-2 hand lost {lost}");
    assert!(lost >= 0.5, "{lost}");
}

#[test]
fn sec33_both_cues_with_half_the_contours_beat_the_ifd_alone_when_the_face_turns() {
    // Sec. 3.3: AND (IFD x skin, eq. 11) with N/2 contours tracks better
    // than one cue with N. With the face turning (+-15 deg) and changing
    // size (+-15 %) as the paper's contour state assumes (default,
    // `pose_motion`), AND at N/2 has the lower centre error and the lower
    // outline distance, both lose (almost) nothing: quick 3.20 / 3.90 / 0 %
    // vs 8.91 / 5.74 / 2.5 % at N = 100, 2.82 / 4.90 / 0 % vs 7.25 / 5.05 /
    // 0 % at N = 200: reproduced. With the face upright (`upright`, this
    // code's first scene) the IFD contour's outline is as good (3.03 vs
    // 3.56, 4.01 vs 3.92 px): the claim needs the turning face. With two
    // moving boxes (`movers-2`) the IFD alone follows them and AND wins by
    // far.
    for n in [100, 200] {
        let and = cell(Representation::Contour, Cue::And, n / 2);
        let ifd = cell(Representation::Contour, Cue::Ifd, n);
        println!("N={n}: {and:?}\n      {ifd:?}");
        assert!(and.centre >= 1.0 && and.centre <= 6.0, "{and:?}");
        assert!(and.outline >= 2.0 && and.outline <= 6.0, "{and:?}");
        assert_eq!(and.loss, 0.0, "{and:?}");
        assert!(ifd.centre >= 4.0 && ifd.centre <= 14.0, "{ifd:?}");
        assert!(ifd.loss <= 0.05, "{ifd:?}");
        assert!(and.centre <= 0.6 * ifd.centre, "{and:?} vs {ifd:?}");
        assert!(and.outline < ifd.outline, "{and:?} vs {ifd:?}");
    }
    assert!(result().verdict(Claim::AndHalfBeatsIfd).holds);
    let pairs = [
        key(Representation::Contour, Cue::And, 50),
        key(Representation::Contour, Cue::Ifd, 100),
        key(Representation::Contour, Cue::And, 100),
        key(Representation::Contour, Cue::Ifd, 200),
    ];
    let (up, _) = grid_of(&reading("upright"), &pairs, false);
    for pair in up.chunks(2) {
        let (and, ifd) = (pair[0], pair[1]);
        println!("upright: {and:?}\n         {ifd:?}");
        assert!(and.loss == 0.0 && ifd.loss <= 0.05, "{and:?} {ifd:?}");
        assert!(and.outline >= 0.8 * ifd.outline, "{and:?} vs {ifd:?}");
    }
    let keys = [
        key(Representation::Contour, Cue::And, 50),
        key(Representation::Contour, Cue::Ifd, 100),
        key(Representation::Contour, Cue::And, 100),
        key(Representation::Contour, Cue::Ifd, 200),
    ];
    let (m, _) = grid_of(&reading("movers-2"), &keys, false);
    for pair in m.chunks(2) {
        let (and, ifd) = (pair[0], pair[1]);
        println!("movers-2: {and:?}\n          {ifd:?}");
        assert!(
            and.centre <= 6.0 && and.outline <= 7.0 && and.loss == 0.0,
            "{and:?}"
        );
        assert!(and.centre <= 0.5 * ifd.centre, "{and:?} vs {ifd:?}");
        assert!(and.outline <= 0.5 * ifd.outline, "{and:?} vs {ifd:?}");
        assert!(ifd.loss >= 0.1 && ifd.loss <= 0.7, "{ifd:?}");
    }
}

#[test]
fn sec33_the_contours_turn_and_scale_with_the_face() {
    // The contour state carries "the rotating angle and the scaling
    // factor" (eq. 13). With the face turning +-15 deg and changing size
    // +-15 % (default) the AND contour's outline is worse than with the
    // face upright (`upright`) by the lag of its pose only: quick 3.90 vs
    // 3.03 px at N = 50, 4.90 vs 4.01 at N = 100 (+0.87, +0.89). With the
    // contour's rotation and scale frozen (no diffusion of theta, alpha)
    // the turning costs +2.04 and +1.43 px (4.44 vs 2.40, 3.75 vs 2.32).
    // Bound: the turning face costs at most 1.25 px of outline.
    let keys = [
        key(Representation::Contour, Cue::And, 50),
        key(Representation::Contour, Cue::And, 100),
    ];
    let (up, _) = grid_of(&reading("upright"), &keys, false);
    for (k, u) in keys.iter().zip(&up) {
        let turning = cell(k.representation, k.cue, k.particles);
        println!("turning {turning:?}\nupright {u:?}");
        assert!(turning.loss == 0.0 && u.loss == 0.0, "{turning:?} {u:?}");
        let cost = turning.outline - u.outline;
        assert!((0.0..=1.25).contains(&cost), "{turning:?} vs {u:?}: {cost}");
    }
}

#[test]
fn sec33_against_the_skin_alone_neither_wins() {
    // Against the skin cue alone at N the comparison goes either way: quick
    // skin N=100 2.83 / 3.57 px vs AND N=50 3.97 / 4.63 px; skin N=200
    // 2.39 / 3.32 vs AND N=100 2.54 / 5.25 px. Both track: that much, and
    // that AND's outline is not better, is asserted.
    for n in [100, 200] {
        let and = cell(Representation::Contour, Cue::And, n / 2);
        let skin = cell(Representation::Contour, Cue::Skin, n);
        println!("N={n}: {and:?}\n      {skin:?}");
        assert!(skin.centre <= 6.0 && and.centre <= 6.0, "{and:?} {skin:?}");
        assert!(skin.loss == 0.0 && and.loss == 0.0, "{and:?} {skin:?}");
        assert!(and.outline >= skin.outline, "{and:?} {skin:?}");
    }
    assert!(!result().verdict(Claim::AndHalfBeatsSkin).holds);
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
fn sec4_cavq_moves_the_set_onto_the_entering_object_at_once() {
    // Sec. 4: a set "in pause position has to move and track the new
    // object instantaneously"; c-AVQ shifts it onto the winning cluster of
    // the border stripes. Read as within 15 frames of the entry (half a
    // second at 30 fps). With the face the only other moving object
    // (default) every side tracker locks on that fast in 14-15 of 16 runs
    // with c-AVQ (points OR, the paper's point cloud: 2 6 3 2 2 5 2 40 4
    // 11 2 11 2 - 4 4); without it at most 3 of 16 reach the hand at all
    // (by diffusion, after 21-31 frames), none within 15. Bound: with at
    // least 12 of 16 within 15 frames; without at most 4 of 16 at all and
    // none within 15.
    for key in &SIDE_TRACKERS {
        let with = lock_on(*key, true);
        let without = lock_on(*key, false);
        println!("{}: with {with:?}\n   without {without:?}", key.label());
        let fast = |v: &[Option<usize>]| v.iter().flatten().filter(|&&k| k <= 15).count();
        let locked = without.iter().flatten().count();
        assert!(fast(&with) >= 12, "{}: {with:?}", key.label());
        assert_eq!(fast(&without), 0, "{}: {without:?}", key.label());
        assert!(locked <= 4, "{}: {without:?}", key.label());
    }
}

#[test]
fn sec5_priority_ifd_keeps_crossing_objects_apart() {
    // Sec. 5 (Fig. 6, point clouds): with the priority-subtracted IFD
    // (eq. 15) two crossing objects are tracked "at different direction".
    // Frames after the crossing (35 a run). The paper's point clouds (OR,
    // N = 50) keep both identities in 83 % of the pooled frames with
    // priority (15 of 16 runs over half), 0 % without (97 % merged):
    // reproduced. The contours (AND, N = 100) keep them in 7 runs of 16
    // (pooled 41 %), none without (99 % merged): partly. Bound: points OR
    // pooled kept in [0.7, 0.95] with, <= 0.05 and merged >= 0.8 without,
    // at least 12 runs over half with; contour at least 4 runs over half
    // with, none without, pooled kept <= 0.05 and merged >= 0.8 without.
    for key in SIDE_TRACKERS {
        println!(
            "{}: with {:?}\n   without {:?}",
            key.label(),
            crossings(key, true),
            crossings(key, false)
        );
    }
    let kept_most = |runs: &[CrossingCount]| runs.iter().filter(|c| 2 * c.kept > c.total()).count();
    let points = SIDE_TRACKERS[0];
    let (with, without) = (crossings(points, true), crossings(points, false));
    let (pw, pwo) = (pooled(&with), pooled(&without));
    println!(
        "points OR: {} runs over half; pooled with {pw:?}, without {pwo:?}",
        kept_most(&with)
    );
    assert!(
        share(pw.kept, &pw) >= 0.7 && share(pw.kept, &pw) <= 0.95,
        "{pw:?}"
    );
    assert!(kept_most(&with) >= 12, "{with:?}");
    assert!(share(pwo.kept, &pwo) <= 0.05, "{pwo:?}");
    assert!(share(pwo.merged, &pwo) >= 0.8, "{pwo:?}");
    let contour = SIDE_TRACKERS[2];
    let (with, without) = (crossings(contour, true), crossings(contour, false));
    let (pw, pwo) = (pooled(&with), pooled(&without));
    println!(
        "contour: runs keeping most frames {} with, {} without; pooled with {pw:?}, without {pwo:?}",
        kept_most(&with),
        kept_most(&without)
    );
    assert!(kept_most(&with) >= 4, "{with:?}");
    assert_eq!(kept_most(&without), 0, "{without:?}");
    assert!(share(pwo.kept, &pwo) <= 0.05, "{pwo:?}");
    assert!(share(pwo.merged, &pwo) >= 0.8, "{pwo:?}");
}
