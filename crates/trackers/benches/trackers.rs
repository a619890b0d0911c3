//! Criterion benchmarks for bayestrack-trackers (frames per second; the
//! throughput line of each benchmark is the tracker's fps).

use std::hint::black_box;

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    BallConfig, BallFilter, BallTracker, HistPfConfig, HistPfTracker, MadTracker, MadTrackerConfig,
    MultiTargetConfig, MultiTargetTracker, NccScaleConfig, NccScaleTracker, PfCorrelationConfig,
    PfCorrelationTracker, SearchArea, Tracker,
};
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Paper 001's screen as the `ball` experiment renders it: 200x160 RGB, a
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

/// Paper 001's five ball trackers, one step per iteration.
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

/// Paper 004's road as the `correlation` experiment renders it, simplified:
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

/// Paper 004's trackers on the 320x240 road: MAD (window and whole-frame
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

criterion_group!(benches, bench_ball, bench_road, bench_street);
criterion_main!(benches);
