//! The common kinematic models, so that a tracker is not written element by
//! element: white-noise process covariances (filterpy's
//! `Q_discrete_white_noise` and `Q_continuous_white_noise`), constant
//! velocity and constant acceleration in any number of axes, and position
//! measurements.
//!
//! States are ordered axis by axis, each axis a block of its derivatives:
//! constant velocity in two axes is `[x, vx, y, vy]`, constant acceleration
//! `[x, vx, ax, y, vy, ay]` (filterpy's default `order_by_dim=True`). The
//! dimension `N` is the caller's const generic; the number of axes is `N`
//! divided by the block size, and a dimension that is not a multiple of it
//! is an error.
//!
//! ```
//! use bayestrack_kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement, NoiseModel};
//! use nalgebra::{Vector2, Vector4};
//!
//! // 2-D constant velocity, dt = 0.1 s, acceleration variance 0.5 (m/s^2)^2.
//! let dynamics = LinearDynamics::<4>::constant_velocity(0.1, 0.5, NoiseModel::Discrete)?;
//! let sensor = LinearMeasurement::<4, 2>::position(0.25)?; // x and y, variance 0.25
//! let kf = Kf::default();
//! let mut belief = Gaussian::new(Vector4::zeros(), nalgebra::Matrix4::identity())?;
//! for z in [Vector2::new(0.1, 0.0), Vector2::new(0.19, 0.02)] {
//!     let prior = kf.predict(&belief, &dynamics)?;
//!     belief = kf.update(&prior, &sensor, Some(&z))?.posterior;
//! }
//! assert!(belief.mean()[1] > 0.0); // some velocity along x
//! # Ok::<(), bayestrack_kalman::KalmanError>(())
//! ```

use nalgebra::SMatrix;

use crate::error::{KalmanError, Result};
use crate::model::{LinearDynamics, LinearMeasurement};

/// How the white noise enters a kinematic block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NoiseModel {
    /// Piecewise-constant white noise over each step (filterpy's
    /// `Q_discrete_white_noise`; Bar-Shalom, Li and Kirubarajan 2001,
    /// sec. 6.3): `Q = var G G^T`, rank 1 per axis. For `K = 2` the noise is
    /// the acceleration (`G = [dt^2/2, dt]`, the discrete white-noise
    /// acceleration model); for `K >= 3` it is the increment of the highest
    /// derivative (`G = [dt^(K-1)/(K-1)!, ..., dt, 1]`, the discrete Wiener
    /// process model).
    #[default]
    Discrete,
    /// Continuous white noise on the highest derivative integrated over the
    /// step (`var` is its spectral density; filterpy's
    /// `Q_continuous_white_noise`): `Q_ij = var dt^(2K-1-i-j) / ((2K-1-i-j)
    /// (K-1-i)! (K-1-j)!)`, 0-based `i, j`. Full rank.
    Continuous,
}

fn factorial(n: usize) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

fn check_step(dt: f64, var: f64) -> Result<()> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(KalmanError::InvalidParameter {
            name: "dt",
            value: dt,
            reason: "must be finite and > 0",
        });
    }
    if !(var.is_finite() && var >= 0.0) {
        return Err(KalmanError::InvalidParameter {
            name: "var",
            value: var,
            reason: "must be finite and >= 0",
        });
    }
    Ok(())
}

/// The `K x K` white-noise covariance of one axis with `K` derivatives
/// (`K = 2`: position and velocity; `3`: and acceleration; `4`: and jerk),
/// step `dt` and variance (or spectral density) `var`, as filterpy's
/// `Q_discrete_white_noise(K, dt, var)` and
/// `Q_continuous_white_noise(K, dt, var)`.
///
/// # Errors
/// [`KalmanError::InvalidParameter`] for `K` outside 2..=4 (filterpy's
/// range), a non-positive or non-finite `dt`, a negative or non-finite
/// `var`.
pub fn white_noise<const K: usize>(
    dt: f64,
    var: f64,
    model: NoiseModel,
) -> Result<SMatrix<f64, K, K>> {
    check_step(dt, var)?;
    if !(2..=4).contains(&K) {
        return Err(KalmanError::InvalidParameter {
            name: "block size",
            value: K as f64,
            reason: "white-noise blocks have 2 to 4 derivatives",
        });
    }
    let q = match model {
        NoiseModel::Discrete => {
            // G_i = dt^(p-i) / (p-i)!, p = 2 for K = 2 (acceleration
            // noise), p = K - 1 otherwise (noise on the highest derivative).
            let p = if K == 2 { 2 } else { K - 1 };
            let g = |i: usize| dt.powi((p - i) as i32) / factorial(p - i);
            SMatrix::<f64, K, K>::from_fn(|i, j| var * g(i) * g(j))
        }
        NoiseModel::Continuous => SMatrix::<f64, K, K>::from_fn(|i, j| {
            let p = 2 * K - 1 - i - j;
            var * dt.powi(p as i32) / (p as f64 * factorial(K - 1 - i) * factorial(K - 1 - j))
        }),
    };
    if q.iter().all(|v| v.is_finite()) {
        Ok(q)
    } else {
        Err(KalmanError::NonFinite {
            what: "white-noise covariance Q (dt or var too large)",
            step: crate::error::Step::Construction,
        })
    }
}

/// `F` and `Q` of `N / K` independent axes, each a chain of `K` derivatives.
fn kinematic<const N: usize, const K: usize>(
    dt: f64,
    var: f64,
    model: NoiseModel,
) -> Result<LinearDynamics<N>> {
    if N == 0 || !N.is_multiple_of(K) {
        return Err(KalmanError::DimensionMismatch {
            what: "state dimension (a whole number of axes of derivatives)",
            expected: K * N.div_ceil(K).max(1),
            got: N,
        });
    }
    let block = white_noise::<K>(dt, var, model)?;
    let mut f = SMatrix::<f64, N, N>::zeros();
    let mut q = SMatrix::<f64, N, N>::zeros();
    for axis in 0..N / K {
        let o = axis * K;
        for i in 0..K {
            for j in i..K {
                f[(o + i, o + j)] = dt.powi((j - i) as i32) / factorial(j - i);
            }
            for j in 0..K {
                q[(o + i, o + j)] = block[(i, j)];
            }
        }
    }
    LinearDynamics::new(f, q)
}

impl<const N: usize> LinearDynamics<N> {
    /// Constant velocity in `N / 2` axes, state `[x, vx, y, vy, ...]`:
    /// `F` has blocks `[[1, dt], [0, 1]]`, `Q` the white-noise block of
    /// `model` with acceleration variance (or spectral density) `var`.
    ///
    /// # Errors
    /// [`KalmanError::DimensionMismatch`] for an odd `N`;
    /// [`KalmanError::InvalidParameter`] for a bad `dt` or `var`.
    pub fn constant_velocity(dt: f64, var: f64, model: NoiseModel) -> Result<Self> {
        kinematic::<N, 2>(dt, var, model)
    }

    /// Constant acceleration in `N / 3` axes, state `[x, vx, ax, y, vy, ay,
    /// ...]`: `F` has blocks `[[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]`, `Q`
    /// the white-noise block of `model` with jerk variance (or spectral
    /// density) `var`.
    ///
    /// # Errors
    /// [`KalmanError::DimensionMismatch`] for `N` not a multiple of 3;
    /// [`KalmanError::InvalidParameter`] for a bad `dt` or `var`.
    pub fn constant_acceleration(dt: f64, var: f64, model: NoiseModel) -> Result<Self> {
        kinematic::<N, 3>(dt, var, model)
    }
}

impl<const N: usize, const M: usize> LinearMeasurement<N, M> {
    /// The position of each of the `M` axes of an `N`-dimensional
    /// kinematic state (blocks of `N / M` derivatives, position first, as
    /// [`LinearDynamics::constant_velocity`] and
    /// [`LinearDynamics::constant_acceleration`] order them), with
    /// independent noise of variance `var` on each.
    ///
    /// # Errors
    /// [`KalmanError::DimensionMismatch`] when `N` is not a multiple of `M`;
    /// [`KalmanError::InvalidParameter`] for a negative or non-finite `var`.
    pub fn position(var: f64) -> Result<Self> {
        if M == 0 || !N.is_multiple_of(M) {
            return Err(KalmanError::DimensionMismatch {
                what: "state dimension (a whole number of blocks per measured axis)",
                expected: M * N.div_ceil(M.max(1)).max(1),
                got: N,
            });
        }
        if !(var.is_finite() && var >= 0.0) {
            return Err(KalmanError::InvalidParameter {
                name: "var",
                value: var,
                reason: "must be finite and >= 0",
            });
        }
        Self::position_with_noise(SMatrix::<f64, M, M>::identity() * var)
    }

    /// [`LinearMeasurement::position`] with a full measurement noise
    /// covariance `r` (correlated axes, a different variance per axis).
    ///
    /// # Errors
    /// [`KalmanError::DimensionMismatch`] when `N` is not a multiple of `M`;
    /// the errors of [`LinearMeasurement::new`] for a bad `r`.
    pub fn position_with_noise(r: SMatrix<f64, M, M>) -> Result<Self> {
        if M == 0 || !N.is_multiple_of(M) {
            return Err(KalmanError::DimensionMismatch {
                what: "state dimension (a whole number of blocks per measured axis)",
                expected: M * N.div_ceil(M.max(1)).max(1),
                got: N,
            });
        }
        let k = N / M;
        let h = SMatrix::<f64, M, N>::from_fn(|i, j| if j == i * k { 1.0 } else { 0.0 });
        Self::new(h, r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix3, Matrix4};

    fn close<const K: usize>(a: &SMatrix<f64, K, K>, b: &SMatrix<f64, K, K>) {
        assert!(
            (a - b).abs().max() <= 1e-15 * b.abs().max().max(1.0),
            "{a}\n{b}"
        );
    }

    /// filterpy's `Q_discrete_white_noise(dim, dt, var)`, its closed forms.
    #[test]
    fn discrete_white_noise_matches_filterpy() {
        let (dt, v) = (0.1f64, 0.5);
        close(
            &white_noise::<2>(dt, v, NoiseModel::Discrete).unwrap(),
            &(Matrix2::new(dt.powi(4) / 4., dt.powi(3) / 2., dt.powi(3) / 2., dt * dt) * v),
        );
        let q3 = Matrix3::new(
            0.25 * dt.powi(4),
            0.5 * dt.powi(3),
            0.5 * dt * dt,
            0.5 * dt.powi(3),
            dt * dt,
            dt,
            0.5 * dt * dt,
            dt,
            1.,
        ) * v;
        close(&white_noise::<3>(dt, v, NoiseModel::Discrete).unwrap(), &q3);
        let q4 = Matrix4::new(
            dt.powi(6) / 36.,
            dt.powi(5) / 12.,
            dt.powi(4) / 6.,
            dt.powi(3) / 6.,
            dt.powi(5) / 12.,
            dt.powi(4) / 4.,
            dt.powi(3) / 2.,
            dt * dt / 2.,
            dt.powi(4) / 6.,
            dt.powi(3) / 2.,
            dt * dt,
            dt,
            dt.powi(3) / 6.,
            dt * dt / 2.,
            dt,
            1.,
        ) * v;
        close(&white_noise::<4>(dt, v, NoiseModel::Discrete).unwrap(), &q4);
    }

    /// filterpy's `Q_continuous_white_noise(dim, dt, spectral_density)`.
    #[test]
    fn continuous_white_noise_matches_filterpy() {
        let (dt, s) = (0.2f64, 3.0);
        close(
            &white_noise::<2>(dt, s, NoiseModel::Continuous).unwrap(),
            &(Matrix2::new(dt.powi(3) / 3., dt * dt / 2., dt * dt / 2., dt) * s),
        );
        let q3 = Matrix3::new(
            dt.powi(5) / 20.,
            dt.powi(4) / 8.,
            dt.powi(3) / 6.,
            dt.powi(4) / 8.,
            dt.powi(3) / 3.,
            dt * dt / 2.,
            dt.powi(3) / 6.,
            dt * dt / 2.,
            dt,
        ) * s;
        close(
            &white_noise::<3>(dt, s, NoiseModel::Continuous).unwrap(),
            &q3,
        );
        let q4 = Matrix4::new(
            dt.powi(7) / 252.,
            dt.powi(6) / 72.,
            dt.powi(5) / 30.,
            dt.powi(4) / 24.,
            dt.powi(6) / 72.,
            dt.powi(5) / 20.,
            dt.powi(4) / 8.,
            dt.powi(3) / 6.,
            dt.powi(5) / 30.,
            dt.powi(4) / 8.,
            dt.powi(3) / 3.,
            dt * dt / 2.,
            dt.powi(4) / 24.,
            dt.powi(3) / 6.,
            dt * dt / 2.,
            dt,
        ) * s;
        close(
            &white_noise::<4>(dt, s, NoiseModel::Continuous).unwrap(),
            &q4,
        );
    }

    #[test]
    fn constant_velocity_and_acceleration_blocks() {
        let dt = 0.5;
        let cv = LinearDynamics::<4>::constant_velocity(dt, 2.0, NoiseModel::Discrete).unwrap();
        let f = cv.transition();
        assert_eq!(
            (f[(0, 1)], f[(2, 3)], f[(0, 2)], f[(1, 0)]),
            (dt, dt, 0.0, 0.0)
        );
        let q2 = white_noise::<2>(dt, 2.0, NoiseModel::Discrete).unwrap();
        assert_eq!(cv.noise().fixed_view::<2, 2>(2, 2), q2);
        assert_eq!(cv.noise()[(0, 2)], 0.0);
        let ca =
            LinearDynamics::<6>::constant_acceleration(dt, 1.0, NoiseModel::Continuous).unwrap();
        let f = ca.transition();
        assert_eq!((f[(3, 5)], f[(4, 5)], f[(3, 4)]), (dt * dt / 2.0, dt, dt));
        let h = LinearMeasurement::<6, 2>::position(0.3).unwrap();
        assert_eq!(h.matrix()[(0, 0)], 1.0);
        assert_eq!(h.matrix()[(1, 3)], 1.0);
        assert_eq!(h.matrix().sum(), 2.0);
        assert_eq!(h.noise()[(1, 1)], 0.3);
    }

    /// Propagating a noiseless state with F is exact kinematics.
    #[test]
    fn transition_is_exact_kinematics() {
        let dt = 0.25;
        let ca = LinearDynamics::<3>::constant_acceleration(dt, 0.0, NoiseModel::Discrete).unwrap();
        let x = nalgebra::Vector3::new(1.0, 2.0, 4.0);
        let y = ca.transition() * x;
        assert_eq!(
            y,
            nalgebra::Vector3::new(1.0 + 2.0 * dt + 2.0 * dt * dt, 2.0 + 4.0 * dt, 4.0)
        );
    }

    #[test]
    fn bad_dimensions_and_parameters_are_errors() {
        assert!(matches!(
            LinearDynamics::<5>::constant_velocity(0.1, 1.0, NoiseModel::Discrete),
            Err(KalmanError::DimensionMismatch { got: 5, .. })
        ));
        assert!(matches!(
            LinearDynamics::<4>::constant_acceleration(0.1, 1.0, NoiseModel::Discrete),
            Err(KalmanError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            LinearMeasurement::<5, 2>::position(1.0),
            Err(KalmanError::DimensionMismatch { .. })
        ));
        for (dt, var) in [
            (0.0, 1.0),
            (f64::NAN, 1.0),
            (0.1, -1.0),
            (0.1, f64::INFINITY),
        ] {
            assert!(matches!(
                LinearDynamics::<4>::constant_velocity(dt, var, NoiseModel::Continuous),
                Err(KalmanError::InvalidParameter { .. })
            ));
        }
        assert!(LinearDynamics::<2>::constant_velocity(1e200, 1.0, NoiseModel::Discrete).is_err());
    }
}
