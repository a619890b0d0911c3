//! What both appearance benches build their frames from.

use bayestrack_image::Image;

/// A `w x h x ch` image of LCG noise (`s = s * 1664525 + 1013904223`, the
/// top byte), as tools/opencv_bench.py reproduces it.
pub fn noise(w: usize, h: usize, ch: usize, seed: u32) -> Image<u8> {
    let mut img = Image::new(w, h, ch, 0u8).unwrap();
    let mut s = seed;
    for v in img.as_mut_slice() {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *v = (s >> 24) as u8;
    }
    img
}
