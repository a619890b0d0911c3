//! Loading tracking sequences (frames + ground truth): OTB-100 sequences
//! by the benchmark's table ([`crate::otb_table`]) and any folder of
//! numbered frames.
//!
//! A layer over `bayestrack-image`'s frame decoding
//! ([`bayestrack_image::read_frame`]) and this crate's ground-truth reader
//! ([`crate::ground_truth`]): it refuses a missing folder with its own error, lines the ground-truth
//! rows up with the frames (frames past the last row are tracked, not
//! scored, and [`Sequence::notes`] says so), and names the frame index and
//! file of a frame that does not decode. Ground-truth rows `0,0,0,0` are unlabelled (`None`)
//! and are not scored by [`crate::metrics::score_otb`].
//!
//! Layouts accepted: `<seq>/img/0001.jpg ...` or `<seq>/img/img00001.png ...`
//! with `<seq>/groundtruth_rect.txt` or `<seq>/*_gt.txt` (comma, tab or space
//! separated `x y w h`, OTB box convention). A plain folder's frames must
//! number the frames one to one ([`order_frames`]: no gap, no number twice,
//! every name UTF-8 with a number), and a folder named as one target of an
//! OTB-100 sequence (`Jogging_2`) must have the benchmark's layout: either
//! would otherwise score frames against another frame's or target's row.

use std::path::{Path, PathBuf};

use bayestrack_image::{BBox, Image, ImageError, list_frames};

use crate::error::OtbError;
use crate::ground_truth::{find_ground_truth_files, read_ground_truth};
use crate::otb_table::{self, OtbEntry};
use crate::source::{FolderSource, decode_numbered, file_name};

/// One sequence on disk: frame files, ground truth, and its name. Frames
/// are decoded on demand.
///
/// A folder named like an OTB-100 sequence with the benchmark's layout (its
/// first frame file and ground-truth file where the table says) runs on the
/// table's frames: David on `img/0300.jpg`-`img/0770.jpg`, Football1 on
/// frames 1-74 of its 81 images, Tiger1 from frame 6
/// ([`crate::otb_table`]). Any other folder runs on all its numbered
/// frames. Frames past the last ground-truth row are tracked but not
/// scored ([`Sequence::notes`] says so).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct Sequence {
    /// Folder name (`Crossing`, `David`, ...), or the OTB-100 target's name
    /// (`Jogging_2`).
    pub name: String,
    /// The sequence folder.
    pub dir: PathBuf,
    /// Frame files in order.
    pub frames: Vec<PathBuf>,
    /// The ground-truth file read (`None` for a frame folder without one).
    pub ground_truth_path: Option<PathBuf>,
    /// One entry per frame; `None` where the row is `0,0,0,0`
    /// (unlabelled), where the file has no row for the frame, or where
    /// there is no ground-truth file.
    pub ground_truth: Vec<Option<BBox>>,
    /// Frames that have a ground-truth row (the first `ground_truth_rows`
    /// frames; 0 without a file).
    pub ground_truth_rows: usize,
    /// The OTB-100 table entry the frames and ground truth follow, if any.
    pub otb: Option<&'static OtbEntry>,
    /// What the loader decided that a user should hear: frames without a
    /// ground-truth row, other targets' ground-truth files, a folder named
    /// like an OTB sequence without its layout.
    pub notes: Vec<String>,
}

impl Sequence {
    /// Opens a sequence folder with ground truth: lists its frames (without
    /// decoding them) and reads its ground truth, by the OTB-100 table when
    /// the folder is one of its sequences.
    ///
    /// # Errors
    /// [`OtbError::MissingFolder`]; [`OtbError::MissingFrame`] for a frame
    /// the OTB table lists that is not there; [`OtbError::Image`]
    /// ([`ImageError::NoFrames`]) for a folder without frames;
    /// [`OtbError::NoGroundTruth`] for one without a ground-truth file;
    /// [`OtbError::GroundTruth`] for a row that does not parse (naming the
    /// file and line); [`OtbError::RowCount`] when a plain folder's file
    /// has more rows than frames.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self, OtbError> {
        Self::load(dir.as_ref(), None, true)
    }

    /// Opens any folder of numbered PNG/JPEG frames (the folder itself or
    /// its `img/` sub-folder) or an OTB-100 sequence; its ground truth is
    /// read when the folder has one (`groundtruth_rect.txt` or `*_gt.txt`),
    /// and every frame is unlabelled otherwise.
    ///
    /// # Errors
    /// As [`Sequence::open`], except that no ground-truth file is needed.
    pub fn open_frames(dir: impl AsRef<Path>) -> Result<Self, OtbError> {
        Self::load(dir.as_ref(), None, false)
    }

    /// Opens a folder as [`Sequence::open_frames`] does, scoring it with the
    /// ground-truth file `ground_truth` instead of the folder's own (the
    /// second target of Jogging: `Jogging/groundtruth_rect.2.txt`). The
    /// file's first row is the sequence's first frame (for an OTB-100
    /// sequence, its `start_frame`).
    ///
    /// # Errors
    /// As [`Sequence::open`]; [`OtbError::Read`] naming `ground_truth`
    /// when it cannot be read.
    pub fn open_with_ground_truth(
        dir: impl AsRef<Path>,
        ground_truth: impl AsRef<Path>,
    ) -> Result<Self, OtbError> {
        Self::load(dir.as_ref(), Some(ground_truth.as_ref()), true)
    }

    fn load(dir: &Path, gt_file: Option<&Path>, require_gt: bool) -> Result<Self, OtbError> {
        let mut notes = Vec::new();
        let mut target = None;
        let mut dir = dir.to_path_buf();
        if !dir.is_dir() {
            // `OTB100/Jogging_2`: a target within the folder `Jogging`.
            let name = folder_name(&dir);
            match otb_table::entry(&name) {
                Some(e) if e.folder() != name && dir.with_file_name(e.folder()).is_dir() => {
                    dir = dir.with_file_name(e.folder());
                    target = Some(e);
                }
                _ => return Err(OtbError::MissingFolder { path: dir }),
            }
        }
        let folder = folder_name(&dir);
        let candidates = otb_table::entries_in_folder(&folder);
        let chosen = target.or_else(|| {
            gt_file
                .and_then(|g| g.file_name())
                .and_then(|g| {
                    candidates
                        .iter()
                        .find(|e| g == std::ffi::OsStr::new(e.groundtruth_file()))
                })
                .or(candidates.first())
                .copied()
        });
        if let Some(entry) = chosen {
            let layout_ok = |first: &Path| {
                first.is_file()
                    && (gt_file.is_some() || dir.join(entry.groundtruth_file()).is_file())
            };
            let first = dir
                .join(entry.frame_subdir())
                .join(entry.frame_file(*entry.frames().start()));
            if layout_ok(&first) {
                if target.is_none() && gt_file.is_none() && candidates.len() > 1 {
                    let others: Vec<String> = candidates
                        .iter()
                        .map(|e| format!("{} ({})", e.name, e.groundtruth_file()))
                        .collect();
                    notes.push(format!(
                        "{folder} holds {} OTB-100 targets: {}; tracking {}; pick another with \
                         --groundtruth {}",
                        candidates.len(),
                        others.join(", "),
                        entry.name,
                        dir.join(candidates[1].groundtruth_file()).display()
                    ));
                }
                return Self::load_otb(&dir, entry, gt_file, notes);
            }
            if let Some(target) = target {
                // `Jogging_2` names one target of the folder: read as a
                // plain folder, it would be scored against the folder's own
                // (the other target's) ground truth.
                return Err(OtbError::NotOtbLayout {
                    target: target.name.clone(),
                    dir,
                    expected: format!("{} with {}", first.display(), entry.groundtruth_file()),
                });
            }
            notes.push(format!(
                "{folder} is named like the OTB-100 sequence {} but has not its layout (no {} \
                 with {}): read as a plain folder of frames",
                entry.name,
                first.display(),
                entry.groundtruth_file()
            ));
        }
        let frames = order_frames(list_frames(&dir)?)?;
        let gt_path = match gt_file {
            Some(g) => Some(g.to_path_buf()),
            None => match find_ground_truth_files(&dir) {
                Ok(found) => {
                    if found.len() > 1 {
                        let names: Vec<String> = found
                            .iter()
                            .skip(1)
                            .map(|p| p.display().to_string())
                            .collect();
                        notes.push(format!(
                            "ground truth read from {}; the folder has other ground-truth files \
                             ({}): pick one with --groundtruth",
                            found[0].display(),
                            names.join(", ")
                        ));
                    }
                    found.into_iter().next()
                }
                Err(e @ OtbError::NoGroundTruth { .. }) => {
                    if require_gt {
                        return Err(e);
                    }
                    None
                }
                Err(e) => return Err(e),
            },
        };
        let (ground_truth, rows) = match &gt_path {
            Some(path) => {
                let rows = read_ground_truth(path)?;
                if rows.len() > frames.len() {
                    return Err(OtbError::RowCount {
                        path: path.clone(),
                        frames: frames.len(),
                        rows: rows.len(),
                    });
                }
                let n = rows.len();
                (pad_rows(rows, frames.len(), path, &mut notes), n)
            }
            None => (vec![None; frames.len()], 0),
        };
        Ok(Self {
            name: folder,
            dir,
            frames,
            ground_truth_path: gt_path,
            ground_truth,
            ground_truth_rows: rows,
            otb: None,
            notes,
        })
    }

    fn load_otb(
        dir: &Path,
        entry: &'static OtbEntry,
        gt_file: Option<&Path>,
        mut notes: Vec<String>,
    ) -> Result<Self, OtbError> {
        let img = dir.join(entry.frame_subdir());
        let mut frames = Vec::with_capacity(entry.len());
        for number in entry.frames() {
            let path = img.join(entry.frame_file(number));
            if !path.is_file() {
                return Err(OtbError::MissingFrame {
                    path,
                    sequence: entry.name.clone(),
                    first: *entry.frames().start(),
                    last: entry.end_frame,
                });
            }
            frames.push(path);
        }
        let gt_path = gt_file.map_or_else(|| dir.join(entry.groundtruth_file()), Path::to_path_buf);
        let mut rows = read_ground_truth(&gt_path)?;
        // The file's first row is start_frame; init_omit frames are left out.
        rows.drain(..entry.init_omit.min(rows.len()));
        if rows.len() > frames.len() {
            notes.push(format!(
                "{}: {} ground-truth rows past frame {} (the last of OTB-100 {}) are not used",
                gt_path.display(),
                rows.len() - frames.len(),
                entry.end_frame,
                entry.name
            ));
            rows.truncate(frames.len());
        }
        let n = rows.len();
        let ground_truth = pad_rows(rows, frames.len(), &gt_path, &mut notes);
        Ok(Self {
            name: entry.name.clone(),
            dir: dir.to_path_buf(),
            frames,
            ground_truth_path: Some(gt_path),
            ground_truth,
            ground_truth_rows: n,
            otb: Some(entry),
            notes,
        })
    }

    /// The sequence's frames as a [`crate::source::FrameSource`], decoded one at a
    /// time.
    pub fn source(&self) -> FolderSource<'_> {
        FolderSource::new(&self.dir, &self.frames)
    }

    /// The file name of frame `index` (0-based): `0300.jpg`.
    pub fn frame_name(&self, index: usize) -> String {
        self.frames
            .get(index)
            .map_or_else(String::new, |p| file_name(p))
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether there are no frames (never true for an opened sequence).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Number of labelled (scorable) frames.
    pub fn labelled(&self) -> usize {
        self.ground_truth.iter().filter(|b| b.is_some()).count()
    }

    /// The box a tracker is initialised from: the ground truth of frame 1
    /// (`None` if that frame is unlabelled).
    pub fn initial_box(&self) -> Option<BBox> {
        self.ground_truth.first().copied().flatten()
    }

    fn path(&self, index: usize) -> Result<&Path, OtbError> {
        self.frames
            .get(index)
            .map(PathBuf::as_path)
            .ok_or(OtbError::IndexOutOfRange {
                index,
                len: self.frames.len(),
            })
    }

    /// Decodes frame `index` (0-based) keeping its colour kind (1 channel
    /// for gray files, 3 for colour).
    ///
    /// # Errors
    /// [`OtbError::IndexOutOfRange`]; [`OtbError::Frame`] naming the index
    /// and file for an unreadable, truncated or corrupt file.
    pub fn frame(&self, index: usize) -> Result<Image<u8>, OtbError> {
        decode_numbered(index, self.path(index)?, |p| {
            bayestrack_image::read_frame(p)
        })
    }

    /// Decodes frame `index` as 1-channel gray.
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn frame_gray(&self, index: usize) -> Result<Image<u8>, OtbError> {
        decode_numbered(index, self.path(index)?, |p| {
            bayestrack_image::read_frame_gray(p)
        })
    }

    /// Decodes frame `index` as 3-channel RGB (gray files replicated).
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn frame_rgb(&self, index: usize) -> Result<Image<u8>, OtbError> {
        decode_numbered(index, self.path(index)?, |p| {
            bayestrack_image::read_frame_rgb(p)
        })
    }

    /// Decodes every frame once and checks that they all have the size of
    /// the first; returns `(width, height, channels)` of the first frame.
    ///
    /// # Errors
    /// The first [`OtbError::Frame`] met; [`OtbError::Frame`] with
    /// [`ImageError::SizeMismatch`] for a frame of another size.
    pub fn check_frames(&self) -> Result<(usize, usize, usize), OtbError> {
        let first = self.frame(0)?;
        let shape = (first.width(), first.height(), first.channels());
        for index in 1..self.len() {
            let f = self.frame(index)?;
            if (f.width(), f.height(), f.channels()) != shape {
                return Err(OtbError::Frame {
                    index,
                    path: self.frames[index].clone(),
                    source: Box::new(ImageError::SizeMismatch {
                        operation: "sequence frames",
                        a_width: shape.0,
                        a_height: shape.1,
                        a_channels: shape.2,
                        b_width: f.width(),
                        b_height: f.height(),
                        b_channels: f.channels(),
                    }),
                });
            }
        }
        Ok(shape)
    }
}

/// Pads `rows` with `None` up to `frames` entries, noting the frames that
/// have no row.
fn pad_rows(
    mut rows: Vec<Option<BBox>>,
    frames: usize,
    path: &Path,
    notes: &mut Vec<String>,
) -> Vec<Option<BBox>> {
    if rows.len() < frames {
        notes.push(format!(
            "{} has {} rows for {frames} frames: frames {}-{frames} have no ground-truth row and \
             are tracked but not scored",
            path.display(),
            rows.len(),
            rows.len() + 1
        ));
        rows.resize(frames, None);
    }
    rows
}

/// The number a frame file is known by: the last run of ASCII digits in
/// its stem (`0001.jpg` is 1, `img00042.png` is 42); `None` when the stem
/// has no digits or the number does not fit in 64 bits.
pub fn frame_number(name: &str) -> Option<u64> {
    let stem = name.rsplit_once('.').map_or(name, |(stem, _)| stem);
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    // just past the last character that is not a digit (which may take
    // more than one byte: `ť8.png`)
    let start = stem[..end]
        .char_indices()
        .rev()
        .find(|(_, c)| !c.is_ascii_digit())
        .map_or(0, |(i, c)| i + c.len_utf8());
    stem[start..end].parse().ok()
}

/// Puts the frame files of a plain folder in frame order and checks that
/// they number the frames one to one: every name UTF-8 with a number
/// ([`frame_number`]), no number twice, none missing between the first and
/// the last. A folder that breaks one of these would shift every later
/// frame against its ground-truth row, so it is refused, naming the file.
///
/// # Errors
/// [`OtbError::FrameNames`] naming the file: a name that is not UTF-8 or
/// has no number, a number two files share, a number missing (naming the
/// files before and after the gap).
pub fn order_frames(frames: Vec<PathBuf>) -> Result<Vec<PathBuf>, OtbError> {
    let bad = |path: &Path, reason: String| OtbError::FrameNames {
        path: path.to_path_buf(),
        reason,
    };
    let mut numbered = Vec::with_capacity(frames.len());
    for path in frames {
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            return Err(bad(
                &path,
                "the file name is not UTF-8, so its frame number cannot be read; rename it"
                    .to_string(),
            ));
        };
        let Some(number) = frame_number(name) else {
            return Err(bad(
                &path,
                "the file name has no frame number (frames are numbered files: 0001.jpg, \
                 img00001.png); move it out of the frame folder"
                    .to_string(),
            ));
        };
        numbered.push((number, path));
    }
    numbered.sort();
    for pair in numbered.windows(2) {
        let ((a, pa), (b, pb)) = (&pair[0], &pair[1]);
        if a == b {
            return Err(bad(
                pb,
                format!(
                    "frame number {b} twice: {} and {}; keep one",
                    file_name(pa),
                    file_name(pb)
                ),
            ));
        }
        if *b != a + 1 {
            let missing = if *b == a + 2 {
                format!("frame {} is missing", a + 1)
            } else {
                format!("frames {}-{} are missing", a + 1, b - 1)
            };
            return Err(bad(
                pb,
                format!(
                    "{missing} ({} is followed by {}): every later frame would be scored \
                     against another frame's ground-truth row",
                    file_name(pa),
                    file_name(pb)
                ),
            ));
        }
    }
    Ok(numbered.into_iter().map(|(_, p)| p).collect())
}

fn folder_name(dir: &Path) -> String {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string())
}

/// The sub-folders of `root` that look like sequences (they hold an `img/`
/// folder), sorted by name; for running every tracker on every sequence.
///
/// # Errors
/// [`OtbError::MissingFolder`] if `root` is not a folder;
/// [`OtbError::Read`] if it cannot be listed.
pub fn list_sequences(root: impl AsRef<Path>) -> Result<Vec<PathBuf>, OtbError> {
    let root = root.as_ref();
    if !root.is_dir() {
        return Err(OtbError::MissingFolder {
            path: root.to_path_buf(),
        });
    }
    let io = |source| OtbError::Read {
        path: root.to_path_buf(),
        source,
    };
    let mut out = Vec::new();
    for entry in std::fs::read_dir(root).map_err(io)? {
        let p = entry.map_err(io)?.path();
        if p.join("img").is_dir() {
            out.push(p);
        }
    }
    out.sort();
    Ok(out)
}
