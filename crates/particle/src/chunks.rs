//! Chunked parallel passes with one random stream per chunk, shared by the
//! auxiliary, Rao-Blackwellised and smoothing passes: the chunk `c` of a
//! pass keyed `key` draws from `stream_rng(key ++ [c])`, so the same key
//! gives the same bits on any number of threads.

use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::error::{ParticleError, Result};
use crate::seed::stream_rng;

/// Checks a chunk size.
pub(crate) fn check_chunk_size(chunk_size: usize) -> Result<()> {
    if chunk_size == 0 {
        return Err(ParticleError::InvalidParameter {
            name: "chunk_size",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    Ok(())
}

/// Runs `f(offset, a, b, rng)` over the chunks of `a` and `b` (of equal
/// lengths) in parallel (on the calling thread when there is one chunk);
/// returns the first error in chunk order.
pub(crate) fn for_chunks<A, B, F>(
    chunk_size: usize,
    a: &mut [A],
    b: &mut [B],
    key: &[u64],
    f: F,
) -> Result<()>
where
    A: Send,
    B: Send,
    F: Fn(usize, &mut [A], &mut [B], &mut Xoshiro256PlusPlus) -> Result<()> + Sync,
{
    debug_assert_eq!(a.len(), b.len());
    let run = |(c, (a, b)): (usize, (&mut [A], &mut [B]))| {
        let mut rng = stream_rng(&[key, &[c as u64]].concat());
        f(c * chunk_size, a, b, &mut rng)
    };
    if a.len() <= chunk_size {
        return run((0, (a, b)));
    }
    let results: Vec<Result<()>> = a
        .par_chunks_mut(chunk_size)
        .zip(b.par_chunks_mut(chunk_size))
        .enumerate()
        .map(run)
        .collect();
    results.into_iter().collect()
}
