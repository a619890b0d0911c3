//! filterpy as an oracle for the IMM (`IMMEstimator` over two
//! `KalmanFilter`s), the cubature filter (`CubatureKalmanFilter`) and the
//! square-root KF (`SquareRootKalmanFilter`): the cases `imm_cv`, `ckf_ct`
//! and `srkf_cv` of the workspace's `tests/data/filterpy_vectors.txt`
//! (made by `tools/filterpy_vectors.py`).

use std::collections::HashMap;

use bayestrack_kalman::nalgebra::{SMatrix, SVector, Vector2};
use bayestrack_kalman::{
    Ckf, FnDynamics, FnMeasurement, Gaussian, Imm, Kf, LinearDynamics, LinearMeasurement, Mode,
    SqrtGaussian, SrKf,
};

type Record = HashMap<String, Vec<f64>>;

/// The parameters and the step records of one case.
fn case(name: &str) -> (Record, Vec<Record>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/filterpy_vectors.txt"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines().skip_while(|l| *l != format!("case {name}"));
    assert!(lines.next().is_some(), "no case {name}");
    let (mut params, mut steps) = (Record::new(), Vec::<Record>::new());
    for line in lines.take_while(|l| !l.starts_with("case ")) {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default().to_string();
        if key == "step" {
            steps.push(Record::new());
            continue;
        }
        let values = words.map(|w| w.parse().unwrap()).collect();
        steps.last_mut().unwrap_or(&mut params).insert(key, values);
    }
    (params, steps)
}

fn mat<const R: usize, const C: usize>(r: &Record, key: &str) -> SMatrix<f64, R, C> {
    let v = &r[key];
    assert_eq!(v.len(), R * C, "{key}");
    SMatrix::from_row_slice(v)
}

fn vector<const D: usize>(r: &Record, key: &str) -> SVector<f64, D> {
    mat::<D, 1>(r, key)
}

/// Largest absolute difference, relative to the larger of 1 and the
/// oracle's magnitude.
fn close<const R: usize, const C: usize>(
    ours: &SMatrix<f64, R, C>,
    theirs: &SMatrix<f64, R, C>,
    tol: f64,
    what: &str,
) {
    let scale = theirs.amax().max(1.0);
    let err = (ours - theirs).amax() / scale;
    assert!(err <= tol, "{what}: {err:e}\nours {ours}\ntheirs {theirs}");
}

#[test]
fn imm_matches_filterpy_imm_estimator() {
    let (p, steps) = case("imm_cv");
    let sensor = LinearMeasurement::new(mat::<2, 4>(&p, "H"), mat(&p, "R")).unwrap();
    let quiet = LinearDynamics::new(mat(&p, "F"), mat(&p, "Q0")).unwrap();
    let agile = LinearDynamics::new(mat(&p, "F"), mat(&p, "Q1")).unwrap();
    let imm = Imm::new(
        vec![
            Box::new(Mode::new(Kf::default(), quiet, sensor)),
            Box::new(Mode::new(Kf::default(), agile, sensor)),
        ],
        &p["M"],
    )
    .unwrap();
    let start = Gaussian::new(vector(&p, "x0"), mat(&p, "P0")).unwrap();
    let mut belief = imm.start(&p["mu0"], &start).unwrap();
    assert_eq!(steps.len(), 40);
    let mut agile_max: f64 = 0.0;
    for (k, s) in steps.iter().enumerate() {
        let z: Vector2<f64> = vector(s, "z");
        belief = imm.step(&belief, Some(&z)).unwrap().belief;
        let mu = SVector::<f64, 2>::from_column_slice(belief.probabilities());
        close(&mu, &vector(s, "mu"), 1e-12, &format!("mu {k}"));
        let est = belief.estimate().unwrap();
        close(est.mean(), &vector(s, "x"), 1e-12, &format!("x {k}"));
        close(est.cov(), &mat(s, "P"), 1e-12, &format!("P {k}"));
        for (i, mode) in belief.modes().iter().enumerate() {
            let g = mode.to_gaussian();
            close(g.mean(), &vector(s, &format!("x{i}")), 1e-12, "mode mean");
            close(g.cov(), &mat(s, &format!("P{i}")), 1e-12, "mode cov");
        }
        agile_max = agile_max.max(mu[1]);
    }
    // the case exercises both modes: the manoeuvre (steps 15-21) makes the
    // agile model the likely one (0.82 at step 17), the quiet one before
    assert!(agile_max > 0.8, "{agile_max}");
}

const CT_DT: f64 = 0.5;

fn ct_f(x: &SVector<f64, 5>) -> SVector<f64, 5> {
    let (v, th, w) = (x[2], x[3], x[4]);
    SVector::<f64, 5>::new(
        x[0] + CT_DT * v * th.cos(),
        x[1] + CT_DT * v * th.sin(),
        v,
        th + CT_DT * w,
        w,
    )
}

fn rb_h(x: &SVector<f64, 5>) -> Vector2<f64> {
    Vector2::new(x[0].hypot(x[1]), x[1].atan2(x[0]))
}

/// Compares a filter step with a record of `emit_update`.
fn check_update<const N: usize, const M: usize>(
    s: &Record,
    prior: &Gaussian<N>,
    update: &bayestrack_kalman::Update<N, M>,
    tol: f64,
    k: usize,
) {
    close(
        prior.mean(),
        &vector(s, "prior_x"),
        tol,
        &format!("prior x {k}"),
    );
    close(
        prior.cov(),
        &mat(s, "prior_P"),
        tol,
        &format!("prior P {k}"),
    );
    close(
        update.posterior.mean(),
        &vector(s, "post_x"),
        tol,
        &format!("x {k}"),
    );
    close(
        update.posterior.cov(),
        &mat(s, "post_P"),
        tol,
        &format!("P {k}"),
    );
    let innovation = update.innovation.unwrap();
    close(
        &innovation.residual,
        &vector(s, "y"),
        tol,
        &format!("y {k}"),
    );
    close(&innovation.covariance, &mat(s, "S"), tol, &format!("S {k}"));
    let ll = s["loglik"][0];
    assert!(
        (innovation.log_likelihood() - ll).abs() <= tol * ll.abs().max(1.0),
        "loglik {k}"
    );
}

#[test]
fn ckf_matches_filterpy_cubature_kalman_filter() {
    let (p, steps) = case("ckf_ct");
    assert_eq!(p["dt"], [CT_DT]);
    let dynamics = FnDynamics::new(ct_f, mat(&p, "Q")).unwrap();
    let sensor = FnMeasurement::new(rb_h, mat(&p, "R")).unwrap();
    let mut belief = Gaussian::new(vector(&p, "x0"), mat(&p, "P0")).unwrap();
    assert_eq!(steps.len(), 30);
    for (k, s) in steps.iter().enumerate() {
        let z: Vector2<f64> = vector(s, "z");
        // filterpy's CKF updates with the predicted cubature points (one
        // point set through f then h): Ckf::step
        let step = Ckf.step(&belief, &dynamics, &sensor, Some(&z)).unwrap();
        check_update(s, &step.predicted, &step.update, 1e-10, k);
        belief = step.update.posterior;
    }
}

#[test]
fn square_root_kf_matches_filterpy_square_root_kalman_filter() {
    let (p, steps) = case("srkf_cv");
    let dynamics = LinearDynamics::new(mat(&p, "F"), mat(&p, "Q")).unwrap();
    let sensor = LinearMeasurement::new(mat::<2, 4>(&p, "H"), mat(&p, "R")).unwrap();
    let start = Gaussian::new(vector(&p, "x0"), mat(&p, "P0")).unwrap();
    let mut belief = SqrtGaussian::from_gaussian(&start).unwrap();
    let srkf = SrKf;
    assert_eq!(steps.len(), 30);
    for (k, s) in steps.iter().enumerate() {
        let z: Vector2<f64> = vector(s, "z");
        let prior = srkf.predict(&belief, &dynamics).unwrap();
        let update = srkf.update(&prior, &sensor, Some(&z)).unwrap();
        let full = bayestrack_kalman::Update {
            posterior: update.posterior.to_gaussian(),
            innovation: update.innovation,
            iterations: update.iterations,
        };
        check_update(s, &prior.to_gaussian(), &full, 1e-12, k);
        belief = update.posterior;
    }
}
