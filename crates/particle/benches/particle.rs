//! Criterion benchmark of the SPEC section 5 particle anchor: a bootstrap
//! particle filter on the `hikpf` model (Gamma(3, rate 2) process noise,
//! x^2/5 measurement with variance 1e-5), N = 10,000, systematic resampling
//! at every step, reported per step (divide by N for ns per particle-step).
//! smelly 0.2's particle filter runs the same model in the same run.
//!
//! The process noise is drawn as an Erlang variable, `(E1 + E2 + E3) / 2`
//! with `E ~ Exp(1)` (rand_distr's ziggurat): exactly Gamma(3, scale 1/2),
//! and cheaper than `rand_distr::Gamma` (Marsaglia-Tsang, 11-18 ns a draw).
//! The sampler is the model's, not the filter's: both filters use this one,
//! so the comparison measures the filters. The model's methods are
//! `#[inline(always)]` so that they inline into both filters' loops (LLVM
//! already inlines smelly's closures; our `sample_transition` was left out of
//! line, costing about a third more time, see the trait's docs).
//!
//! `two_independent_1_thread_filters` runs two separate 1-thread filters at
//! once, one per core, with no synchronisation between them: the machine's
//! own ceiling for two threads, against which `bayestrack_2_thread` is read
//! (the time is per particle-step of both filters together).
#![allow(missing_docs)]

use std::hint::black_box;
use std::time::Instant;

use bayestrack_particle::{
    Bootstrap, Model, ParticleFilter, ParticleSet, ResamplePolicy, Resampling, TransitionDensity,
    stream_rng,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Const, DMatrix, Dyn, OMatrix, SVector, Vector1};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Exp1};

const N: usize = 10_000;
const SIGMA: f64 = 1e-5;

struct Demo {
    drift: f64,
}

impl Demo {
    fn at(t: usize) -> Self {
        Self {
            drift: 1.0 + (0.04 * std::f64::consts::PI * t as f64).sin(),
        }
    }
}

/// Gamma(3, scale 1/2) noise: the sum of three unit exponentials, halved.
#[inline(always)]
fn gamma_noise<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let e1: f64 = Exp1.sample(rng);
    let e2: f64 = Exp1.sample(rng);
    let e3: f64 = Exp1.sample(rng);
    0.5 * (e1 + e2 + e3)
}

impl Model<1> for Demo {
    type Observation = SVector<f64, 1>;
    #[inline(always)]
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        Vector1::new(self.drift + 0.5 * x[0] + gamma_noise(rng))
    }
    #[inline(always)]
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 1>, z: &SVector<f64, 1>) -> f64 {
        let e = z[0] - 0.2 * x[0] * x[0];
        -0.5 * e * e / SIGMA
    }
}

impl TransitionDensity<1> for Demo {
    fn log_transition(&self, _k: usize, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> f64 {
        unreachable!("the bootstrap proposal never evaluates the prior")
    }
}

/// A measurement sequence from the model.
fn measurements() -> Vec<f64> {
    let mut rng = stream_rng(&[99]);
    let mut x = 1.0;
    (1..=60)
        .map(|t| {
            let m = Demo::at(t);
            x = m.drift + 0.5 * x + gamma_noise(&mut rng);
            0.2 * x * x
        })
        .collect()
}

fn bench_bootstrap(c: &mut Criterion) {
    let zs = measurements();
    let mut group = c.benchmark_group("bootstrap_pf_hikpf_n10000_step");
    group.throughput(Throughput::Elements(N as u64));
    let pf = ParticleFilter {
        resampling: Resampling::Systematic,
        policy: ResamplePolicy::Always,
        ..ParticleFilter::default()
    };
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        group.bench_function(format!("bayestrack_{threads}_thread"), |b| {
            pool.install(|| {
                let mut set = ParticleSet::new(vec![Vector1::new(1.0); N]).unwrap();
                let mut k = 0u64;
                b.iter(|| {
                    let t = (k % 59) as usize + 1;
                    let m = Demo::at(t + 1);
                    let r = pf
                        .step(&mut set, &Bootstrap(&m), &Vector1::new(zs[t]), &[k])
                        .unwrap();
                    black_box(r);
                    k += 1;
                })
            })
        });
    }

    group.bench_function("two_independent_1_thread_filters", |b| {
        let pools: Vec<_> = (0..2)
            .map(|_| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .unwrap()
            })
            .collect();
        let mut sets: Vec<_> = (0..2)
            .map(|_| ParticleSet::new(vec![Vector1::new(1.0); N]).unwrap())
            .collect();
        let mut k0 = 0u64;
        b.iter_custom(|iters| {
            // each filter does half the steps: the time is per particle-step
            // of the pair (thread start-up is amortised over the steps)
            let steps = iters.div_ceil(2);
            let start = Instant::now();
            std::thread::scope(|scope| {
                for (i, (pool, set)) in pools.iter().zip(sets.iter_mut()).enumerate() {
                    let (pf, zs) = (&pf, &zs);
                    scope.spawn(move || {
                        pool.install(|| {
                            for k in k0..k0 + steps {
                                let t = (k % 59) as usize + 1;
                                let m = Demo::at(t + 1);
                                let key = [i as u64, k];
                                let z = Vector1::new(zs[t]);
                                black_box(pf.step(set, &Bootstrap(&m), &z, &key).unwrap());
                            }
                        })
                    });
                }
            });
            k0 += steps;
            start.elapsed()
        })
    });

    group.bench_function("smelly", |b| {
        let particles: OMatrix<f64, Const<1>, Dyn> = DMatrix::from_element(1, N, 1.0)
            .fixed_rows::<1>(0)
            .into_owned();
        let mut f = smelly::ParticleFilter::<f64, Const<1>, Dyn>::new(particles).unwrap();
        let mut rng = stream_rng(&[5]);
        let mut k = 0usize;
        b.iter(|| {
            let t = k % 59 + 1;
            let m = Demo::at(t + 1);
            let z = zs[t];
            f.predict(|x, out| out[0] = m.drift + 0.5 * x[0] + gamma_noise(&mut rng))
                .unwrap();
            f.update_log_likelihood(|x| {
                let e = z - 0.2 * x[0] * x[0];
                -0.5 * e * e / SIGMA
            })
            .unwrap();
            let u: f64 = rng.random();
            f.resample(u).unwrap();
            k += 1;
        })
    });
    group.finish();
}

criterion_group!(benches, bench_bootstrap);
criterion_main!(benches);
