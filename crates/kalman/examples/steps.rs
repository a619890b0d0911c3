//! Runs `N` steps of one of the benchmarked filters (the inputs of
//! `benches/kalman.rs`), for instruction counts: run it under
//! `valgrind --tool=callgrind` for `N` and `2N` steps and divide the
//! difference by `N` to get instructions per step.
//!
//! `cargo run --release -p bayestrack-kalman --example steps -- joseph 1000`
//! (filters: `joseph`, `standard`, `srkf` (the square-root KF) and `imm`
//! (an IMM over two KFs; `imm_into` the same with `Imm::step_into`) on the CV model, `ukf`, `ukf_one_set`, `srukf` (the
//! square-root UKF on the pendulum), and `ukf_runtime` /
//! `ukf_runtime_checked`: the pendulum with `Q` and `R` read at run time,
//! checked on every step or once).
#![allow(missing_docs)]

use std::hint::black_box;

use bayestrack_kalman::{
    CovarianceUpdate, Dynamics, Gaussian, Imm, ImmStep, Kf, LinearDynamics, LinearMeasurement,
    Measurement, Mode, NoiseCovariance, SqrtGaussian, SrKf, SrUkf, Ukf,
};
use nalgebra::{Matrix1, Matrix2, Matrix2x4, Matrix4, SMatrix, SVector, Vector1, Vector2, Vector4};

const DT: f64 = 0.1;
const PDT: f64 = 0.01;
const G_OVER_L: f64 = 9.81;

fn pendulum_f(x: &SVector<f64, 2>) -> SVector<f64, 2> {
    Vector2::new(x[0] + PDT * x[1], x[1] - PDT * G_OVER_L * x[0].sin())
}

struct Pendulum;

impl Dynamics<2> for Pendulum {
    #[inline]
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        pendulum_f(x)
    }
    #[inline]
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        Matrix2::new(1e-8, 0.0, 0.0, 1e-6)
    }
}

impl Measurement<2, 1> for Pendulum {
    #[inline]
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        Vector1::new(x[0].sin())
    }
    #[inline]
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(0.0025)
    }
}

/// The pendulum with `Q` and `R` read at run time (not constants the
/// optimiser folds the per-step checks of), optionally checked once.
struct RuntimePendulum {
    q: Matrix2<f64>,
    r: Matrix1<f64>,
    checked: Option<(NoiseCovariance<2>, NoiseCovariance<1>)>,
}

impl Dynamics<2> for RuntimePendulum {
    #[inline]
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        pendulum_f(x)
    }
    #[inline]
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        self.q
    }
    #[inline]
    fn checked_process_noise(&self) -> Option<NoiseCovariance<2>> {
        self.checked.map(|c| c.0)
    }
}

impl Measurement<2, 1> for RuntimePendulum {
    #[inline]
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        Vector1::new(x[0].sin())
    }
    #[inline]
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        self.r
    }
    #[inline]
    fn checked_measurement_noise(&self) -> Option<NoiseCovariance<1>> {
        self.checked.map(|c| c.1)
    }
}

/// The CV model and measurements of the `joseph` arm, for `srkf` and `imm`.
fn cv_model() -> (
    LinearDynamics<4>,
    LinearMeasurement<4, 2>,
    Vec<Vector2<f64>>,
) {
    let mut f = Matrix4::identity();
    f[(0, 2)] = DT;
    f[(1, 3)] = DT;
    let (a, b, c) = (DT.powi(3) / 3.0, DT.powi(2) / 2.0, DT);
    #[rustfmt::skip]
    let q = Matrix4::new(
        a, 0.0, b, 0.0,
        0.0, a, 0.0, b,
        b, 0.0, c, 0.0,
        0.0, b, 0.0, c,
    ) * 0.1;
    let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
    let (f, q, h, r) = black_box((f, q, h, Matrix2::identity() * 0.25));
    let zs: Vec<Vector2<f64>> = (0..64)
        .map(|k| {
            let t = k as f64 * DT;
            Vector2::new(t + 0.3 * (7.0 * t).sin(), 0.5 * t + 0.3 * (5.0 * t).cos())
        })
        .collect();
    let dynamics = LinearDynamics::new(f, q).unwrap();
    let sensor = LinearMeasurement::new(h, r).unwrap();
    (dynamics, sensor, zs)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "joseph".into());
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    match which.as_str() {
        "joseph" | "standard" => {
            let (dynamics, sensor, zs) = cv_model();
            let form = if which == "joseph" {
                CovarianceUpdate::Joseph
            } else {
                CovarianceUpdate::Standard
            };
            let kf = black_box(Kf::new(form));
            let mut belief =
                Gaussian::new(Vector4::new(0.0, 0.0, 1.0, 0.5), Matrix4::identity()).unwrap();
            for k in 0..n {
                let prior = kf.predict(&belief, &dynamics).unwrap();
                let u = black_box(kf.update(&prior, &sensor, Some(&zs[k & 63])).unwrap());
                belief = u.posterior;
            }
            black_box(belief);
        }
        "srkf" => {
            let (dynamics, sensor, zs) = cv_model();
            let start = Gaussian::new(Vector4::new(0.0, 0.0, 1.0, 0.5), Matrix4::identity());
            let mut belief = SqrtGaussian::from_gaussian(&start.unwrap()).unwrap();
            let srkf = black_box(SrKf);
            for k in 0..n {
                let prior = srkf.predict(&belief, &dynamics).unwrap();
                let u = black_box(srkf.update(&prior, &sensor, Some(&zs[k & 63])).unwrap());
                belief = u.posterior;
            }
            black_box(belief);
        }
        "imm" | "imm_into" => {
            let (dynamics, sensor, zs) = cv_model();
            let agile =
                LinearDynamics::new(*dynamics.transition(), dynamics.noise() * 100.0).unwrap();
            let imm = Imm::new(
                vec![
                    Box::new(Mode::new(Kf::default(), dynamics, sensor)),
                    Box::new(Mode::new(Kf::default(), agile, sensor)),
                ],
                &[0.95, 0.05, 0.05, 0.95],
            )
            .unwrap();
            let start = Gaussian::new(Vector4::new(0.0, 0.0, 1.0, 0.5), Matrix4::identity());
            let belief = imm.start(&[0.5, 0.5], &start.unwrap()).unwrap();
            if which == "imm" {
                let mut belief = belief;
                for k in 0..n {
                    belief = black_box(imm.step(&belief, Some(&zs[k & 63])).unwrap()).belief;
                }
                black_box(belief);
            } else {
                // in place: no heap allocation per step (valgrind's heap
                // summary for N and 2N steps is the same)
                let mut now = ImmStep {
                    belief,
                    ..ImmStep::default()
                };
                let mut next = ImmStep::default();
                for k in 0..n {
                    imm.step_into(&now.belief, Some(&zs[k & 63]), &mut next)
                        .unwrap();
                    std::mem::swap(&mut now, black_box(&mut next));
                }
                black_box(now);
            }
        }
        "ukf_runtime" | "ukf_runtime_checked" => {
            let (q, r) = black_box((Matrix2::new(1e-8, 0.0, 0.0, 1e-6), Matrix1::new(0.0025)));
            let checked = (which == "ukf_runtime_checked").then(|| {
                (
                    NoiseCovariance::new(q).unwrap(),
                    NoiseCovariance::new(r).unwrap(),
                )
            });
            let model = RuntimePendulum { q, r, checked };
            let mut x = Vector2::new(0.6, 0.0);
            let zs: Vec<Vector1<f64>> = (0..64)
                .map(|k| {
                    x = pendulum_f(&x);
                    Vector1::new(x[0].sin() + 0.05 * ((k * 7919 % 101) as f64 / 50.0 - 1.0))
                })
                .collect();
            let ukf = black_box(Ukf::new(1e-3, 2.0, 0.0).unwrap());
            let mut belief =
                Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1).unwrap();
            for k in 0..n {
                let prior = ukf.predict(&belief, &model).unwrap();
                let u = black_box(ukf.update(&prior, &model, Some(&zs[k & 63])).unwrap());
                belief = u.posterior;
            }
            black_box(belief);
        }
        "srukf" => {
            let mut x = Vector2::new(0.6, 0.0);
            let zs: Vec<Vector1<f64>> = (0..64)
                .map(|k| {
                    x = pendulum_f(&x);
                    Vector1::new(x[0].sin() + 0.05 * ((k * 7919 % 101) as f64 / 50.0 - 1.0))
                })
                .collect();
            let srukf = black_box(SrUkf::new(1e-3, 2.0, 0.0).unwrap());
            let mut belief =
                SqrtGaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1f64.sqrt())
                    .unwrap();
            for k in 0..n {
                let prior = srukf.predict(&belief, &Pendulum).unwrap();
                let u = black_box(srukf.update(&prior, &Pendulum, Some(&zs[k & 63])).unwrap());
                belief = u.posterior;
            }
            black_box(belief);
        }
        "ukf" | "ukf_one_set" => {
            let mut x = Vector2::new(0.6, 0.0);
            let zs: Vec<Vector1<f64>> = (0..64)
                .map(|k| {
                    x = pendulum_f(&x);
                    Vector1::new(x[0].sin() + 0.05 * ((k * 7919 % 101) as f64 / 50.0 - 1.0))
                })
                .collect();
            let ukf = black_box(Ukf::new(1e-3, 2.0, 0.0).unwrap());
            let mut belief =
                Gaussian::new(Vector2::new(0.5, 0.0), Matrix2::identity() * 0.1).unwrap();
            for k in 0..n {
                if which == "ukf" {
                    let prior = ukf.predict(&belief, &Pendulum).unwrap();
                    let u = black_box(ukf.update(&prior, &Pendulum, Some(&zs[k & 63])).unwrap());
                    belief = u.posterior;
                } else {
                    let s = black_box(
                        ukf.step(&belief, &Pendulum, &Pendulum, Some(&zs[k & 63]))
                            .unwrap(),
                    );
                    belief = s.update.posterior;
                }
            }
            black_box(belief);
        }
        other => panic!("unknown filter {other}"),
    }
}
