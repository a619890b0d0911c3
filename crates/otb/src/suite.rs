//! The OTB one-pass evaluation behind `cargo xtask otb`: every tracker on
//! every sequence of a folder, initialised from frame 1's ground truth,
//! scored on the labelled frames.
//!
//! Each sequence is decoded once and shared by the trackers (fps counts only
//! the tracker's calls). Under the output folder the run writes, as it goes:
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

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use bayestrack_image::Image;
use bayestrack_trackers::{TrackerError, TrackerInfo};

use crate::metrics::{OtbScore, SUCCESS_THRESHOLDS, precision_at, score_otb};
use crate::plot::{Series, line_chart};
use crate::sequence::{OtbError, Sequence, list_sequences};
use crate::table::Table;
use crate::track::{BoxFile, OnBadFrame, TrackError, track_frames};
use crate::write::{PartialCsv, WriteError, clear_partial, create_dir, mark_partial, write_text};

/// Centre-error thresholds of the precision plot, px.
pub const PRECISION_PLOT_MAX: usize = 50;

/// Why a suite run could not produce its report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SuiteError {
    /// The root folder holds no sequence, or cannot be listed.
    #[error("no sequence to run in {root}: {reason}")]
    NoSequences {
        /// The folder asked for.
        root: PathBuf,
        /// Why nothing was found.
        reason: String,
    },
    /// An output file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// What to run and where to write.
#[derive(Debug, Clone)]
pub struct SuiteOptions {
    /// Trackers, in table order.
    pub trackers: Vec<&'static TrackerInfo>,
    /// Seed given to every tracker.
    pub seed: u64,
    /// Output folder.
    pub out: PathBuf,
    /// Print one line per tracker and sequence on stderr.
    pub progress: bool,
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
    fn from_track(e: TrackError) -> Self {
        if let TrackError::Tracker {
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

/// Everything a suite run measured.
#[derive(Debug, Clone)]
pub struct SuiteReport {
    /// Sequence names, in order.
    pub sequences: Vec<String>,
    /// Tracker names, in order.
    pub trackers: Vec<&'static str>,
    /// One cell per (sequence, tracker), sequence-major.
    pub cells: Vec<Cell>,
}

/// Runs every tracker of `options` on every sequence under `root`.
///
/// # Errors
/// [`SuiteError::Write`] when an output file cannot be written;
/// [`SuiteError::NoSequences`] when `root` holds no sequence or cannot
/// be listed. Failures of a tracker or of a sequence's frames are not
/// errors of the run: they fill the affected cells.
pub fn run_suite(root: &Path, options: &SuiteOptions) -> Result<SuiteReport, SuiteError> {
    let bad_root = |reason: String| SuiteError::NoSequences {
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
        trackers: options.trackers.iter().map(|t| t.name).collect(),
        cells: Vec::new(),
    };
    let out = &options.out;
    mark_partial(out, "the OTB one-pass suite (`cargo xtask otb`)")?;
    let cells = PartialCsv::create(&out.join("results.csv"), CSV_HEADER.join(",").as_str())?;
    for dir in &dirs {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let loaded = Sequence::open(dir).and_then(|seq| {
            let frames = (0..seq.len())
                .map(|i| seq.frame(i))
                .collect::<Result<Vec<_>, OtbError>>()?;
            Ok((seq, frames))
        });
        for info in &options.trackers {
            let outcome = match &loaded {
                Ok((seq, frames)) => run_cell(info, seq, frames, options),
                Err(e) => Err(CellError::Failed(e.to_string())),
            };
            if options.progress {
                match &outcome {
                    Ok(c) => eprintln!(
                        "{name:<12} {:<16} AUC {:.3}  P@20 {:.3}  {:>8.0} fps",
                        info.name, c.score.auc, c.score.precision_20, c.fps
                    ),
                    Err(e @ CellError::Failed(_)) => {
                        eprintln!("{name:<12} {:<16} failed: {e}", info.name)
                    }
                    Err(e) => eprintln!("{name:<12} {:<16} {e}", info.name),
                }
            }
            let cell = Cell {
                sequence: name.clone(),
                tracker: info.name,
                outcome,
            };
            let row = csv_table(std::slice::from_ref(&cell)).to_csv();
            cells.append(row.split_once('\n').map_or("", |(_, rows)| rows))?;
            report.cells.push(cell);
        }
        report.sequences.push(name);
    }
    cells.finish(&report.csv())?;
    report.write_summary(out)?;
    clear_partial(out)?;
    Ok(report)
}

/// The columns of `results.csv`.
const CSV_HEADER: [&str; 10] = [
    "sequence",
    "tracker",
    "auc",
    "precision_20",
    "mean_iou",
    "mean_center_error",
    "fps",
    "frames_scored",
    "lost_frames",
    "error",
];

/// The rows of `results.csv` for `cells`.
fn csv_table(cells: &[Cell]) -> Table {
    let mut t = Table::new("", &CSV_HEADER);
    for c in cells {
        let mut row = vec![c.sequence.clone(), c.tracker.to_string()];
        match &c.outcome {
            Ok(s) => {
                row.extend([
                    format!("{:.4}", s.score.auc),
                    format!("{:.4}", s.score.precision_20),
                    format!("{:.4}", s.score.mean_overlap),
                    format!("{:.2}", s.score.mean_center_error),
                    format!("{:.1}", s.fps),
                    s.score.frames_scored.to_string(),
                    s.lost_frames.to_string(),
                    String::new(),
                ]);
            }
            Err(e) => {
                row.extend(std::iter::repeat_n(String::new(), 7));
                row.push(e.to_string());
            }
        }
        t.push(row);
    }
    t
}

fn run_cell(
    info: &TrackerInfo,
    seq: &Sequence,
    frames: &[Image<u8>],
    options: &SuiteOptions,
) -> Result<CellScore, CellError> {
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
        .build(options.seed)
        .map_err(|e| CellError::Failed(e.to_string()))?;
    let run = track_frames(
        tracker.as_mut(),
        frames.len(),
        |i| Ok(Cow::Borrowed(&frames[i])),
        |i| seq.frames[i].clone(),
        init,
        OnBadFrame::Stop,
        |f| file.write(&f.bbox),
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
    Ok(CellScore {
        score,
        fps: run.fps(),
        lost_frames: run.lost_frames,
    })
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

    /// Mean AUC, P@20 and fps of `tracker` over the sequences it finished
    /// (`None` if it finished none), with the number finished.
    pub fn mean(&self, tracker: &str) -> Option<(f64, f64, f64, usize)> {
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
        Some((
            avg(|c| c.score.auc),
            avg(|c| c.score.precision_20),
            avg(|c| c.fps),
            done.len(),
        ))
    }

    /// One row per tracker: `AUC / P@20 / fps` per sequence, then the mean
    /// over sequences.
    pub fn table(&self) -> Table {
        let mut header = vec!["tracker"];
        header.extend(self.sequences.iter().map(String::as_str));
        header.push("mean");
        let mut t = Table::new("OTB one-pass evaluation: AUC / P@20 / fps", &header);
        for &tracker in &self.trackers {
            let mut row = vec![tracker.to_string()];
            for seq in &self.sequences {
                row.push(match self.cell(seq, tracker).map(|c| &c.outcome) {
                    Some(Ok(c)) => format!(
                        "{:.3} / {:.3} / {:.0}",
                        c.score.auc, c.score.precision_20, c.fps
                    ),
                    Some(Err(e)) => e.label(),
                    None => "failed".into(),
                });
            }
            row.push(match self.mean(tracker) {
                Some((auc, p, fps, n)) if n == self.sequences.len() => {
                    format!("{auc:.3} / {p:.3} / {fps:.0}")
                }
                Some((auc, p, fps, n)) => format!("{auc:.3} / {p:.3} / {fps:.0} ({n} seq.)"),
                None if self.failures().iter().any(|c| c.tracker == tracker) => "failed".into(),
                // every cell of the tracker is n/a
                None => "n/a".into(),
            });
            t.push(row);
        }
        t
    }

    fn csv(&self) -> String {
        csv_table(&self.cells).to_csv()
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
    ) -> Result<(), WriteError> {
        let (success, precision): (Vec<Series>, Vec<Series>) = self
            .trackers
            .iter()
            .filter_map(|t| self.curves(t, &pick))
            .unzip();
        line_chart(
            &out.join(format!("success_{label}.svg")),
            &format!("Success plot, OPE, {label} [AUC]"),
            "overlap threshold",
            "success rate",
            &success,
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
        write_text(&out.join("results.csv"), &self.csv())?;
        self.write_summary(out)
    }

    /// Writes `results.md` and the plots under `out`.
    fn write_summary(&self, out: &Path) -> Result<(), WriteError> {
        write_text(&out.join("results.md"), &self.table().to_markdown())?;
        for seq in &self.sequences {
            self.plots(out, seq, |c| &c.sequence == seq)?;
        }
        self.plots(out, "overall", |_| true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tracker_error(frame: usize, source: TrackerError) -> TrackError {
        TrackError::Tracker {
            tracker: "t",
            frame,
            path: PathBuf::from("0001.jpg"),
            source: Box::new(source),
        }
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
        assert!(CellError::from_track(TrackError::NoFrames).is_failure());
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
