//! Arbitrary file names into the frame-folder scanner (what `bayestrack
//! track --seq DIR` lists): no panic, and a folder it accepts numbers its
//! frames one to one (no gap, no number twice), so no ground-truth row is
//! ever scored against another frame.
#![no_main]

use std::path::PathBuf;

use bayestrack_otb::{frame_number, order_frames};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // One file name per line (bytes, so names that are not UTF-8 too).
    let paths: Vec<PathBuf> = data
        .split(|&b| b == b'\n')
        .filter(|n| !n.is_empty() && !n.contains(&b'/') && !n.contains(&0))
        .take(256)
        .map(|n| {
            #[cfg(unix)]
            let name = {
                use std::os::unix::ffi::OsStrExt;
                std::ffi::OsStr::from_bytes(n).to_owned()
            };
            #[cfg(not(unix))]
            let name = std::ffi::OsString::from(String::from_utf8_lossy(n).into_owned());
            PathBuf::from("seq/img").join(name)
        })
        .collect();
    if let Ok(ordered) = order_frames(paths.clone()) {
        assert_eq!(ordered.len(), paths.len());
        let numbers: Vec<u64> = ordered
            .iter()
            .map(|p| {
                frame_number(p.file_name().and_then(|n| n.to_str()).expect("UTF-8 name"))
                    .expect("a numbered name")
            })
            .collect();
        for pair in numbers.windows(2) {
            assert_eq!(pair[1], pair[0] + 1, "{ordered:?}");
        }
    }
});
