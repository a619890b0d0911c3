//! `bayestrack.reproduce_table`: the paper experiments of `cargo xtask
//! reproduce-table`, their tables as Python rows.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use bayestrack_experiments::{ExperimentError, Mode, REGISTRY, RunOptions, find};
use bayestrack_otb::Table;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::tracking::options_of;

/// An experiment error as a Python exception: `OSError` for a file that
/// cannot be written, `ValueError` otherwise; with the Rust message.
fn experiment_err(e: &ExperimentError) -> PyErr {
    match e {
        ExperimentError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// A printed cell as a Python value: an int or a float where the whole
/// cell is one, the text otherwise (`0.31 ± 0.02`, `-`, `n/a`).
fn cell<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    let t = text.trim();
    if let Ok(i) = t.parse::<i64>() {
        return Ok(i.into_pyobject(py)?.into_any());
    }
    // "inf"/"nan" stay text: no silent NaN
    if let Ok(f) = t.parse::<f64>()
        && f.is_finite()
    {
        return Ok(f.into_pyobject(py)?.into_any());
    }
    Ok(text.into_pyobject(py)?.into_any())
}

/// The rows of `tables` as dicts (`table` = the table's title, then one
/// key per column header).
fn rows<'py>(py: Python<'py>, tables: &[Table]) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for t in tables {
        for r in &t.rows {
            let d = PyDict::new(py);
            d.set_item("table", &t.title)?;
            for (h, c) in t.header.iter().zip(r) {
                d.set_item(h, cell(py, c)?)?;
            }
            out.append(d)?;
        }
    }
    Ok(out)
}

/// A fresh scratch folder for a run whose files are not kept.
fn scratch_dir() -> PathBuf {
    static RUN: AtomicUsize = AtomicUsize::new(0);
    std::env::temp_dir().join(format!(
        "bayestrack-py-reproduce-{}-{}",
        std::process::id(),
        RUN.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Runs the paper experiment ``name`` (see :func:`experiment_names`) as
/// ``cargo xtask reproduce-table NAME`` does and returns its tables as a
/// list of dicts, one per row: ``table`` (the table's title), then one key
/// per column, numbers as ``int``/``float`` and other cells as printed
/// text. With pandas installed the Python wrapper returns a
/// ``pandas.DataFrame`` of the same rows.
///
/// ``full=False`` is quick mode (seconds; CI's numbers), ``full=True`` the
/// paper-scale run (minutes to hours). Keyword options are the
/// experiment's ``--set key=value`` options (``ValueError`` naming the
/// valid keys for an unknown one). The CSV and SVG files go to
/// ``out/<name>/`` when ``out`` is given, to a temporary folder removed
/// afterwards otherwise. Runs without the GIL.
#[pyfunction]
#[pyo3(signature = (name, full = false, *, out = None, **options))]
pub fn reproduce_rows<'py>(
    py: Python<'py>,
    name: &str,
    full: bool,
    out: Option<PathBuf>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyList>> {
    // checked here; found again inside the run, which needs no Python
    find(name).map_err(|e| experiment_err(&e))?;
    let set = options_of(options)?;
    let keep = out.is_some();
    let dir = out.unwrap_or_else(scratch_dir);
    let opts = RunOptions {
        mode: if full { Mode::Full } else { Mode::Quick },
        out: dir.clone(),
        progress: false,
        set,
        shard: None,
    };
    let result = py.detach(|| {
        let r = find(name).and_then(|e| bayestrack_experiments::experiment::run_marked(e, &opts));
        if !keep {
            // a scratch folder: nothing in it is the caller's
            let _ = std::fs::remove_dir_all(&dir);
        }
        r
    });
    let tables = result.map_err(|e| experiment_err(&e))?;
    rows(py, &tables)
}

/// The ids of every paper experiment, in the order ``reproduce-table all``
/// runs them.
#[pyfunction]
pub fn experiment_names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.id()).collect()
}
