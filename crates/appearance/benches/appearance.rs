//! Criterion benchmarks for bayestrack-appearance (single thread).

use std::hint::black_box;

use bayestrack_appearance::{
    Candidate, Cue, Frame, HistogramDistance, IfdCue, MadSearch, RgbHistogram, Scratch, SkinModel,
    histogram_search, interframe_difference_into, mad_map_into, mad_search,
};
use bayestrack_image::{Image, Rect, rgb_to_gray};
use criterion::{Criterion, criterion_group, criterion_main};

fn noise(w: usize, h: usize, ch: usize, seed: u32) -> Image<u8> {
    let mut img = Image::new(w, h, ch, 0u8).unwrap();
    let mut s = seed;
    for v in img.as_mut_slice() {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *v = (s >> 24) as u8;
    }
    img
}

/// A smooth-ish 320x240 gray scene (sum of ramps plus noise), closer to a
/// real frame than white noise for the early-termination search.
fn scene(seed: u32) -> Image<u8> {
    let n = noise(320, 240, 1, seed);
    Image::from_fn(320, 240, |x, y| {
        let base = (x as f32 * 0.5 + (y as f32 * 0.07).sin() * 40.0 + 60.0) as u32;
        ((base + u32::from(n.get(x, y, 0).unwrap()) / 8) % 256) as u8
    })
    .unwrap()
}

fn bench_mad(c: &mut Criterion) {
    let frame = scene(1);
    let template = frame.crop(Rect::new(201, 117, 30, 20)).unwrap().to_image();
    let full = Rect::new(0, 0, 320, 240);
    c.bench_function("mad_search 30x20 template over 320x240 (scene)", |b| {
        b.iter(|| mad_search(black_box(frame.view()), template.view(), full).unwrap())
    });
    let mut searcher = MadSearch::new();
    c.bench_function(
        "MadSearch (reused buffers) 30x20 over 320x240 (scene)",
        |b| {
            b.iter(|| {
                searcher
                    .search(black_box(frame.view()), template.view(), full)
                    .unwrap()
            })
        },
    );
    let mut map = Image::new(291, 221, 1, 0f32).unwrap();
    c.bench_function("mad_map_into full 291x221 MAD surface (no pruning)", |b| {
        b.iter(|| {
            mad_map_into(
                black_box(frame.view()),
                template.view(),
                full,
                &mut map.view_mut(),
            )
            .unwrap()
        })
    });
    let white = noise(320, 240, 1, 3);
    let tpl_noise = white.crop(Rect::new(201, 117, 30, 20)).unwrap().to_image();
    c.bench_function("mad_search 30x20 template over 320x240 (noise)", |b| {
        b.iter(|| mad_search(black_box(white.view()), tpl_noise.view(), full).unwrap())
    });
}

fn bench_histogram(c: &mut Criterion) {
    let frame = noise(320, 240, 3, 2);
    let window = Rect::new(100, 80, 40, 40);
    let mut h256 = RgbHistogram::new(256).unwrap();
    c.bench_function("RgbHistogram 3x256 of a 40x40 window", |b| {
        b.iter(|| h256.compute(black_box(frame.view()), window).unwrap())
    });
    let mut h16 = RgbHistogram::new(16).unwrap();
    c.bench_function("RgbHistogram 3x16 of a 40x40 window", |b| {
        b.iter(|| h16.compute(black_box(frame.view()), window).unwrap())
    });
    let reference = RgbHistogram::from_window(frame.view(), window, 256).unwrap();
    let other = RgbHistogram::from_window(frame.view(), Rect::new(10, 10, 40, 40), 256).unwrap();
    c.bench_function("L2 distance 3x256", |b| {
        b.iter(|| black_box(&other).l2_distance(&reference).unwrap())
    });
    let region = Rect::new(80, 60, 80, 80);
    c.bench_function(
        "histogram_search 40x40 over 80x80 region (3x256, sliding L2)",
        |b| {
            b.iter(|| {
                histogram_search(
                    black_box(frame.view()),
                    &reference,
                    40,
                    40,
                    region,
                    HistogramDistance::L2,
                )
                .unwrap()
            })
        },
    );
}

fn bench_skin_ifd(c: &mut Criterion) {
    let frame = noise(320, 240, 3, 4);
    let prev = noise(320, 240, 3, 5);
    let model = SkinModel::new(0.05, 0.4, SkinModel::PAPER_SIGMA).unwrap();
    let mut out = Image::new(320, 240, 1, 0f32).unwrap();
    c.bench_function("skin map 320x240 RGB", |b| {
        b.iter(|| {
            model
                .map_rgb_into(black_box(frame.view()), &mut out.view_mut())
                .unwrap()
        })
    });
    let g1 = rgb_to_gray(frame.view()).unwrap();
    let g0 = rgb_to_gray(prev.view()).unwrap();
    c.bench_function("IFD 320x240 gray u8", |b| {
        b.iter(|| {
            interframe_difference_into(black_box(g1.view()), g0.view(), &mut out.view_mut())
                .unwrap()
        })
    });
    c.bench_function("IFD 320x240 RGB u8 (luma)", |b| {
        b.iter(|| {
            interframe_difference_into(black_box(frame.view()), prev.view(), &mut out.view_mut())
                .unwrap()
        })
    });
    let ifd = out.clone();
    let planes = Frame::new().with_ifd(ifd.view());
    let cue = IfdCue::new(1e-12, 36).unwrap();
    let mut scratch = Scratch::new();
    let cand = Candidate::Window(Rect::new(100, 80, 40, 40));
    c.bench_function("IfdCue log-likelihood of a 40x40 window", |b| {
        b.iter(|| {
            cue.log_likelihood(&planes, black_box(&cand), &mut scratch)
                .unwrap()
        })
    });
}

criterion_group!(benches, bench_mad, bench_histogram, bench_skin_ifd);
criterion_main!(benches);
