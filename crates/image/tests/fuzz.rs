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
