//! Criterion benchmark of the Rao-Blackwellised particle filter's
//! per-particle cost, against the bootstrap filter of the full state as
//! the reference, on the mixed model of `examples/shared/mixed.rs` (one
//! nonlinear state, three linear, two measurements): one step of 1,000
//! particles (one chunk, the calling thread), systematic resampling every
//! step; throughput is particles, so the time per element is the cost of a
//! particle-step. Also the RBPF with correlated process noise
//! (`cross_covariance`) and the auxiliary particle filter (first stage at
//! the transition's mean) on the full state. No Rust peer has a
//! Rao-Blackwellised or auxiliary particle filter.
#![allow(missing_docs)]

#[path = "../examples/shared/mixed.rs"]
#[allow(dead_code)]
mod mixed;

use std::hint::black_box;

use bayestrack_particle::kalman::{LinearDynamics, LinearMeasurement};
use bayestrack_particle::nalgebra::{SMatrix, SVector, Vector1, Vector2, Vector3};
use bayestrack_particle::{
    Auxiliary, AuxiliaryFilter, Bootstrap, ConditionallyLinear, ParticleFilter, ParticleSet,
    RaoBlackwellised, stream_rng,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mixed::{Mixed, QL, QN};

/// [`Mixed`] with the nonlinear noise correlated 0.5 with the first
/// linear state's noise.
struct Correlated<'a>(&'a Mixed);

impl ConditionallyLinear<1, 3, 2> for Correlated<'_> {
    #[inline]
    fn nonlinear(&self, k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<3, 1>) {
        self.0.nonlinear(k, xn)
    }
    #[inline]
    fn linear(&self, k: usize, xn: &Vector1<f64>) -> (Vector3<f64>, LinearDynamics<3>) {
        self.0.linear(k, xn)
    }
    #[inline]
    fn measurement(&self, k: usize, xn: &Vector1<f64>) -> (Vector2<f64>, LinearMeasurement<3, 2>) {
        self.0.measurement(k, xn)
    }
    #[inline]
    fn cross_covariance(&self, _k: usize, _xn: &Vector1<f64>) -> Option<SMatrix<f64, 3, 1>> {
        Some(SMatrix::<f64, 3, 1>::new(0.5 * (QN * QL).sqrt(), 0.0, 0.0))
    }
}

/// The APF's look-ahead on the full state: the transition's mean.
impl Auxiliary<4> for Mixed {
    #[inline]
    fn point(&self, _k: usize, x: &SVector<f64, 4>) -> SVector<f64, 4> {
        let xl = self.a_l * Vector3::new(x[1], x[2], x[3]);
        SVector::<f64, 4>::new(x[0].atan() + x[1], xl[0], xl[1], xl[2])
    }
}

const N: usize = 1000;

fn bench_rbpf(c: &mut Criterion) {
    let model = Mixed::new();
    let (_, zs) = model.simulate(50, &mut stream_rng(&[0]));
    let pf = ParticleFilter::default();
    let mut group = c.benchmark_group("rbpf_mixed_n1000_step");
    group.throughput(Throughput::Elements(N as u64));
    group.bench_function("rbpf_1_plus_3_states", |b| {
        let mut set = ParticleSet::new(model.rb_initial(N)).unwrap();
        let mut k = 0u64;
        b.iter(|| {
            let z = &zs[(k % 50) as usize];
            k += 1;
            black_box(
                pf.step(&mut set, &RaoBlackwellised::new(&model), z, &[1, k])
                    .unwrap(),
            )
        })
    });
    group.bench_function("rbpf_1_plus_3_states_correlated", |b| {
        let corr = Correlated(&model);
        let mut set = ParticleSet::new(model.rb_initial(N)).unwrap();
        let mut k = 0u64;
        b.iter(|| {
            let z = &zs[(k % 50) as usize];
            k += 1;
            black_box(
                pf.step(&mut set, &RaoBlackwellised::new(&corr), z, &[4, k])
                    .unwrap(),
            )
        })
    });
    group.bench_function("apf_4_states", |b| {
        let apf = AuxiliaryFilter::default();
        let mut set = ParticleSet::new(model.initial(N, &mut stream_rng(&[5]))).unwrap();
        let mut k = 0u64;
        b.iter(|| {
            let z = &zs[(k % 50) as usize];
            k += 1;
            black_box(apf.step(&mut set, &model, z, &[6, k]).unwrap())
        })
    });
    group.bench_function("bootstrap_4_states", |b| {
        let mut set = ParticleSet::new(model.initial(N, &mut stream_rng(&[2]))).unwrap();
        let mut k = 0u64;
        b.iter(|| {
            let z = &zs[(k % 50) as usize];
            k += 1;
            black_box(pf.step(&mut set, &Bootstrap(&model), z, &[3, k]).unwrap())
        })
    });
    group.finish();
}

criterion_group!(benches, bench_rbpf);
criterion_main!(benches);
