//! Models shared by the integration tests.
#![allow(dead_code, missing_docs)]

use bayestrack_kalman::{
    Dynamics, DynamicsJacobian, LinearDynamics, LinearMeasurement, Measurement, MeasurementJacobian,
};
use nalgebra::{Matrix2, Matrix2x4, Matrix4, SMatrix, SVector};

/// 2-D constant velocity `[x, y, vx, vy]`, white-noise acceleration with
/// spectral density `q`, positions measured with variance `r`.
pub fn constant_velocity(dt: f64, q: f64, r: f64) -> (LinearDynamics<4>, LinearMeasurement<4, 2>) {
    let mut f = Matrix4::identity();
    f[(0, 2)] = dt;
    f[(1, 3)] = dt;
    let (a, b, c) = (dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt);
    let q = Matrix4::new(
        a, 0.0, b, 0.0, //
        0.0, a, 0.0, b, //
        b, 0.0, c, 0.0, //
        0.0, b, 0.0, c,
    ) * q;
    let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
    (
        LinearDynamics::new(f, q).unwrap(),
        LinearMeasurement::new(h, Matrix2::identity() * r).unwrap(),
    )
}

/// A nonlinear model: constant turn rate and velocity `[px, py, v, heading,
/// turn rate]`, range and bearing measured.
pub struct Turn {
    pub dt: f64,
    pub q: SMatrix<f64, 5, 5>,
    pub r: SMatrix<f64, 2, 2>,
}

impl Turn {
    pub fn new() -> Self {
        Self {
            dt: 0.5,
            q: SMatrix::from_diagonal(&SVector::from([0.01, 0.01, 0.05, 0.001, 0.002])),
            r: SMatrix::from_diagonal(&SVector::from([0.25, 1e-4])),
        }
    }
}

impl Dynamics<5> for Turn {
    fn propagate(&self, x: &SVector<f64, 5>) -> SVector<f64, 5> {
        let dt = self.dt;
        SVector::from([
            x[0] + dt * x[2] * x[3].cos(),
            x[1] + dt * x[2] * x[3].sin(),
            x[2],
            x[3] + dt * x[4],
            x[4],
        ])
    }
    fn process_noise(&self) -> SMatrix<f64, 5, 5> {
        self.q
    }
}

impl DynamicsJacobian<5> for Turn {
    fn jacobian(&self, x: &SVector<f64, 5>) -> SMatrix<f64, 5, 5> {
        let dt = self.dt;
        let mut j = SMatrix::<f64, 5, 5>::identity();
        j[(0, 2)] = dt * x[3].cos();
        j[(0, 3)] = -dt * x[2] * x[3].sin();
        j[(1, 2)] = dt * x[3].sin();
        j[(1, 3)] = dt * x[2] * x[3].cos();
        j[(3, 4)] = dt;
        j
    }
}

impl Measurement<5, 2> for Turn {
    fn observe(&self, x: &SVector<f64, 5>) -> SVector<f64, 2> {
        SVector::from([x[0].hypot(x[1]), x[1].atan2(x[0])])
    }
    fn measurement_noise(&self) -> SMatrix<f64, 2, 2> {
        self.r
    }
}

impl MeasurementJacobian<5, 2> for Turn {
    fn jacobian(&self, x: &SVector<f64, 5>) -> SMatrix<f64, 2, 5> {
        let d2 = x[0] * x[0] + x[1] * x[1];
        let d = d2.sqrt();
        let mut j = SMatrix::<f64, 2, 5>::zeros();
        j[(0, 0)] = x[0] / d;
        j[(0, 1)] = x[1] / d;
        j[(1, 0)] = -x[1] / d2;
        j[(1, 1)] = x[0] / d2;
        j
    }
}

pub fn assert_close<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    b: &SMatrix<f64, R, C>,
    tol: f64,
    what: &str,
) {
    let err = (a - b).amax();
    assert!(
        err <= tol * b.amax().max(1.0),
        "{what}: differs by {err:e}\n{a}\n{b}"
    );
}
