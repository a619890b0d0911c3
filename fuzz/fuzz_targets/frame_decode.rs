//! Arbitrary bytes into frame decoding (PNG/JPEG): no panic, and a decoded
//! frame has pixels.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = bayestrack_image::decode_frame(data, "0001.png") {
        assert!(img.width() > 0 && img.height() > 0);
        assert_eq!(img.as_slice().len(), img.width() * img.height() * img.channels());
    }
});
