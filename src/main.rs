//! `bayestrack`: run a tracker on a real video sequence.
//!
//! ```text
//! bayestrack trackers
//! bayestrack track --seq ../shared/data/sequences/Crossing --tracker ncc-scale --out boxes.txt
//! ```

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use bayestrack::image::{BBox, Rgb, write_frame_with_boxes};
use bayestrack::otb::metrics::score_otb;
use bayestrack::otb::sequence::Sequence;
use bayestrack::otb::track::{BoxFile, OnBadFrame, TrackError, track_frames};
use bayestrack::trackers::{REGISTRY, tracker_info};
use clap::{Parser, Subcommand, ValueEnum};

/// The tracker `track` runs when `--tracker` is not given.
const DEFAULT_TRACKER: &str = "ncc-scale";

#[derive(Parser)]
#[command(
    name = "bayestrack",
    version,
    about = "Bayesian filtering and visual object tracking on real video",
    long_about = "Runs the bayestrack trackers on a folder of video frames. \
                  `bayestrack trackers` lists them; `bayestrack track` runs one."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the trackers, one line each.
    Trackers,
    /// Track one target through a sequence and, when the folder has ground
    /// truth, score the result (OTB one-pass evaluation).
    #[command(after_help = TRACK_AFTER_HELP)]
    Track(TrackArgs),
}

const TRACK_AFTER_HELP: &str = "\
Boxes use the OTB convention: x,y is the 1-based top-left pixel, w,h the size.
Frame 1's box is the initial box; one box per frame is written as soon as it
is known, so an interrupted or failed run keeps every box written so far.
Scores (when the folder has ground truth): success AUC (mean of the success
curve at IoU thresholds 0, 0.05, ..., 1), precision at 20 px centre error,
mean IoU; unlabelled rows (0,0,0,0) are not scored. fps counts only the
tracker's own time (not decoding frames or writing files).

Exit status: 0 on success, 1 when the run failed (the message names the file
or frame), 2 for bad arguments.";

#[derive(clap::Args)]
struct TrackArgs {
    /// Sequence folder: OTB layout (`img/0001.jpg ...` plus
    /// `groundtruth_rect.txt` or `*_gt.txt`), or any folder of numbered
    /// PNG/JPEG frames (then `--init` is required).
    #[arg(long, value_name = "DIR")]
    seq: PathBuf,
    /// Tracker name (see `bayestrack trackers`).
    #[arg(long, default_value = DEFAULT_TRACKER)]
    tracker: String,
    /// Initial box `x,y,w,h` on frame 1 (default: the first ground-truth
    /// row).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_box)]
    init: Option<BBox>,
    /// Where to write the boxes, one `x,y,w,h` line per frame (`-` for
    /// standard output, the default).
    #[arg(long, value_name = "FILE", default_value = "-")]
    out: PathBuf,
    /// Also write every frame as a PNG into this folder with the tracker's
    /// box in green and, where labelled, the ground truth in red.
    #[arg(long, value_name = "DIR")]
    draw: Option<PathBuf>,
    /// Seed of the tracker's random streams (same seed, same boxes).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// What to do with a frame that does not decode: stop (keeping the
    /// boxes written so far) or skip it, repeating the previous box.
    #[arg(long, value_enum, default_value_t = BadFrame::Stop)]
    on_bad_frame: BadFrame,
}

#[derive(Clone, Copy, ValueEnum)]
enum BadFrame {
    Stop,
    Skip,
}

fn parse_box(s: &str) -> Result<BBox, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{s}`: {e} (expected x,y,w,h)"))?;
    match v[..] {
        // the far edges must be numbers too (1e308 + 1e308 is not)
        [x, y, w, h]
            if v.iter().all(|c| c.is_finite())
                && w > 0.0
                && h > 0.0
                && (x + w).is_finite()
                && (y + h).is_finite() =>
        {
            Ok(BBox::new(x, y, w, h))
        }
        _ => Err(format!(
            "`{s}`: expected four finite numbers x,y,w,h with w, h > 0"
        )),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Trackers => {
            list_trackers();
            Ok(())
        }
        Command::Track(args) => track(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

fn list_trackers() {
    let width = REGISTRY.iter().map(|t| t.name.len()).max().unwrap_or(0);
    for t in REGISTRY {
        let scale = if t.handles_scale { "scale" } else { "     " };
        println!("{:<width$}  {scale}  {}", t.name, t.summary);
    }
}

fn track(args: &TrackArgs) -> Result<(), String> {
    let info = tracker_info(&args.tracker).map_err(|e| e.to_string())?;
    let seq = Sequence::open_frames(&args.seq).map_err(|e| e.to_string())?;
    let init = match (args.init, seq.initial_box()) {
        (Some(b), _) | (None, Some(b)) => b,
        (None, None) => {
            return Err(format!(
                "{}: no ground truth for frame 1; give the initial box with --init x,y,w,h",
                seq.dir.display()
            ));
        }
    };
    if let Some(dir) = &args.draw {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let mut tracker = info.build(args.seed).map_err(|e| e.to_string())?;
    let mut writer = BoxFile::create(&args.out).map_err(|e| e.to_string())?;
    let on_bad_frame = match args.on_bad_frame {
        BadFrame::Stop => OnBadFrame::Stop,
        BadFrame::Skip => OnBadFrame::Skip,
    };
    let green = Rgb::new(0, 220, 0);
    let red = Rgb::new(230, 0, 0);
    let mut written = 0usize;
    let result = track_frames(
        tracker.as_mut(),
        seq.len(),
        |i| seq.frame(i).map(Cow::Owned),
        |i| seq.frames[i].clone(),
        init,
        on_bad_frame,
        |f| {
            writer.write(&f.bbox)?;
            written += 1;
            if let (Some(dir), Some(frame)) = (&args.draw, f.frame) {
                let mut boxes = vec![(f.bbox, green)];
                if let Some(truth) = seq.ground_truth[f.index] {
                    boxes.push((truth, red));
                }
                let path = dir.join(format!("{:04}.png", f.index + 1));
                write_frame_with_boxes(&path, frame, &boxes, 1).map_err(|e| {
                    TrackError::Output {
                        path,
                        source: std::io::Error::other(e.to_string()),
                    }
                })?;
            }
            Ok(())
        },
    );
    let run = result.map_err(|e| {
        let kept = if args.out == Path::new("-") {
            String::new()
        } else {
            format!(
                "; the {written} boxes before it are in {}",
                args.out.display()
            )
        };
        format!("{e}{kept}")
    })?;
    for (index, why) in &run.skipped {
        eprintln!("skipped frame {}: {why}", index + 1);
    }
    eprintln!(
        "{}: {} on {} frames, {:.0} fps (tracker time only), target lost on {} frames",
        seq.name,
        info.name,
        run.boxes.len(),
        run.fps(),
        run.lost_frames
    );
    if seq.ground_truth.iter().any(Option::is_some) {
        let score = score_otb(&run.boxes, &seq.ground_truth).map_err(|e| e.to_string())?;
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
    fn a_box_whose_far_edge_overflows_is_refused() {
        assert!(parse_box("1e308,0,1e308,5").is_err());
        assert!(parse_box("1,2,3,4").is_ok());
    }
}
