//! The CONDENSATION trackers of Lee, Jo and Kang (2005) on small synthetic
//! webcam scenes rendered here: skin-coloured ellipses (faces) moving over
//! a textured low-saturation background with a static skin-coloured
//! distractor and sensor noise, 320x240 RGB. Every bound was checked by
//! breaking the code on purpose (see the report of the commit that added
//! this file).

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    CAvqConfig, ContourConfig, ContourTracker, CueSet, MultiCondensation, MultiConfig,
    ObjectConfig, PointCloudConfig, PointCloudTracker, Tracker, TrackerError, build_tracker,
};

const W: usize = 320;
const H: usize = 240;
/// The skin tone of the eval webcam scene (HSV hue 0.066, saturation 0.38).
const SKIN: [f64; 3] = [224.0, 172.0, 138.0];
/// A static skin-coloured distractor (wood / poster tone).
const DISTRACTOR: [f64; 3] = [205.0, 150.0, 110.0];

fn hash(mut v: u64) -> u64 {
    v = v.wrapping_add(0x9E37_79B9_7F4A_7C15);
    v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    v ^ (v >> 31)
}

fn unit(v: u64) -> f64 {
    (hash(v) >> 11) as f64 / (1u64 << 53) as f64
}

/// A face: an ellipse with semi-axes `(a, b)` centred at `(x, y)` (0-based
/// pixels), with two dark eyes unless `plain` (a uniform skin blob).
#[derive(Debug, Clone, Copy, Default)]
struct Face {
    x: f64,
    y: f64,
    a: f64,
    b: f64,
    plain: bool,
}

impl Face {
    /// The OTB box of the ellipse.
    fn bbox(&self) -> BBox {
        BBox::new(
            self.x - self.a + 0.5 + 1.0,
            self.y - self.b + 0.5 + 1.0,
            2.0 * self.a,
            2.0 * self.b,
        )
    }

    /// Fraction of pixel `(px, py)` covered (2x2 supersampling) and the
    /// colour there.
    fn colour(&self, px: f64, py: f64) -> Option<(f64, [f64; 3])> {
        let mut cov = 0.0;
        for (ox, oy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
            let (dx, dy) = ((px + ox - self.x) / self.a, (py + oy - self.y) / self.b);
            if dx * dx + dy * dy <= 1.0 {
                cov += 0.25;
            }
        }
        if cov == 0.0 {
            return None;
        }
        let (dx, dy) = (px - self.x, py - self.y);
        let eye = |ex: f64| ((dx - ex) / 3.6).powi(2) + ((dy + 6.0) / 2.4).powi(2) <= 1.0;
        let c = if !self.plain && (eye(-7.0) || eye(7.0)) {
            [60.0, 40.0, 35.0]
        } else {
            // Shading scales RGB, which keeps hue and saturation.
            let r = (dx / self.a).powi(2) + (dy / self.b).powi(2);
            let s = 1.0 - 0.12 * r;
            SKIN.map(|v| v * s)
        };
        Some((cov, c))
    }

    /// Distance from `(x, y)` to the ellipse outline (dense polygon).
    fn outline_distance(&self, x: f64, y: f64) -> f64 {
        (0..720)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 720.0;
                (self.x + self.a * t.cos() - x).hypot(self.y + self.b * t.sin() - y)
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The static part: value-noise texture (cell 12 px) in low-saturation
/// grey, a darker shelf, and a skin-coloured ellipse distractor at
/// (262, 58).
fn background(seed: u64) -> Image<u8> {
    let cell = 12.0;
    let lattice = |i: i64, j: i64| unit(seed ^ hash((i as u64) << 32 ^ j as u64));
    let noise = |x: f64, y: f64| {
        let (fx, fy) = (x / cell, y / cell);
        let (i, j) = (fx.floor() as i64, fy.floor() as i64);
        let (u, v) = (fx - fx.floor(), fy - fy.floor());
        let (u, v) = (u * u * (3.0 - 2.0 * u), v * v * (3.0 - 2.0 * v));
        let a = lattice(i, j) * (1.0 - u) + lattice(i + 1, j) * u;
        let b = lattice(i, j + 1) * (1.0 - u) + lattice(i + 1, j + 1) * u;
        a * (1.0 - v) + b * v
    };
    let distractor = Face {
        x: 262.0,
        y: 58.0,
        a: 18.0,
        b: 22.0,
        ..Default::default()
    };
    let mut img = Image::new(W, H, 3, 0u8).unwrap();
    for y in 0..H {
        for x in 0..W {
            let (fx, fy) = (x as f64, y as f64);
            let g = 95.0 + 90.0 * noise(fx, fy) + 20.0 * fy / H as f64;
            let mut c = [g, g + 3.0, g + 10.0];
            if (170.0..180.0).contains(&fy) && fx < 150.0 {
                c = [70.0, 66.0, 64.0];
            }
            if let Some((cov, _)) = distractor.colour(fx, fy) {
                for k in 0..3 {
                    c[k] = c[k] * (1.0 - cov) + DISTRACTOR[k] * cov;
                }
            }
            for (k, v) in c.iter().enumerate() {
                img.set(x, y, k, v.round().clamp(0.0, 255.0) as u8);
            }
        }
    }
    img
}

/// Frame `k`: the background with `faces` drawn back to front and
/// +-3 grey levels of uniform sensor noise.
fn render(bg: &Image<u8>, faces: &[Face], k: usize, seed: u64) -> Image<u8> {
    let mut img = bg.clone();
    for f in faces {
        let (x0, x1) = (
            (f.x - f.a - 1.0).max(0.0) as usize,
            (f.x + f.a + 2.0).clamp(0.0, W as f64) as usize,
        );
        let (y0, y1) = (
            (f.y - f.b - 1.0).max(0.0) as usize,
            (f.y + f.b + 2.0).clamp(0.0, H as f64) as usize,
        );
        for y in y0..y1 {
            for x in x0..x1 {
                if let Some((cov, c)) = f.colour(x as f64, y as f64) {
                    for (k, ck) in c.iter().enumerate() {
                        let v = f64::from(img.get(x, y, k).unwrap());
                        img.set(x, y, k, (v * (1.0 - cov) + ck * cov).round() as u8);
                    }
                }
            }
        }
    }
    let key = hash(seed ^ 0xF00D) ^ (k as u64) << 40;
    for (i, v) in img.as_mut_slice().iter_mut().enumerate() {
        let n = (hash(key ^ i as u64) % 7) as i16 - 3;
        *v = (i16::from(*v) + n).clamp(0, 255) as u8;
    }
    img
}

/// The wandering face of frame `k`: a smooth Lissajous path, peak speed
/// about 4 px/frame, over the textured wall.
fn wander(k: usize) -> Face {
    let t = k as f64;
    Face {
        x: 150.0 + 60.0 * (std::f64::consts::TAU * t / 90.0).sin(),
        y: 125.0 + 40.0 * (std::f64::consts::TAU * t / 67.0 + 0.6).sin(),
        a: 20.0,
        b: 26.0,
        ..Default::default()
    }
}

struct Run {
    /// Centre error per frame (px), frames 1..
    centre: Vec<f64>,
    /// Mean curve-to-outline distance per frame (contours only).
    outline: Vec<f64>,
    estimates: Vec<BBox>,
}

fn centre_of(b: &BBox) -> (f64, f64) {
    let (x, y) = b.center();
    (x - 1.0, y - 1.0)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Runs `tracker` over `frames` frames of the wandering face.
fn run_wander(tracker: &mut dyn Tracker, frames: usize, seed: u64) -> Run {
    let bg = background(seed);
    tracker
        .init(render(&bg, &[wander(0)], 0, seed).view(), wander(0).bbox())
        .unwrap();
    let mut run = Run {
        centre: Vec::new(),
        outline: Vec::new(),
        estimates: Vec::new(),
    };
    for k in 1..frames {
        let f = wander(k);
        let e = tracker.step(render(&bg, &[f], k, seed).view()).unwrap();
        let (x, y) = centre_of(&e.bbox);
        run.centre.push((x - f.x).hypot(y - f.y));
        run.estimates.push(e.bbox);
    }
    run
}

fn run_contour(tracker: &mut ContourTracker, frames: usize, seed: u64) -> Run {
    let bg = background(seed);
    tracker
        .init(render(&bg, &[wander(0)], 0, seed).view(), wander(0).bbox())
        .unwrap();
    let mut run = Run {
        centre: Vec::new(),
        outline: Vec::new(),
        estimates: Vec::new(),
    };
    for k in 1..frames {
        let f = wander(k);
        let e = tracker.step(render(&bg, &[f], k, seed).view()).unwrap();
        assert_eq!(e.particles, tracker.config().particles);
        assert_eq!(e.evaluations, tracker.config().particles);
        let m = tracker.mean_state().unwrap();
        run.centre.push((m[0] - f.x).hypot(m[1] - f.y));
        let curve = tracker.curve(&m);
        run.outline.push(mean(
            &curve
                .iter()
                .map(|p| f.outline_distance(p.x, p.y))
                .collect::<Vec<_>>(),
        ));
        run.estimates.push(e.bbox);
    }
    run
}

#[test]
fn points_tracker_follows_the_face() {
    // Sec. 3.1: N = 50, OR fusion, lambda = 1/N, sigma 30 px.
    let mut errs = Vec::new();
    for seed in 0..10 {
        let mut t = PointCloudTracker::new(PointCloudConfig::default(), seed).unwrap();
        let run = run_wander(&mut t, 60, seed);
        let (m, worst) = (
            mean(&run.centre),
            run.centre.iter().copied().fold(0.0, f64::max),
        );
        println!("points seed {seed}: mean centre error {m:.2} px, worst {worst:.2} px");
        errs.push((m, worst));
    }
    // Measured over seeds 0-9: per-seed mean 8.1-17.7 px (pooled 10.7),
    // per-seed worst 22-81 px (median 32.5); before the engine port 8.9-14.5
    // (10.7) and 24-75 (36). The cloud (30 px diffusion, 50
    // particles, weights linear in the cues) is noisy, so the bounds are on
    // the pooled mean and the median worst frame.
    let pooled = errs.iter().map(|e| e.0).sum::<f64>() / errs.len() as f64;
    let mut worst: Vec<f64> = errs.iter().map(|e| e.1).collect();
    worst.sort_by(f64::total_cmp);
    let median_worst = (worst[4] + worst[5]) / 2.0;
    assert!(pooled <= 14.0, "pooled mean centre error {pooled}");
    assert!(
        median_worst <= 50.0,
        "median worst centre error {median_worst}"
    );
}

#[test]
fn contour_tracker_fits_the_outline() {
    // Sec. 3.3: N = 100, n = 21, AND fusion.
    let mut all = Vec::new();
    for seed in 0..3 {
        let mut t = ContourTracker::new(ContourConfig::face(100), seed).unwrap();
        let run = run_contour(&mut t, 60, seed);
        let (c, o) = (mean(&run.centre), mean(&run.outline));
        let worst = run.outline.iter().copied().fold(0.0, f64::max);
        println!(
            "contour AND N=100 seed {seed}: centre {c:.2} px, outline {o:.2} px (worst {worst:.2})"
        );
        all.push((c, o, worst));
    }
    for (c, o, worst) in all {
        // Measured: centre 5.8-7.0 px, outline 5.6-5.9 px, worst 8.2-8.9 px
        // (before the engine port 5.7-6.9, 5.2-5.5, 7.6-9.3).
        assert!(c <= 9.0, "mean centre error {c}");
        assert!(o <= 7.5, "mean outline distance {o}");
        assert!(worst <= 11.0, "worst outline distance {worst}");
    }
}

#[test]
fn hand_settings_with_ifd_only_track_too() {
    // Sec. 3.2's settings (N = 200, n = 45, IFD only, 3 degrees, 0.05) on
    // the same face: the IFD alone is noisier in scale.
    let mut all = Vec::new();
    for seed in 0..3 {
        let mut t = ContourTracker::new(ContourConfig::hand(), seed).unwrap();
        let run = run_contour(&mut t, 60, seed);
        let (c, o) = (mean(&run.centre), mean(&run.outline));
        println!("contour IFD N=200 seed {seed}: centre {c:.2} px, outline {o:.2} px");
        all.push((c, o));
    }
    for (c, o) in all {
        // Measured: centre 8.3-9.5 px, outline 6.3-6.4 px (before the engine
        // port 7.6-8.2, 6.3-6.7).
        assert!(c <= 11.0, "mean centre error {c}");
        assert!(o <= 8.5, "mean outline distance {o}");
    }
}

#[test]
fn same_bits_for_a_seed_on_any_thread() {
    let go = |seed| {
        let mut p = PointCloudTracker::new(PointCloudConfig::default(), seed).unwrap();
        let mut c = ContourTracker::new(ContourConfig::face(50), seed).unwrap();
        let a = run_wander(&mut p, 12, 5).estimates;
        let b = run_wander(&mut c, 12, 5).estimates;
        (a, b)
    };
    let here = go(11);
    let threads: Vec<_> = (0..2).map(|_| std::thread::spawn(move || go(11))).collect();
    for t in threads {
        assert_eq!(t.join().unwrap(), here);
    }
    assert_ne!(go(12).0, here.0, "another seed, other particles");
}

#[test]
fn registry_trackers_run_and_gray_frames_are_typed_errors() {
    for name in ["condensation-points", "condensation-contour"] {
        let mut t = build_tracker(name, 3).unwrap();
        let run = run_wander(t.as_mut(), 20, 1);
        println!(
            "{name}: mean centre error {:.2} px over 20 frames",
            mean(&run.centre)
        );
        assert!(mean(&run.centre) < 15.0, "{name}: {}", mean(&run.centre));
        let gray = Image::new(W, H, 1, 100u8).unwrap();
        let mut t = build_tracker(name, 3).unwrap();
        let err = t.init(gray.view(), BBox::new(10.0, 10.0, 40.0, 52.0));
        assert!(
            matches!(err, Err(TrackerError::Channels { got: 1, .. })),
            "{name}: {err:?}"
        );
        let msg = err.err().unwrap().to_string();
        assert!(msg.contains("skin"), "{msg}");
    }
    // IFD-only contours run on gray frames.
    let mut t = ContourTracker::new(ContourConfig::hand(), 0).unwrap();
    let bg = background(2);
    let gray = |k| bayestrack_image::rgb_to_gray(render(&bg, &[wander(k)], k, 2).view()).unwrap();
    t.init(gray(0).view(), wander(0).bbox()).unwrap();
    for k in 1..10 {
        let e = t.step(gray(k).view()).unwrap();
        assert!(e.bbox.x.is_finite());
    }
}

/// A face resting at the centre; a second face enters through the left
/// border at frame `entry` (its right edge touches the border) moving right
/// 3 px/frame, and rests at x = 90.
fn entering(k: usize, entry: usize) -> [Face; 2] {
    let rest = Face {
        x: 200.0,
        y: 120.0,
        a: 20.0,
        b: 26.0,
        ..Default::default()
    };
    let x = (-20.5 + 3.0 * (k as f64 - entry as f64)).min(90.0);
    [
        rest,
        Face {
            x,
            y: 110.0,
            a: 20.0,
            b: 26.0,
            ..Default::default()
        },
    ]
}

/// Frames from the entry until the estimate is within 20 px of the
/// newcomer's centre for 3 frames in a row (`None`: never within 40 frames).
fn lock_on(tracker: &mut dyn Tracker, seed: u64) -> Option<usize> {
    let entry = 10;
    let bg = background(seed);
    let frame = |k| render(&bg, &entering(k, entry), k, seed);
    tracker
        .init(frame(0).view(), entering(0, entry)[0].bbox())
        .unwrap();
    let mut run = 0;
    for k in 1..entry + 40 {
        let e = tracker.step(frame(k).view()).unwrap();
        let new = entering(k, entry)[1];
        let (x, y) = centre_of(&e.bbox);
        if k >= entry && (x - new.x).hypot(y - new.y) <= 20.0 {
            run += 1;
            if run == 3 {
                return Some(k - 2 - entry);
            }
        } else {
            run = 0;
        }
    }
    None
}

#[test]
fn cavq_locks_onto_an_entering_object() {
    // Sec. 4: the set "has to move and track the new object
    // instantaneously". Whether a run locks on is all or nothing, so the
    // claim is read over seeds: with c-AVQ the contour locks on within 12
    // frames in most seeds (at least half), without it the set stays on
    // the resting face (at most one seed in six reaches the newcomer, by
    // diffusion). The point cloud (30 px diffusion) finds the newcomer by
    // diffusion alone, so c-AVQ need not make it faster: printed, not
    // asserted. Measured: contour 7 frames in all 6 seeds, never without;
    // points 10-20 frames with, 13-27 without (before the engine port
    // contour 7-8, points 8-22 with, 15-24 without).
    const SEEDS: u64 = 6;
    let (mut fast, mut plain_locked) = (0, 0);
    for seed in 0..SEEDS {
        let with = ContourConfig {
            avq: Some(CAvqConfig::default()),
            ..ContourConfig::face(100)
        };
        let mut t = ContourTracker::new(with, seed).unwrap();
        let k = lock_on(&mut t, seed);
        let mut plain = ContourTracker::new(ContourConfig::face(100), seed).unwrap();
        let k0 = lock_on(&mut plain, seed);
        println!("contour seed {seed}: lock-on with c-AVQ {k:?}, without {k0:?}");
        let pts = PointCloudConfig {
            avq: Some(CAvqConfig::default()),
            ..PointCloudConfig::default()
        };
        let mut p = PointCloudTracker::new(pts, seed).unwrap();
        let kp = lock_on(&mut p, seed);
        let mut p0 = PointCloudTracker::new(PointCloudConfig::default(), seed).unwrap();
        let kp0 = lock_on(&mut p0, seed);
        println!("points seed {seed}: lock-on with c-AVQ {kp:?}, without {kp0:?}");
        fast += usize::from(k.is_some_and(|k| k <= 12));
        plain_locked += usize::from(k0.is_some());
    }
    println!(
        "contour: {fast}/{SEEDS} seeds lock on within 12 frames with c-AVQ, {plain_locked} lock on without"
    );
    assert!(2 * fast as u64 >= SEEDS, "with c-AVQ {fast}/{SEEDS}");
    assert!(plain_locked <= 1, "without c-AVQ {plain_locked}/{SEEDS}");
}

/// Two faces crossing: object 0 moves right, object 1 left, 2.5 px/frame,
/// 12 px apart vertically, aligned at frame 40.
fn crossing(k: usize) -> [Face; 2] {
    let t = k as f64 - 40.0;
    [
        Face {
            x: 160.0 + 2.5 * t,
            y: 126.0,
            a: 20.0,
            b: 26.0,
            ..Default::default()
        },
        Face {
            x: 160.0 - 2.5 * t,
            y: 114.0,
            a: 20.0,
            b: 26.0,
            ..Default::default()
        },
    ]
}

/// After the crossing (frames whose true centres are more than 45 px
/// apart, 30 of the 80), how the two estimates sit: each within 20 px of
/// its own object (kept), each within 20 px of the other one (swapped),
/// both within 20 px of the same object (merged), or otherwise (lost).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Crossing {
    kept: usize,
    swapped: usize,
    merged: usize,
    lost: usize,
}

impl std::ops::AddAssign for Crossing {
    fn add_assign(&mut self, o: Self) {
        self.kept += o.kept;
        self.swapped += o.swapped;
        self.merged += o.merged;
        self.lost += o.lost;
    }
}

fn crossing_run(config: MultiConfig, seed: u64) -> Crossing {
    let bg = background(seed);
    let frame = |k| render(&bg, &crossing(k), k, seed);
    let mut m = MultiCondensation::new(config, seed).unwrap();
    let first = frame(0);
    for f in crossing(0) {
        m.add_object(first.view(), f.bbox()).unwrap();
    }
    let mut c = Crossing::default();
    for k in 1..80 {
        let out = m.step(frame(k).view()).unwrap();
        let truth = crossing(k);
        assert_eq!((out[0].id, out[1].id), (0, 1));
        if k > 40 && (truth[0].x - truth[1].x).abs() > 45.0 {
            let on = |i: usize, j: usize| {
                (out[i].centre.0 - truth[j].x).hypot(out[i].centre.1 - truth[j].y) <= 20.0
            };
            if on(0, 0) && on(1, 1) {
                c.kept += 1;
            } else if on(0, 1) && on(1, 0) {
                c.swapped += 1;
            } else if (on(0, 0) && on(1, 0)) || (on(0, 1) && on(1, 1)) {
                c.merged += 1;
            } else {
                c.lost += 1;
            }
        }
    }
    c
}

#[test]
fn crossing_objects_with_and_without_priority_ifd() {
    // Sec. 5's claim: with the priority-subtracted IFD two crossing objects
    // keep their identities. Pooled over seeds 0-4 (150 frames after the
    // crossing), measured (kept / swapped / merged / lost): points 18 / 21 /
    // 3 / 108 with priority, 3 / 14 / 8 / 125 without; contours 2 / 36 / 22
    // / 90 with, 23 / 0 / 24 / 103 without (before the engine port: points
    // 16 / 2 / 8 / 124 and 4 / 2 / 15 / 129, contours 0 / 63 / 21 / 66 and
    // 18 / 44 / 0 / 88). Not reproduced: the point
    // clouds lose both objects in the overlap, and the priority-0 contour
    // follows the object in front (the stronger IFD) whichever it is, so
    // priority turns merges into swaps. Printed, not asserted; what the
    // priority field does guarantee is asserted in
    // `a_later_set_cannot_take_the_motion_an_earlier_set_explains`.
    let contour = MultiConfig {
        object: ObjectConfig::Contour(ContourConfig::face(100)),
        ..MultiConfig::default()
    };
    let no = |c: MultiConfig| MultiConfig {
        priority: false,
        ..c
    };
    let mut result = [Crossing::default(); 4];
    for seed in 0..5 {
        for (r, config) in result.iter_mut().zip([
            MultiConfig::default(),
            no(MultiConfig::default()),
            contour,
            no(contour),
        ]) {
            *r += crossing_run(config, seed);
        }
    }
    let [p, p0, c, c0] = result;
    println!("points: priority {p:?}, without {p0:?}");
    println!("contours: priority {c:?}, without {c0:?}");
    for r in result {
        assert_eq!(r.kept + r.swapped + r.merged + r.lost, 150);
    }
}

#[test]
fn a_later_set_cannot_take_the_motion_an_earlier_set_explains() {
    // Two IFD-only point sets started on the same wandering face. With
    // priority, set 1 measures on V^1, where set 0's box is zeroed: it has
    // no motion of its own to follow. Without priority both follow the face.
    // One seed's share swings with the random streams (set 1 can drift back
    // onto the face for a while), so the claim is on the mean over seeds:
    // set 0 and, without priority, set 1 on the face at least half of the
    // frames; set 1 with priority at most a quarter. Measured (means): set 0
    // 0.68, set 1 0.17 with priority (per seed 0.03-0.42), 0.70 without
    // (before the engine port 0.72, 0.12 (0.05-0.20), 0.74).
    const SEEDS: u64 = 8;
    let mut mean_with = [0.0; 2];
    let mut mean_without = [0.0; 2];
    for seed in 0..SEEDS {
        let config = |priority| MultiConfig {
            object: ObjectConfig::Points(PointCloudConfig {
                cues: CueSet::Ifd,
                ..PointCloudConfig::default()
            }),
            priority,
            ..MultiConfig::default()
        };
        let share_on_face = |priority| {
            let bg = background(seed);
            let mut m = MultiCondensation::new(config(priority), seed).unwrap();
            let first = render(&bg, &[wander(0)], 0, seed);
            m.add_object(first.view(), wander(0).bbox()).unwrap();
            m.add_object(first.view(), wander(0).bbox()).unwrap();
            let mut on = [0usize; 2];
            for k in 1..60 {
                let out = m.step(render(&bg, &[wander(k)], k, seed).view()).unwrap();
                let f = wander(k);
                for (n, o) in on.iter_mut().zip(&out) {
                    if (o.centre.0 - f.x).hypot(o.centre.1 - f.y) <= 15.0 {
                        *n += 1;
                    }
                }
            }
            on.map(|n| n as f64 / 59.0)
        };
        let with = share_on_face(true);
        let without = share_on_face(false);
        println!(
            "seed {seed}: share of frames within 15 px of the face, sets 0 and 1: with priority {with:.2?}, without {without:.2?}"
        );
        for i in 0..2 {
            mean_with[i] += with[i] / SEEDS as f64;
            mean_without[i] += without[i] / SEEDS as f64;
        }
    }
    println!("mean over seeds: with priority {mean_with:.3?}, without {mean_without:.3?}");
    assert!(
        mean_with[0] >= 0.5 && mean_without[0] >= 0.5 && mean_without[1] >= 0.5,
        "{mean_with:?} {mean_without:?}"
    );
    assert!(
        mean_with[1] <= 0.25,
        "set 1 took set 0's motion: {mean_with:?}"
    );
}

#[test]
fn ifd_only_point_cloud_needs_motion() {
    // IFD alone on gray frames: with the face resting, nothing is measured
    // and the tracker says it is lost.
    let mut t = PointCloudTracker::new(
        PointCloudConfig {
            cues: CueSet::Ifd,
            ..PointCloudConfig::default()
        },
        0,
    )
    .unwrap();
    let bg = background(4);
    let still = bayestrack_image::rgb_to_gray(render(&bg, &[wander(0)], 0, 4).view()).unwrap();
    t.init(still.view(), wander(0).bbox()).unwrap();
    let e = t.step(still.view()).unwrap();
    assert!(e.lost);
}

#[test]
fn both_cues_with_half_the_particles() {
    // Sec. 3.3's claim: IFD AND skin with N/2 contours tracks better than
    // one cue with N. Face settings (n = 21, 5 px, 1 degree, 0.01) for all.
    let configs = [
        ("AND N=50", ContourConfig::face(50)),
        (
            "IFD N=100",
            ContourConfig {
                cues: CueSet::Ifd,
                ..ContourConfig::face(100)
            },
        ),
        (
            "skin N=100",
            ContourConfig {
                cues: CueSet::Skin,
                ..ContourConfig::face(100)
            },
        ),
    ];
    let mut result = Vec::new();
    for (name, config) in configs {
        let (mut c, mut o) = (0.0, 0.0);
        for seed in 0..3 {
            let mut t = ContourTracker::new(config, seed).unwrap();
            let run = run_contour(&mut t, 60, seed);
            c += mean(&run.centre) / 3.0;
            o += mean(&run.outline) / 3.0;
        }
        println!("{name}: mean centre error {c:.2} px, mean outline distance {o:.2} px");
        result.push((c, o));
    }
    let [(and_c, and_o), (ifd_c, ifd_o), (skin_c, skin_o)] = result[..] else {
        unreachable!()
    };
    // Measured (3 seeds, 60 frames), centre / outline: AND N=50 6.79 px /
    // 5.38 px, IFD N=100 11.95 / 7.16, skin N=100 6.19 / 4.31 (before the
    // engine port 6.23 / 5.70, 10.88 / 6.55, 6.34 / 4.90). Against the IFD alone the claim
    // reproduces; against the skin alone it does not in this scene (no
    // moving non-skin distractors, the skin distractor far from the path),
    // so that comparison is printed, not asserted.
    let _ = (skin_c, skin_o);
    assert!(and_c <= 9.0, "AND N=50 centre {and_c}");
    assert!(
        and_c <= 0.75 * ifd_c,
        "AND N=50 {and_c} vs IFD N=100 {ifd_c}"
    );
    assert!(and_o < ifd_o, "AND N=50 {and_o} vs IFD N=100 {ifd_o}");
}
