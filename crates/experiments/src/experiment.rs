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
    /// Run one slice of the jobs (`--shard K/N`) and save it for
    /// `cargo xtask merge` instead of the whole experiment.
    pub shard: Option<bayestrack_otb::shard::Shard>,
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

/// Runs `e` with its output folder `opts.out/<id>/` marked partial
/// (`PARTIAL.txt`, see [`bayestrack_otb::write::mark_partial`]) until every
/// file is written: a run that is killed or fails leaves the marker, which
/// says that the `*.partial.*` files hold the finished part and that every
/// other file is from the last run that finished. A run refused for a bad
/// `--set` option ([`ExperimentError::BadOption`], which every experiment
/// checks before it writes) leaves no marker.
///
/// # Errors
/// Those of [`Experiment::run`], and [`ExperimentError::Io`] for the
/// marker.
pub fn run_marked(e: &dyn Experiment, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
    let dir = opts.output_dir(e.id())?;
    let mode = match opts.mode {
        Mode::Quick => "",
        Mode::Full => " --full",
    };
    bayestrack_otb::write::mark_partial(
        &dir,
        &format!("`cargo xtask reproduce-table {}{mode}`", e.id()),
    )?;
    let result = e.run(opts);
    // A refused option is found before anything is written: no marker.
    if matches!(result, Ok(_) | Err(ExperimentError::BadOption { .. })) {
        bayestrack_otb::write::clear_partial(&dir)?;
    }
    result
}

/// A progress bar on stderr for `len` jobs of `what` (e.g. "affine
/// sequences"), showing what runs, elapsed time, done/total and the time
/// left; hidden when `show` is false or stderr is not a terminal.
pub fn progress_bar(len: usize, show: bool, what: &str) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} (ETA {eta})",
    ) {
        bar.set_style(style);
    }
    bar.set_message(what.to_string());
    bar
}

/// Writes `contents` to `path` whole (a temporary file renamed over it),
/// naming the file in the error.
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
    /// An option override that the experiment does not know, or a value
    /// outside the option's domain; the message lists the valid keys.
    #[error("{}", bad_option_text(.key, .value, .experiment, .valid, .expected))]
    BadOption {
        /// The option name.
        key: String,
        /// Its value.
        value: String,
        /// The experiment's id.
        experiment: &'static str,
        /// The experiment's keys with their domains
        /// ([`bayestrack_options::Options::keys`]).
        valid: String,
        /// Why the value is refused (`expected 1..=100000`, or the
        /// cross-option check's reason), or empty for an unknown key.
        expected: String,
    },
    /// Shard outputs that cannot be merged: missing, duplicated, of
    /// different runs, or unreadable.
    #[error("cannot merge shards: {0}")]
    Merge(String),
    /// A filter or tracker failed during the run.
    #[error("experiment `{id}` failed: {message}")]
    Failed {
        /// Experiment id.
        id: &'static str,
        /// What failed.
        message: String,
    },
}

/// An unknown key lists every key; a bad value of a known key says only
/// why that value is refused.
fn bad_option_text(
    key: &str,
    value: &str,
    experiment: &str,
    valid: &str,
    expected: &str,
) -> String {
    if valid.is_empty() && expected.is_empty() {
        format!("expected key=value for {experiment}, got `{key}`")
    } else if expected.is_empty() {
        format!("unknown option `{key}={value}` for {experiment}; valid keys: {valid}")
    } else {
        format!("bad value `{key}={value}` for {experiment}: {expected}")
    }
}

impl ExperimentError {
    /// [`ExperimentError::BadOption`] for `key=value` of `experiment`, whose
    /// valid keys (with their domains) are `valid`.
    pub fn bad_option(experiment: &'static str, valid: &str, key: &str, value: &str) -> Self {
        Self::BadOption {
            key: key.to_string(),
            value: value.to_string(),
            experiment,
            valid: valid.to_string(),
            expected: String::new(),
        }
    }
}

/// Most runs an option may ask for: more is a typo, not an experiment.
pub const MAX_RUNS: usize = 100_000;
/// Most frames or time steps an option may ask for.
pub const MAX_FRAMES: usize = 1_000_000;
/// Most particles an option may ask for.
pub const MAX_PARTICLES: usize = 1_000_000;

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
    /// Its declared options (`reproduce-table ID --options`).
    fn options(&self) -> Vec<bayestrack_options::Spec> {
        Vec::new()
    }
    /// Runs it, writes its files under `opts.out/<id>/` and returns its
    /// tables (with `opts.shard`, one slice of its jobs, saved for
    /// [`Experiment::merge`]).
    fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError>;
    /// Merges the shards of it found under `dirs` (each a `--out` of a
    /// `--shard` run) into `out/<id>/`: the files one run writes; `None`
    /// when no folder holds a shard of it.
    fn merge(
        &self,
        dirs: &[PathBuf],
        out: &std::path::Path,
    ) -> Result<Option<Vec<Table>>, ExperimentError> {
        let _ = (dirs, out);
        Ok(None)
    }
    /// The quick-mode numbers that CI pins (`tests/golden/<id>.csv`), as
    /// CSV with full precision; `None` when nothing is pinned yet.
    /// `cargo xtask bless` rewrites the file from this.
    fn golden(&self) -> Result<Option<String>, ExperimentError> {
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes one file, then fails when asked to; refuses every `--set`.
    struct Fails(bool);

    impl Experiment for Fails {
        fn id(&self) -> &'static str {
            "marker-test"
        }
        fn source(&self) -> &'static str {
            "test"
        }
        fn summary(&self) -> &'static str {
            "test"
        }
        fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
            if let Some((k, v)) = opts.set.first() {
                return Err(ExperimentError::bad_option("marker-test", "none", k, v));
            }
            write_text(&opts.output_dir(self.id())?.join("a.csv"), "x\n")?;
            if self.0 {
                return Err(ExperimentError::Failed {
                    id: "marker-test",
                    message: "on purpose".into(),
                });
            }
            Ok(vec![])
        }
    }

    #[test]
    fn an_unfinished_run_leaves_its_folder_marked_partial() {
        let out = std::env::temp_dir().join(format!("bayestrack-marker-{}", std::process::id()));
        let opts = RunOptions {
            mode: Mode::Full,
            out: out.clone(),
            progress: false,
            set: vec![],
            shard: None,
        };
        let marker = out.join("marker-test").join("PARTIAL.txt");
        assert!(run_marked(&Fails(true), &opts).is_err());
        let text = std::fs::read_to_string(&marker).unwrap();
        assert!(
            text.contains("reproduce-table marker-test --full"),
            "{text}"
        );
        run_marked(&Fails(false), &opts).unwrap();
        assert!(!marker.exists());
        let refused = RunOptions {
            set: vec![("typo".into(), "1".into())],
            ..opts.clone()
        };
        assert!(matches!(
            run_marked(&Fails(true), &refused),
            Err(ExperimentError::BadOption { .. })
        ));
        assert!(!marker.exists(), "a refused option leaves no marker");
        std::fs::remove_dir_all(&out).unwrap();
    }
}
