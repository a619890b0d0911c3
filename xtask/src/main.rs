//! `cargo xtask`: a thin command line over `bayestrack-experiments` (the
//! paper experiments and scenes) and `bayestrack-otb` (the OTB suite).
//!
//! ```text
//! cargo xtask reproduce-table list         # the registry
//! cargo xtask reproduce-table all          # every experiment, quick mode
//! cargo xtask reproduce-table hikpf --full # one experiment at paper scale
//! cargo xtask reproduce-table ball --options # its options: keys, types, defaults
//! cargo xtask reproduce-table ball --full --shard 2/8 --out shards/2  # one slice
//! cargo xtask merge shards/* --out target/reproduce  # the slices as one run
//! cargo xtask otb --root ../shared/data/sequences  # every tracker, every sequence
//! cargo xtask stress                       # every tracker on the synthetic stress set
//! cargo xtask stress --trackers ncc-scale --sweep key=v1,v2  # choose a parameter
//! ```
//!
//! `cargo xtask otb` sets our trackers beside the published OTB results
//! when `--otb-data` (default `../shared/data/otb`) holds them, and shows a
//! progress bar (elapsed time, ETA, the tracker and sequence running) when
//! stderr is a terminal.
//!
//! Default paths (`target/reproduce`, `tests/golden`,
//! `../shared/data/sequences`, ...) are relative to the project root, so
//! `cargo xtask` works from any subfolder; paths given on the command line
//! are relative to the current folder, as usual.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use bayestrack_experiments::{
    Experiment, ExperimentError, Mode, REGISTRY as EXPERIMENTS, RunOptions, Shard,
};
use bayestrack_otb::published::{PUBLISHED_OPE_FILE, Published};
use bayestrack_otb::suite::{SuiteEvent, SuiteOptions, SuiteReport, Timing, run_suite_with};
use bayestrack_trackers::{REGISTRY, TrackerInfo, tracker_info};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "xtask", about = "bayestrack project tasks")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print a paper's table beside ours; write CSV and SVG under `--out/<id>/`.
    ReproduceTable {
        /// `list`, `all`, or an experiment id (see `list`).
        target: String,
        /// Paper scale instead of the quick CI scale.
        #[arg(long)]
        full: bool,
        /// Output root (default: `<project root>/target/reproduce`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a named option of the experiment, `key=value`
        /// (repeatable; see docs/reproduction.md for each experiment's keys).
        #[arg(long = "set", value_parser = parse_key_value)]
        set: Vec<(String, String)>,
        /// Run only slice K of N of the jobs (1-based; seeds are keyed by
        /// run, so a slice needs nothing from the others) and save it for
        /// `cargo xtask merge`.
        #[arg(long, value_parser = parse_shard)]
        shard: Option<Shard>,
        /// List the experiment's options (key, type, domain, default,
        /// documentation) instead of running it.
        #[arg(long)]
        options: bool,
    },
    /// Combine the outputs of `reproduce-table ... --shard K/N` runs (each
    /// folder a shard's `--out`) into exactly the files one run writes,
    /// and print the tables.
    Merge {
        /// The shards' output folders.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output root (default: `<project root>/target/reproduce`).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Write a synthetic scene as PNG frames + groundtruth_rect.txt so a
    /// person can look at it (`list` prints the names).
    Scenes {
        /// Scene name, or `list`.
        name: String,
        /// Output folder (default: `<project root>/target/scenes/<name>`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the scene's random streams.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Number of frames (default: the scene's own length).
        #[arg(long)]
        frames: Option<usize>,
    },
    /// Run every tracker on every sequence of a folder (OTB one-pass
    /// evaluation); print SR@0.5 / AUC / P@20 / fps per sequence and their means,
    /// then ours beside the published OTB trackers (success rate at IoU
    /// 0.5); write boxes, results.csv, results.md and success/precision
    /// plots. `--shard K/N` runs one slice of the cells (on one of N
    /// machines), `--merge DIR...` combines the slices' folders into the
    /// files of one run.
    Otb {
        /// Folder of OTB sequences (each with img/ and ground truth)
        /// (default: `<project root>/../shared/data/sequences`).
        #[arg(long)]
        root: Option<PathBuf>,
        /// Comma-separated tracker names (default: every tracker; see
        /// `bayestrack trackers`).
        #[arg(long, value_delimiter = ',')]
        trackers: Vec<String>,
        /// Seed given to every tracker.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output folder (default: `<project root>/target/otb`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Folder with the published OTB results, `published_ope.csv`
        /// (default: `<project root>/../shared/data/otb`; without it ours
        /// are printed alone).
        #[arg(long)]
        otb_data: Option<PathBuf>,
        /// Run shard K of N: the tracker x sequence cells i (numbered
        /// sequence-major: sequence i / trackers, tracker i % trackers) with
        /// i % N == K - 1, written to --out with what `--merge` needs
        /// (shard.csv, scores/) instead of the results, table and plots.
        #[arg(long, value_name = "K/N", value_parser = parse_shard)]
        shard: Option<Shard>,
        /// Merge the folders of every shard of one run (written by
        /// `--shard`) into --out: the files one run on one machine writes,
        /// byte for byte, beside the published results of --otb-data.
        #[arg(
            long,
            value_name = "DIR",
            num_args = 1..,
            conflicts_with_all = ["shard", "root", "trackers", "seed"]
        )]
        merge: Vec<PathBuf>,
    },
    /// Write the synthetic stress set (partial and full occlusion, scale
    /// 0.5x-2x, fast motion, illumination, same-colour clutter, mixed; colour
    /// and gray) to `--out/sequences` (only what is missing or differs),
    /// run the OTB suite on it (results in `--out/results`) and print the
    /// table per sequence and per stress with the means. `--sweep
    /// key=v1,v2,...` runs one tracker once per value and prints the mean
    /// SR@0.5 / AUC of each: choose parameters here, report them on the
    /// real sequences (see docs/stress.md).
    Stress {
        /// Comma-separated tracker names (default: every tracker).
        #[arg(long, value_delimiter = ',')]
        trackers: Vec<String>,
        /// A tracker option, `key=value`, given to every tracker run
        /// (repeatable; see `bayestrack options <tracker>`).
        #[arg(long = "set", value_parser = parse_key_value)]
        set: Vec<(String, String)>,
        /// Run the one tracker of `--trackers` once per value of an option,
        /// `key=v1,v2,...`, and print its means over the set per value.
        #[arg(long, value_parser = parse_sweep)]
        sweep: Option<(String, Vec<String>)>,
        /// Seed of the stress set's rendering.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Seed given to every tracker.
        #[arg(long, default_value_t = 0)]
        tracker_seed: u64,
        /// Frames of each sequence (default 120).
        #[arg(long)]
        frames: Option<usize>,
        /// Output folder: `sequences/`, `results/` and `sweep/` under it
        /// (default: `<project root>/target/stress`).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Rewrite `tests/golden/<id>.csv` from fresh quick runs and print what
    /// changed.
    Bless {
        /// Experiment ids (default: every implemented one).
        ids: Vec<String>,
    },
}

/// The project root: the folder above xtask's own.
fn project_root() -> PathBuf {
    let xtask = Path::new(env!("CARGO_MANIFEST_DIR"));
    xtask.parent().unwrap_or(xtask).to_path_buf()
}

/// `explicit` as given (relative to the current folder), else `default`
/// under the project root: cargo runs xtask from the folder it was invoked
/// in, and a default must not depend on that.
fn resolve(explicit: Option<PathBuf>, default: &str) -> PathBuf {
    explicit.unwrap_or_else(|| project_root().join(default))
}

/// `key=v1,v2,...`: an option and the values a sweep gives it.
fn parse_sweep(s: &str) -> Result<(String, Vec<String>), String> {
    let (key, values) = parse_key_value(s)?;
    let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
    if values.iter().any(String::is_empty) {
        return Err(format!("`{s}`: an empty value (expected key=v1,v2,...)"));
    }
    Ok((key, values))
}

fn parse_key_value(s: &str) -> Result<(String, String), String> {
    s.split_once('=')
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .ok_or_else(|| format!("expected key=value, got `{s}`"))
}

fn print_registry(reg: &[&dyn Experiment]) {
    println!("{:<14} {:<6} {:<52} summary", "id", "state", "source");
    for e in reg {
        let state = if e.implemented() { "ready" } else { "todo" };
        println!(
            "{:<14} {:<6} {:<52} {}",
            e.id(),
            state,
            e.source(),
            e.summary()
        );
    }
}

fn run_one(e: &dyn Experiment, opts: &RunOptions) -> Result<(), ExperimentError> {
    eprintln!("== {} ({}) ==", e.id(), e.source());
    let start = std::time::Instant::now();
    // the output folder says PARTIAL until every file is written
    let tables = bayestrack_experiments::experiment::run_marked(e, opts)?;
    // on stderr, with the progress: stdout stays the same from run to run
    eprintln!("{} ran in {:.2} s", e.id(), start.elapsed().as_secs_f64());
    for table in tables {
        println!("{table}");
    }
    println!("files: {}", opts.out.join(e.id()).display());
    Ok(())
}

/// Merges the shards under `dirs` of every experiment found there into
/// `out` and prints their tables.
fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), String> {
    let mut merged = 0;
    for e in EXPERIMENTS {
        let Some(tables) = e.merge(dirs, out).map_err(|err| err.to_string())? else {
            continue;
        };
        eprintln!("== {} merged ==", e.id());
        for table in tables {
            println!("{table}");
        }
        println!("files: {}", out.join(e.id()).display());
        merged += 1;
    }
    if merged == 0 {
        return Err(format!(
            "no shard found under {} (a shard's folder holds <id>/{})",
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            bayestrack_experiments::driver::SHARD_FILE
        ));
    }
    Ok(())
}

/// Prints an experiment's declared options.
fn print_options(e: &dyn Experiment) {
    println!("{} ({}): options (`--set key=value`)", e.id(), e.source());
    for spec in e.options() {
        println!("{spec}");
    }
}

/// Rewrites the golden file of one experiment; returns whether it changed.
fn bless(e: &dyn Experiment) -> Result<bool, String> {
    let Some(new) = e.golden().map_err(|err| err.to_string())? else {
        println!("{}: nothing pinned", e.id());
        return Ok(false);
    };
    let golden = project_root().join("tests/golden");
    let path = golden.join(format!("{}.csv", e.id()));
    let old = std::fs::read_to_string(&path).unwrap_or_default();
    if old == new {
        println!("{}: unchanged", e.id());
        return Ok(false);
    }
    let old_lines: Vec<&str> = old.lines().collect();
    for (i, line) in new.lines().enumerate() {
        match old_lines.get(i) {
            Some(o) if *o == line => {}
            Some(o) => println!("{}:{}\n  - {o}\n  + {line}", path.display(), i + 1),
            None => println!("{}:{}\n  + {line}", path.display(), i + 1),
        }
    }
    for (i, o) in old_lines.iter().enumerate().skip(new.lines().count()) {
        println!("{}:{}\n  - {o}", path.display(), i + 1);
    }
    std::fs::create_dir_all(&golden).map_err(|err| format!("{}: {err}", golden.display()))?;
    std::fs::write(&path, new).map_err(|err| format!("{}: {err}", path.display()))?;
    println!("{}: rewritten", path.display());
    Ok(true)
}

/// The published OTB results in `dir`, or `None` with a note on stderr
/// when the folder or its files are absent (ours are then printed alone);
/// a file that is there but cannot be read or parsed is an error.
fn read_published(dir: &Path) -> Result<Option<Published>, String> {
    match Published::read(dir) {
        Ok(p) => Ok(Some(p)),
        Err(e) if Published::is_missing(&e) => {
            eprintln!(
                "note: no published OTB results ({e}); printing ours alone. They are \
                 in ../shared/data/otb/{PUBLISHED_OPE_FILE} (or --otb-data DIR)."
            );
            Ok(None)
        }
        Err(e) => Err(format!("published OTB results: {e}")),
    }
}

/// A progress bar on stderr for the suite, drawn only when stderr is a
/// terminal: elapsed time, frames tracked of all, ETA, what is running.
fn suite_bar() -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let style = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{wide_bar}] {pos}/{len} frames, ETA {eta_precise}  {msg}",
    )
    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
    indicatif::ProgressBar::new(0).with_style(style)
}

/// The run option given to `reproduce-table list`, which runs nothing.
fn list_refuses(opts: &RunOptions, full: bool) -> Option<String> {
    if let Some((k, v)) = opts.set.first() {
        Some(format!("--set {k}={v}"))
    } else if let Some(shard) = opts.shard {
        Some(format!("--shard {shard}"))
    } else if full {
        Some("--full".to_string())
    } else {
        None
    }
}

/// `--shard K/N`: shard K of N.
fn parse_shard(spec: &str) -> Result<Shard, String> {
    Shard::parse(spec).map_err(|e| e.to_string())
}

/// `cargo xtask otb`: the suite on every cell, or on a shard's
/// (`shard`), or the merge of shard folders (`merge_dirs`).
fn otb(
    root: &Path,
    names: &[String],
    seed: u64,
    out: PathBuf,
    otb_data: &Path,
    shard: Option<Shard>,
    merge_dirs: &[PathBuf],
) -> Result<(), String> {
    let trackers = trackers_named(names)?;
    // a broken published file is reported after our results, not instead
    let (published, published_error) = match read_published(otb_data) {
        Ok(p) => (p, None),
        Err(e) => (None, Some(e)),
    };
    let report = if merge_dirs.is_empty() {
        run_otb(root, trackers, seed, &[], out.clone(), published, shard)?
    } else {
        bayestrack_otb::suite::merge(merge_dirs, &out, published).map_err(|e| e.to_string())?
    };
    if let Some(shard) = shard {
        println!(
            "shard {shard}: {} of the tracker x sequence cells; merge the folders of all {} \
             shards with `cargo xtask otb --merge DIR... --out OUT`",
            report.cells.len(),
            shard.count()
        );
    } else {
        print_otb(&report);
    }
    println!("\nfiles: {}", out.display());
    let mut errors: Vec<String> = published_error.into_iter().collect();
    let table = if shard.is_some() {
        bayestrack_otb::shard::SHARD_FILE
    } else {
        "results.csv"
    };
    errors.extend(failures(&report, &out.join(table)));
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors.join("\nerror: "))
    }
}

/// The registry entries `names` (every tracker when empty).
fn trackers_named(names: &[String]) -> Result<Vec<&'static TrackerInfo>, String> {
    if names.is_empty() {
        return Ok(REGISTRY.iter().collect());
    }
    names
        .iter()
        .map(|n| tracker_info(n).map_err(|e| e.to_string()))
        .collect()
}

/// The error for the cells of `report` that failed, if any: cells marked
/// n/a (a tracker that cannot run on the input by design, see
/// `CellError`) are not failures; every other error fails the run.
fn failures(report: &SuiteReport, table: &Path) -> Option<String> {
    let failed = report.failures();
    if failed.is_empty() {
        return None;
    }
    let cells: Vec<String> = failed
        .iter()
        .map(|c| format!("{} x {}", c.tracker, c.sequence))
        .collect();
    Some(format!(
        "{} tracker x sequence cell(s) failed: {} (reasons in the `error` column of {})",
        failed.len(),
        cells.join(", "),
        table.display()
    ))
}

/// What `cargo xtask stress` runs.
struct StressRun {
    trackers: Vec<String>,
    set: Vec<(String, String)>,
    sweep: Option<(String, Vec<String>)>,
    seed: u64,
    tracker_seed: u64,
    frames: Option<usize>,
    out: PathBuf,
}

/// `cargo xtask stress`: writes the set where it is missing or differs,
/// then runs the suite on it once, or once per value of a sweep.
fn stress(run: StressRun) -> Result<(), String> {
    use bayestrack_experiments::stress::{
        SweepRow, default_set, stress_table, sweep_table, write_set,
    };
    let started = std::time::Instant::now();
    let trackers = trackers_named(&run.trackers)?;
    // every option must mean something to every tracker before anything runs
    let mut sets = vec![(String::new(), run.set.clone())];
    if let Some((key, values)) = &run.sweep {
        if trackers.len() != 1 {
            return Err(format!(
                "--sweep {key}=... runs one tracker: give it with --trackers NAME ({} given)",
                trackers.len()
            ));
        }
        sets = values
            .iter()
            .map(|v| {
                let mut set = run.set.clone();
                set.push((key.clone(), v.clone()));
                (v.clone(), set)
            })
            .collect();
    }
    for (_, set) in &sets {
        for t in &trackers {
            t.build_with(run.tracker_seed, set)
                .map_err(|e| format!("{}: {e}", t.name))?;
        }
    }
    let dir = run.out.join("sequences");
    let summary = write_set(&default_set(run.frames), run.seed, &dir).map_err(|e| e.to_string())?;
    println!(
        "stress set (seed {}) in {}: {} written, {} rewritten, {} kept, {} old removed ({:.1} s)",
        run.seed,
        dir.display(),
        summary.written.len(),
        summary.rewritten.len(),
        summary.kept.len(),
        summary.removed.len(),
        started.elapsed().as_secs_f64()
    );
    let mut errors = Vec::new();
    let mut rows = Vec::new();
    for (value, set) in &sets {
        let out = match &run.sweep {
            Some((key, _)) => run.out.join("sweep").join(format!("{key}={value}")),
            None => run.out.join("results"),
        };
        let report = run_otb(
            &dir,
            trackers.clone(),
            run.tracker_seed,
            set,
            out.clone(),
            None,
            None,
        )?;
        if run.sweep.is_none() {
            println!("{}", report.table());
            println!("{}", stress_table(&report));
        } else {
            rows.push(SweepRow {
                value: value.clone(),
                mean: report.mean(trackers[0].name),
                sequences: report.sequences.len(),
            });
        }
        errors.extend(failures(&report, &out.join("results.csv")));
    }
    if let Some((key, _)) = &run.sweep {
        println!("{}", sweep_table(trackers[0].name, key, &rows));
    }
    println!(
        "files: {}\nstress run: {:.1} s",
        run.out.display(),
        started.elapsed().as_secs_f64()
    );
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors.join("\nerror: "))
    }
}

/// Runs the suite (every cell, or `shard`'s) with a progress bar.
fn run_otb(
    root: &Path,
    trackers: Vec<&'static TrackerInfo>,
    seed: u64,
    set: &[(String, String)],
    out: PathBuf,
    published: Option<Published>,
    shard: Option<Shard>,
) -> Result<SuiteReport, String> {
    let options = SuiteOptions {
        trackers,
        seed,
        set: set.to_vec(),
        out,
        progress: true,
        published,
        shard,
        timing: Timing::Measured,
    };
    let bar = suite_bar();
    let report = run_suite_with(root, &options, |event| match event {
        SuiteEvent::Start { total, .. } => bar.set_length(total),
        SuiteEvent::Decoding { sequence } => bar.set_message(format!("decoding {sequence}")),
        SuiteEvent::CellStarted {
            sequence, tracker, ..
        } => bar.set_message(format!("{tracker} on {sequence}")),
        SuiteEvent::Frame { done } => bar.set_position(done),
        SuiteEvent::CellFinished { cell, done } => {
            bar.set_position(done);
            // above the bar, or plainly when it is hidden
            bar.suspend(|| eprintln!("{}", cell.summary()));
        }
        _ => {}
    });
    bar.finish_and_clear();
    report.map_err(|e| e.to_string())
}

/// Prints the suite's table, ours beside the published trackers, and the
/// notes on the frames compared.
fn print_otb(report: &SuiteReport) {
    println!("{}", report.table());
    if let Some(beside) = report.beside_published() {
        println!("{beside}");
    }
    for note in report.published_notes() {
        println!("- {note}");
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Otb {
            root,
            trackers,
            seed,
            out,
            otb_data,
            shard,
            merge,
        } => match otb(
            &resolve(root, "../shared/data/sequences"),
            &trackers,
            seed,
            resolve(out, "target/otb"),
            &resolve(otb_data, "../shared/data/otb"),
            shard,
            &merge,
        ) {
            Ok(()) => ExitCode::SUCCESS,
            Err(err) => {
                eprintln!("error: {err}");
                ExitCode::FAILURE
            }
        },
        Command::Scenes {
            name,
            out,
            seed,
            frames,
        } => {
            if name == "list" {
                for s in bayestrack_experiments::scenes::SCENES {
                    println!("{:<16} {}", s.name, s.summary);
                }
                return ExitCode::SUCCESS;
            }
            let out = resolve(out, &format!("target/scenes/{name}"));
            match bayestrack_experiments::scenes::write_named_scene(&name, seed, frames, &out) {
                Ok(summary) => {
                    println!(
                        "{}: {} frames written to {}",
                        name,
                        summary.frames_written,
                        summary.dir.display()
                    );
                    ExitCode::SUCCESS
                }
                Err(err) => {
                    eprintln!("error: {err}");
                    ExitCode::FAILURE
                }
            }
        }
        Command::Stress {
            trackers,
            set,
            sweep,
            seed,
            tracker_seed,
            frames,
            out,
        } => match stress(StressRun {
            trackers,
            set,
            sweep,
            seed,
            tracker_seed,
            frames,
            out: resolve(out, "target/stress"),
        }) {
            Ok(()) => ExitCode::SUCCESS,
            Err(err) => {
                eprintln!("error: {err}");
                ExitCode::FAILURE
            }
        },
        Command::Bless { ids } => {
            let mut failed = false;
            for e in EXPERIMENTS.iter().filter(|e| e.implemented()) {
                if !ids.is_empty() && !ids.iter().any(|i| i == e.id()) {
                    continue;
                }
                if let Err(err) = bless(*e) {
                    eprintln!("error: {}: {err}", e.id());
                    failed = true;
                }
            }
            if failed {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Command::Merge { dirs, out } => match merge(&dirs, &resolve(out, "target/reproduce")) {
            Ok(()) => ExitCode::SUCCESS,
            Err(err) => {
                eprintln!("error: {err}");
                ExitCode::FAILURE
            }
        },
        Command::ReproduceTable {
            target,
            full,
            out,
            set,
            shard,
            options,
        } => {
            let opts = RunOptions {
                mode: if full { Mode::Full } else { Mode::Quick },
                out: resolve(out, "target/reproduce"),
                progress: true,
                set,
                shard,
            };
            if options {
                let all: Vec<&dyn Experiment> = if target == "all" || target == "list" {
                    EXPERIMENTS.to_vec()
                } else {
                    match bayestrack_experiments::find(&target) {
                        Ok(e) => vec![e],
                        Err(err) => {
                            eprintln!("error: {err}");
                            return ExitCode::FAILURE;
                        }
                    }
                };
                for e in all {
                    print_options(e);
                    println!();
                }
                return ExitCode::SUCCESS;
            }
            match target.as_str() {
                "list" => {
                    // `list` runs nothing: an option for a run is a mistake
                    // to say, not to drop silently
                    if let Some(what) = list_refuses(&opts, full) {
                        eprintln!(
                            "error: `reproduce-table list` runs nothing, so {what} has no \
                             effect; give an experiment id (or `all`) to run with it"
                        );
                        return ExitCode::from(2);
                    }
                    print_registry(EXPERIMENTS);
                    ExitCode::SUCCESS
                }
                "all" => {
                    let mut failed = false;
                    for e in EXPERIMENTS {
                        if !e.implemented() {
                            println!("-- {}: not implemented yet ({})\n", e.id(), e.source());
                            continue;
                        }
                        if let Err(err) = run_one(*e, &opts) {
                            eprintln!("error: {err}");
                            failed = true;
                        }
                    }
                    if failed {
                        ExitCode::FAILURE
                    } else {
                        ExitCode::SUCCESS
                    }
                }
                id => match bayestrack_experiments::find(id).and_then(|e| run_one(e, &opts)) {
                    Ok(()) => ExitCode::SUCCESS,
                    Err(err) => {
                        eprintln!("error: {err}");
                        ExitCode::FAILURE
                    }
                },
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn list_refuses_options_that_only_a_run_uses() {
        let mut opts = super::RunOptions {
            mode: super::Mode::Quick,
            out: std::path::PathBuf::from("out"),
            progress: false,
            set: Vec::new(),
            shard: None,
        };
        assert_eq!(super::list_refuses(&opts, false), None);
        assert!(super::list_refuses(&opts, true).is_some());
        opts.set.push(("runs".into(), "3".into()));
        let said = super::list_refuses(&opts, false).unwrap();
        assert!(said.contains("--set runs=3"), "{said}");
    }

    use super::*;

    #[test]
    fn published_results_absent_are_a_note_and_broken_ones_an_error() {
        let dir = std::env::temp_dir().join(format!("xtask-otb-data-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(read_published(&dir), Ok(None));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(PUBLISHED_OPE_FILE), "tracker,sequence\n").unwrap();
        let err = read_published(&dir).unwrap_err();
        assert!(
            err.starts_with("published OTB results: ") && err.contains("published_ope.csv:1:"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_sweep_is_a_key_and_its_values() {
        assert_eq!(
            parse_sweep("lambda=0.1, 0.2,0.3"),
            Ok((
                "lambda".to_string(),
                vec!["0.1".to_string(), "0.2".to_string(), "0.3".to_string()]
            ))
        );
        assert!(parse_sweep("lambda").is_err());
        assert!(parse_sweep("lambda=0.1,,0.3").is_err());
    }

    #[test]
    fn stress_writes_the_set_scores_it_and_refuses_bad_options_first() {
        let dir = std::env::temp_dir().join(format!("xtask-stress-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let run = |trackers: &[&str], set: &[(&str, &str)], sweep: Option<(&str, &[&str])>| {
            stress(StressRun {
                trackers: trackers.iter().map(|t| t.to_string()).collect(),
                set: set
                    .iter()
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .collect(),
                sweep: sweep
                    .map(|(k, v)| (k.to_string(), v.iter().map(|s| s.to_string()).collect())),
                seed: 1,
                tracker_seed: 0,
                frames: Some(10),
                out: dir.clone(),
            })
        };
        // an option no tracker takes, a sweep over two trackers: refused
        // before anything is written
        let err = run(&["mad"], &[("no_such_key", "1")], None).unwrap_err();
        assert!(err.contains("no_such_key"), "{err}");
        let err = run(&["mad", "ncc-scale"], &[], Some(("scale_step", &["1.02"]))).unwrap_err();
        assert!(err.contains("runs one tracker"), "{err}");
        assert!(!dir.exists());
        run(&["mad"], &[], None).unwrap();
        let csv = std::fs::read_to_string(dir.join("results/results.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 18, "{csv}");
        assert!(csv.contains("\nfull-occlusion-gray,mad,"), "{csv}");
        run(&["ncc-scale"], &[], Some(("scale_step", &["1.02", "1.05"]))).unwrap();
        for v in ["1.02", "1.05"] {
            assert!(
                dir.join(format!("sweep/scale_step={v}/results.csv"))
                    .is_file()
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn defaults_resolve_from_the_project_root_and_given_paths_stay_as_given() {
        let golden = resolve(None, "tests/golden");
        assert!(golden.is_absolute(), "{}", golden.display());
        assert!(golden.is_dir(), "{}", golden.display());
        assert!(project_root().join("Cargo.toml").is_file());
        assert_eq!(
            resolve(Some(PathBuf::from("out")), "target/otb"),
            PathBuf::from("out")
        );
    }
}
