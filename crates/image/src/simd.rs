//! Run-time CPU dispatch, in safe code: the one way the workspace's
//! vector kernels pick an instruction set.
//!
//! A kernel is a value holding its data whose [`Kernel::run`] is the loop,
//! generic over a [`Token`] (the proof that an instruction set is
//! available). [`dispatch`] runs it compiled for the best level this CPU
//! has; [`SimdLevel::run`] for a given level (tests force each level this
//! way and compare the bits with the scalar reference). The body is
//! compiled once per level inside a function that enables that level's
//! target features (through the `pulp` crate's tokens), so a loop the
//! compiler vectorises by itself gets AVX2 or AVX-512 code with no
//! intrinsics written; the image crate's hand-written kernels (the SAD and
//! warp kernels) also take the token's intrinsics.
//!
//! `Kernel::run` and everything its hot loop calls must be
//! `#[inline(always)]`: a function that is not inlined into the dispatched
//! copy runs the baseline code. Kernels use no fused multiply-add and sum
//! in a fixed order, so every level gives the same bits (a kernel that
//! must reproduce another library's fused products writes them as
//! `mul_add`, exactly rounded at every level: the dcf crate's FFT rows).
//!
//! ```
//! use bayestrack_image::simd::{Kernel, SimdLevel, Token, dispatch};
//!
//! /// `sum |a_k - b_k|` over two byte rows.
//! struct AbsDiffSum<'a>(&'a [u8], &'a [u8]);
//!
//! impl Kernel for AbsDiffSum<'_> {
//!     type Output = u32;
//!     #[inline(always)]
//!     fn run<T: Token>(self, _: T) -> u32 {
//!         self.0.iter().zip(self.1).map(|(&a, &b)| u32::from(a.abs_diff(b))).sum()
//!     }
//! }
//!
//! let (a, b) = ([3u8; 100], [5u8; 100]);
//! assert_eq!(dispatch(AbsDiffSum(&a, &b)), 200);
//! for level in SimdLevel::ALL {
//!     // An unavailable level runs at the best one this CPU has.
//!     assert_eq!(level.run(AbsDiffSum(&a, &b)), 200);
//! }
//! ```

use std::sync::atomic::{AtomicU8, Ordering};

mod lanes;

pub use lanes::{
    F32x8, add8, complex_parts, complex_parts_mut, deinterleave8, interleave8, mul_add8, mul8,
    neg8, sub8, transpose8,
};

/// An instruction set the kernels can run with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SimdLevel {
    /// Plain Rust, no target features (the reference; the hand-written
    /// kernels go one element at a time).
    Scalar,
    /// The x86-64 baseline: SSE2 (the SAD kernels' 16-byte `psadbw`).
    Sse2,
    /// x86-64-v3: AVX2 and FMA (32-byte vectors).
    Avx2,
    /// x86-64-v4: AVX-512F, BW, CD, DQ and VL (64-byte vectors; the SAD
    /// kernels take their AVX2 form for rows of at most 32 bytes).
    Avx512,
}

impl SimdLevel {
    /// Every level, scalar first.
    pub const ALL: [SimdLevel; 4] = [
        SimdLevel::Scalar,
        SimdLevel::Sse2,
        SimdLevel::Avx2,
        SimdLevel::Avx512,
    ];

    /// The best level this CPU runs (the CPU is queried once per level,
    /// then the answer is cached).
    pub fn detect() -> Self {
        [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Sse2]
            .into_iter()
            .find(|l| l.is_available())
            .unwrap_or(SimdLevel::Scalar)
    }

    /// Whether this CPU runs the level and [`set_max_level`] allows it.
    pub fn is_available(self) -> bool {
        if self.rank() > MAX_LEVEL.load(Ordering::Relaxed) {
            return false;
        }
        match self {
            SimdLevel::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Sse2 => pulp::x86::V1::is_available(),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => pulp::x86::V3::is_available(),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => pulp::x86::V4::is_available(),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The levels' order (they nest).
    const fn rank(self) -> u8 {
        match self {
            SimdLevel::Scalar => 0,
            SimdLevel::Sse2 => 1,
            SimdLevel::Avx2 => 2,
            SimdLevel::Avx512 => 3,
        }
    }

    /// This level if this CPU runs it, else the best one it runs.
    pub fn or_best(self) -> Self {
        if self.is_available() {
            self
        } else {
            Self::detect()
        }
    }

    /// Runs `kernel` compiled for this level, or for the best level this
    /// CPU runs (and [`set_max_level`] allows) if it does not run this one
    /// (the levels nest: a CPU with AVX-512 has AVX2, and every x86-64 CPU
    /// has SSE2).
    #[inline(always)]
    pub fn run<K: Kernel>(self, kernel: K) -> K::Output {
        #[cfg(target_arch = "x86_64")]
        {
            use pulp::x86::{V1, V3, V4};
            let rank = self
                .rank()
                .min(MAX_LEVEL.load(Ordering::Relaxed))
                .min(K::WIDEST.rank());
            if rank >= 3
                && let Some(token) = V4::try_new()
            {
                return token.vectorize(Body(kernel, token));
            }
            if rank >= 2
                && let Some(token) = V3::try_new()
            {
                return token.vectorize(Body(kernel, token));
            }
            if rank >= 1
                && let Some(token) = V1::try_new()
            {
                return token.vectorize(Body(kernel, token));
            }
        }
        kernel.run(Scalar)
    }
}

/// The highest level [`dispatch`], [`SimdLevel::run`] and
/// [`SimdLevel::detect`] use (the rank of a [`SimdLevel`]).
static MAX_LEVEL: AtomicU8 = AtomicU8::new(SimdLevel::Avx512.rank());

/// Caps the level every kernel of the process runs at, from now on: a
/// machine with AVX-512 can then time and test the AVX2 paths (the benches
/// take it from the `BAYESTRACK_SIMD` environment variable). Objects that
/// chose their level before (a [`crate::SadTemplate`], which keeps the
/// level it was built with, or a thread's cached one) keep it. Every level
/// gives the same results; only the speed changes. `SimdLevel::Avx512`
/// lifts the cap.
pub fn set_max_level(level: SimdLevel) {
    MAX_LEVEL.store(level.rank(), Ordering::Relaxed);
}

/// Caps the level as [`set_max_level`] from the `BAYESTRACK_SIMD`
/// environment variable (`scalar`, `sse2`, `avx2` or `avx512`), for
/// benches and profiling programs that time the lower levels' paths on a
/// machine with AVX-512; nothing when it is unset. Returns the cap set.
///
/// # Errors
/// The variable's value when it names no level.
pub fn cap_from_env() -> Result<Option<SimdLevel>, String> {
    let Some(v) = std::env::var_os("BAYESTRACK_SIMD") else {
        return Ok(None);
    };
    let level = match v.to_str() {
        Some("scalar") => SimdLevel::Scalar,
        Some("sse2") => SimdLevel::Sse2,
        Some("avx2") => SimdLevel::Avx2,
        Some("avx512") => SimdLevel::Avx512,
        _ => {
            return Err(format!(
                "BAYESTRACK_SIMD={v:?}: expected scalar, sse2, avx2 or avx512"
            ));
        }
    };
    set_max_level(level);
    Ok(Some(level))
}

/// The cap [`set_max_level`] set ([`SimdLevel::Avx512`] if none).
pub fn max_level() -> SimdLevel {
    match MAX_LEVEL.load(Ordering::Relaxed) {
        0 => SimdLevel::Scalar,
        1 => SimdLevel::Sse2,
        2 => SimdLevel::Avx2,
        _ => SimdLevel::Avx512,
    }
}

/// Runs `kernel` compiled for the best level this CPU has
/// ([`SimdLevel::Avx512`], [`SimdLevel::Avx2`] or the baseline), at most
/// the one [`set_max_level`] allows.
#[inline(always)]
pub fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    SimdLevel::Avx512.run(kernel)
}

/// A loop for [`dispatch`] and [`SimdLevel::run`]: its data (the value)
/// and its body ([`Kernel::run`]).
///
/// A kernel of at most eight words is handed to the dispatched function
/// in registers, a larger one through a pointer; where a hot loop keeps
/// many of its fields live, implement `Kernel` for a reference to it and
/// compare instruction counts (the SAD kernels are faster that way).
pub trait Kernel {
    /// What the loop returns.
    type Output;
    /// The widest level worth running this kernel at: [`dispatch`] and
    /// [`SimdLevel::run`] run at most this one (the default, AVX-512, caps
    /// nothing). A kernel that takes longer with AVX-512 than with AVX2
    /// (measured, not guessed) says [`SimdLevel::Avx2`]: on a machine with
    /// AVX-512 it then runs its AVX2 copy, the same bits.
    const WIDEST: SimdLevel = SimdLevel::Avx512;
    /// The loop, compiled for the level `T` stands for (mark it
    /// `#[inline(always)]`, and everything it calls in its hot loop).
    fn run<T: Token>(self, token: T) -> Self::Output;
}

/// The proof that an instruction set is available, handed to
/// [`Kernel::run`]: [`Scalar`] or one of the `pulp` crate's x86 tokens.
/// A kernel that leaves vectorising to the compiler ignores it; this
/// crate's hand-written kernels take their intrinsics from it.
pub trait Token: Copy + sealed::Intrinsics {
    /// The level the kernel runs at.
    const LEVEL: SimdLevel;
}

/// The token of [`SimdLevel::Scalar`]: no target features.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scalar;

impl Token for Scalar {
    const LEVEL: SimdLevel = SimdLevel::Scalar;
}

impl sealed::Intrinsics for Scalar {}

#[cfg(target_arch = "x86_64")]
impl Token for pulp::x86::V1 {
    const LEVEL: SimdLevel = SimdLevel::Sse2;
}

#[cfg(target_arch = "x86_64")]
impl sealed::Intrinsics for pulp::x86::V1 {
    #[inline(always)]
    fn sse2(self) -> Option<pulp::x86::V1> {
        Some(self)
    }
}

#[cfg(target_arch = "x86_64")]
impl Token for pulp::x86::V3 {
    const LEVEL: SimdLevel = SimdLevel::Avx2;
}

#[cfg(target_arch = "x86_64")]
impl sealed::Intrinsics for pulp::x86::V3 {
    #[inline(always)]
    fn sse2(self) -> Option<pulp::x86::V1> {
        Some(**self)
    }
    #[inline(always)]
    fn avx2(self) -> Option<pulp::x86::V3> {
        Some(self)
    }
}

#[cfg(target_arch = "x86_64")]
impl Token for pulp::x86::V4 {
    const LEVEL: SimdLevel = SimdLevel::Avx512;
}

#[cfg(target_arch = "x86_64")]
impl sealed::Intrinsics for pulp::x86::V4 {
    #[inline(always)]
    fn sse2(self) -> Option<pulp::x86::V1> {
        Some(***self)
    }
    #[inline(always)]
    fn avx2(self) -> Option<pulp::x86::V3> {
        Some(*self)
    }
    #[inline(always)]
    fn avx512(self) -> Option<pulp::x86::V4> {
        Some(self)
    }
}

pub(crate) mod sealed {
    //! The intrinsics a [`Token`](super::Token) gives this crate's kernels
    //! (not nameable outside the crate, so `pulp`'s types stay out of the
    //! public API).

    /// The x86 tokens a level includes, `None` where it does not.
    pub trait Intrinsics {
        /// SSE2 (every x86-64 level but scalar).
        #[cfg(target_arch = "x86_64")]
        #[inline(always)]
        fn sse2(self) -> Option<pulp::x86::V1>
        where
            Self: Sized,
        {
            None
        }
        /// AVX2 (the AVX2 and AVX-512 levels).
        #[cfg(target_arch = "x86_64")]
        #[inline(always)]
        fn avx2(self) -> Option<pulp::x86::V3>
        where
            Self: Sized,
        {
            None
        }
        /// AVX-512.
        #[cfg(target_arch = "x86_64")]
        #[inline(always)]
        fn avx512(self) -> Option<pulp::x86::V4>
        where
            Self: Sized,
        {
            None
        }
    }
}

/// A [`Kernel`] with its token as `pulp`'s argument-less operation.
#[cfg(target_arch = "x86_64")]
struct Body<K, T>(K, T);

#[cfg(target_arch = "x86_64")]
impl<K: Kernel, T: Token> pulp::NullaryFnOnce for Body<K, T> {
    type Output = K::Output;
    #[inline(always)]
    fn call(self) -> K::Output {
        self.0.run(self.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn a_forced_level_runs_as_asked_where_available() {
        for level in SimdLevel::ALL {
            let ran = level.run(Which);
            assert_eq!(ran, level.or_best(), "{level:?}");
        }
        assert_eq!(dispatch(Which), SimdLevel::detect());
    }

    /// [`Which`] capped at AVX2.
    struct NarrowWhich;
    impl Kernel for NarrowWhich {
        type Output = SimdLevel;
        const WIDEST: SimdLevel = SimdLevel::Avx2;
        #[inline(always)]
        fn run<T: Token>(self, _: T) -> SimdLevel {
            T::LEVEL
        }
    }

    #[test]
    fn a_kernel_capped_at_avx2_never_runs_wider() {
        let widest = SimdLevel::Avx2.or_best();
        for level in SimdLevel::ALL {
            let want = if level == SimdLevel::Avx512 {
                widest
            } else {
                level.or_best()
            };
            assert_eq!(level.run(NarrowWhich), want, "{level:?}");
        }
        assert_eq!(dispatch(NarrowWhich), widest);
    }
}
