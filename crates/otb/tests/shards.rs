//! The OTB suite split into shards (`cargo xtask otb --shard K/N`) and
//! merged (`--merge`) writes the files of a run on one machine, byte for
//! byte; a merge that cannot be done says why and keeps earlier results.

#![cfg(feature = "suite")]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use bayestrack_otb::published::{OtbFrameRange, OtbFrameRanges, Published, PublishedOpe};
use bayestrack_otb::shard::Shard;
use bayestrack_otb::suite::{SuiteOptions, Timing, merge, run_suite};
use bayestrack_trackers::tracker_info;

/// A 4-frame sequence `name` of a bright square moving right by `step` px
/// a frame, gray or colour; `truth: false` leaves out the ground truth
/// (the sequence does not open: its cells fail).
fn sequence(root: &Path, name: &str, step: u32, colour: bool, truth: bool) {
    let dir = root.join(name);
    std::fs::create_dir_all(dir.join("img")).unwrap();
    let mut gt = String::new();
    for k in 0..4u32 {
        let x0 = 12 + k * step;
        let value = |x: u32, y: u32| {
            if (x0..x0 + 12).contains(&x) && (16..28).contains(&y) {
                220
            } else {
                30 + ((x * 7 + y * 3) % 20) as u8
            }
        };
        let path = dir.join("img").join(format!("{:04}.png", k + 1));
        if colour {
            image::RgbImage::from_fn(48, 40, |x, y| {
                let v = value(x, y);
                image::Rgb([v, v / 2, 255 - v])
            })
            .save(path)
            .unwrap();
        } else {
            image::GrayImage::from_fn(48, 40, |x, y| image::Luma([value(x, y)]))
                .save(path)
                .unwrap();
        }
        gt.push_str(&format!("{},16,12,12\n", x0 + 1));
    }
    if truth {
        std::fs::write(dir.join("groundtruth_rect.txt"), gt).unwrap();
    }
}

/// Every file and folder under `dir`, by path relative to it, with its
/// bytes (`None` for a folder).
fn tree(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Option<Vec<u8>>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(root).unwrap().to_path_buf();
            if p.is_dir() {
                out.insert(rel, None);
                walk(root, &p, out);
            } else {
                out.insert(rel, Some(std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn options(out: PathBuf, shard: Option<Shard>) -> SuiteOptions {
    let published = Published {
        dir: PathBuf::from("otb"),
        results: PublishedOpe::parse(
            "tracker,sequence,success_rate_iou_0.5,mean_overlap_of_frames_with_overlap\n\
             TLD,gray,0.6667,0.8\nMIL,colour,0.3333,0.5\n",
            Path::new("published_ope.csv"),
        )
        .unwrap(),
        ranges: OtbFrameRanges::from_ranges([
            OtbFrameRange::new("gray", 1, 4),
            OtbFrameRange::new("colour", 1, 9),
        ]),
    };
    SuiteOptions {
        trackers: ["mad", "ncc-scale", "condensation-points"]
            .iter()
            .map(|n| tracker_info(n).unwrap())
            .collect(),
        seed: 7,
        set: Vec::new(),
        out,
        progress: false,
        published: Some(published),
        shard,
        timing: Timing::PerCall(0.001),
    }
}

#[test]
fn shards_merged_write_the_files_of_one_run_byte_for_byte() {
    let root = std::env::temp_dir().join(format!("bayestrack-shards-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let seqs = root.join("seqs");
    sequence(&seqs, "colour", 1, true, true);
    sequence(&seqs, "gray", 2, false, true);
    sequence(&seqs, "nogt", 1, false, false);

    let single = root.join("single");
    let report = run_suite(&seqs, &options(single.clone(), None)).unwrap();
    // the suite has every kind of cell: scored, n/a (the colour tracker on
    // the gray sequence) and failed (a sequence without ground truth)
    let kinds: Vec<String> = report
        .cells
        .iter()
        .map(|c| match &c.outcome {
            Ok(_) => "ok".into(),
            Err(e) => e.label(),
        })
        .collect();
    let failed = "failed".to_string();
    let mut want = vec!["ok".to_string(); 5];
    want.push("n/a (needs colour)".into());
    want.extend([failed.clone(), failed.clone(), failed]);
    assert_eq!(kinds, want);
    let expected = tree(&single);
    assert!(expected.contains_key(Path::new("results.md")));
    assert!(expected.contains_key(Path::new("boxes/mad/gray.txt")));

    for n in [2, 3] {
        let shards: Vec<PathBuf> = (1..=n)
            .map(|k| {
                let dir = root.join(format!("shard{k}of{n}"));
                let shard = Shard::new(k, n).unwrap();
                let part = run_suite(&seqs, &options(dir.clone(), Some(shard))).unwrap();
                assert_eq!(part.cells.len(), (9 - k + n) / n, "shard {shard}");
                assert!(!dir.join("results.csv").exists());
                dir
            })
            .collect();
        let merged = root.join(format!("merged{n}"));
        let report = merge(&shards, &merged, options(merged.clone(), None).published).unwrap();
        assert_eq!(report.cells.len(), 9);
        let got = tree(&merged);
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            expected.keys().collect::<Vec<_>>(),
            "{n} shards: the files"
        );
        for (path, bytes) in &expected {
            assert!(
                got[path] == *bytes,
                "{n} shards: {} differs",
                path.display()
            );
        }
    }

    // a shard missing: nothing written, the earlier results kept
    let merged = root.join("merged3");
    let before = tree(&merged);
    let two: Vec<PathBuf> = [1, 3]
        .iter()
        .map(|k| root.join(format!("shard{k}of3")))
        .collect();
    let e = merge(&two, &merged, None).unwrap_err().to_string();
    assert!(e.contains("give the folders of shard(s) 2/3"), "{e}");
    // the same shard twice, or shards of two splits
    let twice = [root.join("shard1of3"), root.join("shard1of3")];
    let e = merge(&twice, &merged, None).unwrap_err().to_string();
    assert!(e.contains("holds shard 1/3, and so does"), "{e}");
    let mixed = [root.join("shard1of2"), root.join("shard2of3")];
    let e = merge(&mixed, &merged, None).unwrap_err().to_string();
    assert!(e.contains("from another suite run"), "{e}");
    // an unfinished shard
    std::fs::write(root.join("shard2of3/PARTIAL.txt"), "running").unwrap();
    let all: Vec<PathBuf> = (1..=3).map(|k| root.join(format!("shard{k}of3"))).collect();
    let e = merge(&all, &merged, None).unwrap_err().to_string();
    assert!(e.contains("shard2of3") && e.contains("PARTIAL.txt"), "{e}");
    assert!(
        tree(&merged) == before,
        "a failed merge changed its output folder"
    );
    std::fs::remove_dir_all(&root).unwrap();
}
