//! `bayestrack.Tracker`: every tracker of the registry behind OpenCV's
//! tracker interface (`init(frame, box)`, `update(frame) -> (ok, box)`),
//! on the numpy arrays OpenCV gives.

use std::sync::Mutex;

use bayestrack_image::{BBox, ImageView};
use bayestrack_otb::clip_initial_box;
use bayestrack_trackers::{REGISTRY, TrackerError, tracker_info};
use numpy::ndarray::{ArrayView2, ArrayViewD, Axis, Ix2};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};

/// A `key=value` option from a keyword argument: `True`/`False` as
/// `true`/`false`, numbers as Python prints them (`repr`, the shortest
/// text that reads back), strings as they are.
pub fn option_value(key: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(if b.is_true() { "true" } else { "false" }.to_string());
    }
    if v.is_instance_of::<PyInt>() || v.is_instance_of::<PyFloat>() {
        return Ok(v.repr()?.to_string());
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(s.to_string());
    }
    // numpy scalars and the like: their float or int value
    if let Ok(i) = v.extract::<i64>() {
        return Ok(i.to_string());
    }
    if let Ok(f) = v.extract::<f64>() {
        return Ok(PyFloat::new(v.py(), f).repr()?.to_string());
    }
    Err(PyTypeError::new_err(format!(
        "option {key}: expected a bool, number or string, got {}",
        v.get_type().name()?
    )))
}

/// The keyword arguments as `key=value` pairs, in the order given.
pub fn options_of(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut set = Vec::new();
    if let Some(kw) = kwargs {
        for (k, v) in kw.iter() {
            let key: String = k.extract()?;
            let value = option_value(&key, &v)?;
            set.push((key, value));
        }
    }
    Ok(set)
}

/// A tracker error as a Python exception: `ValueError` with the Rust
/// message.
fn tracker_err(e: &TrackerError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The four numbers of a box given as any sequence (tuple, list, numpy
/// array, OpenCV's `Rect`).
fn read_box(b: &Bound<'_, PyAny>) -> PyResult<[f64; 4]> {
    let v: Vec<f64> = b
        .try_iter()
        .and_then(|it| it.map(|x| x?.extract::<f64>()).collect())
        .map_err(|_| {
            PyValueError::new_err("box must be a sequence of 4 numbers (x, y, width, height)")
        })?;
    let v: [f64; 4] = v.try_into().map_err(|v: Vec<f64>| {
        PyValueError::new_err(format!(
            "box must have 4 numbers (x, y, width, height), got {}",
            v.len()
        ))
    })?;
    if v.iter().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "box ({}, {}, {}, {}) contains NaN or infinity",
            v[0], v[1], v[2], v[3]
        )));
    }
    Ok(v)
}

/// Height, width and channels of a frame array, checked.
fn frame_shape(shape: &[usize]) -> PyResult<(usize, usize, usize)> {
    match *shape {
        [h, w] => Ok((h, w, 1)),
        [h, w, c @ (1 | 3)] => Ok((h, w, c)),
        [_, _, 4] => Err(PyValueError::new_err(
            "frame has 4 channels (BGRA?): give BGR or gray, e.g. cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)",
        )),
        _ => Err(PyValueError::new_err(format!(
            "frame must be (height, width) gray or (height, width, 3) colour, got shape {shape:?}"
        ))),
    }
}

/// The frame as the trackers read it (row-major RGB or gray), borrowed
/// from the numpy array where its layout allows (C-contiguous, and RGB or
/// gray), otherwise copied into `buf` (channels swapped from BGR).
/// Returns whether it was copied.
fn with_frame<R>(
    py: Python<'_>,
    frame: &Bound<'_, PyAny>,
    bgr: bool,
    buf: &mut Vec<u8>,
    f: impl FnOnce(ImageView<'_, u8>) -> R + Send,
) -> PyResult<(R, bool)>
where
    R: Send,
{
    let arr = frame.cast::<PyArrayDyn<u8>>().map_err(|_| {
        let what = frame
            .getattr("dtype")
            .map(|d| format!("an array of {d}"))
            .unwrap_or_else(|_| {
                frame
                    .get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            });
        PyValueError::new_err(format!(
            "frame must be a uint8 numpy array (as OpenCV gives), got {what}"
        ))
    })?;
    let (h, w, c) = frame_shape(arr.shape())?;
    if h == 0 || w == 0 {
        return Err(PyValueError::new_err(format!(
            "frame is empty ({w}x{h} pixels)"
        )));
    }
    let ro = arr
        .try_readonly()
        .map_err(|e| PyValueError::new_err(format!("frame cannot be read: {e}")))?;
    let swap = bgr && c == 3;
    // as_slice also takes Fortran order, whose memory is not row-major
    let slice = if swap || !arr.is_c_contiguous() {
        None
    } else {
        ro.as_slice().ok()
    };
    let view = ro.as_array();
    let out = py.detach(move || {
        let (data, copied): (&[u8], bool) = match slice {
            Some(s) => (s, false),
            None => {
                buf.clear();
                buf.resize(h * w * c, 0);
                copy_frame(&view, swap, buf);
                (&buf[..], true)
            }
        };
        let image = ImageView::from_slice(data, w, h, c, w * c);
        (image.map(f), copied)
    });
    let (r, copied) = out;
    let r = r.map_err(|e| PyValueError::new_err(format!("frame: {e}")))?;
    Ok((r, copied))
}

/// Copies a frame array of any strides into row-major `out` (`h * w * c`
/// bytes), swapping the first and third channels when `swap`: row by row,
/// each row as a slice where its pixels are contiguous.
fn copy_frame(view: &ArrayViewD<'_, u8>, swap: bool, out: &mut [u8]) {
    let rows: Vec<ArrayView2<'_, u8>> = match view.ndim() {
        // (H, W): each row as (W, 1)
        2 => view
            .outer_iter()
            .filter_map(|r| r.insert_axis(Axis(1)).into_dimensionality::<Ix2>().ok())
            .collect(),
        _ => view
            .outer_iter()
            .filter_map(|r| r.into_dimensionality::<Ix2>().ok())
            .collect(),
    };
    let row_len = out.len() / rows.len().max(1);
    for (row, dst) in rows.iter().zip(out.chunks_exact_mut(row_len.max(1))) {
        match (row.as_slice(), swap) {
            (Some(src), false) => dst.copy_from_slice(src),
            (Some(src), true) => {
                for (d, p) in dst.chunks_exact_mut(3).zip(src.chunks_exact(3)) {
                    d[0] = p[2];
                    d[1] = p[1];
                    d[2] = p[0];
                }
            }
            (None, _) => {
                for (d, p) in dst.chunks_exact_mut(row.ncols()).zip(row.outer_iter()) {
                    for (k, v) in d.iter_mut().enumerate() {
                        let from = if swap { 2 - k } else { k };
                        *v = p[from];
                    }
                }
            }
        }
    }
}

/// The tracker and what it keeps between calls.
struct State {
    tracker: Box<dyn bayestrack_trackers::Tracker>,
    /// Frame copy (BGR swapped to RGB, or a strided array made contiguous).
    buf: Vec<u8>,
    initialised: bool,
    /// Whether the last frame was copied.
    copied: bool,
    /// The box the tracker was initialised with (clipped to the frame).
    init: Option<BBox>,
    lost: bool,
    particles: usize,
}

/// A single-target tracker with OpenCV's interface:
/// ``tracker.init(frame, box)`` then ``ok, box = tracker.update(frame)`` per
/// frame.
///
/// ``name`` is any tracker of :func:`tracker_names` (``bayestrack
/// trackers``); keyword options are the tracker's ``key=value`` options
/// (``bayestrack track --set``), ``True``/``False`` for booleans; an unknown
/// key or a bad value raises ``ValueError`` naming the valid keys.
///
/// Frames are uint8 numpy arrays: ``(H, W, 3)`` colour in OpenCV's BGR
/// order by default (``bgr=False`` for RGB arrays), or ``(H, W)`` gray; any
/// strides. A C-contiguous gray or RGB array is read in place; a BGR frame
/// is copied once into RGB order (a strided one into a contiguous buffer),
/// see :attr:`copied`. Boxes are ``(x, y, width, height)`` with a 0-based
/// top-left corner as OpenCV's (``one_based=True`` for the OTB ground-truth
/// convention the CLI writes). ``update`` releases the GIL.
#[pyclass(module = "bayestrack._bayestrack", name = "Tracker")]
pub struct Tracker {
    state: Mutex<State>,
    name: &'static str,
    seed: u64,
    bgr: bool,
    one_based: bool,
    set: Vec<(String, String)>,
}

impl Tracker {
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, State>> {
        // never block while holding the GIL: the holder may be waiting for
        // it at the end of its own update
        self.state.try_lock().map_err(|e| match e {
            std::sync::TryLockError::WouldBlock => PyRuntimeError::new_err(format!(
                "{}: in use by another thread (a tracker follows one video at a time)",
                self.name
            )),
            std::sync::TryLockError::Poisoned(_) => {
                PyRuntimeError::new_err("tracker state poisoned by an earlier panic")
            }
        })
    }

    fn out_box(&self, b: BBox) -> (f64, f64, f64, f64) {
        let o = if self.one_based { 0.0 } else { 1.0 };
        (b.x - o, b.y - o, b.width, b.height)
    }
}

#[pymethods]
impl Tracker {
    #[new]
    #[pyo3(signature = (name, *, seed = 0, bgr = true, one_based = false, **options))]
    fn new(
        name: &str,
        seed: u64,
        bgr: bool,
        one_based: bool,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let info = tracker_info(name).map_err(|e| tracker_err(&e))?;
        let set = options_of(options)?;
        let tracker = info.build_with(seed, &set).map_err(|e| tracker_err(&e))?;
        Ok(Self {
            state: Mutex::new(State {
                tracker,
                buf: Vec::new(),
                initialised: false,
                copied: false,
                init: None,
                lost: false,
                particles: 0,
            }),
            name: info.name,
            seed,
            bgr,
            one_based,
            set,
        })
    }

    /// Starts tracking ``box`` = ``(x, y, width, height)`` in ``frame``. A
    /// box reaching outside the frame is clipped to it (as ``bayestrack
    /// track`` does); one wholly outside, empty or not finite raises
    /// ``ValueError``. Calling it again restarts the tracker.
    #[pyo3(signature = (frame, r#box))]
    fn init(
        &self,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        r#box: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let v = read_box(r#box)?;
        let o = if self.one_based { 0.0 } else { 1.0 };
        let target = BBox::new(v[0] + o, v[1] + o, v[2], v[3]);
        // a fresh tracker, so that init restarts
        let info = tracker_info(self.name).map_err(|e| tracker_err(&e))?;
        let fresh = info
            .build_with(self.seed, &self.set)
            .map_err(|e| tracker_err(&e))?;
        let mut guard = self.lock()?;
        let st = &mut *guard;
        st.tracker = fresh;
        st.initialised = false;
        let tracker = &mut st.tracker;
        let (r, copied) = with_frame(py, frame, self.bgr, &mut st.buf, |im| {
            let init = clip_initial_box(target, im.width(), im.height()).unwrap_or(target);
            tracker.init(im, init).map(|()| init)
        })?;
        st.copied = copied;
        let init = r.map_err(|e| tracker_err(&e))?;
        st.init = Some(init);
        st.initialised = true;
        st.lost = false;
        st.particles = 0;
        Ok(())
    }

    /// Tracks into the next frame: ``(ok, (x, y, width, height))``, ``ok``
    /// false when the tracker says it lost the target (the box is then its
    /// last guess). Raises ``ValueError`` before :meth:`init`, for a frame of
    /// another size or channel count than the first, or a bad array.
    fn update(
        &self,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
    ) -> PyResult<(bool, (f64, f64, f64, f64))> {
        let mut guard = self.lock()?;
        let st = &mut *guard;
        if !st.initialised {
            return Err(PyValueError::new_err(format!(
                "{}: update before init (call init(frame, box) first)",
                self.name
            )));
        }
        let tracker = &mut st.tracker;
        let (r, copied) = with_frame(py, frame, self.bgr, &mut st.buf, |im| tracker.step(im))?;
        st.copied = copied;
        let e = r.map_err(|e| tracker_err(&e))?;
        st.lost = e.lost;
        st.particles = e.particles;
        Ok((!e.lost, self.out_box(e.bbox)))
    }

    /// The tracker's registry name.
    #[getter]
    fn name(&self) -> &'static str {
        self.name
    }

    /// The options given, as ``key=value`` strings in the order given.
    #[getter]
    fn options(&self) -> Vec<String> {
        self.set.iter().map(|(k, v)| format!("{k}={v}")).collect()
    }

    /// The box :meth:`init` started from, clipped to the first frame, in
    /// this tracker's box convention (``None`` before ``init``).
    #[getter]
    fn init_box(&self) -> PyResult<Option<(f64, f64, f64, f64)>> {
        Ok(self.lock()?.init.map(|b| self.out_box(b)))
    }

    /// Whether the last frame was copied (BGR to RGB, or a strided array)
    /// rather than read in place.
    #[getter]
    fn copied(&self) -> PyResult<bool> {
        Ok(self.lock()?.copied)
    }

    /// Particles the tracker used on the last frame (0 for deterministic
    /// trackers).
    #[getter]
    fn particles(&self) -> PyResult<usize> {
        Ok(self.lock()?.particles)
    }

    fn __repr__(&self) -> String {
        let mut s = format!("Tracker({:?}", self.name);
        if self.seed != 0 {
            s.push_str(&format!(", seed={}", self.seed));
        }
        for (k, v) in &self.set {
            s.push_str(&format!(", {k}={v:?}"));
        }
        s.push(')');
        s
    }
}

/// The names of every registered tracker, in the order ``bayestrack
/// trackers`` lists them.
#[pyfunction]
pub fn tracker_names() -> Vec<&'static str> {
    REGISTRY.iter().map(|t| t.name).collect()
}

/// The options of tracker ``name``: a list of dicts with ``key``, ``type``,
/// ``domain``, ``default`` (as text, as ``--set`` reads it) and ``doc``.
#[pyfunction]
pub fn tracker_options<'py>(py: Python<'py>, name: &str) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let info = tracker_info(name).map_err(|e| tracker_err(&e))?;
    info.options()
        .into_iter()
        .map(|s| {
            let d = PyDict::new(py);
            d.set_item("key", s.key)?;
            d.set_item("type", s.ty)?;
            d.set_item("domain", s.domain)?;
            d.set_item("default", s.default)?;
            d.set_item("doc", s.doc)?;
            Ok(d)
        })
        .collect()
}
