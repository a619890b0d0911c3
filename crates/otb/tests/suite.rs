//! The OTB suite keeps its results whole: a finished run leaves no partial
//! files, and the files of a previous run are replaced only by renaming.

#![cfg(feature = "suite")]

use std::path::{Path, PathBuf};

use bayestrack_otb::suite::{SuiteOptions, run_suite};
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
        out: out.clone(),
        progress: false,
    };
    let report = run_suite(&seqs, &options).unwrap();
    assert_eq!(report.cells.len(), 1);
    assert!(report.cells[0].outcome.is_ok(), "{:?}", report.cells[0]);
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.starts_with("sequence,tracker,auc"), "{csv}");
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
    std::fs::remove_dir_all(&root).unwrap();
}
