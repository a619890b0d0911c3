//! Test helpers shared by the workspace's tests and benches (`publish =
//! false`; a path-only dev-dependency, which `cargo package` strips).
//!
//! - [`Lcg32`] and [`Lcg64`]: the two seeded linear congruential streams
//!   the tests draw their data from (no dependency, the same numbers on
//!   every platform; [`ansi_c_lcg`], a third, for one test), and
//!   [`noise`] / [`noise_bytes`], images and buffers of the first one's
//!   top bytes.
//! - [`paste`]: a target (a textured patch) pasted into a frame at a known
//!   place, for searches that must find it.
//! - [`strategies`]: proptest strategies the fuzz tests share.
//!
//! The streams are fixed: tests pin numbers computed from them, so a
//! change to a constant or to the order of the draws changes those tests'
//! data.
//!
//! `bayestrack-image`'s own unit tests cannot take this crate's `Image`
//! (the crate under test is a different copy of the type), so they use the
//! functions on plain buffers ([`noise_bytes`], [`Lcg32`]).

use bayestrack_image::{Image, ImageView, Pixel};

pub mod strategies;

/// The 32-bit LCG `s = s * 1664525 + 1013904223` (Numerical Recipes),
/// the stream of the workspace's noise images (and of
/// `tools/opencv_bench.py`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lcg32(pub u32);

impl Lcg32 {
    /// Advances the stream and returns the new state.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        self.0
    }

    /// The next state's top byte (the noise images' pixel).
    #[inline]
    pub fn byte(&mut self) -> u8 {
        (self.next_u32() >> 24) as u8
    }
}

/// The 64-bit LCG `s = s * 6364136223846793005 + 1442695040888963407`
/// (Knuth's MMIX constants), for uniform `f64` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lcg64(pub u64);

impl Lcg64 {
    /// Advances the stream and returns the new state.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0
    }

    /// A uniform draw in `[0, 1)`: the new state's top 53 bits.
    #[inline]
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniform draw in `[lo, hi)`.
    #[inline]
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// The states of the 32-bit LCG `s = s * 1103515245 + 12345` (the C
/// standard's example `rand`) from `seed`: a variant one test's data was
/// drawn from.
pub fn ansi_c_lcg(seed: u32) -> impl FnMut() -> u32 {
    let mut s = seed;
    move || {
        s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
        s
    }
}

/// `n` bytes of the [`Lcg32`] stream seeded with `seed` (each the top
/// byte of the next state).
pub fn noise_bytes(n: usize, seed: u32) -> Vec<u8> {
    let mut lcg = Lcg32(seed);
    (0..n).map(|_| lcg.byte()).collect()
}

/// A `w x h` image of `ch` channels filled, in memory order (rows, then
/// pixels, then channels), with [`noise_bytes`].
///
/// # Panics
/// On an empty geometry.
pub fn noise(w: usize, h: usize, ch: usize, seed: u32) -> Image<u8> {
    Image::from_vec(w, h, ch, noise_bytes(w * h * ch, seed)).expect("a noise image's geometry")
}

/// Copies `patch` into `frame` with its top-left pixel at `(x, y)` (a
/// target at a known place).
///
/// # Panics
/// If the patch leaves the frame or the channel counts differ.
pub fn paste<T: Pixel>(frame: &mut Image<T>, patch: ImageView<'_, T>, x: usize, y: usize) {
    let ch = frame.channels();
    assert_eq!(patch.channels(), ch, "paste: channel counts differ");
    assert!(
        x + patch.width() <= frame.width() && y + patch.height() <= frame.height(),
        "paste: the patch leaves the frame"
    );
    for r in 0..patch.height() {
        for c in 0..patch.width() {
            for k in 0..ch {
                let v = patch.get(c, r, k).expect("inside the patch");
                frame.set(x + c, y + r, k, v);
            }
        }
    }
}

/// Panics unless every file of `tests_dir` (each `*.rs` but the root, and
/// each folder with a `mod.rs`) is declared `mod <name>;` in `root_source`,
/// the text of a crate's one integration-test root (`tests/integration.rs`
/// under `autotests = false`): a file left out would never run.
pub fn assert_every_test_file_is_a_module(tests_dir: &str, root: &str, root_source: &str) {
    for entry in std::fs::read_dir(tests_dir).unwrap_or_else(|e| panic!("{tests_dir}: {e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{tests_dir}: {e}")).path();
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let module = path.extension().is_some_and(|e| e == "rs") && stem != root
            || path.join("mod.rs").is_file();
        assert!(
            !module || root_source.contains(&format!("\nmod {stem};\n")),
            "{tests_dir}/{stem} is not a module of {root}.rs: its tests never run"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_streams_are_the_pinned_ones() {
        let mut a = Lcg32(1);
        assert_eq!(a.next_u32(), 1_015_568_748);
        assert_eq!(
            noise_bytes(2, 1),
            [(1_015_568_748u32 >> 24) as u8, Lcg32(1_015_568_748).byte()]
        );
        let mut b = Lcg64(19);
        let u = b.unit();
        assert!((0.0..1.0).contains(&u));
        let img = noise(5, 4, 3, 9);
        assert_eq!(img.as_slice(), noise_bytes(60, 9).as_slice());
    }

    #[test]
    fn paste_puts_the_patch_where_asked() {
        let mut frame = noise(20, 10, 1, 1);
        let patch = noise(4, 3, 1, 2);
        paste(&mut frame, patch.view(), 15, 6);
        for y in 0..3 {
            for x in 0..4 {
                assert_eq!(frame.get(15 + x, 6 + y, 0), patch.get(x, y, 0));
            }
        }
    }
}
