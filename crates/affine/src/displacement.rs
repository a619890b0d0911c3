//! The global displacement `d_k` of Xu, Gao and Yang 2015 (paper 002) eq. 4, predicted by a Kalman
//! filter (from `bayestrack-kalman`) on the constant-acceleration state
//! `X = (x, y, vx, vy, ax, ay)` of Xu, Gao and Yang 2015 (paper 002) section 1, whose measurement is
//! the position of the final estimate `M_k*` (its translation).

use bayestrack_kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement};
use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

use crate::error::{AffineError, Result, check_finite};

/// Kalman predictor of the target centre; `predict` returns the displacement
/// `d_k` that the left factor `exp(d_k(1) A5 + d_k(2) A6)` of eq. 4 applies.
#[derive(Debug, Clone)]
pub struct DisplacementPredictor {
    kf: Kf,
    dynamics: LinearDynamics<6>,
    measurement: LinearMeasurement<6, 2>,
    belief: Gaussian<6>,
}

impl DisplacementPredictor {
    /// A predictor starting at `position` at rest, with frame interval `dt`,
    /// white-jerk process noise of spectral density `q` (pixels^2 / s^5) per
    /// axis, measurement noise standard deviation `r` (pixels) and initial
    /// standard deviations `sigma0 = (position, velocity, acceleration)`.
    pub fn new(position: Vector2<f64>, dt: f64, q: f64, r: f64, sigma0: [f64; 3]) -> Result<Self> {
        check_finite(
            "displacement predictor parameters",
            &[position[0], position[1], dt, q, r],
        )?;
        check_finite("sigma0", &sigma0)?;
        for (name, v) in [("dt", dt), ("r", r)] {
            if v <= 0.0 {
                return Err(AffineError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be > 0",
                });
            }
        }
        if q < 0.0 || sigma0.iter().any(|s| *s <= 0.0) {
            return Err(AffineError::InvalidParameter {
                name: "q / sigma0",
                value: q,
                reason: "q must be >= 0 and sigma0 > 0",
            });
        }
        // State order (x, y, vx, vy, ax, ay).
        let mut f = SMatrix::<f64, 6, 6>::identity();
        let mut qm = SMatrix::<f64, 6, 6>::zeros();
        // Per-axis white-jerk covariance on (p, v, a).
        let qa = [
            [dt.powi(5) / 20.0, dt.powi(4) / 8.0, dt.powi(3) / 6.0],
            [dt.powi(4) / 8.0, dt.powi(3) / 3.0, dt.powi(2) / 2.0],
            [dt.powi(3) / 6.0, dt.powi(2) / 2.0, dt],
        ];
        for axis in 0..2 {
            let (p, v, a) = (axis, 2 + axis, 4 + axis);
            f[(p, v)] = dt;
            f[(p, a)] = 0.5 * dt * dt;
            f[(v, a)] = dt;
            let idx = [p, v, a];
            for i in 0..3 {
                for j in 0..3 {
                    qm[(idx[i], idx[j])] = q * qa[i][j];
                }
            }
        }
        let mut h = SMatrix::<f64, 2, 6>::zeros();
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        let mean =
            SVector::<f64, 6>::from_column_slice(&[position[0], position[1], 0.0, 0.0, 0.0, 0.0]);
        let s2 = sigma0.map(|s| s * s);
        let var = SVector::<f64, 6>::from_column_slice(&[s2[0], s2[0], s2[1], s2[1], s2[2], s2[2]]);
        Ok(Self {
            kf: Kf::default(),
            dynamics: LinearDynamics::new(f, qm)?,
            measurement: LinearMeasurement::new(h, Matrix2::identity() * (r * r))?,
            belief: Gaussian::diagonal(mean, var)?,
        })
    }

    /// The current belief over `(x, y, vx, vy, ax, ay)`.
    pub fn belief(&self) -> &Gaussian<6> {
        &self.belief
    }

    /// Time update; returns `d_k`, the predicted minus the previous mean
    /// position.
    pub fn predict(&mut self) -> Result<Vector2<f64>> {
        let before = Vector2::new(self.belief.mean()[0], self.belief.mean()[1]);
        self.belief = self.kf.predict(&self.belief, &self.dynamics)?;
        Ok(Vector2::new(self.belief.mean()[0], self.belief.mean()[1]) - before)
    }

    /// Covariance of the predicted position: the elliptical search region of
    /// the hierarchical estimation.
    pub fn position_covariance(&self) -> Matrix2<f64> {
        self.belief.cov().fixed_view::<2, 2>(0, 0).into_owned()
    }

    /// Measurement update with the centre of the final estimate (`None` when
    /// the tracker produced no estimate). Returns the normalised innovation
    /// squared when a measurement was used.
    pub fn update(&mut self, z: Option<Vector2<f64>>) -> Result<Option<f64>> {
        let up = self
            .kf
            .update(&self.belief, &self.measurement, z.as_ref())?;
        self.belief = up.posterior;
        Ok(up.innovation.map(|i| i.nis))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Affine2;
    use crate::dynamics::BrownianDynamics;
    use crate::group::{AffineGroup, AlgebraVector};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    #[test]
    fn predicts_constant_acceleration_displacement() {
        // x(t) = 100 + 3 t + 0.1 t^2, y(t) = 50 - 2 t (per frame).
        let truth = |k: f64| Vector2::new(100.0 + 3.0 * k + 0.1 * k * k, 50.0 - 2.0 * k);
        let mut kf =
            DisplacementPredictor::new(truth(0.0), 1.0, 1e-4, 0.5, [1.0, 5.0, 1.0]).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
        let mut errs = Vec::new();
        for k in 1..60 {
            let d = kf.predict().unwrap();
            let true_d = truth(k as f64) - truth(k as f64 - 1.0);
            if k > 20 {
                errs.push((d - true_d).norm());
            }
            let noise = Vector2::new(
                StandardNormal.sample(&mut rng),
                StandardNormal.sample(&mut rng),
            ) * 0.5;
            kf.update(Some(truth(k as f64) + noise)).unwrap();
        }
        let mean_err = errs.iter().sum::<f64>() / errs.len() as f64;
        println!("KF displacement: mean error {mean_err:.3} px per frame (true |d| ~ 7)");
        assert!(mean_err < 0.5, "{mean_err}");
        // A missing measurement keeps the prediction.
        kf.predict().unwrap();
        assert_eq!(kf.update(None).unwrap(), None);
        assert!(kf.update(Some(Vector2::new(f64::NAN, 0.0))).is_err());
        assert!(DisplacementPredictor::new(Vector2::zeros(), 0.0, 1.0, 1.0, [1.0; 3]).is_err());
    }

    #[test]
    fn drives_the_group_dynamics() {
        // Eq. 4: the KF displacement moves the previous pose, Brownian noise
        // perturbs it; with zero noise the centre lands on the KF prediction.
        let mut kf =
            DisplacementPredictor::new(Vector2::new(40.0, 30.0), 1.0, 1e-3, 0.5, [1.0, 1.0, 1.0])
                .unwrap();
        let mut m = Affine2::translation(40.0, 30.0);
        let still = BrownianDynamics::from_std(&AlgebraVector::zeros()).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        for k in 1..10 {
            let z = Vector2::new(40.0 + 2.0 * k as f64, 30.0);
            let d = kf.predict().unwrap();
            let pred = m.offset() + d;
            m = still.propagate(&m, d, &mut rng).unwrap();
            assert!((m.offset() - pred).norm() < 1e-12);
            // The "tracker" measures the true centre; feed it back.
            m = Affine2::translation(z[0], z[1]);
            kf.update(Some(z)).unwrap();
        }
        let v = kf.belief().mean()[2];
        assert!((v - 2.0).abs() < 0.3, "velocity {v}");
    }
}
