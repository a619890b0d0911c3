//! Criterion benchmark of the Rao-Blackwellised particle filter's
//! per-particle cost, against the bootstrap filter of the full state as
//! the reference, on the mixed model of `examples/shared/mixed.rs` (one
//! nonlinear state, three linear, two measurements): one step of 1,000
//! particles (one chunk, the calling thread), systematic resampling every
//! step; throughput is particles, so the time per element is the cost of a
//! particle-step. No Rust peer has a Rao-Blackwellised filter.
#![allow(missing_docs)]

#[path = "../examples/shared/mixed.rs"]
#[allow(dead_code)]
mod mixed;

use std::hint::black_box;

use bayestrack_particle::{Bootstrap, ParticleFilter, ParticleSet, RaoBlackwellised, stream_rng};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mixed::Mixed;

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
