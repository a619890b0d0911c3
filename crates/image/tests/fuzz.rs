//! Property tests: arbitrary bytes into the frame decoder never panic, and
//! what comes back `Ok` is finite (the ground-truth reader is
//! `bayestrack-otb`'s, fuzzed there).

#![cfg(feature = "io")]

use bayestrack_image::{Image, read_frame, write_png};
use proptest::prelude::*;

use bayestrack_testkit::strategies::cases;

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("bayestrack-fuzz-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

proptest! {
    // each case writes and decodes a file: few cases
    #![proptest_config(ProptestConfig { cases: cases(48), ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic_the_reader(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let dir = scratch("bytes");
        let path = dir.join("0001.png");
        std::fs::write(&path, &bytes).unwrap();
        if let Ok(img) = read_frame(&path) {
            prop_assert!(img.width() > 0 && img.height() > 0);
        }
    }

    #[test]
    fn damaged_png_frames_decode_whole_or_fail(
        w in 1usize..12,
        h in 1usize..12,
        seed in any::<u64>(),
        cut in 0.0f64..1.0,
        flips in prop::collection::vec((0.0f64..1.0, any::<u8>()), 0..4),
    ) {
        let dir = scratch("png");
        let path = dir.join(format!("{seed}.png"));
        let data: Vec<u8> = (0..w * h * 3).map(|i| (seed.wrapping_mul(i as u64 + 7) >> 13) as u8).collect();
        write_png(&path, Image::from_vec(w, h, 3, data.clone()).unwrap().view()).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        let whole = bytes.len();
        let damaged = !flips.is_empty();
        for (at, v) in flips {
            let i = ((bytes.len() - 1) as f64 * at) as usize;
            bytes[i] ^= v;
        }
        let keep = ((bytes.len() as f64) * (0.5 + cut / 2.0)) as usize;
        bytes.truncate(keep.max(1));
        std::fs::write(&path, &bytes).unwrap();
        match read_frame(&path) {
            Ok(img) => {
                prop_assert!(img.width() > 0 && img.height() > 0);
                // a truncated file decodes only when nothing but the end of
                // its IEND chunk is missing: then every pixel is there
                if !damaged {
                    prop_assert!(bytes.len() + 8 >= whole, "{} of {whole} bytes", bytes.len());
                    prop_assert_eq!(img.as_slice(), &data[..]);
                }
            }
            Err(e) => prop_assert!(e.to_string().contains(&format!("{seed}.png")), "{e}"),
        }
        let _ = std::fs::remove_file(&path);
    }
}

/// Issue 28 (arithmetic overflow in size computations): sizes at the edge
/// of `usize` give a typed error or a correct answer, never a panic (debug)
/// or a wrapped number (release).
mod sizes {
    use bayestrack_image::{Image, ImageError, Rect, dilate, erode};
    use proptest::prelude::*;

    fn size() -> impl Strategy<Value = usize> {
        prop_oneof![
            0usize..5,
            Just(usize::MAX),
            Just(usize::MAX / 2 + 1),
            Just(1usize << 32),
            Just(isize::MAX as usize),
            any::<usize>(),
        ]
    }

    #[test]
    fn images_too_large_for_memory_are_a_typed_error() {
        // width * channels overflowed in `new` when the height was 0
        assert!(matches!(
            Image::new(usize::MAX, 0, 2, 0u8),
            Err(ImageError::ZeroSize { .. })
        ));
        // from_fn multiplied width * height unchecked
        assert!(matches!(
            Image::from_fn(usize::MAX, 2, |_, _| 0u8),
            Err(ImageError::TooLarge { .. })
        ));
        // fits in usize, not in memory: vec! aborted or panicked
        assert!(matches!(
            Image::new(1 << 31, 1 << 31, 3, 0u8),
            Err(ImageError::TooLarge { .. })
        ));
        let mut img = Image::new(2, 2, 1, 0u8).unwrap();
        assert!(matches!(
            img.reshape(1 << 40, 1 << 20, 1, 0),
            Err(ImageError::TooLarge { .. })
        ));
        assert_eq!((img.width(), img.height()), (2, 2));
    }

    #[test]
    fn rect_edges_saturate() {
        let r = Rect::new(usize::MAX - 1, 5, 10, usize::MAX);
        assert_eq!(r.right(), usize::MAX);
        assert_eq!(r.bottom(), usize::MAX);
        assert_eq!(r.area(), usize::MAX);
        assert!(!r.fits_in(usize::MAX, usize::MAX));
    }

    #[test]
    fn a_huge_morphology_radius_is_the_whole_image() {
        let m = Image::from_fn(5, 4, |x, y| x == 2 && y == 1).unwrap();
        let d = dilate(m.view(), usize::MAX).unwrap();
        assert!(d.as_slice().iter().all(|&v| v));
        let e = erode(d.view(), usize::MAX).unwrap();
        assert!(e.as_slice().iter().all(|&v| v));
        let e = erode(m.view(), usize::MAX - 1).unwrap();
        assert!(e.as_slice().iter().all(|&v| !v));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: bayestrack_testkit::strategies::cases(256), ..ProptestConfig::default() })]

        #[test]
        fn any_geometry_is_an_image_or_an_error(w in size(), h in size(), c in size()) {
            // sizes that fit in memory are only built when small (the
            // others would allocate gigabytes)
            let n = w.checked_mul(h).and_then(|n| n.checked_mul(c));
            if n.is_some_and(|n| n > 1 << 20) {
                let r = Rect::new(w, h, c, w);
                prop_assert!(r.right() >= r.x && r.bottom() >= r.y);
                return Ok(());
            }
            if let Ok(img) = Image::new(w, h, c, 0u8) {
                prop_assert_eq!(img.as_slice().len(), w * h * c);
            }
            let r = Rect::new(w, h, c, w);
            prop_assert!(r.right() >= r.x && r.bottom() >= r.y);
            prop_assert_eq!(r.area(), r.width.saturating_mul(r.height));
            if let Ok(img) = Image::from_fn(w.min(64), h.min(64), |_, _| 1u8) {
                prop_assert_eq!(img.as_slice().len(), w.min(64) * h.min(64));
            }
            let mut img = Image::new(1, 1, 1, 0u8).unwrap();
            if img.reshape(w, h, c, 0).is_ok() {
                prop_assert_eq!(img.as_slice().len(), w * h * c);
            }
        }
    }
}
