//! Criterion benchmarks of bayestrack-affine: exp/log, LWPR update and
//! predict (cross benchmark, 1296-dimensional features), and one step of the
//! LWPR pose estimator.
//!
//! Instruction counts: `AFFINE_BENCH_PROFILE=<case> AFFINE_BENCH_CALLS=<n>`
//! runs `n` calls of one case (`lwpr_1296x6_update`, `lwpr_1296x6_predict`,
//! `lwpr_1296x6_predict_trusted`, `pose_tune_step_144feat`,
//! `pose_tune_step_1296feat`) outside criterion, through the never-inlined
//! `profiled_*` functions, so that
//! `valgrind --tool=callgrind --toggle-collect='*profiled_*' <bench binary>`
//! counts the calls alone (setup excluded); divide by `n`.

use std::hint::black_box;

use bayestrack_affine::{
    Affine2, AffineGroup, AlgebraVector, Lwpr, LwprConfig, PoseConfig, PoseEstimator,
};
use bayestrack_image::Image;
use criterion::{BatchSize, Criterion};
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

/// Samples of 1296-dimensional inputs (36 x 36 patches) with 6 outputs (an
/// affine increment) that depend on a few directions.
type Samples1296 = Vec<(Vec<f64>, [f64; 6])>;

/// A diagonal-metric model of 1296 inputs and 6 outputs trained on the
/// first `n_train` of the returned samples (drawn with `seed`), and
/// `n_train + 256` samples in all. A receptive field becomes trustworthy
/// (and predicts) once its forgetting-weighted sample count exceeds 2N =
/// 2592: with the default initial forgetting factor (`trusted` false) that
/// count stays near 1 / (1 - 0.999) = 1000 for thousands of samples, so 200
/// samples give a model whose predictions only compute activations; with
/// no forgetting at the start (`trusted`: initial factor = final factor
/// 0.99999) 3000 samples make every RF trustworthy.
fn trained_1296(seed: u64, n_train: usize, trusted: bool) -> (Lwpr, Samples1296) {
    let n = 1296;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut cfg = LwprConfig::new(n, 6).init_d_spherical(1.0 / n as f64);
    cfg.w_gen = 0.2;
    if trusted {
        cfg.init_lambda = cfg.final_lambda;
    }
    let mut model = Lwpr::new(cfg).unwrap();
    let samples: Samples1296 = (0..n_train + 256)
        .map(|_| {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let y = [x[0], x[1], x[2] * 0.5, x[3], x[4] + x[5], x[6]];
            (x, y)
        })
        .collect();
    for (x, y) in samples.iter().take(n_train) {
        model.update(x, y).unwrap();
    }
    (model, samples)
}

/// The training length of `lwpr_1296x6_predict_trusted`.
const TRUSTED_TRAINING: usize = 3000;

fn lwpr_1296(c: &mut Criterion) {
    let (model, samples) = trained_1296(2, 200, false);
    let mut k = 0;
    let mut yp = [0.0; 6];
    // Every iteration updates a fresh copy of the trained model (the copy is
    // not timed), so the cost does not drift with the model's growth.
    c.bench_function("lwpr_1296x6_update", |b| {
        b.iter_batched_ref(
            || model.clone(),
            |m| {
                let (x, y) = &samples[k % samples.len()];
                k += 1;
                m.update_into(x, y, &mut yp).unwrap();
            },
            BatchSize::SmallInput,
        )
    });
    let mut m = model;
    c.bench_function("lwpr_1296x6_predict", |b| {
        b.iter(|| {
            let (x, _) = &samples[k % samples.len()];
            k += 1;
            m.predict_into(x, 0.001, &mut yp).unwrap();
        })
    });
    let (mut m, samples) = trained_1296(5, TRUSTED_TRAINING, true);
    let test = &samples[TRUSTED_TRAINING..];
    c.bench_function("lwpr_1296x6_predict_trusted", |b| {
        b.iter(|| {
            let (x, _) = &test[k % test.len()];
            k += 1;
            m.predict_into(x, 0.001, &mut yp).unwrap();
        })
    });
}

/// A 160 x 160 texture of Gaussian blobs, a pose estimator (pooling `pool`)
/// trained around its centre, and a perturbed pose to tune.
fn pose_setup(pool: usize) -> (Image<f32>, PoseEstimator, Affine2) {
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
    let m_star = Affine2::translation(80.0, 80.0);
    // The 1296-feature estimator is trained after the 144-feature one from
    // the same generator (the order of the original bench).
    if pool == 1 {
        let _ = pose_estimator(&frame, &m_star, 3, &mut rng);
    }
    let pe = pose_estimator(&frame, &m_star, pool, &mut rng);
    let m = m_star
        .compose(&Affine2::exp(&AlgebraVector::new(0.02, 0.0, 0.03, 0.0, 1.0, -1.0)).unwrap());
    (frame, pe, m)
}

fn pose_estimator(
    frame: &Image<f32>,
    m_star: &Affine2,
    pool: usize,
    rng: &mut Xoshiro256PlusPlus,
) -> PoseEstimator {
    let cfg = PoseConfig {
        pool,
        ..PoseConfig::default()
    };
    let mut pe = PoseEstimator::new(cfg, 40.0, 40.0).unwrap();
    let n = if pool == 1 { 300 } else { 1200 };
    pe.train(frame.view(), m_star, n, rng).unwrap();
    pe
}

fn pose_tuning(c: &mut Criterion) {
    for pool in [3usize, 1] {
        let (frame, mut pe, m) = pose_setup(pool);
        let name = format!("pose_tune_step_{}feat", pe.feature_dim());
        c.bench_function(&name, |b| {
            b.iter(|| pe.tune_step(frame.view(), black_box(&m)).unwrap())
        });
    }
}

#[inline(never)]
fn profiled_update(m: &mut Lwpr, x: &[f64], y: &[f64], yp: &mut [f64]) {
    m.update_into(x, y, yp).unwrap();
}

#[inline(never)]
fn profiled_predict(m: &mut Lwpr, x: &[f64], yp: &mut [f64]) {
    m.predict_into(x, 0.001, yp).unwrap();
}

#[inline(never)]
fn profiled_tune_step(pe: &mut PoseEstimator, frame: &Image<f32>, m: &Affine2) -> Affine2 {
    pe.tune_step(frame.view(), m).unwrap()
}

/// Runs `calls` calls of one case outside criterion (see the module docs).
fn profile(case: &str, calls: usize) {
    let mut yp = [0.0; 6];
    match case {
        "lwpr_1296x6_update" => {
            let (model, samples) = trained_1296(2, 200, false);
            for k in 0..calls {
                let mut m = model.clone();
                let (x, y) = &samples[k % samples.len()];
                profiled_update(&mut m, x, y, &mut yp);
                black_box(&yp);
            }
        }
        "lwpr_1296x6_predict" | "lwpr_1296x6_predict_trusted" => {
            let n_train = if case == "lwpr_1296x6_predict" {
                200
            } else {
                TRUSTED_TRAINING
            };
            let trusted = n_train != 200;
            let (mut m, samples) = trained_1296(if trusted { 5 } else { 2 }, n_train, trusted);
            let test = &samples[n_train..];
            for k in 0..calls {
                profiled_predict(&mut m, &test[k % test.len()].0, &mut yp);
                black_box(&yp);
            }
        }
        "pose_tune_step_144feat" | "pose_tune_step_1296feat" => {
            let pool = if case == "pose_tune_step_144feat" {
                3
            } else {
                1
            };
            let (frame, mut pe, m) = pose_setup(pool);
            for _ in 0..calls {
                black_box(profiled_tune_step(&mut pe, &frame, black_box(&m)));
            }
        }
        other => panic!("unknown AFFINE_BENCH_PROFILE case {other}"),
    }
}

fn main() {
    if let Ok(case) = std::env::var("AFFINE_BENCH_PROFILE") {
        let calls = std::env::var("AFFINE_BENCH_CALLS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(100);
        profile(&case, calls);
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    group(&mut c);
    lwpr_cross(&mut c);
    lwpr_1296(&mut c);
    pose_tuning(&mut c);
    c.final_summary();
}
