//! `bayestrack.otb`: OTB scoring (`score`) and sequence folders
//! (`load_sequence`) with their frames decoded one at a time.

use std::path::PathBuf;

use bayestrack_image::{BBox, Image, ImageError};
use bayestrack_otb::metrics::score_otb;
use bayestrack_otb::{OtbError, Sequence};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyFileNotFoundError, PyIndexError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use crate::util::read_f64;

/// An OTB error as a Python exception: `FileNotFoundError` for a missing
/// folder, `OSError` for a file that cannot be read, `ValueError` for
/// everything else; always with the Rust message.
pub fn otb_err(e: &OtbError) -> PyErr {
    let msg = e.to_string();
    match e {
        OtbError::MissingFolder { .. } => PyFileNotFoundError::new_err(msg),
        OtbError::MissingFrame { .. }
        | OtbError::NoGroundTruth { .. }
        | OtbError::Read { .. }
        | OtbError::Write(_)
        | OtbError::Image(ImageError::Io { .. }) => PyOSError::new_err(msg),
        OtbError::Frame { source, .. } if matches!(**source, ImageError::Io { .. }) => {
            PyOSError::new_err(msg)
        }
        _ => PyValueError::new_err(msg),
    }
}

/// Boxes from an `(N, 4)` array-like; with `labels`, a row of `None`, all
/// NaN or all zero (OTB's `0,0,0,0`) is unlabelled.
fn read_boxes(obj: &Bound<'_, PyAny>, name: &str, labels: bool) -> PyResult<Vec<Option<BBox>>> {
    let row = |v: &[f64], i: usize| -> PyResult<Option<BBox>> {
        if labels && (v.iter().all(|x| x.is_nan()) || v.iter().all(|&x| x == 0.0)) {
            return Ok(None);
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "{name}[{i}] = {v:?} contains NaN or infinity{}",
                if labels {
                    " (an unlabelled row is all NaN, all zero or None)"
                } else {
                    ""
                }
            )));
        }
        Ok(Some(BBox::new(v[0], v[1], v[2], v[3])))
    };
    // a list with None rows (unlabelled frames)
    if labels && (obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>()) {
        let mut out = Vec::new();
        for (i, r) in obj.try_iter()?.enumerate() {
            let r = r?;
            if r.is_none() {
                out.push(None);
                continue;
            }
            let (shape, v) = read_f64(&r, &format!("{name}[{i}]"))?;
            if shape != [4] {
                return Err(PyValueError::new_err(format!(
                    "{name}[{i}] must be 4 numbers (x, y, width, height) or None, got shape {shape:?}"
                )));
            }
            out.push(row(&v, i)?);
        }
        return Ok(out);
    }
    let (shape, v) = read_f64(obj, name)?;
    if shape.len() != 2 || shape[1] != 4 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (N, 4) (x, y, width, height per frame), got {shape:?}"
        )));
    }
    v.chunks_exact(4)
        .enumerate()
        .map(|(i, r)| row(r, i))
        .collect()
}

fn optional_array<'py>(py: Python<'py>, v: &[Option<f64>]) -> Bound<'py, PyArray1<f64>> {
    v.iter()
        .map(|x| x.unwrap_or(f64::NAN))
        .collect::<Vec<_>>()
        .into_pyarray(py)
}

/// OTB scores of ``boxes`` against ground truth ``gt``, as
/// ``bayestrack-otb`` computes them (``cargo xtask otb``, ``bayestrack
/// track``): both ``(N, 4)`` ``(x, y, width, height)`` in the same
/// convention (the scores do not depend on which). Unlabelled ``gt`` rows
/// (``None``, all NaN, or OTB's ``0,0,0,0``) are not scored.
///
/// Returns a dict: ``success_auc`` (mean of the success curve),
/// ``precision_20`` (fraction of scored frames with centre error <= 20
/// px), ``success_rate_50`` (fraction with overlap > 0.5),
/// ``success_curve`` (21 values at thresholds 0, 0.05, ..., 1),
/// ``frames_scored``, ``mean_overlap``, ``mean_center_error``, and per
/// frame ``overlaps`` and ``center_errors`` (NaN on unlabelled frames).
/// Raises ``ValueError`` for lists of different lengths, a box that is not
/// finite or has negative size, or no labelled frame.
#[pyfunction]
pub fn score<'py>(
    py: Python<'py>,
    gt: &Bound<'py, PyAny>,
    boxes: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let truth = read_boxes(gt, "gt", true)?;
    let predicted: Vec<BBox> = read_boxes(boxes, "boxes", false)?
        .into_iter()
        .flatten()
        .collect();
    let s = score_otb(&predicted, &truth).map_err(|e| otb_err(&e))?;
    let d = PyDict::new(py);
    d.set_item("success_auc", s.auc)?;
    d.set_item("precision_20", s.precision_20)?;
    d.set_item("success_rate_50", s.success_rate_50)?;
    d.set_item("success_curve", s.success.to_vec())?;
    d.set_item("frames_scored", s.frames_scored)?;
    d.set_item("mean_overlap", s.mean_overlap)?;
    d.set_item("mean_center_error", s.mean_center_error)?;
    d.set_item("overlaps", optional_array(py, &s.overlaps))?;
    d.set_item("center_errors", optional_array(py, &s.center_errors))?;
    Ok(d)
}

/// A decoded frame as a numpy array: `(H, W)` gray or `(H, W, 3)` in BGR
/// (OpenCV's order) or RGB order.
fn frame_array(py: Python<'_>, image: Image<u8>, bgr: bool) -> PyResult<Bound<'_, PyAny>> {
    let (w, h, c) = (image.width(), image.height(), image.channels());
    let mut data = image.into_vec();
    if bgr && c == 3 {
        for p in data.chunks_exact_mut(3) {
            p.swap(0, 2);
        }
    }
    let shape_err = |e: numpy::ndarray::ShapeError| PyValueError::new_err(e.to_string());
    Ok(if c == 1 {
        Array2::from_shape_vec((h, w), data)
            .map_err(shape_err)?
            .into_pyarray(py)
            .into_any()
    } else {
        Array3::from_shape_vec((h, w, c), data)
            .map_err(shape_err)?
            .into_pyarray(py)
            .into_any()
    })
}

/// A tracking sequence on disk (:func:`load_sequence`): its frames, decoded
/// one at a time when asked for, and its ground truth.
///
/// ``len(seq)`` frames; ``seq[i]`` decodes frame ``i``; iterating decodes
/// them in order, one at a time (memory does not grow with the sequence).
/// Frames are ``(H, W)`` gray or ``(H, W, 3)`` colour uint8 arrays, in
/// OpenCV's BGR order unless ``bgr=False`` was given.
#[pyclass(module = "bayestrack._bayestrack", name = "TrackingSequence", frozen)]
pub struct PySequence {
    seq: Sequence,
    bgr: bool,
    one_based: bool,
}

impl PySequence {
    fn decode<'py>(&self, py: Python<'py>, index: usize) -> PyResult<Bound<'py, PyAny>> {
        let seq = &self.seq;
        let image = py.detach(|| seq.frame(index)).map_err(|e| otb_err(&e))?;
        frame_array(py, image, self.bgr)
    }
}

#[pymethods]
impl PySequence {
    /// The sequence's name (its folder, or the OTB-100 target).
    #[getter]
    fn name(&self) -> &str {
        &self.seq.name
    }

    /// The sequence folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.seq.dir.clone()
    }

    /// The frame files, in order.
    #[getter]
    fn files(&self) -> Vec<PathBuf> {
        self.seq.frames.clone()
    }

    /// Ground truth, ``(N, 4)`` float64 ``(x, y, width, height)`` per frame
    /// (0-based corner unless ``one_based=True``); rows of unlabelled frames
    /// are NaN (see :attr:`labelled`).
    #[getter]
    fn groundtruth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let o = if self.one_based { 0.0 } else { 1.0 };
        let n = self.seq.len();
        let mut a = Array2::from_elem((n, 4), f64::NAN);
        for (i, b) in self.seq.ground_truth.iter().enumerate().take(n) {
            if let Some(b) = b {
                a[[i, 0]] = b.x - o;
                a[[i, 1]] = b.y - o;
                a[[i, 2]] = b.width;
                a[[i, 3]] = b.height;
            }
        }
        Ok(a.into_pyarray(py))
    }

    /// Per frame, whether it has a ground-truth box (a bool array).
    #[getter]
    fn labelled<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let n = self.seq.len();
        (0..n)
            .map(|i| self.seq.ground_truth.get(i).copied().flatten().is_some())
            .collect::<Vec<_>>()
            .into_pyarray(py)
    }

    /// The box to initialise a tracker with (frame 0's ground truth), or
    /// ``None`` when frame 0 is unlabelled.
    #[getter]
    fn init_box(&self) -> Option<(f64, f64, f64, f64)> {
        let o = if self.one_based { 0.0 } else { 1.0 };
        self.seq
            .initial_box()
            .map(|b| (b.x - o, b.y - o, b.width, b.height))
    }

    /// What the loader noted (frames without a ground-truth row, ...).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.seq.notes.clone()
    }

    fn __len__(&self) -> usize {
        self.seq.len()
    }

    /// Frame ``index`` (negative counts from the end), decoded now.
    fn __getitem__<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyAny>> {
        let n = self.seq.len() as isize;
        let i = if index < 0 { index + n } else { index };
        if i < 0 || i >= n {
            return Err(PyIndexError::new_err(format!(
                "frame {index} of a {n}-frame sequence"
            )));
        }
        self.decode(py, i as usize)
    }

    fn __iter__(slf: Bound<'_, Self>) -> FrameIter {
        FrameIter {
            seq: slf.unbind(),
            next: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Sequence({:?}, {} frames, {} labelled)",
            self.seq.name,
            self.seq.len(),
            self.seq.labelled()
        )
    }
}

/// Iterator over a :class:`Sequence`'s frames, decoding each when asked.
#[pyclass(module = "bayestrack._bayestrack", frozen)]
pub struct FrameIter {
    seq: Py<PySequence>,
    next: std::sync::atomic::AtomicUsize,
}

#[pymethods]
impl FrameIter {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let seq = self.seq.get();
        let i = self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if i >= seq.seq.len() {
            return Ok(None);
        }
        seq.decode(py, i).map(Some)
    }
}

/// Opens the tracking sequence in folder ``path``: an OTB folder
/// (``img/`` and ``groundtruth_rect.txt``, OTB-100's frame ranges), or any
/// folder of numbered PNG/JPEG frames with a ``*_gt.txt`` or
/// ``groundtruth_rect.txt`` file, as ``bayestrack track --seq`` reads it.
/// Lists the frames without decoding them.
///
/// ``bgr`` (default True): colour frames in OpenCV's BGR order (False:
/// RGB). ``one_based`` (default False): boxes with a 0-based corner as
/// OpenCV's (True: OTB's 1-based files as they are). ``require_groundtruth``
/// (default True): False opens a folder without a ground-truth file (every
/// frame unlabelled).
///
/// Raises ``FileNotFoundError`` for a missing folder, ``OSError`` for a
/// folder without ground truth or an unreadable file, ``ValueError`` for a
/// ground-truth row that does not parse (naming file and line).
#[pyfunction]
#[pyo3(signature = (path, *, bgr = true, one_based = false, require_groundtruth = true))]
pub fn load_sequence(
    py: Python<'_>,
    path: PathBuf,
    bgr: bool,
    one_based: bool,
    require_groundtruth: bool,
) -> PyResult<PySequence> {
    let seq = py
        .detach(|| {
            if require_groundtruth {
                Sequence::open(&path)
            } else {
                Sequence::open_frames(&path)
            }
        })
        .map_err(|e| otb_err(&e))?;
    Ok(PySequence {
        seq,
        bgr,
        one_based,
    })
}

/// A box as ``bayestrack track`` writes it in its ``--out`` file:
/// ``x,y,w,h`` with at most two decimals (``1,2.5,10.13,3``).
#[pyfunction]
pub fn format_box(r#box: &Bound<'_, PyAny>) -> PyResult<String> {
    let (shape, v) = read_f64(r#box, "box")?;
    if shape != [4] {
        return Err(PyValueError::new_err(format!(
            "box must be 4 numbers (x, y, width, height), got shape {shape:?}"
        )));
    }
    Ok(bayestrack_otb::write::box_row(&BBox::new(
        v[0], v[1], v[2], v[3],
    )))
}
