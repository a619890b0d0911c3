//! The experiment registry behind `cargo xtask reproduce-table`.
//!
//! Every paper table the project reproduces is an [`Experiment`] with a stable
//! id. An experiment is seeded and deterministic, writes its CSV and SVG files
//! under `<out>/<id>/`, and returns its tables (the paper's cells beside ours).

use std::path::PathBuf;

use crate::table::Table;

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
    std::fs::write(path, contents).map_err(|source| ExperimentError::Io {
        path: path.to_path_buf(),
        source,
    })
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

/// An experiment that the SPEC asks for and that is not built yet.
struct Planned {
    id: &'static str,
    source: &'static str,
    summary: &'static str,
}

impl Experiment for Planned {
    fn id(&self) -> &'static str {
        self.id
    }
    fn source(&self) -> &'static str {
        self.source
    }
    fn summary(&self) -> &'static str {
        self.summary
    }
    fn implemented(&self) -> bool {
        false
    }
    fn run(&self, _opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
        Err(ExperimentError::NotImplemented(self.id))
    }
}

/// Every experiment, in the order `all` runs them.
pub fn registry() -> Vec<Box<dyn Experiment>> {
    vec![
        Box::new(crate::hikpf::HikpfExperiment),
        Box::new(crate::ball::BallExperiment),
        Box::new(Planned {
            id: "affine",
            source: "paper 002 (RMS eq. 6, particles per frame)",
            summary: "HKPF, ISPF and self-tuning HKPF on synthetic affine sequences",
        }),
        Box::new(crate::correlation::CorrelationExperiment),
        Box::new(Planned {
            id: "condensation",
            source: "paper 003",
            summary: "CONDENSATION with IFD, skin, OR and AND cues; c-AVQ; priority IFD",
        }),
    ]
}

/// Looks an experiment up by id.
pub fn find(id: &str) -> Result<Box<dyn Experiment>, ExperimentError> {
    registry()
        .into_iter()
        .find(|e| e.id() == id)
        .ok_or_else(|| ExperimentError::Unknown(id.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_unique() {
        let reg = registry();
        let mut ids: Vec<_> = reg.iter().map(|e| e.id()).collect();
        ids.sort();
        ids.dedup();
        assert_eq!(ids.len(), reg.len());
    }

    #[test]
    fn unknown_id_is_an_error() {
        assert!(matches!(find("nope"), Err(ExperimentError::Unknown(_))));
    }
}
