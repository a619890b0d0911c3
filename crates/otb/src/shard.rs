//! The files of a shard of the OTB suite (`cargo xtask otb --shard K/N`):
//! which cells a shard runs ([`Shard`]), and what it leaves for the merge
//! ([`crate::suite::merge`]) besides its box files.
//!
//! The suite's cells are numbered sequence-major, as the report lists
//! them: cell `i` is sequence `i / T` with tracker `i % T` (`T` trackers,
//! sequences in name order). Shard `K` of `N` runs the cells with
//! `i % N == K - 1`: round robin, so every shard gets a share of the long
//! sequences and of the slow trackers. Each cell's tracker is seeded with
//! the run's seed alone, so a cell needs nothing from the others and runs
//! the same wherever it runs.
//!
//! A shard's folder holds, beside `boxes/<tracker>/<sequence>.txt` (as a
//! single run writes them):
//! - [`SHARD_FILE`] (`shard.csv`): one [`ShardRow`] per finished cell,
//!   appended to `shard.partial.csv` as cells finish and written whole at
//!   the end ([`crate::write::PartialCsv`]); while the shard runs the
//!   folder holds `PARTIAL.txt`, and the merge refuses such a folder.
//! - `scores/<tracker>/<sequence>.csv`: one [`ScoreRow`] per frame of a
//!   cell that ran (its box and the ground truth at full precision), from
//!   which the merge computes the cell's scores with the same
//!   [`crate::metrics::score_otb`] call as a single run: the same bits.
//!
//! This module knows nothing of the suite: the suite writes and reads
//! these files through it.

use std::fmt;
use std::path::{Path, PathBuf};

use bayestrack_image::BBox;

use crate::error::{OtbError, WriteError};
use crate::write::{PARTIAL_MARKER, write_csv};

/// The file of a shard's finished cells.
pub const SHARD_FILE: &str = "shard.csv";

/// The folder (in a shard's output) of the per-frame boxes and ground
/// truth of its cells.
pub const SCORES_DIR: &str = "scores";

/// Shard `index` of `count` (both 1-based: `K/N`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    index: usize,
    count: usize,
}

impl Shard {
    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`OtbError::Shard`] when `count` is 0 or `index` is outside
    /// `1..=count`.
    pub fn new(index: usize, count: usize) -> Result<Self, OtbError> {
        let bad = |reason: String| OtbError::Shard {
            spec: format!("{index}/{count}"),
            reason,
        };
        if count == 0 {
            return Err(bad("N, the number of shards, must be at least 1".into()));
        }
        if !(1..=count).contains(&index) {
            return Err(bad(format!(
                "K, the shard to run, must be 1 to {count} (shards are numbered from 1)"
            )));
        }
        Ok(Self { index, count })
    }

    /// Parses `K/N` (`2/3`: the second of three shards).
    ///
    /// # Errors
    /// [`OtbError::Shard`] for text that is not two whole numbers `K/N`
    /// with `1 <= K <= N`.
    pub fn parse(spec: &str) -> Result<Self, OtbError> {
        let number = |s: &str| s.trim().parse::<usize>().ok();
        match spec.split_once('/').map(|(k, n)| (number(k), number(n))) {
            Some((Some(k), Some(n))) => Self::new(k, n).map_err(|e| match e {
                OtbError::Shard { reason, .. } => OtbError::Shard {
                    spec: spec.to_string(),
                    reason,
                },
                other => other,
            }),
            _ => Err(OtbError::Shard {
                spec: spec.to_string(),
                reason: "expected K/N, two whole numbers: shard K of N (1 <= K <= N), e.g. 2/3"
                    .into(),
            }),
        }
    }

    /// The shard, 1-based (`K`).
    pub fn index(&self) -> usize {
        self.index
    }

    /// The number of shards (`N`).
    pub fn count(&self) -> usize {
        self.count
    }

    /// Whether cell `cell` (0-based, sequence-major) is this shard's:
    /// `cell % N == K - 1`.
    pub fn contains(&self, cell: usize) -> bool {
        cell % self.count == self.index - 1
    }

    /// The shard a cell belongs to among `count`.
    pub fn of_cell(cell: usize, count: usize) -> usize {
        cell % count.max(1) + 1
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// One finished cell of a shard, a row of [`SHARD_FILE`]: where it sits in
/// the whole suite and how it ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShardRow {
    /// The cell's number in the whole suite (0-based, sequence-major).
    pub cell: usize,
    /// The shard that ran it, `K/N`.
    pub shard: String,
    /// Cells in the whole suite.
    pub cells: usize,
    /// Trackers in the suite (cells per sequence).
    pub trackers: usize,
    /// The seed every tracker was given.
    pub seed: u64,
    /// Sequence (folder) name.
    pub sequence: String,
    /// Frames of the sequence (0 when it could not be opened).
    pub frames: usize,
    /// Tracker name.
    pub tracker: String,
    /// `ok`, `n/a` (cannot run on this input by design) or `failed`.
    pub outcome: String,
    /// What the tracker needs, for `n/a` (`needs colour`).
    pub needs: String,
    /// The error, for `n/a` and `failed`.
    pub error: String,
    /// Frames per second of the tracker's calls, for `ok`.
    pub fps: Option<f64>,
    /// Frames the tracker reported lost, for `ok`.
    pub lost_frames: Option<usize>,
}

/// One frame of a cell that ran: the box the tracker reported and the
/// ground truth, every number at full precision (a row of
/// `scores/<tracker>/<sequence>.csv`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScoreRow {
    /// 1-based frame.
    pub frame: usize,
    /// The box: left edge (OTB, 1-based).
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub width: f64,
    /// Height.
    pub height: f64,
    /// The ground truth's left edge (empty where unlabelled).
    pub truth_x: Option<f64>,
    /// Its top edge.
    pub truth_y: Option<f64>,
    /// Its width.
    pub truth_width: Option<f64>,
    /// Its height.
    pub truth_height: Option<f64>,
}

/// Where a shard keeps the per-frame boxes of `tracker` on `sequence`.
pub fn scores_path(dir: &Path, tracker: &str, sequence: &str) -> PathBuf {
    dir.join(SCORES_DIR)
        .join(tracker)
        .join(format!("{sequence}.csv"))
}

/// Writes the boxes of a cell and the ground truth, frame by frame, to
/// `path` (replaced whole).
///
/// # Errors
/// [`WriteError`] naming the file or its folder.
pub fn write_scores(path: &Path, boxes: &[BBox], truth: &[Option<BBox>]) -> Result<(), WriteError> {
    if let Some(dir) = path.parent() {
        crate::write::create_dir(dir)?;
    }
    let rows: Vec<ScoreRow> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let t = truth.get(i).copied().flatten();
            ScoreRow {
                frame: i + 1,
                x: b.x,
                y: b.y,
                width: b.width,
                height: b.height,
                truth_x: t.map(|t| t.x),
                truth_y: t.map(|t| t.y),
                truth_width: t.map(|t| t.width),
                truth_height: t.map(|t| t.height),
            }
        })
        .collect();
    write_csv(path, &rows)
}

/// Reads what [`write_scores`] wrote: the boxes and the ground truth.
///
/// # Errors
/// [`OtbError::Read`] for a file that cannot be read; [`OtbError::Row`]
/// naming the line of a row that does not parse, of a frame out of order,
/// or of a ground truth given in part.
pub fn read_scores(path: &Path) -> Result<(Vec<BBox>, Vec<Option<BBox>>), OtbError> {
    let rows: Vec<(usize, ScoreRow)> = read_rows(path)?;
    let mut boxes = Vec::with_capacity(rows.len());
    let mut truth = Vec::with_capacity(rows.len());
    for (line, r) in rows {
        let bad = |message: String| OtbError::Row {
            path: path.to_path_buf(),
            line,
            message,
        };
        if r.frame != boxes.len() + 1 {
            return Err(bad(format!(
                "frame {} where frame {} was expected",
                r.frame,
                boxes.len() + 1
            )));
        }
        boxes.push(BBox::new(r.x, r.y, r.width, r.height));
        truth.push(
            match (r.truth_x, r.truth_y, r.truth_width, r.truth_height) {
                (Some(x), Some(y), Some(w), Some(h)) => Some(BBox::new(x, y, w, h)),
                (None, None, None, None) => None,
                _ => return Err(bad("a ground-truth box given in part".into())),
            },
        );
    }
    Ok((boxes, truth))
}

/// The finished cells of the shard folder `dir`, with the line each was
/// read from.
///
/// # Errors
/// [`OtbError::Merge`] for a folder still marked `PARTIAL.txt` (its shard
/// has not finished); [`OtbError::Read`] for a missing or unreadable
/// [`SHARD_FILE`]; [`OtbError::Row`] naming the line of a row that does
/// not parse.
pub fn read_shard(dir: &Path) -> Result<Vec<(usize, ShardRow)>, OtbError> {
    if dir.join(PARTIAL_MARKER).exists() {
        return Err(OtbError::Merge {
            path: dir.to_path_buf(),
            reason: format!(
                "it holds {PARTIAL_MARKER}: its shard is running, was killed or failed; run it \
                 again to the end (its finished cells are in shard.partial.csv)"
            ),
        });
    }
    read_rows(&dir.join(SHARD_FILE))
}

/// The rows of a CSV file written by [`crate::write::csv_text`], each with
/// its 1-based line.
fn read_rows<R: serde::de::DeserializeOwned>(path: &Path) -> Result<Vec<(usize, R)>, OtbError> {
    let text = std::fs::read_to_string(path).map_err(|source| OtbError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let mut rows = Vec::new();
    for record in reader.deserialize::<R>() {
        match record {
            Ok(row) => rows.push((rows.len() + 2, row)),
            Err(e) => {
                return Err(OtbError::Row {
                    path: path.to_path_buf(),
                    line: e.position().map_or(rows.len() + 2, |p| p.line() as usize),
                    message: e.to_string(),
                });
            }
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_split_the_cells_round_robin() {
        let s = Shard::parse("2/3").unwrap();
        assert_eq!((s.index(), s.count(), s.to_string()), (2, 3, "2/3".into()));
        let mine: Vec<usize> = (0..8).filter(|&i| s.contains(i)).collect();
        assert_eq!(mine, [1, 4, 7]);
        assert_eq!(Shard::of_cell(7, 3), 2);
        // every cell in exactly one shard
        for n in 1..5 {
            for cell in 0..20 {
                let owners = (1..=n)
                    .filter(|&k| Shard::new(k, n).unwrap().contains(cell))
                    .count();
                assert_eq!(owners, 1);
            }
        }
        for (spec, says) in [
            ("0/3", "K, the shard to run, must be 1 to 3"),
            ("4/3", "must be 1 to 3"),
            ("1/0", "N, the number of shards, must be at least 1"),
            ("1", "expected K/N"),
            ("a/b", "expected K/N"),
            ("-1/2", "expected K/N"),
        ] {
            let e = Shard::parse(spec).unwrap_err().to_string();
            assert!(e.starts_with(&format!("shard `{spec}`: ")), "{e}");
            assert!(e.contains(says), "{spec}: {e}");
        }
    }

    #[test]
    fn scores_round_trip_every_bit() {
        let dir = std::env::temp_dir().join(format!("bayestrack-scores-{}", std::process::id()));
        let path = scores_path(&dir, "mad", "square");
        let boxes = [
            BBox::new(0.1 + 0.2, 1.0 / 3.0, 12.0, 1e-300),
            BBox::new(f64::NAN, -0.0, 5e307, 2.5),
        ];
        let truth = [Some(BBox::new(1.0, 2.0, 3.0, std::f64::consts::PI)), None];
        write_scores(&path, &boxes, &truth).unwrap();
        let (b, t) = read_scores(&path).unwrap();
        let bits = |b: &BBox| [b.x, b.y, b.width, b.height].map(f64::to_bits);
        assert_eq!(
            b.iter().map(bits).collect::<Vec<_>>(),
            boxes.iter().map(bits).collect::<Vec<_>>()
        );
        assert_eq!(t, truth);
        // a frame out of order names its line
        std::fs::write(
            &path,
            "frame,x,y,width,height,truth_x,truth_y,truth_width,truth_height\n1,1,1,1,1,,,,\n3,1,1,1,1,,,,\n",
        )
        .unwrap();
        let e = read_scores(&path).unwrap_err().to_string();
        assert!(e.contains("square.csv:3: frame 3 where frame 2"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
