//! A Python callable seen by the filters as a function of the state,
//! optionally vectorised over the sigma points (one call on the
//! `(2N+1, N)` array instead of one call per point).

use std::cell::{Cell, RefCell};

use nalgebra::{SMatrix, SVector};
use numpy::IntoPyArray;
use numpy::ndarray::{Array1, Array2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::util::call_values;

/// How a single point is handed to the callable.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// `(N,)` (filterpy's UKF).
    Flat,
    /// `(N, 1)` (filterpy's KF/EKF column vectors).
    Column,
}

/// A Python function of a state `x` of dimension `N`, called as
/// `f(x, *extra, **kwargs)`.
pub struct PyMap<'a, 'py, const N: usize> {
    f: &'a Bound<'py, PyAny>,
    extra: Vec<Bound<'py, PyAny>>,
    kwargs: Option<&'a Bound<'py, PyDict>>,
    name: &'static str,
    err: &'a RefCell<Option<PyErr>>,
    shape: Shape,
    vectorized: bool,
    /// Points evaluated by one vectorised call and their images (row-major,
    /// `len` values per point).
    cache: RefCell<(Vec<SVector<f64, N>>, Vec<f64>)>,
    next: Cell<usize>,
}

impl<'a, 'py, const N: usize> PyMap<'a, 'py, N> {
    /// The callable `f`; errors (including wrong output sizes) go to `err`.
    pub fn new(
        f: &'a Bound<'py, PyAny>,
        extra: Vec<Bound<'py, PyAny>>,
        kwargs: Option<&'a Bound<'py, PyDict>>,
        name: &'static str,
        err: &'a RefCell<Option<PyErr>>,
        shape: Shape,
        vectorized: bool,
    ) -> Self {
        Self {
            f,
            extra,
            kwargs,
            name,
            err,
            shape,
            vectorized,
            cache: RefCell::new((Vec::new(), Vec::new())),
            next: Cell::new(0),
        }
    }

    fn call(&self, x: Bound<'py, PyAny>, len: usize) -> Option<Vec<f64>> {
        let mut v = Vec::with_capacity(1 + self.extra.len());
        v.push(x);
        v.extend(self.extra.iter().cloned());
        match PyTuple::new(self.f.py(), v) {
            Ok(args) => call_values(self.f, args, self.kwargs, len, self.name, self.err),
            Err(e) => {
                *self.err.borrow_mut() = Some(e);
                None
            }
        }
    }

    /// `len` values of `f(x)`, or `None` when the callable failed (the error
    /// is stored).
    fn values(&self, x: &SVector<f64, N>, len: usize) -> Option<Vec<f64>> {
        let py = self.f.py();
        if self.vectorized {
            let i = self.next.get();
            {
                let cache = self.cache.borrow();
                if i < cache.0.len() && cache.0[i] == *x {
                    self.next.set(i + 1);
                    return Some(cache.1[i * len..(i + 1) * len].to_vec());
                }
            }
            // a point that was not primed: one call on a (1, N) array
            let a = Array2::from_shape_fn((1, N), |(_, j)| x[j]).into_pyarray(py);
            return self.call(a.into_any(), len);
        }
        let a = match self.shape {
            Shape::Flat => Array1::from_iter(x.iter().copied())
                .into_pyarray(py)
                .into_any(),
            Shape::Column => Array2::from_shape_fn((N, 1), |(i, _)| x[i])
                .into_pyarray(py)
                .into_any(),
        };
        self.call(a, len)
    }

    /// `f(x)` as a vector; NaN when the callable failed.
    pub fn vector<const K: usize>(&self, x: &SVector<f64, N>) -> SVector<f64, K> {
        match self.values(x, K) {
            Some(v) => SVector::from_column_slice(&v),
            None => SVector::repeat(f64::NAN),
        }
    }

    /// `f(x)` as a `R x C` matrix (row-major values); NaN when it failed.
    pub fn matrix<const R: usize, const C: usize>(
        &self,
        x: &SVector<f64, N>,
    ) -> SMatrix<f64, R, C> {
        match self.values(x, R * C) {
            Some(v) => SMatrix::from_row_slice(&v),
            None => SMatrix::repeat(f64::NAN),
        }
    }

    /// For a vectorised callable: evaluate `points` (in the order in which
    /// the filter will ask for them) in one call on the `(len, N)` array,
    /// `len` values per point.
    pub fn prime(&self, points: Vec<SVector<f64, N>>, len: usize) {
        if !self.vectorized || points.is_empty() {
            return;
        }
        let py = self.f.py();
        let n = points.len();
        let a = Array2::from_shape_fn((n, N), |(i, j)| points[i][j]).into_pyarray(py);
        *self.cache.borrow_mut() = match self.call(a.into_any(), n * len) {
            Some(v) => (points, v),
            None => (Vec::new(), Vec::new()),
        };
        self.next.set(0);
    }
}
