//! The published one-pass (OPE) results of the OTB benchmark (Wu, Lim and
//! Yang, "Object Tracking Benchmark", TPAMI 2015), to print our trackers
//! beside them.
//!
//! [`PublishedOpe::read`] reads `published_ope.csv` (one row per tracker
//! and sequence, from the benchmark's result files):
//!
//! ```text
//! tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap
//! ASLA,BasketBall,0.5559,0.3839
//! ```
//!
//! - `success_rate_iou_0.5`: the fraction of the sequence's frames with
//!   IoU at least 0.5 (`1 - errorNum / 10` of the benchmark's files, which
//!   count IoU `< 0.5` as an error). Ours, [`crate::metrics::OtbScore::success_rate_50`],
//!   counts IoU `> 0.5` as the success plot does; the two differ only on a
//!   frame whose IoU is exactly 0.5.
//! - `mean_overlap_of_frames_with_overlap`: the mean IoU over the frames
//!   with IoU `> 0` only (the benchmark's `overlapScores`), higher than AUC
//!   and than the mean IoU: compare it with
//!   [`crate::metrics::OtbScore::mean_overlap_of_frames_with_overlap`], never with
//!   AUC.
//!
//! The frames each published number covers are the benchmark's sequence
//! table compiled into the crate ([`crate::otb_table`], the one the
//! sequence loader reads; OTB's David is frames 300-770):
//! [`OtbFrameRanges::otb100`]. A published number is comparable with ours
//! only when our copy of the sequence has those frames
//! ([`OtbFrameRanges::same_frames`]).
//!
//! ```
//! use bayestrack_otb::published::PublishedOpe;
//! use std::path::Path;
//!
//! let text = "tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap\n\
//!             IVT,Crossing,0.2417,0.2966\n";
//! let published = PublishedOpe::parse(text, Path::new("published_ope.csv")).unwrap();
//! let ivt = published.score("IVT", "crossing").unwrap();
//! assert_eq!(ivt.success_rate_50, 0.2417);
//! assert_eq!(published.trackers(), ["IVT"]);
//! ```

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::OtbError;
use crate::otb_table::{OtbEntry, otb100};

/// File name of the published results in the OTB data folder.
pub const PUBLISHED_OPE_FILE: &str = "published_ope.csv";

/// The header of `published_ope.csv`.
pub const PUBLISHED_OPE_HEADER: [&str; 4] = [
    "tracker",
    "sequence",
    "success_rate_iou_0.5",
    "mean_overlap_of_frames_with_overlap",
];

/// The published results of the OTB data folder and the frame ranges they
/// cover.
#[derive(Debug, Clone, PartialEq)]
pub struct Published {
    /// The folder read.
    pub dir: PathBuf,
    /// `published_ope.csv`.
    pub results: PublishedOpe,
    /// The benchmark's frame ranges ([`OtbFrameRanges::otb100`] when
    /// read).
    pub ranges: OtbFrameRanges,
}

impl Published {
    /// Reads [`PUBLISHED_OPE_FILE`] in `dir`, with the frame ranges of the
    /// compiled OTB-100 table ([`OtbFrameRanges::otb100`]).
    ///
    /// # Errors
    /// [`OtbError`] naming the file (and the line) that cannot be
    /// read; [`Published::is_missing`] says whether it is simply absent.
    pub fn read(dir: &Path) -> Result<Self, OtbError> {
        Ok(Self {
            dir: dir.to_path_buf(),
            results: PublishedOpe::read(&dir.join(PUBLISHED_OPE_FILE))?,
            ranges: OtbFrameRanges::otb100(),
        })
    }

    /// Whether `error` says that the file is not there (rather than
    /// unreadable or malformed).
    pub fn is_missing(error: &OtbError) -> bool {
        matches!(error, OtbError::Read { source, .. }
            if source.kind() == std::io::ErrorKind::NotFound)
    }

    /// Whether the published numbers of `sequence` are for the frames of
    /// our copy, which has `frames` frames ([`OtbFrameRanges::same_frames`]).
    pub fn same_frames(&self, sequence: &str, frames: usize) -> bool {
        self.results.has_sequence(sequence) && self.ranges.same_frames(sequence, frames)
    }
}

/// One published tracker on one sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PublishedScore {
    /// Fraction of frames with IoU `>= 0.5` (column `success_rate_iou_0.5`).
    pub success_rate_50: f64,
    /// Mean IoU over the frames with IoU `> 0` (column
    /// `mean_overlap_of_frames_with_overlap`).
    pub mean_overlap_of_frames_with_overlap: f64,
}

/// The published results: trackers in file order, scores by tracker and
/// sequence (sequence names compare as [`sequence_key`] does: the file
/// spells `BasketBall` and `Jogging-1`, the dataset `Basketball` and
/// `Jogging_1`).
#[derive(Debug, Clone, PartialEq)]
pub struct PublishedOpe {
    trackers: Vec<String>,
    sequences: Vec<String>,
    scores: HashMap<(String, String), PublishedScore>,
}

/// A sequence name as compared across the benchmark's files: lower case,
/// `-` read as `_`.
pub fn sequence_key(name: &str) -> String {
    name.to_lowercase().replace('-', "_")
}

/// The non-empty lines of `text` with their 1-based numbers, a UTF-8 byte
/// order mark and CRLF endings removed.
fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.strip_prefix('\u{feff}')
        .unwrap_or(text)
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty())
}

impl PublishedOpe {
    /// Reads `path` (see the module docs for the format).
    ///
    /// # Errors
    /// [`OtbError`] naming the file, and the line for a bad row.
    pub fn read(path: &Path) -> Result<Self, OtbError> {
        let text = std::fs::read_to_string(path).map_err(|source| OtbError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses the text of a `published_ope.csv`; `path` names it in errors.
    ///
    /// # Errors
    /// [`OtbError::Header`] for another header;
    /// [`OtbError::Row`] for a row without four fields, an empty name
    /// or a value that is not a number in `[0, 1]`;
    /// [`OtbError::Duplicate`] for a tracker and sequence given twice;
    /// [`OtbError::Empty`] for a file with no rows.
    pub fn parse(text: &str, path: &Path) -> Result<Self, OtbError> {
        let mut lines = lines(text);
        let header = PUBLISHED_OPE_HEADER.join(",");
        match lines.next() {
            Some((_, found)) if found.split(',').map(str::trim).eq(PUBLISHED_OPE_HEADER) => {}
            found => {
                return Err(OtbError::Header {
                    path: path.to_path_buf(),
                    expected: header,
                    found: found.map_or_else(String::new, |(_, l)| l.to_string()),
                });
            }
        }
        let mut out = Self {
            trackers: Vec::new(),
            sequences: Vec::new(),
            scores: HashMap::new(),
        };
        let mut first_line: HashMap<(String, String), usize> = HashMap::new();
        for (line, row) in lines {
            let bad = |message: String| OtbError::Row {
                path: path.to_path_buf(),
                line,
                message,
            };
            let fields: Vec<&str> = row.split(',').map(str::trim).collect();
            let [tracker, sequence, success, overlap] = fields[..] else {
                return Err(bad(format!(
                    "{} fields, expected 4 ({header})",
                    fields.len()
                )));
            };
            if tracker.is_empty() || sequence.is_empty() {
                return Err(bad("empty tracker or sequence name".into()));
            }
            let value = |column: &str, text: &str| match text.parse::<f64>() {
                Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
                _ => Err(bad(format!("{column} `{text}` is not a number in [0, 1]"))),
            };
            let score = PublishedScore {
                success_rate_50: value(PUBLISHED_OPE_HEADER[2], success)?,
                mean_overlap_of_frames_with_overlap: value(PUBLISHED_OPE_HEADER[3], overlap)?,
            };
            let key = (tracker.to_string(), sequence_key(sequence));
            if let Some(&first) = first_line.get(&key) {
                return Err(OtbError::Duplicate {
                    path: path.to_path_buf(),
                    line,
                    first,
                    what: format!("{tracker} on {sequence}"),
                });
            }
            first_line.insert(key.clone(), line);
            if !out.trackers.iter().any(|t| t == tracker) {
                out.trackers.push(tracker.to_string());
            }
            if !out.sequences.iter().any(|s| sequence_key(s) == key.1) {
                out.sequences.push(sequence.to_string());
            }
            out.scores.insert(key, score);
        }
        if out.scores.is_empty() {
            return Err(OtbError::Empty {
                path: path.to_path_buf(),
            });
        }
        Ok(out)
    }

    /// Tracker names, in the order of the file.
    pub fn trackers(&self) -> &[String] {
        &self.trackers
    }

    /// Sequence names as the file spells them, in the order of the file.
    pub fn sequences(&self) -> &[String] {
        &self.sequences
    }

    /// Whether some tracker has a result on `sequence` ([`sequence_key`]).
    pub fn has_sequence(&self, sequence: &str) -> bool {
        let key = sequence_key(sequence);
        self.sequences.iter().any(|s| sequence_key(s) == key)
    }

    /// The result of `tracker` on `sequence` ([`sequence_key`]).
    pub fn score(&self, tracker: &str, sequence: &str) -> Option<PublishedScore> {
        self.scores
            .get(&(tracker.to_string(), sequence_key(sequence)))
            .copied()
    }

    /// Mean success rate at IoU 0.5 of `tracker` over `sequences`; `None`
    /// if a sequence has no result for it (or the list is empty).
    pub fn mean_success_rate(&self, tracker: &str, sequences: &[&str]) -> Option<f64> {
        let rates: Option<Vec<f64>> = sequences
            .iter()
            .map(|s| self.score(tracker, s).map(|p| p.success_rate_50))
            .collect();
        let rates = rates?;
        (!rates.is_empty()).then(|| rates.iter().sum::<f64>() / rates.len() as f64)
    }
}

/// The frames the benchmark scores on one sequence: `start_frame ..=
/// end_frame` as its configuration names them (Tiger1's `init_omit` frames
/// are inside the range).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OtbFrameRange {
    /// Sequence name as the table spells it.
    pub name: String,
    /// First scored frame number (1-based file number).
    pub start_frame: usize,
    /// Last scored frame number.
    pub end_frame: usize,
}

impl OtbFrameRange {
    /// The range `start_frame ..= end_frame` of the sequence `name`.
    pub fn new(name: impl Into<String>, start_frame: usize, end_frame: usize) -> Self {
        Self {
            name: name.into(),
            start_frame,
            end_frame,
        }
    }

    /// Number of frames in `start_frame ..= end_frame` (0 when the end is
    /// before the start).
    pub fn len(&self) -> usize {
        (self.end_frame + 1).saturating_sub(self.start_frame)
    }

    /// Whether the range has no frame (never for the OTB-100 table's
    /// ranges).
    pub fn is_empty(&self) -> bool {
        self.end_frame < self.start_frame
    }
}

impl From<&OtbEntry> for OtbFrameRange {
    fn from(entry: &OtbEntry) -> Self {
        Self::new(entry.name.as_str(), entry.start_frame, entry.end_frame)
    }
}

/// The benchmark's frame range of each sequence, looked up by name
/// ([`sequence_key`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OtbFrameRanges {
    ranges: Vec<OtbFrameRange>,
}

impl OtbFrameRanges {
    /// The ranges of the 100 sequences of the compiled OTB-100 table
    /// ([`crate::otb_table::otb100`]), in its order.
    pub fn otb100() -> Self {
        Self::from_ranges(otb100().iter().map(OtbFrameRange::from))
    }

    /// The ranges given, in their order (where a name comes twice,
    /// [`OtbFrameRanges::get`] finds the first).
    pub fn from_ranges(ranges: impl IntoIterator<Item = OtbFrameRange>) -> Self {
        Self {
            ranges: ranges.into_iter().collect(),
        }
    }

    /// The range of `sequence` ([`sequence_key`]).
    pub fn get(&self, sequence: &str) -> Option<&OtbFrameRange> {
        let key = sequence_key(sequence);
        self.ranges.iter().find(|r| sequence_key(&r.name) == key)
    }

    /// Every range, in order.
    pub fn ranges(&self) -> &[OtbFrameRange] {
        &self.ranges
    }

    /// Whether our copy of `sequence`, with `frames` frames, covers the
    /// benchmark's frames: same name and as many frames as the benchmark's
    /// range (our copies start at the range's first frame; a copy with
    /// another count is another cut of the video, such as the MIL tracker's
    /// 462-frame David beside OTB's frames 300-770).
    pub fn same_frames(&self, sequence: &str, frames: usize) -> bool {
        self.get(sequence).is_some_and(|r| r.len() == frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str =
        "tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap\n";

    fn parse(body: &str) -> Result<PublishedOpe, OtbError> {
        PublishedOpe::parse(&format!("{HEADER}{body}"), Path::new("p.csv"))
    }

    fn message(r: Result<impl std::fmt::Debug, OtbError>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn reads_rows_in_order_with_case_free_sequences() {
        let p = PublishedOpe::parse(
            &format!(
                "\u{feff}{}MIL,BasketBall,0.2,0.3\r\nIVT,Crossing,0.2417,0.2966\r\n\r\nMIL,Crossing,1,0.9\nMIL,Jogging-1,0,0\n",
                HEADER.replace('\n', "\r\n")
            ),
            Path::new("p.csv"),
        )
        .unwrap();
        assert_eq!(p.trackers(), ["MIL", "IVT"]);
        assert_eq!(p.sequences(), ["BasketBall", "Crossing", "Jogging-1"]);
        assert!(p.has_sequence("basketball"));
        assert!(p.has_sequence("Jogging_1"));
        assert!(!p.has_sequence("Jogging_2"));
        assert_eq!(
            p.score("MIL", "Basketball"),
            Some(PublishedScore {
                success_rate_50: 0.2,
                mean_overlap_of_frames_with_overlap: 0.3
            })
        );
        assert_eq!(p.score("IVT", "BasketBall"), None);
        assert_eq!(
            p.mean_success_rate("MIL", &["Crossing", "basketball"]),
            Some(0.6)
        );
        assert_eq!(
            p.mean_success_rate("IVT", &["Crossing", "Basketball"]),
            None
        );
        assert_eq!(p.mean_success_rate("MIL", &[]), None);
    }

    #[test]
    fn bad_files_name_the_file_and_line() {
        let header = message(PublishedOpe::parse(
            "tracker,sequence,auc,mean_iou\nA,B,0.1,0.2\n",
            Path::new("p.csv"),
        ));
        assert!(
            header.starts_with("p.csv:1: expected the header"),
            "{header}"
        );
        assert!(
            message(PublishedOpe::parse("", Path::new("p.csv"))).contains("found ``"),
            "empty file"
        );
        assert_eq!(message(parse("")), "p.csv: no rows after the header");
        assert_eq!(
            message(parse("A,B,0.1,0.2\nA,B,0.1\n")),
            format!(
                "p.csv:3: 3 fields, expected 4 ({})",
                PUBLISHED_OPE_HEADER.join(",")
            )
        );
        assert_eq!(
            message(parse("A,B,0.1,0.2\n,B,0.1,0.2\n")),
            "p.csv:3: empty tracker or sequence name"
        );
        assert_eq!(
            message(parse("A,B,1.5,0.2\n")),
            "p.csv:2: success_rate_iou_0.5 `1.5` is not a number in [0, 1]"
        );
        assert_eq!(
            message(parse("A,B,0.5,NaN\n")),
            "p.csv:2: mean_overlap_of_frames_with_overlap `NaN` is not a number in [0, 1]"
        );
        assert_eq!(
            message(parse("A,B,0.5,\n")),
            "p.csv:2: mean_overlap_of_frames_with_overlap `` is not a number in [0, 1]"
        );
        assert_eq!(
            message(parse("A,Bolt,0.5,0.5\nB,Bolt,0.5,0.5\nA,bolt,0.1,0.1\n")),
            "p.csv:4: A on bolt repeats line 2"
        );
        let missing = PublishedOpe::read(Path::new("/nonexistent/published_ope.csv"));
        assert!(
            message(missing).starts_with("cannot read /nonexistent/published_ope.csv: "),
            "read error"
        );
    }

    #[test]
    fn the_otb100_ranges_and_same_frames() {
        let r = OtbFrameRanges::otb100();
        assert_eq!(r.ranges().len(), 100);
        let david = r.get("david").unwrap();
        assert_eq!(
            (david.start_frame, david.end_frame, david.len()),
            (300, 770, 471)
        );
        assert!(!david.is_empty());
        // the published file's spelling finds the table's `Jogging_1`
        assert_eq!(r.get("Jogging-1").unwrap().name, "Jogging_1");
        // the configuration's range, init_omit inside it
        assert_eq!(r.get("Tiger1").unwrap().len(), 354);
        // our copies (../shared/data/sequences): Crossing and Couple are the
        // benchmark's frames, David is the MIL tracker's 462-frame cut
        assert!(r.same_frames("Crossing", 120));
        assert!(!r.same_frames("Crossing", 119));
        assert!(r.same_frames("Couple", 140));
        assert!(!r.same_frames("David", 462));
        assert!(r.same_frames("David", 471));
        assert!(!r.same_frames("Square", 3));
    }

    #[test]
    fn ranges_given_by_hand() {
        let range = OtbFrameRange::new;
        let r = OtbFrameRanges::from_ranges([
            range("Square", 1, 3),
            range("square", 5, 9),
            range("Odd", 4, 2),
        ]);
        assert_eq!(r.get("SQUARE"), Some(&range("Square", 1, 3)));
        assert!(r.same_frames("square", 3));
        assert!(!r.same_frames("square", 5));
        let odd = r.get("Odd").unwrap();
        assert!(odd.is_empty());
        assert_eq!(odd.len(), 0);
        assert!(!r.same_frames("Crossing", 120));
    }
}
