//! Conversions between numpy arrays and nalgebra matrices, the mapping of
//! Rust errors to Python exceptions and the size dispatch of the
//! const-generic filters.

use std::cell::RefCell;

use bayestrack_kalman::KalmanError;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};

/// Largest state dimension the wheel is compiled for.
pub const MAX_X: usize = 6;
/// Largest measurement dimension the wheel is compiled for.
pub const MAX_Z: usize = 4;

/// A failure inside a filter step: a Rust error, or the exception a Python
/// callable raised (kept to be re-raised as it was).
pub enum Fail {
    /// The filter's own error.
    Kalman(KalmanError),
    /// A Python error (a callable raised, or returned the wrong shape).
    Py(PyErr),
}

impl From<KalmanError> for Fail {
    fn from(e: KalmanError) -> Self {
        Fail::Kalman(e)
    }
}

impl From<PyErr> for Fail {
    fn from(e: PyErr) -> Self {
        Fail::Py(e)
    }
}

/// Result of a step run through the size dispatch.
pub type Res<T> = Result<T, Fail>;

/// The Python exception for a Rust error: `numpy.linalg.LinAlgError` for a
/// matrix that is not positive definite (as filterpy raises), `ValueError`
/// for everything else, with the Rust message.
pub fn kalman_err(py: Python<'_>, e: &KalmanError) -> PyErr {
    let msg = e.to_string();
    if matches!(e, KalmanError::NotPositiveDefinite { .. })
        && let Ok(t) = py
            .import("numpy.linalg")
            .and_then(|m| m.getattr("LinAlgError"))
            .and_then(|t| t.cast_into::<PyType>().map_err(PyErr::from))
    {
        return PyErr::from_type(t, msg);
    }
    PyValueError::new_err(msg)
}

/// [`Fail`] to `PyErr`.
pub fn to_py_err(py: Python<'_>, f: Fail) -> PyErr {
    match f {
        Fail::Kalman(e) => kalman_err(py, &e),
        Fail::Py(e) => e,
    }
}

/// `numpy.asarray(obj, dtype=float64)` as (shape, row-major values).
pub fn read_f64(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    // fast paths: a float64 array (no copy, no call into numpy) or a float
    if let Ok(arr) = obj.cast::<PyArrayDyn<f64>>() {
        let ro = arr
            .try_readonly()
            .map_err(|e| PyValueError::new_err(format!("{name} cannot be read: {e}")))?;
        let view = ro.as_array();
        return Ok((view.shape().to_vec(), view.iter().copied().collect()));
    }
    if let Ok(f) = obj.cast::<pyo3::types::PyFloat>() {
        return Ok((vec![], vec![f.value()]));
    }
    let py = obj.py();
    let np = py.import("numpy")?;
    let kw = PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    let arr = np.call_method("asarray", (obj,), Some(&kw)).map_err(|e| {
        PyValueError::new_err(format!("{name} is not convertible to a float array: {e}"))
    })?;
    let arr = arr
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|_| PyValueError::new_err(format!("{name} is not a float64 array")))?;
    let ro = arr
        .try_readonly()
        .map_err(|e| PyValueError::new_err(format!("{name} cannot be read: {e}")))?;
    let view = ro.as_array();
    Ok((view.shape().to_vec(), view.iter().copied().collect()))
}

fn check_finite(values: &[f64], name: &str) -> PyResult<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name} contains NaN or infinity"
        )))
    }
}

/// A finite `rows x cols` matrix from an array-like of exactly that shape
/// (a scalar or a 1-vector is accepted for `1 x 1`).
pub fn matrix(
    obj: &Bound<'_, PyAny>,
    rows: usize,
    cols: usize,
    name: &str,
) -> PyResult<DMatrix<f64>> {
    let (shape, v) = read_f64(obj, name)?;
    let ok =
        shape == [rows, cols] || (rows == 1 && cols == 1 && (shape.is_empty() || shape == [1]));
    if !ok {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({rows}, {cols}), got {shape:?}"
        )));
    }
    check_finite(&v, name)?;
    Ok(DMatrix::from_row_slice(rows, cols, &v))
}

/// A finite vector of length `n` from shape `(n,)`, `(n, 1)` or a scalar
/// when `n == 1`.
pub fn vector(obj: &Bound<'_, PyAny>, n: usize, name: &str) -> PyResult<DVector<f64>> {
    let (shape, v) = read_f64(obj, name)?;
    let ok = shape == [n] || shape == [n, 1] || (n == 1 && shape.is_empty());
    if !ok {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({n},) or ({n}, 1), got {shape:?}"
        )));
    }
    check_finite(&v, name)?;
    Ok(DVector::from_vec(v))
}

/// A 1-D numpy array.
pub fn py_vec<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    Array1::from_iter(v.iter().copied()).into_pyarray(py)
}

/// A 2-D numpy array.
pub fn py_mat<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// Static vector from a dynamic one of the same length.
#[inline]
pub fn sv<const N: usize>(v: &DVector<f64>) -> SVector<f64, N> {
    SVector::from_column_slice(v.as_slice())
}

/// Static matrix from a dynamic one of the same shape.
#[inline]
pub fn sm<const R: usize, const C: usize>(m: &DMatrix<f64>) -> SMatrix<f64, R, C> {
    SMatrix::from_column_slice(m.as_slice())
}

/// Dynamic vector from a static one.
#[inline]
pub fn dv<const N: usize>(v: &SVector<f64, N>) -> DVector<f64> {
    DVector::from_column_slice(v.as_slice())
}

/// Dynamic matrix from a static one.
#[inline]
pub fn dm<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

/// Checks that `n` (and `m`) are dimensions this wheel supports.
pub fn check_dims(dim_x: usize, dim_z: usize) -> PyResult<()> {
    if !(1..=MAX_X).contains(&dim_x) {
        return Err(PyValueError::new_err(format!(
            "dim_x = {dim_x} is not supported: this build supports 1 <= dim_x <= {MAX_X}"
        )));
    }
    if !(1..=MAX_Z).contains(&dim_z) {
        return Err(PyValueError::new_err(format!(
            "dim_z = {dim_z} is not supported: this build supports 1 <= dim_z <= {MAX_Z}"
        )));
    }
    Ok(())
}

/// Calls `f(args)` and reads the result as `len` finite values (any shape
/// with that many elements); errors are stored in `err` and NaN is returned
/// so the filter stops with a non-finite error, which the caller replaces
/// with the stored exception.
pub fn call_values(
    f: &Bound<'_, PyAny>,
    args: Bound<'_, pyo3::types::PyTuple>,
    kwargs: Option<&Bound<'_, PyDict>>,
    len: usize,
    name: &str,
    err: &RefCell<Option<PyErr>>,
) -> Option<Vec<f64>> {
    if err.borrow().is_some() {
        return None;
    }
    let r = f.call(args, kwargs).and_then(|out| {
        let (shape, v) = read_f64(&out, &format!("the result of {name}"))?;
        if v.len() != len {
            return Err(PyValueError::new_err(format!(
                "{name} returned shape {shape:?}; {len} values were expected"
            )));
        }
        if !v.iter().all(|x| x.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "{name} returned NaN or infinity"
            )));
        }
        Ok(v)
    });
    match r {
        Ok(v) => Some(v),
        Err(e) => {
            *err.borrow_mut() = Some(e);
            None
        }
    }
}

/// The stored callable error if there is one, else `f`.
pub fn prefer_stored(err: &RefCell<Option<PyErr>>, f: Fail) -> Fail {
    match err.borrow_mut().take() {
        Some(e) => Fail::Py(e),
        None => f,
    }
}

/// `match` on the state dimension, calling `$f::<N>(args)`.
macro_rules! dispatch_n {
    ($n:expr, $f:ident ( $($a:expr),* $(,)? )) => {
        match $n {
            1 => $f::<1>($($a),*),
            2 => $f::<2>($($a),*),
            3 => $f::<3>($($a),*),
            4 => $f::<4>($($a),*),
            5 => $f::<5>($($a),*),
            6 => $f::<6>($($a),*),
            _ => unreachable!("dimensions are checked at construction"),
        }
    };
}

/// `match` on the measurement dimension for a fixed state dimension.
macro_rules! dispatch_m {
    ($n:literal, $m:expr, $f:ident ( $($a:expr),* )) => {
        match $m {
            1 => $f::<$n, 1>($($a),*),
            2 => $f::<$n, 2>($($a),*),
            3 => $f::<$n, 3>($($a),*),
            4 => $f::<$n, 4>($($a),*),
            _ => unreachable!("dimensions are checked at construction"),
        }
    };
}

/// `match` on state and measurement dimensions, calling `$f::<N, M>(args)`.
macro_rules! dispatch_nm {
    ($n:expr, $m:expr, $f:ident ( $($a:expr),* $(,)? )) => {
        match $n {
            1 => dispatch_m!(1, $m, $f($($a),*)),
            2 => dispatch_m!(2, $m, $f($($a),*)),
            3 => dispatch_m!(3, $m, $f($($a),*)),
            4 => dispatch_m!(4, $m, $f($($a),*)),
            5 => dispatch_m!(5, $m, $f($($a),*)),
            6 => dispatch_m!(6, $m, $f($($a),*)),
            _ => unreachable!("dimensions are checked at construction"),
        }
    };
}

pub(crate) use {dispatch_m, dispatch_n, dispatch_nm};
