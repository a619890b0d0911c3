//! `bayestrack`: run a tracker on a real video sequence.
//!
//! ```text
//! bayestrack trackers
//! bayestrack track --seq ../shared/data/sequences/Crossing --tracker ncc-scale --out boxes.txt
//! bayestrack track --seq clip.mp4 --init 120,80,40,60 --out boxes.txt
//! ffmpeg -i clip.mp4 -f yuv4mpegpipe - | bayestrack track --seq - --init 120,80,40,60
//! ```

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use bayestrack::image::{BBox, Rgb, write_frame_with_boxes};
use bayestrack::otb::Sequence;
use bayestrack::otb::ground_truth::{check_box, read_ground_truth, short_number};
use bayestrack::otb::metrics::score_otb;
use bayestrack::otb::write::{BoxFile, box_row};
use bayestrack::otb::{DecodeAhead, FrameSelection, FrameSource, Select, VideoSource, Y4mSource};
use bayestrack::otb::{FrameBox, OnBadFrame, SKIPPED_LISTED, track_stream};
use bayestrack::otb::{OtbError, WriteError};
use bayestrack::trackers::{REGISTRY, tracker_info};
use clap::{Parser, Subcommand, ValueEnum};

/// The tracker `track` runs when `--tracker` is not given.
const DEFAULT_TRACKER: &str = "ncc-scale";

/// Frames `track` decodes ahead of the tracker by default (`--decode-ahead`).
const DEFAULT_DECODE_AHEAD: usize = 4;

/// Threads that decode a folder's frames by default (`--decode-threads`):
/// two, the second only once the tracker has spent half its time waiting
/// for frames ([`DecodeAhead`]: decoding is then well behind). With both always
/// decoding (2026-12-03) the fast trackers ran 1.1-1.3x faster than with
/// one but those busy on each frame (ncc-scale then, dcf, hkpf) 5-15 %
/// slower, three busy threads on two cores; the second thread now stays
/// idle behind them.
const DEFAULT_DECODE_THREADS: usize = 2;

#[derive(Parser)]
#[command(
    name = "bayestrack",
    version,
    about = "Bayesian filtering and visual object tracking on real video",
    long_about = "Runs the bayestrack trackers on real video: a folder of frames, an OTB \
                  sequence, a video file (through ffmpeg) or a Y4M stream on standard input. \
                  `bayestrack trackers` lists them; `bayestrack track` runs one."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size of the `track` variant costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// List the trackers, one line each, or one tracker's options.
    Trackers {
        /// List this tracker's options (key, type, domain, default and
        /// documentation) instead.
        #[arg(long, value_name = "NAME")]
        options: Option<String>,
    },
    /// Track one target through a sequence and, when the folder has ground
    /// truth, score the result (OTB one-pass evaluation).
    #[command(after_help = TRACK_AFTER_HELP)]
    Track(TrackArgs),
}

const TRACK_AFTER_HELP: &str = "\
Video: `--seq clip.mp4` decodes through the ffmpeg on PATH (or BAYESTRACK_FFMPEG);
any decoder can pipe Y4M instead:
  ffmpeg -i clip.mp4 -f yuv4mpegpipe - | bayestrack track --seq - --init x,y,w,h

Boxes use the OTB convention: x,y is the 1-based top-left pixel, w,h the size.
The first frame's box is the initial box; one box per frame run is written as
soon as it is known (a row whole or not at all), so an interrupted or failed
run keeps every box written so far. The --out file is created with the first
box: a run that fails before it leaves the previous file as it was. An --out
that is an input (by any name or link), or a .png in the --draw folder, is
refused. Scores (with ground truth): success AUC
(mean of the success curve at IoU thresholds 0, 0.05, ..., 1), precision at
20 px centre error, mean IoU; unlabelled rows (0,0,0,0) and frames past the
last ground-truth row are not scored. fps counts only the tracker's own time
(not decoding frames or writing files); the whole run's fps counts everything
from the first frame to the last box. Frames are decoded on other threads,
--decode-ahead frames ahead of the tracker (0: in turn with it), a folder's
frames on up to --decode-threads threads at once (a video or a stream on
one; the threads after the first start once the tracker has spent half its
time waiting for frames); the boxes are the same either way. Progress goes to standard error when it is a
terminal.

Exit status: 0 on success, 1 when the run failed (the message names the file
or frame), 2 for bad arguments.";

#[derive(clap::Args)]
struct TrackArgs {
    /// What to track: a folder of numbered PNG/JPEG frames (OTB layout
    /// `img/0001.jpg ...` plus `groundtruth_rect.txt` or `*_gt.txt`; an
    /// OTB-100 sequence runs on the benchmark's frames), `-` for a Y4M
    /// stream on standard input (`ffmpeg -i clip.mp4 -f yuv4mpegpipe - |
    /// bayestrack track --seq - ...`), a `.y4m` file, or a video file
    /// (decoded by the `ffmpeg` on PATH).
    #[arg(long, value_name = "DIR|FILE|-")]
    seq: PathBuf,
    /// Tracker name (see `bayestrack trackers`).
    #[arg(long, default_value = DEFAULT_TRACKER)]
    tracker: String,
    /// Initial box `x,y,w,h` on the first frame run (default: its
    /// ground-truth row). A box partly outside the frame is clipped to it.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_box, allow_hyphen_values = true)]
    init: Option<BBox>,
    /// Ground-truth file to score with instead of the folder's own (one row
    /// per frame from the source's first; Jogging's second target:
    /// `Jogging/groundtruth_rect.2.txt`); also scores a video or a stream.
    #[arg(long, value_name = "FILE")]
    groundtruth: Option<PathBuf>,
    /// Frames to run, `a..b` (1-based, inclusive, counted from the
    /// source's first frame), `a..` or `a`.
    #[arg(long, value_name = "A..B")]
    frames: Option<String>,
    /// Run on every Nth frame of the range only.
    #[arg(long, value_name = "N", default_value_t = 1)]
    every: usize,
    /// Where to write the boxes, one `x,y,w,h` line per frame run (`-` for
    /// standard output, the default). An input file is refused.
    #[arg(long, value_name = "FILE", default_value = "-")]
    out: PathBuf,
    /// Also write every frame run as a PNG into this folder with the
    /// tracker's box in green and, where labelled, the ground truth in red.
    #[arg(long, value_name = "DIR")]
    draw: Option<PathBuf>,
    /// Seed of the tracker's random streams (same seed, same boxes).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// A tracker option `key=value` (repeatable; `bayestrack trackers
    /// --options NAME` lists them), e.g. `--set particles=70`.
    #[arg(long = "set", value_name = "KEY=VALUE", value_parser = parse_key_value)]
    set: Vec<(String, String)>,
    /// What to do with a frame that does not decode: stop (keeping the
    /// boxes written so far) or skip it, repeating the previous box.
    #[arg(long, value_enum, default_value_t = BadFrame::Stop)]
    on_bad_frame: BadFrame,
    /// Decode up to N frames ahead on a second thread, while the tracker
    /// runs (0: decode each frame when the tracker asks for it, on the same
    /// thread). Same boxes, same errors either way.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DECODE_AHEAD)]
    decode_ahead: usize,
    /// Threads that decode a folder's frames at once, each its own frame
    /// (with --decode-ahead 1 or more; a video or a Y4M stream is decoded
    /// on one); those after the first start only once the tracker has
    /// spent half its time waiting for frames. Same boxes, same errors whatever the number.
    #[arg(long, value_name = "K", default_value_t = DEFAULT_DECODE_THREADS,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=64))]
    decode_threads: usize,
}

#[derive(Clone, Copy, ValueEnum)]
enum BadFrame {
    Stop,
    Skip,
}

fn parse_key_value(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("`{s}`: expected key=value")),
    }
}

fn parse_box(s: &str) -> Result<BBox, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{s}`: {e} (expected x,y,w,h)"))?;
    match v[..] {
        // the rule every labelled ground-truth row follows too
        [x, y, w, h] => check_box(x, y, w, h).map_err(|why| format!("`{s}`: {why}")),
        _ => Err(format!(
            "`{s}`: expected four finite numbers x,y,w,h with w, h > 0"
        )),
    }
}

fn main() -> ExitCode {
    // before anything opens a file: a closed standard output is reopened on
    // /dev/null by the Rust runtime, and would swallow the boxes
    let stdout_closed = stdout_was_closed();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Trackers { options: None } => {
            list_trackers();
            Ok(())
        }
        Command::Trackers {
            options: Some(name),
        } => list_options(&name),
        Command::Track(args) => track(&args, stdout_closed),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {}", shorten_numbers(&msg));
            ExitCode::FAILURE
        }
    }
}

/// `text` with every number written out in more than 20 characters (Rust
/// prints `1e300` as a 301-digit decimal) in its short form (`1e300`),
/// whichever crate formatted it.
fn shorten_numbers(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        out.push_str(&rest[..start]);
        let tail = &rest[start..];
        let mut end = tail
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(tail.len());
        if tail[end..].starts_with('.') {
            let frac = &tail[end + 1..];
            let digits = frac
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(frac.len());
            if digits > 0 {
                end += 1 + digits;
            }
        }
        let number = &tail[..end];
        match number.parse::<f64>() {
            Ok(v) if number.len() > 20 => out.push_str(&short_number(v)),
            _ => out.push_str(number),
        }
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}

fn list_trackers() {
    let width = REGISTRY.iter().map(|t| t.name.len()).max().unwrap_or(0);
    for t in REGISTRY {
        let scale = if t.handles_scale { "scale" } else { "     " };
        println!("{:<width$}  {scale}  {}", t.name, t.summary);
    }
}

fn list_options(name: &str) -> Result<(), String> {
    let info = tracker_info(name).map_err(|e| e.to_string())?;
    let specs = info.options();
    if specs.is_empty() {
        println!("{name} takes no options yet (only --seed)");
    }
    for spec in specs {
        println!("{spec}");
    }
    Ok(())
}

/// What `--seq` names, opened.
enum Input {
    /// A folder of frames (or an OTB-100 sequence).
    Folder(Sequence),
    /// A Y4M stream or a video decoded by ffmpeg.
    Stream(Box<dyn FrameSource + Send>),
}

fn open_input(args: &TrackArgs) -> Result<Input, String> {
    let seq = &args.seq;
    let e = |e: OtbError| e.to_string();
    if seq == Path::new("-") {
        return Ok(Input::Stream(Box::new(Y4mSource::stdin().map_err(e)?)));
    }
    if seq.is_file() {
        let y4m = seq
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("y4m"));
        let source: Box<dyn FrameSource + Send> = if y4m {
            Box::new(Y4mSource::open(seq).map_err(e)?)
        } else {
            Box::new(VideoSource::open(seq).map_err(e)?)
        };
        return Ok(Input::Stream(source));
    }
    if !seq.exists() && seq.extension().is_some() {
        // `clip.mp4`: a missing file, not a missing folder
        return Err(format!("--seq {}: no such file", seq.display()));
    }
    let folder = match &args.groundtruth {
        Some(gt) => Sequence::open_with_ground_truth(seq, gt),
        None => Sequence::open_frames(seq),
    };
    folder.map(Input::Folder).map_err(e)
}

/// The canonical form of `path`; `None` when it does not exist.
fn canonical(path: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(path).ok()
}

/// What a file is, whatever names it: device and inode on Unix (a hard
/// link, a symlink and the file itself are one), the canonical path
/// elsewhere. `None` when it does not exist or is not a regular file.
#[derive(PartialEq, Eq)]
enum FileId {
    #[cfg(unix)]
    Inode(u64, u64),
    #[cfg(not(unix))]
    Path(PathBuf),
}

fn id_of(meta: &std::fs::Metadata, _path: Option<&Path>) -> Option<FileId> {
    if !meta.is_file() {
        return None;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        Some(FileId::Inode(meta.dev(), meta.ino()))
    }
    #[cfg(not(unix))]
    {
        _path.and_then(canonical).map(FileId::Path)
    }
}

fn file_id(path: &Path) -> Option<FileId> {
    id_of(&std::fs::metadata(path).ok()?, Some(path))
}

/// The file standard input reads (`bayestrack track --seq - < clip.y4m`).
fn stdin_id() -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd;
        let fd = std::io::stdin().as_fd().try_clone_to_owned().ok()?;
        id_of(&std::fs::File::from(fd).metadata().ok()?, None)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Whether standard output was closed when the program started
/// (`bayestrack track ... >&-`): the Rust runtime then opens /dev/null
/// read-write in its place, which a shell redirection (`> /dev/null`, write
/// only) does not. Linux only; elsewhere `false`.
fn stdout_was_closed() -> bool {
    #[cfg(target_os = "linux")]
    {
        let target = std::fs::read_link("/proc/self/fd/1").ok();
        if target.as_deref() != Some(Path::new("/dev/null")) {
            return false;
        }
        let info = std::fs::read_to_string("/proc/self/fdinfo/1").unwrap_or_default();
        info.lines()
            .find_map(|l| l.strip_prefix("flags:"))
            .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
            .is_some_and(|flags| flags & 3 == 2)
    }
    #[cfg(not(target_os = "linux"))]
    {
        false
    }
}

/// An input of the run, for [`check_out`]: a file by its name, or
/// standard input.
enum InputFile<'a> {
    Path(&'a Path),
    Stdin,
}

/// Refuses an `--out` that is one of the inputs (the same file, by
/// whatever name: a hard link, a symlink's target, standard input), or a
/// `.png` in the `--draw` folder (a name a drawn frame takes), before
/// anything is written.
fn check_out(out: &Path, inputs: &[InputFile<'_>], draw: Option<&Path>) -> Result<(), String> {
    if out == Path::new("-") {
        return Ok(());
    }
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    // the names drawn frames take (`0003.png`, and `0003.png.part` while
    // one is written)
    let drawn_name = name.ends_with(".png") || name.ends_with(".png.part");
    if let Some(dir) = draw.filter(|_| drawn_name) {
        let parent = out
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let same = match (canonical(parent), canonical(dir)) {
            (Some(a), Some(b)) => a == b,
            _ => parent == dir,
        };
        if same {
            return Err(format!(
                "--out {} is a PNG file in the --draw folder {}, where the drawn frames go: a \
                 drawn frame could replace it; write the boxes elsewhere",
                out.display(),
                dir.display()
            ));
        }
    }
    let Some(out_id) = file_id(out) else {
        return Ok(()); // it does not exist (or is no regular file), so it is no input
    };
    for input in inputs {
        let (id, name) = match input {
            InputFile::Path(p) => (file_id(p), p.display().to_string()),
            InputFile::Stdin => (stdin_id(), "standard input".to_string()),
        };
        if id.as_ref() == Some(&out_id) {
            return Err(format!(
                "--out {} is an input of this run ({name}, the same file by another name or \
                 link): it would be overwritten; write the boxes elsewhere",
                out.display()
            ));
        }
    }
    Ok(())
}

/// Writes a drawn frame whole or not at all: into a `.part` file renamed
/// over `path`, which is removed when writing fails part-way.
fn write_drawn(path: &Path, write: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), String> {
    let mut part = path.as_os_str().to_owned();
    part.push(".part");
    let part = PathBuf::from(part);
    let done = write(&part).and_then(|()| {
        std::fs::rename(&part, path).map_err(|e| format!("cannot write {}: {e}", path.display()))
    });
    if done.is_err() {
        let _ = std::fs::remove_file(&part);
    }
    done
}

/// Progress on standard error when it is a terminal: frames done, elapsed
/// time and, when the length is known, the time left.
struct Progress {
    on: bool,
    total: Option<usize>,
    start: Instant,
    shown: Option<Instant>,
}

impl Progress {
    fn new(total: Option<usize>) -> Self {
        Self {
            on: std::io::stderr().is_terminal(),
            total,
            start: Instant::now(),
            shown: None,
        }
    }

    fn update(&mut self, done: usize) {
        if !self.on || self.shown.is_some_and(|t| t.elapsed().as_millis() < 100) {
            return;
        }
        self.shown = Some(Instant::now());
        let elapsed = self.start.elapsed().as_secs_f64();
        let clock = |s: f64| {
            let s = s.round() as u64;
            format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
        };
        let line = match self.total {
            Some(total) if total > 0 => {
                let left = elapsed / done.max(1) as f64 * total.saturating_sub(done) as f64;
                format!(
                    "frame {done}/{total} ({:.0}%), elapsed {}, ETA {}",
                    100.0 * done as f64 / total as f64,
                    clock(elapsed),
                    clock(left)
                )
            }
            _ => format!("frame {done}, elapsed {}", clock(elapsed)),
        };
        eprint!("\r{line}\x1b[K");
    }

    fn finish(&self) {
        if self.on && self.shown.is_some() {
            eprint!("\r\x1b[K");
        }
    }
}

fn track(args: &TrackArgs, stdout_closed: bool) -> Result<(), String> {
    if args.out == Path::new("-") && stdout_closed {
        return Err(
            "standard output is closed (`>&-`): the boxes would be lost; give --out FILE or \
             redirect standard output to a file"
                .to_string(),
        );
    }
    let info = tracker_info(&args.tracker).map_err(|e| e.to_string())?;
    // options are checked before anything is read or written
    let mut tracker = info
        .build_with(args.seed, &args.set)
        .map_err(|e| e.to_string())?;
    let selection = FrameSelection::parse(args.frames.as_deref(), args.every)?;
    let input = open_input(args)?;
    if let Input::Folder(seq) = &input
        && selection.first > seq.len()
    {
        return Err(format!(
            "--frames {}: {} has {} frames, so there is no frame {} to start from",
            args.frames.as_deref().unwrap_or_default(),
            seq.name,
            seq.len(),
            selection.first
        ));
    }
    if let Input::Folder(seq) = &input
        && let Some(last) = selection.last.filter(|&b| b > seq.len())
    {
        eprintln!(
            "note: --frames {}: {} has {} frames, so frames {}-{last} do not exist; running \
             frames {}-{}",
            args.frames.as_deref().unwrap_or_default(),
            seq.name,
            seq.len(),
            seq.len() + 1,
            selection.first,
            seq.len()
        );
    }
    // The ground truth, one entry per source position.
    let (truth, truth_rows, notes): (Vec<Option<BBox>>, usize, Vec<String>) = match &input {
        Input::Folder(seq) => (
            seq.ground_truth.clone(),
            seq.ground_truth_rows,
            seq.notes.clone(),
        ),
        Input::Stream(_) => match &args.groundtruth {
            Some(gt) => {
                let rows = read_ground_truth(gt).map_err(|e| e.to_string())?;
                let n = rows.len();
                (rows, n, Vec::new())
            }
            None => (Vec::new(), 0, Vec::new()),
        },
    };
    for note in &notes {
        eprintln!("note: {}", shorten_numbers(note));
    }
    let mut inputs: Vec<InputFile<'_>> = Vec::new();
    if let Input::Folder(seq) = &input {
        inputs.extend(seq.frames.iter().map(|f| InputFile::Path(f)));
        inputs.extend(seq.ground_truth_path.as_deref().map(InputFile::Path));
    } else if args.seq == Path::new("-") {
        inputs.push(InputFile::Stdin);
    } else {
        inputs.push(InputFile::Path(&args.seq));
    }
    inputs.extend(args.groundtruth.as_deref().map(InputFile::Path));
    check_out(&args.out, &inputs, args.draw.as_deref())?;
    if let (Some(dir), Input::Folder(seq)) = (&args.draw, &input) {
        let frame_dir = seq.frames.first().and_then(|f| f.parent());
        if frame_dir
            .and_then(canonical)
            .is_some_and(|f| canonical(dir) == Some(f))
        {
            return Err(format!(
                "--draw {} is the folder of the input frames: drawn frames could overwrite them",
                dir.display()
            ));
        }
    }
    let (folder, stream) = match input {
        Input::Folder(seq) => (Some(seq), None),
        Input::Stream(stream) => (None, Some(stream)),
    };
    let name = match &folder {
        Some(seq) => seq.name.clone(),
        None if args.seq == Path::new("-") => "stdin".to_string(),
        None => args.seq.display().to_string(),
    };
    let source: Box<dyn FrameSource + Send + '_> = match (&folder, stream) {
        (Some(seq), _) => Box::new(Select::new(seq.source(), selection)),
        (None, Some(stream)) => Box::new(Select::new(stream, selection)),
        (None, None) => unreachable!("the input is a folder or a stream"),
    };
    // a stream is read in order: more threads would only wait their turn
    let decode_threads = if folder.is_some() {
        args.decode_threads
    } else {
        1
    };
    let init = match args.init {
        Some(b) => b,
        None => truth
            .get(selection.first - 1)
            .copied()
            .flatten()
            .ok_or_else(|| {
                format!(
                    "{name}: no ground truth for frame {} (the first run); give the initial box \
                     with --init x,y,w,h",
                    selection.first
                )
            })?,
    };
    // checks the folder; the file is created (a previous one replaced) with
    // the first box, so a run that fails before it leaves the old file
    let mut writer = BoxFile::create(&args.out).map_err(|e| e.to_string())?;
    if let Some(dir) = &args.draw {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let on_bad_frame = match args.on_bad_frame {
        BadFrame::Stop => OnBadFrame::Stop,
        BadFrame::Skip => OnBadFrame::Skip,
    };
    let green = Rgb::new(0, 220, 0);
    let red = Rgb::new(230, 0, 0);
    let mut written = 0usize;
    let mut progress = Progress::new(source.remaining());
    let started = Instant::now();
    // Only what scoring needs is kept: the boxes of frames that have a
    // ground-truth row (as many as the file has rows), so memory does not
    // grow with a long stream.
    let (mut scored_boxes, mut scored_truth) = (Vec::new(), Vec::new());
    let (mut unscored, mut skipped_numbers) = (0usize, Vec::new());
    let mut sink = |f: FrameBox<'_>| {
        writer.write(&f.bbox)?;
        written += 1;
        progress.update(written);
        if f.number <= truth_rows {
            scored_boxes.push(f.bbox);
            scored_truth.push(truth.get(f.number - 1).copied().flatten());
        } else {
            unscored += 1;
        }
        if f.frame.is_none() && skipped_numbers.len() < SKIPPED_LISTED {
            skipped_numbers.push(f.number);
        }
        if let (Some(dir), Some(frame)) = (&args.draw, f.frame) {
            let mut boxes = vec![(f.bbox, green)];
            if let Some(t) = truth.get(f.number - 1).copied().flatten() {
                boxes.push((t, red));
            }
            let stem = folder
                .as_ref()
                .and_then(|s| s.frames.get(f.number - 1))
                .and_then(|p| p.file_stem())
                .map_or_else(
                    || format!("{:04}", f.number),
                    |s| s.to_string_lossy().into_owned(),
                );
            let path = dir.join(format!("{stem}.png"));
            write_drawn(&path, |part| {
                write_frame_with_boxes(part, frame, &boxes, 1).map_err(|e| e.to_string())
            })
            .map_err(|e| WriteError::new(&path, std::io::Error::other(e)))?;
        }
        Ok(())
    };
    let result = if args.decode_ahead == 0 {
        let mut source = source;
        track_stream(tracker.as_mut(), &mut source, init, on_bad_frame, &mut sink)
    } else {
        // the scope ends when the decoding thread has: at the end of the
        // source, or at its next frame once the run stopped
        std::thread::scope(|scope| {
            let mut ahead =
                DecodeAhead::with_threads(scope, source, args.decode_ahead, decode_threads);
            track_stream(tracker.as_mut(), &mut ahead, init, on_bad_frame, &mut sink)
        })
    };
    let whole_seconds = started.elapsed().as_secs_f64();
    progress.finish();
    let run = result.map_err(|e| {
        let kept = if args.out == Path::new("-") {
            String::new()
        } else if written == 0 {
            format!("; nothing was written, {} is as it was", args.out.display())
        } else {
            format!(
                "; the {written} boxes before it are in {}",
                args.out.display()
            )
        };
        match e {
            OtbError::NoFramesToTrack if selection.first > 1 => format!(
                "--frames {}: {name} ends before frame {}{kept}",
                args.frames.as_deref().unwrap_or_default(),
                selection.first
            ),
            e => format!("{e}{kept}"),
        }
    })?;
    if run.init != init {
        eprintln!(
            "note: the initial box {} reaches outside the first frame: clipped to {}",
            box_row(&init),
            box_row(&run.init)
        );
    }
    for ((_, why), number) in run.skipped.iter().zip(&skipped_numbers) {
        eprintln!("skipped frame {number}: {why}");
    }
    if run.skipped_count > run.skipped.len() {
        eprintln!(
            "... and {} more skipped frames ({} in all)",
            run.skipped_count - run.skipped.len(),
            run.skipped_count
        );
    }
    if let Some(first) = run.converted.first() {
        let n = run.converted_count;
        eprintln!(
            "note: {n} frames (the first: frame {first}) had another channel count than the \
             first frame and were converted to it"
        );
    }
    eprintln!(
        "{name}: {} on {} frames, {:.0} fps (tracker time only), {:.0} fps whole run, target \
         lost on {} frames",
        info.name,
        run.frames_run,
        run.fps(),
        run.frames_run as f64 / whole_seconds.max(1e-9),
        run.lost_frames
    );
    if truth_rows > 0 && unscored > 0 {
        eprintln!(
            "note: {unscored} of the {} frames run have no ground-truth row: tracked, written, \
             not scored",
            run.frames_run
        );
    }
    if scored_truth.iter().any(Option::is_some) {
        let score = score_otb(&scored_boxes, &scored_truth).map_err(|e| e.to_string())?;
        eprintln!(
            "success AUC {:.3}, precision@20px {:.3}, mean IoU {:.3} over {} labelled frames",
            score.auc, score.precision_20, score.mean_overlap, score.frames_scored
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_box;
    use proptest::prelude::*;

    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            any::<f64>().prop_map(|v| v.to_string()),
            (-1e4f64..1e4).prop_map(|v| format!("{v:.2}")),
            prop::sample::select(vec!["inf", "NaN", "-0", "1e309", "", " 3 ", "0x10", "1,5"])
                .prop_map(String::from),
            "\\PC{0,6}",
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

        #[test]
        fn init_boxes_parse_finite_or_are_refused(parts in prop::collection::vec(number(), 0..6)) {
            let s = parts.join(",");
            if let Ok(b) = parse_box(&s) {
                let v = [b.x, b.y, b.width, b.height, b.x + b.width, b.y + b.height];
                prop_assert!(v.iter().all(|c| c.is_finite()), "{s} -> {b:?}");
                prop_assert!(b.width > 0.0 && b.height > 0.0);
            }
        }

        #[test]
        fn any_text_never_panics_the_init_parser(s in "\\PC{0,40}") {
            let _ = parse_box(&s);
        }
    }

    #[test]
    fn a_drawn_frame_that_fails_part_way_leaves_no_file() {
        let dir = std::env::temp_dir().join(format!("bayestrack-drawn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("0001.png");
        // The disk fills after part of the PNG is written.
        let e = super::write_drawn(&target, |part| {
            std::fs::write(part, b"\x89PNG half").unwrap();
            Err("No space left on device".to_string())
        })
        .unwrap_err();
        assert!(e.contains("No space left"), "{e}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        super::write_drawn(&target, |part| {
            std::fs::write(part, b"whole").map_err(|e| e.to_string())
        })
        .unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn long_numbers_are_printed_short() {
        let long = format!("box {},1,5,5 is outside", 1e300);
        assert_eq!(super::shorten_numbers(&long), "box 1e300,1,5,5 is outside");
        let tiny = format!("alpha {} too small", 1e-300);
        assert_eq!(super::shorten_numbers(&tiny), "alpha 1e-300 too small");
        let plain = "frame 12 of 0300.jpg at 1.5, 2026";
        assert_eq!(super::shorten_numbers(plain), plain);
    }

    #[test]
    fn a_box_whose_far_edge_overflows_is_refused() {
        assert!(parse_box("1e308,0,1e308,5").is_err());
        assert!(parse_box("1,2,3,4").is_ok());
    }
}
