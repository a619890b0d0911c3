//! The three paper-002 trackers (HKPF, ISPF, the self-tuning HKPF) on
//! small synthetic sequences with exact affine ground truth.
//!
//! The scene: a 320x240 gray (or RGB) frame with a smooth textured
//! background and a 40x48 textured target mapped by a known pose
//! `M_k = [R(theta_k) diag(s_k, s_k a_k) | c_k]` (template coordinates
//! centred on the template to 0-based image coordinates), plus sensor
//! noise. `M_0` is a pure translation, so the trackers' poses compare
//! with the truth directly. Error = RMS distance of the four template
//! corners and the centre ([`bayestrack_affine::pose_error`]).

use bayestrack_affine::{Affine2, AffineGroup, pose_error};
use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    AffineTracker, Estimate, HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StopRule,
    StpfConfig, StpfTracker, Tracker, TrackerError, UpdateRule, build_tracker,
};
use nalgebra::{Matrix2, Vector2};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

const W: usize = 320;
const H: usize = 240;
const TW: f64 = 40.0;
const TH: f64 = 48.0;

/// A smooth random field: a sum of Gaussian blobs.
struct Blobs(Vec<(f64, f64, f64, f64)>);

impl Blobs {
    fn new(w: f64, h: f64, n: usize, size: (f64, f64), seed: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        Self(
            (0..n)
                .map(|_| {
                    (
                        rng.random_range(0.0..w),
                        rng.random_range(0.0..h),
                        rng.random_range(size.0..size.1),
                        rng.random_range(-1.0..1.0),
                    )
                })
                .collect(),
        )
    }

    fn at(&self, x: f64, y: f64) -> f64 {
        self.0
            .iter()
            .map(|&(cx, cy, s, a)| {
                let d2 = (x - cx).powi(2) + (y - cy).powi(2);
                if d2 > 9.0 * s * s {
                    0.0
                } else {
                    a * (-d2 / (2.0 * s * s)).exp()
                }
            })
            .sum()
    }
}

/// How the target moves.
#[derive(Clone, Copy)]
struct Motion {
    frames: usize,
    /// Rotation amplitude (rad), scale amplitude, aspect amplitude.
    pose: [f64; 3],
    /// Drift amplitudes (px) of the centre, x and y.
    drift: [f64; 2],
}

/// The true pose of frame `k`.
fn truth(m: &Motion, k: usize) -> Affine2 {
    let t = k as f64;
    let tau = std::f64::consts::TAU;
    let theta = m.pose[0] * (tau * t / 80.0).sin();
    let s = 1.0 + m.pose[1] * (tau * t / 60.0).sin();
    let a = 1.0 + m.pose[2] * (tau * t / 50.0).sin();
    let cx = 160.0 + m.drift[0] * (tau * t / 90.0).sin();
    let cy = 120.0 + m.drift[1] * (1.0 - (tau * t / 70.0).cos());
    let (sn, cs) = theta.sin_cos();
    let lin = Matrix2::new(cs, -sn, sn, cs) * Matrix2::new(s, 0.0, 0.0, s * a);
    Affine2::from_parts(lin, Vector2::new(cx, cy)).unwrap()
}

/// Renders the sequence: frames (1 or 3 channels) and true poses.
fn scene(m: &Motion, channels: usize, seed: u64) -> (Vec<Image<u8>>, Vec<Affine2>) {
    let background = Blobs::new(W as f64, H as f64, 160, (6.0, 20.0), 1000 + seed);
    let texture = Blobs::new(TW, TH, 40, (2.5, 6.0), 2000 + seed);
    let bg = Image::from_fn(W, H, |x, y| {
        120.0 + 45.0 * background.at(x as f64, y as f64)
    })
    .unwrap();
    let mut noise = Xoshiro256PlusPlus::seed_from_u64(3000 + seed);
    let mut frames = Vec::new();
    let mut poses = Vec::new();
    for k in 0..m.frames {
        let pose = truth(m, k);
        let inv = pose.inverse().unwrap();
        let mut data = Vec::with_capacity(W * H * channels);
        for y in 0..H {
            for x in 0..W {
                let mut v = bg.as_slice()[y * W + x];
                let p = inv.map_point(Vector2::new(x as f64, y as f64));
                let inside = (TW / 2.0 - p[0].abs()).min(TH / 2.0 - p[1].abs());
                if inside > -0.5 {
                    let alpha = (inside + 0.5).clamp(0.0, 1.0);
                    let t = 140.0 + 90.0 * texture.at(p[0] + TW / 2.0, p[1] + TH / 2.0);
                    v = v * (1.0 - alpha) + t * alpha;
                }
                let n: f64 = StandardNormal.sample(&mut noise);
                let g = (v + 2.0 * n).round().clamp(0.0, 255.0) as u8;
                for c in 0..channels {
                    // Colour: tint the channels, keeping the luma close.
                    let tint = [8i16, -4, -8][c] * (channels == 3) as i16;
                    data.push((g as i16 + tint).clamp(0, 255) as u8);
                }
            }
        }
        frames.push(Image::from_vec(W, H, channels, data).unwrap());
        poses.push(pose);
    }
    (frames, poses)
}

/// The OTB box of the initial pose (a translation).
fn initial_box(m0: &Affine2) -> BBox {
    let c = m0.offset();
    BBox::new(
        c[0] - (TW - 1.0) / 2.0 + 1.0,
        c[1] - (TH - 1.0) / 2.0 + 1.0,
        TW,
        TH,
    )
}

struct Run {
    errors: Vec<f64>,
    estimates: Vec<Estimate>,
}

impl Run {
    fn mean_error(&self) -> f64 {
        self.errors.iter().sum::<f64>() / self.errors.len() as f64
    }
    fn max_error(&self) -> f64 {
        self.errors.iter().copied().fold(0.0, f64::max)
    }
    fn mean_particles(&self) -> f64 {
        self.estimates.iter().map(|e| e.particles).sum::<usize>() as f64
            / self.estimates.len() as f64
    }
    fn mean_evaluations(&self) -> f64 {
        self.estimates.iter().map(|e| e.evaluations).sum::<usize>() as f64
            / self.estimates.len() as f64
    }
}

fn run(t: &mut dyn Tracker, frames: &[Image<u8>], poses: &[Affine2]) -> Run {
    t.init(frames[0].view(), initial_box(&poses[0])).unwrap();
    let mut errors = Vec::new();
    let mut estimates = Vec::new();
    for (f, p) in frames.iter().zip(poses).skip(1) {
        let e = t.step(f.view()).unwrap();
        let m = e.pose.unwrap();
        errors.push(pose_error(&m, p, TW, TH));
        estimates.push(e);
    }
    Run { errors, estimates }
}

fn report(name: &str, r: &Run) {
    println!(
        "{name}: corner error mean {:.2} px, max {:.2} px; particles/frame {:.1}; evaluations/frame {:.1}",
        r.mean_error(),
        r.max_error(),
        r.mean_particles(),
        r.mean_evaluations()
    );
    if std::env::var_os("AFFINE_TRACE").is_some() {
        let e: Vec<String> = r.errors.iter().map(|v| format!("{v:.1}")).collect();
        let n: Vec<String> = r
            .estimates
            .iter()
            .map(|v| v.particles.to_string())
            .collect();
        println!("  errors {}\n  particles {}", e.join(" "), n.join(" "));
    }
}

const POSE_CHANGE: Motion = Motion {
    frames: 61,
    pose: [0.6, 0.25, 0.1],
    drift: [30.0, 18.0],
};

/// Fast motion: the centre swings 90 px (up to 6.3 px per frame, beyond
/// the pose estimator's training range of 2 template px), mild pose change.
const FAST: Motion = Motion {
    frames: 61,
    pose: [0.2, 0.1, 0.05],
    drift: [90.0, 25.0],
};

fn stpf(seed: u64) -> StpfTracker {
    StpfTracker::new(StpfConfig::default(), seed).unwrap()
}

fn ispf(seed: u64) -> IspfTracker {
    IspfTracker::new(IspfConfig::default(), seed).unwrap()
}

fn hkpf(seed: u64) -> HkpfTracker {
    HkpfTracker::new(HkpfConfig::default(), seed).unwrap()
}

#[test]
fn stpf_follows_pose_change_with_few_particles() {
    let (frames, poses) = scene(&POSE_CHANGE, 1, 1);
    let r = run(&mut stpf(1), &frames, &poses);
    report("stpf", &r);
    // Measured on seeds 1-4: mean 1.4-2.4 px, max 6.4-8.1 px, 1.4-3.1
    // particles per frame.
    assert!(r.mean_error() < 3.0, "mean error {}", r.mean_error());
    assert!(r.max_error() < 10.0, "max error {}", r.max_error());
    assert!(r.mean_particles() < 5.0, "{}", r.mean_particles());
    assert!(r.estimates.iter().all(|e| !e.lost));
}

#[test]
fn stpf_follows_fast_motion_through_the_kalman_region() {
    let (frames, poses) = scene(&FAST, 1, 1);
    let r = run(&mut stpf(1), &frames, &poses);
    report("stpf fast", &r);
    // Measured on seeds 1-4: mean 1.3-2.1 px, max 3.3-5.4 px, 1.2-2.0
    // particles per frame (seed 1: 1.2; 3.4 when the particles ignore the
    // Kalman displacement).
    assert!(r.mean_error() < 3.0, "mean error {}", r.mean_error());
    assert!(r.max_error() < 8.0, "max error {}", r.max_error());
    assert!(r.mean_particles() < 2.5, "{}", r.mean_particles());
}

#[test]
fn stpf_needs_fewer_particles_than_ispf_at_comparable_error() {
    let (frames, poses) = scene(&POSE_CHANGE, 1, 2);
    let s = run(&mut stpf(2), &frames, &poses);
    let i = run(&mut ispf(2), &frames, &poses);
    report("stpf", &s);
    report("ispf", &i);
    // Measured on seeds 1-4: ISPF mean error 1.4-2.6 px with 7.2-8.8
    // particles per frame, the self-tuning filter 1.4-2.4 px with 1.4-3.1.
    assert!(i.mean_error() < 3.5, "ispf mean error {}", i.mean_error());
    assert!(s.mean_error() < 3.0, "stpf mean error {}", s.mean_error());
    assert!(
        s.mean_particles() < 0.6 * i.mean_particles(),
        "stpf {} ispf {}",
        s.mean_particles(),
        i.mean_particles()
    );
}

#[test]
fn hkpf_tracks_position_but_not_pose() {
    let (frames, poses) = scene(&POSE_CHANGE, 1, 3);
    let h = run(&mut hkpf(3), &frames, &poses);
    let s = run(&mut stpf(3), &frames, &poses);
    report("hkpf", &h);
    report("stpf", &s);
    // Measured on seeds 1-4: HKPF mean error 4.1-4.4 px (it keeps the
    // target: max 7.2-10.2 px), the self-tuning filter 1.4-2.4 px.
    assert!(h.estimates.iter().all(|e| e.particles == 100));
    assert!(
        h.mean_error() > 1.4 * s.mean_error(),
        "hkpf {} stpf {}",
        h.mean_error(),
        s.mean_error()
    );
    assert!(h.mean_error() > 3.0, "hkpf mean error {}", h.mean_error());
    assert!(h.mean_error() < 6.0, "hkpf mean error {}", h.mean_error());
}

#[test]
fn rgb_frames_are_tracked() {
    let (frames, poses) = scene(&POSE_CHANGE, 3, 4);
    let r = run(&mut stpf(4), &frames[..31], &poses[..31]);
    // Measured: 3.0 px over these 30 frames (the gray frames of seed 4
    // give 2.1 px over 60).
    report("stpf rgb", &r);
    assert!(r.mean_error() < 4.0, "mean error {}", r.mean_error());
}

#[test]
fn seeded_and_thread_independent() {
    let (frames, poses) = scene(
        &Motion {
            frames: 12,
            ..POSE_CHANGE
        },
        1,
        5,
    );
    for name in ["stpf", "ispf", "hkpf"] {
        let poses_of = |seed: u64| -> Vec<([f64; 6], usize)> {
            let mut t = build_tracker(name, seed).unwrap();
            run(t.as_mut(), &frames, &poses)
                .estimates
                .iter()
                .map(|e| (e.pose.unwrap().as_array(), e.particles))
                .collect()
        };
        let a = poses_of(7);
        // The same seed on other threads, two at once.
        let (b, c) = std::thread::scope(|s| {
            let b = s.spawn(|| poses_of(7));
            let c = s.spawn(|| poses_of(7));
            (b.join().unwrap(), c.join().unwrap())
        });
        assert!(a == b && a == c, "{name}: same seed, same bits");
        assert_ne!(a, poses_of(8), "{name}: another seed, another run");
    }
}

#[test]
fn registry_builds_them_and_they_report_their_work() {
    let (frames, poses) = scene(
        &Motion {
            frames: 11,
            ..POSE_CHANGE
        },
        1,
        6,
    );
    for name in ["hkpf", "ispf", "stpf"] {
        let mut t = build_tracker(name, 1).unwrap();
        assert_eq!(t.name(), name);
        let r = run(t.as_mut(), &frames, &poses);
        assert!(r.mean_error() < 6.0, "{name}: {}", r.mean_error());
        assert!(r.estimates.iter().all(|e| e.evaluations >= e.particles));
    }
    let mut t = stpf(1);
    t.init(frames[0].view(), initial_box(&poses[0])).unwrap();
    assert!(t.pose().is_some() && t.model().is_some());
    let e = t.step(frames[1].view()).unwrap();
    let s = t.stats();
    assert_eq!(s.particles, e.particles);
    assert_eq!(s.evaluations, e.evaluations);
    assert_eq!(t.particles().len(), e.particles);
    assert!(s.pose_estimator_calls >= e.particles && s.batches >= 1);
    assert!(s.best_similarity > s.stop_threshold || e.particles == 50);
    assert_eq!(e.pose.unwrap(), t.pose().unwrap());
    // The box is the bounding box of the posed template.
    let bb = t.pose().unwrap().bounding_box(TW, TH).unwrap();
    assert_eq!(e.bbox, bb);
    // A frame without the target: lost, not an error.
    let flat = Image::new(W, H, 1, 90u8).unwrap();
    let e = t.step(flat.view()).unwrap();
    assert!(e.lost && e.particles == 50, "{e:?}");
}

#[test]
fn bad_input_is_a_typed_error() {
    let gray = Image::new(80, 60, 1, 100u8).unwrap();
    let two = Image::new(80, 60, 2, 100u8).unwrap();
    let other = Image::new(81, 60, 1, 100u8).unwrap();
    let trackers: Vec<Box<dyn Tracker>> =
        vec![Box::new(stpf(0)), Box::new(ispf(0)), Box::new(hkpf(0))];
    for mut t in trackers {
        assert!(matches!(
            t.step(gray.view()),
            Err(TrackerError::NotInitialised)
        ));
        assert!(matches!(
            t.init(two.view(), BBox::new(10.0, 10.0, 20.0, 20.0)),
            Err(TrackerError::Channels { .. })
        ));
        assert!(matches!(
            t.init(gray.view(), BBox::new(70.0, 10.0, 20.0, 20.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        assert!(matches!(
            t.init(gray.view(), BBox::new(f64::NAN, 10.0, 20.0, 20.0)),
            Err(TrackerError::NonFiniteBox { .. })
        ));
        // A flat frame and a box touching the border initialise.
        t.init(gray.view(), BBox::new(1.0, 1.0, 20.0, 20.0))
            .unwrap();
        assert!(t.step(gray.view()).is_ok());
        // A 2x2 box and a box filling the frame (no room for particles:
        // lost, not an error).
        t.init(gray.view(), BBox::new(30.0, 30.0, 2.0, 2.0))
            .unwrap();
        assert!(t.step(gray.view()).is_ok());
        t.init(gray.view(), BBox::new(1.0, 1.0, 80.0, 60.0))
            .unwrap();
        let e = t.step(gray.view()).unwrap();
        assert!(e.lost && e.bbox.x.is_finite());
        assert!(matches!(
            t.step(other.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        assert!(matches!(
            t.step(two.view()),
            Err(TrackerError::FrameSizeChanged { .. }) | Err(TrackerError::Channels { .. })
        ));
    }
    let invalid = |r: Result<(), TrackerError>| {
        assert!(
            matches!(r, Err(TrackerError::InvalidParameter { .. })),
            "{r:?}"
        )
    };
    invalid(
        StpfTracker::new(
            StpfConfig {
                initial_particles: 0,
                ..StpfConfig::default()
            },
            0,
        )
        .map(|_| ()),
    );
    invalid(
        StpfTracker::new(
            StpfConfig {
                increment: f64::NAN,
                ..StpfConfig::default()
            },
            0,
        )
        .map(|_| ()),
    );
    let mut bad_region = StpfConfig::default();
    bad_region.region.r = -1.0;
    invalid(StpfTracker::new(bad_region, 0).map(|_| ()));
    let mut bad_patch = StpfConfig::default();
    bad_patch.appearance.pose.pool = 5;
    invalid(StpfTracker::new(bad_patch, 0).map(|_| ()));
    invalid(
        IspfTracker::new(
            IspfConfig {
                ar_coefficient: 2.0,
                ..IspfConfig::default()
            },
            0,
        )
        .map(|_| ()),
    );
    invalid(
        HkpfTracker::new(
            HkpfConfig {
                particles: 0,
                ..HkpfConfig::default()
            },
            0,
        )
        .map(|_| ()),
    );
    // The alternatives of the paper's two inconsistencies are options.
    let alt = StpfConfig {
        stop_rule: StopRule::MuPlusSigma,
        ..StpfConfig::default()
    };
    let mut alt = alt;
    alt.appearance.update_rule = UpdateRule::MuBMinusSigma;
    assert!(StpfTracker::new(alt, 0).is_ok());
}

#[test]
fn a_target_leaving_the_frame_does_not_carry_the_pose_away() {
    // The target drifts out through the right edge (centre up to x = 360
    // at frame 22) and comes back. While no particle can be scored (every
    // patch outside the frame) the pose stays at the last scored one and
    // the Kalman filter restarts there; coasting on the predicted velocity
    // and acceleration carried the pose out of the frame for good (the
    // Dudek setting of the `affine` experiment, RMS in the thousands).
    let out = Motion {
        frames: 40,
        pose: [0.0, 0.0, 0.0],
        drift: [200.0, 0.0],
    };
    let (frames, poses) = scene(&out, 1, 1);
    let trackers: [Box<dyn Tracker>; 2] = [Box::new(stpf(1)), Box::new(hkpf(1))];
    for mut t in trackers {
        let r = run(t.as_mut(), &frames, &poses);
        for (k, e) in r.estimates.iter().enumerate() {
            let c = e.pose.unwrap().offset();
            assert!(
                (0.0..W as f64).contains(&c[0]) && (0.0..H as f64).contains(&c[1]),
                "{} frame {}: centre {c:?}",
                t.name(),
                k + 2
            );
        }
    }
}
