//! Criterion benchmarks of bayestrack-affine: exp/log, LWPR update and
//! predict (cross benchmark, 1296-dimensional features).

use std::hint::black_box;

use bayestrack_affine::{Affine2, AlgebraVector, Lwpr, LwprConfig, PoseConfig, PoseEstimator};
use bayestrack_image::Image;
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

fn pose_tuning(c: &mut Criterion) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let blobs: Vec<(f64, f64, f64, f64)> = (0..120)
        .map(|_| {
            (
                rng.random_range(0.0..160.0),
                rng.random_range(0.0..160.0),
                rng.random_range(3.0..9.0),
                rng.random_range(-1.0..1.0),
            )
        })
        .collect();
    let frame = Image::from_fn(160, 160, |x, y| {
        let mut v = 0.5;
        for &(cx, cy, s, a) in &blobs {
            let d2 = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
            v += 0.3 * a * (-d2 / (2.0 * s * s)).exp();
        }
        v as f32
    })
    .unwrap();
    let m_star = Affine2::translation(80.0, 80.0).unwrap();
    for pool in [3usize, 1] {
        let cfg = PoseConfig {
            pool,
            ..PoseConfig::default()
        };
        let mut pe = PoseEstimator::new(cfg, 40.0, 40.0).unwrap();
        let n = if pool == 1 { 300 } else { 1200 };
        pe.train(frame.view(), &m_star, n, &mut rng).unwrap();
        let m = m_star
            .compose(&Affine2::exp(&AlgebraVector::new(0.02, 0.0, 0.03, 0.0, 1.0, -1.0)).unwrap());
        let name = format!("pose_tune_step_{}feat", pe.feature_dim());
        c.bench_function(&name, |b| {
            b.iter(|| pe.tune_step(frame.view(), black_box(&m)).unwrap())
        });
    }
}

criterion_group!(benches, group, lwpr_cross, lwpr_1296, pose_tuning);
criterion_main!(benches);
