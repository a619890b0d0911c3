//! The Rao-Blackwellised particle filter against the Kalman filter.

use bayestrack_kalman::{Gaussian, KalmanError, Kf, LinearDynamics, LinearMeasurement};
use bayestrack_particle::{
    ConditionallyLinear, ParticleFilter, ParticleSet, Proposal, RaoBlackwellised, RbParticle,
    stream_rng,
};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, SVector, Vector1, Vector2};
use rand_distr::{Distribution, StandardNormal};

/// A deterministic clock `xn_k = xn_{k-1} + 1` and a constant-velocity
/// linear state seen in position through a known nonlinear offset
/// `sin(xn)`: every particle is the same, the filter is the KF.
struct Clocked {
    nonlinear: LinearMeasurement<2, 1>,
    linear: LinearDynamics<2>,
    sensor: LinearMeasurement<2, 1>,
}

impl Clocked {
    fn new() -> Self {
        Self {
            nonlinear: LinearMeasurement::new(Matrix1x2::zeros(), Matrix1::zeros()).unwrap(),
            linear: LinearDynamics::new(
                Matrix2::new(1.0, 0.5, 0.0, 1.0),
                Matrix2::new(0.02, 0.05, 0.05, 0.2),
            )
            .unwrap(),
            sensor: LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(0.3)).unwrap(),
        }
    }
}

impl ConditionallyLinear<1, 2, 1> for Clocked {
    fn nonlinear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<2, 1>) {
        (xn.add_scalar(1.0), self.nonlinear)
    }
    fn linear(&self, _k: usize, _xn: &Vector1<f64>) -> (Vector2<f64>, LinearDynamics<2>) {
        (Vector2::zeros(), self.linear)
    }
    fn measurement(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<2, 1>) {
        (Vector1::new(xn[0].sin()), self.sensor)
    }
}

#[test]
fn rbpf_equals_the_kalman_filter_when_the_nonlinear_part_is_degenerate() {
    let m = Clocked::new();
    let kf = Kf::default();
    let p0 = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::new(1.0, 0.1, 0.1, 0.5)).unwrap();
    let mut rng = stream_rng(&[1]);
    let particle = RbParticle {
        xn: Vector1::new(0.0),
        xl: p0,
    };
    let mut set = ParticleSet::new(vec![particle; 50]).unwrap();
    let pf = ParticleFilter {
        chunk_size: 16,
        ..ParticleFilter::default()
    };
    let mut belief = p0;
    let (mut ll_kf, mut ll_rb) = (0.0, 0.0);
    for k in 1..=20 {
        let clock = k as f64;
        let e: f64 = StandardNormal.sample(&mut rng);
        let z = Vector1::new(0.7 * clock + clock.sin() + e);
        let prior = kf.predict(&belief, &m.linear).unwrap();
        let u = kf
            .update(&prior, &m.sensor, Some(&(z - Vector1::new(clock.sin()))))
            .unwrap();
        ll_kf += u.innovation.unwrap().log_likelihood();
        belief = u.posterior;
        let r = pf
            .step(&mut set, &RaoBlackwellised::new(&m), &z, &[2, k])
            .unwrap();
        ll_rb += r.log_evidence;
        let (mean, cov) = set.linear_moments();
        assert!((mean - belief.mean()).amax() < 1e-9, "k={k}");
        assert!((cov - belief.cov()).amax() < 1e-9, "k={k}");
        assert!((r.mean[0] - clock).abs() < 1e-9);
        assert!((r.ess - 50.0).abs() < 1e-9);
    }
    assert!((ll_rb - ll_kf).abs() < 1e-9, "{ll_rb} vs {ll_kf}");
}

/// Position `xn` and velocity `xl`: `xn_k = xn + dt xl + wn`,
/// `xl_k = xl + wl`, `z = xn + e`: fully linear, with the velocity coupled
/// into the nonlinear state's dynamics (`An = dt`).
struct Coupled {
    nonlinear: LinearMeasurement<1, 1>,
    linear: LinearDynamics<1>,
    sensor: LinearMeasurement<1, 1>,
}

const DT: f64 = 0.5;
const QN: f64 = 0.1;
const QL: f64 = 0.05;
const R: f64 = 0.2;

impl ConditionallyLinear<1, 1, 1> for Coupled {
    fn nonlinear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (*xn, self.nonlinear)
    }
    fn linear(&self, _k: usize, _xn: &Vector1<f64>) -> (Vector1<f64>, LinearDynamics<1>) {
        (Vector1::zeros(), self.linear)
    }
    fn measurement(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (*xn, self.sensor)
    }
}

fn coupled_run(threads: usize, n: usize, chunk: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let m = Coupled {
        nonlinear: LinearMeasurement::new(Matrix1::new(DT), Matrix1::new(QN)).unwrap(),
        linear: LinearDynamics::new(Matrix1::new(1.0), Matrix1::new(QL)).unwrap(),
        sensor: LinearMeasurement::new(Matrix1::zeros(), Matrix1::new(R)).unwrap(),
    };
    // the same model as one 2-state KF
    let kf = Kf::default();
    let full_dyn = LinearDynamics::new(
        Matrix2::new(1.0, DT, 0.0, 1.0),
        Matrix2::new(QN, 0.0, 0.0, QL),
    )
    .unwrap();
    let full_sensor = LinearMeasurement::new(Matrix1x2::new(1.0, 0.0), Matrix1::new(R)).unwrap();
    let mut belief =
        Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::new(0.5, 0.0, 0.0, 1.0)).unwrap();
    let mut rng = stream_rng(&[3]);
    let parts: Vec<RbParticle<1, 1>> = (0..n)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            RbParticle {
                xn: Vector1::new(0.5f64.sqrt() * e),
                xl: Gaussian::new(Vector1::new(1.0), Matrix1::new(1.0)).unwrap(),
            }
        })
        .collect();
    let pf = ParticleFilter {
        chunk_size: chunk,
        ..ParticleFilter::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut set = ParticleSet::new(parts).unwrap();
        let mut sim = stream_rng(&[4]);
        let mut x = Vector2::new(0.0, 1.0);
        let (mut rb, mut exact) = (vec![], vec![]);
        for k in 1..=15u64 {
            let w: SVector<f64, 3> = SVector::from_fn(|_, _| StandardNormal.sample(&mut sim));
            x = Vector2::new(x[0] + DT * x[1] + QN.sqrt() * w[0], x[1] + QL.sqrt() * w[1]);
            let z = Vector1::new(x[0] + R.sqrt() * w[2]);
            belief = kf.predict(&belief, &full_dyn).unwrap();
            belief = kf
                .update(&belief, &full_sensor, Some(&z))
                .unwrap()
                .posterior;
            let r = pf
                .step(&mut set, &RaoBlackwellised::new(&m), &z, &[5, k])
                .unwrap();
            let (ml, _) = set.linear_moments();
            rb.push([r.mean[0], ml[0]]);
            exact.push([belief.mean()[0], belief.mean()[1]]);
        }
        (rb, exact)
    })
}

#[test]
fn rbpf_tracks_the_kalman_filter_when_the_linear_state_drives_the_nonlinear_one() {
    // exercises the pseudo-measurement update (An != 0): with 2,000
    // particles the position and velocity estimates stay within 0.05 of
    // the exact ones (posterior standard deviations 0.3 and 0.3: MC error
    // about 0.3 / sqrt(ESS ~ 1,000) = 0.01)
    let (rb, exact) = coupled_run(1, 2000, 512);
    for (k, (a, b)) in rb.iter().zip(&exact).enumerate() {
        assert!((a[0] - b[0]).abs() < 0.05, "k={k} position {a:?} vs {b:?}");
        assert!((a[1] - b[1]).abs() < 0.05, "k={k} velocity {a:?} vs {b:?}");
    }
}

#[test]
fn rbpf_gives_the_same_bits_on_any_thread_count() {
    assert_eq!(coupled_run(1, 300, 64).0, coupled_run(4, 300, 64).0);
}

/// A fully linear model `xn_k = 0.8 xn + 0.5 xl + wn`, `xl_k = 0.3 xn +
/// 0.9 xl + wl`, `z = 0.4 xn + xl + e`, with `cov(wl, wn) = qln`.
struct Correlated {
    qln: f64,
}

const CQN: f64 = 0.1;
const CQL: f64 = 0.05;
const CR: f64 = 0.2;

impl ConditionallyLinear<1, 1, 1> for Correlated {
    fn nonlinear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (
            xn * 0.8,
            LinearMeasurement::new(Matrix1::new(0.5), Matrix1::new(CQN)).unwrap(),
        )
    }
    fn linear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearDynamics<1>) {
        (
            xn * 0.3,
            LinearDynamics::new(Matrix1::new(0.9), Matrix1::new(CQL)).unwrap(),
        )
    }
    fn measurement(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (
            xn * 0.4,
            LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(CR)).unwrap(),
        )
    }
    fn cross_covariance(&self, _k: usize, _xn: &Vector1<f64>) -> Option<Matrix1<f64>> {
        Some(Matrix1::new(self.qln))
    }
}

#[test]
fn rbpf_equals_the_kalman_filter_given_the_nonlinear_path_with_correlated_noise() {
    // each particle's linear belief is p(xl_k | xn_{0:k}, z_{1:k}) and its
    // weight increment log p(z_k | xn_{0:k}, z_{1:k-1}): a 2-state KF of
    // the same model with the joint noise [[Qn, Qln], [Qln, Ql]], which
    // measures xn_k exactly and then z_k, gives both; to 1e-9, with the
    // noises correlated 0.85 and uncorrelated
    for qln in [0.06, -0.03, 0.0] {
        let m = Correlated { qln };
        let f = Matrix2::new(0.8, 0.5, 0.3, 0.9);
        let q = Matrix2::new(CQN, qln, qln, CQL);
        let h = Matrix1x2::new(0.4, 1.0);
        let mut sim = stream_rng(&[31]);
        let mut rng = stream_rng(&[32]);
        let mut x = Vector2::new(0.3, 1.0);
        let lq = q.cholesky().unwrap().l();
        let mut p = RbParticle {
            xn: Vector1::new(0.3),
            xl: Gaussian::new(Vector1::new(1.0), Matrix1::new(1.0)).unwrap(),
        };
        let (mut mean, mut cov) = (Vector2::new(0.3, 1.0), Matrix2::new(0.0, 0.0, 0.0, 1.0));
        let rb = RaoBlackwellised::new(&m);
        for k in 1..=30 {
            let w: Vector2<f64> = Vector2::from_fn(|_, _| StandardNormal.sample(&mut sim));
            x = f * x + lq * w;
            let e: f64 = StandardNormal.sample(&mut sim);
            let z = Vector1::new((h * x)[0] + CR.sqrt() * e);
            let (child, lw) = rb.propose(k, &p, &z, &mut (), &mut rng).unwrap();
            // the reference: predict, measure xn_k exactly, measure z_k
            mean = f * mean;
            cov = f * cov * f.transpose() + q;
            let s = cov[(0, 0)];
            let gain = cov.column(0) / s;
            mean += gain * (child.xn[0] - mean[0]);
            cov -= gain * gain.transpose() * s;
            let s = (h * cov * h.transpose())[0] + CR;
            let v = z[0] - (h * mean)[0];
            let ll = -0.5 * ((2.0 * std::f64::consts::PI * s).ln() + v * v / s);
            let gain = cov * h.transpose() / s;
            mean += gain * v;
            cov -= gain * gain.transpose() * s;
            assert!(
                (child.xl.mean()[0] - mean[1]).abs() < 1e-9,
                "qln {qln} k={k}"
            );
            assert!(
                (child.xl.cov()[(0, 0)] - cov[(1, 1)]).abs() < 1e-9,
                "qln {qln} k={k}"
            );
            assert!((lw - ll).abs() < 1e-9, "qln {qln} k={k}: {lw} vs {ll}");
            p = child;
        }
    }
}

#[test]
fn rbpf_refuses_a_joint_noise_that_is_not_a_covariance() {
    let p = RbParticle {
        xn: Vector1::new(0.3),
        xl: Gaussian::new(Vector1::new(1.0), Matrix1::new(1.0)).unwrap(),
    };
    let z = Vector1::new(0.0);
    // |Qln| > sqrt(Qn Ql): no joint Gaussian has these blocks
    let m = Correlated { qln: 0.1 };
    let mut rng = stream_rng(&[33]);
    assert!(matches!(
        RaoBlackwellised::new(&m).propose(1, &p, &z, &mut (), &mut rng),
        Err(KalmanError::NotPositiveDefinite { .. })
    ));
    let m = Correlated { qln: f64::NAN };
    assert!(matches!(
        RaoBlackwellised::new(&m).propose(1, &p, &z, &mut (), &mut rng),
        Err(KalmanError::NonFinite { .. })
    ));
}
