//! Python bindings of bayestrack (PyO3 + rust-numpy), built by maturin into
//! the `bayestrack` wheel (module `bayestrack._bayestrack`; the Python
//! package `bayestrack` re-exports it).
//!
//! The filters are const-generic in Rust; the bindings dispatch at run time
//! over the sizes they are compiled for (`1 <= dim_x <= 6`,
//! `1 <= dim_z <= 4`).

mod kalman;
mod pymap;
mod util;

use pyo3::prelude::*;

/// The compiled extension module.
#[pymodule]
fn _bayestrack(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<kalman::KalmanFilter>()?;
    m.add_class::<kalman::ExtendedKalmanFilter>()?;
    m.add_class::<kalman::IteratedExtendedKalmanFilter>()?;
    m.add_class::<kalman::UnscentedKalmanFilter>()?;
    m.add("MAX_DIM_X", util::MAX_X)?;
    m.add("MAX_DIM_Z", util::MAX_Z)?;
    Ok(())
}
