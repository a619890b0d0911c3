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
use std::path::PathBuf;
use std::time::Instant;

use bayestrack_image::{BBox, Image, ImageView};
use bayestrack_trackers::Tracker;

use crate::error::OtbError;
use crate::source::FrameSource;

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

/// One frame's outcome, handed to the sink.
#[derive(Debug, Clone, Copy)]
pub struct FrameBox<'a> {
    /// 0-based index of the frame in the run.
    pub index: usize,
    /// 1-based position of the frame in its source ([`Frame::number`](crate::source::Frame::number):
    /// the ground-truth row it belongs to); `index + 1` for
    /// [`track_frames`].
    pub number: usize,
    /// The frame's name ([`Frame::name`](crate::source::Frame::name), or its file for
    /// [`track_frames`]).
    pub name: &'a str,
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
    /// the reason: the first [`SKIPPED_LISTED`] of them
    /// ([`TrackRun::skipped_count`] counts them all), so the list does not
    /// grow with a long stream of bad frames.
    pub skipped: Vec<(usize, String)>,
    /// Frames skipped because they did not decode, all of them.
    pub skipped_count: usize,
    /// Frames on which the tracker reported the target lost.
    pub lost_frames: usize,
    /// Particles summed over frames (0 for deterministic trackers).
    pub particles: usize,
    /// The box the tracker was initialised with: the initial box, clipped
    /// to the first frame where it reaches outside ([`clip_initial_box`]).
    pub init: BBox,
    /// 1-based source positions of the frames run, one per box.
    pub numbers: Vec<usize>,
    /// Source positions of frames whose channel count differed from the
    /// first frame's and which were converted to it ([`track_source`]):
    /// the first [`CONVERTED_LISTED`] of them ([`TrackRun::converted_count`]
    /// counts them all), so the list does not grow with a long stream.
    pub converted: Vec<usize>,
    /// Frames converted to the first frame's channel count, all of them.
    pub converted_count: usize,
    /// Frames run (one box each), also where [`track_stream`] keeps no
    /// boxes.
    pub frames_run: usize,
}

/// How many skipped frames [`TrackRun::skipped`] lists.
pub const SKIPPED_LISTED: usize = 100;

/// How many converted frames [`TrackRun::converted`] lists.
pub const CONVERTED_LISTED: usize = 16;

impl TrackRun {
    /// Frames the tracker processed per second of its own time.
    pub fn fps(&self) -> f64 {
        let seen = self.frames_run - self.skipped_count;
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
/// [`OtbError::NoFramesToTrack`]; the frame's error ([`OtbError::Frame`])
/// for a frame that does not decode (always for frame 1, otherwise only
/// under [`OnBadFrame::Stop`]); [`OtbError::Tracker`] naming the frame the
/// tracker refused; whatever
/// the sink returns. Boxes handed to the sink before the error stay handed.
pub fn track_frames<'f, F, P, S>(
    tracker: &mut dyn Tracker,
    len: usize,
    mut frame: F,
    path: P,
    init: BBox,
    on_bad_frame: OnBadFrame,
    mut sink: S,
) -> Result<TrackRun, OtbError>
where
    F: FnMut(usize) -> Result<Cow<'f, Image<u8>>, OtbError>,
    P: Fn(usize) -> PathBuf,
    S: FnMut(FrameBox<'_>) -> Result<(), OtbError>,
{
    let frames = (0..len).map(|i| {
        frame(i).map(|image| Input {
            number: i + 1,
            name: path(i).display().to_string(),
            image,
        })
    });
    run_frames(
        tracker,
        frames,
        |index, _| path(index),
        |index, _| path(index).display().to_string(),
        false,
        true,
        init,
        on_bad_frame,
        &mut sink,
        |_| {},
    )
}

/// Clips an initial box (OTB convention: 1-based top-left corner) to a
/// `width x height` frame: the part inside, or `None` when less than one
/// pixel of it is inside (or it is not finite). A box wholly inside comes
/// back unchanged.
pub fn clip_initial_box(b: BBox, width: usize, height: usize) -> Option<BBox> {
    let (w, h) = (width as f64, height as f64);
    let (x0, y0) = (b.x - 1.0, b.y - 1.0);
    let (x1, y1) = (x0 + b.width, y0 + b.height);
    if ![x0, y0, x1, y1].iter().all(|v| v.is_finite()) {
        return None;
    }
    if x0 >= 0.0 && y0 >= 0.0 && x1 <= w && y1 <= h {
        return Some(b);
    }
    let (cx0, cy0, cx1, cy1) = (x0.max(0.0), y0.max(0.0), x1.min(w), y1.min(h));
    (cx1 - cx0 >= 1.0 && cy1 - cy0 >= 1.0)
        .then(|| BBox::new(cx0 + 1.0, cy0 + 1.0, cx1 - cx0, cy1 - cy0))
}

/// Brings `image` to `channels` (1 gray, 3 RGB) as the first frame of a run
/// had them: gray is replicated to RGB, RGB becomes gray by its luma (ITU-R
/// BT.601 weights). `None` when it already has them.
fn match_channels(image: &Image<u8>, channels: usize) -> Option<Image<u8>> {
    match (image.channels(), channels) {
        (a, b) if a == b => None,
        (1, 3) => bayestrack_image::gray_to_rgb(image.view()).ok(),
        (3, 1) => bayestrack_image::rgb_to_gray(image.view()).ok(),
        _ => None,
    }
}

/// Runs `tracker` over the frames `source` delivers, pulling one frame at
/// a time: each is decoded when asked for and dropped before the next, so
/// memory does not grow with the length of the sequence. `init` is the box
/// on the first frame delivered (clipped to it where it reaches outside,
/// [`clip_initial_box`]); `sink` receives every frame's box in order, as
/// soon as it is known.
///
/// Every frame is given the first frame's channel count: a gray frame in a
/// colour sequence is replicated to RGB, a colour frame in a gray sequence
/// becomes gray, and [`TrackRun::converted`] lists them, so a tracker never
/// sees its cues change kind part-way.
///
/// # Errors
/// [`OtbError::NoFramesToTrack`] when the source delivers none; the
/// frame's error ([`OtbError::Frame`], [`OtbError::Y4m`], ...) for a frame
/// that does not decode (always for the first, otherwise only under
/// [`OnBadFrame::Stop`]); [`OtbError::Tracker`] naming the frame the
/// tracker refused; whatever
/// the sink returns. Boxes handed to the sink before the error stay handed.
pub fn track_source<S>(
    tracker: &mut dyn Tracker,
    source: &mut dyn FrameSource,
    init: BBox,
    on_bad_frame: OnBadFrame,
    sink: S,
) -> Result<TrackRun, OtbError>
where
    S: FnMut(FrameBox<'_>) -> Result<(), OtbError>,
{
    source_loop(tracker, source, init, on_bad_frame, true, sink)
}

/// [`track_source`] for a source of any length (a camera, a Y4M stream of
/// millions of frames): the boxes go to `sink` only, and the returned
/// [`TrackRun`] keeps none ([`TrackRun::boxes`] and [`TrackRun::numbers`]
/// are empty, [`TrackRun::frames_run`] counts them), so memory stays the
/// same however long the source runs.
///
/// # Errors
/// As [`track_source`].
pub fn track_stream<S>(
    tracker: &mut dyn Tracker,
    source: &mut dyn FrameSource,
    init: BBox,
    on_bad_frame: OnBadFrame,
    sink: S,
) -> Result<TrackRun, OtbError>
where
    S: FnMut(FrameBox<'_>) -> Result<(), OtbError>,
{
    source_loop(tracker, source, init, on_bad_frame, false, sink)
}

fn source_loop<S>(
    tracker: &mut dyn Tracker,
    source: &mut dyn FrameSource,
    init: BBox,
    on_bad_frame: OnBadFrame,
    keep_boxes: bool,
    mut sink: S,
) -> Result<TrackRun, OtbError>
where
    S: FnMut(FrameBox<'_>) -> Result<(), OtbError>,
{
    let describe = source.describe();
    let pool = source.frame_pool();
    let frames = source.map(|r| {
        r.map(|f| Input {
            number: f.number,
            name: f.name,
            image: Cow::Owned(f.image),
        })
    });
    run_frames(
        tracker,
        frames,
        |_, name| PathBuf::from(format!("{describe}: {name}")),
        |_, number| format!("frame {number}"),
        true,
        keep_boxes,
        init,
        on_bad_frame,
        &mut sink,
        |image| {
            if let Some(pool) = &pool {
                pool.give_back(image);
            }
        },
    )
}

/// A frame for [`run_frames`]: its 1-based position in its source, its
/// name and its pixels.
struct Input<'f> {
    number: usize,
    name: String,
    image: Cow<'f, Image<u8>>,
}

/// The loop behind [`track_frames`] and [`track_source`]: `error_path(index,
/// name)` names a frame the tracker refused, `skipped_name(index, number)` a
/// frame that did not decode (the stream says which position failed only
/// through the next good frame: the failed one is the one after the last);
/// with `convert_channels` every frame is brought to the first frame's
/// channel count ([`TrackRun::converted`]). A frame's own pixels go to
/// `give_back` once the sink has had them (a source's [`bayestrack_image::FramePool`]).
#[allow(clippy::too_many_arguments)]
fn run_frames<'f, S>(
    tracker: &mut dyn Tracker,
    mut frames: impl Iterator<Item = Result<Input<'f>, OtbError>>,
    error_path: impl Fn(usize, &str) -> PathBuf,
    skipped_name: impl Fn(usize, usize) -> String,
    convert_channels: bool,
    keep_boxes: bool,
    init: BBox,
    on_bad_frame: OnBadFrame,
    sink: &mut S,
    mut give_back: impl FnMut(Image<u8>),
) -> Result<TrackRun, OtbError>
where
    S: FnMut(FrameBox<'_>) -> Result<(), OtbError>,
{
    let name = tracker.name();
    let refused = |frame: &Input<'_>, index: usize| {
        let path = error_path(index, &frame.name);
        move |source| OtbError::Tracker {
            tracker: name,
            frame: index + 1,
            path,
            source: Box::new(source),
        }
    };
    let capacity = if keep_boxes { frames.size_hint().0 } else { 0 };
    let first = frames.next().ok_or(OtbError::NoFramesToTrack)??;
    let channels = first.image.channels();
    let init = clip_initial_box(init, first.image.width(), first.image.height()).unwrap_or(init);
    let mut run = TrackRun {
        boxes: Vec::with_capacity(capacity + 1),
        tracker_seconds: 0.0,
        skipped: Vec::new(),
        skipped_count: 0,
        lost_frames: 0,
        particles: 0,
        init,
        numbers: Vec::with_capacity(capacity + 1),
        converted: Vec::new(),
        converted_count: 0,
        frames_run: 0,
    };
    let record = |run: &mut TrackRun, bbox: BBox, number: usize| {
        run.frames_run += 1;
        if keep_boxes {
            run.boxes.push(bbox);
            run.numbers.push(number);
        }
    };
    let start = Instant::now();
    tracker
        .init(first.image.view(), init)
        .map_err(refused(&first, 0))?;
    run.tracker_seconds += start.elapsed().as_secs_f64();
    record(&mut run, init, first.number);
    sink(FrameBox {
        index: 0,
        number: first.number,
        name: &first.name,
        bbox: init,
        frame: Some(first.image.view()),
        lost: false,
    })?;
    let mut previous = first.number;
    if let Cow::Owned(image) = first.image {
        give_back(image);
    }

    let mut last = init;
    for (index, next) in (1..).zip(frames) {
        let mut frame = match next {
            Ok(frame) => frame,
            Err(e) if on_bad_frame == OnBadFrame::Skip => {
                let number = previous + 1;
                previous = number;
                if run.skipped.len() < SKIPPED_LISTED {
                    run.skipped.push((index, e.to_string()));
                }
                run.skipped_count += 1;
                record(&mut run, last, number);
                sink(FrameBox {
                    index,
                    number,
                    name: &skipped_name(index, number),
                    bbox: last,
                    frame: None,
                    lost: false,
                })?;
                continue;
            }
            Err(e) => return Err(e),
        };
        previous = frame.number;
        if convert_channels && let Some(converted) = match_channels(&frame.image, channels) {
            frame.image = Cow::Owned(converted);
            if run.converted.len() < CONVERTED_LISTED {
                run.converted.push(frame.number);
            }
            run.converted_count += 1;
        }
        let start = Instant::now();
        let estimate = tracker
            .step(frame.image.view())
            .map_err(refused(&frame, index))?;
        run.tracker_seconds += start.elapsed().as_secs_f64();
        last = estimate.bbox;
        run.lost_frames += usize::from(estimate.lost);
        run.particles += estimate.particles;
        record(&mut run, last, frame.number);
        sink(FrameBox {
            index,
            number: frame.number,
            name: &frame.name,
            bbox: last,
            frame: Some(frame.image.view()),
            lost: estimate.lost,
        })?;
        if let Cow::Owned(image) = frame.image {
            give_back(image);
        }
    }
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_trackers::{Estimate, Result as TrackerResult, TrackerError};

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
        assert!(matches!(stop, Err(OtbError::IndexOutOfRange { .. })));
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
        assert_eq!((run.skipped.len(), run.skipped_count), (1, 1));
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
        assert!(matches!(first_bad, Err(OtbError::IndexOutOfRange { .. })));
    }

    /// A Y4M stream of `n` 8x4 gray frames.
    fn gray_stream(n: usize) -> Vec<u8> {
        let mut out = b"YUV4MPEG2 W8 H4 Cmono\n".to_vec();
        for k in 0..n {
            out.extend(b"FRAME\n");
            out.extend(std::iter::repeat_n((k % 200) as u8, 32));
        }
        out
    }

    /// What a run keeps per frame stays bounded on a long stream: no box,
    /// no number, at most [`CONVERTED_LISTED`] converted frames (issue 28:
    /// about 80 bytes a frame over millions of frames).
    #[test]
    fn a_folder_run_hands_each_frames_pixels_back_to_its_pool() {
        let dir = std::env::temp_dir().join(format!("bayestrack-otb-pool-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let paths: Vec<PathBuf> = (1..=30)
            .map(|n| {
                let p = dir.join(format!("{n:04}.png"));
                let img = Image::from_fn(8, 4, |x, y| (x + y + n) as u8).unwrap();
                bayestrack_image::write_png(&p, img.view()).unwrap();
                p
            })
            .collect();
        let init = BBox::new(1.0, 1.0, 2.0, 2.0);
        let run_with = |ahead: usize| {
            let source = crate::source::FolderSource::new(&dir, &paths);
            let pool = source.frame_pool().unwrap();
            let mut boxes = Vec::new();
            let mut drift = Drift {
                bbox: init,
                width: 0,
            };
            let mut sink = |f: FrameBox<'_>| {
                boxes.push(f.bbox);
                Ok(())
            };
            let run = if ahead == 0 {
                let mut source = source;
                track_stream(&mut drift, &mut source, init, OnBadFrame::Stop, &mut sink)
            } else {
                std::thread::scope(|scope| {
                    let mut ahead =
                        crate::source::DecodeAhead::with_threads(scope, source, ahead, 2);
                    assert!(ahead.frame_pool().is_some());
                    track_stream(&mut drift, &mut ahead, init, OnBadFrame::Stop, &mut sink)
                })
            };
            assert_eq!(run.unwrap().frames_run, 30);
            (boxes, pool.len())
        };
        // in turn: the one buffer goes round; ahead: as many as were in
        // flight at once (at most the depth, the threads and the frame in
        // hand), never one a frame
        let (boxes, held) = run_with(0);
        assert_eq!(held, 1);
        let (ahead, held) = run_with(3);
        assert_eq!(ahead, boxes);
        assert!((1..=6).contains(&held), "{held} buffers held");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_streamed_run_keeps_nothing_per_frame() {
        let bytes = gray_stream(5000);
        let mut source = crate::source::Y4mSource::new(&bytes[..], "long").unwrap();
        let mut sunk = 0;
        let run = track_stream(
            &mut Drift {
                bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
                width: 0,
            },
            &mut source,
            BBox::new(1.0, 1.0, 2.0, 2.0),
            OnBadFrame::Stop,
            |_| {
                sunk += 1;
                Ok(())
            },
        )
        .unwrap();
        assert_eq!((run.frames_run, sunk), (5000, 5000));
        assert!(run.boxes.is_empty() && run.numbers.is_empty());
        assert!(run.boxes.capacity() <= 1 && run.numbers.capacity() <= 1);
        assert!(run.fps() > 0.0);
        // a source of colour frames after a gray one lists only the first
        // converted frames, and counts them all
        let mut colour = b"YUV4MPEG2 W8 H4 C444\n".to_vec();
        for _ in 0..100 {
            colour.extend(b"FRAME\n");
            colour.extend([128u8; 96]);
        }
        let mut frames = crate::source::Y4mSource::new(&bytes[..32 + 6 + 22], "g")
            .unwrap()
            .chain(crate::source::Y4mSource::new(&colour[..], "c").unwrap());
        struct Chain<I>(I);
        impl<I: Iterator<Item = Result<crate::source::Frame, OtbError>>> Iterator for Chain<I> {
            type Item = I::Item;
            fn next(&mut self) -> Option<Self::Item> {
                self.0.next()
            }
        }
        impl<I: Iterator<Item = Result<crate::source::Frame, OtbError>>> FrameSource for Chain<I> {
            fn describe(&self) -> String {
                "chain".into()
            }
            fn remaining(&self) -> Option<usize> {
                None
            }
        }
        let mut chain = Chain(frames.by_ref());
        let run = track_stream(
            &mut Drift {
                bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
                width: 0,
            },
            &mut chain,
            BBox::new(1.0, 1.0, 2.0, 2.0),
            OnBadFrame::Stop,
            |_| Ok(()),
        )
        .unwrap();
        assert_eq!(run.converted_count, 100);
        assert_eq!(run.converted.len(), CONVERTED_LISTED);
        // every other frame with a broken FRAME line, skipped: the reasons
        // are listed for the first SKIPPED_LISTED, counted for all
        let mut broken = gray_stream(300);
        for k in (1..300).step_by(2) {
            let at = 22 + k * 38;
            broken[at..at + 5].copy_from_slice(b"FRAMX");
        }
        let mut source = crate::source::Y4mSource::new(&broken[..], "broken").unwrap();
        let run = track_stream(
            &mut Drift {
                bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
                width: 0,
            },
            &mut source,
            BBox::new(1.0, 1.0, 2.0, 2.0),
            OnBadFrame::Skip,
            |_| Ok(()),
        )
        .unwrap();
        assert_eq!(run.frames_run, 300);
        assert_eq!(
            (run.skipped.len(), run.skipped_count),
            (SKIPPED_LISTED, 150)
        );
    }
}
