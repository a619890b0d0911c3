//! Lanes for kernels (in any crate) that compute eight independent
//! problems at once, one per lane: moves of `f32` values between memory's
//! order and lanes (an 8 x 8 transpose, [`transpose8`]; the split of eight
//! complex numbers' interleaved parts into two lanes and back,
//! [`deinterleave8`], [`interleave8`]) and the lane-by-lane arithmetic on
//! them ([`add8`], [`sub8`], [`mul8`], [`mul_add8`], [`neg8`]: each lane's
//! one IEEE operation, so the same bits at every level). Written as plain
//! loops over `[f32; 8]` in a large kernel, both came out of the compiler
//! split into 128-bit halves, mixed across arrays and spilled; these are
//! whole 256-bit vector operations where the [`Token`] has AVX2.
//!
//! Complex data (the `num_complex` type `rustfft` and the dcf crate use)
//! takes them through its `f32` view ([`complex_parts`],
//! [`complex_parts_mut`]): then a kernel loads and stores whole `[f32; 8]`
//! arrays, which the compiler keeps as whole vectors (built from or taken
//! apart into complex numbers one field at a time, they were moved
//! element by element).
//!
//! The moves are pure data moves: every level gives the same values.
//! Where the [`Token`] has AVX2 (the AVX2 and AVX-512 levels) everything
//! is AVX on whole 256-bit vectors; elsewhere the plain loops. Like every
//! function a kernel's hot loop calls, they are `#[inline(always)]`: call
//! them from inside [`Kernel::run`](super::Kernel::run) with its token.

use pulp::num_complex::Complex;

use super::Token;

/// Eight `f32`, one per lane.
pub type F32x8 = [f32; 8];

/// The complex numbers `c` as their interleaved parts: `2 c.len()` values,
/// the real part of `c[k]` at `2 k`, its imaginary part at `2 k + 1` (the
/// same memory; `Complex` is `repr(C)`).
#[inline(always)]
pub fn complex_parts(c: &[Complex<f32>]) -> &[f32] {
    pulp::bytemuck::cast_slice(c)
}

/// [`complex_parts`] to write through.
#[inline(always)]
pub fn complex_parts_mut(c: &mut [Complex<f32>]) -> &mut [f32] {
    pulp::bytemuck::cast_slice_mut(c)
}

/// The 8 x 8 transpose of `rows`: `out[i][j] == rows[j][i]`.
///
/// Eight rows of memory (eight complex pairs' four points each, eight
/// columns of eight samples...) become eight vectors of one value per
/// row, and back: under AVX2, 24 shuffles (eight `unpack`s, eight
/// `shuffle`s, eight 128-bit `permute`s) between whole-vector loads and
/// stores.
#[inline(always)]
pub fn transpose8<T: Token>(token: T, rows: &[F32x8; 8]) -> [F32x8; 8] {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::transpose8(simd, rows);
    }
    let _ = token;
    std::array::from_fn(|i| std::array::from_fn(|j| rows[j][i]))
}

/// Eight complex numbers stored as interleaved parts (`pairs[2 k]` the
/// real part of number `k`, `pairs[2 k + 1]` its imaginary part) split
/// into their real parts and their imaginary parts, one number per lane:
/// `[re, im]` with `re[k] == pairs[2 k]`, `im[k] == pairs[2 k + 1]`.
/// Under AVX2, four shuffles between two whole-vector loads and the two
/// lanes.
#[inline(always)]
pub fn deinterleave8<T: Token>(token: T, pairs: &[f32; 16]) -> [F32x8; 2] {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::deinterleave8(simd, pairs);
    }
    let _ = token;
    [0, 1].map(|part| std::array::from_fn(|k| pairs[2 * k + part]))
}

/// [`deinterleave8`]'s way back: the real parts `re` and imaginary parts
/// `im` of eight complex numbers interleaved (`out[2 k] == re[k]`,
/// `out[2 k + 1] == im[k]`). Under AVX2, four shuffles then two
/// whole-vector stores.
#[inline(always)]
pub fn interleave8<T: Token>(token: T, re: &F32x8, im: &F32x8) -> [f32; 16] {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::interleave8(simd, re, im);
    }
    let _ = token;
    std::array::from_fn(|i| if i % 2 == 0 { re[i / 2] } else { im[i / 2] })
}

/// `a + b`, lane by lane.
#[inline(always)]
pub fn add8<T: Token>(token: T, a: F32x8, b: F32x8) -> F32x8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::binary(a, b, |a, b| simd.avx._mm256_add_ps(a, b));
    }
    let _ = token;
    std::array::from_fn(|l| a[l] + b[l])
}

/// `a - b`, lane by lane.
#[inline(always)]
pub fn sub8<T: Token>(token: T, a: F32x8, b: F32x8) -> F32x8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::binary(a, b, |a, b| simd.avx._mm256_sub_ps(a, b));
    }
    let _ = token;
    std::array::from_fn(|l| a[l] - b[l])
}

/// `a b`, lane by lane.
#[inline(always)]
pub fn mul8<T: Token>(token: T, a: F32x8, b: F32x8) -> F32x8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        return x86::binary(a, b, |a, b| simd.avx._mm256_mul_ps(a, b));
    }
    let _ = token;
    std::array::from_fn(|l| a[l] * b[l])
}

/// `a b + c`, lane by lane, rounded once ([`f32::mul_add`]; under AVX2
/// one `vfmadd`: the same bits).
#[inline(always)]
pub fn mul_add8<T: Token>(token: T, a: F32x8, b: F32x8, c: F32x8) -> F32x8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        let [a, b, c] = [a, b, c].map(cast::<F32x8, core::arch::x86_64::__m256>);
        return cast(simd.fma._mm256_fmadd_ps(a, b, c));
    }
    let _ = token;
    std::array::from_fn(|l| a[l].mul_add(b[l], c[l]))
}

/// `-a`, lane by lane: the sign bits flipped (under AVX2 one `xor`).
#[inline(always)]
pub fn neg8<T: Token>(token: T, a: F32x8) -> F32x8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = token.avx2() {
        let sign = simd.avx._mm256_set1_ps(-0.0);
        return cast(simd.avx._mm256_xor_ps(cast(a), sign));
    }
    let _ = token;
    a.map(|v| -v)
}

#[cfg(target_arch = "x86_64")]
use pulp::bytemuck::cast;

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The AVX forms. `unpacklo`/`unpackhi` and `shuffle` work within each
    //! 128-bit half of a vector, `permute2f128` picks whole halves.

    use core::arch::x86_64::__m256;

    use pulp::bytemuck::cast;
    use pulp::x86::V3;

    use super::F32x8;

    /// `op` on `a` and `b` as vectors.
    #[inline(always)]
    pub(super) fn binary(a: F32x8, b: F32x8, op: impl Fn(__m256, __m256) -> __m256) -> F32x8 {
        cast(op(cast(a), cast(b)))
    }

    #[inline(always)]
    pub(super) fn transpose8(simd: V3, rows: &[F32x8; 8]) -> [F32x8; 8] {
        let a = simd.avx;
        let r = rows.map(cast::<F32x8, __m256>);
        // pairs of rows interleaved: t[2 p] holds rows 2 p and 2 p + 1's
        // columns 0, 1 (low half) and 4, 5 (high half), t[2 p + 1] their
        // columns 2, 3 and 6, 7
        let t = [
            a._mm256_unpacklo_ps(r[0], r[1]),
            a._mm256_unpackhi_ps(r[0], r[1]),
            a._mm256_unpacklo_ps(r[2], r[3]),
            a._mm256_unpackhi_ps(r[2], r[3]),
            a._mm256_unpacklo_ps(r[4], r[5]),
            a._mm256_unpackhi_ps(r[4], r[5]),
            a._mm256_unpacklo_ps(r[6], r[7]),
            a._mm256_unpackhi_ps(r[6], r[7]),
        ];
        // four rows' column c (low half) and c + 4 (high half): q[c] for
        // rows 0..4, q[c + 4] for rows 4..8
        let q = [
            a._mm256_shuffle_ps::<0x44>(t[0], t[2]),
            a._mm256_shuffle_ps::<0xee>(t[0], t[2]),
            a._mm256_shuffle_ps::<0x44>(t[1], t[3]),
            a._mm256_shuffle_ps::<0xee>(t[1], t[3]),
            a._mm256_shuffle_ps::<0x44>(t[4], t[6]),
            a._mm256_shuffle_ps::<0xee>(t[4], t[6]),
            a._mm256_shuffle_ps::<0x44>(t[5], t[7]),
            a._mm256_shuffle_ps::<0xee>(t[5], t[7]),
        ];
        // column c: its low halves (rows 0..4, 4..8), column c + 4: the
        // high ones
        [
            a._mm256_permute2f128_ps::<0x20>(q[0], q[4]),
            a._mm256_permute2f128_ps::<0x20>(q[1], q[5]),
            a._mm256_permute2f128_ps::<0x20>(q[2], q[6]),
            a._mm256_permute2f128_ps::<0x20>(q[3], q[7]),
            a._mm256_permute2f128_ps::<0x31>(q[0], q[4]),
            a._mm256_permute2f128_ps::<0x31>(q[1], q[5]),
            a._mm256_permute2f128_ps::<0x31>(q[2], q[6]),
            a._mm256_permute2f128_ps::<0x31>(q[3], q[7]),
        ]
        .map(cast)
    }

    #[inline(always)]
    pub(super) fn deinterleave8(simd: V3, pairs: &[f32; 16]) -> [F32x8; 2] {
        let a = simd.avx;
        let [x, y]: [__m256; 2] = cast(*pairs);
        // numbers 0, 1 | 4, 5 and 2, 3 | 6, 7
        let lo = a._mm256_permute2f128_ps::<0x20>(x, y);
        let hi = a._mm256_permute2f128_ps::<0x31>(x, y);
        [
            cast(a._mm256_shuffle_ps::<0x88>(lo, hi)),
            cast(a._mm256_shuffle_ps::<0xdd>(lo, hi)),
        ]
    }

    #[inline(always)]
    pub(super) fn interleave8(simd: V3, re: &F32x8, im: &F32x8) -> [f32; 16] {
        let a = simd.avx;
        let (re, im) = (cast(*re), cast(*im));
        // numbers 0, 1 | 4, 5 and 2, 3 | 6, 7
        let lo = a._mm256_unpacklo_ps(re, im);
        let hi = a._mm256_unpackhi_ps(re, im);
        cast([
            a._mm256_permute2f128_ps::<0x20>(lo, hi),
            a._mm256_permute2f128_ps::<0x31>(lo, hi),
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Kernel, SimdLevel};
    use super::*;

    /// Distinct values with every bit pattern kind a move must keep:
    /// signed zeros, a NaN with a payload, infinities, subnormals.
    fn values(n: usize, seed: u32) -> Vec<f32> {
        let special = [
            -0.0f32,
            0.0,
            f32::from_bits(0x7fc0_1234),
            f32::from_bits(0xffa0_0001),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::from_bits(1),
            -f32::MIN_POSITIVE,
        ];
        (0..n)
            .map(|i| {
                let k = (i as u32).wrapping_mul(2_654_435_761) ^ seed;
                if k.is_multiple_of(5) {
                    special[(k / 5) as usize % special.len()]
                } else {
                    f32::from_bits(k.rotate_left(7))
                }
            })
            .collect()
    }

    fn bits<const N: usize>(v: &[F32x8; N]) -> Vec<u32> {
        v.iter().flatten().map(|x| x.to_bits()).collect()
    }

    /// The three moves at a level.
    struct Moves<'a>(&'a [F32x8; 8], &'a [f32; 16]);

    impl Kernel for Moves<'_> {
        type Output = ([F32x8; 8], [F32x8; 2], [f32; 16]);
        #[inline(always)]
        fn run<T: Token>(self, token: T) -> Self::Output {
            let [re, im] = deinterleave8(token, self.1);
            (
                transpose8(token, self.0),
                [re, im],
                interleave8(token, &self.0[0], &self.0[1]),
            )
        }
    }

    /// The five lane operations at a level, on the same three inputs.
    struct Arithmetic([F32x8; 3]);

    impl Kernel for Arithmetic {
        type Output = [F32x8; 5];
        #[inline(always)]
        fn run<T: Token>(self, token: T) -> [F32x8; 5] {
            let [a, b, c] = self.0;
            [
                add8(token, a, b),
                sub8(token, a, b),
                mul8(token, a, b),
                mul_add8(token, a, b, c),
                neg8(token, a),
            ]
        }
    }

    #[test]
    fn lane_arithmetic_is_the_plain_operations_bit_for_bit_at_every_level() {
        // ordinary values, the special ones (signed zeros, NaNs,
        // infinities, subnormals), and products whose fused and unfused
        // roundings differ (x (1 + 2^-12) - x^2 (1 + 2^-11) cancels)
        let x = 1.0f32 + f32::EPSILON * 7.0;
        let y = 1.0f32 + f32::EPSILON * 5.0;
        let fused = ([x; 8], [y; 8], [-(x * y); 8]);
        assert_ne!(x.mul_add(y, -(x * y)), 0.0);
        for seed in 0..64 {
            let v = values(24, seed);
            let mut ins: [F32x8; 3] = std::array::from_fn(|k| v[8 * k..][..8].try_into().unwrap());
            if seed == 0 {
                ins = [fused.0, fused.1, fused.2];
            }
            let [a, b, c] = ins;
            let want = [
                std::array::from_fn(|l| a[l] + b[l]),
                std::array::from_fn(|l| a[l] - b[l]),
                std::array::from_fn(|l| a[l] * b[l]),
                std::array::from_fn(|l| a[l].mul_add(b[l], c[l])),
                a.map(|v| -v),
            ];
            for level in SimdLevel::ALL {
                let got = level.run(Arithmetic(ins));
                for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                    for l in 0..8 {
                        // a NaN result's payload is the CPU's choice
                        // (both NaN is the same answer)
                        let same =
                            g[l].to_bits() == w[l].to_bits() || g[l].is_nan() && w[l].is_nan();
                        assert!(same, "{level:?} op {k} lane {l}: {} vs {}", g[l], w[l]);
                    }
                }
            }
        }
    }

    #[test]
    fn moves_are_the_plain_loops_bit_for_bit_at_every_level() {
        for seed in 0..16 {
            let v = values(64 + 16, seed);
            let rows: [F32x8; 8] = std::array::from_fn(|j| v[8 * j..][..8].try_into().unwrap());
            let pairs: [f32; 16] = v[64..].try_into().unwrap();
            for level in SimdLevel::ALL {
                let (t, [re, im], inter) = level.run(Moves(&rows, &pairs));
                for i in 0..8 {
                    for j in 0..8 {
                        assert_eq!(
                            t[i][j].to_bits(),
                            rows[j][i].to_bits(),
                            "{level:?} transpose ({i}, {j})"
                        );
                    }
                }
                for k in 0..8 {
                    assert_eq!(re[k].to_bits(), pairs[2 * k].to_bits(), "{level:?} re {k}");
                    assert_eq!(
                        im[k].to_bits(),
                        pairs[2 * k + 1].to_bits(),
                        "{level:?} im {k}"
                    );
                    assert_eq!(inter[2 * k].to_bits(), rows[0][k].to_bits(), "{level:?}");
                    assert_eq!(
                        inter[2 * k + 1].to_bits(),
                        rows[1][k].to_bits(),
                        "{level:?}"
                    );
                }
                // and back
                let back = level.run(Moves(&t, &inter));
                assert_eq!(bits(&back.0), bits(&rows), "{level:?} transpose twice");
                assert_eq!(
                    bits(&back.1),
                    bits(&[rows[0], rows[1]]),
                    "{level:?} round trip"
                );
            }
        }
    }
}
