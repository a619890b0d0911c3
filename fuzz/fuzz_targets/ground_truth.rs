//! Arbitrary bytes into the OTB ground-truth parser: no panic, and every
//! parsed box is finite with non-negative size.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(rows) =
        bayestrack_otb::ground_truth::parse_ground_truth(&text, "groundtruth_rect.txt")
    {
        for b in rows.iter().flatten() {
            assert!([b.x, b.y, b.width, b.height].iter().all(|v| v.is_finite()));
            assert!(b.width >= 0.0 && b.height >= 0.0);
        }
    }
});
