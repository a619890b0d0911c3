//! Loading OTB-layout tracking sequences (frames + ground truth).
//!
//! A thin, stricter layer over `bayestrack-image`'s `io` feature
//! ([`bayestrack_image::OtbSequence`], [`bayestrack_image::read_frame`]): it
//! refuses a missing folder with its own error, checks that there is one
//! ground-truth row per frame, and names the frame index and file of a frame
//! that does not decode. Ground-truth rows `0,0,0,0` are unlabelled (`None`)
//! and are not scored by [`crate::metrics::score_otb`].
//!
//! Layouts accepted: `<seq>/img/0001.jpg ...` or `<seq>/img/img00001.png ...`
//! with `<seq>/groundtruth_rect.txt` or `<seq>/*_gt.txt` (comma, tab or space
//! separated `x y w h`, OTB box convention).

use std::path::{Path, PathBuf};

use bayestrack_image::{
    BBox, Image, ImageError, OtbSequence, find_ground_truth, list_frames, read_ground_truth,
};

/// What can go wrong while loading an OTB sequence.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OtbError {
    /// The sequence folder does not exist or is not a folder.
    #[error("sequence folder {path} does not exist")]
    MissingFolder {
        /// The folder asked for.
        path: PathBuf,
    },
    /// The ground-truth file has fewer (or more) rows than there are frames.
    #[error("{path}: {rows} ground-truth rows for {frames} frames")]
    RowCount {
        /// The ground-truth file.
        path: PathBuf,
        /// Frames found.
        frames: usize,
        /// Ground-truth rows found (blank lines excluded).
        rows: usize,
    },
    /// A frame that cannot be read or decoded (truncated, corrupt, not an
    /// image); the source names the file too.
    #[error("frame {} ({path}): {source}", .index + 1)]
    Frame {
        /// 0-based frame index.
        index: usize,
        /// The frame file.
        path: PathBuf,
        /// What `bayestrack-image` reported.
        #[source]
        source: Box<ImageError>,
    },
    /// A frame index past the end of the sequence.
    #[error("frame {index} requested from a {len}-frame sequence")]
    IndexOutOfRange {
        /// Index asked for.
        index: usize,
        /// Frames in the sequence.
        len: usize,
    },
    /// Listing frames or reading/parsing the ground truth failed
    /// ([`ImageError::GroundTruthParse`] names the file and 1-based line,
    /// [`ImageError::NoFrames`] and [`ImageError::NoGroundTruth`] the folder).
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// One OTB sequence on disk: frame files, ground truth, and its name.
/// Frames are decoded on demand.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// Folder name (`Crossing`, `David`, ...).
    pub name: String,
    /// The sequence folder.
    pub dir: PathBuf,
    /// Frame files in numeric order.
    pub frames: Vec<PathBuf>,
    /// The ground-truth file read (`None` for a bare frame folder opened
    /// with [`Sequence::open_frames`]).
    pub ground_truth_path: Option<PathBuf>,
    /// One entry per frame; `None` where the row is `0,0,0,0` (unlabelled)
    /// or where there is no ground-truth file.
    pub ground_truth: Vec<Option<BBox>>,
}

impl Sequence {
    /// Opens a sequence folder: lists its frames (without decoding them) and
    /// reads its ground truth.
    ///
    /// # Errors
    /// [`OtbError::MissingFolder`]; [`OtbError::Image`] for a folder without
    /// frames or ground-truth file and for a ground-truth row that does not
    /// parse (naming the line); [`OtbError::RowCount`] unless there is exactly
    /// one ground-truth row per frame.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self, OtbError> {
        let dir = dir.as_ref();
        if !dir.is_dir() {
            return Err(OtbError::MissingFolder {
                path: dir.to_path_buf(),
            });
        }
        let seq = OtbSequence::open(dir)?;
        if seq.ground_truth.len() != seq.frames.len() {
            return Err(OtbError::RowCount {
                path: seq.ground_truth_path,
                frames: seq.frames.len(),
                rows: seq.ground_truth.len(),
            });
        }
        Ok(Self {
            name: folder_name(dir),
            dir: seq.dir,
            frames: seq.frames,
            ground_truth_path: Some(seq.ground_truth_path),
            ground_truth: seq.ground_truth,
        })
    }

    /// Opens any folder of numbered PNG/JPEG frames (the folder itself or
    /// its `img/` sub-folder); its ground truth is read when the folder has
    /// one (`groundtruth_rect.txt` or `*_gt.txt`), and every frame is
    /// unlabelled otherwise.
    ///
    /// # Errors
    /// [`OtbError::MissingFolder`]; [`OtbError::Image`] for a folder without
    /// frames and for a ground-truth row that does not parse;
    /// [`OtbError::RowCount`] when a ground-truth file is present without
    /// exactly one row per frame.
    pub fn open_frames(dir: impl AsRef<Path>) -> Result<Self, OtbError> {
        let dir = dir.as_ref();
        if !dir.is_dir() {
            return Err(OtbError::MissingFolder {
                path: dir.to_path_buf(),
            });
        }
        let frames = list_frames(dir)?;
        let (ground_truth_path, ground_truth) = match find_ground_truth(dir) {
            Ok(path) => {
                let rows = read_ground_truth(&path)?;
                if rows.len() != frames.len() {
                    return Err(OtbError::RowCount {
                        path,
                        frames: frames.len(),
                        rows: rows.len(),
                    });
                }
                (Some(path), rows)
            }
            Err(ImageError::NoGroundTruth { .. }) => (None, vec![None; frames.len()]),
            Err(e) => return Err(e.into()),
        };
        Ok(Self {
            name: folder_name(dir),
            dir: dir.to_path_buf(),
            frames,
            ground_truth_path,
            ground_truth,
        })
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

    fn wrap(index: usize, path: &Path) -> impl FnOnce(ImageError) -> OtbError + '_ {
        move |source| OtbError::Frame {
            index,
            path: path.to_path_buf(),
            source: Box::new(source),
        }
    }

    /// Decodes frame `index` (0-based) keeping its colour kind (1 channel
    /// for gray files, 3 for colour).
    ///
    /// # Errors
    /// [`OtbError::IndexOutOfRange`]; [`OtbError::Frame`] naming the index
    /// and file for an unreadable, truncated or corrupt file.
    pub fn frame(&self, index: usize) -> Result<Image<u8>, OtbError> {
        let path = self.path(index)?;
        bayestrack_image::read_frame(path).map_err(Self::wrap(index, path))
    }

    /// Decodes frame `index` as 1-channel gray.
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn frame_gray(&self, index: usize) -> Result<Image<u8>, OtbError> {
        let path = self.path(index)?;
        bayestrack_image::read_frame_gray(path).map_err(Self::wrap(index, path))
    }

    /// Decodes frame `index` as 3-channel RGB (gray files replicated).
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn frame_rgb(&self, index: usize) -> Result<Image<u8>, OtbError> {
        let path = self.path(index)?;
        bayestrack_image::read_frame_rgb(path).map_err(Self::wrap(index, path))
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
/// [`OtbError::Image`] ([`ImageError::Io`]) if it cannot be listed.
pub fn list_sequences(root: impl AsRef<Path>) -> Result<Vec<PathBuf>, OtbError> {
    let root = root.as_ref();
    if !root.is_dir() {
        return Err(OtbError::MissingFolder {
            path: root.to_path_buf(),
        });
    }
    let io = |source| ImageError::Io {
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
