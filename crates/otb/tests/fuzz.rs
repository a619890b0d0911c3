//! Property tests: arbitrary text and bytes into the ground-truth reader,
//! the Y4M reader and the frame-folder scanner never panic; what the
//! ground-truth reader returns `Ok` is a box `--init` would accept, what
//! the Y4M reader returns is a frame of its header's size, bounded before
//! any frame is read, and what the scanner returns numbers the frames one
//! to one (frame decoding is `bayestrack-image`'s, fuzzed there). The
//! cargo-fuzz targets in `fuzz/` run the same checks for longer.

use std::path::PathBuf;

use bayestrack_otb::Y4mSource;
use bayestrack_otb::ground_truth::{check_box, parse_ground_truth, read_ground_truth};
use bayestrack_otb::y4m::Y4M_MAX_PIXELS;
use bayestrack_otb::{frame_number, order_frames};
use proptest::prelude::*;

/// The case count: `n`, or `PROPTEST_CASES` when set (a longer hunt).
fn cases(n: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(n)
}

/// A token of a ground-truth row: numbers of every kind and junk.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        (-1e4f64..1e4).prop_map(|v| format!("{v:.3}")),
        Just("0".to_string()),
        Just("nan".to_string()),
        Just("-inf".to_string()),
        Just("1e309".to_string()),
        "[ -~]{0,6}",
    ]
}

/// Rows of 2 to 5 tokens joined by commas, tabs or spaces.
fn ground_truth_text() -> impl Strategy<Value = String> {
    prop::collection::vec(
        (
            prop::collection::vec(token(), 2..6),
            prop::sample::select(vec![",", "\t", " ", ", "]),
        ),
        0..6,
    )
    .prop_map(|rows| {
        rows.into_iter()
            .map(|(t, sep)| t.join(sep))
            .collect::<Vec<_>>()
            .join("\n")
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn ground_truth_rows_parse_to_finite_boxes_or_name_the_line(text in ground_truth_text()) {
        match parse_ground_truth(&text, "gt.txt") {
            Ok(rows) => {
                for b in rows.iter().flatten() {
                    // the rule of --init: finite, w, h > 0, far edges finite
                    prop_assert!(check_box(b.x, b.y, b.width, b.height).is_ok(), "{b:?}");
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("gt.txt"), "{e}"),
        }
    }

    #[test]
    fn arbitrary_text_never_panics_the_ground_truth_parser(text in "\\PC{0,80}") {
        let _ = parse_ground_truth(&text, "gt.txt");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(48), ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic_the_reader(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let dir = std::env::temp_dir().join(format!("bayestrack-otb-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let gt = dir.join("groundtruth_rect.txt");
        std::fs::write(&gt, &bytes).unwrap();
        if let Ok(rows) = read_ground_truth(&gt) {
            for b in rows.iter().flatten() {
                prop_assert!([b.x, b.y, b.width, b.height].iter().all(|v| v.is_finite()));
            }
        }
    }
}

/// Y4M bytes: a header with sizes (some huge), colour spaces, CR or not,
/// then FRAME lines (some broken) and plane data of any length.
fn y4m_bytes() -> impl Strategy<Value = Vec<u8>> {
    (
        prop_oneof![
            1usize..24,
            Just(32768),
            Just(1 << 14),
            any::<u16>().prop_map(usize::from)
        ],
        prop_oneof![1usize..24, Just(32768), Just(1 << 14)],
        prop::sample::select(vec![
            "",
            " C420jpeg",
            " C444",
            " Cmono",
            " C422",
            " C444alpha",
            " C411",
        ]),
        prop::sample::select(vec!["\n", "\r\n", ""]),
        prop::collection::vec(
            (
                prop::sample::select(vec!["FRAME\n", "FRAMX\n", "FRAME Ixyz\n", "", "FRAME"]),
                prop::collection::vec(any::<u8>(), 0..600),
            ),
            0..5,
        ),
    )
        .prop_map(|(w, h, c, end, frames)| {
            let mut out = format!("YUV4MPEG2 W{w} H{h}{c}{end}").into_bytes();
            for (marker, data) in frames {
                out.extend(marker.as_bytes());
                out.extend(data);
            }
            out
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn the_y4m_reader_never_panics_and_bounds_what_a_header_asks(bytes in y4m_bytes()) {
        match Y4mSource::new(&bytes[..], "fuzz") {
            Ok(source) => {
                let header = source.header().clone();
                prop_assert!(header.width * header.height <= Y4M_MAX_PIXELS);
                // at most one frame per FRAME-sized chunk of input, and it
                // ends (a stream cannot loop)
                for f in source.take(64).flatten() {
                    prop_assert_eq!(
                        (f.image.width(), f.image.height()),
                        (header.width, header.height)
                    );
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("fuzz"), "{e}"),
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_y4m_reader(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut input = b"YUV4MPEG2 W3 H2 C444\n".to_vec();
        input.extend(&bytes);
        if let Ok(source) = Y4mSource::new(&input[..], "fuzz") {
            for frame in source.take(64) {
                let _ = frame;
            }
        }
        let _ = Y4mSource::new(&bytes[..], "fuzz").map(|s| s.take(8).count());
    }

    #[test]
    fn the_frame_folder_scanner_numbers_frames_one_to_one_or_names_the_file(
        names in prop::collection::vec(
            prop_oneof![
                (0u64..40).prop_map(|n| format!("{n:04}.png")),
                (0u64..40).prop_map(|n| format!("img{n:05}.jpg")),
                (0u64..40).prop_map(|n| format!("{n}.png")),
                "[a-z0-9]{0,6}\\.png",
                Just("99999999999999999999999.png".to_string()),
            ],
            0..12,
        )
    ) {
        let paths: Vec<PathBuf> = names.iter().map(|n| PathBuf::from("seq/img").join(n)).collect();
        match order_frames(paths.clone()) {
            Ok(ordered) => {
                prop_assert_eq!(ordered.len(), paths.len());
                let numbers: Vec<u64> = ordered
                    .iter()
                    .map(|p| frame_number(p.file_name().unwrap().to_str().unwrap()).unwrap())
                    .collect();
                for pair in numbers.windows(2) {
                    prop_assert_eq!(pair[1], pair[0] + 1, "{:?}", ordered);
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("seq/img/"), "{e}"),
        }
    }
}

/// Found by the `frame_folder` fuzz target: a multi-byte character before
/// the number (`*ť8ť`) panicked the number reader.
#[test]
fn a_multibyte_character_before_the_number_is_read() {
    assert_eq!(frame_number("*\u{165}8\u{165}"), Some(8));
    assert_eq!(frame_number("\u{e9}t\u{e9}0012.png"), Some(12));
    let ordered = order_frames(vec![
        PathBuf::from("s/\u{165}2.png"),
        PathBuf::from("s/\u{165}1.png"),
    ])
    .unwrap();
    assert_eq!(ordered[0], PathBuf::from("s/\u{165}1.png"));
}

#[cfg(unix)]
#[test]
fn a_non_utf8_frame_name_is_refused_naming_it() {
    use std::os::unix::ffi::OsStrExt;
    let odd = PathBuf::from("seq/img").join(std::ffi::OsStr::from_bytes(b"\xff0002.png"));
    let e = order_frames(vec![PathBuf::from("seq/img/0001.png"), odd]).unwrap_err();
    assert!(e.to_string().contains("UTF-8"), "{e}");
}
