//! A manoeuvring target (straight legs and coordinated turns) tracked by an
//! IMM over a constant-velocity KF and a coordinated-turn EKF, against each
//! of them alone; prints the RMS position and velocity errors.
//!
//! `cargo run -p bayestrack-kalman --example imm_manoeuvre`
//!
//! State `[x, vx, y, vy, omega]` (m, m/s, rad/s), one step per second,
//! positions measured with 10 m noise; the target flies straight, turns at
//! 3 deg/s, flies straight, turns back at -4 deg/s. Seeded: the same
//! numbers on every run.
#![allow(missing_docs)]

use bayestrack_kalman::nalgebra::{Matrix2, SMatrix, SVector, Vector2};
use bayestrack_kalman::{
    Ekf, FnDynamics, Gaussian, Imm, Kf, LinearDynamics, LinearMeasurement, Mode, NoiseModel,
    Result, white_noise,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

type State = SVector<f64, 5>;

const DT: f64 = 1.0;

/// The coordinated turn at the rate `x[4]` (the straight line as the limit).
fn turn(x: &State) -> State {
    let w = x[4];
    let (s, c) = (w * DT).sin_cos();
    let (a, b) = if w.abs() < 1e-9 {
        (DT, 0.0)
    } else {
        (s / w, (1.0 - c) / w)
    };
    State::from([
        x[0] + a * x[1] - b * x[3],
        c * x[1] - s * x[3],
        x[2] + b * x[1] + a * x[3],
        s * x[1] + c * x[3],
        w,
    ])
}

/// The Jacobian of [`turn`] by central differences (the example keeps the
/// model short; an analytic Jacobian is the same to about 1e-8 here).
fn turn_jacobian(x: &State) -> SMatrix<f64, 5, 5> {
    let mut j = SMatrix::<f64, 5, 5>::zeros();
    for k in 0..5 {
        let h = 1e-6 * x[k].abs().max(1e-2);
        let mut up = *x;
        let mut down = *x;
        up[k] += h;
        down[k] -= h;
        j.set_column(k, &((turn(&up) - turn(&down)) / (2.0 * h)));
    }
    j
}

/// `Q` with acceleration variance `accel` on both axes and turn-rate
/// variance `rate` per step.
fn noise(accel: f64, rate: f64) -> Result<SMatrix<f64, 5, 5>> {
    let block = white_noise::<2>(DT, accel, NoiseModel::Discrete)?;
    let mut q = SMatrix::<f64, 5, 5>::zeros();
    q.fixed_view_mut::<2, 2>(0, 0).copy_from(&block);
    q.fixed_view_mut::<2, 2>(2, 2).copy_from(&block);
    q[(4, 4)] = rate;
    Ok(q)
}

fn main() -> Result<()> {
    // the truth
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2026);
    let sigma = 10.0;
    let measurement_noise = Normal::new(0.0, sigma).expect("finite");
    let deg = std::f64::consts::PI / 180.0;
    let mut x = State::from([0.0, 120.0, 0.0, 0.0, 0.0]);
    let (mut truth, mut zs) = (Vec::new(), Vec::new());
    for k in 0..200 {
        x[4] = match k {
            40..70 => 3.0 * deg,
            110..150 => -4.0 * deg,
            _ => 0.0,
        };
        x = turn(&x);
        truth.push(x);
        let noise = Vector2::new(
            measurement_noise.sample(&mut rng),
            measurement_noise.sample(&mut rng),
        );
        zs.push(Vector2::new(x[0], x[2]) + noise);
    }

    // the models
    let mut h = SMatrix::<f64, 2, 5>::zeros();
    h[(0, 0)] = 1.0;
    h[(1, 2)] = 1.0;
    let sensor = LinearMeasurement::new(h, Matrix2::identity() * sigma * sigma)?;
    let mut f_cv = SMatrix::<f64, 5, 5>::identity();
    f_cv[(0, 1)] = DT;
    f_cv[(2, 3)] = DT;
    f_cv[(4, 4)] = 0.0; // a constant-velocity target does not turn
    let cv = LinearDynamics::new(f_cv, noise(0.5, 1e-12)?)?;
    let ct = FnDynamics::new(turn, noise(0.5, (0.5 * deg).powi(2))?)?.with_jacobian(turn_jacobian);
    let imm = Imm::new(
        vec![
            Box::new(Mode::new(Kf::default(), cv, sensor)),
            Box::new(Mode::new(Ekf::default(), ct, sensor)),
        ],
        &[0.95, 0.05, 0.05, 0.95],
    )?;

    let start = Gaussian::diagonal(
        State::from([zs[0][0], 100.0, zs[0][1], 0.0, 0.0]),
        State::from([
            sigma * sigma,
            400.0,
            sigma * sigma,
            400.0,
            (2.0 * deg).powi(2),
        ]),
    )?;
    let mut imm_belief = imm.start(&[0.5, 0.5], &start)?;
    let (mut kf_belief, mut ekf_belief) = (start, start);
    let (kf, ekf) = (Kf::default(), Ekf::default());
    // squared errors: position, velocity
    let mut err = [[0.0; 2]; 3];
    let mut turning = 0.0;
    let mut add = |i: usize, g: &Gaussian<5>, t: &State| {
        let e = g.mean() - t;
        err[i][0] += e[0] * e[0] + e[2] * e[2];
        err[i][1] += e[1] * e[1] + e[3] * e[3];
    };
    for (z, t) in zs.iter().zip(&truth).skip(1) {
        imm_belief = imm.step(&imm_belief, Some(z))?.belief;
        kf_belief = kf
            .update(&kf.predict(&kf_belief, &cv)?, &sensor, Some(z))?
            .posterior;
        ekf_belief = ekf
            .update(&ekf.predict(&ekf_belief, &ct)?, &sensor, Some(z))?
            .posterior;
        add(0, &imm_belief.estimate()?, t);
        add(1, &kf_belief, t);
        add(2, &ekf_belief, t);
        if t[4] != 0.0 {
            turning += imm_belief.probabilities()[1];
        }
    }
    let n = (zs.len() - 1) as f64;
    println!(
        "{} steps, position noise {sigma} m; RMS errors:",
        zs.len() - 1
    );
    println!(
        "{:<28} {:>12} {:>14}",
        "filter", "position (m)", "velocity (m/s)"
    );
    for (name, e) in [
        ("IMM (CV KF + CT EKF)", err[0]),
        ("CV KF alone", err[1]),
        ("CT EKF alone", err[2]),
    ] {
        println!(
            "{name:<28} {:>12.2} {:>14.2}",
            (e[0] / n).sqrt(),
            (e[1] / n).sqrt()
        );
    }
    println!(
        "mean probability of the turn model while turning: {:.2}",
        turning / 70.0
    );
    Ok(())
}
