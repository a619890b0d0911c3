//! An unscented Kalman filter with an angle in the state: a robot [x, y, heading] drives six
//! circles measuring range and bearing to a landmark. Heading and bearing cross +-pi every lap;
//! the model's `Angles` spaces wrap them. `cargo run --example ukf_angle`

use bayestrack::kalman::{Angles, Dynamics, Gaussian, Manifold, Measurement, Ukf};
use bayestrack::nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

fn wrap<const D: usize>(mut v: SVector<f64, D>, i: usize) -> SVector<f64, D> {
    v[i] = v[i].sin().atan2(v[i].cos()); // the angle v[i] into [-pi, pi]
    v
}
/// A unicycle at 1 m/s turning at 0.25 rad/s, time step 0.5 s; landmark at (10, 0).
struct Robot;
impl Dynamics<3> for Robot {
    fn propagate(&self, x: &SVector<f64, 3>) -> SVector<f64, 3> {
        let step = Vector3::new(0.5 * x[2].cos(), 0.5 * x[2].sin(), 0.125);
        wrap(x + step, 2)
    }
    fn process_noise(&self) -> SMatrix<f64, 3, 3> {
        Matrix3::from_diagonal(&Vector3::new(1e-3, 1e-3, 1e-4))
    }
    fn state_space(&self) -> impl Manifold<3> {
        Angles::new([false, false, true]) // the heading wraps
    }
}
impl Measurement<3, 2> for Robot {
    fn observe(&self, x: &SVector<f64, 3>) -> SVector<f64, 2> {
        let (dx, dy) = (10.0 - x[0], -x[1]);
        wrap(Vector2::new(dx.hypot(dy), dy.atan2(dx) - x[2]), 1)
    }
    fn measurement_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::from_diagonal(&Vector2::new(0.1 * 0.1, 0.05 * 0.05))
    }
    fn measurement_space(&self) -> impl Manifold<2> {
        Angles::new([false, true]) // the bearing wraps
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ukf = Ukf::new(1.0, 2.0, 0.0)?;
    let mut rng = bayestrack::particle::stream_rng(&[7]);
    let q = Gaussian::new(Vector3::zeros(), Robot.process_noise())?;
    let r = Gaussian::new(Vector2::zeros(), Robot.measurement_noise())?;
    let mut truth = Vector3::new(0.0, -4.0, 0.0);
    let mut belief = Gaussian::new(truth, Matrix3::identity() * 0.01)?;
    for _ in 0..300 {
        truth = Robot.propagate(&truth) + q.sample(&mut rng)?;
        let z = Robot.observe(&truth) + r.sample(&mut rng)?;
        let prior = ukf.predict(&belief, &Robot)?;
        belief = ukf.update(&prior, &Robot, Some(&z))?.posterior;
    }
    let e = wrap(belief.mean() - truth, 2);
    let (pos, heading) = (e.xy().norm(), e[2].abs());
    println!("after 300 steps: position error {pos:.3} m, heading error {heading:.4} rad");
    Ok(())
}
