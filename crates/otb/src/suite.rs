//! The OTB one-pass evaluation behind `cargo xtask otb`: every tracker on
//! every sequence of a folder, initialised from frame 1's ground truth,
//! scored on the labelled frames.
//!
//! Each tracker streams a sequence's frames, decoding one at a time (memory
//! does not grow with the sequence's length; fps counts only the tracker's
//! calls), and every frame is given the first frame's channel count, as
//! `bayestrack track` does. Under the output folder the run writes, as it goes:
//! `boxes/<tracker>/<sequence>.txt` (one `x,y,w,h` row per frame, flushed
//! per frame), then `results.csv`, `results.md` and, per sequence and over
//! all of them, the success plot (fraction of frames with IoU above each
//! threshold) and the precision plot (fraction within each centre-error
//! distance) as SVG. A tracker that fails on a sequence is reported in its
//! cell and the run goes on; [`SuiteReport::failures`] lists those cells
//! (`cargo xtask otb` exits non-zero when there is any). A tracker that
//! cannot run on a sequence by design (see [`CellError::NotApplicable`])
//! is not a failure.
//!
//! A run killed part-way keeps every finished cell: while it runs the
//! folder holds `PARTIAL.txt`, each finished cell is appended to
//! `results.partial.csv` at once, and a cell's boxes go to
//! `boxes/<tracker>/<sequence>.partial.txt`, renamed to `<sequence>.txt`
//! when the cell finishes. The files of the previous run (`results.csv`,
//! the plots, box files) are only ever replaced whole, by renaming.
//!
//! Given the published OTB results ([`SuiteOptions::published`], read from
//! `../shared/data/otb`), the report also sets our trackers beside the 34
//! published ones on the sequences both ran ([`SuiteReport::beside_published`]:
//! success rate at IoU 0.5, with our AUC and precision at 20 px), says
//! which published numbers are for the frames of our copies
//! ([`SuiteReport::published_notes`]), and the success plots draw the
//! published success rates at IoU 0.5 as reference marks.
//!
//! [`run_suite_with`] reports what it is doing ([`SuiteEvent`]: the cell
//! running, each frame tracked) so that a caller can draw a progress bar.
//!
//! On several machines, each runs one shard of the cells
//! ([`SuiteOptions::shard`], [`crate::shard`] says which cells and what a
//! shard writes) and [`merge`] combines the shard folders into the files a
//! single run writes, byte for byte ([`Timing::PerCall`] makes two runs'
//! fps, and so every byte, comparable in tests).

use std::path::{Path, PathBuf};

use bayestrack_image::BBox;
use bayestrack_trackers::{TrackerError, TrackerInfo};

use crate::error::{OtbError, WriteError};
use crate::metrics::{
    OtbScore, SUCCESS_RATE_THRESHOLD, SUCCESS_THRESHOLDS, precision_at, score_otb,
};
use crate::plot::{Marks, Series, line_chart, line_chart_with_marks};
use crate::published::Published;
use crate::sequence::{Sequence, list_sequences};
use crate::shard::{
    SHARD_FILE, Shard, ShardRow, read_scores, read_shard, scores_path, write_scores,
};
use crate::table::Table;
use crate::track::{OnBadFrame, track_source};
use crate::write::{
    BoxFile, PartialCsv, clear_partial, copy_file, create_dir, mark_partial, partial_path,
    write_csv, write_text,
};

/// Centre-error thresholds of the precision plot, px.
pub const PRECISION_PLOT_MAX: usize = 50;

/// What to run and where to write.
#[derive(Debug, Clone)]
pub struct SuiteOptions {
    /// Trackers, in table order.
    pub trackers: Vec<&'static TrackerInfo>,
    /// Seed given to every tracker.
    pub seed: u64,
    /// `key=value` options given to every tracker (applied in order over
    /// its defaults, as `bayestrack track --set` gives them; empty: the
    /// defaults). A key a tracker does not take fails its cells.
    pub set: Vec<(String, String)>,
    /// Output folder.
    pub out: PathBuf,
    /// Print one line per tracker and sequence on stderr ([`run_suite`];
    /// [`run_suite_with`] leaves the printing to its caller).
    pub progress: bool,
    /// The published OTB results to set ours beside (`None`: ours alone).
    pub published: Option<Published>,
    /// Run only this shard's cells and write them for [`merge`] (`None`:
    /// every cell, and the results, table and plots).
    pub shard: Option<Shard>,
    /// How the trackers' time (fps) is counted.
    pub timing: Timing,
}

/// How a suite run counts the trackers' time, from which it reports fps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Timing {
    /// The wall clock around each tracker call (the default).
    #[default]
    Measured,
    /// This many seconds per tracker call, whatever the calls took: the fps
    /// of two runs is then the same, and so is every byte they write (to
    /// compare a sharded run with a single one).
    PerCall(f64),
}

/// What a suite run is doing, for a progress display ([`run_suite_with`]).
/// Work is counted in tracked frames: every tracker on every frame of
/// every sequence.
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum SuiteEvent<'a> {
    /// Before anything runs: the frames to track in all.
    Start {
        /// Number of sequences.
        sequences: usize,
        /// Number of trackers.
        trackers: usize,
        /// Frames x trackers, summed over sequences.
        total: u64,
    },
    /// A sequence's frames are being decoded.
    Decoding {
        /// Sequence name.
        sequence: &'a str,
    },
    /// A tracker starts on a sequence.
    CellStarted {
        /// Sequence name.
        sequence: &'a str,
        /// Tracker name.
        tracker: &'static str,
        /// Frames of the sequence.
        frames: usize,
    },
    /// One more frame tracked.
    Frame {
        /// Frames tracked so far (of every cell).
        done: u64,
    },
    /// A cell has finished or failed; the frames it did not track count as
    /// done.
    CellFinished {
        /// The cell.
        cell: &'a Cell,
        /// Frames done so far.
        done: u64,
    },
}

/// One tracker on one sequence.
#[derive(Debug, Clone)]
pub struct Cell {
    /// Sequence name.
    pub sequence: String,
    /// Tracker name.
    pub tracker: &'static str,
    /// The scores, or why there are none.
    pub outcome: Result<CellScore, CellError>,
}

/// Why a cell has no scores.
///
/// A tracker that refuses the first frame's channel count
/// ([`TrackerError::Channels`] on frame 1, e.g. the skin-colour
/// `condensation-*` trackers on a gray sequence such as David) cannot run
/// on that input by design: the cell is [`CellError::NotApplicable`],
/// shown as `n/a (needs colour)`, and does not fail the run, since no fix
/// to the tracker or the data is wanted. Every other error (a bad frame,
/// a tracker error on a later frame, including a channel count that
/// changes mid-sequence, an output that cannot be written) is
/// [`CellError::Failed`]: something that should have worked did not.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum CellError {
    /// The tracker cannot run on this input by design.
    NotApplicable {
        /// What the tracker needs, e.g. `needs colour`.
        needs: String,
        /// The tracker's error.
        message: String,
    },
    /// A real failure.
    Failed(String),
}

impl std::fmt::Display for CellError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotApplicable { needs, message } => write!(f, "n/a ({needs}): {message}"),
            Self::Failed(message) => f.write_str(message),
        }
    }
}

impl CellError {
    /// Whether this is a real failure (not [`CellError::NotApplicable`]).
    pub fn is_failure(&self) -> bool {
        matches!(self, Self::Failed(_))
    }

    /// The short label of a table cell: `n/a (...)` or `failed`.
    pub fn label(&self) -> String {
        match self {
            Self::NotApplicable { needs, .. } => format!("n/a ({needs})"),
            Self::Failed(_) => "failed".into(),
        }
    }

    /// Classifies a tracking error (see the type's documentation).
    fn from_track(e: OtbError) -> Self {
        if let OtbError::Tracker {
            frame: 1, source, ..
        } = &e
            && let TrackerError::Channels { expected, .. } = source.as_ref()
        {
            // `expected` may carry an explanation: "3 (RGB: the skin cue ...)"
            let needs = if expected.starts_with('3') {
                "needs colour".to_string()
            } else {
                format!("needs {expected} channels")
            };
            return Self::NotApplicable {
                needs,
                message: e.to_string(),
            };
        }
        Self::Failed(e.to_string())
    }
}

/// Scores of a finished run.
#[derive(Debug, Clone)]
pub struct CellScore {
    /// OTB scores on the labelled frames.
    pub score: OtbScore,
    /// Frames per second of tracker time.
    pub fps: f64,
    /// Frames on which the tracker said it lost the target.
    pub lost_frames: usize,
}

impl Cell {
    /// One line for a log: the sequence, the tracker and its success rate
    /// at IoU 0.5, AUC, P@20 and fps, or why it has none.
    pub fn summary(&self) -> String {
        let (seq, tracker) = (&self.sequence, self.tracker);
        match &self.outcome {
            Ok(c) => format!(
                "{seq:<12} {tracker:<20} SR@0.5 {:.3}  AUC {:.3}  P@20 {:.3}  {:>8.0} fps",
                c.score.success_rate_50, c.score.auc, c.score.precision_20, c.fps
            ),
            Err(e @ CellError::Failed(_)) => format!("{seq:<12} {tracker:<20} failed: {e}"),
            Err(e) => format!("{seq:<12} {tracker:<20} {e}"),
        }
    }
}

/// A tracker's mean scores over the sequences it finished
/// ([`SuiteReport::mean`]): each sequence counts once, whatever its length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanScore {
    /// Mean success rate at IoU 0.5.
    pub success_rate_50: f64,
    /// Mean area under the success curve.
    pub auc: f64,
    /// Mean precision at 20 px.
    pub precision_20: f64,
    /// Mean fps.
    pub fps: f64,
    /// Number of sequences finished.
    pub sequences: usize,
}

impl std::fmt::Display for MeanScore {
    /// `SR@0.5 / AUC / P@20 / fps`, as the suite's table prints a cell.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.3} / {:.3} / {:.3} / {:.0}",
            self.success_rate_50, self.auc, self.precision_20, self.fps
        )
    }
}

/// Everything a suite run measured.
#[derive(Debug, Clone)]
pub struct SuiteReport {
    /// Sequence names, in order.
    pub sequences: Vec<String>,
    /// Frames of each sequence, in the order of `sequences` (0 for a
    /// sequence that could not be opened).
    pub frames: Vec<usize>,
    /// The published results the report sets ours beside, if given.
    pub published: Option<Published>,
    /// Tracker names, in order.
    pub trackers: Vec<&'static str>,
    /// One cell per (sequence, tracker), sequence-major.
    pub cells: Vec<Cell>,
}

/// Runs every tracker of `options` on every sequence under `root`,
/// printing [`Cell::summary`] on stderr as cells finish when
/// `options.progress` is set.
///
/// # Errors
/// [`OtbError::Write`] when an output file cannot be written;
/// [`OtbError::NoSequences`] when `root` holds no sequence or cannot
/// be listed. Failures of a tracker or of a sequence's frames are not
/// errors of the run: they fill the affected cells.
pub fn run_suite(root: &Path, options: &SuiteOptions) -> Result<SuiteReport, OtbError> {
    run_suite_with(root, options, |event| {
        if let (true, SuiteEvent::CellFinished { cell, .. }) = (options.progress, event) {
            eprintln!("{}", cell.summary());
        }
    })
}

/// Runs the suite as [`run_suite`] does, handing `observe` every
/// [`SuiteEvent`] (and printing nothing itself).
///
/// # Errors
/// As [`run_suite`].
pub fn run_suite_with(
    root: &Path,
    options: &SuiteOptions,
    mut observe: impl FnMut(SuiteEvent<'_>),
) -> Result<SuiteReport, OtbError> {
    let bad_root = |reason: String| OtbError::NoSequences {
        root: root.to_path_buf(),
        reason,
    };
    let dirs = list_sequences(root).map_err(|e| bad_root(e.to_string()))?;
    if dirs.is_empty() {
        return Err(bad_root(
            "no sequence folder with an img/ sub-folder".into(),
        ));
    }
    let mut report = SuiteReport {
        sequences: Vec::new(),
        frames: Vec::new(),
        published: options.published.clone(),
        trackers: options.trackers.iter().map(|t| t.name).collect(),
        cells: Vec::new(),
    };
    let out = &options.out;
    let shard = options.shard;
    match shard {
        None => mark_partial(out, "the OTB one-pass suite (`cargo xtask otb`)")?,
        Some(s) => mark_partial(
            out,
            &format!("shard {s} of the OTB one-pass suite (`cargo xtask otb --shard {s}`)"),
        )?,
    }
    let (cells, shard_cells) = match shard {
        None => (Some(PartialCsv::create(&out.join("results.csv"))?), None),
        Some(_) => (None, Some(PartialCsv::create(&out.join(SHARD_FILE))?)),
    };
    let mut shard_rows = Vec::new();
    let n_trackers = options.trackers.len();
    let total_cells = dirs.len() * n_trackers;
    let mine = |cell: usize| shard.is_none_or(|s| s.contains(cell));
    // listing the frames is cheap: it gives the total work for the progress
    // display before any frame is decoded
    let opened: Vec<Result<Sequence, OtbError>> = dirs.iter().map(Sequence::open).collect();
    let lengths: Vec<usize> = opened
        .iter()
        .map(|s| s.as_ref().map_or(0, Sequence::len))
        .collect();
    let cells_of = |s: usize| (0..n_trackers).filter(|t| mine(s * n_trackers + t)).count();
    observe(SuiteEvent::Start {
        sequences: dirs.len(),
        trackers: n_trackers,
        total: (0..dirs.len())
            .map(|s| (lengths[s] * cells_of(s)) as u64)
            .sum(),
    });
    let mut done = 0u64;
    for (s, ((dir, opened), len)) in dirs.iter().zip(opened).zip(lengths).enumerate() {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        report.sequences.push(name.clone());
        report.frames.push(len);
        if shard.is_some() && cells_of(s) == 0 {
            continue;
        }
        // Frames are decoded one at a time inside each cell (streamed, as
        // the CLI does): memory does not grow with the sequence's length.
        observe(SuiteEvent::Decoding { sequence: &name });
        let loaded = opened;
        for (t, info) in options.trackers.iter().enumerate() {
            let index = s * n_trackers + t;
            if !mine(index) {
                continue;
            }
            observe(SuiteEvent::CellStarted {
                sequence: &name,
                tracker: info.name,
                frames: len,
            });
            let outcome = match &loaded {
                Ok(seq) => run_cell(info, seq, options, &mut |k| {
                    observe(SuiteEvent::Frame {
                        done: done + k as u64,
                    })
                }),
                Err(e) => Err(CellError::Failed(e.to_string())),
            };
            done += len as u64;
            let (outcome, boxes) = match outcome {
                Ok((score, boxes)) => (Ok(score), Some(boxes)),
                Err(e) => (Err(e), None),
            };
            let cell = Cell {
                sequence: name.clone(),
                tracker: info.name,
                outcome,
            };
            observe(SuiteEvent::CellFinished { cell: &cell, done });
            if let Some(cells) = &cells {
                cells.append(&[ResultRow::of(&cell)])?;
            }
            if let (Some(shard_cells), Some(shard)) = (&shard_cells, shard) {
                if let (Some(boxes), Ok(seq)) = (&boxes, &loaded) {
                    write_scores(
                        &scores_path(out, info.name, &name),
                        boxes,
                        &seq.ground_truth,
                    )?;
                }
                let row = shard_row(
                    &cell,
                    index,
                    shard,
                    total_cells,
                    n_trackers,
                    options.seed,
                    len,
                );
                shard_cells.append(std::slice::from_ref(&row))?;
                shard_rows.push(row);
            }
            report.cells.push(cell);
        }
    }
    if let Some(cells) = cells {
        cells.finish(&report.rows())?;
        report.write_summary(out)?;
    }
    if let Some(shard_cells) = shard_cells {
        shard_cells.finish(&shard_rows)?;
    }
    clear_partial(out)?;
    Ok(report)
}

/// The row of [`SHARD_FILE`] for `cell`, the suite's cell `index`.
fn shard_row(
    cell: &Cell,
    index: usize,
    shard: Shard,
    cells: usize,
    trackers: usize,
    seed: u64,
    frames: usize,
) -> ShardRow {
    let mut row = ShardRow {
        cell: index,
        shard: shard.to_string(),
        cells,
        trackers,
        seed,
        sequence: cell.sequence.clone(),
        frames,
        tracker: cell.tracker.to_string(),
        outcome: "ok".into(),
        needs: String::new(),
        error: String::new(),
        fps: None,
        lost_frames: None,
    };
    match &cell.outcome {
        Ok(c) => {
            row.fps = Some(c.fps);
            row.lost_frames = Some(c.lost_frames);
        }
        Err(CellError::NotApplicable { needs, message }) => {
            row.outcome = "n/a".into();
            row.needs.clone_from(needs);
            row.error.clone_from(message);
        }
        Err(CellError::Failed(message)) => {
            row.outcome = "failed".into();
            row.error.clone_from(message);
        }
    }
    row
}

/// Combines the folders of the shards of one suite run
/// ([`SuiteOptions::shard`], `cargo xtask otb --shard K/N`) into `out`:
/// exactly the files a single run of every cell writes there, byte for
/// byte (`results.csv`, `results.md`, the plots, `boxes/`), given the same
/// `published` results. Every shard folder is read and checked before
/// anything is written; `out` is marked `PARTIAL.txt` while the files are
/// written, and each is replaced whole, so a merge that fails keeps the
/// earlier results.
///
/// # Errors
/// [`OtbError::Merge`] for a shard folder still marked `PARTIAL.txt`, a
/// shard missing or given twice, folders of different runs (another
/// number of shards, other trackers or sequences, another seed), a tracker
/// not in the registry; [`OtbError::Read`] / [`OtbError::Row`] for a shard
/// file that cannot be read (naming the file and line);
/// [`OtbError::Write`] for an output that cannot be written.
pub fn merge(
    shards: &[PathBuf],
    out: &Path,
    published: Option<Published>,
) -> Result<SuiteReport, OtbError> {
    let (report, owners) = merged_report(shards, out, published)?;
    mark_partial(
        out,
        "merging the shards of the OTB one-pass suite (`cargo xtask otb --merge`)",
    )?;
    for (cell, dir) in report.cells.iter().zip(&owners) {
        let from = dir.join("boxes").join(cell.tracker);
        let to = out.join("boxes").join(cell.tracker);
        if from.is_dir() {
            create_dir(&to)?;
        }
        let boxes = format!("{}.txt", cell.sequence);
        for file in [PathBuf::from(&boxes), partial_path(Path::new(&boxes))] {
            if from.join(&file).is_file() {
                copy_file(&from.join(&file), &to.join(&file))?;
            }
        }
    }
    // a single run leaves no partial results behind it
    let stale = partial_path(&out.join("results.csv"));
    match std::fs::remove_file(&stale) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(WriteError::new(&stale, e).into());
        }
        _ => {}
    }
    report.write(out)?;
    clear_partial(out)?;
    Ok(report)
}

/// The report the shards in `shards` make together, with the folder each
/// cell comes from.
fn merged_report(
    shards: &[PathBuf],
    out: &Path,
    published: Option<Published>,
) -> Result<(SuiteReport, Vec<PathBuf>), OtbError> {
    let merge_error = |path: &Path, reason: String| OtbError::Merge {
        path: path.to_path_buf(),
        reason,
    };
    // (N, cells, trackers, seed) of the run, and the file that said so first
    let mut run: Option<((usize, usize, usize, u64), PathBuf)> = None;
    let mut folders: Vec<(Shard, &PathBuf)> = Vec::new();
    let mut rows: Vec<(usize, PathBuf, ShardRow)> = Vec::new();
    for dir in shards {
        let file = dir.join(SHARD_FILE);
        let mut this: Option<Shard> = None;
        for (line, row) in read_shard(dir)? {
            let bad = |message: String| OtbError::Row {
                path: file.clone(),
                line,
                message,
            };
            let shard = Shard::parse(&row.shard).map_err(|e| bad(e.to_string()))?;
            match this {
                Some(s) if s != shard => {
                    return Err(bad(format!(
                        "a cell of shard {shard} among those of shard {s}"
                    )));
                }
                _ => this = Some(shard),
            }
            let key = (shard.count(), row.cells, row.trackers, row.seed);
            match &run {
                None => run = Some((key, file.clone())),
                Some((first, said)) if *first != key => {
                    return Err(merge_error(
                        dir,
                        format!(
                            "it is from another suite run than {}: {} shards, {} cells of {} trackers, \
                             seed {} against {} shards, {} cells of {} trackers, seed {}",
                            said.display(),
                            key.0,
                            key.1,
                            key.2,
                            key.3,
                            first.0,
                            first.1,
                            first.2,
                            first.3
                        ),
                    ));
                }
                Some(_) => {}
            }
            if row.trackers == 0 || row.cells % row.trackers != 0 {
                return Err(bad(format!(
                    "{} cells is not a whole number of sequences of {} trackers",
                    row.cells, row.trackers
                )));
            }
            if row.cell >= row.cells || !shard.contains(row.cell) {
                return Err(bad(format!(
                    "cell {} is not one of shard {shard}'s (of {} cells)",
                    row.cell, row.cells
                )));
            }
            rows.push((line, file.clone(), row));
        }
        if let Some(shard) = this {
            if let Some((_, other)) = folders.iter().find(|(s, _)| *s == shard) {
                return Err(merge_error(
                    dir,
                    format!("it holds shard {shard}, and so does {}", other.display()),
                ));
            }
            folders.push((shard, dir));
        }
    }
    let Some(((count, total, n_trackers, _), _)) = run else {
        return Err(merge_error(
            out,
            "the shard folders given hold no finished cell".into(),
        ));
    };
    let mut by_cell: Vec<Option<(usize, PathBuf, ShardRow)>> = vec![None; total];
    for (line, file, row) in rows {
        let cell = row.cell;
        if let Some((first, _, _)) = &by_cell[cell] {
            return Err(OtbError::Row {
                path: file,
                line,
                message: format!("cell {cell} again (first on line {first})"),
            });
        }
        by_cell[cell] = Some((line, file, row));
    }
    let missing: Vec<usize> = (0..total).filter(|&i| by_cell[i].is_none()).collect();
    if !missing.is_empty() {
        let mut absent: Vec<usize> = missing.iter().map(|&i| Shard::of_cell(i, count)).collect();
        absent.sort_unstable();
        absent.dedup();
        let absent: Vec<String> = absent.iter().map(|k| format!("{k}/{count}")).collect();
        return Err(merge_error(
            out,
            format!(
                "{} of {total} cells have no shard folder: give the folders of shard(s) {}",
                missing.len(),
                absent.join(", ")
            ),
        ));
    }
    let rows: Vec<(usize, PathBuf, ShardRow)> = by_cell.into_iter().flatten().collect();
    let mut report = SuiteReport {
        sequences: Vec::new(),
        frames: Vec::new(),
        published,
        trackers: Vec::new(),
        cells: Vec::with_capacity(total),
    };
    let mut owners = Vec::with_capacity(total);
    for (index, (line, file, row)) in rows.into_iter().enumerate() {
        let bad = |message: String| OtbError::Row {
            path: file.clone(),
            line,
            message,
        };
        let (s, t) = (index / n_trackers, index % n_trackers);
        if t == 0 {
            report.sequences.push(row.sequence.clone());
            report.frames.push(row.frames);
        } else if (report.sequences[s].as_str(), report.frames[s]) != (&row.sequence, row.frames) {
            return Err(bad(format!(
                "sequence {} ({} frames) where the other shards have {} ({} frames)",
                row.sequence, row.frames, report.sequences[s], report.frames[s]
            )));
        }
        if s == 0 {
            let info = bayestrack_trackers::tracker_info(&row.tracker)
                .map_err(|e| bad(format!("tracker {}: {e}", row.tracker)))?;
            report.trackers.push(info.name);
        } else if report.trackers[t] != row.tracker {
            return Err(bad(format!(
                "tracker {} where the other shards have {}",
                row.tracker, report.trackers[t]
            )));
        }
        let dir = file.parent().map_or_else(PathBuf::new, Path::to_path_buf);
        let outcome = match row.outcome.as_str() {
            "ok" => {
                let scores = scores_path(&dir, &row.tracker, &row.sequence);
                let (boxes, truth) = read_scores(&scores)?;
                let score = score_otb(&boxes, &truth)
                    .map_err(|e| merge_error(&scores, format!("its boxes do not score: {e}")))?;
                Ok(CellScore {
                    score,
                    fps: row
                        .fps
                        .ok_or_else(|| bad("a cell that ran without fps".into()))?,
                    lost_frames: row
                        .lost_frames
                        .ok_or_else(|| bad("a cell that ran without lost_frames".into()))?,
                })
            }
            "n/a" => Err(CellError::NotApplicable {
                needs: row.needs,
                message: row.error,
            }),
            "failed" => Err(CellError::Failed(row.error)),
            other => {
                return Err(bad(format!(
                    "outcome {other:?}: expected ok, n/a or failed"
                )));
            }
        };
        report.cells.push(Cell {
            sequence: report.sequences[s].clone(),
            tracker: report.trackers[t],
            outcome,
        });
        owners.push(dir);
    }
    Ok((report, owners))
}

/// One row of `results.csv`: one tracker on one sequence, every number at
/// full precision; a cell that failed has empty scores and its error.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ResultRow {
    /// Sequence (folder) name.
    pub sequence: String,
    /// Tracker name.
    pub tracker: &'static str,
    /// Share of scored frames with IoU > 0.5.
    pub success_rate_50: Option<f64>,
    /// Area under the success curve.
    pub auc: Option<f64>,
    /// Share of scored frames with a centre error of at most 20 px.
    pub precision_20: Option<f64>,
    /// Mean IoU over scored frames.
    pub mean_iou: Option<f64>,
    /// The benchmark's overlap score: mean IoU over frames with IoU > 0.
    pub mean_overlap_of_frames_with_overlap: Option<f64>,
    /// Mean centre error (pixels).
    pub mean_center_error: Option<f64>,
    /// Frames per second of the tracker's own calls.
    pub fps: Option<f64>,
    /// Frames with ground truth.
    pub frames_scored: Option<usize>,
    /// Frames the tracker reported lost.
    pub lost_frames: Option<usize>,
    /// Why the cell failed (empty when it ran).
    pub error: String,
}

impl ResultRow {
    fn of(c: &Cell) -> Self {
        let mut row = Self {
            sequence: c.sequence.clone(),
            tracker: c.tracker,
            success_rate_50: None,
            auc: None,
            precision_20: None,
            mean_iou: None,
            mean_overlap_of_frames_with_overlap: None,
            mean_center_error: None,
            fps: None,
            frames_scored: None,
            lost_frames: None,
            error: String::new(),
        };
        match &c.outcome {
            Ok(s) => {
                row.success_rate_50 = Some(s.score.success_rate_50);
                row.auc = Some(s.score.auc);
                row.precision_20 = Some(s.score.precision_20);
                row.mean_iou = Some(s.score.mean_overlap);
                row.mean_overlap_of_frames_with_overlap =
                    s.score.mean_overlap_of_frames_with_overlap;
                row.mean_center_error = Some(s.score.mean_center_error);
                row.fps = Some(s.fps);
                row.frames_scored = Some(s.score.frames_scored);
                row.lost_frames = Some(s.lost_frames);
            }
            Err(e) => row.error = e.to_string(),
        }
        row
    }
}

/// Runs one tracker on one sequence, its frames decoded one at a time
/// (and given the first frame's channel count, as `bayestrack track` does);
/// `on_frame(k)` after the `k`-th frame's box (1-based) is written. The
/// scores come with the boxes they were computed from.
fn run_cell(
    info: &TrackerInfo,
    seq: &Sequence,
    options: &SuiteOptions,
    on_frame: &mut dyn FnMut(usize),
) -> Result<(CellScore, Vec<BBox>), CellError> {
    let init = seq
        .initial_box()
        .ok_or_else(|| CellError::Failed(format!("{}: frame 1 is unlabelled", seq.name)))?;
    let dir = options.out.join("boxes").join(info.name);
    std::fs::create_dir_all(&dir)
        .map_err(|e| CellError::Failed(format!("cannot create {}: {e}", dir.display())))?;
    // the boxes go to a partial file, renamed over the previous one only
    // when the cell has finished
    let boxes = dir.join(format!("{}.txt", seq.name));
    let partial = crate::write::partial_path(&boxes);
    let mut file = BoxFile::create(&partial).map_err(|e| CellError::Failed(e.to_string()))?;
    let mut tracker = info
        .build_with(options.seed, &options.set)
        .map_err(|e| CellError::Failed(e.to_string()))?;
    let mut run = track_source(
        tracker.as_mut(),
        &mut seq.source(),
        init,
        OnBadFrame::Stop,
        |f| {
            file.write(&f.bbox)?;
            on_frame(f.index + 1);
            Ok(())
        },
    )
    .map_err(|e| {
        let e = CellError::from_track(e);
        if !e.is_failure() {
            // nothing to keep: the tracker cannot run on this sequence
            drop(std::fs::remove_file(&partial));
        }
        e
    })?;
    drop(file);
    std::fs::rename(&partial, &boxes).map_err(|e| {
        CellError::Failed(format!(
            "cannot rename {} to {}: {e}",
            partial.display(),
            boxes.display()
        ))
    })?;
    let score =
        score_otb(&run.boxes, &seq.ground_truth).map_err(|e| CellError::Failed(e.to_string()))?;
    if let Timing::PerCall(seconds) = options.timing {
        run.tracker_seconds = (run.frames_run - run.skipped_count) as f64 * seconds;
    }
    let score = CellScore {
        score,
        fps: run.fps(),
        lost_frames: run.lost_frames,
    };
    Ok((score, run.boxes))
}

impl SuiteReport {
    /// The cell of `tracker` on `sequence`.
    pub fn cell(&self, sequence: &str, tracker: &str) -> Option<&Cell> {
        self.cells
            .iter()
            .find(|c| c.sequence == sequence && c.tracker == tracker)
    }

    /// The cells that failed for real (not the
    /// [`CellError::NotApplicable`] ones), in run order.
    pub fn failures(&self) -> Vec<&Cell> {
        self.cells
            .iter()
            .filter(|c| c.outcome.as_ref().is_err_and(CellError::is_failure))
            .collect()
    }

    /// Mean scores of `tracker` over the sequences it finished (`None` if
    /// it finished none).
    pub fn mean(&self, tracker: &str) -> Option<MeanScore> {
        let done: Vec<&CellScore> = self
            .cells
            .iter()
            .filter(|c| c.tracker == tracker)
            .filter_map(|c| c.outcome.as_ref().ok())
            .collect();
        if done.is_empty() {
            return None;
        }
        let n = done.len() as f64;
        let avg = |f: fn(&CellScore) -> f64| done.iter().map(|c| f(c)).sum::<f64>() / n;
        Some(MeanScore {
            success_rate_50: avg(|c| c.score.success_rate_50),
            auc: avg(|c| c.score.auc),
            precision_20: avg(|c| c.score.precision_20),
            fps: avg(|c| c.fps),
            sequences: done.len(),
        })
    }

    /// One row per tracker: `SR@0.5 / AUC / P@20 / fps` per sequence, then
    /// the mean over sequences.
    pub fn table(&self) -> Table {
        let mut header = vec!["tracker"];
        header.extend(self.sequences.iter().map(String::as_str));
        header.push("mean");
        let mut t = Table::new(
            "OTB one-pass evaluation: SR@0.5 / AUC / P@20 / fps",
            &header,
        );
        for &tracker in &self.trackers {
            let mut row = vec![tracker.to_string()];
            for seq in &self.sequences {
                row.push(match self.cell(seq, tracker).map(|c| &c.outcome) {
                    Some(Ok(c)) => format!(
                        "{:.3} / {:.3} / {:.3} / {:.0}",
                        c.score.success_rate_50, c.score.auc, c.score.precision_20, c.fps
                    ),
                    Some(Err(e)) => e.label(),
                    None => "failed".into(),
                });
            }
            row.push(match self.mean(tracker) {
                Some(m) if m.sequences == self.sequences.len() => m.to_string(),
                Some(m) => format!("{m} ({} seq.)", m.sequences),
                None if self.failures().iter().any(|c| c.tracker == tracker) => "failed".into(),
                // every cell of the tracker is n/a
                None => "n/a".into(),
            });
            t.push(row);
        }
        t
    }

    /// The rows of `results.csv`, one per tracker x sequence cell.
    pub fn rows(&self) -> Vec<ResultRow> {
        self.cells.iter().map(ResultRow::of).collect()
    }

    /// The sequences we ran that have published results, with whether the
    /// published numbers are for the frames of our copy.
    fn compared(&self) -> Vec<(&str, bool)> {
        let Some(published) = &self.published else {
            return Vec::new();
        };
        self.sequences
            .iter()
            .zip(&self.frames)
            .filter(|(s, _)| published.results.has_sequence(s))
            .map(|(s, &n)| (s.as_str(), published.same_frames(s, n)))
            .collect()
    }

    /// The sequences with published results for the frames of our copies.
    pub fn same_frame_sequences(&self) -> Vec<&str> {
        self.compared()
            .into_iter()
            .filter_map(|(s, same)| same.then_some(s))
            .collect()
    }

    /// Our trackers beside the published ones: one row per tracker, ours
    /// (`SR@0.5 / AUC / P@20`, marked `(ours)`) and published (`SR@0.5`),
    /// one column per sequence both ran (headed `(other frames)` where the
    /// published numbers are not for our copy's frames), then the mean over
    /// the sequences with the same frames, by which the rows are sorted
    /// (ours first on ties; rows without that mean last). `None` without
    /// published results or when no sequence we ran has any.
    pub fn beside_published(&self) -> Option<Table> {
        let published = self.published.as_ref()?;
        let compared = self.compared();
        if compared.is_empty() {
            return None;
        }
        let same = self.same_frame_sequences();
        let mut header: Vec<String> = vec!["tracker".into()];
        for &(s, same) in &compared {
            header.push(if same {
                s.to_string()
            } else {
                format!("{s} (other frames)")
            });
        }
        if !same.is_empty() {
            header.push(format!("mean over {}", same.join(", ")));
        }
        let mut rows: Vec<(Option<f64>, Vec<String>)> = Vec::new();
        for &tracker in &self.trackers {
            let mut row = vec![format!("{tracker} (ours)")];
            for &(s, _) in &compared {
                row.push(match self.cell(s, tracker).map(|c| &c.outcome) {
                    Some(Ok(c)) => format!(
                        "{:.3} / {:.3} / {:.3}",
                        c.score.success_rate_50, c.score.auc, c.score.precision_20
                    ),
                    Some(Err(e)) => e.label(),
                    None => "failed".into(),
                });
            }
            let done: Vec<&OtbScore> = same
                .iter()
                .filter_map(|s| self.cell(s, tracker)?.outcome.as_ref().ok())
                .map(|c| &c.score)
                .collect();
            let mut key = None;
            if !same.is_empty() {
                row.push(if done.is_empty() {
                    "-".into()
                } else {
                    let n = done.len() as f64;
                    let mean = |f: fn(&OtbScore) -> f64| done.iter().map(|s| f(s)).sum::<f64>() / n;
                    let sr = mean(|s| s.success_rate_50);
                    let text = format!(
                        "{sr:.3} / {:.3} / {:.3}",
                        mean(|s| s.auc),
                        mean(|s| s.precision_20)
                    );
                    if done.len() == same.len() {
                        key = Some(sr);
                        text
                    } else {
                        format!("{text} ({} of {} seq.)", done.len(), same.len())
                    }
                });
            }
            rows.push((key, row));
        }
        for tracker in published.results.trackers() {
            let mut row = vec![tracker.clone()];
            for &(s, _) in &compared {
                row.push(
                    published
                        .results
                        .score(tracker, s)
                        .map_or_else(|| "-".into(), |p| format!("{:.3}", p.success_rate_50)),
                );
            }
            let key = published.results.mean_success_rate(tracker, &same);
            if !same.is_empty() {
                row.push(key.map_or_else(|| "-".into(), |m| format!("{m:.3}")));
            }
            rows.push((key, row));
        }
        // stable: ours (pushed first) stay first on ties
        rows.sort_by(|a, b| match (a.0, b.0) {
            (Some(x), Some(y)) => y.total_cmp(&x),
            (Some(_), None) => std::cmp::Ordering::Less,
            (None, Some(_)) => std::cmp::Ordering::Greater,
            (None, None) => std::cmp::Ordering::Equal,
        });
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut t = Table::new(
            format!(
                "Beside the {} published OTB trackers: success rate at IoU 0.5 \
                 (ours: SR@0.5 / AUC / P@20)",
                published.results.trackers().len()
            ),
            &header,
        );
        for (_, row) in rows {
            t.push(row);
        }
        Some(t)
    }

    /// What the comparison with the published results rests on, one line
    /// per sequence we ran: the frames of our copy against the benchmark's
    /// range, or that the sequence has no published results; or why there
    /// is no comparison at all.
    pub fn published_notes(&self) -> Vec<String> {
        let Some(published) = &self.published else {
            return vec!["no published results given: ours alone".into()];
        };
        let mut notes = vec![format!(
            "published: {} trackers x {} sequences from {} (the benchmark's \
             one-pass results; its success rate counts IoU >= 0.5, ours IoU > 0.5: \
             they differ only on frames at exactly 0.5)",
            published.results.trackers().len(),
            published.results.sequences().len(),
            published.dir.display()
        )];
        for (s, &n) in self.sequences.iter().zip(&self.frames) {
            let range = published.ranges.get(s);
            notes.push(match (published.results.has_sequence(s), range) {
                (false, _) => format!("{s}: no published results"),
                (true, None) => format!("{s}: no frame range in the OTB table: not compared"),
                (true, Some(r)) if r.len() == n => format!(
                    "{s}: ours {n} frames, the benchmark's frames {}-{}: the same frames",
                    r.start_frame, r.end_frame
                ),
                (true, Some(r)) => format!(
                    "{s}: ours {n} frames, the benchmark's frames {}-{} ({}): other \
                     frames, the published numbers are not for our copy (shown, not in the mean)",
                    r.start_frame,
                    r.end_frame,
                    r.len()
                ),
            });
        }
        notes
    }

    /// Reference marks of the published success rates at IoU 0.5 on
    /// `sequences` (each tracker's mean over them); the best three are
    /// labelled. Empty without published results or sequences.
    fn published_marks(&self, sequences: &[&str]) -> Marks {
        let Some(published) = &self.published else {
            return Marks::default();
        };
        if sequences.is_empty() {
            return Marks::default();
        }
        let mut rates: Vec<(f64, &str)> = published
            .results
            .trackers()
            .iter()
            .filter_map(|t| {
                Some((
                    published.results.mean_success_rate(t, sequences)?,
                    t.as_str(),
                ))
            })
            .collect();
        rates.sort_by(|a, b| b.0.total_cmp(&a.0));
        Marks {
            name: format!(
                "{} published trackers, success rate at IoU 0.5 ({})",
                rates.len(),
                sequences.join(", ")
            ),
            points: rates
                .iter()
                .enumerate()
                .map(|(i, &(r, t))| {
                    let label = (i < 3).then(|| format!("{t} {r:.3}"));
                    (SUCCESS_RATE_THRESHOLD, r, label)
                })
                .collect(),
        }
    }

    /// Success and precision curves of `tracker` over the cells `pick`
    /// selects, averaged; legend labels carry the AUC and P@20.
    fn curves(&self, tracker: &str, pick: impl Fn(&Cell) -> bool) -> Option<(Series, Series)> {
        let done: Vec<&CellScore> = self
            .cells
            .iter()
            .filter(|c| c.tracker == tracker && pick(c))
            .filter_map(|c| c.outcome.as_ref().ok())
            .collect();
        if done.is_empty() {
            return None;
        }
        let n = done.len() as f64;
        let success: Vec<(f64, f64)> = SUCCESS_THRESHOLDS
            .iter()
            .enumerate()
            .map(|(i, &t)| (t, done.iter().map(|c| c.score.success[i]).sum::<f64>() / n))
            .collect();
        let precision: Vec<(f64, f64)> = (0..=PRECISION_PLOT_MAX)
            .map(|d| {
                let p = done
                    .iter()
                    .map(|c| {
                        let errors: Vec<f64> =
                            c.score.center_errors.iter().flatten().copied().collect();
                        precision_at(&errors, d as f64)
                    })
                    .sum::<f64>()
                    / n;
                (d as f64, p)
            })
            .collect();
        let auc = success.iter().map(|p| p.1).sum::<f64>() / success.len() as f64;
        let p20 = precision[20].1;
        Some((
            Series {
                name: format!("{tracker} [{auc:.3}]"),
                points: success,
            },
            Series {
                name: format!("{tracker} [{p20:.3}]"),
                points: precision,
            },
        ))
    }

    fn plots(
        &self,
        out: &Path,
        label: &str,
        pick: impl Fn(&Cell) -> bool,
        marks: &Marks,
    ) -> Result<(), WriteError> {
        let (success, precision): (Vec<Series>, Vec<Series>) = self
            .trackers
            .iter()
            .filter_map(|t| self.curves(t, &pick))
            .unzip();
        line_chart_with_marks(
            &out.join(format!("success_{label}.svg")),
            &format!("Success plot, OPE, {label} [AUC]"),
            "overlap threshold",
            "success rate",
            &success,
            marks,
        )?;
        line_chart(
            &out.join(format!("precision_{label}.svg")),
            &format!("Precision plot, OPE, {label} [precision at 20 px]"),
            "location error threshold (px)",
            "precision",
            &precision,
        )
    }

    /// Writes `results.csv`, `results.md` and the plots under `out`.
    ///
    /// # Errors
    /// [`WriteError`] naming the file.
    pub fn write(&self, out: &Path) -> Result<(), WriteError> {
        create_dir(out)?;
        write_csv(&out.join("results.csv"), &self.rows())?;
        self.write_summary(out)
    }

    /// `results.md`: our table, then ours beside the published trackers
    /// and the notes on the frames compared.
    pub fn markdown(&self) -> String {
        let mut md = self.table().to_markdown();
        if let Some(t) = self.beside_published() {
            md.push('\n');
            md.push_str(&t.to_markdown());
        }
        md.push('\n');
        for note in self.published_notes() {
            md.push_str(&format!("- {note}\n"));
        }
        md
    }

    /// Writes `results.md` and the plots under `out`; the success plots of
    /// the sequences with the same frames as the published results, and
    /// the overall one, carry the published success rates at IoU 0.5 as
    /// marks (the overall marks: the mean over those sequences).
    fn write_summary(&self, out: &Path) -> Result<(), WriteError> {
        write_text(&out.join("results.md"), &self.markdown())?;
        let same = self.same_frame_sequences();
        for seq in &self.sequences {
            let marks = if same.contains(&seq.as_str()) {
                self.published_marks(&[seq])
            } else {
                Marks::default()
            };
            self.plots(out, seq, |c| &c.sequence == seq, &marks)?;
        }
        self.plots(out, "overall", |_| true, &self.published_marks(&same))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tracker_error(frame: usize, source: TrackerError) -> OtbError {
        OtbError::Tracker {
            tracker: "t",
            frame,
            path: PathBuf::from("0001.jpg"),
            source: Box::new(source),
        }
    }

    /// The table's cells are SR@0.5 / AUC / P@20 / fps, and the mean row
    /// averages each over the sequences (each sequence once).
    #[test]
    fn the_table_gives_sr_auc_precision_and_fps_and_their_means() {
        let gt = BBox::new(1.0, 1.0, 10.0, 10.0);
        let cell = |sequence: &str, boxes: &[BBox], fps: f64| Cell {
            sequence: sequence.into(),
            tracker: "t",
            outcome: Ok(CellScore {
                score: score_otb(boxes, &vec![Some(gt); boxes.len()]).unwrap(),
                fps,
                lost_frames: 0,
            }),
        };
        // a: IoUs 1 and 1/3 (SR 0.5); b: IoU 1 / 0.5 / 0 (SR 1/3)
        let a = cell("a", &[gt, BBox::new(6.0, 1.0, 10.0, 10.0)], 100.0);
        let b = cell(
            "b",
            &[
                gt,
                BBox::new(1.0, 1.0, 20.0, 10.0),
                BBox::new(40.0, 1.0, 10.0, 10.0),
            ],
            300.0,
        );
        let report = SuiteReport {
            sequences: vec!["a".into(), "b".into()],
            frames: vec![2, 3],
            published: None,
            trackers: vec!["t"],
            cells: vec![a, b],
        };
        let t = report.table();
        assert_eq!(
            t.title,
            "OTB one-pass evaluation: SR@0.5 / AUC / P@20 / fps"
        );
        let (sa, sb) = (1.0 / 2.0, 1.0 / 3.0);
        let auc_a = (20.0 + 7.0) / 42.0; // 1 passes 20 of the 21, 1/3 passes 7
        let auc_b = (20.0 + 10.0) / 63.0;
        assert_eq!(t.rows[0][1], format!("0.500 / {auc_a:.3} / 1.000 / 100"));
        assert_eq!(t.rows[0][2], format!("0.333 / {auc_b:.3} / 0.667 / 300"));
        let m = report.mean("t").unwrap();
        assert_eq!(m.success_rate_50, (sa + sb) / 2.0);
        assert!((m.auc - (auc_a + auc_b) / 2.0).abs() < 1e-12);
        assert_eq!((m.fps, m.sequences), (200.0, 2));
        assert_eq!(
            t.rows[0][3],
            format!("0.417 / {:.3} / 0.833 / 200", (auc_a + auc_b) / 2.0)
        );
    }

    #[test]
    fn a_colour_tracker_on_a_gray_sequence_is_not_a_failure() {
        let channels = || TrackerError::Channels {
            tracker: "t",
            expected: "3 (RGB)",
            got: 1,
        };
        let e = CellError::from_track(tracker_error(1, channels()));
        assert!(!e.is_failure());
        assert_eq!(e.label(), "n/a (needs colour)");
        assert!(e.to_string().starts_with("n/a (needs colour): "), "{e}");
        // the channel count changing mid-sequence is a real failure
        assert!(CellError::from_track(tracker_error(7, channels())).is_failure());
        assert!(CellError::from_track(tracker_error(1, TrackerError::NotInitialised)).is_failure());
        assert!(CellError::from_track(OtbError::NoFramesToTrack).is_failure());
    }

    /// A score whose success rate at 0.5 is `hits / frames` (IoU 1 on the
    /// hits, 0 elsewhere).
    fn score(hits: usize, frames: usize) -> CellScore {
        let t = BBox::new(1.0, 1.0, 10.0, 10.0);
        let far = BBox::new(100.0, 100.0, 10.0, 10.0);
        let pred: Vec<BBox> = (0..frames)
            .map(|i| if i < hits { t } else { far })
            .collect();
        CellScore {
            score: score_otb(&pred, &vec![Some(t); frames]).unwrap(),
            fps: 100.0,
            lost_frames: 0,
        }
    }

    fn published() -> Published {
        use crate::published::{OtbFrameRange, OtbFrameRanges, PublishedOpe};
        let results = PublishedOpe::parse(
            "tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap\n\
             IVT,Crossing,0.25,0.3\nIVT,David,0.8,0.6\nIVT,Couple,0.1,0.1\n\
             MIL,Crossing,0.95,0.7\nMIL,David,0.2,0.4\nMIL,Couple,0.6,0.5\n",
            Path::new("published_ope.csv"),
        )
        .unwrap();
        let ranges = OtbFrameRanges::from_ranges([
            OtbFrameRange::new("Crossing", 1, 4),
            OtbFrameRange::new("Couple", 1, 140),
            OtbFrameRange::new("David", 300, 770),
        ]);
        Published {
            dir: PathBuf::from("otb"),
            results,
            ranges,
        }
    }

    #[test]
    fn ours_beside_the_published_on_the_same_frames() {
        let cell = |sequence: &str, tracker, outcome| Cell {
            sequence: sequence.into(),
            tracker,
            outcome,
        };
        let mut report = SuiteReport {
            sequences: vec!["Crossing".into(), "David".into(), "Own".into()],
            frames: vec![4, 5, 4],
            published: Some(published()),
            trackers: vec!["a", "b"],
            cells: vec![
                cell("Crossing", "a", Ok(score(3, 4))),
                cell("Crossing", "b", Err(CellError::Failed("boom".into()))),
                cell("David", "a", Ok(score(5, 5))),
                cell("David", "b", Ok(score(1, 5))),
                cell("Own", "a", Ok(score(1, 4))),
                cell("Own", "b", Ok(score(1, 4))),
            ],
        };
        assert_eq!(report.same_frame_sequences(), ["Crossing"]);
        let t = report.beside_published().unwrap();
        assert_eq!(
            t.header,
            [
                "tracker",
                "Crossing",
                "David (other frames)",
                "mean over Crossing"
            ]
        );
        let rows: Vec<String> = t.rows.iter().map(|r| r.join(" | ")).collect();
        // sorted by the mean over the same-frame sequences (Crossing alone);
        // a: SR 3/4; AUC (20 * 3/4 + 0) / 21 = 0.714; P@20 3/4
        assert_eq!(
            rows,
            [
                "MIL | 0.950 | 0.200 | 0.950",
                "a (ours) | 0.750 / 0.714 / 0.750 | 1.000 / 0.952 / 1.000 | 0.750 / 0.714 / 0.750",
                "IVT | 0.250 | 0.800 | 0.250",
                "b (ours) | failed | 0.200 / 0.190 / 0.200 | -",
            ]
        );
        assert!(t.title.starts_with("Beside the 2 published OTB trackers"));
        let notes = report.published_notes();
        assert!(
            notes[1].starts_with("Crossing: ours 4 frames, the benchmark's frames 1-4: the same"),
            "{notes:?}"
        );
        assert!(
            notes[2].starts_with(
                "David: ours 5 frames, the benchmark's frames 300-770 (471): other frames"
            ),
            "{notes:?}"
        );
        assert_eq!(notes[3], "Own: no published results");
        let marks = report.published_marks(&["Crossing"]);
        let points: Vec<(f64, f64, Option<&str>)> = marks
            .points
            .iter()
            .map(|(x, y, l)| (*x, *y, l.as_deref()))
            .collect();
        assert_eq!(
            points,
            [
                (0.5, 0.95, Some("MIL 0.950")),
                (0.5, 0.25, Some("IVT 0.250"))
            ]
        );
        // without the published results: ours alone, said so
        report.published = None;
        assert!(report.beside_published().is_none());
        assert_eq!(
            report.published_notes(),
            ["no published results given: ours alone"]
        );
        assert!(report.published_marks(&["Crossing"]).points.is_empty());
        assert!(
            report
                .markdown()
                .contains("- no published results given: ours alone")
        );
    }

    #[test]
    fn failures_leave_out_the_cells_that_cannot_run() {
        let cell = |tracker, outcome| Cell {
            sequence: "David".into(),
            tracker,
            outcome,
        };
        let report = SuiteReport {
            sequences: vec!["David".into()],
            frames: vec![462],
            published: None,
            trackers: vec!["a", "b"],
            cells: vec![
                cell(
                    "a",
                    Err(CellError::NotApplicable {
                        needs: "needs colour".into(),
                        message: "m".into(),
                    }),
                ),
                cell("b", Err(CellError::Failed("boom".into()))),
            ],
        };
        let failed: Vec<&str> = report.failures().iter().map(|c| c.tracker).collect();
        assert_eq!(failed, ["b"]);
        let table = report.table().to_csv();
        assert!(table.contains("n/a (needs colour),n/a"), "{table}");
        assert!(table.contains("failed,failed"), "{table}");
    }
}
