//! What every experiment behind `cargo xtask reproduce-table` is: the
//! [`Experiment`] trait, its run options and its errors. The list of
//! experiments is [`crate::REGISTRY`]; this module knows none of them.
//!
//! Every paper table the project reproduces is an [`Experiment`] with a stable
//! id. An experiment is seeded and deterministic, writes its CSV and SVG files
//! under `<out>/<id>/`, and returns its tables (the paper's cells beside ours).

use std::path::PathBuf;

use bayestrack_otb::Table;

/// Scale of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Small enough for CI; the numbers guarded by the golden files.
    Quick,
    /// Paper scale.
    Full,
}

/// Options common to every experiment.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Quick (CI) or full (paper-scale) run.
    pub mode: Mode,
    /// Root folder for outputs; each experiment writes under `out/<id>/`.
    pub out: PathBuf,
    /// Show progress on stderr.
    pub progress: bool,
    /// `key=value` overrides of the experiment's named options.
    pub set: Vec<(String, String)>,
}

impl RunOptions {
    /// The experiment's output folder `out/<id>/`, created if missing.
    ///
    /// # Errors
    /// [`ExperimentError::Io`] naming the folder.
    pub fn output_dir(&self, id: &str) -> Result<PathBuf, ExperimentError> {
        let dir = self.out.join(id);
        std::fs::create_dir_all(&dir).map_err(|source| ExperimentError::Io {
            path: dir.clone(),
            source,
        })?;
        Ok(dir)
    }
}

/// Writes `contents` to `path`, naming the file in the error.
///
/// # Errors
/// [`ExperimentError::Io`].
pub fn write_text(path: &std::path::Path, contents: &str) -> Result<(), ExperimentError> {
    Ok(bayestrack_otb::write::write_text(path, contents)?)
}

impl From<bayestrack_otb::WriteError> for ExperimentError {
    fn from(e: bayestrack_otb::WriteError) -> Self {
        Self::Io {
            path: e.path,
            source: e.source,
        }
    }
}

/// What went wrong while running an experiment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// An output file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The id is not in the registry.
    #[error("unknown experiment `{0}` (try `list`)")]
    Unknown(String),
    /// The experiment is registered but not implemented yet.
    #[error("experiment `{0}` is registered but not implemented yet")]
    NotImplemented(&'static str),
    /// An option override that the experiment does not know.
    #[error("unknown option or value `{key}={value}`")]
    BadOption {
        /// The option name.
        key: String,
        /// Its value.
        value: String,
    },
    /// A filter or tracker failed during the run.
    #[error("experiment `{id}` failed: {message}")]
    Failed {
        /// Experiment id.
        id: &'static str,
        /// What failed.
        message: String,
    },
}

/// One reproducible experiment.
pub trait Experiment: Sync {
    /// Stable id used on the command line (`hikpf`, `ball`, ...).
    fn id(&self) -> &'static str;
    /// Which paper and table it reproduces.
    fn source(&self) -> &'static str;
    /// One line saying what it measures.
    fn summary(&self) -> &'static str;
    /// Whether it can run yet.
    fn implemented(&self) -> bool {
        true
    }
    /// Runs it, writes its files under `opts.out/<id>/` and returns its tables.
    fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError>;
    /// The quick-mode numbers that CI pins (`tests/golden/<id>.csv`), as
    /// CSV with full precision; `None` when nothing is pinned yet.
    /// `cargo xtask bless` rewrites the file from this.
    fn golden(&self) -> Result<Option<String>, ExperimentError> {
        Ok(None)
    }
}
