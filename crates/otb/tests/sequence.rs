//! The sequence loader on the real sequences in `../shared/data/sequences`
//! and on bad input.

use std::fs;
use std::path::{Path, PathBuf};

use bayestrack_image::{BBox, Image, ImageError, write_png};
use bayestrack_otb::OtbError;
use bayestrack_otb::metrics::score_otb;
use bayestrack_otb::{Sequence, list_sequences};

fn sequences_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sequences")
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bayestrack-otb-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn real_sequences_load_with_one_row_per_frame() {
    let root = sequences_root();
    if !root.is_dir() {
        eprintln!(
            "SKIPPED: the real OTB sequences are not at {} (expected ../shared/data/sequences \
             next to the repository); nothing to check",
            root.display()
        );
        return;
    }
    let found = list_sequences(&root).unwrap();
    let names: Vec<_> = found
        .iter()
        .map(|p| p.file_name().unwrap().to_str().unwrap().to_string())
        .collect();
    for (name, frames, size, labelled_all) in [
        ("Crossing", 120, (360, 240, 3), true),
        ("Couple", 140, (320, 240, 3), true),
        ("David", 462, (320, 240, 1), false),
    ] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} not listed in {names:?}"
        );
        let seq = Sequence::open(root.join(name)).unwrap();
        assert_eq!(seq.name, name);
        assert_eq!(seq.len(), frames, "{name}: frames");
        assert_eq!(seq.ground_truth.len(), seq.len(), "{name}: rows == frames");
        assert!(seq.initial_box().is_some(), "{name}: frame 1 is labelled");
        if labelled_all {
            assert_eq!(seq.labelled(), frames, "{name}");
        } else {
            // David: every 5th frame is labelled, the rest is 0,0,0,0.
            assert!(
                seq.labelled() > frames / 6 && seq.labelled() < frames / 4,
                "{name}"
            );
            assert_eq!(seq.ground_truth[1], None);
            assert_eq!(seq.labelled(), 93, "{name}: labelled rows");
        }
        // Numeric order: the first file is frame 1.
        assert!(seq.frame_name(0).contains("0001"), "{name}: first frame");
        // Every frame decodes (and passes the truncation check) at one size.
        assert_eq!(seq.check_frames().unwrap(), size, "{name}: frame size");
        // Ground truth scored against itself is perfect; unlabelled frames are skipped.
        let pred: Vec<BBox> = seq
            .ground_truth
            .iter()
            .map(|b| b.unwrap_or(BBox::new(f64::NAN, 0.0, 0.0, 0.0)))
            .collect();
        let s = score_otb(&pred, &seq.ground_truth).unwrap();
        assert_eq!(s.frames_scored, seq.labelled());
        assert_eq!((s.auc, s.precision_20), (20.0 / 21.0, 1.0), "{name}");
    }
    let gray = Sequence::open(root.join("David")).unwrap();
    assert_eq!(gray.frame_rgb(0).unwrap().channels(), 3);
    assert_eq!(gray.frame_gray(0).unwrap().channels(), 1);
    assert!(matches!(
        gray.frame(10_000),
        Err(OtbError::IndexOutOfRange {
            index: 10_000,
            len: 462
        })
    ));
}

/// A valid 3-frame sequence folder.
fn make_sequence(name: &str, gt: &str) -> PathBuf {
    let d = tmpdir(name);
    fs::create_dir_all(d.join("img")).unwrap();
    let img = Image::from_fn(16, 12, |x, y| (x * 10 + y) as u8).unwrap();
    for i in 1..=3 {
        write_png(d.join(format!("img/{i:04}.png")), img.view()).unwrap();
    }
    fs::write(d.join("groundtruth_rect.txt"), gt).unwrap();
    d
}

#[test]
fn a_small_valid_sequence_opens() {
    let d = make_sequence("valid", "1,1,4,4\n0,0,0,0\n2\t2\t4\t4\n");
    let s = Sequence::open(&d).unwrap();
    assert_eq!(s.len(), 3);
    assert_eq!(
        s.ground_truth,
        [
            Some(BBox::new(1.0, 1.0, 4.0, 4.0)),
            None,
            Some(BBox::new(2.0, 2.0, 4.0, 4.0))
        ]
    );
    assert_eq!(s.labelled(), 2);
    assert_eq!(s.check_frames().unwrap(), (16, 12, 1));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn missing_folder_is_a_typed_error() {
    let missing = std::env::temp_dir().join("bayestrack-otb-no-such-sequence");
    match Sequence::open(&missing) {
        Err(OtbError::MissingFolder { path }) => assert_eq!(path, missing),
        other => panic!("expected MissingFolder, got {other:?}"),
    }
    assert!(matches!(
        list_sequences(&missing),
        Err(OtbError::MissingFolder { .. })
    ));
}

#[test]
fn frames_past_the_last_ground_truth_row_are_unlabelled_and_noted() {
    let d = make_sequence("rows", "1,1,4,4\n2,2,4,4\n");
    let s = Sequence::open(&d).unwrap();
    assert_eq!((s.len(), s.ground_truth_rows, s.labelled()), (3, 2, 2));
    assert_eq!(s.ground_truth[2], None);
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("frames 3-3 have no ground-truth row")),
        "{:?}",
        s.notes
    );
    // More rows than frames: which row is which frame is unknown.
    fs::write(d.join("groundtruth_rect.txt"), "1,1,4,4\n".repeat(4)).unwrap();
    match Sequence::open(&d) {
        Err(
            e @ OtbError::RowCount {
                frames: 3, rows: 4, ..
            },
        ) => {
            assert!(e.to_string().contains("groundtruth_rect.txt"), "{e}");
        }
        other => panic!("expected RowCount, got {other:?}"),
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn bad_ground_truth_line_names_the_line() {
    let d = make_sequence("badline", "1,1,4,4\n1,1,four,4\n1,1,4,4\n");
    match Sequence::open(&d) {
        Err(e @ OtbError::GroundTruth { line: 2, .. }) => {
            assert!(e.to_string().contains("groundtruth_rect.txt:2"), "{e}");
        }
        other => panic!("expected a parse error on line 2, got {other:?}"),
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn truncated_or_non_image_frames_name_the_file() {
    let d = make_sequence("badframe", "1,1,4,4\n1,1,4,4\n1,1,4,4\n");
    let second = d.join("img/0002.png");
    let bytes = fs::read(&second).unwrap();
    fs::write(&second, &bytes[..bytes.len() / 2]).unwrap();
    fs::write(d.join("img/0003.png"), "not a PNG at all").unwrap();
    let s = Sequence::open(&d).unwrap();
    assert!(s.frame(0).is_ok());
    for (index, file) in [(1, "0002.png"), (2, "0003.png")] {
        match s.frame(index) {
            Err(e @ OtbError::Frame { .. }) => {
                let text = e.to_string();
                assert!(text.contains(file), "{text}");
                assert!(text.contains(&format!("frame {} ", index + 1)), "{text}");
            }
            other => panic!("frame {index}: expected a Frame error, got {other:?}"),
        }
    }
    assert!(matches!(
        s.check_frames(),
        Err(OtbError::Frame { index: 1, .. })
    ));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn empty_folder_has_no_frames() {
    let d = tmpdir("empty");
    assert!(matches!(
        Sequence::open(&d),
        Err(OtbError::Image(ImageError::NoFrames { .. }))
    ));
    let _ = fs::remove_dir_all(&d);
}
