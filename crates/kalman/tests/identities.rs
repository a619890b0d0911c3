//! Identities between filters: each pair must agree to round-off.

use crate::common;

use bayestrack_kalman::{
    Additive, CovarianceUpdate, Ekf, Gaussian, HybridPrior, HybridUkfIekf, Iekf, Kf, Ukf,
};
use common::{Turn, assert_close, constant_velocity};
use nalgebra::{DMatrix, DVector, Matrix4, SVector, Vector2, Vector4};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

fn measurements(n: usize, seed: u64) -> Vec<Vector2<f64>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.1;
            let (e1, e2): (f64, f64) = (
                StandardNormal.sample(&mut rng),
                StandardNormal.sample(&mut rng),
            );
            Vector2::new(t + 0.5 * e1, 0.5 * t + 0.5 * e2)
        })
        .collect()
}

fn prior4() -> Gaussian<4> {
    Gaussian::new(
        Vector4::new(0.1, -0.2, 1.0, 0.5),
        Matrix4::from_diagonal(&Vector4::new(1.0, 2.0, 0.5, 0.3)),
    )
    .unwrap()
}

#[test]
fn ukf_equals_kf_on_a_linear_gaussian_model() {
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let kf = Kf::default();
    // Small alpha makes W0 large and negative (-2499 for 1e-2, about -1e6
    // for 1e-3): the moments are accumulated as deviations from the central
    // point, so the large weights do not cancel each other; what remains is
    // the round-off of the point differences times W_i ~ 1 / alpha^2,
    // below 1e-9 down to alpha = 1e-3.
    for (alpha, beta, kappa) in [
        (1.0, 0.0, 2.0),
        (1e-2, 2.0, 0.0),
        (1e-3, 2.0, 0.0),
        (0.5, 2.0, -1.0),
    ] {
        let ukf = Ukf::new(alpha, beta, kappa).unwrap();
        let (mut a, mut b) = (prior4(), prior4());
        for (k, z) in measurements(40, 1).iter().enumerate() {
            let z = if k % 7 == 3 { None } else { Some(z) };
            let pa = kf.predict(&a, &dynamics).unwrap();
            let pb = ukf.predict(&b, &dynamics).unwrap();
            assert_close(pb.mean(), pa.mean(), 1e-9, "predicted mean");
            assert_close(pb.cov(), pa.cov(), 1e-9, "predicted covariance");
            let ua = kf.update(&pa, &sensor, z).unwrap();
            let ub = ukf.update(&pb, &sensor, z).unwrap();
            assert_close(ub.posterior.mean(), ua.posterior.mean(), 1e-9, "mean");
            assert_close(ub.posterior.cov(), ua.posterior.cov(), 1e-9, "covariance");
            if let (Some(ia), Some(ib)) = (ua.innovation, ub.innovation) {
                let tol = 1e-9 * ia.nis.abs().max(1.0);
                assert!(
                    (ia.log_likelihood() - ib.log_likelihood()).abs() < tol,
                    "alpha {alpha}: {} {}",
                    ia.log_likelihood(),
                    ib.log_likelihood()
                );
                assert!(
                    (ia.nis - ib.nis).abs() < tol,
                    "alpha {alpha}: {} {}",
                    ia.nis,
                    ib.nis
                );
            }
            a = ua.posterior;
            b = ub.posterior;
        }
    }
}

#[test]
fn joint_augmented_ukf_step_equals_kf_on_a_linear_model() {
    // With linear f and h, the sigma points of [x, v, n] carry Q into the
    // cross-covariance exactly, so the one-set augmented step is the KF.
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let kf = Kf::default();
    let ukf = Ukf::new(1.0, 0.0, 2.0).unwrap();
    let (mut a, mut b) = (prior4(), prior4());
    for z in measurements(30, 2).iter() {
        let pa = kf.predict(&a, &dynamics).unwrap();
        let ua = kf.update(&pa, &sensor, Some(z)).unwrap();
        let s = ukf
            .step_augmented(&b, &Additive(&dynamics), &Additive(&sensor), Some(z))
            .unwrap();
        assert_close(s.predicted.cov(), pa.cov(), 1e-9, "predicted covariance");
        assert_close(s.update.posterior.mean(), ua.posterior.mean(), 1e-9, "mean");
        assert_close(
            s.update.posterior.cov(),
            ua.posterior.cov(),
            1e-9,
            "covariance",
        );
        a = ua.posterior;
        b = s.update.posterior;
    }
}

#[test]
fn augmented_ukf_equals_additive_ukf_when_the_noise_is_additive() {
    // Matching sqrt(L + lambda) across dimensions: kappa_aug = kappa + N - L
    // gives the same points along the state axes; the noise axes then add
    // exactly Q (or R) to the covariance.
    let model = Turn::new();
    let (alpha, beta, kappa) = (0.5, 2.0, 1.0);
    let additive = Ukf::new(alpha, beta, kappa).unwrap();
    let aug_predict = Ukf::new(alpha, beta, kappa - 5.0).unwrap(); // L = 5 + 5
    let aug_update = Ukf::new(alpha, beta, kappa - 2.0).unwrap(); // L = 5 + 2
    let mut a = Gaussian::new(
        SVector::from([10.0, 5.0, 2.0, 0.3, 0.05]),
        nalgebra::SMatrix::from_diagonal(&SVector::from([1.0, 1.0, 0.5, 0.05, 0.01])),
    )
    .unwrap();
    let mut b = a;
    for k in 0..25 {
        let pa = additive.predict(&a, &model).unwrap();
        let pb = aug_predict
            .predict_augmented(&b, &Additive(&model))
            .unwrap();
        assert_close(pb.mean(), pa.mean(), 1e-9, "predicted mean");
        assert_close(pb.cov(), pa.cov(), 1e-9, "predicted covariance");
        let truth = pa.mean();
        let z = Vector2::new(
            truth[0].hypot(truth[1]) + 0.1,
            truth[1].atan2(truth[0]) - 0.005,
        );
        let z = (k != 9).then_some(z);
        let ua = additive.update(&pa, &model, z.as_ref()).unwrap();
        let ub = aug_update
            .update_augmented(&pb, &Additive(&model), z.as_ref())
            .unwrap();
        assert_close(ub.posterior.mean(), ua.posterior.mean(), 1e-9, "mean");
        assert_close(ub.posterior.cov(), ua.posterior.cov(), 1e-9, "covariance");
        a = ua.posterior;
        b = ub.posterior;
    }
}

#[test]
fn iekf_with_one_iteration_equals_ekf() {
    let model = Turn::new();
    let ekf = Ekf::default();
    let iekf = Iekf::new(1, 0.0).unwrap();
    let mut a = Gaussian::new(
        SVector::from([10.0, 5.0, 2.0, 0.3, 0.05]),
        nalgebra::SMatrix::from_diagonal(&SVector::from([1.0, 1.0, 0.5, 0.05, 0.01])),
    )
    .unwrap();
    let mut b = a;
    for k in 0..25 {
        let pa = ekf.predict(&a, &model).unwrap();
        let pb = iekf.predict(&b, &model).unwrap();
        assert_eq!(pa, pb);
        let t = pa.mean();
        let z = Vector2::new(
            t[0].hypot(t[1]) + 0.3,
            t[1].atan2(t[0]) + 0.01 * (k as f64).sin(),
        );
        let ua = ekf.update(&pa, &model, Some(&z)).unwrap();
        let ub = iekf.update(&pb, &model, Some(&z)).unwrap();
        assert_eq!(ub.iterations, 1);
        assert_eq!(ua.posterior, ub.posterior);
        assert_eq!(ua.innovation, ub.innovation);
        a = ua.posterior;
        b = ub.posterior;
    }
}

#[test]
fn iekf_converges_to_the_map_estimate() {
    // The Gauss-Newton fixed point x* satisfies the MAP stationarity condition
    // P^-1 (x* - x_f) = H(x*)^T R^-1 (z - h(x*)).
    let model = Turn::new();
    let prior = Gaussian::new(
        SVector::from([3.0, 4.0, 1.0, 0.2, 0.0]),
        nalgebra::SMatrix::from_diagonal(&SVector::from([4.0, 4.0, 0.5, 0.05, 0.01])),
    )
    .unwrap();
    let z = Vector2::new(6.0, 1.1);
    let iekf = Iekf::new(50, 1e-13).unwrap();
    let u = iekf.update(&prior, &model, Some(&z)).unwrap();
    assert!(u.iterations > 1 && u.iterations < 50, "{}", u.iterations);
    let x = u.posterior.mean();
    use bayestrack_kalman::{Measurement, MeasurementJacobian};
    let lhs = prior.cov().try_inverse().unwrap() * (x - prior.mean());
    let h = model.jacobian(x);
    let rhs =
        h.transpose() * model.measurement_noise().try_inverse().unwrap() * (z - model.observe(x));
    assert_close(&lhs, &rhs, 1e-8, "MAP stationarity");
    // ... which the one-step EKF does not reach here
    let e = Ekf::default().update(&prior, &model, Some(&z)).unwrap();
    assert!((e.posterior.mean() - x).amax() > 1e-3);
}

#[test]
fn joseph_and_standard_forms_agree_for_the_optimal_gain() {
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let joseph = Kf::new(CovarianceUpdate::Joseph);
    let standard = Kf::new(CovarianceUpdate::Standard);
    let mut a = prior4();
    for z in measurements(20, 3).iter() {
        let p = joseph.predict(&a, &dynamics).unwrap();
        let ua = joseph.update(&p, &sensor, Some(z)).unwrap();
        let ub = standard.update(&p, &sensor, Some(z)).unwrap();
        assert_close(ua.posterior.cov(), ub.posterior.cov(), 1e-12, "covariance");
        a = ua.posterior;
    }
}

#[test]
fn hybrid_step_equals_kf_on_a_linear_model() {
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let kf = Kf::default();
    let hybrid = HybridUkfIekf::new(
        Ukf::new(1.0, 0.0, 2.0).unwrap(),
        Iekf::new(3, 1e-12).unwrap(),
    );
    assert_eq!(hybrid.prior, HybridPrior::UkfPredicted);
    let (mut a, mut b) = (prior4(), prior4());
    for z in measurements(20, 4).iter() {
        let pa = kf.predict(&a, &dynamics).unwrap();
        let ua = kf.update(&pa, &sensor, Some(z)).unwrap();
        let s = hybrid
            .step(&b, &Additive(&dynamics), &sensor, Some(z))
            .unwrap();
        assert_close(s.update.posterior.mean(), ua.posterior.mean(), 1e-9, "mean");
        assert_close(
            s.update.posterior.cov(),
            ua.posterior.cov(),
            1e-9,
            "covariance",
        );
        a = ua.posterior;
        b = s.update.posterior;
    }
    // Using the UKF posterior as the IEKF prior counts the measurement twice:
    // the covariance shrinks below the KF's.
    let twice = HybridUkfIekf {
        prior: HybridPrior::UkfPosterior,
        ..hybrid
    };
    let z = measurements(1, 5)[0];
    let s = twice
        .step(&prior4(), &Additive(&dynamics), &sensor, Some(&z))
        .unwrap();
    let pa = kf.predict(&prior4(), &dynamics).unwrap();
    let ua = kf.update(&pa, &sensor, Some(&z)).unwrap();
    assert!(s.update.posterior.cov().trace() < ua.posterior.cov().trace() * 0.9);
}

fn add_block(m: &mut DMatrix<f64>, r: usize, c: usize, b: &Matrix4<f64>) {
    for i in 0..4 {
        for j in 0..4 {
            m[(r + i, c + j)] += b[(i, j)];
        }
    }
}

fn add_rows(v: &mut DVector<f64>, r: usize, b: &Vector4<f64>) {
    for i in 0..4 {
        v[r + i] += b[i];
    }
}

#[test]
fn rts_smoother_equals_batch_least_squares() {
    // States x_0..x_T, prior on x_0, z_k on x_k for k = 1..T. The smoothed
    // means and covariances are the solution and the inverse information
    // matrix of one weighted least-squares problem over all states.
    let (dynamics, sensor) = constant_velocity(0.2, 0.5, 0.3);
    let kf = Kf::default();
    let prior = prior4();
    let zs = measurements(8, 6);
    let t = zs.len();
    let mut filtered = vec![prior];
    let mut belief = prior;
    for z in &zs {
        let p = kf.predict(&belief, &dynamics).unwrap();
        belief = kf.update(&p, &sensor, Some(z)).unwrap().posterior;
        filtered.push(belief);
    }
    let smoothed = kf.rts_smooth(&filtered, &dynamics, None).unwrap();

    let n = 4;
    let dim = n * (t + 1);
    let mut info = DMatrix::<f64>::zeros(dim, dim);
    let mut rhs = DVector::<f64>::zeros(dim);
    let p0i = prior.cov().try_inverse().unwrap();
    add_block(&mut info, 0, 0, &p0i);
    add_rows(&mut rhs, 0, &(p0i * prior.mean()));
    let f = dynamics.transition();
    let qi = dynamics.noise().try_inverse().unwrap();
    let h = sensor.matrix();
    let ri = sensor.noise().try_inverse().unwrap();
    for (k, z) in zs.iter().enumerate() {
        // residual x_{k+1} - F x_k with weight Q^-1: blocks [-F, I]
        let (a, b) = (k * n, (k + 1) * n);
        let ftqif = f.transpose() * qi * f;
        let ftqi = f.transpose() * qi;
        add_block(&mut info, a, a, &ftqif);
        add_block(&mut info, a, b, &(-ftqi));
        add_block(&mut info, b, a, &(-ftqi.transpose()));
        add_block(&mut info, b, b, &qi);
        // measurement z_{k+1} = H x_{k+1}
        add_block(&mut info, b, b, &(h.transpose() * ri * h));
        add_rows(&mut rhs, b, &(h.transpose() * ri * z));
    }
    let chol = info.cholesky().unwrap();
    let x = chol.solve(&rhs);
    let cov = chol.inverse();
    for (k, s) in smoothed.iter().enumerate() {
        let xm = Vector4::from_iterator(x.rows(k * n, n).iter().copied());
        let pm = Matrix4::from_iterator(cov.view((k * n, k * n), (n, n)).iter().copied());
        assert_close(s.mean(), &xm, 1e-9, "smoothed mean");
        assert_close(s.cov(), &pm, 1e-9, "smoothed covariance");
    }
}

#[test]
fn urts_smoother_equals_rts_on_a_linear_model() {
    let (dynamics, sensor) = constant_velocity(0.1, 0.1, 0.25);
    let kf = Kf::default();
    let ukf = Ukf::new(1.0, 2.0, 0.0).unwrap();
    let mut filtered = vec![];
    let mut belief = prior4();
    for z in measurements(15, 7).iter() {
        let p = kf.predict(&belief, &dynamics).unwrap();
        belief = kf.update(&p, &sensor, Some(z)).unwrap().posterior;
        filtered.push(belief);
    }
    let a = kf.rts_smooth(&filtered, &dynamics, None).unwrap();
    let b = ukf.rts_smooth(&filtered, &dynamics).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert_close(y.mean(), x.mean(), 1e-9, "mean");
        assert_close(y.cov(), x.cov(), 1e-9, "covariance");
    }
}
