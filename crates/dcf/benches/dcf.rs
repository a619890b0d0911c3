//! Criterion benchmarks of the correlation-filter kernels: the 2-D real
//! FFT round trip at 2,3,5-smooth and prime sizes (what the padding to
//! smooth sizes buys), the batched forward FFT of a filter's 31 feature
//! channels, fHOG of a search window and of a scale sample (the
//! scale filter computes 17-33 of them a frame), and the area sampling of
//! a patch from a frame.

use std::hint::black_box;

use bayestrack_dcf::features::Fhog;
use bayestrack_dcf::fft::{C32, Fft2};
use bayestrack_dcf::sample::PatchSampler;
use bayestrack_image::Image;
use criterion::{Criterion, criterion_group, criterion_main};

fn bench_fft(c: &mut Criterion) {
    let mut group = c.benchmark_group("fft2 forward+inverse (cells)");
    // 37 and 41 are primes; 36, 40, 48 their smooth neighbours
    for n in [36usize, 37, 40, 41, 48] {
        let mut f = Fft2::new(n, n).unwrap();
        let x: Vec<f32> = (0..n * n)
            .map(|i| ((i * 7919) % 101) as f32 / 101.0)
            .collect();
        let mut spec = vec![C32::default(); f.spectrum_len()];
        let mut back = vec![0.0; n * n];
        group.bench_function(format!("{n}x{n}"), |b| {
            b.iter(|| {
                f.forward(black_box(&x), &mut spec).unwrap();
                f.inverse(&mut spec, &mut back).unwrap();
                black_box(back[0])
            })
        });
    }
    group.finish();
    // a correlation filter's features: 31 fHOG channels of 16 x 40 cells
    // (even rows, zero first and last rows as after a cosine window) and
    // 31 of 15 x 24 (odd rows), transformed in one call
    let mut group = c.benchmark_group("fft2 forward_many 31 channels (cells)");
    for (w, h) in [(16usize, 40usize), (15, 24)] {
        let mut f = Fft2::new(w, h).unwrap();
        let x: Vec<f32> = (0..31 * w * h)
            .map(|i| {
                let y = (i / w) % h;
                if y == 0 || y == h - 1 {
                    0.0
                } else {
                    ((i * 7919) % 101) as f32 / 101.0
                }
            })
            .collect();
        let mut spec = vec![C32::default(); 31 * f.spectrum_len()];
        group.bench_function(format!("{w}x{h}"), |b| {
            b.iter(|| {
                f.forward_many(black_box(&x), &mut spec).unwrap();
                black_box(spec[0])
            })
        });
    }
    group.finish();
}

fn bench_hog(c: &mut Criterion) {
    // the default search window: 150^2 model pixels, about 38x38 cells
    let (w, h) = (152usize, 152usize);
    let patch: Vec<f32> = (0..w * h)
        .map(|i| (((i % w) * 13 + (i / w) * 7) % 255) as f32 / 255.0)
        .collect();
    let mut hog = Fhog::new(w, h, 4).unwrap();
    let mut out = vec![0.0; hog.len()];
    c.bench_function("fhog 152x152 px, 4 px cells", |b| {
        b.iter(|| {
            hog.compute(black_box(&patch), &mut out).unwrap();
            black_box(out[0])
        })
    });
}

fn bench_small_hog(c: &mut Criterion) {
    // a scale sample: the target shrunk to at most 512 pixels
    let (w, h) = (32usize, 16usize);
    let patch: Vec<f32> = (0..w * h)
        .map(|i| (((i % w) * 13 + (i / w) * 7) % 255) as f32 / 255.0)
        .collect();
    let mut hog = Fhog::new(w, h, 4).unwrap();
    let mut out = vec![0.0; hog.len()];
    c.bench_function("fhog 32x16 px, 4 px cells", |b| {
        b.iter(|| {
            hog.compute(black_box(&patch), &mut out).unwrap();
            black_box(out[0])
        })
    });
}

fn bench_sample(c: &mut Criterion) {
    // a 320x240 frame, a 152x152 patch shrunk from 1.37 times its size
    let frame = Image::from_fn(320, 240, |x, y| ((x * 7 + y * 13 + x * y) % 251) as u8).unwrap();
    let mut s = PatchSampler::new();
    s.load(frame.view()).unwrap();
    let mut out = vec![0.0f32; 152 * 152];
    c.bench_function("area sample 152x152 from 1.37x", |b| {
        b.iter(|| {
            s.sample(0, black_box(40.3), 10.7, 1.37, 1.37, &mut out, 152, 152)
                .unwrap();
            black_box(out[0])
        })
    });
}

criterion_group!(benches, bench_fft, bench_hog, bench_small_hog, bench_sample);
criterion_main!(benches);
