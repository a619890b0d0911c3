//! `ParticleFilter`: a bootstrap (sequential importance resampling)
//! particle filter whose model is either two vectorised Python callables
//! or one of the models built into the wheel ([`crate::pf_models`]), which
//! run entirely in Rust with [`Smc`].

use bayestrack_particle::nalgebra::SVector;
use bayestrack_particle::{
    Bootstrap, Model, ParticleError, ParticleFilter as PfConfig, ParticleSet, ResamplePolicy,
    Resampler, Resampling, Smc, stream_rng, stream_seed,
};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyNotImplementedError, PyValueError};
use pyo3::prelude::*;

use crate::pf_models::{ConstantVelocity, Hikpf};
use crate::util::read_f64;

/// Stream id of the resampling draw of a step, beyond any chunk index (as
/// the particle crate numbers its own).
const RESAMPLE_STREAM: u64 = u64::MAX;

/// Largest number of particles (the arrays are `n x dim` float64).
const MAX_PARTICLES: usize = 100_000_000;

fn particle_err(e: &ParticleError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn scheme(name: &str) -> PyResult<Resampling> {
    Resampling::ALL
        .into_iter()
        .find(|s| s.name() == name)
        .ok_or_else(|| {
            let names: Vec<&str> = Resampling::ALL.iter().map(|s| s.name()).collect();
            PyValueError::new_err(format!("resampling = {name:?} is not one of {names:?}"))
        })
}

fn policy(ess_threshold: Option<f64>) -> PyResult<ResamplePolicy> {
    match ess_threshold {
        None => Ok(ResamplePolicy::Always),
        Some(t) if (0.0..=1.0).contains(&t) => Ok(ResamplePolicy::Ess(t)),
        Some(t) => Err(PyValueError::new_err(format!(
            "ess_threshold = {t} must be in [0, 1] (or None: resample after every step)"
        ))),
    }
}

/// The first row of an `n x dim` row-major array with a NaN or infinite
/// entry.
fn first_bad_row(v: &[f64], dim: usize) -> Option<usize> {
    v.iter().position(|x| !x.is_finite()).map(|i| i / dim)
}

/// Initial particles: `None` (zeros, or `default` for every particle), a
/// `(dim,)` state copied to every particle, or an `(n, dim)` array.
fn initial_particles(
    particles: Option<&Bound<'_, PyAny>>,
    n: usize,
    dim: usize,
    default: f64,
) -> PyResult<Vec<f64>> {
    let Some(p) = particles else {
        return Ok(vec![default; n * dim]);
    };
    let (shape, v) = read_f64(p, "particles")?;
    let out = if shape == [n, dim] || (dim == 1 && shape == [n]) {
        v
    } else if shape == [dim] || (dim == 1 && shape.is_empty()) {
        v.iter().copied().cycle().take(n * dim).collect()
    } else {
        return Err(PyValueError::new_err(format!(
            "particles must have shape ({n}, {dim}) or ({dim},), not {shape:?}"
        )));
    };
    if let Some(i) = first_bad_row(&out, dim) {
        return Err(PyValueError::new_err(format!(
            "particles: particle {i} has a NaN or infinite entry"
        )));
    }
    Ok(out)
}

// ------------------------------------------------------- built-in models

/// A built-in model: its observation from the values of `z`.
trait Observe<const N: usize>: Model<N, Observation = Self::Z> + Send {
    /// The observation type.
    type Z: Sync;
    /// Length of `z`.
    const LEN: usize;
    /// The observation from `LEN` finite values.
    fn observation(z: &[f64]) -> Self::Z;
}

impl Observe<1> for Hikpf {
    type Z = f64;
    const LEN: usize = 1;
    fn observation(z: &[f64]) -> f64 {
        z[0]
    }
}

macro_rules! cv_observe {
    ($a:literal, $n:literal) => {
        impl Observe<$n> for ConstantVelocity<$a> {
            type Z = SVector<f64, $a>;
            const LEN: usize = $a;
            fn observation(z: &[f64]) -> SVector<f64, $a> {
                SVector::from_column_slice(z)
            }
        }
    };
}
cv_observe!(1, 2);
cv_observe!(2, 4);
cv_observe!(3, 6);

/// What the class needs of a built-in model's filter, whatever its size.
trait Engine: Send + Sync {
    /// One step with measurement `z` (`z_len` finite values): the step's
    /// estimate and its ESS before resampling.
    fn step(&mut self, z: &[f64]) -> Result<(Vec<f64>, f64), ParticleError>;
    fn particles(&self) -> Vec<f64>;
    fn log_weights(&self) -> Vec<f64>;
    fn log_evidence(&self) -> f64;
    fn k(&self) -> usize;
    fn z_len(&self) -> usize;
}

struct Builtin<M, const N: usize> {
    model: M,
    smc: Smc<SVector<f64, N>>,
}

impl<M: Observe<N> + Sync, const N: usize> Engine for Builtin<M, N> {
    fn step(&mut self, z: &[f64]) -> Result<(Vec<f64>, f64), ParticleError> {
        let z = M::observation(z);
        let r = self.smc.step(&Bootstrap(&self.model), &z)?;
        Ok((r.mean.iter().copied().collect(), r.ess))
    }
    fn particles(&self) -> Vec<f64> {
        self.smc
            .set
            .particles()
            .iter()
            .flat_map(|p| p.iter().copied())
            .collect()
    }
    fn log_weights(&self) -> Vec<f64> {
        self.smc.set.log_weights().to_vec()
    }
    fn log_evidence(&self) -> f64 {
        self.smc.log_evidence()
    }
    fn k(&self) -> usize {
        self.smc.k()
    }
    fn z_len(&self) -> usize {
        M::LEN
    }
}

fn builtin<M: Observe<N> + Sync + 'static, const N: usize>(
    model: M,
    config: PfConfig,
    particles: &[f64],
    seed: u64,
) -> PyResult<Box<dyn Engine>> {
    let ps = particles
        .chunks_exact(N)
        .map(SVector::<f64, N>::from_column_slice)
        .collect();
    let set = ParticleSet::new(ps).map_err(|e| particle_err(&e))?;
    let smc = Smc::new(config, set, seed).map_err(|e| particle_err(&e))?;
    Ok(Box::new(Builtin { model, smc }))
}

// ---------------------------------------------------------- Python model

/// The particles and weights of a filter whose model is Python.
struct PyModel {
    sample: Py<PyAny>,
    log_likelihood: Py<PyAny>,
    particles: Vec<f64>,
    /// Normalised log-weights.
    log_w: Vec<f64>,
    k: usize,
    log_evidence: f64,
}

enum Inner {
    Py(PyModel),
    Rust(Box<dyn Engine>),
}

/// A bootstrap particle filter (sequential importance resampling, Nagy,
/// Ahmed and Zayed (paper 000) sec. 2.3).
///
/// With a Python model, ``sample(particles, k, rng)`` returns the
/// propagated ``(n, dim)`` array and ``log_likelihood(particles, z, k)``
/// the ``(n,)`` log-likelihoods; each is called once per step on the whole
/// array, never per particle. ``rng`` is
/// ``numpy.random.default_rng(stream_seed([seed, k]))``: a fresh generator
/// per step, so the same seed gives the same run. The built-in models
/// (``ParticleFilter.hikpf``, ``ParticleFilter.constant_velocity``) run
/// entirely in Rust (without the GIL, on ``threads`` threads) and give the
/// same bits as the Rust API (``Smc`` with ``Bootstrap``) for the same
/// seed, on any number of threads.
///
/// Resampling (``"systematic"``, ``"multinomial"``, ``"residual"`` or
/// ``"stratified"``) follows every step, or with ``ess_threshold = t``
/// only when the ESS falls below ``t n``; the resampling draw of step
/// ``k`` comes from the key ``[seed, k, 2**64 - 1]``.
#[pyclass(module = "bayestrack._bayestrack")]
pub struct ParticleFilter {
    n: usize,
    dim: usize,
    config: PfConfig,
    seed: u64,
    pool: Option<rayon::ThreadPool>,
    inner: Inner,
    /// ESS before resampling of the last step (`n` before any).
    ess: f64,
    /// Estimate of the last step.
    estimate: Option<Vec<f64>>,
}

impl ParticleFilter {
    #[allow(clippy::too_many_arguments)]
    fn build(
        n: usize,
        dim: usize,
        resampling: &str,
        ess_threshold: Option<f64>,
        seed: u64,
        threads: Option<usize>,
        make: impl FnOnce(PfConfig) -> PyResult<Inner>,
    ) -> PyResult<Self> {
        if n == 0 || n > MAX_PARTICLES {
            return Err(PyValueError::new_err(format!(
                "n = {n} particles: must be in 1..={MAX_PARTICLES}"
            )));
        }
        let config = PfConfig {
            resampling: scheme(resampling)?,
            policy: policy(ess_threshold)?,
            ..PfConfig::default()
        };
        let pool = match threads {
            None => None,
            Some(0) => {
                return Err(PyValueError::new_err(
                    "threads = 0: must be at least 1 (or None: rayon's global pool)",
                ));
            }
            Some(t) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| PyValueError::new_err(format!("threads = {t}: {e}")))?,
            ),
        };
        let inner = make(config)?;
        Ok(Self {
            n,
            dim,
            config,
            seed,
            pool,
            inner,
            ess: n as f64,
            estimate: None,
        })
    }

    fn state(&self) -> (Vec<f64>, Vec<f64>) {
        match &self.inner {
            Inner::Py(m) => (m.particles.clone(), m.log_w.clone()),
            Inner::Rust(e) => (e.particles(), e.log_weights()),
        }
    }

    fn array2<'py>(&self, py: Python<'py>, v: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
        PyArray1::from_vec(py, v)
            .reshape([self.n, self.dim])
            .map(|a| a.into_any())
    }

    /// `sample` on the particles for time `k`.
    fn py_predict(&mut self, py: Python<'_>) -> PyResult<()> {
        let (n, dim, seed) = (self.n, self.dim, self.seed);
        let Inner::Py(m) = &mut self.inner else {
            unreachable!("called for Python models")
        };
        let k = m.k + 1;
        let rng = py
            .import("numpy.random")?
            .call_method1("default_rng", (stream_seed(&[seed, k as u64]),))?;
        let arr = PyArray1::from_vec(py, m.particles.clone()).reshape([n, dim])?;
        let out = m.sample.bind(py).call1((arr, k, rng))?;
        let (shape, v) = read_f64(&out, "the result of sample")?;
        if !(shape == [n, dim] || (dim == 1 && shape == [n])) {
            return Err(PyValueError::new_err(format!(
                "sample returned shape {shape:?}; ({n}, {dim}) was expected"
            )));
        }
        if let Some(i) = first_bad_row(&v, dim) {
            return Err(PyValueError::new_err(format!(
                "sample returned a NaN or infinite state for particle {i} at step {k}"
            )));
        }
        m.particles = v;
        m.k = k;
        Ok(())
    }

    /// `log_likelihood` of the particles at their time index, the weights,
    /// and resampling.
    fn py_update(&mut self, py: Python<'_>, z: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let (n, dim, seed, config) = (self.n, self.dim, self.seed, self.config);
        let Inner::Py(m) = &mut self.inner else {
            unreachable!("called for Python models")
        };
        let k = m.k;
        let arr = PyArray1::from_vec(py, m.particles.clone()).reshape([n, dim])?;
        let out = m.log_likelihood.bind(py).call1((arr, z, k))?;
        let (shape, inc) = read_f64(&out, "the result of log_likelihood")?;
        if !(shape == [n] || shape == [n, 1]) {
            return Err(PyValueError::new_err(format!(
                "log_likelihood returned shape {shape:?}; ({n},) was expected"
            )));
        }
        if let Some(i) = inc.iter().position(|x| x.is_nan() || *x == f64::INFINITY) {
            return Err(PyValueError::new_err(format!(
                "log_likelihood returned {} for particle {i} at step {k}",
                inc[i]
            )));
        }
        let mut lw: Vec<f64> = m.log_w.iter().zip(&inc).map(|(l, x)| l + x).collect();
        let max = lw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if max == f64::NEG_INFINITY {
            return Err(particle_err(&ParticleError::AllWeightsZero { count: n }));
        }
        // one exponential per particle: the weights relative to the
        // largest, then normalised by their sum
        let mut w: Vec<f64> = lw.iter().map(|l| (l - max).exp()).collect();
        let sum: f64 = w.iter().sum();
        let lse = max + sum.ln();
        for (l, w) in lw.iter_mut().zip(&mut w) {
            *l -= lse;
            *w /= sum;
        }
        let ess = 1.0 / w.iter().map(|w| w * w).sum::<f64>();
        let mut mean = vec![0.0; dim];
        for (row, &wi) in m.particles.chunks_exact(dim).zip(&w) {
            for (o, x) in mean.iter_mut().zip(row) {
                *o += wi * x;
            }
        }
        let resample = match config.policy {
            ResamplePolicy::Always => true,
            ResamplePolicy::Ess(t) => ess < t * n as f64,
            ResamplePolicy::Never => false,
        };
        if resample {
            let mut rng = stream_rng(&[seed, k as u64, RESAMPLE_STREAM]);
            let mut ancestors = vec![0usize; n];
            config
                .resampling
                .resample(&w, &mut rng, &mut ancestors)
                .map_err(|e| particle_err(&e))?;
            let mut gathered = Vec::with_capacity(n * dim);
            for &a in &ancestors {
                gathered.extend_from_slice(&m.particles[a * dim..(a + 1) * dim]);
            }
            m.particles = gathered;
            lw.fill(-(n as f64).ln());
        }
        m.log_w = lw;
        m.log_evidence += lse;
        self.ess = ess;
        Ok(mean)
    }
}

#[pymethods]
impl ParticleFilter {
    /// A filter with a Python model: ``sample(particles, k, rng)`` and
    /// ``log_likelihood(particles, z, k)`` on the whole ``(n, dim)`` array.
    #[new]
    #[pyo3(signature = (n, dim, sample, log_likelihood, particles = None, *, resampling = "systematic", ess_threshold = None, seed = 0, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        n: usize,
        dim: usize,
        sample: Bound<'_, PyAny>,
        log_likelihood: Bound<'_, PyAny>,
        particles: Option<&Bound<'_, PyAny>>,
        resampling: &str,
        ess_threshold: Option<f64>,
        seed: u64,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        if dim == 0 {
            return Err(PyValueError::new_err("dim = 0: must be at least 1"));
        }
        for (f, name) in [(&sample, "sample"), (&log_likelihood, "log_likelihood")] {
            if !f.is_callable() {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "{name} must be callable"
                )));
            }
        }
        Self::build(n, dim, resampling, ess_threshold, seed, threads, |_| {
            let ps = initial_particles(particles, n, dim, 0.0)?;
            Ok(Inner::Py(PyModel {
                sample: sample.unbind(),
                log_likelihood: log_likelihood.unbind(),
                particles: ps,
                log_w: vec![-(n as f64).ln(); n],
                k: 0,
                log_evidence: 0.0,
            }))
        })
    }

    /// Paper 000's scalar model (``x_t = 1 + sin(w pi t) + 0.5 x_{t-1} +
    /// Gamma(3, rate 2)``, ``z_t = x_t^2 / 5`` for ``t <= 30``, ``x_t / 2 -
    /// 2`` after, plus ``N(0, 1e-5)``) in Rust; step ``k`` is time ``t = k +
    /// 1`` and the particles start at ``x_1 = x0``.
    #[staticmethod]
    #[pyo3(signature = (n, x0 = 1.0, sin_freq = 0.04, *, resampling = "systematic", ess_threshold = None, seed = 0, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn hikpf(
        n: usize,
        x0: f64,
        sin_freq: f64,
        resampling: &str,
        ess_threshold: Option<f64>,
        seed: u64,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        if !x0.is_finite() || !sin_freq.is_finite() {
            return Err(PyValueError::new_err("x0 and sin_freq must be finite"));
        }
        Self::build(n, 1, resampling, ess_threshold, seed, threads, |c| {
            builtin(Hikpf::new(sin_freq), c, &vec![x0; n], seed).map(Inner::Rust)
        })
    }

    /// A constant-velocity model on ``axes`` (1 to 3) axes in Rust: state
    /// ``[p_1, v_1, ..., p_A, v_A]``, per axis ``p' = p + dt v + dt^2/2 a``,
    /// ``v' = v + dt a``, ``a ~ N(0, q)``; ``z = positions + N(0, r I)``.
    #[staticmethod]
    #[pyo3(signature = (n, axes = 2, dt = 1.0, q = 1.0, r = 1.0, particles = None, *, resampling = "systematic", ess_threshold = None, seed = 0, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn constant_velocity(
        n: usize,
        axes: usize,
        dt: f64,
        q: f64,
        r: f64,
        particles: Option<&Bound<'_, PyAny>>,
        resampling: &str,
        ess_threshold: Option<f64>,
        seed: u64,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        if !(1..=3).contains(&axes) {
            return Err(PyValueError::new_err(format!(
                "axes = {axes}: must be 1, 2 or 3"
            )));
        }
        if !(dt.is_finite() && q.is_finite() && q >= 0.0 && r.is_finite() && r > 0.0) {
            return Err(PyValueError::new_err(format!(
                "dt = {dt}, q = {q}, r = {r}: dt finite, q >= 0 and r > 0 are required"
            )));
        }
        let dim = 2 * axes;
        Self::build(n, dim, resampling, ess_threshold, seed, threads, |c| {
            let ps = initial_particles(particles, n, dim, 0.0)?;
            match axes {
                1 => builtin(ConstantVelocity::<1> { dt, q, r }, c, &ps, seed),
                2 => builtin(ConstantVelocity::<2> { dt, q, r }, c, &ps, seed),
                _ => builtin(ConstantVelocity::<3> { dt, q, r }, c, &ps, seed),
            }
            .map(Inner::Rust)
        })
    }

    /// Number of particles.
    #[getter]
    fn n(&self) -> usize {
        self.n
    }

    /// State dimension.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
    }

    /// The seed of the run.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// Steps taken: the time index of the particles.
    #[getter]
    fn k(&self) -> usize {
        match &self.inner {
            Inner::Py(m) => m.k,
            Inner::Rust(e) => e.k(),
        }
    }

    /// The particles, a ``(n, dim)`` copy.
    #[getter]
    fn particles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (p, _) = self.state();
        self.array2(py, p)
    }

    /// The normalised weights, ``(n,)``.
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let (_, lw) = self.state();
        PyArray1::from_vec(py, lw.iter().map(|l| l.exp()).collect())
    }

    /// Weighted mean of the particles, ``(dim,)``.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let (p, lw) = self.state();
        PyArray1::from_vec(py, weighted_mean(&p, &lw, self.dim))
    }

    /// Weighted covariance of the particles, ``(dim, dim)``.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (p, lw) = self.state();
        let d = self.dim;
        let m = weighted_mean(&p, &lw, d);
        let mut c = vec![0.0; d * d];
        for (row, l) in p.chunks_exact(d).zip(&lw) {
            let w = l.exp();
            for i in 0..d {
                for j in 0..d {
                    c[i * d + j] += w * (row[i] - m[i]) * (row[j] - m[j]);
                }
            }
        }
        PyArray1::from_vec(py, c)
            .reshape([d, d])
            .map(|a| a.into_any())
    }

    /// The effective sample size ``1 / sum w_i^2`` of the last step before
    /// resampling (``n`` before the first step).
    #[getter]
    fn ess(&self) -> f64 {
        self.ess
    }

    /// ``log p(z_1, ..., z_k)`` estimated by the filter (0 before the first
    /// step).
    #[getter]
    fn log_evidence(&self) -> f64 {
        match &self.inner {
            Inner::Py(m) => m.log_evidence,
            Inner::Rust(e) => e.log_evidence(),
        }
    }

    /// The estimate of the last step: the weighted mean of the proposed
    /// particles before resampling (``None`` before the first step).
    #[getter]
    fn estimate<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.estimate
            .as_ref()
            .map(|e| PyArray1::from_vec(py, e.clone()))
    }

    /// Propagates the particles with ``sample`` (Python models only; a
    /// built-in model runs whole steps).
    fn predict(&mut self, py: Python<'_>) -> PyResult<()> {
        if matches!(self.inner, Inner::Rust(_)) {
            return Err(PyNotImplementedError::new_err(
                "a built-in model runs whole steps: call step(z)",
            ));
        }
        self.py_predict(py)
    }

    /// Weighs the particles by ``log_likelihood`` with ``z`` and resamples
    /// (Python models only); returns the step's estimate.
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        z: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        if matches!(self.inner, Inner::Rust(_)) {
            return Err(PyNotImplementedError::new_err(
                "a built-in model runs whole steps: call step(z)",
            ));
        }
        let e = self.py_update(py, z)?;
        self.estimate = Some(e.clone());
        Ok(PyArray1::from_vec(py, e))
    }

    /// One step with measurement ``z``: ``predict`` then ``update``;
    /// returns the step's estimate (the weighted mean before resampling).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        z: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let e = match &mut self.inner {
            Inner::Py(_) => {
                self.py_predict(py)?;
                self.py_update(py, z)?
            }
            Inner::Rust(engine) => {
                let len = engine.z_len();
                let (shape, v) = read_f64(z, "z")?;
                if v.len() != len || shape.len() > 1 {
                    return Err(PyValueError::new_err(format!(
                        "z must have shape ({len},), not {shape:?}"
                    )));
                }
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(PyValueError::new_err("z contains NaN or infinity"));
                }
                let pool = self.pool.as_ref();
                let (e, ess) = py
                    .detach(|| match pool {
                        Some(p) => p.install(|| engine.step(&v)),
                        None => engine.step(&v),
                    })
                    .map_err(|e| particle_err(&e))?;
                self.ess = ess;
                e
            }
        };
        self.estimate = Some(e.clone());
        Ok(PyArray1::from_vec(py, e))
    }

    fn __repr__(&self) -> String {
        let model = match self.inner {
            Inner::Py(_) => "python",
            Inner::Rust(_) => "built-in",
        };
        format!(
            "ParticleFilter(n={}, dim={}, model={model}, resampling={:?}, seed={})",
            self.n,
            self.dim,
            self.config.resampling.name(),
            self.seed
        )
    }
}

fn weighted_mean(p: &[f64], lw: &[f64], dim: usize) -> Vec<f64> {
    let mut m = vec![0.0; dim];
    for (row, l) in p.chunks_exact(dim).zip(lw) {
        let w = l.exp();
        for (o, x) in m.iter_mut().zip(row) {
            *o += w * x;
        }
    }
    m
}

/// ``stream_seed(key)``: the seed the filters mix from a key of integers
/// (``[seed, k]`` for the generator of step ``k``).
#[pyfunction(name = "stream_seed")]
pub fn py_stream_seed(key: Vec<u64>) -> u64 {
    stream_seed(&key)
}

/// The Rust reference run of paper 000's model (``n`` particles, ``seed``,
/// measurements ``zs``): rows ``(mean, ess, log_evidence)``, for the test
/// that the built-in model from Python equals it bit for bit.
#[pyfunction]
pub fn _hikpf_reference_run<'py>(
    py: Python<'py>,
    n: usize,
    seed: u64,
    zs: Vec<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = crate::pf_models::reference_run(n, seed, &zs).map_err(|e| particle_err(&e))?;
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat)
        .reshape([rows.len(), 3])
        .map(|a| a.into_any())
}
