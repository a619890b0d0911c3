//! The Kalman family with filterpy's names: `KalmanFilter`,
//! `ExtendedKalmanFilter`, `IteratedExtendedKalmanFilter` and
//! `UnscentedKalmanFilter`, and the hybrid UKF -> IEKF step
//! `HybridUkfIekf`.

use std::cell::RefCell;

use bayestrack_kalman::HybridUkfIekf as RustHybrid;
use bayestrack_kalman::{
    Additive, CovarianceUpdate, Ekf, FnDynamics, FnMeasurement, Gaussian, HybridPrior, Iekf, Kf,
    LinearDynamics, LinearMeasurement, Ukf, Update,
};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use numpy::{PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat};

use crate::pymap::{PyMap, Shape};
use crate::util::{
    Fail, Res, check_dims, dispatch_m, dispatch_n, dispatch_nm, dm, dv, matrix, prefer_stored,
    py_mat, py_vec, read_f64, sm, sv, to_py_err, vector,
};

// ---------------------------------------------------------------- state

/// The belief and model matrices as numpy arrays the user may also modify
/// in place (`kf.P *= 1000`, `kf.x[0] = 1`), read and checked on every step.
struct Arrays {
    dim_x: usize,
    dim_z: usize,
    x: Py<PyAny>,
    p: Py<PyAny>,
    q: Py<PyAny>,
    r: Py<PyAny>,
    y: Py<PyAny>,
    s: Py<PyAny>,
    log_likelihood: f64,
}

impl Arrays {
    fn new(py: Python<'_>, dim_x: usize, dim_z: usize, column: bool) -> PyResult<Self> {
        let x = DVector::zeros(dim_x);
        Ok(Self {
            dim_x,
            dim_z,
            x: store_x(py, &x, column)?,
            p: py_mat(py, &DMatrix::identity(dim_x, dim_x))
                .into_any()
                .unbind(),
            q: py_mat(py, &DMatrix::identity(dim_x, dim_x))
                .into_any()
                .unbind(),
            r: py_mat(py, &DMatrix::identity(dim_z, dim_z))
                .into_any()
                .unbind(),
            y: store_x(py, &DVector::zeros(dim_z), column)?,
            s: py_mat(py, &DMatrix::zeros(dim_z, dim_z))
                .into_any()
                .unbind(),
            log_likelihood: f64::NAN,
        })
    }

    fn x(&self, py: Python<'_>) -> PyResult<DVector<f64>> {
        vector(self.x.bind(py), self.dim_x, "x")
    }

    fn is_column(&self, py: Python<'_>) -> PyResult<bool> {
        let (shape, _) = read_f64(self.x.bind(py), "x")?;
        Ok(shape.len() == 2)
    }

    fn p(&self, py: Python<'_>) -> PyResult<DMatrix<f64>> {
        matrix(self.p.bind(py), self.dim_x, self.dim_x, "P")
    }

    fn q(&self, py: Python<'_>) -> PyResult<DMatrix<f64>> {
        matrix(self.q.bind(py), self.dim_x, self.dim_x, "Q")
    }

    fn r(&self, py: Python<'_>, r: Option<&Bound<'_, PyAny>>) -> PyResult<DMatrix<f64>> {
        match r {
            // filterpy accepts a scalar R as R * I
            Some(r) if r.is_instance_of::<PyFloat>() || r.extract::<i64>().is_ok() => {
                let v: f64 = r.extract()?;
                if !v.is_finite() {
                    return Err(PyValueError::new_err("R contains NaN or infinity"));
                }
                Ok(DMatrix::identity(self.dim_z, self.dim_z) * v)
            }
            Some(r) => matrix(r, self.dim_z, self.dim_z, "R"),
            None => matrix(self.r.bind(py), self.dim_z, self.dim_z, "R"),
        }
    }

    fn set_belief(&mut self, py: Python<'_>, x: &DVector<f64>, p: &DMatrix<f64>) -> PyResult<()> {
        let column = self.is_column(py)?;
        self.x = store_x(py, x, column)?;
        self.p = py_mat(py, p).into_any().unbind();
        Ok(())
    }

    fn set_update(&mut self, py: Python<'_>, u: &UpdOut) -> PyResult<()> {
        self.set_belief(py, &u.x, &u.p)?;
        let column = self.is_column(py)?;
        match &u.innovation {
            Some((y, s, ll)) => {
                self.y = store_x(py, y, column)?;
                self.s = py_mat(py, s).into_any().unbind();
                self.log_likelihood = *ll;
            }
            None => {
                // filterpy: a missing measurement leaves y = 0
                self.y = store_x(py, &DVector::zeros(self.dim_z), column)?;
            }
        }
        Ok(())
    }
}

/// `x` as stored: `(n, 1)` (filterpy's KF/EKF) or `(n,)` (its UKF).
fn store_x(py: Python<'_>, x: &DVector<f64>, column: bool) -> PyResult<Py<PyAny>> {
    if column {
        Ok(
            py_mat(py, &DMatrix::from_column_slice(x.len(), 1, x.as_slice()))
                .into_any()
                .unbind(),
        )
    } else {
        Ok(py_vec(py, x).into_any().unbind())
    }
}

/// Checks `value` as a vector of `n` and stores a float64 copy with its
/// shape (`(n,)` or `(n, 1)`).
fn checked_x(value: &Bound<'_, PyAny>, n: usize, name: &str) -> PyResult<Py<PyAny>> {
    let (shape, _) = read_f64(value, name)?;
    let v = vector(value, n, name)?;
    store_x(value.py(), &v, shape.len() == 2)
}

fn checked_matrix(value: &Bound<'_, PyAny>, r: usize, c: usize, name: &str) -> PyResult<Py<PyAny>> {
    let m = matrix(value, r, c, name)?;
    Ok(py_mat(value.py(), &m).into_any().unbind())
}

fn covariance_update(joseph: bool) -> CovarianceUpdate {
    if joseph {
        CovarianceUpdate::Joseph
    } else {
        CovarianceUpdate::Standard
    }
}

// ----------------------------------------------------- generic steps

/// A posterior with its innovation `(y, S, log-likelihood)`.
struct UpdOut {
    x: DVector<f64>,
    p: DMatrix<f64>,
    innovation: Option<(DVector<f64>, DMatrix<f64>, f64)>,
    iterations: usize,
}

fn upd_out<const N: usize, const M: usize>(u: &Update<N, M>) -> UpdOut {
    UpdOut {
        x: dv(u.posterior.mean()),
        p: dm(u.posterior.cov()),
        innovation: u
            .innovation
            .as_ref()
            .map(|i| (dv(&i.residual), dm(&i.covariance), i.log_likelihood())),
        iterations: u.iterations,
    }
}

fn belief<const N: usize>(x: &DVector<f64>, p: &DMatrix<f64>) -> Res<Gaussian<N>> {
    Ok(Gaussian::new(sv(x), sm(p))?)
}

/// `B` (`N x U`, `U <= N`) and `u` padded with zeros to `N x N` and `N`.
fn pad_control<const N: usize>(
    b: &DMatrix<f64>,
    u: &DVector<f64>,
) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
    let mut bb = SMatrix::<f64, N, N>::zeros();
    let mut uu = SVector::<f64, N>::zeros();
    for j in 0..u.len() {
        uu[j] = u[j];
        for i in 0..N {
            bb[(i, j)] = b[(i, j)];
        }
    }
    (bb, uu)
}

type Control<'a> = Option<(&'a DMatrix<f64>, &'a DVector<f64>)>;

fn linear_predict<const N: usize>(
    kf: &Kf,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    f: &DMatrix<f64>,
    q: &DMatrix<f64>,
    control: Control<'_>,
) -> Res<(DVector<f64>, DMatrix<f64>)> {
    let g = belief::<N>(x, p)?;
    let out = match control {
        None => kf.predict(&g, &LinearDynamics::<N, 0>::new(sm(f), sm(q))?)?,
        Some((b, u)) => {
            let (bb, uu) = pad_control::<N>(b, u);
            let model = LinearDynamics::<N, N>::with_control(sm(f), bb, sm(q))?;
            kf.predict_with_control(&g, &model, &uu)?
        }
    };
    Ok((dv(out.mean()), dm(out.cov())))
}

fn linear_update<const N: usize, const M: usize>(
    kf: &Kf,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    h: &DMatrix<f64>,
    r: &DMatrix<f64>,
    z: Option<&DVector<f64>>,
) -> Res<UpdOut> {
    let g = belief::<N>(x, p)?;
    let model = LinearMeasurement::<N, M>::new(sm(h), sm(r))?;
    let z = z.map(sv::<M>);
    Ok(upd_out(&kf.update(&g, &model, z.as_ref())?))
}

/// Everything `batch_filter` needs, owned (it runs without the GIL).
struct BatchIn {
    kf: Kf,
    x: DVector<f64>,
    p: DMatrix<f64>,
    f: DMatrix<f64>,
    q: DMatrix<f64>,
    h: DMatrix<f64>,
    r: DMatrix<f64>,
    b: Option<DMatrix<f64>>,
    /// `T x dim_u` controls, row-major, or empty.
    us: Vec<f64>,
    dim_u: usize,
    /// `T x dim_z` measurements, row-major; `present[k]` false = missing.
    zs: Vec<f64>,
    present: Vec<bool>,
}

/// Row-major results of `batch_filter`.
#[derive(Default)]
struct BatchOut {
    means: Vec<f64>,
    covs: Vec<f64>,
    means_p: Vec<f64>,
    covs_p: Vec<f64>,
    last: Option<UpdOut>,
}

fn push_belief<const N: usize>(means: &mut Vec<f64>, covs: &mut Vec<f64>, g: &Gaussian<N>) {
    means.extend_from_slice(g.mean().as_slice());
    let c = g.cov();
    for i in 0..N {
        for j in 0..N {
            covs.push(c[(i, j)]);
        }
    }
}

fn linear_batch<const N: usize, const M: usize>(b: &BatchIn) -> Res<BatchOut> {
    let t = b.present.len();
    let mut g = belief::<N>(&b.x, &b.p)?;
    let plain = LinearDynamics::<N, 0>::new(sm(&b.f), sm(&b.q))?;
    let controlled = match &b.b {
        Some(bm) if b.dim_u > 0 => {
            let (bb, _) = pad_control::<N>(bm, &DVector::zeros(b.dim_u));
            Some(LinearDynamics::<N, N>::with_control(
                sm(&b.f),
                bb,
                sm(&b.q),
            )?)
        }
        _ => None,
    };
    let sensor = LinearMeasurement::<N, M>::new(sm(&b.h), sm(&b.r))?;
    let mut out = BatchOut {
        means: Vec::with_capacity(t * N),
        covs: Vec::with_capacity(t * N * N),
        means_p: Vec::with_capacity(t * N),
        covs_p: Vec::with_capacity(t * N * N),
        last: None,
    };
    let mut last = None;
    for k in 0..t {
        let prior = match &controlled {
            Some(model) => {
                let mut uu = SVector::<f64, N>::zeros();
                uu.as_mut_slice()[..b.dim_u].copy_from_slice(&b.us[k * b.dim_u..(k + 1) * b.dim_u]);
                b.kf.predict_with_control(&g, model, &uu)?
            }
            None => b.kf.predict(&g, &plain)?,
        };
        push_belief(&mut out.means_p, &mut out.covs_p, &prior);
        let z =
            b.present[k].then(|| SVector::<f64, M>::from_column_slice(&b.zs[k * M..(k + 1) * M]));
        let u = b.kf.update(&prior, &sensor, z.as_ref())?;
        g = u.posterior;
        push_belief(&mut out.means, &mut out.covs, &g);
        last = Some(u);
    }
    out.last = last.as_ref().map(upd_out);
    Ok(out)
}

fn linear_rts<const N: usize>(
    kf: &Kf,
    xs: &[f64],
    ps: &[f64],
    f: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Res<(Vec<f64>, Vec<f64>)> {
    let filtered = beliefs::<N>(xs, ps)?;
    let model = LinearDynamics::<N, 0>::new(sm(f), sm(q))?;
    let smoothed = kf.rts_smooth(&filtered, &model, None)?;
    Ok(flatten(&smoothed))
}

fn beliefs<const N: usize>(xs: &[f64], ps: &[f64]) -> Res<Vec<Gaussian<N>>> {
    xs.chunks_exact(N)
        .zip(ps.chunks_exact(N * N))
        .map(|(x, p)| {
            Ok(Gaussian::new(
                SVector::from_column_slice(x),
                SMatrix::from_row_slice(p),
            )?)
        })
        .collect()
}

fn flatten<const N: usize>(gs: &[Gaussian<N>]) -> (Vec<f64>, Vec<f64>) {
    let mut m = Vec::with_capacity(gs.len() * N);
    let mut c = Vec::with_capacity(gs.len() * N * N);
    for g in gs {
        push_belief(&mut m, &mut c, g);
    }
    (m, c)
}

// ----------------------------------------------------- numpy helpers

/// Measurements for a batch: a `(T, m)` (or `(T,)` when `m == 1`) float
/// array, or a sequence whose items are vectors or `None` (missing).
fn read_zs(zs: &Bound<'_, PyAny>, m: usize) -> PyResult<(Vec<f64>, Vec<bool>)> {
    if let Ok(arr) = zs.cast::<PyArrayDyn<f64>>() {
        let ro = arr
            .try_readonly()
            .map_err(|e| PyValueError::new_err(format!("zs cannot be read: {e}")))?;
        let view = ro.as_array();
        let shape = view.shape().to_vec();
        let ok = (shape.len() == 2 && shape[1] == m)
            || (shape.len() == 3 && shape[1] == m && shape[2] == 1)
            || (shape.len() == 1 && m == 1);
        if !ok {
            return Err(PyValueError::new_err(format!(
                "zs must have shape (T, {m}), got {shape:?}"
            )));
        }
        let v: Vec<f64> = view.iter().copied().collect();
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "zs[{}] contains NaN or infinity (pass None for a missing measurement)",
                i / m
            )));
        }
        let t = v.len() / m;
        return Ok((v, vec![true; t]));
    }
    let mut v = Vec::new();
    let mut present = Vec::new();
    for (k, item) in zs.try_iter()?.enumerate() {
        let item = item?;
        if item.is_none() {
            v.extend(std::iter::repeat_n(0.0, m));
            present.push(false);
        } else {
            let z = vector(&item, m, &format!("zs[{k}]"))?;
            v.extend_from_slice(z.as_slice());
            present.push(true);
        }
    }
    Ok((v, present))
}

/// Filtered means `(T, n)` or `(T, n, 1)` and covariances `(T, n, n)`.
fn read_beliefs(
    xs: &Bound<'_, PyAny>,
    ps: &Bound<'_, PyAny>,
    n: usize,
) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let (xshape, xv) = read_f64(xs, "Xs")?;
    let (pshape, pv) = read_f64(ps, "Ps")?;
    let t = xshape.first().copied().unwrap_or(0);
    let xok = xshape == [t, n] || xshape == [t, n, 1];
    if !xok || pshape != [t, n, n] {
        return Err(PyValueError::new_err(format!(
            "Xs must have shape (T, {n}) and Ps (T, {n}, {n}); got {xshape:?} and {pshape:?}"
        )));
    }
    if !xv.iter().chain(&pv).all(|v| v.is_finite()) {
        return Err(PyValueError::new_err("Xs or Ps contains NaN or infinity"));
    }
    Ok((xv, pv))
}

/// `(T, n)` array (or `(T, n, 1)` when `column`).
fn means_array<'py>(
    py: Python<'py>,
    v: Vec<f64>,
    n: usize,
    column: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let t = v.len() / n;
    let a = numpy::PyArray1::from_vec(py, v);
    if column {
        a.reshape([t, n, 1]).map(|a| a.into_any())
    } else {
        a.reshape([t, n]).map(|a| a.into_any())
    }
}

fn covs_array<'py>(py: Python<'py>, v: Vec<f64>, n: usize) -> PyResult<Bound<'py, PyAny>> {
    let t = v.len() / (n * n);
    numpy::PyArray1::from_vec(py, v)
        .reshape([t, n, n])
        .map(|a| a.into_any())
}

// ------------------------------------------- shared attribute plumbing

/// `#[pymethods] impl $ty { ... }` with the attributes every filter keeps in
/// its [`Arrays`] (`dim_x`, `dim_z`, `x`, `P`, `Q`, `R`, `y`, `S`,
/// `log_likelihood`) followed by the class's own methods.
///
/// The caller writes the `#[pymethods]` attribute: generated from the
/// caller's tokens, the names pyo3 makes for `**kwargs` are in the scope of
/// the methods that use them (macro hygiene).
macro_rules! belief_pymethods {
    ($hash:tt $attr:tt $ty:ident, { $($rest:tt)* }) => {
        $hash $attr
        impl $ty {
            /// State dimension.
            #[getter]
            fn dim_x(&self) -> usize {
                self.a.dim_x
            }
            /// Measurement dimension.
            #[getter]
            fn dim_z(&self) -> usize {
                self.a.dim_z
            }
            /// State mean.
            #[getter]
            fn get_x(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.x.clone_ref(py)
            }
            #[setter]
            fn set_x(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                self.a.x = checked_x(v, self.a.dim_x, "x")?;
                Ok(())
            }
            /// State covariance.
            #[getter(P)]
            fn get_p(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.p.clone_ref(py)
            }
            #[setter(P)]
            fn set_p(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                self.a.p = checked_matrix(v, self.a.dim_x, self.a.dim_x, "P")?;
                Ok(())
            }
            /// Process noise covariance.
            #[getter(Q)]
            fn get_q(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.q.clone_ref(py)
            }
            #[setter(Q)]
            fn set_q(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                self.a.q = checked_matrix(v, self.a.dim_x, self.a.dim_x, "Q")?;
                Ok(())
            }
            /// Measurement noise covariance.
            #[getter(R)]
            fn get_r(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.r.clone_ref(py)
            }
            #[setter(R)]
            fn set_r(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                self.a.r = checked_matrix(v, self.a.dim_z, self.a.dim_z, "R")?;
                Ok(())
            }
            /// Residual of the last update.
            #[getter]
            fn y(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.y.clone_ref(py)
            }
            /// Innovation covariance of the last update.
            #[getter(S)]
            fn get_s(&self, py: Python<'_>) -> Py<PyAny> {
                self.a.s.clone_ref(py)
            }
            /// Log-likelihood of the last measurement (NaN before the first).
            #[getter]
            fn log_likelihood(&self) -> f64 {
                self.a.log_likelihood
            }

            $($rest)*
        }
    };
}

/// [`belief_pymethods`] plus the linear model's `F` and `B` (fields `f`,
/// `b` and `dim_u`) of the KF and the EKF.
macro_rules! linear_pymethods {
    ($hash:tt $attr:tt $ty:ident, { $($rest:tt)* }) => {
        belief_pymethods!($hash $attr $ty, {
            /// State transition matrix (of the linear `predict()`).
            #[getter(F)]
            fn get_f(&self, py: Python<'_>) -> Py<PyAny> {
                self.f.clone_ref(py)
            }
            #[setter(F)]
            fn set_f(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
                self.f = checked_matrix(v, self.a.dim_x, self.a.dim_x, "F")?;
                Ok(())
            }
            /// Control matrix (`None` when there is no control input).
            #[getter(B)]
            fn get_b(&self, py: Python<'_>) -> Option<Py<PyAny>> {
                self.b.as_ref().map(|b| b.clone_ref(py))
            }
            #[setter(B)]
            fn set_b(&mut self, v: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
                self.b = match v {
                    Some(v) if !v.is_none() => {
                        Some(checked_matrix(v, self.a.dim_x, self.dim_u, "B")?)
                    }
                    _ => None,
                };
                Ok(())
            }

            $($rest)*
        });
    };
}

// ------------------------------------------------------- KalmanFilter

/// `(means, covariances, means_predicted, covariances_predicted)`.
type FourArrays<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// The linear Kalman filter, with filterpy's `KalmanFilter` attributes
/// (`x`, `P`, `F`, `H`, `Q`, `R`, `B`, `y`, `S`, `log_likelihood`) and
/// methods (`predict`, `update`, `batch_filter`, `rts_smoother`).
///
/// The posterior covariance uses the Joseph form by default (as filterpy).
/// `x` keeps the shape it was given: `(dim_x, 1)` by default as in filterpy,
/// or `(dim_x,)`.
#[pyclass(module = "bayestrack._bayestrack")]
pub struct KalmanFilter {
    a: Arrays,
    /// Control dimension.
    #[pyo3(get)]
    dim_u: usize,
    f: Py<PyAny>,
    h: Py<PyAny>,
    b: Option<Py<PyAny>>,
    kf: Kf,
}

impl KalmanFilter {
    fn f(&self, py: Python<'_>) -> PyResult<DMatrix<f64>> {
        matrix(self.f.bind(py), self.a.dim_x, self.a.dim_x, "F")
    }
    fn h(&self, py: Python<'_>, h: Option<&Bound<'_, PyAny>>) -> PyResult<DMatrix<f64>> {
        matrix(
            h.unwrap_or(self.h.bind(py)),
            self.a.dim_z,
            self.a.dim_x,
            "H",
        )
    }
    fn b(&self, py: Python<'_>) -> PyResult<Option<DMatrix<f64>>> {
        match &self.b {
            Some(b) => Ok(Some(matrix(b.bind(py), self.a.dim_x, self.dim_u, "B")?)),
            None => Ok(None),
        }
    }
}

linear_pymethods!(
    #[pymethods]
    KalmanFilter,
    {
        /// `KalmanFilter(dim_x, dim_z, dim_u=0, joseph=True)`: `x = 0`,
        /// `P = F = Q = I`, `H = 0`, `R = I`, `B = None` (filterpy's defaults).
        #[new]
        #[pyo3(signature = (dim_x, dim_z, dim_u = 0, joseph = true))]
        fn new(
            py: Python<'_>,
            dim_x: usize,
            dim_z: usize,
            dim_u: usize,
            joseph: bool,
        ) -> PyResult<Self> {
            check_dims(dim_x, dim_z)?;
            if dim_u > dim_x {
                return Err(PyValueError::new_err(format!(
                    "dim_u = {dim_u} > dim_x = {dim_x} is not supported"
                )));
            }
            Ok(Self {
                a: Arrays::new(py, dim_x, dim_z, true)?,
                dim_u,
                f: py_mat(py, &DMatrix::identity(dim_x, dim_x))
                    .into_any()
                    .unbind(),
                h: py_mat(py, &DMatrix::zeros(dim_z, dim_x))
                    .into_any()
                    .unbind(),
                b: None,
                kf: Kf::new(covariance_update(joseph)),
            })
        }

        /// Measurement matrix.
        #[getter(H)]
        fn get_h(&self, py: Python<'_>) -> Py<PyAny> {
            self.h.clone_ref(py)
        }
        #[setter(H)]
        fn set_h(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
            self.h = checked_matrix(v, self.a.dim_z, self.a.dim_x, "H")?;
            Ok(())
        }

        /// Time update `x = F x (+ B u)`, `P = F P F^T + Q`.
        #[pyo3(signature = (u = None))]
        fn predict(&mut self, py: Python<'_>, u: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
            let (x, p, f, q) = (self.a.x(py)?, self.a.p(py)?, self.f(py)?, self.a.q(py)?);
            let bu = match (u, self.b(py)?) {
                (Some(u), Some(b)) if !u.is_none() => Some((b, vector(u, self.dim_u, "u")?)),
                (Some(u), None) if !u.is_none() => {
                    return Err(PyValueError::new_err("u given but B is None"));
                }
                _ => None,
            };
            let kf = self.kf;
            let control = bu.as_ref().map(|(b, u)| (b, u));
            let (x, p) = dispatch_n!(self.a.dim_x, linear_predict(&kf, &x, &p, &f, &q, control))
                .map_err(|e| to_py_err(py, e))?;
            self.a.set_belief(py, &x, &p)
        }

        /// Measurement update with `z` (`None`: missing, the prior is kept);
        /// `R` and `H` override the stored ones for this step.
        #[pyo3(signature = (z, R = None, H = None))]
        #[allow(non_snake_case)]
        fn update(
            &mut self,
            py: Python<'_>,
            z: Option<&Bound<'_, PyAny>>,
            R: Option<&Bound<'_, PyAny>>,
            H: Option<&Bound<'_, PyAny>>,
        ) -> PyResult<()> {
            let z = match z {
                Some(z) if !z.is_none() => Some(vector(z, self.a.dim_z, "z")?),
                _ => None,
            };
            let (x, p, h, r) = (
                self.a.x(py)?,
                self.a.p(py)?,
                self.h(py, H)?,
                self.a.r(py, R)?,
            );
            let kf = self.kf;
            let out = dispatch_nm!(
                self.a.dim_x,
                self.a.dim_z,
                linear_update(&kf, &x, &p, &h, &r, z.as_ref())
            )
            .map_err(|e| to_py_err(py, e))?;
            self.a.set_update(py, &out)
        }

        /// Runs `predict` + `update` over `zs` (a `(T, dim_z)` array, or a
        /// sequence with `None` for missing measurements) without the GIL;
        /// `us` are the controls (`(T, dim_u)`). Returns
        /// `(means, covariances, means_predicted, covariances_predicted)` as
        /// filterpy does, and leaves the filter at the last posterior.
        #[pyo3(signature = (zs, us = None))]
        fn batch_filter<'py>(
            &mut self,
            py: Python<'py>,
            zs: &Bound<'py, PyAny>,
            us: Option<&Bound<'py, PyAny>>,
        ) -> PyResult<FourArrays<'py>> {
            let (dim_x, dim_z) = (self.a.dim_x, self.a.dim_z);
            let (zs, present) = read_zs(zs, dim_z)?;
            let t = present.len();
            let b = self.b(py)?;
            let us = match us {
                Some(us) if !us.is_none() => {
                    if b.is_none() {
                        return Err(PyValueError::new_err("us given but B is None"));
                    }
                    let m = matrix(us, t, self.dim_u, "us").or_else(|_| {
                        // (T,) for dim_u == 1
                        if self.dim_u == 1 {
                            vector(us, t, "us")
                                .map(|v| DMatrix::from_column_slice(t, 1, v.as_slice()))
                        } else {
                            Err(PyValueError::new_err(format!(
                                "us must have shape ({t}, {})",
                                self.dim_u
                            )))
                        }
                    })?;
                    m.transpose().as_slice().to_vec()
                }
                _ => Vec::new(),
            };
            let dim_u = if us.is_empty() { 0 } else { self.dim_u };
            let input = BatchIn {
                kf: self.kf,
                x: self.a.x(py)?,
                p: self.a.p(py)?,
                f: self.f(py)?,
                q: self.a.q(py)?,
                h: self.h(py, None)?,
                r: self.a.r(py, None)?,
                b: if dim_u > 0 { b } else { None },
                us,
                dim_u,
                zs,
                present,
            };
            let out = py
                .detach(|| dispatch_nm!(dim_x, dim_z, linear_batch(&input)))
                .map_err(|e| to_py_err(py, e))?;
            let column = self.a.is_column(py)?;
            if let Some(last) = &out.last {
                self.a.set_update(py, last)?;
            }
            Ok((
                means_array(py, out.means, dim_x, column)?,
                covs_array(py, out.covs, dim_x)?,
                means_array(py, out.means_p, dim_x, column)?,
                covs_array(py, out.covs_p, dim_x)?,
            ))
        }

        /// Rauch-Tung-Striebel smoothing of filtered `Xs` `(T, dim_x)` and `Ps`
        /// `(T, dim_x, dim_x)` with this filter's `F` and `Q` (or `Fs` / `Qs`
        /// when all of their entries are the same matrix); returns
        /// `(xs, Ps)` (filterpy's method also returns gains and predictions).
        #[pyo3(signature = (Xs, Ps, Fs = None, Qs = None))]
        #[allow(non_snake_case)]
        fn rts_smoother<'py>(
            &self,
            py: Python<'py>,
            Xs: &Bound<'py, PyAny>,
            Ps: &Bound<'py, PyAny>,
            Fs: Option<&Bound<'py, PyAny>>,
            Qs: Option<&Bound<'py, PyAny>>,
        ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
            let n = self.a.dim_x;
            let (xs, ps) = read_beliefs(Xs, Ps, n)?;
            let f = constant_or(py, Fs, n, "Fs", self.f(py)?)?;
            let q = constant_or(py, Qs, n, "Qs", self.a.q(py)?)?;
            let kf = self.kf;
            let (m, c) = py
                .detach(|| dispatch_n!(n, linear_rts(&kf, &xs, &ps, &f, &q)))
                .map_err(|e| to_py_err(py, e))?;
            let column = matches!(read_f64(Xs, "Xs")?.0.len(), 3);
            Ok((means_array(py, m, n, column)?, covs_array(py, c, n)?))
        }

        fn __repr__(&self) -> String {
            format!(
                "KalmanFilter(dim_x={}, dim_z={}, dim_u={})",
                self.a.dim_x, self.a.dim_z, self.dim_u
            )
        }
    }
);

/// `default`, or the one matrix that every entry of `seq` equals.
fn constant_or(
    _py: Python<'_>,
    seq: Option<&Bound<'_, PyAny>>,
    n: usize,
    name: &str,
    default: DMatrix<f64>,
) -> PyResult<DMatrix<f64>> {
    let Some(seq) = seq.filter(|s| !s.is_none()) else {
        return Ok(default);
    };
    let mut first: Option<DMatrix<f64>> = None;
    for (k, item) in seq.try_iter()?.enumerate() {
        let m = matrix(&item?, n, n, &format!("{name}[{k}]"))?;
        match &first {
            None => first = Some(m),
            Some(f) if *f != m => {
                return Err(PyValueError::new_err(format!(
                    "{name} must hold one matrix repeated (time-varying models are not supported)"
                )));
            }
            _ => {}
        }
    }
    Ok(first.unwrap_or(default))
}

// --------------------------------------------- EKF and IEKF

#[derive(Clone, Copy)]
enum Linearised {
    Ekf(Ekf),
    Iekf(Iekf),
}

#[allow(clippy::too_many_arguments)]
fn ext_update<const N: usize, const M: usize>(
    filter: Linearised,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    r: &DMatrix<f64>,
    z: &DVector<f64>,
    hj: &Bound<'_, PyAny>,
    hx: &Bound<'_, PyAny>,
    args: &[Bound<'_, PyAny>],
    hx_args: &[Bound<'_, PyAny>],
) -> Res<UpdOut> {
    let err = RefCell::new(None);
    let g = belief::<N>(x, p)?;
    let hmap = PyMap::<N>::new(hx, hx_args.to_vec(), None, "Hx", &err, Shape::Column, false);
    let jmap = PyMap::<N>::new(
        hj,
        args.to_vec(),
        None,
        "HJacobian",
        &err,
        Shape::Column,
        false,
    );
    let model = FnMeasurement::<N, M, _>::new(|s: &SVector<f64, N>| hmap.vector::<M>(s), sm(r))?
        .with_jacobian(|s: &SVector<f64, N>| jmap.matrix::<M, N>(s));
    let z = sv::<M>(z);
    let out = match filter {
        Linearised::Ekf(f) => f.update(&g, &model, Some(&z)),
        Linearised::Iekf(f) => f.update(&g, &model, Some(&z)),
    };
    match out {
        Ok(u) => match err.borrow_mut().take() {
            Some(e) => Err(Fail::Py(e)),
            None => Ok(upd_out(&u)),
        },
        Err(e) => Err(prefer_stored(&err, e.into())),
    }
}

fn ext_predict<const N: usize>(
    ekf: &Ekf,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    q: &DMatrix<f64>,
    fx: &Bound<'_, PyAny>,
    fj: &Bound<'_, PyAny>,
) -> Res<(DVector<f64>, DMatrix<f64>)> {
    let err = RefCell::new(None);
    let g = belief::<N>(x, p)?;
    let fmap = PyMap::<N>::new(fx, vec![], None, "fx", &err, Shape::Column, false);
    let jmap = PyMap::<N>::new(fj, vec![], None, "FJacobian", &err, Shape::Column, false);
    let model = FnDynamics::<N, _>::new(|s: &SVector<f64, N>| fmap.vector::<N>(s), sm(q))?
        .with_jacobian(|s: &SVector<f64, N>| jmap.matrix::<N, N>(s));
    let out = ekf.predict(&g, &model);
    finish(out.map(|g| (dv(g.mean()), dm(g.cov()))), &err)
}

fn finish<T>(out: bayestrack_kalman::Result<T>, err: &RefCell<Option<PyErr>>) -> Res<T> {
    match out {
        Ok(v) => match err.borrow_mut().take() {
            Some(e) => Err(Fail::Py(e)),
            None => Ok(v),
        },
        Err(e) => Err(prefer_stored(err, e.into())),
    }
}

fn tuple_items<'py>(args: Option<&Bound<'py, PyAny>>) -> PyResult<Vec<Bound<'py, PyAny>>> {
    match args {
        None => Ok(vec![]),
        Some(a) if a.is_none() => Ok(vec![]),
        Some(a) => match a.cast::<pyo3::types::PyTuple>() {
            Ok(t) => Ok(t.iter().collect()),
            Err(_) => Ok(vec![a.clone()]),
        },
    }
}

/// The extended Kalman filter with filterpy's `ExtendedKalmanFilter`
/// interface: `predict()` is linear with `F` (as filterpy's), or nonlinear
/// with `predict(fx=..., FJacobian=...)`; `update(z, HJacobian, Hx)` takes
/// the measurement function and its Jacobian as callables of the column
/// state `x` (`(dim_x, 1)`), as filterpy does.
///
/// `IteratedExtendedKalmanFilter` is the same class with an iterated update.
#[pyclass(module = "bayestrack._bayestrack", subclass)]
pub struct ExtendedKalmanFilter {
    a: Arrays,
    /// Control dimension.
    #[pyo3(get)]
    dim_u: usize,
    f: Py<PyAny>,
    b: Option<Py<PyAny>>,
    filter: Linearised,
    /// Relinearisations done by the last update (1 for the EKF).
    #[pyo3(get)]
    iterations: usize,
}

impl ExtendedKalmanFilter {
    fn build(
        py: Python<'_>,
        dim_x: usize,
        dim_z: usize,
        dim_u: usize,
        filter: Linearised,
    ) -> PyResult<Self> {
        check_dims(dim_x, dim_z)?;
        if dim_u > dim_x {
            return Err(PyValueError::new_err(format!(
                "dim_u = {dim_u} > dim_x = {dim_x} is not supported"
            )));
        }
        Ok(Self {
            a: Arrays::new(py, dim_x, dim_z, true)?,
            dim_u,
            f: py_mat(py, &DMatrix::identity(dim_x, dim_x))
                .into_any()
                .unbind(),
            b: None,
            filter,
            iterations: 0,
        })
    }

    fn kf(&self) -> Kf {
        match self.filter {
            Linearised::Ekf(e) => Kf::new(e.covariance_update),
            Linearised::Iekf(i) => Kf::new(i.covariance_update),
        }
    }

    fn ekf(&self) -> Ekf {
        match self.filter {
            Linearised::Ekf(e) => e,
            Linearised::Iekf(i) => Ekf::new(i.covariance_update),
        }
    }
}

linear_pymethods!(
    #[pymethods]
    ExtendedKalmanFilter,
    {
        /// `ExtendedKalmanFilter(dim_x, dim_z, dim_u=0, joseph=True)`.
        #[new]
        #[pyo3(signature = (dim_x, dim_z, dim_u = 0, joseph = true))]
        fn new(
            py: Python<'_>,
            dim_x: usize,
            dim_z: usize,
            dim_u: usize,
            joseph: bool,
        ) -> PyResult<Self> {
            Self::build(
                py,
                dim_x,
                dim_z,
                dim_u,
                Linearised::Ekf(Ekf::new(covariance_update(joseph))),
            )
        }

        /// Time update: linear with `F` (and `B u`) as filterpy's EKF, or, with
        /// `fx` and `FJacobian` (callables of the column state), the EKF
        /// prediction `x = fx(x)`, `P = J P J^T + Q`.
        #[pyo3(signature = (u = None, fx = None, FJacobian = None))]
        #[allow(non_snake_case)]
        fn predict(
            &mut self,
            py: Python<'_>,
            u: Option<&Bound<'_, PyAny>>,
            fx: Option<&Bound<'_, PyAny>>,
            FJacobian: Option<&Bound<'_, PyAny>>,
        ) -> PyResult<()> {
            let (x, p, q) = (self.a.x(py)?, self.a.p(py)?, self.a.q(py)?);
            let n = self.a.dim_x;
            let (x, p) = match (fx, FJacobian) {
                (Some(fx), Some(fj)) => {
                    if u.is_some_and(|u| !u.is_none()) {
                        return Err(PyValueError::new_err("u cannot be combined with fx"));
                    }
                    let ekf = self.ekf();
                    dispatch_n!(n, ext_predict(&ekf, &x, &p, &q, fx, fj))
                }
                (None, None) => {
                    let f = matrix(self.f.bind(py), n, n, "F")?;
                    let b = match &self.b {
                        Some(b) => Some(matrix(b.bind(py), n, self.dim_u, "B")?),
                        None => None,
                    };
                    let bu = match (u, b) {
                        (Some(u), Some(b)) if !u.is_none() => {
                            Some((b, vector(u, self.dim_u, "u")?))
                        }
                        (Some(u), None) if !u.is_none() => {
                            return Err(PyValueError::new_err("u given but B is None"));
                        }
                        _ => None,
                    };
                    let kf = self.kf();
                    let control = bu.as_ref().map(|(b, u)| (b, u));
                    dispatch_n!(n, linear_predict(&kf, &x, &p, &f, &q, control))
                }
                _ => {
                    return Err(PyTypeError::new_err(
                        "fx and FJacobian must be given together",
                    ));
                }
            }
            .map_err(|e| to_py_err(py, e))?;
            self.a.set_belief(py, &x, &p)
        }

        /// Measurement update: `HJacobian(x, *args)` returns `dh/dx`
        /// (`(dim_z, dim_x)`), `Hx(x, *hx_args)` the predicted measurement;
        /// `z = None` keeps the prior.
        #[pyo3(signature = (z, HJacobian, Hx, R = None, args = None, hx_args = None))]
        #[allow(non_snake_case, clippy::too_many_arguments)]
        fn update(
            &mut self,
            py: Python<'_>,
            z: Option<&Bound<'_, PyAny>>,
            HJacobian: &Bound<'_, PyAny>,
            Hx: &Bound<'_, PyAny>,
            R: Option<&Bound<'_, PyAny>>,
            args: Option<&Bound<'_, PyAny>>,
            hx_args: Option<&Bound<'_, PyAny>>,
        ) -> PyResult<()> {
            if !HJacobian.is_callable() || !Hx.is_callable() {
                return Err(PyTypeError::new_err("HJacobian and Hx must be callable"));
            }
            let Some(z) = z.filter(|z| !z.is_none()) else {
                let (x, p) = (self.a.x(py)?, self.a.p(py)?);
                self.iterations = 0;
                return self.a.set_update(
                    py,
                    &UpdOut {
                        x,
                        p,
                        innovation: None,
                        iterations: 0,
                    },
                );
            };
            let z = vector(z, self.a.dim_z, "z")?;
            let (x, p, r) = (self.a.x(py)?, self.a.p(py)?, self.a.r(py, R)?);
            let (args, hx_args) = (tuple_items(args)?, tuple_items(hx_args)?);
            let filter = self.filter;
            let out = dispatch_nm!(
                self.a.dim_x,
                self.a.dim_z,
                ext_update(filter, &x, &p, &r, &z, HJacobian, Hx, &args, &hx_args)
            )
            .map_err(|e| to_py_err(py, e))?;
            self.iterations = out.iterations;
            self.a.set_update(py, &out)
        }

        fn __repr__(&self) -> String {
            let name = match self.filter {
                Linearised::Ekf(_) => "ExtendedKalmanFilter",
                Linearised::Iekf(_) => "IteratedExtendedKalmanFilter",
            };
            format!("{name}(dim_x={}, dim_z={})", self.a.dim_x, self.a.dim_z)
        }
    }
);

/// The iterated extended Kalman filter: the EKF's interface, with an
/// update that relinearises `Hx` about its latest iterate (Gauss-Newton,
/// Bell and Cathey 1993) at most `max_iterations` times, stopping when a
/// step is below `tolerance`; `iterations` reports how many it did.
#[pyclass(module = "bayestrack._bayestrack", extends = ExtendedKalmanFilter)]
pub struct IteratedExtendedKalmanFilter;

#[pymethods]
impl IteratedExtendedKalmanFilter {
    /// `IteratedExtendedKalmanFilter(dim_x, dim_z, max_iterations=5,
    /// tolerance=1e-12, dim_u=0, joseph=True)`.
    #[new]
    #[pyo3(signature = (dim_x, dim_z, max_iterations = 5, tolerance = 1e-12, dim_u = 0, joseph = true))]
    fn new(
        py: Python<'_>,
        dim_x: usize,
        dim_z: usize,
        max_iterations: usize,
        tolerance: f64,
        dim_u: usize,
        joseph: bool,
    ) -> PyResult<(Self, ExtendedKalmanFilter)> {
        let mut iekf =
            Iekf::new(max_iterations, tolerance).map_err(|e| crate::util::kalman_err(py, &e))?;
        iekf.covariance_update = covariance_update(joseph);
        let base = ExtendedKalmanFilter::build(py, dim_x, dim_z, dim_u, Linearised::Iekf(iekf))?;
        Ok((Self, base))
    }
}

// ------------------------------------------------------------ UKF

/// Sigma-point parameters and the Python model of a UKF step.
struct UkfModel<'a, 'py> {
    ukf: Ukf,
    fx: &'a Bound<'py, PyAny>,
    hx: &'a Bound<'py, PyAny>,
    dt: Bound<'py, PyAny>,
    fx_kw: Option<&'a Bound<'py, PyDict>>,
    hx_kw: Option<&'a Bound<'py, PyDict>>,
    vectorized: bool,
}

fn ukf_predict<const N: usize>(
    m: &UkfModel<'_, '_>,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Res<(DVector<f64>, DMatrix<f64>)> {
    let err = RefCell::new(None);
    let g = belief::<N>(x, p)?;
    let q = sm::<N, N>(q);
    let fmap = PyMap::<N>::new(
        m.fx,
        vec![m.dt.clone()],
        m.fx_kw,
        "fx",
        &err,
        Shape::Flat,
        m.vectorized,
    );
    if m.vectorized {
        // record the sigma points (they depend on the prior only), then one call
        let seen = RefCell::new(Vec::new());
        let rec = FnDynamics::new(
            |s: &SVector<f64, N>| {
                seen.borrow_mut().push(*s);
                *s
            },
            q,
        )?;
        let _ = m.ukf.predict(&g, &rec);
        fmap.prime(seen.into_inner(), N);
    }
    let model = FnDynamics::new(|s: &SVector<f64, N>| fmap.vector::<N>(s), q)?;
    finish(
        m.ukf
            .predict(&g, &model)
            .map(|g| (dv(g.mean()), dm(g.cov()))),
        &err,
    )
}

fn ukf_update<const N: usize, const M: usize>(
    m: &UkfModel<'_, '_>,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    r: &DMatrix<f64>,
    z: Option<&DVector<f64>>,
) -> Res<UpdOut> {
    let err = RefCell::new(None);
    let g = belief::<N>(x, p)?;
    let r = sm::<M, M>(r);
    let z = z.map(sv::<M>);
    let hmap = PyMap::<N>::new(m.hx, vec![], m.hx_kw, "hx", &err, Shape::Flat, m.vectorized);
    if m.vectorized && z.is_some() {
        let seen = RefCell::new(Vec::new());
        let rec = FnMeasurement::<N, M, _>::new(
            |s: &SVector<f64, N>| {
                seen.borrow_mut().push(*s);
                SVector::<f64, M>::zeros()
            },
            r,
        )?;
        let _ = m.ukf.update(&g, &rec, z.as_ref());
        hmap.prime(seen.into_inner(), M);
    }
    let model = FnMeasurement::<N, M, _>::new(|s: &SVector<f64, N>| hmap.vector::<M>(s), r)?;
    finish(
        m.ukf.update(&g, &model, z.as_ref()).map(|u| upd_out(&u)),
        &err,
    )
}

fn ukf_rts<const N: usize>(
    m: &UkfModel<'_, '_>,
    xs: &[f64],
    ps: &[f64],
    q: &DMatrix<f64>,
) -> Res<(Vec<f64>, Vec<f64>)> {
    let err = RefCell::new(None);
    let filtered = beliefs::<N>(xs, ps)?;
    let q = sm::<N, N>(q);
    let fmap = PyMap::<N>::new(
        m.fx,
        vec![m.dt.clone()],
        m.fx_kw,
        "fx",
        &err,
        Shape::Flat,
        m.vectorized,
    );
    if m.vectorized {
        let seen = RefCell::new(Vec::new());
        let rec = FnDynamics::new(
            |s: &SVector<f64, N>| {
                seen.borrow_mut().push(*s);
                *s
            },
            q,
        )?;
        let _ = m.ukf.rts_smooth(&filtered, &rec);
        fmap.prime(seen.into_inner(), N);
    }
    let model = FnDynamics::new(|s: &SVector<f64, N>| fmap.vector::<N>(s), q)?;
    finish(
        m.ukf.rts_smooth(&filtered, &model).map(|g| flatten(&g)),
        &err,
    )
}

/// The unscented Kalman filter with filterpy's `UnscentedKalmanFilter`
/// interface: `fx(x, dt, **fx_args)` and `hx(x, **hx_args)` receive the
/// state as a 1-D array, or, with `vectorized=True`, all sigma points as
/// one `(2 dim_x + 1, dim_x)` array (one Python call per step) and return
/// one row per point. Sigma points are van der Merwe's scaled points with
/// `alpha`, `beta`, `kappa` (given directly or read from `points`, e.g.
/// filterpy's `MerweScaledSigmaPoints`); predict then update redraws the
/// points, as filterpy does.
#[pyclass(module = "bayestrack._bayestrack")]
pub struct UnscentedKalmanFilter {
    a: Arrays,
    /// Default time step passed to `fx`.
    #[pyo3(get, set)]
    dt: f64,
    /// State transition function.
    #[pyo3(get, set)]
    fx: Py<PyAny>,
    /// Measurement function.
    #[pyo3(get, set)]
    hx: Py<PyAny>,
    /// Whether `fx` and `hx` take all sigma points at once.
    #[pyo3(get, set)]
    vectorized: bool,
    ukf: Ukf,
}

impl UnscentedKalmanFilter {
    fn model<'a, 'py>(
        &self,
        py: Python<'py>,
        fx: &'a Bound<'py, PyAny>,
        hx: &'a Bound<'py, PyAny>,
        dt: f64,
        fx_kw: Option<&'a Bound<'py, PyDict>>,
        hx_kw: Option<&'a Bound<'py, PyDict>>,
    ) -> UkfModel<'a, 'py> {
        UkfModel {
            ukf: self.ukf,
            fx,
            hx,
            dt: PyFloat::new(py, dt).into_any(),
            fx_kw: fx_kw.filter(|k| !k.is_empty()),
            hx_kw: hx_kw.filter(|k| !k.is_empty()),
            vectorized: self.vectorized,
        }
    }
}

belief_pymethods!(
    #[pymethods]
    UnscentedKalmanFilter,
    {
        /// `UnscentedKalmanFilter(dim_x, dim_z, dt, hx, fx, points=None,
        /// alpha=1e-3, beta=2.0, kappa=0.0, vectorized=False)`.
        #[new]
        #[pyo3(signature = (dim_x, dim_z, dt, hx, fx, points = None, *, alpha = None, beta = None, kappa = None, vectorized = false))]
        #[allow(clippy::too_many_arguments)]
        fn new(
            py: Python<'_>,
            dim_x: usize,
            dim_z: usize,
            dt: f64,
            hx: Py<PyAny>,
            fx: Py<PyAny>,
            points: Option<&Bound<'_, PyAny>>,
            alpha: Option<f64>,
            beta: Option<f64>,
            kappa: Option<f64>,
            vectorized: bool,
        ) -> PyResult<Self> {
            check_dims(dim_x, dim_z)?;
            if !hx.bind(py).is_callable() || !fx.bind(py).is_callable() {
                return Err(PyTypeError::new_err("hx and fx must be callable"));
            }
            let get = |name: &str, given: Option<f64>, default: f64| -> PyResult<f64> {
                if let Some(v) = given {
                    return Ok(v);
                }
                match points.filter(|p| !p.is_none()) {
                    Some(p) => p.getattr(name)?.extract(),
                    None => Ok(default),
                }
            };
            let (alpha, beta, kappa) = (
                get("alpha", alpha, 1e-3)?,
                get("beta", beta, 2.0)?,
                get("kappa", kappa, 0.0)?,
            );
            let ukf = Ukf::new(alpha, beta, kappa).map_err(|e| crate::util::kalman_err(py, &e))?;
            ukf.weights(dim_x)
                .map_err(|e| crate::util::kalman_err(py, &e))?;
            if !dt.is_finite() {
                return Err(PyValueError::new_err("dt is not finite"));
            }
            Ok(Self {
                a: Arrays::new(py, dim_x, dim_z, false)?,
                dt,
                fx,
                hx,
                vectorized,
                ukf,
            })
        }

        /// `(alpha, beta, kappa)`.
        #[getter]
        fn sigma_parameters(&self) -> (f64, f64, f64) {
            (self.ukf.alpha(), self.ukf.beta(), self.ukf.kappa())
        }

        /// Time update through `fx` (`dt` and `fx` override the stored ones for
        /// this step; keyword arguments go to `fx`).
        #[pyo3(signature = (dt = None, fx = None, **fx_args))]
        fn predict(
            &mut self,
            py: Python<'_>,
            dt: Option<f64>,
            fx: Option<&Bound<'_, PyAny>>,
            fx_args: Option<&Bound<'_, PyDict>>,
        ) -> PyResult<()> {
            let (x, p, q) = (self.a.x(py)?, self.a.p(py)?, self.a.q(py)?);
            let (sf, sh) = (self.fx.bind(py).clone(), self.hx.bind(py).clone());
            let fx = fx.unwrap_or(&sf);
            let m = self.model(py, fx, &sh, dt.unwrap_or(self.dt), fx_args, None);
            let (x, p) = dispatch_n!(self.a.dim_x, ukf_predict(&m, &x, &p, &q))
                .map_err(|e| to_py_err(py, e))?;
            self.a.set_belief(py, &x, &p)
        }

        /// Measurement update through `hx` (`z = None`: missing; `R` and `hx`
        /// override the stored ones; keyword arguments go to `hx`).
        #[pyo3(signature = (z, R = None, hx = None, **hx_args))]
        #[allow(non_snake_case)]
        fn update(
            &mut self,
            py: Python<'_>,
            z: Option<&Bound<'_, PyAny>>,
            R: Option<&Bound<'_, PyAny>>,
            hx: Option<&Bound<'_, PyAny>>,
            hx_args: Option<&Bound<'_, PyDict>>,
        ) -> PyResult<()> {
            let z = match z {
                Some(z) if !z.is_none() => Some(vector(z, self.a.dim_z, "z")?),
                _ => None,
            };
            let (x, p, r) = (self.a.x(py)?, self.a.p(py)?, self.a.r(py, R)?);
            let (sf, sh) = (self.fx.bind(py).clone(), self.hx.bind(py).clone());
            let hx = hx.unwrap_or(&sh);
            let m = self.model(py, &sf, hx, self.dt, None, hx_args);
            let out = dispatch_nm!(
                self.a.dim_x,
                self.a.dim_z,
                ukf_update(&m, &x, &p, &r, z.as_ref())
            )
            .map_err(|e| to_py_err(py, e))?;
            self.a.set_update(py, &out)
        }

        /// `predict` + `update` over `zs` (a `(T, dim_z)` array or a sequence
        /// with `None` for missing measurements); returns `(means, covariances)`
        /// as filterpy does and leaves the filter at the last posterior.
        fn batch_filter<'py>(
            &mut self,
            py: Python<'py>,
            zs: &Bound<'py, PyAny>,
        ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
            let n = self.a.dim_x;
            let (zv, present) = read_zs(zs, self.a.dim_z)?;
            let mut means = Vec::with_capacity(present.len() * n);
            let mut covs = Vec::with_capacity(present.len() * n * n);
            let dim_z = self.a.dim_z;
            for (k, &has) in present.iter().enumerate() {
                self.predict(py, None, None, None)?;
                let z = has.then(|| {
                    numpy::PyArray1::from_slice(py, &zv[k * dim_z..(k + 1) * dim_z]).into_any()
                });
                self.update(py, z.as_ref(), None, None, None)?;
                means.extend_from_slice(self.a.x(py)?.as_slice());
                covs.extend(self.a.p(py)?.transpose().iter().copied());
            }
            Ok((means_array(py, means, n, false)?, covs_array(py, covs, n)?))
        }

        /// Unscented RTS smoothing (Sarkka 2008) of filtered `Xs` `(T, dim_x)`
        /// and `Ps` with `fx`, `dt` and `Q`; returns `(xs, Ps)`.
        #[pyo3(signature = (Xs, Ps))]
        #[allow(non_snake_case)]
        fn rts_smoother<'py>(
            &self,
            py: Python<'py>,
            Xs: &Bound<'py, PyAny>,
            Ps: &Bound<'py, PyAny>,
        ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
            let n = self.a.dim_x;
            let (xs, ps) = read_beliefs(Xs, Ps, n)?;
            let q = self.a.q(py)?;
            let (sf, sh) = (self.fx.bind(py).clone(), self.hx.bind(py).clone());
            let m = self.model(py, &sf, &sh, self.dt, None, None);
            let (mv, cv) =
                dispatch_n!(n, ukf_rts(&m, &xs, &ps, &q)).map_err(|e| to_py_err(py, e))?;
            Ok((means_array(py, mv, n, false)?, covs_array(py, cv, n)?))
        }

        fn __repr__(&self) -> String {
            format!(
                "UnscentedKalmanFilter(dim_x={}, dim_z={}, alpha={}, beta={}, kappa={})",
                self.a.dim_x,
                self.a.dim_z,
                self.ukf.alpha(),
                self.ukf.beta(),
                self.ukf.kappa()
            )
        }
    }
);

// --------------------------------------------------------- hybrid step

/// The Python model of a hybrid step.
struct HybridModel<'a, 'py> {
    filter: RustHybrid,
    fx: &'a Bound<'py, PyAny>,
    hx: &'a Bound<'py, PyAny>,
    hjacobian: &'a Bound<'py, PyAny>,
    dt: Bound<'py, PyAny>,
}

/// The final update and the UKF posterior of step (a).
type HybridOut = (UpdOut, DVector<f64>, DMatrix<f64>);

fn hybrid_step<const N: usize, const M: usize>(
    m: &HybridModel<'_, '_>,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    z: Option<&DVector<f64>>,
) -> Res<HybridOut> {
    let err = RefCell::new(None);
    let g = belief::<N>(x, p)?;
    let fmap = PyMap::<N>::new(
        m.fx,
        vec![m.dt.clone()],
        None,
        "fx",
        &err,
        Shape::Flat,
        false,
    );
    let hmap = PyMap::<N>::new(m.hx, vec![], None, "hx", &err, Shape::Flat, false);
    let jmap = PyMap::<N>::new(
        m.hjacobian,
        vec![],
        None,
        "HJacobian",
        &err,
        Shape::Flat,
        false,
    );
    let dynamics = FnDynamics::new(|s: &SVector<f64, N>| fmap.vector::<N>(s), sm::<N, N>(q))?;
    let measurement =
        FnMeasurement::<N, M, _>::new(|s: &SVector<f64, N>| hmap.vector::<M>(s), sm::<M, M>(r))?
            .with_jacobian(|s: &SVector<f64, N>| jmap.matrix::<M, N>(s));
    let z = z.map(sv::<M>);
    finish(
        m.filter
            .step(&g, &Additive(&dynamics), &measurement, z.as_ref())
            .map(|s| {
                let a = &s.ukf.update.posterior;
                (upd_out(&s.update), dv(a.mean()), dm(a.cov()))
            }),
        &err,
    )
}

/// The hybrid UKF -> IEKF step of the HIKPF proposal (Nagy, Ahmed and
/// Zayed (paper 000) sec. 3.3): (a) a UKF step with `fx(x, dt)` (additive
/// process noise `Q`) and `hx(x)`, then (b) an IEKF update that
/// relinearises `hx` with `HJacobian(x)` (a `(dim_z, dim_x)` array) about
/// its latest iterate, starting from the UKF posterior. The callables take
/// the state as a 1-D array (as the UKF's); `x` is `(dim_x,)`.
///
/// `prior` names the prior of step (b): `"ukf_predicted"` (default, the
/// measurement used once) or `"ukf_posterior"` (the paper's wording, the
/// measurement used twice). After `step`, `x_ukf` and `P_ukf` hold the UKF
/// posterior of step (a) and `iterations` the IEKF's relinearisations.
#[pyclass(module = "bayestrack._bayestrack")]
pub struct HybridUkfIekf {
    a: Arrays,
    /// Time step passed to `fx`.
    #[pyo3(get, set)]
    dt: f64,
    /// State transition function `fx(x, dt)`.
    #[pyo3(get, set)]
    fx: Py<PyAny>,
    /// Measurement function `hx(x)`.
    #[pyo3(get, set)]
    hx: Py<PyAny>,
    /// Jacobian of `hx`, `HJacobian(x)`.
    #[pyo3(get, set, name = "HJacobian")]
    hjacobian: Py<PyAny>,
    filter: RustHybrid,
    /// IEKF relinearisations of the last step.
    #[pyo3(get)]
    iterations: usize,
    x_ukf: Option<Py<PyAny>>,
    p_ukf: Option<Py<PyAny>>,
}

belief_pymethods!(
    #[pymethods]
    HybridUkfIekf,
    {
        /// `HybridUkfIekf(dim_x, dim_z, dt, hx, fx, HJacobian, alpha=1e-3,
        /// beta=2.0, kappa=0.0, max_iterations=5, tolerance=1e-12,
        /// prior="ukf_predicted")`.
        #[new]
        #[pyo3(signature = (dim_x, dim_z, dt, hx, fx, HJacobian, *, alpha = 1e-3, beta = 2.0, kappa = 0.0, max_iterations = 5, tolerance = 1e-12, prior = "ukf_predicted"))]
        #[allow(clippy::too_many_arguments, non_snake_case)]
        fn new(
            py: Python<'_>,
            dim_x: usize,
            dim_z: usize,
            dt: f64,
            hx: Py<PyAny>,
            fx: Py<PyAny>,
            HJacobian: Py<PyAny>,
            alpha: f64,
            beta: f64,
            kappa: f64,
            max_iterations: usize,
            tolerance: f64,
            prior: &str,
        ) -> PyResult<Self> {
            check_dims(dim_x, dim_z)?;
            if !hx.bind(py).is_callable()
                || !fx.bind(py).is_callable()
                || !HJacobian.bind(py).is_callable()
            {
                return Err(PyTypeError::new_err(
                    "hx, fx and HJacobian must be callable",
                ));
            }
            let prior = match prior {
                "ukf_predicted" => HybridPrior::UkfPredicted,
                "ukf_posterior" => HybridPrior::UkfPosterior,
                other => {
                    return Err(PyValueError::new_err(format!(
                        "prior = {other:?}: must be \"ukf_predicted\" or \"ukf_posterior\""
                    )));
                }
            };
            let ukf = Ukf::new(alpha, beta, kappa).map_err(|e| to_py_err(py, e.into()))?;
            let iekf = Iekf::new(max_iterations, tolerance).map_err(|e| to_py_err(py, e.into()))?;
            let mut filter = RustHybrid::new(ukf, iekf);
            filter.prior = prior;
            Ok(Self {
                a: Arrays::new(py, dim_x, dim_z, false)?,
                dt,
                fx,
                hx,
                hjacobian: HJacobian,
                filter,
                iterations: 0,
                x_ukf: None,
                p_ukf: None,
            })
        }

        /// The UKF posterior mean of step (a) of the last step (`None` before).
        #[getter]
        fn x_ukf(&self, py: Python<'_>) -> Option<Py<PyAny>> {
            self.x_ukf.as_ref().map(|x| x.clone_ref(py))
        }

        /// The UKF posterior covariance of step (a) of the last step.
        #[getter(P_ukf)]
        fn p_ukf(&self, py: Python<'_>) -> Option<Py<PyAny>> {
            self.p_ukf.as_ref().map(|p| p.clone_ref(py))
        }

        /// One step from the belief at `k-1` to the belief at `k` with
        /// measurement `z` (`None`: missing, the UKF prediction alone).
        #[pyo3(signature = (z, R = None))]
        #[allow(non_snake_case)]
        fn step(
            &mut self,
            py: Python<'_>,
            z: Option<&Bound<'_, PyAny>>,
            R: Option<&Bound<'_, PyAny>>,
        ) -> PyResult<()> {
            let z = match z {
                Some(z) if !z.is_none() => Some(vector(z, self.a.dim_z, "z")?),
                _ => None,
            };
            let (x, p, q, r) = (
                self.a.x(py)?,
                self.a.p(py)?,
                self.a.q(py)?,
                self.a.r(py, R)?,
            );
            let (fx, hx, hj) = (
                self.fx.bind(py).clone(),
                self.hx.bind(py).clone(),
                self.hjacobian.bind(py).clone(),
            );
            let m = HybridModel {
                filter: self.filter,
                fx: &fx,
                hx: &hx,
                hjacobian: &hj,
                dt: PyFloat::new(py, self.dt).into_any(),
            };
            let (out, xu, pu) = dispatch_nm!(
                self.a.dim_x,
                self.a.dim_z,
                hybrid_step(&m, &x, &p, &q, &r, z.as_ref())
            )
            .map_err(|e| to_py_err(py, e))?;
            self.a.set_update(py, &out)?;
            self.iterations = out.iterations;
            self.x_ukf = Some(py_vec(py, &xu).into_any().unbind());
            self.p_ukf = Some(py_mat(py, &pu).into_any().unbind());
            Ok(())
        }

        /// `step` over `zs` (a `(T, dim_z)` array or a sequence with `None` for
        /// missing measurements); returns `(means, covariances)`.
        fn batch_filter<'py>(
            &mut self,
            py: Python<'py>,
            zs: &Bound<'py, PyAny>,
        ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
            let n = self.a.dim_x;
            let dim_z = self.a.dim_z;
            let (zv, present) = read_zs(zs, dim_z)?;
            let mut means = Vec::with_capacity(present.len() * n);
            let mut covs = Vec::with_capacity(present.len() * n * n);
            for (k, &has) in present.iter().enumerate() {
                let z = has.then(|| {
                    numpy::PyArray1::from_slice(py, &zv[k * dim_z..(k + 1) * dim_z]).into_any()
                });
                self.step(py, z.as_ref(), None)?;
                means.extend_from_slice(self.a.x(py)?.as_slice());
                covs.extend(self.a.p(py)?.transpose().iter().copied());
            }
            Ok((means_array(py, means, n, false)?, covs_array(py, covs, n)?))
        }

        fn __repr__(&self) -> String {
            format!(
                "HybridUkfIekf(dim_x={}, dim_z={}, prior={:?})",
                self.a.dim_x, self.a.dim_z, self.filter.prior
            )
        }
    }
);
