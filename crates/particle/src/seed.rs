//! Seeds for independent random streams, derived from a key.
//!
//! Every random stream of a run is `Xoshiro256PlusPlus::seed_from_u64` of a
//! seed mixed from a key such as (experiment, run, step, chunk), so results
//! do not depend on the order in which threads execute.

use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// SplitMix64 finaliser: a bijective 64-bit mixer.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seed mixed from the parts of a key; different keys give unrelated seeds.
#[inline]
pub fn stream_seed(key: &[u64]) -> u64 {
    key.iter()
        .fold(0x6261_7965_7374_7261, |h, &k| mix(h ^ mix(k)))
}

/// `stream_seed` of `key` followed by `part`, from `stream_seed(key)`: the
/// per-chunk seeds of a step without building each chunk's key.
#[inline]
pub(crate) fn extend_seed(seed: u64, part: u64) -> u64 {
    mix(seed ^ mix(part))
}

/// The generator for a key.
#[inline]
pub fn stream_rng(key: &[u64]) -> Xoshiro256PlusPlus {
    Xoshiro256PlusPlus::seed_from_u64(stream_seed(key))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_give_distinct_seeds() {
        let mut seeds: Vec<u64> = (0..100)
            .flat_map(|a| (0..100).map(move |b| stream_seed(&[a, b])))
            .collect();
        seeds.sort_unstable();
        seeds.dedup();
        assert_eq!(seeds.len(), 10_000);
        assert_ne!(stream_seed(&[1, 2]), stream_seed(&[2, 1]));
        assert_eq!(stream_seed(&[7, 8, 9]), stream_seed(&[7, 8, 9]));
        assert_eq!(
            extend_seed(stream_seed(&[7, 8]), 9),
            stream_seed(&[7, 8, 9])
        );
    }
}
