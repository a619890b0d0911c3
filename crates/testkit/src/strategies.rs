//! proptest strategies and settings the fuzz tests share.

use bayestrack_image::{Image, Rect};
use nalgebra::Matrix3;
use proptest::prelude::*;

/// The case count: `n`, or `PROPTEST_CASES` when set (a longer hunt).
pub fn cases(n: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(n)
}

/// A gray or colour (`channels`) byte image of 1 to 19 pixels a side,
/// any bytes.
pub fn image_u8(channels: usize) -> impl Strategy<Value = Image<u8>> {
    (1usize..20, 1usize..20).prop_flat_map(move |(w, h)| {
        prop::collection::vec(any::<u8>(), w * h * channels)
            .prop_map(move |data| Image::from_vec(w, h, channels, data).unwrap())
    })
}

/// A one-channel `f32` image of 1 to 15 pixels a side, values in
/// `[lo, hi)`.
pub fn image_f32(lo: f32, hi: f32) -> impl Strategy<Value = Image<f32>> {
    (1usize..16, 1usize..16).prop_flat_map(move |(w, h)| {
        prop::collection::vec(lo..hi, w * h)
            .prop_map(move |data| Image::from_vec(w, h, 1, data).unwrap())
    })
}

/// A rectangle with corner and size in `0..24` (often partly or wholly
/// outside a small image, sometimes empty).
pub fn rect() -> impl Strategy<Value = Rect> {
    (0usize..24, 0usize..24, 0usize..24, 0usize..24).prop_map(|(x, y, w, h)| Rect::new(x, y, w, h))
}

/// `sum_{j < rank} a_j a_j^T` over the first `rank` columns of the
/// row-major `a`: symmetric positive semi-definite of rank at most `rank`.
pub fn psd3_of(a: [f64; 9], rank: usize) -> Matrix3<f64> {
    let a = Matrix3::from_row_slice(&a);
    let mut m = Matrix3::zeros();
    for j in 0..rank {
        let c = a.column(j);
        m += c * c.transpose();
    }
    m
}

/// A symmetric positive semi-definite 3x3 matrix of random rank (0 to 3)
/// and scale (`10^-300` to `10^299`).
pub fn psd3() -> impl Strategy<Value = Matrix3<f64>> {
    (prop::array::uniform9(-2.0f64..2.0), 0usize..4, -300i32..300)
        .prop_map(|(a, rank, e)| psd3_of(a, rank) * 10f64.powi(e))
}

/// A well-conditioned symmetric positive definite 3x3 matrix:
/// `A A^T + d I` with entries of `A` in `[-2, 2)` and `d` in `[0.05, 2)`.
pub fn spd3() -> impl Strategy<Value = Matrix3<f64>> {
    (prop::array::uniform9(-2.0f64..2.0), 0.05f64..2.0).prop_map(|(a, d)| {
        let a = Matrix3::from_row_slice(&a);
        a * a.transpose() + Matrix3::identity() * d
    })
}

/// Any `f64` a caller can hand a library, weighted towards the edges:
/// `±1e308`, `±f64::MAX`, subnormals, `f64::MIN_POSITIVE`, `±0`, NaN,
/// `±inf`, tiny and huge values at random scales, and ordinary numbers.
pub fn extreme_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => prop::sample::select(vec![
            0.0,
            -0.0,
            1e308,
            -1e308,
            f64::MAX,
            -f64::MAX,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE / 2.0,
            5e-324,
            -5e-324,
            1e-160,
            1e154,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1.0,
            -1.0,
        ]),
        3 => (-1.0f64..1.0, -324i32..309).prop_map(|(m, e)| m * 10f64.powi(e)),
        4 => -10.0f64..10.0,
    ]
}

/// [`extreme_f64`] narrowed to `f32` (values beyond its range become
/// `±inf`, tiny ones its subnormals or 0).
pub fn extreme_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => prop::sample::select(vec![
            f32::MAX,
            -f32::MAX,
            f32::MIN_POSITIVE,
            1e-45,
            3e38,
            f32::NAN,
        ]),
        4 => extreme_f64().prop_map(|x| x as f32),
    ]
}
