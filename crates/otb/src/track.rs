//! Running one tracker over one sequence, frame by frame: the loop behind
//! `bayestrack track` and `cargo xtask otb`.
//!
//! Frame 1 initialises the tracker from a box (OTB one-pass evaluation);
//! every later frame is one [`Tracker::step`]. Each frame's box goes to a
//! caller-supplied sink as soon as it is known, so a run that fails
//! part-way has already handed over (and, for a file sink, written) every
//! box before the failure. Only the tracker's own calls are timed: decoding
//! frames and writing boxes are not part of the reported fps.

use std::borrow::Cow;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use bayestrack_image::{BBox, Image, ImageView};
use bayestrack_trackers::{Tracker, TrackerError};

use crate::sequence::OtbError;

/// What to do with a frame that does not decode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OnBadFrame {
    /// Stop the run with an error naming the frame (the default).
    #[default]
    Stop,
    /// Skip it: the tracker does not see it and the previous box is
    /// repeated for it. The first frame cannot be skipped.
    Skip,
}

/// What went wrong while tracking a sequence.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrackError {
    /// A frame could not be read or decoded (the source names the file).
    #[error(transparent)]
    Frame(#[from] OtbError),
    /// The tracker refused a frame (changed size, wrong channels, a box
    /// outside the first frame, ...).
    #[error("{tracker} failed on frame {frame} ({path}): {source}")]
    Tracker {
        /// Tracker name.
        tracker: &'static str,
        /// 1-based frame number.
        frame: usize,
        /// The frame file.
        path: PathBuf,
        /// What the tracker reported.
        #[source]
        source: Box<TrackerError>,
    },
    /// The sink (an output file, a drawing) failed.
    #[error("cannot write {path}: {source}")]
    Output {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The sequence has no frames.
    #[error("the sequence has no frames")]
    NoFrames,
}

/// One frame's outcome, handed to the sink.
#[derive(Debug, Clone, Copy)]
pub struct FrameBox<'a> {
    /// 0-based frame index.
    pub index: usize,
    /// The box reported for the frame (the initial box on frame 1, the
    /// previous box on a skipped frame).
    pub bbox: BBox,
    /// The decoded frame (`None` when it was skipped).
    pub frame: Option<ImageView<'a, u8>>,
    /// Whether the tracker said it lost the target on this frame.
    pub lost: bool,
}

/// Summary of a finished run.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRun {
    /// One box per frame, frame 1 first.
    pub boxes: Vec<BBox>,
    /// Seconds spent inside the tracker's `init` and `step` calls.
    pub tracker_seconds: f64,
    /// 0-based indices of frames skipped because they did not decode, with
    /// the reason.
    pub skipped: Vec<(usize, String)>,
    /// Frames on which the tracker reported the target lost.
    pub lost_frames: usize,
    /// Particles summed over frames (0 for deterministic trackers).
    pub particles: usize,
}

impl TrackRun {
    /// Frames the tracker processed per second of its own time.
    pub fn fps(&self) -> f64 {
        let seen = self.boxes.len() - self.skipped.len();
        if self.tracker_seconds > 0.0 {
            seen as f64 / self.tracker_seconds
        } else {
            f64::INFINITY
        }
    }
}

/// Runs `tracker` over `len` frames: `frame(i)` decodes frame `i`,
/// `path(i)` names its file for errors, `init` is the box on frame 1, and
/// `sink` receives every frame's box in order, as soon as it is known.
///
/// # Errors
/// [`TrackError::NoFrames`]; [`TrackError::Frame`] for a frame that does not
/// decode (always for frame 1, otherwise only under [`OnBadFrame::Stop`]);
/// [`TrackError::Tracker`] naming the frame the tracker refused; whatever
/// the sink returns. Boxes handed to the sink before the error stay handed.
pub fn track_frames<'f, F, P, S>(
    tracker: &mut dyn Tracker,
    len: usize,
    mut frame: F,
    path: P,
    init: BBox,
    on_bad_frame: OnBadFrame,
    mut sink: S,
) -> Result<TrackRun, TrackError>
where
    F: FnMut(usize) -> Result<Cow<'f, Image<u8>>, OtbError>,
    P: Fn(usize) -> PathBuf,
    S: FnMut(FrameBox<'_>) -> Result<(), TrackError>,
{
    if len == 0 {
        return Err(TrackError::NoFrames);
    }
    let name = tracker.name();
    let refused = |index: usize| {
        let path = path(index);
        move |source| TrackError::Tracker {
            tracker: name,
            frame: index + 1,
            path,
            source: Box::new(source),
        }
    };
    let mut run = TrackRun {
        boxes: Vec::with_capacity(len),
        tracker_seconds: 0.0,
        skipped: Vec::new(),
        lost_frames: 0,
        particles: 0,
    };

    let first = frame(0)?;
    let start = Instant::now();
    tracker.init(first.view(), init).map_err(refused(0))?;
    run.tracker_seconds += start.elapsed().as_secs_f64();
    run.boxes.push(init);
    sink(FrameBox {
        index: 0,
        bbox: init,
        frame: Some(first.view()),
        lost: false,
    })?;
    drop(first);

    let mut last = init;
    for index in 1..len {
        let image = match frame(index) {
            Ok(image) => image,
            Err(e) if on_bad_frame == OnBadFrame::Skip => {
                run.skipped.push((index, e.to_string()));
                run.boxes.push(last);
                sink(FrameBox {
                    index,
                    bbox: last,
                    frame: None,
                    lost: false,
                })?;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let start = Instant::now();
        let estimate = tracker.step(image.view()).map_err(refused(index))?;
        run.tracker_seconds += start.elapsed().as_secs_f64();
        last = estimate.bbox;
        run.lost_frames += usize::from(estimate.lost);
        run.particles += estimate.particles;
        run.boxes.push(last);
        sink(FrameBox {
            index,
            bbox: last,
            frame: Some(image.view()),
            lost: estimate.lost,
        })?;
    }
    Ok(run)
}

/// An OTB result file, one `x,y,w,h` row per frame, flushed row by row so
/// that an interrupted run keeps every box it wrote. The path `-` is
/// standard output.
pub struct BoxFile {
    path: PathBuf,
    out: Box<dyn Write>,
}

impl BoxFile {
    /// Creates (truncates) the file.
    ///
    /// # Errors
    /// [`TrackError::Output`] naming the file.
    pub fn create(path: &Path) -> Result<Self, TrackError> {
        let out: Box<dyn Write> = if path == Path::new("-") {
            Box::new(std::io::stdout())
        } else {
            let file = File::create(path).map_err(|source| TrackError::Output {
                path: path.to_path_buf(),
                source,
            })?;
            Box::new(BufWriter::new(file))
        };
        Ok(Self {
            path: path.to_path_buf(),
            out,
        })
    }

    /// Appends one row and flushes it.
    ///
    /// # Errors
    /// [`TrackError::Output`] naming the file.
    pub fn write(&mut self, b: &BBox) -> Result<(), TrackError> {
        writeln!(self.out, "{}", box_row(b))
            .and_then(|()| self.out.flush())
            .map_err(|source| TrackError::Output {
                path: self.path.clone(),
                source,
            })
    }
}

/// Formats a box as an OTB result row `x,y,w,h` (at most 2 decimals,
/// trailing zeros dropped).
pub fn box_row(b: &BBox) -> String {
    let f = |v: f64| {
        let s = format!("{v:.2}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_string()
        } else {
            s.to_string()
        }
    };
    format!("{},{},{},{}", f(b.x), f(b.y), f(b.width), f(b.height))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_trackers::{Estimate, Result as TrackerResult};

    /// Moves its box one pixel right per frame; refuses frames of another
    /// size than the first.
    struct Drift {
        bbox: BBox,
        width: usize,
    }

    impl Tracker for Drift {
        fn name(&self) -> &'static str {
            "drift"
        }
        fn init(&mut self, frame: ImageView<'_, u8>, target: BBox) -> TrackerResult<()> {
            self.bbox = target;
            self.width = frame.width();
            Ok(())
        }
        fn step(&mut self, frame: ImageView<'_, u8>) -> TrackerResult<Estimate> {
            if frame.width() != self.width {
                return Err(TrackerError::NotInitialised);
            }
            self.bbox.x += 1.0;
            Ok(Estimate {
                bbox: self.bbox,
                pose: None,
                particles: 0,
                evaluations: 1,
                lost: false,
            })
        }
    }

    fn frames(widths: &[usize]) -> Vec<Image<u8>> {
        widths
            .iter()
            .map(|&w| Image::new(w, 4, 1, 0).unwrap())
            .collect()
    }

    fn bad(index: usize) -> OtbError {
        OtbError::IndexOutOfRange { index, len: 0 }
    }

    #[test]
    fn boxes_reach_the_sink_in_order_and_a_failure_keeps_them() {
        let images = frames(&[8, 8, 8, 9, 8]);
        let mut seen = Vec::new();
        let err = track_frames(
            &mut Drift {
                bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
                width: 0,
            },
            images.len(),
            |i| Ok(Cow::Borrowed(&images[i])),
            |i| PathBuf::from(format!("{i}.png")),
            BBox::new(1.0, 1.0, 2.0, 2.0),
            OnBadFrame::Stop,
            |f| {
                seen.push(f.bbox.x);
                Ok(())
            },
        )
        .unwrap_err();
        assert_eq!(seen, vec![1.0, 2.0, 3.0]);
        let msg = err.to_string();
        assert!(msg.contains("frame 4") && msg.contains("3.png"), "{msg}");
    }

    #[test]
    fn bad_frames_stop_or_repeat_the_last_box() {
        let images = frames(&[8, 8, 8, 8]);
        let load = |i: usize| {
            if i == 2 {
                Err(bad(i))
            } else {
                Ok(Cow::Borrowed(&images[i]))
            }
        };
        let mut tracker = Drift {
            bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
            width: 0,
        };
        let init = BBox::new(1.0, 1.0, 2.0, 2.0);
        let stop = track_frames(
            &mut tracker,
            4,
            load,
            |i| PathBuf::from(format!("{i}")),
            init,
            OnBadFrame::Stop,
            |_| Ok(()),
        );
        assert!(matches!(stop, Err(TrackError::Frame(_))));
        let run = track_frames(
            &mut tracker,
            4,
            load,
            |i| PathBuf::from(format!("{i}")),
            init,
            OnBadFrame::Skip,
            |_| Ok(()),
        )
        .unwrap();
        let xs: Vec<f64> = run.boxes.iter().map(|b| b.x).collect();
        assert_eq!(xs, vec![1.0, 2.0, 2.0, 3.0]);
        assert_eq!(run.skipped.len(), 1);
        assert_eq!(run.skipped[0].0, 2);
        // A bad first frame cannot be skipped.
        let first_bad = track_frames(
            &mut tracker,
            2,
            |i| Err(bad(i)),
            |i| PathBuf::from(format!("{i}")),
            init,
            OnBadFrame::Skip,
            |_| Ok(()),
        );
        assert!(matches!(first_bad, Err(TrackError::Frame(_))));
    }

    #[test]
    fn box_rows_are_short() {
        assert_eq!(box_row(&BBox::new(1.0, 2.5, 10.126, 3.0)), "1,2.5,10.13,3");
    }
}
