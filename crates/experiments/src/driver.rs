//! The one driver every paper experiment runs on: an experiment is data
//! ([`Paper`]: its options, presets, jobs, log rows and report), and the
//! driver owns the rest: quick/full presets, `--set`, the output folder,
//! the partial log (`runs.partial.csv` until the run finishes, see
//! [`PartialCsv`]), the progress bar, the options footer of the first
//! table, shards (`--shard K/N`) and their merge.
//!
//! # Jobs and shards
//! An experiment's work is [`Paper::jobs`] independent jobs, numbered in
//! output order; job `j`'s random streams are keyed by `j` (its run), so
//! its result does not depend on which other jobs run, where, or on how
//! many threads. Shard `K/N` runs the jobs `j` with `j % N == K - 1` and
//! writes their results to `<out>/<id>/shard.cbor` (with `SHARD.txt`, which
//! says what it is, and its own rows of the log); [`merge`] reads the
//! shards of every folder given, checks that they are the `N` shards of one
//! options line, and writes exactly the files a single run writes.

use std::path::{Path, PathBuf};

use bayestrack_options::Options;
use bayestrack_otb::Table;
use bayestrack_otb::write::PartialCsv;
use rayon::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::experiment::{Experiment, ExperimentError, Mode, RunOptions, progress_bar, write_text};

/// The file a shard writes its job results to (CBOR).
pub const SHARD_FILE: &str = "shard.cbor";
/// The note a shard leaves beside [`SHARD_FILE`].
pub const SHARD_NOTE: &str = "SHARD.txt";

/// One slice of an experiment's jobs, `--shard K/N`: job `j` is shard
/// `j % N + 1`'s (the OTB suite's [`Shard`], the same rule for its cells).
pub use bayestrack_otb::shard::Shard;

/// A paper experiment as data: what the driver needs to run, shard, merge
/// and pin it. Every `P: Paper` is an [`Experiment`].
pub trait Paper: Sync + Send + 'static {
    /// Its declared options.
    type Config: Options + Send + Sync;
    /// What one job produces (saved by a shard, read back by [`merge`]).
    type Done: Serialize + DeserializeOwned + Send + Sync;
    /// One row of its per-job log ([`Paper::LOG`]).
    type Row: Serialize + Send + Sync;
    /// What the jobs of one process share, built once before them by
    /// [`Paper::prepare`] (rendered scenes; `()` for most).
    type Shared: Sync;
    /// Stable id (`hikpf`, `ball`, ...).
    const ID: &'static str;
    /// Which paper and table it reproduces.
    const SOURCE: &'static str;
    /// One line saying what it measures.
    const SUMMARY: &'static str;
    /// The per-job log file (`runs.csv`, `frames.csv`).
    const LOG: &'static str;
    /// What the progress bar counts (`hikpf runs`).
    const JOBS: &'static str;
    /// The CI scale (`cargo xtask reproduce-table ID`).
    fn quick() -> Self::Config;
    /// The paper's scale (`--full`).
    fn full() -> Self::Config;
    /// Jobs in all, in output order.
    fn jobs(config: &Self::Config) -> usize;
    /// Builds what the jobs `jobs` share (deterministic, from `config`).
    ///
    /// # Errors
    /// [`ExperimentError::Failed`] naming what failed.
    fn prepare(config: &Self::Config, jobs: &[usize]) -> Result<Self::Shared, ExperimentError>;
    /// The jobs `jobs` in the groups that run one after another, each with
    /// its own [`Paper::prepare`] (dropped before the next group's): an
    /// experiment whose shared data is large per run keeps one run's at a
    /// time. The results are the same in any grouping (every job has its
    /// own seeds); the default is one group.
    fn groups(_config: &Self::Config, jobs: &[usize]) -> Vec<Vec<usize>> {
        vec![jobs.to_vec()]
    }
    /// Runs job `job` (keyed by its index alone).
    ///
    /// # Errors
    /// [`ExperimentError::Failed`] naming what failed.
    fn run_job(
        config: &Self::Config,
        shared: &Self::Shared,
        job: usize,
    ) -> Result<Self::Done, ExperimentError>;
    /// Job `job`'s rows of [`Paper::LOG`].
    fn rows(config: &Self::Config, job: usize, done: &Self::Done) -> Vec<Self::Row>;
    /// Writes the tables' CSVs and figures under `dir` from every job's
    /// result (in job order) and returns the tables.
    ///
    /// # Errors
    /// [`ExperimentError::Io`], or [`ExperimentError::Failed`] for work
    /// done after the jobs.
    fn report(
        config: &Self::Config,
        done: Vec<Self::Done>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError>;
    /// The quick-mode numbers CI pins (see [`Experiment::golden`]).
    ///
    /// # Errors
    /// Those of the runs.
    fn golden() -> Result<Option<String>, ExperimentError> {
        Ok(None)
    }
}

/// `key=value` refused by `id`'s options, as [`ExperimentError::BadOption`].
pub fn bad_option(id: &'static str, e: bayestrack_options::OptionError) -> ExperimentError {
    use bayestrack_options::OptionError as E;
    let (key, value, valid, expected) = match e {
        E::UnknownKey { key, valid } => (key, String::new(), valid, String::new()),
        E::BadValue {
            key,
            value,
            expected,
            valid,
        } => (key, value, valid, expected),
        E::NotKeyValue { item } => (item, String::new(), String::new(), String::new()),
        _ => (String::new(), String::new(), String::new(), String::new()),
    };
    ExperimentError::BadOption {
        key,
        value,
        experiment: id,
        valid,
        expected,
    }
}

/// Sets `key=value` on `config`, refusals as [`ExperimentError::BadOption`].
///
/// # Errors
/// [`ExperimentError::BadOption`]; `config` is then unchanged.
pub fn apply<C: Options>(
    id: &'static str,
    config: &mut C,
    key: &str,
    value: &str,
) -> Result<(), ExperimentError> {
    config.set(key, value).map_err(|e| match bad_option(id, e) {
        ExperimentError::BadOption {
            key,
            experiment,
            valid,
            expected,
            ..
        } => ExperimentError::BadOption {
            key,
            value: value.to_string(),
            experiment,
            valid,
            expected,
        },
        other => other,
    })
}

/// The preset of `mode` with the `--set` overrides applied.
///
/// # Errors
/// [`ExperimentError::BadOption`].
pub fn config<P: Paper>(opts: &RunOptions) -> Result<P::Config, ExperimentError> {
    let mut config = match opts.mode {
        Mode::Quick => P::quick(),
        Mode::Full => P::full(),
    };
    for (k, v) in &opts.set {
        apply(P::ID, &mut config, k, v)?;
    }
    config.validate().map_err(|e| bad_option(P::ID, e))?;
    Ok(config)
}

/// Runs the jobs `jobs` in parallel, with their rows appended to
/// `log`'s partial file as each finishes and the whole log (in job order)
/// written over `log` at the end; returns the results in the order of
/// `jobs`.
///
/// # Errors
/// The first job's error; [`ExperimentError::Io`] for the log.
pub fn run_jobs<P: Paper>(
    config: &P::Config,
    jobs: &[usize],
    log: Option<&Path>,
    progress: bool,
) -> Result<Vec<P::Done>, ExperimentError> {
    let (done, partial) = run_jobs_partial::<P>(config, jobs, log, progress)?;
    if let Some(partial) = partial {
        partial.finish(&log_rows::<P>(config, jobs, &done))?;
    }
    Ok(done)
}

/// The rows of `P::LOG` for `jobs` and their results, in job order.
fn log_rows<P: Paper>(config: &P::Config, jobs: &[usize], done: &[P::Done]) -> Vec<P::Row> {
    jobs.iter()
        .zip(done)
        .flat_map(|(&j, d)| P::rows(config, j, d))
        .collect()
}

/// Every job's result, with the partial log still to be replaced.
type JobsDone<P> = (
    Vec<<P as Paper>::Done>,
    Option<PartialCsv<<P as Paper>::Row>>,
);

/// [`run_jobs`] without writing the whole log: the partial log (with every
/// job's rows) is handed back for the caller to replace once every other
/// file is written too.
fn run_jobs_partial<P: Paper>(
    config: &P::Config,
    jobs: &[usize],
    log: Option<&Path>,
    progress: bool,
) -> Result<JobsDone<P>, ExperimentError> {
    let partial = log.map(PartialCsv::<P::Row>::create).transpose()?;
    let bar = progress_bar(jobs.len(), progress, P::JOBS);
    let position: std::collections::HashMap<usize, usize> =
        jobs.iter().enumerate().map(|(i, &j)| (j, i)).collect();
    let mut slots: Vec<Option<P::Done>> =
        std::iter::repeat_with(|| None).take(jobs.len()).collect();
    for group in P::groups(config, jobs) {
        let shared = P::prepare(config, &group)?;
        let done: Vec<P::Done> = group
            .par_iter()
            .map(|&j| {
                let done = P::run_job(config, &shared, j)?;
                if let Some(partial) = &partial {
                    partial.append(&P::rows(config, j, &done))?;
                }
                bar.inc(1);
                Ok(done)
            })
            .collect::<Result<_, ExperimentError>>()?;
        for (j, d) in group.into_iter().zip(done) {
            if let Some(&i) = position.get(&j) {
                slots[i] = Some(d);
            }
        }
    }
    bar.finish_and_clear();
    let done = slots
        .into_iter()
        .zip(jobs)
        .map(|(d, &j)| {
            d.ok_or_else(|| ExperimentError::Failed {
                id: P::ID,
                message: format!("job {j} in no group"),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((done, partial))
}

/// The folder (inside an experiment's output folder) where a finished run
/// writes its files before they replace the previous run's.
pub const STAGING_DIR: &str = "finished.partial";

/// Writes a finished run's files (the log `rows` as the file `log`, and
/// whatever `write` writes into the folder it is given) so that the output folder `dir` never mixes two runs: they go to
/// `dir/finished.partial/` first, and only when every one is written do they
/// replace the previous run's, file by file. A run killed before then leaves
/// every earlier file as it was (the `PARTIAL.txt` marker of
/// [`crate::experiment::run_marked`] says so, and the `*.partial.*` files
/// hold what it finished). The one mechanism behind every experiment's
/// whole run and `cargo xtask merge`.
///
/// # Errors
/// [`ExperimentError::Io`] naming the file; those of `write`.
pub fn publish<R: Serialize, T>(
    dir: &Path,
    log: &str,
    rows: &[R],
    write: impl FnOnce(&Path) -> Result<T, ExperimentError>,
) -> Result<T, ExperimentError> {
    let staging = dir.join(STAGING_DIR);
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(io(&staging))?;
    }
    std::fs::create_dir_all(&staging).map_err(io(&staging))?;
    bayestrack_otb::write::write_csv(&staging.join(log), rows)?;
    let out = write(&staging)?;
    move_into(&staging, dir)?;
    std::fs::remove_dir_all(&staging).map_err(io(&staging))?;
    Ok(out)
}

/// Moves every file under `from` to the same place under `to` (renames in
/// one file system), creating folders as needed.
fn move_into(from: &Path, to: &Path) -> Result<(), ExperimentError> {
    for entry in std::fs::read_dir(from).map_err(io(from))? {
        let entry = entry.map_err(io(from))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if entry.file_type().map_err(io(&src))?.is_dir() {
            std::fs::create_dir_all(&dst).map_err(io(&dst))?;
            move_into(&src, &dst)?;
        } else {
            std::fs::rename(&src, &dst).map_err(io(&dst))?;
        }
    }
    Ok(())
}

/// Every job of `config`, in order (see [`run_jobs`]), after checking
/// `config` against its declared domains.
///
/// # Errors
/// [`ExperimentError::BadOption`] for options outside their domains;
/// those of [`run_jobs`].
pub fn run_all<P: Paper>(
    config: &P::Config,
    log: Option<&Path>,
    progress: bool,
) -> Result<Vec<P::Done>, ExperimentError> {
    config.validate().map_err(|e| bad_option(P::ID, e))?;
    let jobs: Vec<usize> = (0..P::jobs(config)).collect();
    run_jobs::<P>(config, &jobs, log, progress)
}

/// The report with the options line under the first table's title.
fn report<P: Paper>(
    config: &P::Config,
    done: Vec<P::Done>,
    dir: &Path,
) -> Result<Vec<Table>, ExperimentError> {
    let mut tables = P::report(config, done, dir)?;
    if let Some(first) = tables.first_mut() {
        first.title = format!("{}\n  options: {}", first.title, config.describe());
    }
    Ok(tables)
}

/// What a shard saves: enough to check it belongs with the others and to
/// rebuild its jobs' results.
#[derive(serde::Serialize, serde::Deserialize)]
struct ShardFile<D> {
    id: String,
    k: usize,
    n: usize,
    options: String,
    jobs: usize,
    done: Vec<(usize, D)>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn corrupt(path: &Path, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Merge(format!("{}: {e}", path.display()))
}

/// Runs shard `shard` of `P` and writes it under `dir`.
fn run_shard<P: Paper>(
    config: &P::Config,
    shard: Shard,
    dir: &Path,
    progress: bool,
) -> Result<Vec<Table>, ExperimentError> {
    let total = P::jobs(config);
    let jobs: Vec<usize> = (0..total).filter(|&j| shard.contains(j)).collect();
    // a shard's folder holds only what the shard wrote
    for stale in [SHARD_FILE, SHARD_NOTE] {
        let _ = std::fs::remove_file(dir.join(stale));
    }
    let done = run_jobs::<P>(config, &jobs, Some(&dir.join(P::LOG)), progress)?;
    let file = ShardFile {
        id: P::ID.to_string(),
        k: shard.index(),
        n: shard.count(),
        options: config.describe(),
        jobs: total,
        done: jobs.iter().copied().zip(done).collect(),
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&file, &mut bytes)
        .map_err(|e| ExperimentError::Merge(format!("cannot encode shard: {e}")))?;
    let path = dir.join(SHARD_FILE);
    let tmp = dir.join(format!("{SHARD_FILE}.tmp"));
    std::fs::write(&tmp, &bytes).map_err(io(&tmp))?;
    std::fs::rename(&tmp, &path).map_err(io(&path))?;
    write_text(
        &dir.join(SHARD_NOTE),
        &format!(
            "Shard {shard} of `cargo xtask reproduce-table {}`: jobs j with j % {} == {} \
             ({} of {total}). Not a result on its own: `cargo xtask merge` the {} shard \
             folders to get the tables.\noptions: {}\n",
            P::ID,
            shard.count(),
            shard.index() - 1,
            jobs.len(),
            shard.count(),
            file.options
        ),
    )?;
    let mut t = Table::new(
        format!(
            "{}: shard {shard} ({} of {total} jobs) written to {}\n  options: {}",
            P::ID,
            jobs.len(),
            dir.display(),
            file.options
        ),
        &["shard", "jobs", "of"],
    );
    t.push(vec![
        shard.to_string(),
        jobs.len().to_string(),
        total.to_string(),
    ]);
    Ok(vec![t])
}

/// Reads every shard of `P` under `dirs` (`<dir>/<id>/shard.cbor`), checks
/// they are the `N` shards of one run, and writes what one run writes to
/// `out/<id>/`; `None` when no folder holds a shard of `P`.
///
/// # Errors
/// [`ExperimentError::Merge`] for shards that do not belong together or
/// are missing; [`ExperimentError::Io`].
pub fn merge<P: Paper>(
    dirs: &[PathBuf],
    out: &Path,
) -> Result<Option<Vec<Table>>, ExperimentError> {
    let mut shards: Vec<(PathBuf, ShardFile<P::Done>)> = vec![];
    for d in dirs {
        let path = d.join(P::ID).join(SHARD_FILE);
        if !path.is_file() {
            continue;
        }
        let bytes = std::fs::read(&path).map_err(io(&path))?;
        let file: ShardFile<P::Done> =
            ciborium::from_reader(bytes.as_slice()).map_err(|e| corrupt(&path, e))?;
        if file.id != P::ID {
            return Err(corrupt(&path, format!("a shard of `{}`", file.id)));
        }
        shards.push((path, file));
    }
    let Some((first_path, first)) = shards.first() else {
        return Ok(None);
    };
    let (n, options, total) = (first.n, first.options.clone(), first.jobs);
    let mut seen = vec![None::<&Path>; n];
    for (path, s) in &shards {
        if s.n != n || s.options != options || s.jobs != total {
            return Err(ExperimentError::Merge(format!(
                "{} and {} are shards of different runs (shard {}/{} of `{}` vs {}/{} of `{}`)",
                first_path.display(),
                path.display(),
                first.k,
                n,
                options,
                s.k,
                s.n,
                s.options
            )));
        }
        if let Some(other) = seen[s.k - 1] {
            return Err(ExperimentError::Merge(format!(
                "shard {}/{n} twice: {} and {}",
                s.k,
                other.display(),
                path.display()
            )));
        }
        seen[s.k - 1] = Some(path);
    }
    let missing: Vec<String> = (1..=n)
        .filter(|k| seen[k - 1].is_none())
        .map(|k| format!("{k}/{n}"))
        .collect();
    if !missing.is_empty() {
        return Err(ExperimentError::Merge(format!(
            "{}: shard(s) {} missing",
            P::ID,
            missing.join(", ")
        )));
    }
    let mut config = P::quick();
    config
        .set_all(&options)
        .map_err(|e| corrupt(first_path, e))?;
    let mut slots: Vec<Option<P::Done>> = (0..total).map(|_| None).collect();
    for (path, s) in shards {
        for (j, d) in s.done {
            match slots.get_mut(j) {
                Some(slot @ None) if Shard::of_cell(j, n) == s.k => *slot = Some(d),
                _ => return Err(corrupt(&path, format!("unexpected job {j}"))),
            }
        }
    }
    let done: Vec<P::Done> = slots
        .into_iter()
        .enumerate()
        .map(|(j, d)| {
            d.ok_or_else(|| ExperimentError::Merge(format!("{}: job {j} missing", P::ID)))
        })
        .collect::<Result<_, _>>()?;
    let dir = out.join(P::ID);
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    bayestrack_otb::write::mark_partial(&dir, &format!("`cargo xtask merge` of {}", P::ID))?;
    let rows: Vec<P::Row> = done
        .iter()
        .enumerate()
        .flat_map(|(j, d)| P::rows(&config, j, d))
        .collect();
    let tables = publish(&dir, P::LOG, &rows, |staging| {
        report::<P>(&config, done, staging)
    })?;
    bayestrack_otb::write::clear_partial(&dir)?;
    Ok(Some(tables))
}

impl<P: Paper> Experiment for P {
    fn id(&self) -> &'static str {
        P::ID
    }
    fn source(&self) -> &'static str {
        P::SOURCE
    }
    fn summary(&self) -> &'static str {
        P::SUMMARY
    }
    fn options(&self) -> Vec<bayestrack_options::Spec> {
        <P::Config as Options>::specs()
    }
    fn run(&self, opts: &RunOptions) -> Result<Vec<Table>, ExperimentError> {
        let config = config::<P>(opts)?;
        let dir = opts.output_dir(P::ID)?;
        match opts.shard {
            Some(shard) => run_shard::<P>(&config, shard, &dir, opts.progress),
            None => {
                // a folder that held a shard holds a whole run now
                for stale in [SHARD_FILE, SHARD_NOTE] {
                    let _ = std::fs::remove_file(dir.join(stale));
                }
                // every file of the finished run replaces the previous
                // run's only once all are written (`publish`)
                let jobs: Vec<usize> = (0..P::jobs(&config)).collect();
                let (done, partial) =
                    run_jobs_partial::<P>(&config, &jobs, Some(&dir.join(P::LOG)), opts.progress)?;
                let rows = log_rows::<P>(&config, &jobs, &done);
                let tables = publish(&dir, P::LOG, &rows, |staging| {
                    report::<P>(&config, done, staging)
                })?;
                if let Some(partial) = partial {
                    partial.discard()?;
                }
                Ok(tables)
            }
        }
    }
    fn merge(&self, dirs: &[PathBuf], out: &Path) -> Result<Option<Vec<Table>>, ExperimentError> {
        merge::<P>(dirs, out)
    }
    fn golden(&self) -> Result<Option<String>, ExperimentError> {
        P::golden()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    bayestrack_options::options! {
        /// A two-file experiment whose report can fail part-way.
        #[derive(Debug, Clone, PartialEq)]
        pub struct TinyConfig {
            /// Jobs.
            pub jobs: usize = 3, in 1..=10;
            /// Added to every job's result.
            pub offset: usize = 0, in 0..=100;
            /// Fail after writing the first of the report's files.
            pub fail_report: bool = false;
        }
    }

    #[derive(serde::Serialize)]
    struct TinyRow {
        job: usize,
        value: usize,
    }

    struct Tiny;

    impl Paper for Tiny {
        type Config = TinyConfig;
        type Done = usize;
        type Row = TinyRow;
        type Shared = ();
        const ID: &'static str = "tiny";
        const SOURCE: &'static str = "a test";
        const SUMMARY: &'static str = "a test";
        const LOG: &'static str = "runs.csv";
        const JOBS: &'static str = "tiny jobs";
        fn quick() -> TinyConfig {
            TinyConfig::default()
        }
        fn full() -> TinyConfig {
            TinyConfig::default()
        }
        fn jobs(c: &TinyConfig) -> usize {
            c.jobs
        }
        fn prepare(_: &TinyConfig, _: &[usize]) -> Result<(), ExperimentError> {
            Ok(())
        }
        fn run_job(c: &TinyConfig, _: &(), j: usize) -> Result<usize, ExperimentError> {
            Ok(j + c.offset)
        }
        fn rows(_: &TinyConfig, j: usize, done: &usize) -> Vec<TinyRow> {
            vec![TinyRow {
                job: j,
                value: *done,
            }]
        }
        fn report(
            c: &TinyConfig,
            done: Vec<usize>,
            dir: &Path,
        ) -> Result<Vec<Table>, ExperimentError> {
            write_text(&dir.join("table.csv"), &format!("{done:?}\n"))?;
            if c.fail_report {
                return Err(ExperimentError::Failed {
                    id: "tiny",
                    message: "killed part-way through the report".into(),
                });
            }
            write_text(&dir.join("errors.svg"), &format!("<svg>{done:?}</svg>\n"))?;
            Ok(Vec::new())
        }
    }

    /// A run that stops part-way through writing its files (killed, or
    /// failed) leaves every file of the last finished run as it was, and
    /// what it finished in `*.partial*` files (issue 28: hikpf --full
    /// replaced runs.csv, table.csv and errors.svg before that).
    #[test]
    fn a_run_stopped_while_writing_its_files_keeps_the_last_finished_run() {
        let out = std::env::temp_dir().join(format!("bayestrack-driver-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let opts = |set: &[(&str, &str)]| RunOptions {
            mode: Mode::Quick,
            out: out.clone(),
            progress: false,
            set: set
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            shard: None,
        };
        let dir = out.join("tiny");
        Tiny.run(&opts(&[])).unwrap();
        let files = ["runs.csv", "table.csv", "errors.svg"];
        let before: Vec<String> = files
            .iter()
            .map(|f| std::fs::read_to_string(dir.join(f)).unwrap())
            .collect();
        assert_eq!(before[1], "[0, 1, 2]\n");
        let e = Tiny
            .run(&opts(&[("offset", "10"), ("fail_report", "true")]))
            .unwrap_err();
        assert!(e.to_string().contains("part-way"), "{e}");
        for (f, old) in files.iter().zip(&before) {
            assert_eq!(&std::fs::read_to_string(dir.join(f)).unwrap(), old, "{f}");
        }
        // the finished part is kept, under names that say it is partial
        let partial = std::fs::read_to_string(dir.join("runs.partial.csv")).unwrap();
        assert_eq!(partial.lines().count(), 4, "{partial}");
        // a finished run replaces every file and leaves no partial one
        Tiny.run(&opts(&[("offset", "10")])).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("table.csv")).unwrap(),
            "[10, 11, 12]\n"
        );
        assert!(!dir.join("runs.partial.csv").exists());
        assert!(!dir.join(STAGING_DIR).exists());
        let _ = std::fs::remove_dir_all(&out);
    }

    /// Jobs run in groups (odd jobs first, then even), each group with its
    /// own shared data that holds only its jobs.
    struct Grouped;

    impl Paper for Grouped {
        type Config = TinyConfig;
        type Done = usize;
        type Row = TinyRow;
        type Shared = Vec<usize>;
        const ID: &'static str = "grouped";
        const SOURCE: &'static str = "a test";
        const SUMMARY: &'static str = "a test";
        const LOG: &'static str = "runs.csv";
        const JOBS: &'static str = "grouped jobs";
        fn quick() -> TinyConfig {
            TinyConfig::default()
        }
        fn full() -> TinyConfig {
            TinyConfig::default()
        }
        fn jobs(_: &TinyConfig) -> usize {
            7
        }
        fn prepare(_: &TinyConfig, jobs: &[usize]) -> Result<Vec<usize>, ExperimentError> {
            Ok(jobs.to_vec())
        }
        fn groups(_: &TinyConfig, jobs: &[usize]) -> Vec<Vec<usize>> {
            let (even, odd): (Vec<usize>, Vec<usize>) = jobs.iter().partition(|&&j| j % 2 == 0);
            vec![odd, even]
        }
        fn run_job(
            _: &TinyConfig,
            shared: &Vec<usize>,
            j: usize,
        ) -> Result<usize, ExperimentError> {
            assert!(shared.contains(&j), "job {j} ran with another group's data");
            Ok(10 * j)
        }
        fn rows(_: &TinyConfig, j: usize, done: &usize) -> Vec<TinyRow> {
            vec![TinyRow {
                job: j,
                value: *done,
            }]
        }
        fn report(_: &TinyConfig, _: Vec<usize>, _: &Path) -> Result<Vec<Table>, ExperimentError> {
            Ok(Vec::new())
        }
    }

    #[test]
    fn grouped_jobs_come_back_in_job_order() {
        let c = TinyConfig::default();
        let done = run_all::<Grouped>(&c, None, false).unwrap();
        assert_eq!(done, vec![0, 10, 20, 30, 40, 50, 60]);
        let done = run_jobs::<Grouped>(&c, &[1, 4, 5], None, false).unwrap();
        assert_eq!(done, vec![10, 40, 50]);
    }

    #[test]
    fn shards_parse_and_partition_the_jobs() {
        assert_eq!(Shard::parse("2/3").ok(), Shard::new(2, 3).ok());
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", ""] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let shards: Vec<Shard> = (1..=3).map(|k| Shard::new(k, 3).unwrap()).collect();
        for j in 0..20 {
            assert_eq!(shards.iter().filter(|s| s.contains(j)).count(), 1);
        }
    }
}
