//! The OTB suite keeps its results whole: a finished run leaves no partial
//! files, and the files of a previous run are replaced only by renaming.

#![cfg(feature = "suite")]

use std::path::{Path, PathBuf};

use bayestrack_otb::published::{
    OtbFrameRange, OtbFrameRanges, PUBLISHED_OPE_FILE, Published, PublishedOpe,
};
use bayestrack_otb::suite::{SuiteEvent, SuiteOptions, Timing, run_suite, run_suite_with};
use bayestrack_trackers::tracker_info;

/// A 3-frame sequence of a bright square moving right by 1 px a frame.
fn sequence(root: &Path) -> PathBuf {
    let dir = root.join("square");
    std::fs::create_dir_all(dir.join("img")).unwrap();
    let mut gt = String::new();
    for k in 0..3u32 {
        let img = image::GrayImage::from_fn(48, 48, |x, y| {
            let inside = (14 + k..26 + k).contains(&x) && (16..28).contains(&y);
            image::Luma([if inside {
                220
            } else {
                30 + ((x * 7 + y * 3) % 20) as u8
            }])
        });
        img.save(dir.join("img").join(format!("{:04}.png", k + 1)))
            .unwrap();
        gt.push_str(&format!("{},16,12,12\n", 14 + k));
    }
    std::fs::write(dir.join("groundtruth_rect.txt"), gt).unwrap();
    dir
}

fn files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(files(&p));
        } else {
            out.push(p.to_string_lossy().into_owned());
        }
    }
    out
}

#[test]
fn a_finished_suite_replaces_the_previous_results_and_leaves_nothing_partial() {
    let root = std::env::temp_dir().join(format!("bayestrack-suite-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let seqs = root.join("seqs");
    sequence(&seqs);
    let out = root.join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("results.csv"), "old\n").unwrap();
    let options = SuiteOptions {
        trackers: vec![tracker_info("mad").unwrap()],
        seed: 0,
        set: Vec::new(),
        out: out.clone(),
        progress: false,
        published: None,
        shard: None,
        timing: Timing::Measured,
    };
    let report = run_suite(&seqs, &options).unwrap();
    assert_eq!(report.cells.len(), 1);
    assert!(report.cells[0].outcome.is_ok(), "{:?}", report.cells[0]);
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(
        csv.starts_with("sequence,tracker,success_rate_50,auc,"),
        "{csv}"
    );
    assert!(csv.contains("square,mad,"), "{csv}");
    let all = files(&out);
    assert!(
        all.iter().all(|f| !f.contains(".partial")
            && !f.ends_with(".tmp")
            && !f.ends_with("PARTIAL.txt")),
        "{all:?}"
    );
    let boxes = std::fs::read_to_string(out.join("boxes/mad/square.txt")).unwrap();
    assert_eq!(boxes.lines().count(), 3);
    // our own table: SR@0.5 / AUC / P@20 / fps per sequence and the mean
    let c = report.cells[0].outcome.as_ref().unwrap();
    let cell = format!(
        "{:.3} / {:.3} / {:.3} / {:.0}",
        c.score.success_rate_50, c.score.auc, c.score.precision_20, c.fps
    );
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(
        md.contains("OTB one-pass evaluation: SR@0.5 / AUC / P@20 / fps"),
        "{md}"
    );
    assert!(md.contains(&format!("| mad | {cell} | {cell} |")), "{md}");
    let mean = report.mean("mad").unwrap();
    assert_eq!(mean.success_rate_50, c.score.success_rate_50);
    assert_eq!((mean.auc, mean.sequences), (c.score.auc, 1));
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn published_results_sit_beside_ours_in_the_table_and_the_plot() {
    let root = std::env::temp_dir().join(format!("bayestrack-suite-pub-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let seqs = root.join("seqs");
    sequence(&seqs);
    let published = Published {
        dir: PathBuf::from("otb"),
        results: PublishedOpe::parse(
            "tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap\n\
             TLD,Square,0.6667,0.8\nMIL,square,0.3333,0.5\n",
            Path::new("published_ope.csv"),
        )
        .unwrap(),
        ranges: OtbFrameRanges::from_ranges([OtbFrameRange::new("Square", 1, 3)]),
    };
    let options = SuiteOptions {
        trackers: vec![tracker_info("mad").unwrap()],
        seed: 0,
        set: Vec::new(),
        out: root.join("out"),
        progress: false,
        published: Some(published),
        shard: None,
        timing: Timing::Measured,
    };
    let mut events = Vec::new();
    let report = run_suite_with(&seqs, &options, |e| {
        events.push(match e {
            SuiteEvent::Start { total, .. } => format!("start {total}"),
            SuiteEvent::Decoding { sequence } => format!("decoding {sequence}"),
            SuiteEvent::CellStarted {
                sequence, tracker, ..
            } => format!("{tracker} on {sequence}"),
            SuiteEvent::Frame { done } => format!("frame {done}"),
            SuiteEvent::CellFinished { cell, done } => format!("{} {done}", cell.tracker),
            _ => "other".into(),
        })
    })
    .unwrap();
    assert_eq!(
        events,
        [
            "start 3",
            "decoding square",
            "mad on square",
            "frame 1",
            "frame 2",
            "frame 3",
            "mad 3"
        ]
    );
    let score = &report.cells[0].outcome.as_ref().unwrap().score;
    let md = std::fs::read_to_string(root.join("out/results.md")).unwrap();
    let ours = format!(
        "| mad (ours) | {sr:.3} / {:.3} / {:.3} | {sr:.3} / {:.3} / {:.3} |",
        score.auc,
        score.precision_20,
        score.auc,
        score.precision_20,
        sr = score.success_rate_50
    );
    assert!(
        md.contains("| tracker | square | mean over square |"),
        "{md}"
    );
    assert!(md.contains(&ours), "{md}");
    assert!(md.contains("| TLD | 0.667 | 0.667 |"), "{md}");
    assert!(
        md.contains("- square: ours 3 frames, the benchmark's frames 1-3: the same frames"),
        "{md}"
    );
    for plot in ["success_square.svg", "success_overall.svg"] {
        let svg = std::fs::read_to_string(root.join("out").join(plot)).unwrap();
        assert!(
            svg.contains("TLD 0.667") && svg.contains("MIL 0.333"),
            "{plot}"
        );
    }
    let precision = std::fs::read_to_string(root.join("out/precision_overall.svg")).unwrap();
    assert!(!precision.contains("TLD"));
    std::fs::remove_dir_all(&root).unwrap();
}

/// `../shared/data/otb` as shipped: the 34 trackers on the 100 sequences,
/// each sequence with its frame range in the compiled OTB-100 table, and
/// which of our three copies have the benchmark's frames.
#[test]
fn the_shipped_published_results_read_whole() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/otb");
    if !dir.is_dir() {
        eprintln!(
            "skipped: {} is absent (the published OTB results are not part of the repository)",
            dir.display()
        );
        return;
    }
    let p = Published::read(&dir).unwrap();
    assert_eq!(p.results.trackers().len(), 34);
    assert_eq!(p.results.sequences().len(), 100);
    assert_eq!(p.ranges.ranges().len(), 100);
    for t in p.results.trackers() {
        for s in p.results.sequences() {
            assert!(p.results.score(t, s).is_some(), "{t} on {s}");
            assert!(p.ranges.get(s).is_some(), "no frame range for {s}");
        }
    }
    let david = p.ranges.get("David").unwrap();
    assert_eq!((david.start_frame, david.end_frame), (300, 770));
    // our copies (../shared/data/sequences): Crossing and Couple are the
    // benchmark's frames, David is the MIL tracker's 462-frame cut
    assert!(p.same_frames("Crossing", 120));
    assert!(p.same_frames("Couple", 140));
    assert!(!p.same_frames("David", 462));
    let muster = p.results.score("MUSTer", "Couple").unwrap();
    assert_eq!(muster.success_rate_50, 0.8);
    assert!(Published::is_missing(
        &Published::read(&dir.join("absent")).unwrap_err()
    ));
    // the published results alone are enough: the ranges are compiled in
    let alone = std::env::temp_dir().join(format!("bayestrack-published-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&alone);
    std::fs::create_dir_all(&alone).unwrap();
    std::fs::copy(dir.join(PUBLISHED_OPE_FILE), alone.join(PUBLISHED_OPE_FILE)).unwrap();
    let q = Published::read(&alone).unwrap();
    std::fs::remove_dir_all(&alone).unwrap();
    assert_eq!((q.results, q.ranges), (p.results, p.ranges));
}

/// A colour sequence with one gray frame: every tracker gets the frame
/// converted to colour, as `bayestrack track` gives it (issue 28: two
/// trackers' cells failed on it in `cargo xtask otb`).
#[test]
fn a_gray_frame_in_a_colour_sequence_is_converted_as_the_cli_does() {
    let root = std::env::temp_dir().join(format!("bayestrack-suite-mixed-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let dir = root.join("seqs").join("mixed");
    std::fs::create_dir_all(dir.join("img")).unwrap();
    let mut gt = String::new();
    for k in 0..4u32 {
        let inside = |x: u32, y: u32| (14 + k..26 + k).contains(&x) && (16..28).contains(&y);
        let path = dir.join("img").join(format!("{:04}.png", k + 1));
        if k == 2 {
            image::GrayImage::from_fn(48, 48, |x, y| {
                image::Luma([if inside(x, y) {
                    if (x / 3 + y / 3) % 2 == 0 { 230 } else { 20 }
                } else {
                    40 + ((x + y) % 9) as u8
                }])
            })
            .save(path)
            .unwrap();
        } else {
            image::RgbImage::from_fn(48, 48, |x, y| {
                image::Rgb(if inside(x, y) {
                    if (x / 3 + y / 3) % 2 == 0 {
                        [230, 200, 40]
                    } else {
                        [20, 20, 160]
                    }
                } else {
                    [30, 60 + ((x * 7 + y * 3) % 20) as u8, 90]
                })
            })
            .save(path)
            .unwrap();
        }
        gt.push_str(&format!("{},17,12,12\n", 15 + k));
    }
    std::fs::write(dir.join("groundtruth_rect.txt"), gt).unwrap();
    let options = SuiteOptions {
        trackers: bayestrack_trackers::REGISTRY.iter().collect(),
        seed: 0,
        set: Vec::new(),
        out: root.join("out"),
        progress: false,
        published: None,
        shard: None,
        timing: Timing::PerCall(1e-3),
    };
    let report = run_suite(&root.join("seqs"), &options).unwrap();
    let failures: Vec<String> = report
        .cells
        .iter()
        .filter_map(|c| {
            c.outcome
                .as_ref()
                .err()
                .map(|e| format!("{}: {e}", c.tracker))
        })
        .collect();
    assert!(failures.is_empty(), "{failures:?}");
    std::fs::remove_dir_all(&root).unwrap();
}
