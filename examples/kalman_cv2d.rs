//! A 2-D constant-velocity Kalman tracker on noisy positions; the mean NIS
//! of its updates checks that the filter is consistent.
//!
//! `cargo run --example kalman_cv2d`

use bayestrack::kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel};
use bayestrack::nalgebra::{Matrix4, Vector2, Vector4};
use bayestrack::rand::SeedableRng;
use bayestrack::rand_distr::{Distribution, Normal};
use bayestrack::rand_xoshiro::Xoshiro256PlusPlus;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dt = 0.1;
    // State [x, vx, y, vy]; white-noise acceleration of variance 0.2.
    let dynamics = LinearDynamics::<4>::constant_velocity(dt, 0.2, NoiseModel::Discrete)?;
    let sensor = LinearMeasurement::<4, 2>::position(0.5 * 0.5)?;
    let kf = Kf::default();

    let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
    let noise = Normal::new(0.0, 0.5)?;
    let mut belief = Gaussian::new(Vector4::zeros(), Matrix4::identity() * 10.0)?;
    let mut nis_sum = 0.0;
    for k in 1..=50 {
        let t = k as f64 * dt;
        let truth = Vector2::new(2.0 * t, 1.0 - 0.5 * t); // 2 m/s right, 0.5 m/s down
        let z = truth + Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng));
        let prior = kf.predict(&belief, &dynamics)?;
        let update = kf.update(&prior, &sensor, Some(&z))?;
        nis_sum += update.innovation.map_or(0.0, |i| i.nis);
        belief = update.posterior;
    }
    let x = belief.mean();
    println!(
        "position ({:.2}, {:.2}), velocity ({:.2}, {:.2})",
        x[0], x[2], x[1], x[3]
    );
    println!("mean NIS {:.2} (2 for a consistent filter)", nis_sum / 50.0);
    Ok(())
}
