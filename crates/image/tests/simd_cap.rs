//! `simd::set_max_level` (its own test binary: the cap is process-wide,
//! and the unit tests force levels in parallel threads).

use bayestrack_image::SadTemplate;
use bayestrack_image::simd::{self, Kernel, SimdLevel, Token, dispatch};

/// Reports the level it ran at.
struct Which;

impl Kernel for Which {
    type Output = SimdLevel;
    #[inline(always)]
    fn run<T: Token>(self, _: T) -> SimdLevel {
        T::LEVEL
    }
}

#[test]
fn a_capped_process_runs_at_most_the_cap() {
    let best = SimdLevel::detect();
    assert_eq!(simd::max_level(), SimdLevel::Avx512);
    let rank = |l: SimdLevel| SimdLevel::ALL.iter().position(|&a| a == l).unwrap();
    for cap in SimdLevel::ALL {
        simd::set_max_level(cap);
        assert_eq!(simd::max_level(), cap);
        let want = if rank(cap) < rank(best) { cap } else { best };
        assert_eq!(SimdLevel::detect(), want, "cap {cap:?}");
        assert_eq!(dispatch(Which), want, "cap {cap:?}");
        for level in SimdLevel::ALL {
            let ran = level.run(Which);
            assert!(
                rank(ran) <= rank(want),
                "cap {cap:?}, {level:?} ran at {ran:?}"
            );
            assert_eq!(level.is_available(), rank(level) <= rank(want));
        }
        assert_eq!(SadTemplate::new(SimdLevel::Avx512).level(), want);
        // Same sums whatever the cap.
        assert_eq!(
            bayestrack_image::sad_u8(&[1, 2, 250], &[3, 0, 5]),
            2 + 2 + 245
        );
    }
    simd::set_max_level(SimdLevel::Avx512);
    assert_eq!(SimdLevel::detect(), best);
}
