//! The Rao-Blackwellised particle filter against a bootstrap particle
//! filter of the full state at equal wall time, on a mixed
//! linear/nonlinear model of the shape of Schön, Gustafsson and Nordlund's
//! (2005) example (see `shared/mixed.rs`): the bootstrap filter gets as
//! many more particles as the time an RBPF particle costs more.
//!
//! `cargo run --release -p bayestrack-particle --example rbpf_vs_bootstrap`

#[path = "shared/mixed.rs"]
mod mixed;

use std::time::Instant;

use bayestrack_particle::nalgebra::Vector3;
use bayestrack_particle::{Bootstrap, ParticleFilter, ParticleSet, RaoBlackwellised, stream_rng};
use mixed::Mixed;

const T: usize = 100;
const RUNS: u64 = 20;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = Mixed::new();
    let pf = ParticleFilter::default();
    let n_rb = 200;
    // calibrate: seconds per particle-step of each filter, both with
    // 1,000 particles (one chunk: the calling thread alone)
    let (_, zs) = model.simulate(T, &mut stream_rng(&[0]));
    let time = |f: &mut dyn FnMut() -> Result<(), Box<dyn std::error::Error>>| {
        let start = Instant::now();
        f().map(|()| start.elapsed().as_secs_f64())
    };
    let per_rb = time(&mut || {
        let mut set = ParticleSet::new(model.rb_initial(1000))?;
        for (k, z) in zs.iter().enumerate() {
            pf.step(&mut set, &RaoBlackwellised::new(&model), z, &[1, k as u64])?;
        }
        Ok(())
    })? / (1000 * T) as f64;
    let per_boot = time(&mut || {
        let mut set = ParticleSet::new(model.initial(1000, &mut stream_rng(&[2])))?;
        for (k, z) in zs.iter().enumerate() {
            pf.step(&mut set, &Bootstrap(&model), z, &[3, k as u64])?;
        }
        Ok(())
    })? / (1000 * T) as f64;
    let n_boot = ((n_rb as f64) * per_rb / per_boot).round() as usize;
    println!(
        "per particle-step: RBPF {:.0} ns, bootstrap {:.0} ns ({:.1}x); \
         at equal time: RBPF N = {n_rb}, bootstrap N = {n_boot}",
        per_rb * 1e9,
        per_boot * 1e9,
        per_rb / per_boot
    );
    let (mut se_rb, mut se_boot) = ([0.0; 2], [0.0; 2]);
    let (mut t_rb, mut t_boot) = (0.0, 0.0);
    for run in 0..RUNS {
        let (xs, zs) = model.simulate(T, &mut stream_rng(&[10, run]));
        let mut rb = ParticleSet::new(model.rb_initial(n_rb))?;
        let mut boot = ParticleSet::new(model.initial(n_boot, &mut stream_rng(&[11, run])))?;
        for (k, (x, z)) in xs.iter().zip(&zs).enumerate() {
            let start = Instant::now();
            let r = pf.step(
                &mut rb,
                &RaoBlackwellised::new(&model),
                z,
                &[12, run, k as u64],
            )?;
            let (xl, _) = rb.linear_moments();
            t_rb += start.elapsed().as_secs_f64();
            let start = Instant::now();
            let b = pf.step(&mut boot, &Bootstrap(&model), z, &[13, run, k as u64])?;
            t_boot += start.elapsed().as_secs_f64();
            let truth_l = Vector3::new(x[1], x[2], x[3]);
            se_rb[0] += (r.mean[0] - x[0]).powi(2);
            se_rb[1] += (xl - truth_l).norm_squared();
            se_boot[0] += (b.mean[0] - x[0]).powi(2);
            se_boot[1] += (Vector3::new(b.mean[1], b.mean[2], b.mean[3]) - truth_l).norm_squared();
        }
    }
    let steps = (RUNS as usize * T) as f64;
    let rms = |s: f64| (s / steps).sqrt();
    println!("over {RUNS} runs of {T} steps:");
    println!(
        "  RBPF      (N = {n_rb:>5}): RMS error xn {:.4}, xl {:.4}; {:.2} s",
        rms(se_rb[0]),
        rms(se_rb[1]),
        t_rb
    );
    println!(
        "  bootstrap (N = {n_boot:>5}): RMS error xn {:.4}, xl {:.4}; {:.2} s",
        rms(se_boot[0]),
        rms(se_boot[1]),
        t_boot
    );
    Ok(())
}
