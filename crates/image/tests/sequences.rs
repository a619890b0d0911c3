//! Decodes the real OTB sequences' frames in `../shared/data/sequences`
//! when present (loading sequences with their ground truth is
//! `bayestrack-otb`'s, tested there).
#![cfg(feature = "io")]

use std::path::PathBuf;

use bayestrack_image::{FramePool, ImageError, read_frame};

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

/// Every frame of the real sequences, read through one [`FramePool`] as
/// `bayestrack track` reads a folder (each frame decoded into the buffer
/// an earlier one gave back), has the pixels the image crate's own
/// loading gives.
#[test]
fn real_frames_through_a_pool_are_the_image_crates_pixels() {
    let Some(root) = root() else { return };
    let pool = FramePool::new();
    let mut frames = 0;
    for seq in ["Crossing", "Couple", "David"] {
        let dir = root.join(seq).join("img");
        let Ok(paths) = bayestrack_image::list_frames(&dir) else {
            eprintln!("SKIPPED: {} is missing", dir.display());
            continue;
        };
        for p in paths {
            let got = pool.read_frame(&p).unwrap();
            let want = image::open(&p).unwrap();
            let want = if want.color().has_color() {
                want.into_rgb8().into_raw()
            } else {
                want.into_luma8().into_raw()
            };
            assert_eq!(got.as_slice(), &want[..], "{}", p.display());
            pool.give_back(got);
            frames += 1;
        }
    }
    eprintln!("{frames} real frames compared");
}
