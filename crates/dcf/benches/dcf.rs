//! Criterion benchmarks of the correlation-filter kernels: the 2-D real
//! FFT round trip at 2,3,5-smooth and prime sizes (what the padding to
//! smooth sizes buys) and fHOG of a search window.

use std::hint::black_box;

use bayestrack_dcf::features::Fhog;
use bayestrack_dcf::fft::{C32, Fft2};
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

criterion_group!(benches, bench_fft, bench_hog);
criterion_main!(benches);
