//! Arbitrary bytes into the Y4M reader, as they would arrive on standard
//! input: no panic, no allocation a header alone can ask for (a frame over
//! the pixel limit is refused before any is read), and every frame that
//! decodes has its header's size.
#![no_main]

use bayestrack_otb::Y4mSource;
use bayestrack_otb::y4m::Y4M_MAX_PIXELS;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Half the inputs get a valid small header, so the frame reader (FRAME
    // lines, bad markers, cut planes) is reached, not only the header.
    let with_header;
    let input = if data.first().is_some_and(|b| b & 1 == 1) {
        with_header = [&b"YUV4MPEG2 W5 H3 C420jpeg\n"[..], &data[1..]].concat();
        &with_header[..]
    } else {
        data
    };
    if let Ok(source) = Y4mSource::new(input, "fuzz") {
        let header = source.header().clone();
        assert!(header.width * header.height <= Y4M_MAX_PIXELS);
        for f in source.take(1024).flatten() {
            assert_eq!(
                (f.image.width(), f.image.height()),
                (header.width, header.height)
            );
        }
    }
});
