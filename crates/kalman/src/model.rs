//! Model traits: what a user plugs into the filters.
//!
//! Additive-noise models (`x_k = f(x_{k-1}) + v`, `z = h(x) + n`) implement
//! [`Dynamics`] and [`Measurement`], plus the `*Jacobian` traits for the EKF
//! and IEKF. Models whose noise enters non-additively (the augmented UKF of
//! Nagy, Ahmed and Zayed (paper 000) sec. 3.3, `x_a = [x, v, n]`) implement [`NoisyDynamics`] and
//! [`NoisyMeasurement`]; [`Additive`] turns an additive model into one.
//! States and measurements that are not plain vectors (angles) name their
//! [`Manifold`].

use nalgebra::{SMatrix, SVector};

use crate::error::{Result, Step};
use crate::gaussian::Gaussian;
use crate::linalg;

/// A noise covariance checked once: finite, symmetric (to a relative 1e-9,
/// then stored as `(A + A^T) / 2`) and positive semi-definite (singular is
/// accepted). A model whose `Q` or `R` does not change returns one from
/// [`Dynamics::checked_process_noise`] or
/// [`Measurement::checked_measurement_noise`], and the filters skip the
/// per-step check of the matrix.
///
/// ```
/// use bayestrack_kalman::{KalmanError, NoiseCovariance};
/// use nalgebra::Matrix2;
///
/// let q = NoiseCovariance::new(Matrix2::new(1e-8, 0.0, 0.0, 1e-6))?;
/// assert_eq!(q.matrix()[(1, 1)], 1e-6);
/// assert!(NoiseCovariance::new(Matrix2::new(-1.0, 0.0, 0.0, 1.0)).is_err());
/// # Ok::<(), KalmanError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseCovariance<const D: usize>(SMatrix<f64, D, D>);

impl<const D: usize> NoiseCovariance<D> {
    /// Checks `m`.
    ///
    /// # Errors
    /// [`KalmanError::NonFinite`](crate::KalmanError::NonFinite),
    /// [`KalmanError::NotSymmetric`](crate::KalmanError::NotSymmetric) or
    /// [`KalmanError::NotPositiveDefinite`](crate::KalmanError::NotPositiveDefinite)
    /// naming "noise covariance" in the construction step.
    pub fn new(m: SMatrix<f64, D, D>) -> Result<Self> {
        Self::named(m, "noise covariance", Step::Construction)
    }

    /// [`NoiseCovariance::new`] with the matrix and step named in errors.
    #[inline(always)]
    pub(crate) fn named(m: SMatrix<f64, D, D>, matrix: &'static str, step: Step) -> Result<Self> {
        linalg::check_noise(&m, matrix, step)?;
        Ok(Self(linalg::symmetrize(&m)))
    }

    /// The matrix (exactly symmetric).
    #[inline]
    pub fn matrix(&self) -> &SMatrix<f64, D, D> {
        &self.0
    }
}

/// The space a state or a measurement lives in, as the filters see it:
/// the difference of two points and a point moved by a vector (the
/// `[-]` and `[+]` of Hertzberg et al. 2013; filterpy's `residual_x` /
/// `residual_z` and `x_mean_fn` / `z_mean_fn`). The one hook for states
/// and measurements that are not plain vectors: a model returns one from
/// [`Dynamics::state_space`], [`Measurement::measurement_space`] (and the
/// same methods of [`NoisyDynamics`] and [`NoisyMeasurement`]), and every
/// filter of the crate (KF, EKF, IEKF, UKF, CKF, SR-UKF, the augmented UKF
/// and the RTS smoothers) takes its differences and means through it.
///
/// The sigma-point mean is `center [+] offset`, with `center` the central
/// point and `offset` the weighted mean of the residuals `X_i [-] center`
/// of the other points (one step of the mean on a manifold): with a
/// wrapping residual and a wrapping `[+]`, the circular mean of points that
/// span less than half a turn.
///
/// Both methods default to plain arithmetic ([`Euclidean`]).
///
/// ```
/// use bayestrack_kalman::{Angles, Euclidean, Manifold};
/// use nalgebra::Vector2;
///
/// // a position and a heading
/// let space = Angles::new([false, true]);
/// let a = Vector2::new(1.0, 3.1);
/// let b = Vector2::new(0.5, -3.1);
/// let d = space.residual(&a, &b);
/// assert!((d[1] - (6.2 - std::f64::consts::TAU)).abs() < 1e-12);
/// assert_eq!(Euclidean.residual(&a, &b), a - b);
/// ```
pub trait Manifold<const D: usize> {
    /// `a [-] b`: the vector that takes `b` to `a`.
    #[inline(always)]
    fn residual(&self, a: &SVector<f64, D>, b: &SVector<f64, D>) -> SVector<f64, D> {
        a - b
    }

    /// `center [+] offset`: `center` moved by `offset`.
    #[inline(always)]
    fn boxplus(&self, center: &SVector<f64, D>, offset: &SVector<f64, D>) -> SVector<f64, D> {
        center + offset
    }
}

/// The vector space `R^D`: plain subtraction and addition (the default
/// [`Manifold`] of every model).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Euclidean;

impl<const D: usize> Manifold<D> for Euclidean {}

impl<const D: usize, T: Manifold<D> + ?Sized> Manifold<D> for &T {
    #[inline(always)]
    fn residual(&self, a: &SVector<f64, D>, b: &SVector<f64, D>) -> SVector<f64, D> {
        (**self).residual(a, b)
    }
    #[inline(always)]
    fn boxplus(&self, center: &SVector<f64, D>, offset: &SVector<f64, D>) -> SVector<f64, D> {
        (**self).boxplus(center, offset)
    }
}

/// Vectors some of whose components are angles in radians: those
/// components of a residual and of `[+]` are wrapped to `(-pi, pi]`, the
/// others are plain arithmetic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Angles<const D: usize> {
    angle: [bool; D],
}

impl<const D: usize> Angles<D> {
    /// `angle[i]`: component `i` is an angle.
    pub const fn new(angle: [bool; D]) -> Self {
        Self { angle }
    }

    /// Which components are angles.
    pub const fn mask(&self) -> &[bool; D] {
        &self.angle
    }

    /// `v` with its angle components wrapped to `(-pi, pi]` (a non-finite
    /// component stays non-finite, and the filters report it).
    #[inline]
    pub fn wrap(&self, mut v: SVector<f64, D>) -> SVector<f64, D> {
        for (x, &is_angle) in v.iter_mut().zip(&self.angle) {
            if is_angle {
                *x = wrap_angle(*x);
            }
        }
        v
    }
}

/// `a` wrapped to `(-pi, pi]` (the range of `atan2`).
#[inline]
fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if a > -PI && a <= PI {
        a
    } else {
        let w = (a + PI).rem_euclid(TAU) - PI;
        if w == -PI { PI } else { w }
    }
}

impl<const D: usize> Manifold<D> for Angles<D> {
    #[inline]
    fn residual(&self, a: &SVector<f64, D>, b: &SVector<f64, D>) -> SVector<f64, D> {
        self.wrap(a - b)
    }
    #[inline]
    fn boxplus(&self, center: &SVector<f64, D>, offset: &SVector<f64, D>) -> SVector<f64, D> {
        self.wrap(center + offset)
    }
}

/// `Q` of `dynamics` for a filter step: the model's checked matrix, or
/// [`Dynamics::process_noise`] checked now (named "process noise Q" in
/// `step`); exactly symmetric either way.
#[inline(always)]
pub(crate) fn process_noise<const N: usize, D: Dynamics<N> + ?Sized>(
    dynamics: &D,
    step: Step,
) -> Result<SMatrix<f64, N, N>> {
    match dynamics.checked_process_noise() {
        Some(q) => Ok(q.0),
        None => Ok(NoiseCovariance::named(dynamics.process_noise(), "process noise Q", step)?.0),
    }
}

/// `R` of `measurement` for a filter step, as [`process_noise`]
/// ("measurement noise R", update step).
#[inline(always)]
pub(crate) fn measurement_noise<const N: usize, const M: usize, H: Measurement<N, M> + ?Sized>(
    measurement: &H,
) -> Result<SMatrix<f64, M, M>> {
    match measurement.checked_measurement_noise() {
        Some(r) => Ok(r.0),
        None => Ok(NoiseCovariance::named(
            measurement.measurement_noise(),
            "measurement noise R",
            Step::Update,
        )?
        .0),
    }
}

/// State transition with additive noise: `x_k = f(x_{k-1}) + v`, `v ~ N(0, Q)`.
pub trait Dynamics<const N: usize> {
    /// `f(x)`.
    fn propagate(&self, x: &SVector<f64, N>) -> SVector<f64, N>;
    /// `Q`, the covariance of the additive process noise.
    fn process_noise(&self) -> SMatrix<f64, N, N>;

    /// `Q` checked once, for a model whose `Q` does not change: the filters
    /// then use it and skip checking [`Dynamics::process_noise`] (finite,
    /// symmetric, positive semi-definite) on every step. It must be the
    /// same matrix. The default, `None`, has every step check `Q`.
    #[inline(always)]
    fn checked_process_noise(&self) -> Option<NoiseCovariance<N>> {
        None
    }

    /// The space of the state: how the sigma-point filters difference and
    /// average states ([`Manifold`]). The default, [`Euclidean`], is plain
    /// arithmetic; return an [`Angles`] (or your own [`Manifold`]) for a
    /// state with angles. Every filter and smoother of the crate takes the
    /// state's residuals and means through it.
    #[inline(always)]
    fn state_space(&self) -> impl Manifold<N> {
        Euclidean
    }
}

/// The Jacobian `F = df/dx` of a [`Dynamics`] (EKF, IEKF).
pub trait DynamicsJacobian<const N: usize>: Dynamics<N> {
    /// `df/dx` at `x`.
    fn jacobian(&self, x: &SVector<f64, N>) -> SMatrix<f64, N, N>;
}

/// Measurement with additive noise: `z = h(x) + n`, `n ~ N(0, R)`.
pub trait Measurement<const N: usize, const M: usize> {
    /// `h(x)`.
    fn observe(&self, x: &SVector<f64, N>) -> SVector<f64, M>;
    /// `R`, the covariance of the additive measurement noise.
    fn measurement_noise(&self) -> SMatrix<f64, M, M>;

    /// `R` checked once, as [`Dynamics::checked_process_noise`].
    #[inline(always)]
    fn checked_measurement_noise(&self) -> Option<NoiseCovariance<M>> {
        None
    }

    /// The space of the measurement ([`Manifold`]): the innovation
    /// `z [-] z_hat` of every filter, and the differences and mean of the
    /// UKF's sigma points in measurement space, are taken through it. The
    /// default, [`Euclidean`], is plain arithmetic; return an [`Angles`]
    /// for a measurement with angles (a bearing).
    #[inline(always)]
    fn measurement_space(&self) -> impl Manifold<M> {
        Euclidean
    }
}

/// The Jacobian `H = dh/dx` of a [`Measurement`] (EKF, IEKF).
pub trait MeasurementJacobian<const N: usize, const M: usize>: Measurement<N, M> {
    /// `dh/dx` at `x`.
    fn jacobian(&self, x: &SVector<f64, N>) -> SMatrix<f64, M, N>;
}

/// State transition with general noise: `x_k = f(x_{k-1}, v)`, `v ~ N(mu_v, Q_v)`.
///
/// The noise may have a non-zero mean (a Gaussian moment match of, say, the
/// Gamma noise of the `hikpf` model).
pub trait NoisyDynamics<const N: usize, const V: usize> {
    /// `f(x, v)`.
    fn propagate_with(&self, x: &SVector<f64, N>, v: &SVector<f64, V>) -> SVector<f64, N>;
    /// The distribution of `v`.
    fn process_noise_dist(&self) -> Gaussian<V>;

    /// The space of the state, as [`Dynamics::state_space`] (the augmented
    /// UKF differences and averages its propagated sigma points in it).
    #[inline(always)]
    fn state_space(&self) -> impl Manifold<N> {
        Euclidean
    }
}

/// Measurement with general noise: `z = h(x, n)`, `n ~ N(mu_n, R_n)`.
pub trait NoisyMeasurement<const N: usize, const M: usize, const W: usize> {
    /// `h(x, n)`.
    fn observe_with(&self, x: &SVector<f64, N>, n: &SVector<f64, W>) -> SVector<f64, M>;
    /// The distribution of `n`.
    fn measurement_noise_dist(&self) -> Gaussian<W>;

    /// The space of the measurement, as [`Measurement::measurement_space`].
    #[inline(always)]
    fn measurement_space(&self) -> impl Manifold<M> {
        Euclidean
    }
}

/// Adapter: an additive-noise model seen as a general-noise one
/// (`f(x, v) = f(x) + v`, `v ~ N(0, Q)`), for the augmented UKF. The
/// model's [`Manifold`]s carry over.
#[derive(Debug, Clone, Copy)]
pub struct Additive<'a, T>(pub &'a T);

impl<const N: usize, T: Dynamics<N>> NoisyDynamics<N, N> for Additive<'_, T> {
    fn propagate_with(&self, x: &SVector<f64, N>, v: &SVector<f64, N>) -> SVector<f64, N> {
        self.0.propagate(x) + v
    }
    fn process_noise_dist(&self) -> Gaussian<N> {
        Gaussian::from_parts(SVector::zeros(), self.0.process_noise())
    }
    fn state_space(&self) -> impl Manifold<N> {
        self.0.state_space()
    }
}

impl<const N: usize, const M: usize, T: Measurement<N, M>> NoisyMeasurement<N, M, M>
    for Additive<'_, T>
{
    fn observe_with(&self, x: &SVector<f64, N>, n: &SVector<f64, M>) -> SVector<f64, M> {
        self.0.observe(x) + n
    }
    fn measurement_noise_dist(&self) -> Gaussian<M> {
        Gaussian::from_parts(SVector::zeros(), self.0.measurement_noise())
    }
    fn measurement_space(&self) -> impl Manifold<M> {
        self.0.measurement_space()
    }
}

/// Linear dynamics `x_k = F x_{k-1} + B u + v`, `v ~ N(0, Q)`, with a control
/// input of dimension `U` (0 for none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearDynamics<const N: usize, const U: usize = 0> {
    f: SMatrix<f64, N, N>,
    b: SMatrix<f64, N, U>,
    q: SMatrix<f64, N, N>,
}

impl<const N: usize> LinearDynamics<N, 0> {
    /// `x_k = F x_{k-1} + v`, `v ~ N(0, Q)`.
    ///
    /// # Errors
    /// Non-finite `F` or `Q`; `Q` not symmetric positive semi-definite.
    pub fn new(f: SMatrix<f64, N, N>, q: SMatrix<f64, N, N>) -> Result<Self> {
        Self::with_control(f, SMatrix::zeros(), q)
    }
}

impl<const N: usize, const U: usize> LinearDynamics<N, U> {
    /// `x_k = F x_{k-1} + B u + v`, `v ~ N(0, Q)`.
    ///
    /// # Errors
    /// Non-finite `F`, `B` or `Q`; `Q` not symmetric positive semi-definite.
    pub fn with_control(
        f: SMatrix<f64, N, N>,
        b: SMatrix<f64, N, U>,
        q: SMatrix<f64, N, N>,
    ) -> Result<Self> {
        linalg::check_finite_mat(&f, "transition matrix F", Step::Construction)?;
        linalg::check_finite_mat(&b, "control matrix B", Step::Construction)?;
        linalg::check_covariance(&q, "process noise Q", Step::Construction)?;
        linalg::user_psd_sqrt(&q, "process noise Q", Step::Construction)?;
        // symmetrised once here instead of on every step (the same bits:
        // `(Q + Q^T) / 2` is what each step formed)
        Ok(Self {
            f,
            b,
            q: linalg::symmetrize(&q),
        })
    }

    /// `F`.
    pub fn transition(&self) -> &SMatrix<f64, N, N> {
        &self.f
    }

    /// `B`.
    pub fn control(&self) -> &SMatrix<f64, N, U> {
        &self.b
    }

    /// `Q`, symmetrised (`(Q + Q^T) / 2` of the matrix given, which passed
    /// the symmetry check to a relative 1e-9).
    pub fn noise(&self) -> &SMatrix<f64, N, N> {
        &self.q
    }
}

impl<const N: usize, const U: usize> Dynamics<N> for LinearDynamics<N, U> {
    #[inline]
    fn propagate(&self, x: &SVector<f64, N>) -> SVector<f64, N> {
        self.f * x
    }
    #[inline]
    fn process_noise(&self) -> SMatrix<f64, N, N> {
        self.q
    }
    #[inline(always)]
    fn checked_process_noise(&self) -> Option<NoiseCovariance<N>> {
        // checked and symmetrised by the constructor
        Some(NoiseCovariance(self.q))
    }
}

impl<const N: usize, const U: usize> DynamicsJacobian<N> for LinearDynamics<N, U> {
    #[inline]
    fn jacobian(&self, _x: &SVector<f64, N>) -> SMatrix<f64, N, N> {
        self.f
    }
}

/// Linear measurement `z = H x + n`, `n ~ N(0, R)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearMeasurement<const N: usize, const M: usize> {
    h: SMatrix<f64, M, N>,
    r: SMatrix<f64, M, M>,
}

impl<const N: usize, const M: usize> LinearMeasurement<N, M> {
    /// `z = H x + n`, `n ~ N(0, R)`.
    ///
    /// # Errors
    /// Non-finite `H` or `R`; `R` not symmetric positive semi-definite.
    pub fn new(h: SMatrix<f64, M, N>, r: SMatrix<f64, M, M>) -> Result<Self> {
        linalg::check_finite_mat(&h, "measurement matrix H", Step::Construction)?;
        linalg::check_covariance(&r, "measurement noise R", Step::Construction)?;
        linalg::user_psd_sqrt(&r, "measurement noise R", Step::Construction)?;
        Ok(Self {
            h,
            r: linalg::symmetrize(&r),
        })
    }

    /// `H`.
    pub fn matrix(&self) -> &SMatrix<f64, M, N> {
        &self.h
    }

    /// `R`, symmetrised (`(R + R^T) / 2` of the matrix given).
    pub fn noise(&self) -> &SMatrix<f64, M, M> {
        &self.r
    }
}

impl<const N: usize, const M: usize> Measurement<N, M> for LinearMeasurement<N, M> {
    #[inline]
    fn observe(&self, x: &SVector<f64, N>) -> SVector<f64, M> {
        self.h * x
    }
    #[inline]
    fn measurement_noise(&self) -> SMatrix<f64, M, M> {
        self.r
    }
    #[inline(always)]
    fn checked_measurement_noise(&self) -> Option<NoiseCovariance<M>> {
        Some(NoiseCovariance(self.r))
    }
}

impl<const N: usize, const M: usize> MeasurementJacobian<N, M> for LinearMeasurement<N, M> {
    #[inline]
    fn jacobian(&self, _x: &SVector<f64, N>) -> SMatrix<f64, M, N> {
        self.h
    }
}
