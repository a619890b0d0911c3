//! Criterion benchmarks for bayestrack-appearance (single thread).

use std::hint::black_box;

use bayestrack_appearance::{
    Candidate, Cue, Frame, HistogramDistance, IfdCue, MadSearch, RgbHistogram, Scratch, SkinModel,
    histogram_search, interframe_difference_into, mad_map_into, mad_search,
};
use bayestrack_image::{Image, Rect, SadTemplate, SimdLevel, rgb_to_gray};
use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};

use bayestrack_testkit::noise;

/// Two consecutive frames of a real sequence (`../shared/data/sequences`)
/// and the 30x20 template cut from the first, at the target (a tracker's
/// case: the template comes from the previous frame). Falls back to a
/// rendered pair (the scene moved by (3, 2) pixels, fresh noise) when the
/// data folder is absent; the label says which.
fn template_pair(rgb: bool) -> (String, Image<u8>, Image<u8>, Image<u8>) {
    let root =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sequences");
    // 0-based top-left of the template: inside the first ground-truth box.
    let (seq, f0, f1, x, y) = if rgb {
        ("Couple", "img/0001.jpg", "img/0002.jpg", 48, 67)
    } else {
        ("David", "img/img00001.png", "img/img00002.png", 143, 95)
    };
    let read = |f: &str| {
        let p = root.join(seq).join(f);
        if rgb {
            bayestrack_image::read_frame_rgb(p)
        } else {
            bayestrack_image::read_frame_gray(p)
        }
    };
    let (label, a, b) = match (read(f0), read(f1)) {
        (Ok(a), Ok(b)) => (format!("{seq} frames 1->2"), a, b),
        _ => {
            let ch = if rgb { 3 } else { 1 };
            let a = rendered(0, 0, ch, 1);
            let b = rendered(3, 2, ch, 2);
            ("rendered pair (no ../shared data)".to_string(), a, b)
        }
    };
    let template = a.crop(Rect::new(x, y, 30, 20)).unwrap().to_image();
    (label, a, b, template)
}

/// A smooth scene (sum of ramps plus noise) shifted by `(dx, dy)`, `ch`
/// channels: closer to a real frame than white noise.
fn rendered(dx: usize, dy: usize, ch: usize, seed: u32) -> Image<u8> {
    let n = noise(320, 240, ch, seed);
    let mut img = Image::new(320, 240, ch, 0u8).unwrap();
    for y in 0..240 {
        for x in 0..320 {
            for c in 0..ch {
                let (sx, sy) = (x as f32 - dx as f32, y as f32 - dy as f32);
                let base = (sx * 0.5 + (sy * 0.07).sin() * 40.0 + 60.0 + 30.0 * c as f32) as u32;
                let v = (base + u32::from(n.get(x, y, c).unwrap()) / 8) % 256;
                img.set(x, y, c, v as u8);
            }
        }
    }
    img
}

/// `BAYESTRACK_SIMD=scalar|sse2|avx2|avx512` caps the kernels' level (to
/// time the AVX2 paths on a machine with AVX-512; unset: the best level).
fn simd_cap() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(simd_cap_once);
}

fn simd_cap_once() {
    let level = bayestrack_image::simd::cap_from_env().unwrap_or_else(|e| panic!("{e}"));
    if let Some(level) = level {
        eprintln!(
            "kernels capped at {level:?}: running at {:?}",
            SimdLevel::detect()
        );
    }
}

fn bench_mad(c: &mut Criterion) {
    simd_cap();
    // Flat sampling (every sample the same number of calls, about 20 ms of
    // them), as tools/opencv_bench.py times OpenCV: samples of equal length
    // on both sides take the same share of a loaded machine's preemptions.
    let mut g = c.benchmark_group("mad");
    g.sampling_mode(SamplingMode::Flat);
    let full = Rect::new(0, 0, 320, 240);
    let mut searcher = MadSearch::new();
    let mut map = Image::new(291, 221, 1, 0f32).unwrap();
    for rgb in [false, true] {
        let (label, first, next, template) = template_pair(rgb);
        let kind = if rgb { "RGB" } else { "gray" };
        g.bench_function(
            format!("mad_search {kind} 30x20 over 320x240, next-frame template ({label})"),
            |b| b.iter(|| mad_search(black_box(next.view()), template.view(), full).unwrap()),
        );
        g.bench_function(
            format!("MadSearch (reused) {kind} 30x20 over 320x240, next-frame template ({label})"),
            |b| {
                b.iter(|| {
                    searcher
                        .search(black_box(next.view()), template.view(), full)
                        .unwrap()
                })
            },
        );
        g.bench_function(
            format!(
                "mad_search {kind} 30x20 over 320x240, SAME-frame template ({label}, exact match)"
            ),
            |b| b.iter(|| mad_search(black_box(first.view()), template.view(), full).unwrap()),
        );
        g.bench_function(
            format!("mad_map_into {kind} full 291x221 MAD surface ({label})"),
            |b| {
                b.iter(|| {
                    mad_map_into(
                        black_box(next.view()),
                        template.view(),
                        full,
                        &mut map.view_mut(),
                    )
                    .unwrap()
                })
            },
        );
        if !rgb {
            // The surface's SAD kernel alone (integer sums, no scaling to
            // MADs), row by row as mad_map_into runs it: the rest of the
            // surface's time is the scaling and the calls around it.
            let mut sad = SadTemplate::new(SimdLevel::detect());
            sad.set(template.view());
            let mut sums = vec![0u32; 291];
            g.bench_function(
                format!(
                    "sad_windows {kind} 30x20, 221 rows of 291 windows: the surface's kernel \
                     alone ({label})"
                ),
                |b| {
                    b.iter(|| {
                        for y in 0..221 {
                            sad.sad_windows(black_box(next.view()), 0, y, &mut sums);
                        }
                    })
                },
            );
        }
    }
    let white = noise(320, 240, 1, 3);
    let tpl_noise = white.crop(Rect::new(201, 117, 30, 20)).unwrap().to_image();
    g.bench_function(
        "mad_search gray 30x20 over 320x240, SAME-frame template (white noise)",
        |b| b.iter(|| mad_search(black_box(white.view()), tpl_noise.view(), full).unwrap()),
    );
    g.finish();
}

fn bench_histogram(c: &mut Criterion) {
    simd_cap();
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
    simd_cap();
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
