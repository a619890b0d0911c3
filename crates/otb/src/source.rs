//! Frame sources: where the tracking loop (`track::track_source`, feature
//! `track`) pulls its frames from, one at a time.
//!
//! A [`FrameSource`] is an iterator of decoded frames with their names. It
//! streams: a frame is decoded when the loop asks for it and dropped before
//! the next is asked for, so memory does not grow with the length of the
//! sequence, and a decoder or a camera plugs in by implementing the trait.
//! Implementations: [`FolderSource`] (a list of PNG/JPEG frame files: a
//! folder of numbered frames or an OTB sequence,
//! [`crate::sequence::Sequence::source`]),
//! [`Y4mSource`] (YUV4MPEG2 from standard input or a file) and
//! [`VideoSource`] (any video file, decoded by piping it through an
//! `ffmpeg` executable). [`Select`] runs any of them on a range of frames
//! and on every Nth frame. [`DecodeAhead`] runs any of them on a second
//! thread a few frames ahead of the loop, so that decoding overlaps
//! tracking (same frames, same order, same errors).

use std::collections::VecDeque;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::{JoinHandle, Scope};
use std::time::{Duration, Instant};

use bayestrack_image::{FramePool, Image, ImageError};

use crate::error::OtbError;
use crate::y4m::Y4mReader;

/// One decoded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// 1-based position of the frame in its source, before any selection
    /// ([`Select`]); the ground-truth row that belongs to it.
    pub number: usize,
    /// The frame's name for messages and drawn files: its file name
    /// (`0300.jpg`) or, in a stream, `frame 12`.
    pub name: String,
    /// The pixels: 1 channel (gray) or 3 (RGB).
    pub image: Image<u8>,
}

/// A stream of decoded frames, pulled one at a time.
pub trait FrameSource: Iterator<Item = Result<Frame, OtbError>> {
    /// What the frames come from (`folder ../David`, `stdin`, `clip.mp4`),
    /// for messages.
    fn describe(&self) -> String;

    /// Frames left to deliver, when the source knows (a folder does, a
    /// stream does not): for progress and its time estimate.
    fn remaining(&self) -> Option<usize>;

    /// Passes over the next frame without decoding it where the source can
    /// (a folder only moves on; a stream still reads the bytes). `None` at
    /// the end.
    ///
    /// # Errors
    /// Those of reading the frame, where it has to be read.
    fn skip_frame(&mut self) -> Option<Result<(), OtbError>> {
        self.next().map(|r| r.map(|_| ()))
    }

    /// Takes the next frame without decoding it yet, where the source can
    /// (a folder: each frame is its own file), so that [`DecodeAhead`]
    /// decodes several at once on as many threads; `None` at the end.
    /// [`PendingFrame::decode`] gives what [`Iterator::next`] would have.
    /// The default decodes now (a stream has to be read in order).
    fn next_pending(&mut self) -> Option<PendingFrame> {
        self.next().map(PendingFrame::ready)
    }

    /// Where a frame's pixels go once the consumer is done with them, for
    /// the next frames to be decoded into (a folder's frames:
    /// [`FramePool`]); `None` where the source reuses none.
    fn frame_pool(&self) -> Option<FramePool> {
        None
    }
}

/// A frame taken from a [`FrameSource`] ([`FrameSource::next_pending`]),
/// decoded by [`PendingFrame::decode`] on whatever thread calls it.
pub struct PendingFrame(Pending);

enum Pending {
    Ready(Result<Frame, OtbError>),
    Later(Box<dyn FnOnce() -> Result<Frame, OtbError> + Send>),
}

impl std::fmt::Debug for PendingFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Pending::Ready(item) => f.debug_tuple("PendingFrame::ready").field(item).finish(),
            Pending::Later(_) => f.write_str("PendingFrame::later(..)"),
        }
    }
}

impl PendingFrame {
    /// A frame (or the error of reading it) already decoded.
    pub fn ready(item: Result<Frame, OtbError>) -> Self {
        Self(Pending::Ready(item))
    }

    /// A frame that `decode` decodes when asked (it must not depend on the
    /// frames taken after it: they may be decoded first).
    pub fn later(decode: impl FnOnce() -> Result<Frame, OtbError> + Send + 'static) -> Self {
        Self(Pending::Later(Box::new(decode)))
    }

    /// The frame, or the error of decoding it.
    ///
    /// # Errors
    /// Those of reading the frame.
    pub fn decode(self) -> Result<Frame, OtbError> {
        match self.0 {
            Pending::Ready(item) => item,
            Pending::Later(decode) => decode(),
        }
    }
}

/// A list of frame files (a folder of numbered frames or an OTB sequence,
/// [`crate::sequence::Sequence::source`]), decoded one by one in order.
#[derive(Debug, Clone)]
pub struct FolderSource<'a> {
    dir: &'a Path,
    frames: &'a [PathBuf],
    next: usize,
    pool: FramePool,
}

impl<'a> FolderSource<'a> {
    /// The files `frames` of the folder `dir` (which names the source in
    /// [`FrameSource::describe`]), from the first.
    pub fn new(dir: &'a Path, frames: &'a [PathBuf]) -> Self {
        Self {
            dir,
            frames,
            next: 0,
            pool: FramePool::new(),
        }
    }
}

/// The file name of `path` (`0300.jpg`), or the whole path when it has
/// none.
pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Decodes frame `index` (0-based) from `path` with `read`, naming the
/// index and the file in the error ([`OtbError::Frame`]).
pub(crate) fn decode_numbered(
    index: usize,
    path: &Path,
    read: impl FnOnce(&Path) -> Result<Image<u8>, ImageError>,
) -> Result<Image<u8>, OtbError> {
    read(path).map_err(|source| OtbError::Frame {
        index,
        path: path.to_path_buf(),
        source: Box::new(source),
    })
}

impl Iterator for FolderSource<'_> {
    type Item = Result<Frame, OtbError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_pending().map(PendingFrame::decode)
    }
}

impl FrameSource for FolderSource<'_> {
    fn next_pending(&mut self) -> Option<PendingFrame> {
        let index = self.next;
        let path = self.frames.get(index)?.clone();
        self.next += 1;
        let pool = self.pool.clone();
        Some(PendingFrame::later(move || {
            decode_numbered(index, &path, |p| pool.read_frame(p)).map(|image| Frame {
                number: index + 1,
                name: file_name(&path),
                image,
            })
        }))
    }

    fn describe(&self) -> String {
        format!("folder {}", self.dir.display())
    }

    fn remaining(&self) -> Option<usize> {
        Some(self.frames.len() - self.next)
    }

    fn skip_frame(&mut self) -> Option<Result<(), OtbError>> {
        (self.next < self.frames.len()).then(|| {
            self.next += 1;
            Ok(())
        })
    }

    fn frame_pool(&self) -> Option<FramePool> {
        Some(self.pool.clone())
    }
}

/// YUV4MPEG2 frames from any byte stream: standard input (`--seq -`), a
/// `.y4m` file, a pipe ([`crate::y4m`] describes the format).
#[derive(Debug)]
pub struct Y4mSource<R: Read> {
    reader: Y4mReader<R>,
}

impl Y4mSource<std::io::Stdin> {
    /// Y4M on standard input, as `ffmpeg -i clip.mp4 -f yuv4mpegpipe -`
    /// writes it; its header is read now.
    ///
    /// # Errors
    /// [`OtbError::Y4m`] for an empty stream or a bad header.
    pub fn stdin() -> Result<Self, OtbError> {
        Self::new(std::io::stdin(), "stdin")
    }
}

impl Y4mSource<std::fs::File> {
    /// A `.y4m` file; its header is read now.
    ///
    /// # Errors
    /// [`OtbError::Read`] naming a file that cannot be opened;
    /// [`OtbError::Y4m`] for a bad header.
    pub fn open(path: &Path) -> Result<Self, OtbError> {
        let file = std::fs::File::open(path).map_err(|source| OtbError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(file, path.display().to_string())
    }
}

impl<R: Read> Y4mSource<R> {
    /// Y4M from `input`, named `name` in errors; its header is read now.
    ///
    /// # Errors
    /// [`OtbError::Y4m`] for an empty stream or a bad header.
    pub fn new(input: R, name: impl Into<String>) -> Result<Self, OtbError> {
        Ok(Self {
            reader: Y4mReader::new(input, name)?,
        })
    }

    /// The stream header (size, frame rate, colour space).
    pub fn header(&self) -> &crate::y4m::Y4mHeader {
        self.reader.header()
    }
}

impl<R: Read> Iterator for Y4mSource<R> {
    type Item = Result<Frame, OtbError>;

    fn next(&mut self) -> Option<Self::Item> {
        let image = self.reader.next_image()?;
        let number = self.reader.frames_read();
        Some(image.map(|image| Frame {
            number,
            name: format!("frame {number}"),
            image,
        }))
    }
}

impl<R: Read> FrameSource for Y4mSource<R> {
    fn describe(&self) -> String {
        self.reader.name().to_string()
    }

    fn remaining(&self) -> Option<usize> {
        None
    }

    fn skip_frame(&mut self) -> Option<Result<(), OtbError>> {
        self.reader.skip_image()
    }
}

/// The environment variable that names the `ffmpeg` executable
/// [`VideoSource`] runs (default: `ffmpeg` on `PATH`).
pub const FFMPEG_ENV: &str = "BAYESTRACK_FFMPEG";

/// A video file decoded by an `ffmpeg` child process that pipes it as Y4M
/// (`ffmpeg -i <file> -f yuv4mpegpipe -pix_fmt yuv444p -`): any format
/// ffmpeg reads, with no video library linked. The child is stopped when
/// the source is dropped (a run on the first frames of a long video does
/// not decode the rest).
pub struct VideoSource {
    path: PathBuf,
    child: Child,
    frames: Y4mSource<ChildStdout>,
    stderr: Option<JoinHandle<String>>,
    finished: bool,
}

impl std::fmt::Debug for VideoSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoSource")
            .field("path", &self.path)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl VideoSource {
    /// Starts decoding `path` with the `ffmpeg` on `PATH` (or the one
    /// [`FFMPEG_ENV`] names) and reads the stream header.
    ///
    /// # Errors
    /// [`OtbError::NoFfmpeg`] (saying how to get one) when there is no such
    /// executable; [`OtbError::Video`] with ffmpeg's own message when it
    /// cannot read the file.
    pub fn open(path: &Path) -> Result<Self, OtbError> {
        let program = std::env::var_os(FFMPEG_ENV).unwrap_or_else(|| "ffmpeg".into());
        if !path.is_file() {
            return Err(OtbError::Video {
                video: path.to_path_buf(),
                reason: "no such file".to_string(),
            });
        }
        let mut child = Command::new(&program)
            .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-i"])
            .arg(path)
            .args(["-f", "yuv4mpegpipe", "-pix_fmt", "yuv444p", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                if e.kind() == std::io::ErrorKind::NotFound {
                    OtbError::NoFfmpeg {
                        video: path.to_path_buf(),
                        program: program.to_string_lossy().into_owned(),
                    }
                } else {
                    OtbError::Video {
                        video: path.to_path_buf(),
                        reason: format!("cannot run {}: {e}", program.to_string_lossy()),
                    }
                }
            })?;
        let stderr = child.stderr.take().map(|mut err| {
            std::thread::spawn(move || {
                let mut text = String::new();
                let _ = err.read_to_string(&mut text);
                text
            })
        });
        let stdout = child.stdout.take().ok_or_else(|| OtbError::Video {
            video: path.to_path_buf(),
            reason: "ffmpeg's output could not be read".to_string(),
        })?;
        let source = match Y4mSource::new(stdout, path.display().to_string()) {
            Ok(frames) => frames,
            Err(e) => {
                let status = child.wait().ok();
                let said = stderr.and_then(|h| h.join().ok()).unwrap_or_default();
                return Err(OtbError::Video {
                    video: path.to_path_buf(),
                    reason: ffmpeg_reason(status, &said, &e),
                });
            }
        };
        Ok(Self {
            path: path.to_path_buf(),
            child,
            frames: source,
            stderr,
            finished: false,
        })
    }

    /// The stream header ffmpeg wrote (size, frame rate).
    pub fn header(&self) -> &crate::y4m::Y4mHeader {
        self.frames.header()
    }

    /// At the end of the stream: ffmpeg's exit status decides whether the
    /// video ended or decoding failed.
    fn finish(&mut self) -> Option<Result<Frame, OtbError>> {
        if self.finished {
            return None;
        }
        self.finished = true;
        let status = self.child.wait().ok();
        let said = self
            .stderr
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default();
        match status {
            Some(s) if s.success() => None,
            _ => Some(Err(OtbError::Video {
                video: self.path.clone(),
                reason: format!(
                    "ffmpeg stopped after frame {} ({}): {}",
                    self.frames.reader.frames_read(),
                    status.map_or("no exit status".to_string(), |s| s.to_string()),
                    last_lines(&said)
                ),
            })),
        }
    }
}

fn last_lines(text: &str) -> String {
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let tail = &lines[lines.len().saturating_sub(3)..];
    if tail.is_empty() {
        "it said nothing".to_string()
    } else {
        tail.join(" / ")
    }
}

fn ffmpeg_reason(status: Option<std::process::ExitStatus>, said: &str, e: &OtbError) -> String {
    match status {
        Some(s) if !s.success() => format!("ffmpeg failed ({s}): {}", last_lines(said)),
        _ => format!("ffmpeg's output is not a Y4M stream: {e}"),
    }
}

impl Iterator for VideoSource {
    type Item = Result<Frame, OtbError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.finished {
            return None;
        }
        match self.frames.next() {
            Some(frame) => Some(frame),
            None => self.finish(),
        }
    }
}

impl FrameSource for VideoSource {
    fn describe(&self) -> String {
        self.path.display().to_string()
    }

    fn remaining(&self) -> Option<usize> {
        None
    }

    fn skip_frame(&mut self) -> Option<Result<(), OtbError>> {
        if self.finished {
            return None;
        }
        match self.frames.skip_frame() {
            Some(r) => Some(r),
            None => self.finish().map(|r| r.map(|_| ())),
        }
    }
}

impl Drop for VideoSource {
    fn drop(&mut self) {
        if !self.finished {
            // A run that stopped early: stop decoding the rest.
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Which frames of a source to run on: `first..=last` (1-based positions,
/// inclusive; `last` `None` for the end) and every `every`th of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSelection {
    /// First frame, 1-based.
    pub first: usize,
    /// Last frame, inclusive (`None`: to the end).
    pub last: Option<usize>,
    /// Run on every `every`th frame from `first` (1: every frame).
    pub every: usize,
}

impl Default for FrameSelection {
    fn default() -> Self {
        Self {
            first: 1,
            last: None,
            every: 1,
        }
    }
}

impl FrameSelection {
    /// Parses `a..b` (1-based, inclusive), `a..` (to the end) or `a` (one
    /// frame), with `every` from `--every`.
    ///
    /// # Errors
    /// A message for text that is not such a range, a frame 0, `b < a` or
    /// `every` 0.
    pub fn parse(range: Option<&str>, every: usize) -> Result<Self, String> {
        if every == 0 {
            return Err("--every must be at least 1".to_string());
        }
        let Some(range) = range else {
            return Ok(Self {
                every,
                ..Self::default()
            });
        };
        let num = |s: &str| {
            s.trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| {
                    format!(
                        "`{range}`: expected frames a..b (1-based, inclusive), a.. or a, with \
                         whole numbers from 1"
                    )
                })
        };
        let (first, last) = match range.split_once("..") {
            Some((a, b)) if b.trim().is_empty() => (num(a)?, None),
            Some((a, b)) => (num(a)?, Some(num(b.trim_start_matches('='))?)),
            None => {
                let a = num(range)?;
                (a, Some(a))
            }
        };
        if last.is_some_and(|b| b < first) {
            return Err(format!("`{range}`: the last frame is before the first"));
        }
        Ok(Self { first, last, every })
    }

    /// Whether frame `number` (1-based) is run.
    pub fn contains(&self, number: usize) -> bool {
        number >= self.first
            && self.last.is_none_or(|b| number <= b)
            && (number - self.first).is_multiple_of(self.every)
    }

    /// How many of `total` frames are run.
    pub fn count(&self, total: usize) -> usize {
        let last = self.last.map_or(total, |b| b.min(total));
        if last < self.first {
            0
        } else {
            (last - self.first) / self.every + 1
        }
    }
}

/// A source restricted to a [`FrameSelection`]: frames outside it are
/// passed over without decoding where the source allows, and nothing after
/// the last selected frame is read.
#[derive(Debug)]
pub struct Select<S> {
    inner: S,
    selection: FrameSelection,
    position: usize,
    total: Option<usize>,
}

impl<S: FrameSource> Select<S> {
    /// Runs `inner` on the frames `selection` picks.
    pub fn new(inner: S, selection: FrameSelection) -> Self {
        let total = inner.remaining();
        Self {
            inner,
            selection,
            position: 0,
            total,
        }
    }
}

impl<S: FrameSource> Select<S> {
    /// Passes over the frames before the next selected one: `Some(Ok(()))`
    /// when the inner source's next frame is that one, the error of passing
    /// over a frame, or `None` after the last.
    fn pass_unselected(&mut self) -> Option<Result<(), OtbError>> {
        loop {
            let number = self.position + 1;
            if self.selection.last.is_some_and(|b| number > b) {
                return None;
            }
            if self.selection.contains(number) {
                self.position += 1;
                return Some(Ok(()));
            }
            match self.inner.skip_frame()? {
                Ok(()) => self.position += 1,
                Err(e) => {
                    self.position += 1;
                    return Some(Err(e));
                }
            }
        }
    }
}

impl<S: FrameSource> Iterator for Select<S> {
    type Item = Result<Frame, OtbError>;

    fn next(&mut self) -> Option<Self::Item> {
        match self.pass_unselected()? {
            Ok(()) => self.inner.next(),
            Err(e) => Some(Err(e)),
        }
    }
}

impl<S: FrameSource> FrameSource for Select<S> {
    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn remaining(&self) -> Option<usize> {
        let total = self.total?;
        let all = self.selection.count(total);
        let done = FrameSelection {
            last: Some(self.position),
            ..self.selection
        }
        .count(total);
        Some(all - done.min(all))
    }

    fn next_pending(&mut self) -> Option<PendingFrame> {
        match self.pass_unselected()? {
            Ok(()) => self.inner.next_pending(),
            Err(e) => Some(PendingFrame::ready(Err(e))),
        }
    }

    fn frame_pool(&self) -> Option<FramePool> {
        self.inner.frame_pool()
    }
}

impl<S: FrameSource + ?Sized> FrameSource for Box<S> {
    fn describe(&self) -> String {
        (**self).describe()
    }

    fn remaining(&self) -> Option<usize> {
        (**self).remaining()
    }

    fn skip_frame(&mut self) -> Option<Result<(), OtbError>> {
        (**self).skip_frame()
    }

    fn next_pending(&mut self) -> Option<PendingFrame> {
        (**self).next_pending()
    }

    fn frame_pool(&self) -> Option<FramePool> {
        (**self).frame_pool()
    }
}

/// One item a [`DecodeAhead`] thread hands over: what the source's `next`
/// returned, and what its `remaining` said right after.
struct Ahead {
    item: Option<Result<Frame, OtbError>>,
    remaining: Option<usize>,
}

/// The source, shared by the decoding threads: one at a time takes the
/// next frame from it, in order.
struct Feed<S> {
    source: S,
    /// Frames (and the end) taken from the source so far.
    taken: usize,
    /// The source has ended: nothing more to take.
    ended: bool,
}

/// What the decoding threads hand over, and to whom.
struct Handover {
    queue: Mutex<Queue>,
    /// The consumer waits here for the next item in order.
    ready: Condvar,
    /// The thread that holds the source waits here for room.
    room: Condvar,
    /// The helpers (the decoding threads after the first) wait here until
    /// the consumer has spent half its time waiting for frames
    /// ([`Queue::engaged`]) or the run is over.
    wanted: Condvar,
    /// Items taken from the source and not yet handed to the consumer, at
    /// most (queued, or being decoded).
    limit: usize,
}

struct Queue {
    /// Items from number `delivered` on, in source order; `None` where
    /// that frame is still being decoded.
    items: VecDeque<Option<Ahead>>,
    /// Items handed to the consumer so far.
    delivered: usize,
    /// The consumer dropped the [`DecodeAhead`]: stop.
    gone: bool,
    /// A decoding thread panicked (the scope passes the panic on).
    failed: bool,
    /// The consumer has spent half its time waiting for frames: decoding
    /// is the bottleneck, so the helpers decode too.
    engaged: bool,
    /// The source has ended: a helper still waiting has nothing to do.
    done: bool,
}

impl Handover {
    fn queue(&self) -> MutexGuard<'_, Queue> {
        // Nothing panics while holding this lock; a poisoned one still has
        // consistent contents.
        self.queue.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Marks a decoding thread's panic in the hand-over, so that the consumer
/// and the other threads stop waiting for it.
struct PanicGuard<'a>(&'a Handover);

impl Drop for PanicGuard<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.queue().failed = true;
            self.0.ready.notify_all();
            self.0.room.notify_all();
            self.0.wanted.notify_all();
        }
    }
}

/// A source decoded on other threads, up to `depth` frames ahead of the
/// loop that pulls them, on up to `threads` threads at once (memory stays
/// at `depth + threads + 1` frames whatever the length of the source:
/// those queued or being decoded, and the one the loop holds).
///
/// One thread decodes from the start; the others (helpers) wait until the
/// loop has spent half its time waiting for frames since its first (over
/// at least 4 ms, in windows of 100 ms), the sign
/// that decoding is well behind (a tracker taking less than half a
/// frame's decoding time), and then decode too. Behind a slower tracker
/// the first thread keeps up alone and the helpers never run: on the
/// 2-core machine (2026-12-04) a second decoding thread made the whole
/// run 1.7-1.9x faster behind trackers that wait 60 % of the time (mad,
/// pf-correlation), no faster behind those that wait 20-35 % (ball-kf,
/// ncc-scale; it adds a quarter to the run's CPU time) and 5-15 % slower
/// behind those that hardly wait (dcf, hkpf, condensation-contour).
///
/// The frames, their order, their errors and the end of the stream are
/// those of the wrapped source, item for item, whatever the number of
/// threads: a frame that does not decode comes out as the same error at
/// the same place, after the frames before it. Only the time moves: the
/// next frames are decoded while the caller tracks this one, so on a
/// machine with two cores decoding no longer adds to the time of a run.
/// Several threads decode several frames at once only for a source that
/// takes its frames undecoded ([`FrameSource::next_pending`]: a folder of
/// frame files); a stream is read by one thread at a time, in order.
///
/// The threads are scoped ([`std::thread::scope`]), so the source may
/// borrow (a [`FolderSource`] borrows its sequence). When the
/// `DecodeAhead` is dropped (the run ended, failed or stopped early) the
/// threads stop after the frame each is decoding, with at most `depth +
/// threads` frames decoded for nothing. A source that blocks (standard
/// input with no writer) holds the end of the scope until it delivers or
/// ends. Waiting threads sleep (no busy-waiting).
///
/// ```
/// use bayestrack_otb::{DecodeAhead, Frame, FrameSource, OtbError};
/// # use bayestrack_image::Image;
/// # struct Numbers(usize);
/// # impl Iterator for Numbers {
/// #     type Item = Result<Frame, OtbError>;
/// #     fn next(&mut self) -> Option<Self::Item> {
/// #         (self.0 < 5).then(|| {
/// #             self.0 += 1;
/// #             Ok(Frame { number: self.0, name: format!("frame {}", self.0),
/// #                        image: Image::new(4, 4, 1, 0u8).unwrap() })
/// #         })
/// #     }
/// # }
/// # impl FrameSource for Numbers {
/// #     fn describe(&self) -> String { "numbers".into() }
/// #     fn remaining(&self) -> Option<usize> { Some(5 - self.0) }
/// # }
/// let numbers: Vec<usize> = std::thread::scope(|scope| {
///     let ahead = DecodeAhead::with_threads(scope, Numbers(0), 2, 2);
///     ahead.map(|f| f.unwrap().number).collect()
/// });
/// assert_eq!(numbers, [1, 2, 3, 4, 5]);
/// ```
pub struct DecodeAhead {
    handover: Arc<Handover>,
    describe: String,
    remaining: Option<usize>,
    pool: Option<FramePool>,
    ended: bool,
    /// Since when the consumer's waiting is being measured (from its first
    /// frame on; restarted every `ENGAGE_WINDOW`), and how long it has
    /// waited since then.
    window: Option<(Instant, Duration)>,
}

/// How long the consumer must have run since its first frame (or the
/// window's start) before its waiting engages the helpers.
const ENGAGE_AFTER: Duration = Duration::from_millis(4);

/// The window over which the consumer's waiting is measured: a slow start
/// (a tracker's first frames) is forgotten after it.
const ENGAGE_WINDOW: Duration = Duration::from_millis(100);

/// How often a waiting consumer checks whether to engage the helpers.
const ENGAGE_POLL: Duration = Duration::from_millis(1);

impl std::fmt::Debug for DecodeAhead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DecodeAhead")
            .field("source", &self.describe)
            .field("remaining", &self.remaining)
            .finish_non_exhaustive()
    }
}

impl DecodeAhead {
    /// Starts decoding `source` on one thread of `scope`, at most `depth`
    /// frames ahead ([`DecodeAhead::with_threads`] with 1 thread).
    pub fn new<'scope, 'env, S>(scope: &'scope Scope<'scope, 'env>, source: S, depth: usize) -> Self
    where
        S: FrameSource + Send + 'scope,
    {
        Self::with_threads(scope, source, depth, 1)
    }

    /// Starts decoding `source` on `threads` threads of `scope` (0 counts
    /// as 1), at most `depth` frames ahead (a `depth` of 0 counts as 1: the
    /// threads decode the next frames while the caller works on this one).
    pub fn with_threads<'scope, 'env, S>(
        scope: &'scope Scope<'scope, 'env>,
        source: S,
        depth: usize,
        threads: usize,
    ) -> Self
    where
        S: FrameSource + Send + 'scope,
    {
        let describe = source.describe();
        let remaining = source.remaining();
        let pool = source.frame_pool();
        let threads = threads.max(1);
        let handover = Arc::new(Handover {
            queue: Mutex::new(Queue {
                items: VecDeque::new(),
                delivered: 0,
                gone: false,
                failed: false,
                engaged: false,
                done: false,
            }),
            ready: Condvar::new(),
            room: Condvar::new(),
            wanted: Condvar::new(),
            limit: depth.max(1) + threads,
        });
        let feed = Arc::new(Mutex::new(Feed {
            source,
            taken: 0,
            ended: false,
        }));
        for helper in (0..threads).map(|t| t > 0) {
            let (feed, handover) = (Arc::clone(&feed), Arc::clone(&handover));
            scope.spawn(move || decode_into(&feed, &handover, helper));
        }
        Self {
            handover,
            describe,
            remaining,
            pool,
            ended: false,
            window: None,
        }
    }
}

/// A decoding thread's loop: takes the next frame from the source (in
/// turn with the other threads, when there is room), decodes it and puts
/// it in its place, up to the end of the source or until the consumer is
/// gone. A `helper` first waits until the consumer has spent half its
/// time waiting for frames (and returns if the run ends before).
fn decode_into<S: FrameSource>(feed: &Mutex<Feed<S>>, handover: &Handover, helper: bool) {
    let _guard = PanicGuard(handover);
    if helper {
        let mut queue = handover.queue();
        while !queue.engaged {
            if queue.gone || queue.failed || queue.done {
                return;
            }
            queue = handover
                .wanted
                .wait(queue)
                .unwrap_or_else(PoisonError::into_inner);
        }
    }
    loop {
        let (number, pending, remaining) = {
            // poisoned: another thread panicked in the source
            let Ok(mut feed) = feed.lock() else { return };
            if feed.ended {
                return;
            }
            let mut queue = handover.queue();
            while !queue.gone && !queue.failed && feed.taken >= queue.delivered + handover.limit {
                queue = handover
                    .room
                    .wait(queue)
                    .unwrap_or_else(PoisonError::into_inner);
            }
            if queue.gone || queue.failed {
                return;
            }
            drop(queue);
            let pending = feed.source.next_pending();
            let number = feed.taken;
            feed.taken += 1;
            feed.ended = pending.is_none();
            (number, pending, feed.source.remaining())
        };
        let item = pending.map(PendingFrame::decode);
        let end = item.is_none();
        let mut queue = handover.queue();
        if queue.gone {
            return;
        }
        if end && !queue.done {
            queue.done = true;
            handover.wanted.notify_all();
        }
        // `number` is not handed over before it is here: at or after `delivered`
        let slot = number - queue.delivered;
        if queue.items.len() <= slot {
            queue.items.resize_with(slot + 1, || None);
        }
        queue.items[slot] = Some(Ahead { item, remaining });
        let next_is_here = slot == 0;
        drop(queue);
        if next_is_here {
            handover.ready.notify_one();
        }
        if end {
            return;
        }
    }
}

#[cfg(test)]
impl DecodeAhead {
    /// Whether the next item is decoded and queued (`next` will not wait).
    fn next_is_ready(&self) -> bool {
        self.handover
            .queue()
            .items
            .front()
            .is_some_and(Option::is_some)
    }

    /// Whether the helpers have been asked to decode.
    fn engaged(&self) -> bool {
        self.handover.queue().engaged
    }
}

impl Iterator for DecodeAhead {
    type Item = Result<Frame, OtbError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.ended {
            return None;
        }
        let mut queue = self.handover.queue();
        let mut began = None;
        let Ahead { item, remaining } = loop {
            if let Some(ahead) = queue.items.front_mut().and_then(Option::take) {
                break ahead;
            }
            if queue.failed {
                // the scope passes the thread's panic on when it joins
                self.ended = true;
                return None;
            }
            if !queue.engaged
                && let Some((start, waited)) = self.window
            {
                let now = Instant::now();
                let waited = waited + (now - *began.get_or_insert(now));
                let ran = now - start;
                if ran >= ENGAGE_AFTER && waited * 2 >= ran {
                    queue.engaged = true;
                    self.handover.wanted.notify_all();
                } else {
                    queue = self
                        .handover
                        .ready
                        .wait_timeout(queue, ENGAGE_POLL)
                        .unwrap_or_else(PoisonError::into_inner)
                        .0;
                    continue;
                }
            }
            queue = self
                .handover
                .ready
                .wait(queue)
                .unwrap_or_else(PoisonError::into_inner);
        };
        queue.items.pop_front();
        queue.delivered += 1;
        let engaged = queue.engaged;
        drop(queue);
        if !engaged {
            let now = Instant::now();
            self.window = match (self.window, began) {
                (Some((start, _)), _) if now - start >= ENGAGE_WINDOW => {
                    Some((now, Duration::ZERO))
                }
                (Some((start, waited)), Some(b)) => Some((start, waited + (now - b))),
                (Some(w), None) => Some(w),
                // the first frame: waiting for it is starting up
                (None, _) => Some((now, Duration::ZERO)),
            };
        }
        self.handover.room.notify_one();
        self.remaining = remaining;
        self.ended = item.is_none();
        item
    }
}

impl FrameSource for DecodeAhead {
    fn describe(&self) -> String {
        self.describe.clone()
    }

    fn remaining(&self) -> Option<usize> {
        self.remaining
    }

    fn frame_pool(&self) -> Option<FramePool> {
        self.pool.clone()
    }
}

impl Drop for DecodeAhead {
    fn drop(&mut self) {
        let mut queue = self.handover.queue();
        queue.gone = true;
        queue.items.clear();
        drop(queue);
        self.handover.room.notify_all();
        self.handover.wanted.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::time::{Duration, Instant};

    use super::*;

    /// How a [`Counted`] source hands its frames over.
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Decoding {
        /// Decoded in `next` (a stream).
        Now,
        /// Taken undecoded (a folder): decoded where `PendingFrame::decode`
        /// runs.
        Later,
        /// As `Later`, and frames `2..=k` wait (up to 20 s) until frame
        /// `k + 1` has started decoding: once the loop waits for frame 2
        /// (frame 1 is decoded alone), `k` threads must decode at once,
        /// and frame `k + 1` ends first.
        Together(usize),
    }

    /// Frames `1..=len` (4x3 gray, every pixel its number), a decode error
    /// at the numbers in `bad`; counts the frames decoded (or started).
    struct Counted {
        len: usize,
        bad: Vec<usize>,
        next: usize,
        decoding: Decoding,
        made: Arc<AtomicUsize>,
        /// A frame of `Together` gave up waiting.
        waited_in_vain: Arc<AtomicUsize>,
    }

    impl Counted {
        fn new(len: usize, bad: &[usize]) -> Self {
            Self::decoded(len, bad, Decoding::Now)
        }

        fn decoded(len: usize, bad: &[usize], decoding: Decoding) -> Self {
            Self {
                len,
                bad: bad.to_vec(),
                next: 0,
                decoding,
                made: Arc::new(AtomicUsize::new(0)),
                waited_in_vain: Arc::new(AtomicUsize::new(0)),
            }
        }
    }

    /// Frame `n` of a [`Counted`] source, or its error.
    fn counted_frame(n: usize, bad: bool) -> Result<Frame, OtbError> {
        let path = PathBuf::from(format!("{n:04}.png"));
        if bad {
            Err(OtbError::Frame {
                index: n - 1,
                path: path.clone(),
                source: Box::new(ImageError::Truncated {
                    path,
                    format: "PNG".to_string(),
                }),
            })
        } else {
            Ok(Frame {
                number: n,
                name: format!("{n:04}.png"),
                image: Image::new(4, 3, 1, n as u8).unwrap(),
            })
        }
    }

    /// Waits (sleeping, up to 20 s) until `done` holds; whether it did.
    fn wait_for(done: impl Fn() -> bool) -> bool {
        let start = Instant::now();
        while !done() {
            if start.elapsed() > Duration::from_secs(20) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        true
    }

    impl Iterator for Counted {
        type Item = Result<Frame, OtbError>;

        fn next(&mut self) -> Option<Self::Item> {
            self.next_pending().map(PendingFrame::decode)
        }
    }

    impl FrameSource for Counted {
        fn describe(&self) -> String {
            "counted".to_string()
        }

        fn remaining(&self) -> Option<usize> {
            Some(self.len - self.next)
        }

        fn next_pending(&mut self) -> Option<PendingFrame> {
            if self.next == self.len {
                return None;
            }
            self.next += 1;
            let (n, bad) = (self.next, self.bad.contains(&self.next));
            let made = Arc::clone(&self.made);
            let decode = move || {
                made.fetch_add(1, Ordering::SeqCst);
                counted_frame(n, bad)
            };
            Some(match self.decoding {
                Decoding::Now => PendingFrame::ready(decode()),
                Decoding::Later => PendingFrame::later(decode),
                Decoding::Together(k) => {
                    let (made, vain) = (Arc::clone(&self.made), Arc::clone(&self.waited_in_vain));
                    PendingFrame::later(move || {
                        let frame = decode();
                        if (2..=k).contains(&n) && !wait_for(|| made.load(Ordering::SeqCst) > k) {
                            vain.fetch_add(1, Ordering::SeqCst);
                        }
                        frame
                    })
                }
            })
        }
    }

    /// Each item as text (frame or error) with the source's `remaining`
    /// after it, then the end.
    fn drain(source: &mut dyn FrameSource) -> Vec<String> {
        let mut seen = vec![format!("{} {:?}", source.describe(), source.remaining())];
        loop {
            let item = source.next();
            let end = item.is_none();
            let text = match item {
                None => "end".to_string(),
                Some(Ok(f)) => format!("{} {} {:?}", f.number, f.name, f.image),
                Some(Err(e)) => format!("error: {e}"),
            };
            seen.push(format!("{text}, remaining {:?}", source.remaining()));
            if end {
                return seen;
            }
        }
    }

    #[test]
    fn decoding_ahead_gives_the_same_items_in_the_same_order() {
        for (len, bad) in [
            (0, vec![]),
            (1, vec![]),
            (7, vec![3]),
            (40, vec![1, 2, 20, 40]),
        ] {
            let want = drain(&mut Counted::new(len, &bad));
            assert_eq!(want.len(), len + 2);
            for decoding in [Decoding::Now, Decoding::Later] {
                assert_eq!(drain(&mut Counted::decoded(len, &bad, decoding)), want);
                for depth in [0, 1, 2, 8, 100] {
                    for threads in [0, 1, 2, 3] {
                        let got = std::thread::scope(|scope| {
                            let source = Counted::decoded(len, &bad, decoding);
                            drain(&mut DecodeAhead::with_threads(
                                scope, source, depth, threads,
                            ))
                        });
                        assert_eq!(
                            got, want,
                            "{len} frames, bad {bad:?}, {decoding:?}, depth {depth}, \
                             {threads} threads"
                        );
                    }
                }
            }
        }
        // Through a selection, as the CLI runs it: frames 7 and 11 run and
        // fail, frame 5 fails as it is passed over.
        let pick = FrameSelection::parse(Some("3..20"), 4).unwrap();
        let want = drain(&mut Select::new(Counted::new(30, &[5, 7, 11]), pick));
        assert_eq!(want.iter().filter(|s| s.contains("error")).count(), 3);
        for threads in [1, 2, 3] {
            let got = std::thread::scope(|scope| {
                let inner = Select::new(Counted::decoded(30, &[5, 7, 11], Decoding::Later), pick);
                drain(&mut DecodeAhead::with_threads(scope, inner, 2, threads))
            });
            assert_eq!(got, want, "{threads} threads");
        }
    }

    #[test]
    fn several_threads_decode_several_frames_at_once_and_hand_them_over_in_order() {
        for threads in [2, 3] {
            for depth in [1, 4] {
                let want = drain(&mut Counted::new(12, &[threads]));
                // alone, and boxed behind a selection as the CLI runs it
                for boxed in [false, true] {
                    let source = Counted::decoded(12, &[threads], Decoding::Together(threads));
                    let vain = Arc::clone(&source.waited_in_vain);
                    let source: Box<dyn FrameSource + Send> = if boxed {
                        Box::new(Select::new(source, FrameSelection::default()))
                    } else {
                        Box::new(source)
                    };
                    let got = std::thread::scope(|scope| {
                        drain(&mut DecodeAhead::with_threads(
                            scope, source, depth, threads,
                        ))
                    });
                    let case = format!("{threads} threads, depth {depth}, boxed {boxed}");
                    assert_eq!(got, want, "{case}");
                    assert_eq!(
                        vain.load(Ordering::SeqCst),
                        0,
                        "{case}: frames 2..={threads} were not decoded at once"
                    );
                }
            }
        }
    }

    /// A loop that never waits for a frame after its first leaves the
    /// helpers idle (one thread decodes everything); one that waits for
    /// frame 2 (longer than `ENGAGE_AFTER`) engages them (and then, as
    /// `several_threads_decode_several_frames_at_once_and_hand_them_over_in_order`
    /// shows, they decode at once).
    #[test]
    fn the_helpers_decode_only_once_the_loop_has_waited_for_a_frame() {
        let want = drain(&mut Counted::new(12, &[5]));
        for threads in [2, 3] {
            for depth in [1, 4] {
                let source = Counted::decoded(12, &[5], Decoding::Later);
                let (got, engaged) = std::thread::scope(|scope| {
                    let mut ahead = DecodeAhead::with_threads(scope, source, depth, threads);
                    let mut got = vec![format!("{} {:?}", ahead.describe(), ahead.remaining())];
                    loop {
                        if got.len() > 1 {
                            assert!(wait_for(|| ahead.next_is_ready()), "never decoded");
                        }
                        let item = ahead.next();
                        let end = item.is_none();
                        got.push(match item {
                            None => "end".to_string(),
                            Some(Ok(f)) => format!("{} {} {:?}", f.number, f.name, f.image),
                            Some(Err(e)) => format!("error: {e}"),
                        });
                        let last = got.len() - 1;
                        got[last] = format!("{}, remaining {:?}", got[last], ahead.remaining());
                        if end {
                            return (got, ahead.engaged());
                        }
                    }
                });
                assert_eq!(got, want, "{threads} threads, depth {depth}");
                assert!(
                    !engaged,
                    "{threads} threads, depth {depth}: helpers engaged"
                );
            }
            // frame 2 takes 20 s unless frame 3 starts meanwhile: only a
            // helper can start it, once the loop waits for frame 2
            let source = Counted::decoded(4, &[], Decoding::Together(2));
            let vain = Arc::clone(&source.waited_in_vain);
            let engaged = std::thread::scope(|scope| {
                let mut ahead = DecodeAhead::with_threads(scope, source, 1, threads);
                assert_eq!(ahead.next().unwrap().unwrap().number, 1);
                assert_eq!(ahead.next().unwrap().unwrap().number, 2);
                ahead.engaged()
            });
            assert!(engaged, "{threads} threads: helpers not engaged");
            assert_eq!(vain.load(Ordering::SeqCst), 0, "{threads} threads");
        }
    }

    #[test]
    fn a_folder_hands_its_frames_over_undecoded() {
        let dir = Path::new("no-such-folder");
        let frames = [dir.join("0001.jpg"), dir.join("0002.jpg")];
        let mut folder = FolderSource::new(dir, &frames);
        let first = folder.next_pending().unwrap();
        // nothing read yet: the file is opened where it is decoded
        assert_eq!(format!("{first:?}"), "PendingFrame::later(..)");
        assert_eq!(folder.remaining(), Some(1));
        let second = folder.next_pending().unwrap();
        assert!(folder.next_pending().is_none());
        for (index, pending) in [(1, second), (0, first)] {
            match pending.decode() {
                Err(OtbError::Frame { index: i, path, .. }) => {
                    assert_eq!((i, path), (index, frames[index].clone()));
                }
                other => panic!("frame {index}: {other:?}"),
            }
        }
    }

    #[test]
    fn a_loop_that_stops_early_stops_the_decoding_threads() {
        for decoding in [Decoding::Now, Decoding::Later] {
            for depth in [1, 3] {
                for threads in [1, 2, 3] {
                    let source = Counted::decoded(10_000, &[], decoding);
                    let made = Arc::clone(&source.made);
                    // three taken, `depth` queued and one being decoded by
                    // each thread: never more, and the threads get there
                    let most = 3 + depth + threads;
                    let reached = std::thread::scope(|scope| {
                        let mut ahead = DecodeAhead::with_threads(scope, source, depth, threads);
                        for n in 1..=3 {
                            assert_eq!(ahead.next().unwrap().unwrap().number, n);
                        }
                        wait_for(|| made.load(Ordering::SeqCst) >= most)
                        // dropped here: the scope joins the threads, which must end
                    });
                    let made = made.load(Ordering::SeqCst);
                    let case = format!("{decoding:?}, depth {depth}, {threads} threads");
                    assert!(reached, "{case}: only {made} frames decoded ahead");
                    assert_eq!(made, most, "{case}: {made} frames decoded");
                }
            }
        }
    }

    #[test]
    fn a_decoding_thread_that_panics_ends_the_stream_and_the_scope_passes_the_panic_on() {
        /// Frames 1..=9 of which frame 5 panics when decoded.
        struct Panics(usize);
        impl Iterator for Panics {
            type Item = Result<Frame, OtbError>;
            fn next(&mut self) -> Option<Self::Item> {
                self.next_pending().map(PendingFrame::decode)
            }
        }
        impl FrameSource for Panics {
            fn describe(&self) -> String {
                "panics".to_string()
            }
            fn remaining(&self) -> Option<usize> {
                Some(9 - self.0)
            }
            fn next_pending(&mut self) -> Option<PendingFrame> {
                (self.0 < 9).then(|| {
                    self.0 += 1;
                    let n = self.0;
                    PendingFrame::later(move || {
                        assert!(n != 5, "frame 5 does not decode");
                        counted_frame(n, false)
                    })
                })
            }
        }
        for threads in [1, 2, 3] {
            let mut numbers = Vec::new();
            let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                std::thread::scope(|scope| {
                    let ahead = DecodeAhead::with_threads(scope, Panics(0), 2, threads);
                    numbers.extend(ahead.map(|f| f.unwrap().number));
                });
            }));
            assert!(run.is_err(), "{threads} threads: the panic was lost");
            assert_eq!(numbers, [1, 2, 3, 4], "{threads} threads");
        }
    }
}
