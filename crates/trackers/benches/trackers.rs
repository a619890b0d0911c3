//! Criterion benchmarks for bayestrack-trackers (frames per second; the
//! throughput line of each benchmark is the tracker's fps).

use std::hint::black_box;

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    BallConfig, BallFilter, BallTracker, HistPfConfig, HistPfTracker, MadTracker, MadTrackerConfig,
    MultiTargetConfig, MultiTargetTracker, NccScaleConfig, NccScaleTracker, PfCorrelationConfig,
    PfCorrelationTracker, SearchArea, Tracker,
};
use bayestrack_trackers::{DcfTracker, DcfTrackerConfig, StapleTracker, StapleTrackerConfig};
use bayestrack_trackers::{
    HkpfConfig, HkpfTracker, IspfConfig, IspfTracker, StpfConfig, StpfTracker,
};
use bayestrack_trackers::{PfDcfConfig, PfDcfTracker};
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Bócsi and Csató's (paper 001) screen as the `ball` experiment renders it: 200x160 RGB, a
/// dark ball of radius 10 on a light screen moving 3 px/frame and reflected
/// at the edges, Gaussian sensor noise of 3 grey levels. Returns the frames
/// and the first frame's OTB box.
fn ball_frames(n: usize) -> (Vec<Image<u8>>, BBox) {
    let (w, h, r) = (200usize, 160usize, 10.0f64);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let (mut x, mut y, mut vx, mut vy) = (60.0f64, 50.0f64, 2.4f64, 1.8f64);
    let mut frames = Vec::with_capacity(n);
    let first = BBox::new(x - r + 1.5, y - r + 1.5, 2.0 * r, 2.0 * r);
    for _ in 0..n {
        let mut img = Image::new(w, h, 3, 0u8).unwrap();
        for (i, v) in img.as_mut_slice().iter_mut().enumerate() {
            let (px, py) = ((i / 3) % w, i / 3 / w);
            let inside = (px as f64 - x).hypot(py as f64 - y) <= r;
            let base = if inside { 20.0 } else { 245.0 };
            let z: f64 = StandardNormal.sample(&mut rng);
            *v = (base + 3.0 * z).round().clamp(0.0, 255.0) as u8;
        }
        frames.push(img);
        x += vx;
        y += vy;
        if !(r - 0.5..=w as f64 - 0.5 - r).contains(&x) {
            vx = -vx;
        }
        if !(r - 0.5..=h as f64 - 0.5 - r).contains(&y) {
            vy = -vy;
        }
    }
    (frames, first)
}

/// One tracker step per iteration through `frames`, starting again from
/// the first frame (re-initialised on `first`) at the end.
fn bench_steps<T: Tracker + ?Sized>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    tracker: &mut T,
    frames: &[Image<u8>],
    first: BBox,
) {
    tracker.init(frames[0].view(), first).unwrap();
    let mut k = 0;
    group.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            if k == frames.len() {
                k = 1;
                tracker.init(frames[0].view(), first).unwrap();
            }
            black_box(tracker.step(black_box(frames[k].view())).unwrap())
        })
    });
}

/// Bócsi and Csató's (paper 001) five ball trackers, one step per iteration.
fn bench_ball(c: &mut Criterion) {
    let (frames, first) = ball_frames(120);
    let mut group = c.benchmark_group("ball 200x160 (paper 001)");
    group.throughput(Throughput::Elements(1));
    for filter in BallFilter::PAPER {
        let mut tracker = BallTracker::new(filter, BallConfig::default(), 7).unwrap();
        let name = format!("{} step", filter.label());
        bench_steps(&mut group, &name, &mut tracker, &frames, first);
    }
    group.finish();
}

/// Dong and Chen's (paper 004) road as the `correlation` experiment renders it, simplified:
/// 320x240 gray, a textured road, `cars` dark 24x32 cars moving (2.56, 5)
/// px/frame (the second 60 px to the right), a billboard over rows 118-171,
/// noise of 2 grey levels. Returns the background, the frames and the first
/// car's OTB box.
fn road_frames(n: usize, cars: usize) -> (Image<u8>, Vec<Image<u8>>, BBox) {
    let (w, h) = (320usize, 240usize);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let bg = Image::from_fn(w, h, |x, y| (95 + (x * 7 + y * 13) % 11) as u8).unwrap();
    let mut frames = Vec::with_capacity(n);
    for k in 0..n {
        let mut img = bg.clone();
        for c in 0..cars {
            let (cx, cy) = (
                57.0 + 60.0 * c as f64 + 2.56 * k as f64,
                85.0 + 5.0 * (k % 20) as f64,
            );
            for y in 0..h {
                for x in 0..w {
                    let (u, v) = ((x as f64 - cx + 12.0) / 24.0, (y as f64 - cy + 16.0) / 32.0);
                    if (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) {
                        let shade = if (0.3..0.6).contains(&v) { 200 } else { 55 };
                        img.set(x, y, 0, shade);
                    }
                }
            }
        }
        if cars == 1 {
            for y in 118..172 {
                for x in 50..140 {
                    img.set(x, y, 0, if (y - 118) / 11 % 2 == 1 { 55 } else { 228 });
                }
            }
        }
        for v in img.as_mut_slice() {
            let z: f64 = StandardNormal.sample(&mut rng);
            *v = (f64::from(*v) + 2.0 * z).round().clamp(0.0, 255.0) as u8;
        }
        frames.push(img);
    }
    (bg, frames, BBox::new(46.0, 70.0, 25.0, 33.0))
}

/// Dong and Chen's (paper 004) trackers on the 320x240 road: MAD (window and whole-frame
/// search), PF correlation (Ns = 15), and the Kalman multi-target tracker
/// on two cars.
fn bench_road(c: &mut Criterion) {
    let (_, frames, first) = road_frames(20, 1);
    let mut group = c.benchmark_group("road 320x240 (paper 004)");
    group.throughput(Throughput::Elements(1));
    let trackers: Vec<(&str, Box<dyn Tracker>)> = vec![
        (
            "MAD window step",
            Box::new(MadTracker::new(MadTrackerConfig::default()).unwrap()),
        ),
        (
            "MAD frame step",
            Box::new(
                MadTracker::new(MadTrackerConfig {
                    search: SearchArea::Frame,
                    ..MadTrackerConfig::default()
                })
                .unwrap(),
            ),
        ),
        (
            "PF correlation Ns=15 step",
            Box::new(PfCorrelationTracker::new(PfCorrelationConfig::default()).unwrap()),
        ),
    ];
    for (name, mut tracker) in trackers {
        bench_steps(&mut group, name, tracker.as_mut(), &frames, first);
    }
    let (bg, frames, _) = road_frames(20, 2);
    let mut multi = MultiTargetTracker::new(MultiTargetConfig::default(), bg.view()).unwrap();
    let mut k = 0;
    group.bench_function("multi-target 2 cars step", |b| {
        b.iter(|| {
            k = (k + 1) % frames.len();
            black_box(multi.step(black_box(frames[k].view())).unwrap())
        })
    });
    group.finish();
}

/// A real-video-like 320x240 RGB sequence: a textured orange 26x64 target
/// (the size of Couple's pedestrians) walking 1.5 px/frame over a textured
/// green-grey background and growing 0.5 % per frame, noise of 3 grey
/// levels. Returns the frames and the first OTB box.
fn street_frames(n: usize) -> (Vec<Image<u8>>, BBox) {
    let (w, h) = (320usize, 240usize);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let bg =
        |x: f64, y: f64| 128.0 + 40.0 * (0.21 * x + 0.13 * y).sin() * (0.07 * x - 0.17 * y).cos();
    let fg = |u: f64, v: f64| 90.0 + 50.0 * (9.0 * u).sin() * (13.0 * v + 1.0).cos();
    let mut frames = Vec::with_capacity(n);
    let path = |k: usize| {
        let s = 1.005f64.powi(k as i32);
        (100.0 + 1.5 * k as f64, 120.0, 26.0 * s, 64.0 * s)
    };
    for k in 0..n {
        let (cx, cy, tw, th) = path(k);
        let mut data = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let (u, v) = ((x as f64 - cx) / tw, (y as f64 - cy) / th);
                let z: f64 = StandardNormal.sample(&mut rng);
                let p = if u.abs() <= 0.5 && v.abs() <= 0.5 {
                    let g = fg(u, v) + 3.0 * z;
                    [g * 1.3 + 40.0, g * 0.7, g * 0.4]
                } else {
                    let g = bg(x as f64, y as f64) + 3.0 * z;
                    [g * 0.8, g, g * 0.85]
                };
                data.extend(p.map(|v| v.round().clamp(0.0, 255.0) as u8));
            }
        }
        frames.push(Image::from_vec(w, h, 3, data).unwrap());
    }
    let (cx, cy, tw, th) = path(0);
    let first = BBox::new(
        cx - (tw - 1.0) / 2.0 + 1.0,
        cy - (th - 1.0) / 2.0 + 1.0,
        tw,
        th,
    );
    (frames, first)
}

/// The real-video trackers with scale (issue #7) on the 320x240 street.
fn bench_street(c: &mut Criterion) {
    let (frames, first) = street_frames(40);
    let mut group = c.benchmark_group("street 320x240 RGB (real-video trackers)");
    group.throughput(Throughput::Elements(1));
    let trackers: Vec<(&str, Box<dyn Tracker>)> = vec![
        (
            "ncc-scale step",
            Box::new(NccScaleTracker::new(NccScaleConfig::default()).unwrap()),
        ),
        (
            "hist-pf-scale step",
            Box::new(HistPfTracker::new(HistPfConfig::default(), 7).unwrap()),
        ),
    ];
    for (name, mut tracker) in trackers {
        bench_steps(&mut group, name, tracker.as_mut(), &frames, first);
    }
    group.finish();
}

/// Xu, Gao and Yang's (2015, paper 002) setting, simplified: 320x240 gray, a smooth textured
/// background, a 40x48 textured patch under a known affine motion (drift
/// of 30 px, rotation up to 0.6 rad, scale 0.75-1.25), noise of 2 grey
/// levels. Returns the frames and the first frame's OTB box.
fn affine_frames(n: usize) -> (Vec<Image<u8>>, BBox) {
    let (w, h, tw, th) = (320usize, 240usize, 40.0f64, 48.0f64);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let bg = |x: f64, y: f64| {
        128.0
            + 30.0 * (0.11 * x + 0.07 * y).sin() * (0.05 * x - 0.13 * y).cos()
            + 15.0 * (0.31 * x).sin() * (0.27 * y).cos()
    };
    let fg = |u: f64, v: f64| {
        140.0 + 50.0 * (0.35 * u + 0.6).sin() * (0.29 * v).cos() + 30.0 * (0.21 * (u - v)).sin()
    };
    let tau = std::f64::consts::TAU;
    let mut frames = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64;
        let theta = 0.6 * (tau * t / 80.0).sin();
        let s = 1.0 + 0.25 * (tau * t / 60.0).sin();
        let (cx, cy) = (
            160.0 + 30.0 * (tau * t / 90.0).sin(),
            120.0 + 18.0 * (1.0 - (tau * t / 70.0).cos()),
        );
        let (sn, cs) = theta.sin_cos();
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                let (u, v) = ((cs * dx + sn * dy) / s, (-sn * dx + cs * dy) / s);
                let z: f64 = StandardNormal.sample(&mut rng);
                let g = if u.abs() <= tw / 2.0 && v.abs() <= th / 2.0 {
                    fg(u, v)
                } else {
                    bg(x as f64, y as f64)
                };
                data.push((g + 2.0 * z).round().clamp(0.0, 255.0) as u8);
            }
        }
        frames.push(Image::from_vec(w, h, 1, data).unwrap());
    }
    let first = BBox::new(
        160.0 - (tw - 1.0) / 2.0 + 1.0,
        120.0 - (th - 1.0) / 2.0 + 1.0,
        tw,
        th,
    );
    (frames, first)
}

/// Xu, Gao and Yang's (2015, paper 002) three trackers at its settings, one step per iteration (the
/// initialisation, with the pose estimator's first training, is not timed).
fn bench_affine(c: &mut Criterion) {
    let (frames, first) = affine_frames(60);
    let mut group = c.benchmark_group("affine 320x240 gray (paper 002)");
    group.throughput(Throughput::Elements(1));
    let trackers: Vec<(&str, Box<dyn Tracker>)> = vec![
        (
            "stpf step",
            Box::new(StpfTracker::new(StpfConfig::default(), 7).unwrap()),
        ),
        (
            "stpf step, no per-frame LWPR training",
            Box::new(
                StpfTracker::new(
                    {
                        let mut c = StpfConfig::default();
                        c.appearance.training_per_update = 0;
                        c
                    },
                    7,
                )
                .unwrap(),
            ),
        ),
        (
            "ispf step",
            Box::new(IspfTracker::new(IspfConfig::default(), 7).unwrap()),
        ),
        (
            "hkpf step (100 particles)",
            Box::new(HkpfTracker::new(HkpfConfig::default(), 7).unwrap()),
        ),
    ];
    for (name, mut tracker) in trackers {
        let mut k = 0;
        tracker.init(frames[0].view(), first).unwrap();
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut total = std::time::Duration::ZERO;
                for _ in 0..iters {
                    k += 1;
                    if k == frames.len() {
                        k = 1;
                        tracker.init(frames[0].view(), first).unwrap();
                    }
                    let start = std::time::Instant::now();
                    black_box(tracker.step(black_box(frames[k].view())).unwrap());
                    total += start.elapsed();
                }
                total
            })
        });
    }
    group.finish();
}

/// Lee, Jo and Kang's (paper 003) webcam at 320x240 RGB: a skin-coloured ellipse (40x52,
/// RGB 224 172 138) wandering at up to about 4 px/frame over a textured
/// low-saturation wall. Returns the frames and the first frame's OTB box.
fn webcam_frames(n: usize) -> (Vec<Image<u8>>, BBox) {
    let (w, h) = (320usize, 240usize);
    let wall =
        |x: usize, y: usize| (110 + (x * 7 + y * 13) % 37 + (x / 12 + y / 12) % 3 * 15) as f64;
    let at = |k: usize| {
        let t = k as f64;
        (
            150.0 + 60.0 * (std::f64::consts::TAU * t / 90.0).sin(),
            125.0 + 40.0 * (std::f64::consts::TAU * t / 67.0 + 0.6).sin(),
        )
    };
    let frames = (0..n)
        .map(|k| {
            let (cx, cy) = at(k);
            let mut img = Image::new(w, h, 3, 0u8).unwrap();
            for y in 0..h {
                for x in 0..w {
                    let (dx, dy) = ((x as f64 - cx) / 20.0, (y as f64 - cy) / 26.0);
                    let c = if dx * dx + dy * dy <= 1.0 {
                        [224.0, 172.0, 138.0]
                    } else {
                        let g = wall(x, y);
                        [g, g + 3.0, g + 10.0]
                    };
                    for (ch, v) in c.iter().enumerate() {
                        img.set(x, y, ch, *v as u8);
                    }
                }
            }
            img
        })
        .collect();
    let (cx, cy) = at(0);
    (
        frames,
        BBox::new(cx - 19.5 + 1.0, cy - 25.5 + 1.0, 40.0, 52.0),
    )
}

/// Lee, Jo and Kang's (paper 003) CONDENSATION trackers, one step per iteration (a step
/// includes the frame's IFD map), and one contour measurement per
/// particle (the curve cues on one pose).
fn bench_condensation(c: &mut Criterion) {
    use bayestrack_appearance::{Candidate, Cue, Frame, Scratch, SkinModel};
    use bayestrack_trackers::{
        ContourConfig, ContourTracker, CurveCue, CurveCueKind, PointCloudConfig, PointCloudTracker,
    };
    let (frames, first) = webcam_frames(90);
    let mut group = c.benchmark_group("condensation 320x240 (paper 003)");
    group.throughput(Throughput::Elements(1));
    let mut points = PointCloudTracker::new(PointCloudConfig::default(), 7).unwrap();
    bench_steps(
        &mut group,
        "points step (N=50, OR)",
        &mut points,
        &frames,
        first,
    );
    let mut hand = ContourTracker::new(ContourConfig::hand(), 7).unwrap();
    bench_steps(
        &mut group,
        "contour step (N=200, n=45, IFD)",
        &mut hand,
        &frames,
        first,
    );
    for n in [100, 200] {
        let mut face = ContourTracker::new(ContourConfig::face(n), 7).unwrap();
        let name = format!("contour step (N={n}, n=21, AND)");
        bench_steps(&mut group, &name, &mut face, &frames, first);
    }
    // One contour measurement: 84 curve points (n = 21, 4 per span).
    let ifd =
        bayestrack_appearance::interframe_difference(frames[1].view(), frames[0].view()).unwrap();
    let spline =
        bayestrack_affine::ClosedBSpline::ellipse(21, 20.0, 26.0, Default::default()).unwrap();
    let pts = spline.sample(4);
    let skin = SkinModel::new(0.066, 0.38, 0.05).unwrap();
    let planes = Frame::new().with_ifd(ifd.view()).with_rgb(frames[1].view());
    let pose = Candidate::Pose(bayestrack_image::Affine2::translation(
        first.x + 19.0,
        first.y + 25.0,
    ));
    let mut scratch = Scratch::new();
    for (name, cue) in [
        (
            "contour measurement, IFD (84 points)",
            CurveCue::new(CurveCueKind::Ifd, &pts).unwrap(),
        ),
        (
            "contour measurement, skin (84 points)",
            CurveCue::new(CurveCueKind::Skin(skin), &pts).unwrap(),
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(
                    cue.log_likelihood(&planes, black_box(&pose), &mut scratch)
                        .unwrap(),
                )
            })
        });
    }
    group.finish();
}

/// The first frame box and frames of a shared real sequence
/// (`../shared/data/sequences/NAME`, see its README), or `None` (with a
/// note) when the folder is missing.
fn real_sequence(name: &str) -> Option<(Vec<Image<u8>>, BBox)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/sequences")
        .join(name);
    if !dir.is_dir() {
        eprintln!(
            "SKIPPED: {} is missing (the shared real sequences); no {name} bench",
            dir.display()
        );
        return None;
    }
    let gt = std::fs::read_to_string(dir.join("groundtruth_rect.txt")).ok()?;
    let v: Vec<f64> = gt
        .lines()
        .next()?
        .split([',', '\t', ' '])
        .filter(|s| !s.is_empty())
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let frames = bayestrack_image::list_frames(&dir)
        .ok()?
        .iter()
        .map(|p| bayestrack_image::read_frame(p).unwrap())
        .collect();
    Some((frames, BBox::new(v[0], v[1], v[2], v[3])))
}

/// The correlation-filter trackers per frame on the real OTB sequences
/// Crossing (360x240) and Couple (320x240), RGB (every other tracker on
/// the same frames: [`bench_registry`]).
fn bench_dcf(c: &mut Criterion) {
    for name in ["Crossing", "Couple"] {
        let Some((frames, first)) = real_sequence(name) else {
            continue;
        };
        let mut group = c.benchmark_group(format!("{name} real RGB (correlation filters)"));
        group.throughput(Throughput::Elements(1));
        let trackers: Vec<(&str, Box<dyn Tracker>)> = vec![
            (
                "dcf step",
                Box::new(DcfTracker::new(DcfTrackerConfig::default()).unwrap()),
            ),
            (
                "dcf-staple step",
                Box::new(StapleTracker::new(StapleTrackerConfig::default()).unwrap()),
            ),
            (
                "ncc-scale step",
                Box::new(NccScaleTracker::new(NccScaleConfig::default()).unwrap()),
            ),
        ];
        for (tname, mut tracker) in trackers {
            bench_steps(&mut group, tname, tracker.as_mut(), &frames, first);
        }
        group.finish();
    }
}

/// Every registered tracker (`REGISTRY`, built as `bayestrack track` and
/// `cargo xtask otb` build them: seed 0, default options) per frame on the
/// real Crossing (360x240) and Couple (320x240) frames: the throughput line
/// of each is the tracker-only frames per second that README quotes.
fn bench_registry(c: &mut Criterion) {
    for name in ["Crossing", "Couple"] {
        let Some((frames, first)) = real_sequence(name) else {
            continue;
        };
        let mut group = c.benchmark_group(format!("{name} real (every registered tracker)"));
        group.throughput(Throughput::Elements(1));
        group.warm_up_time(std::time::Duration::from_secs(1));
        group.measurement_time(std::time::Duration::from_secs(3));
        for info in bayestrack_trackers::REGISTRY {
            let mut tracker = info.build(0).unwrap();
            let label = format!("{} step", info.name);
            bench_steps(&mut group, &label, tracker.as_mut(), &frames, first);
        }
        group.finish();
    }
}

/// `pf-dcf` per frame on the same real sequences as [`bench_dcf`], RGB
/// (200 particles, 3 responses and one model update per tracked frame).
fn bench_pf_dcf(c: &mut Criterion) {
    for name in ["Crossing", "Couple"] {
        let Some((frames, first)) = real_sequence(name) else {
            continue;
        };
        let mut group = c.benchmark_group(format!("{name} real RGB (pf-dcf)"));
        group.throughput(Throughput::Elements(1));
        let mut tracker = PfDcfTracker::new(PfDcfConfig::default(), 0).unwrap();
        bench_steps(&mut group, "pf-dcf step", &mut tracker, &frames, first);
        group.finish();
    }
}

/// `BAYESTRACK_SIMD=avx2` (or `scalar`, `sse2`) caps the kernels' level for
/// the whole run (to time the AVX2 paths on a machine with AVX-512): first
/// in the group, it runs before any bench, whatever the filter.
fn simd_cap(_: &mut Criterion) {
    if let Some(level) = bayestrack_image::simd::cap_from_env().expect("BAYESTRACK_SIMD") {
        eprintln!("kernels capped at {level:?}");
    }
}

criterion_group!(
    benches,
    simd_cap,
    bench_dcf,
    bench_pf_dcf,
    bench_registry,
    bench_ball,
    bench_road,
    bench_street,
    bench_affine,
    bench_condensation
);
criterion_main!(benches);
