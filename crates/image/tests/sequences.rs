//! Reads the real OTB sequences in `../shared/data/sequences` when present.
#![cfg(feature = "io")]

use std::path::PathBuf;

use bayestrack_image::{ImageError, OtbSequence, read_frame};

fn root() -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sequences");
    if root.is_dir() {
        Some(root)
    } else {
        eprintln!(
            "SKIPPED: sequence folder {} is missing; real-sequence checks not run",
            root.display()
        );
        None
    }
}

#[test]
fn frame_count_matches_ground_truth_rows() {
    let Some(root) = root() else { return };
    for (name, frames, channels, labelled) in [
        ("Crossing", 120, 3, 120),
        ("Couple", 140, 3, 140),
        ("David", 462, 1, 93),
    ] {
        let seq = OtbSequence::open(root.join(name)).unwrap();
        assert_eq!(seq.len(), frames, "{name}: frame count");
        assert_eq!(
            seq.ground_truth.len(),
            seq.len(),
            "{name}: ground-truth rows"
        );
        let n_labelled = seq.ground_truth.iter().flatten().count();
        assert_eq!(n_labelled, labelled, "{name}: labelled rows");
        assert!(seq.ground_truth[0].is_some(), "{name}: frame 1 labelled");
        // Every frame decodes (and passes the truncation check).
        for i in 0..seq.len() {
            let f = seq.frame(i).unwrap();
            assert_eq!(f.channels(), channels, "{name}: frame {i}");
        }
        let first = seq.frame(0).unwrap();
        let last = seq.frame(seq.len() - 1).unwrap();
        assert_eq!(first.channels(), channels, "{name}: channels");
        assert_eq!(
            (first.width(), first.height()),
            (last.width(), last.height())
        );
        // Numeric order: the first file is frame 1.
        let stem = seq.frames[0].file_stem().unwrap().to_str().unwrap();
        assert!(stem.ends_with("0001"), "{name}: first frame {stem}");
    }
}

#[test]
fn truncated_real_jpeg_is_an_error_naming_the_file() {
    let Some(root) = root() else { return };
    let src = root.join("Crossing/img/0001.jpg");
    let bytes = std::fs::read(&src).unwrap();
    let dir = std::env::temp_dir().join(format!("bayestrack-trunc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("0001.jpg");
    std::fs::write(&p, &bytes[..bytes.len() / 3]).unwrap();
    match read_frame(&p) {
        Err(e @ (ImageError::Decode { .. } | ImageError::Truncated { .. })) => {
            assert!(e.to_string().contains("0001.jpg"))
        }
        Ok(img) => panic!("a truncated JPEG decoded to {img:?}"),
        Err(e) => panic!("unexpected error {e}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
