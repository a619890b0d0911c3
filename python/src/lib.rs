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
// --- trackers (pytrack) ---
mod experiments;
mod otb;
mod tracking;

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
    // --- trackers (pytrack) ---
    m.add_class::<tracking::Tracker>()?;
    m.add_function(wrap_pyfunction!(tracking::tracker_names, m)?)?;
    m.add_function(wrap_pyfunction!(tracking::tracker_options, m)?)?;
    m.add_class::<otb::PySequence>()?;
    m.add_class::<otb::FrameIter>()?;
    m.add_function(wrap_pyfunction!(otb::score, m)?)?;
    m.add_function(wrap_pyfunction!(otb::load_sequence, m)?)?;
    m.add_function(wrap_pyfunction!(otb::format_box, m)?)?;
    m.add_function(wrap_pyfunction!(experiments::reproduce_rows, m)?)?;
    m.add_function(wrap_pyfunction!(experiments::experiment_names, m)?)?;
    Ok(())
}
