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
// --- filters (pypf) ---
mod particle;
mod pf_models;

use pyo3::prelude::*;

/// The compiled extension module.
#[pymodule]
fn _bayestrack(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<kalman::KalmanFilter>()?;
    m.add_class::<kalman::ExtendedKalmanFilter>()?;
    m.add_class::<kalman::IteratedExtendedKalmanFilter>()?;
    m.add_class::<kalman::UnscentedKalmanFilter>()?;
    // --- filters (pypf) ---
    m.add_class::<particle::ParticleFilter>()?;
    m.add_class::<kalman::HybridUkfIekf>()?;
    m.add_function(wrap_pyfunction!(particle::py_stream_seed, m)?)?;
    m.add_function(wrap_pyfunction!(particle::_hikpf_reference_run, m)?)?;
    m.add("MAX_DIM_X", util::MAX_X)?;
    m.add("MAX_DIM_Z", util::MAX_Z)?;
    Ok(())
}
