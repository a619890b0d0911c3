//! Run-time CPU dispatch for the crate's auto-vectorised loops (the skin
//! map, histogram bins and sums, the MAD search's bounds, the interframe
//! difference).

/// Runs `kernel` compiled for the best instruction set this CPU has
/// (AVX-512, AVX2 + FMA, or the x86-64 baseline) through `pulp`'s run-time
/// dispatch. The kernel's `Kernel::run` and everything its hot loop
/// calls must be `#[inline(always)]` (a closure or a function item called
/// through `FnOnce` is not inlined into the dispatched copy, and then runs
/// the baseline code); the compiler then auto-vectorises it for each
/// instruction set. The kernels use no fused multiply-add and sum in a
/// fixed order, so every instruction set gives the same bits.
#[inline(always)]
pub(crate) fn vectorised<K: Kernel>(kernel: K) -> K::Output {
    pulp::Arch::new().dispatch(Dispatch(kernel))
}

/// A loop for [`vectorised`]: its data and, in `run`, its body.
pub(crate) trait Kernel {
    /// What the loop returns.
    type Output;
    /// The loop (mark it `#[inline(always)]`).
    fn run(self) -> Self::Output;
}

/// A [`Kernel`] as a `pulp` operation.
struct Dispatch<K>(K);

impl<K: Kernel> pulp::WithSimd for Dispatch<K> {
    type Output = K::Output;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> K::Output {
        self.0.run()
    }
}
