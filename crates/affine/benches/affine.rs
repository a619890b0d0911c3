//! Criterion benchmarks of bayestrack-affine: exp/log, LWPR update and
//! predict (cross benchmark, 1296-dimensional features).

use std::hint::black_box;

use bayestrack_affine::{Affine2, AlgebraVector, Lwpr, LwprConfig};
use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn cross(x1: f64, x2: f64) -> f64 {
    let a = (-10.0 * x1 * x1).exp();
    let b = (-50.0 * x2 * x2).exp();
    let c = 1.25 * (-5.0 * (x1 * x1 + x2 * x2)).exp();
    a.max(b).max(c)
}

fn group(c: &mut Criterion) {
    let w = AlgebraVector::new(0.05, -0.02, 0.1, 0.03, 2.0, -1.0);
    let m = Affine2::exp(&w).unwrap();
    c.bench_function("aff2_exp", |b| b.iter(|| Affine2::exp(black_box(&w))));
    c.bench_function("aff2_log", |b| b.iter(|| black_box(&m).log()));
}

/// A model trained on the cross benchmark (20,000 samples) and a sample
/// stream for further updates.
fn trained_cross() -> (Lwpr, Vec<([f64; 2], f64)>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut cfg = LwprConfig::new(2, 1).init_d_spherical(50.0);
    cfg.init_alpha = 250.0;
    cfg.w_gen = 0.2;
    let mut model = Lwpr::new(cfg).unwrap();
    let draw = |rng: &mut Xoshiro256PlusPlus| {
        let x = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
        (x, cross(x[0], x[1]) + rng.random_range(-0.05..0.05))
    };
    for _ in 0..20_000 {
        let (x, y) = draw(&mut rng);
        model.update(&x, &[y]).unwrap();
    }
    let stream = (0..4096).map(|_| draw(&mut rng)).collect();
    (model, stream)
}

fn lwpr_cross(c: &mut Criterion) {
    let (model, stream) = trained_cross();
    let mut m = model.clone();
    let mut k = 0;
    let mut yp = [0.0];
    c.bench_function("lwpr_cross_update", |b| {
        b.iter(|| {
            let (x, y) = &stream[k % stream.len()];
            k += 1;
            m.update_into(x, &[*y], &mut yp).unwrap();
        })
    });
    let mut m = model;
    let mut y = [0.0];
    c.bench_function("lwpr_cross_predict", |b| {
        b.iter(|| {
            let (x, _) = &stream[k % stream.len()];
            k += 1;
            m.predict_into(x, 0.001, &mut y).unwrap();
        })
    });
}

fn lwpr_1296(c: &mut Criterion) {
    // 1296-dimensional inputs (36 x 36 patches), 6 outputs (an affine
    // increment), diagonal metric: y depends on a few directions.
    let n = 1296;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let mut cfg = LwprConfig::new(n, 6).init_d_spherical(1.0 / n as f64);
    cfg.w_gen = 0.2;
    let mut model = Lwpr::new(cfg).unwrap();
    let samples: Vec<(Vec<f64>, [f64; 6])> = (0..256)
        .map(|_| {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let y = [x[0], x[1], x[2] * 0.5, x[3], x[4] + x[5], x[6]];
            (x, y)
        })
        .collect();
    for (x, y) in samples.iter().take(200) {
        model.update(x, y).unwrap();
    }
    let mut k = 0;
    let mut yp = [0.0; 6];
    let mut m = model.clone();
    c.bench_function("lwpr_1296x6_update", |b| {
        b.iter(|| {
            let (x, y) = &samples[k % samples.len()];
            k += 1;
            m.update_into(x, y, &mut yp).unwrap();
        })
    });
    let mut m = model;
    c.bench_function("lwpr_1296x6_predict", |b| {
        b.iter(|| {
            let (x, _) = &samples[k % samples.len()];
            k += 1;
            m.predict_into(x, 0.001, &mut yp).unwrap();
        })
    });
}

criterion_group!(benches, group, lwpr_cross, lwpr_1296);
criterion_main!(benches);
