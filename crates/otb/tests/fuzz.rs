//! Property tests: arbitrary text and bytes into the ground-truth reader
//! never panic, and what comes back `Ok` is finite (frame decoding is
//! `bayestrack-image`'s, fuzzed there).

use bayestrack_otb::ground_truth::{parse_ground_truth, read_ground_truth};
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
                    prop_assert!([b.x, b.y, b.width, b.height].iter().all(|v| v.is_finite()));
                    prop_assert!(b.width >= 0.0 && b.height >= 0.0);
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
