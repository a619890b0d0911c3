//! A mixed linear/nonlinear model of the shape of Schön, Gustafsson and
//! Nordlund's (2005) simulation example (sec. V): one nonlinear state
//! driven by the first of three linear states, a nonlinear and a linear
//! measurement.
//!
//! ```text
//! xn' = atan(xn) + xl_1 + wn
//! xl' = [1 0.3 0; 0 0.92 -0.3; 0 0.3 0.92] xl + wl
//! z   = [0.1 xn^2 sign(xn); 0] + [0 0 0; 1 -1 1] xl + e
//! wn ~ N(0, 0.01), wl ~ N(0, 0.01 I), e ~ N(0, 0.1 I)
//! ```
//!
//! Shared by the `rbpf_vs_bootstrap` example and the `rbpf` bench.

use bayestrack_particle::kalman::{Gaussian, LinearDynamics, LinearMeasurement};
use bayestrack_particle::nalgebra::{
    Matrix1, Matrix2, Matrix3, SMatrix, SVector, Vector1, Vector2, Vector3,
};
use bayestrack_particle::rand::Rng;
use bayestrack_particle::rand_distr::{Distribution, StandardNormal};
use bayestrack_particle::{ConditionallyLinear, Model, RbParticle};

pub const QN: f64 = 0.01;
pub const QL: f64 = 0.01;
pub const R: f64 = 0.1;

pub struct Mixed {
    pub nonlinear: LinearMeasurement<3, 1>,
    pub linear: LinearDynamics<3>,
    pub sensor: LinearMeasurement<3, 2>,
    pub a_l: Matrix3<f64>,
    pub c: SMatrix<f64, 2, 3>,
}

impl Mixed {
    pub fn new() -> Self {
        let a_l = Matrix3::new(1.0, 0.3, 0.0, 0.0, 0.92, -0.3, 0.0, 0.3, 0.92);
        let c = SMatrix::<f64, 2, 3>::new(0.0, 0.0, 0.0, 1.0, -1.0, 1.0);
        Self {
            nonlinear: LinearMeasurement::new(
                SMatrix::<f64, 1, 3>::new(1.0, 0.0, 0.0),
                Matrix1::new(QN),
            )
            .unwrap(),
            linear: LinearDynamics::new(a_l, Matrix3::identity() * QL).unwrap(),
            sensor: LinearMeasurement::new(c, Matrix2::identity() * R).unwrap(),
            a_l,
            c,
        }
    }

    fn h(xn: f64) -> Vector2<f64> {
        Vector2::new(0.1 * xn * xn * xn.signum(), 0.0)
    }

    /// Simulates `t` steps from `x_0 = 0`: states `[xn, xl]` and measurements.
    pub fn simulate<G: Rng>(
        &self,
        t: usize,
        rng: &mut G,
    ) -> (Vec<SVector<f64, 4>>, Vec<Vector2<f64>>) {
        let mut x = SVector::<f64, 4>::zeros();
        let mut xs = vec![];
        let mut zs = vec![];
        for k in 1..=t {
            x = self.sample_transition(k, &x, rng);
            let e = Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng)) * R.sqrt();
            let xl = Vector3::new(x[1], x[2], x[3]);
            zs.push(Self::h(x[0]) + self.c * xl + e);
            xs.push(x);
        }
        (xs, zs)
    }

    /// The Rao-Blackwellised filter's initial particles: `xn_0 = 0`,
    /// `xl_0 ~ N(0, 0.01 I)` (the truth starts at 0).
    pub fn rb_initial(&self, n: usize) -> Vec<RbParticle<1, 3>> {
        let xl = Gaussian::new(Vector3::zeros(), Matrix3::identity() * 0.01).unwrap();
        vec![
            RbParticle {
                xn: Vector1::zeros(),
                xl
            };
            n
        ]
    }

    /// The bootstrap filter's initial particles, the same prior sampled.
    pub fn initial<G: Rng>(&self, n: usize, rng: &mut G) -> Vec<SVector<f64, 4>> {
        (0..n)
            .map(|_| {
                let e = SVector::<f64, 3>::from_fn(|_, _| StandardNormal.sample(rng));
                SVector::<f64, 4>::new(0.0, 0.1 * e[0], 0.1 * e[1], 0.1 * e[2])
            })
            .collect()
    }
}

impl ConditionallyLinear<1, 3, 2> for Mixed {
    #[inline]
    fn nonlinear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<3, 1>) {
        (Vector1::new(xn[0].atan()), self.nonlinear)
    }
    #[inline]
    fn linear(&self, _k: usize, _xn: &Vector1<f64>) -> (Vector3<f64>, LinearDynamics<3>) {
        (Vector3::zeros(), self.linear)
    }
    #[inline]
    fn measurement(&self, _k: usize, xn: &Vector1<f64>) -> (Vector2<f64>, LinearMeasurement<3, 2>) {
        (Self::h(xn[0]), self.sensor)
    }
}

/// The same model on the full state `[xn, xl]`, for the bootstrap filter.
impl Model<4> for Mixed {
    type Observation = Vector2<f64>;
    #[inline(always)]
    fn sample_transition<G: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 4>,
        rng: &mut G,
    ) -> SVector<f64, 4> {
        let xl = Vector3::new(x[1], x[2], x[3]);
        let wn: f64 = StandardNormal.sample(rng);
        let wl = Vector3::new(
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
        );
        let xl2 = self.a_l * xl + wl * QL.sqrt();
        SVector::<f64, 4>::new(x[0].atan() + xl[0] + wn * QN.sqrt(), xl2[0], xl2[1], xl2[2])
    }
    #[inline(always)]
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 4>, z: &Vector2<f64>) -> f64 {
        let xl = Vector3::new(x[1], x[2], x[3]);
        let d = z - Self::h(x[0]) - self.c * xl;
        -0.5 * d.norm_squared() / R
    }
}
