//! A bootstrap particle filter with a user model: a target at nearly constant velocity in the
//! plane, seen from the origin in range and bearing. It passes behind the sensor, so the bearing
//! crosses +-pi (the likelihood wraps it). `cargo run --release --example pf_range_bearing`

use bayestrack::nalgebra::{SVector, Vector2, Vector4};
use bayestrack::particle::{Bootstrap, Model, ParticleFilter, ParticleSet, Smc, stream_rng};
use bayestrack::rand::Rng;
use bayestrack::rand_distr::{Distribution, Normal, StandardNormal};

/// Measurement noise: range (m) and bearing (rad) standard deviations.
const SD: [f64; 2] = [0.5, 0.02];

/// State [x, y, vx, vy] in m and m/s, 1 s steps, white-noise acceleration of 0.05 m/s^2.
struct RangeBearing;

fn observe(x: &SVector<f64, 4>) -> Vector2<f64> {
    Vector2::new(x[0].hypot(x[1]), x[1].atan2(x[0]))
}

impl Model<4> for RangeBearing {
    type Observation = SVector<f64, 2>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 4>,
        rng: &mut R,
    ) -> SVector<f64, 4> {
        let a = Vector2::<f64>::from_fn(|_, _| StandardNormal.sample(rng)) * 0.05;
        x + Vector4::new(x[2] + 0.5 * a.x, x[3] + 0.5 * a.y, a.x, a.y)
    }
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 4>, z: &SVector<f64, 2>) -> f64 {
        let d = z - observe(x);
        let bearing = d[1].sin().atan2(d[1].cos()); // wrapped into [-pi, pi]
        -0.5 * ((d[0] / SD[0]).powi(2) + (bearing / SD[1]).powi(2))
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut rng, unit) = (stream_rng(&[7]), Normal::new(0.0, 1.0)?);
    let mut truth = Vector4::new(-20.0, 10.0, 0.3, -0.5); // behind the sensor at step 20
    let spread = Vector4::new(2.0, 2.0, 0.5, 0.5); // prior standard deviations
    let particles = (0..2000)
        .map(|_| truth + spread.map(|s| s * unit.sample(&mut rng)))
        .collect();
    let mut pf = Smc::new(ParticleFilter::default(), ParticleSet::new(particles)?, 1)?;
    let (mut sq_pf, mut sq_z) = (0.0, 0.0);
    for k in 1..=50 {
        truth = RangeBearing.sample_transition(k, &truth, &mut rng);
        let z = observe(&truth) + Vector2::from_fn(|i, _| SD[i] * unit.sample(&mut rng));
        pf.step(&Bootstrap(&RangeBearing), &z)?;
        sq_pf += (pf.set.mean().xy() - truth.xy()).norm_squared();
        sq_z += (Vector2::new(z[1].cos(), z[1].sin()) * z[0] - truth.xy()).norm_squared();
    }
    let rms = |sq: f64| (sq / 50.0).sqrt();
    let last = (pf.set.mean().xy() - truth.xy()).norm();
    println!("RMS position error: particle filter {:.2} m", rms(sq_pf));
    println!("                    measurement alone {:.2} m", rms(sq_z));
    println!("final position error {last:.2} m after {} steps", pf.k());
    Ok(())
}
