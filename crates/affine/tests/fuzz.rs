//! Property tests: Aff(2) exp/log and LWPR update/predict on arbitrary
//! numbers. Nothing panics; what comes back `Ok` is finite.

use bayestrack_affine::{Affine2, AffineGroup, AlgebraVector, Lwpr, LwprConfig};
use nalgebra::Matrix3;
use proptest::prelude::*;

use bayestrack_testkit::strategies::cases;

/// A number at any scale, sometimes not finite.
fn wide() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -5.0f64..5.0,
        3 => (-1.0f64..1.0, -300i32..308).prop_map(|(m, e)| m * 10f64.powi(e)),
        1 => any::<f64>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn exp_and_log_are_finite_or_errors(w in prop::array::uniform6(wide())) {
        let w = AlgebraVector::from(w);
        if let Ok(g) = Affine2::exp(&w) {
            prop_assert!(g.matrix().iter().all(|v| v.is_finite()), "{w:?} -> {g:?}");
            if let Ok(l) = g.log() {
                prop_assert!(l.iter().all(|v| v.is_finite()), "{g:?} -> {l:?}");
            }
        }
    }

    #[test]
    fn log_of_any_matrix_is_finite_or_an_error(a in prop::array::uniform6(wide())) {
        let m = Matrix3::new(a[0], a[1], a[2], a[3], a[4], a[5], 0.0, 0.0, 1.0);
        if let Ok(g) = Affine2::from_matrix(m) {
            if let Ok(l) = g.log() {
                prop_assert!(l.iter().all(|v| v.is_finite()), "{g:?} -> {l:?}");
                if let Ok(back) = Affine2::exp(&l) {
                    prop_assert!(back.matrix().iter().all(|v| v.is_finite()));
                }
            }
            if let Ok(inv) = g.try_inverse() {
                prop_assert!(inv.matrix().iter().all(|v| v.is_finite()));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(64), ..ProptestConfig::default() })]

    #[test]
    fn lwpr_update_and_predict_are_finite_or_errors(
        samples in prop::collection::vec(
            (
                prop_oneof![3 => prop::array::uniform2(-1.0f64..1.0), 1 => prop::array::uniform2(wide())],
                prop_oneof![3 => -2.0f64..2.0, 1 => wide()],
            ),
            1..40,
        ),
        queries in prop::collection::vec(
            (prop::array::uniform2(wide()), prop_oneof![3 => 0.0f64..1.0, 1 => wide()]),
            1..6,
        ),
    ) {
        let mut model = Lwpr::new(LwprConfig::new(2, 1).init_d_spherical(25.0)).unwrap();
        for (x, y) in &samples {
            if let Ok(p) = model.update(x, &[*y]) {
                prop_assert!(p.iter().all(|v| v.is_finite()), "update({x:?}, {y}) -> {p:?}");
            }
        }
        for (x, cutoff) in &queries {
            if let Ok(p) = model.predict(x, *cutoff) {
                prop_assert!(p.iter().all(|v| v.is_finite()), "predict({x:?}, {cutoff}) -> {p:?}");
            }
            if let Ok(p) = model.predict_conf(x, *cutoff) {
                // +inf confidence is "no trustworthy field", never NaN
                prop_assert!(p.y.iter().all(|v| v.is_finite()), "predict_conf({x:?}) -> {p:?}");
                prop_assert!(p.conf.iter().all(|v| !v.is_nan() && *v >= 0.0), "{p:?}");
            }
        }
    }

    #[test]
    fn bounding_boxes_are_finite_or_errors(
        a in prop::array::uniform6(wide()),
        size in prop::array::uniform2(prop_oneof![3 => 1.0f64..100.0, 1 => wide()]),
    ) {
        if let Ok(m) = Affine2::from_rows([[a[0], a[1], a[2]], [a[3], a[4], a[5]]])
            && let Ok(b) = m.bounding_box(size[0], size[1])
        {
            prop_assert!([b.x, b.y, b.width, b.height].iter().all(|v| v.is_finite()), "{b:?}");
        }
    }
}

/// Issue 28's examples: a pose at scale 1e308, and LWPR asked with
/// confidence after inputs of 1e99.
#[test]
fn issue_examples_are_errors_or_finite() {
    let huge = Affine2::from_rows([[1e308, 0.0, 0.0], [0.0, 1e308, 0.0]]).unwrap();
    assert!(huge.bounding_box(10.0, 10.0).is_err());
    let mut model = Lwpr::new(LwprConfig::new(2, 1).init_d_spherical(25.0)).unwrap();
    for k in 0..20 {
        let x = [1e99 * (k as f64 - 10.0), 1e99];
        let _ = model.update(&x, &[1e99]);
    }
    for _ in 0..200 {
        let _ = model.update(&[1e99, 1e99], &[1e99]);
    }
    if let Ok(p) = model.predict_conf(&[1e99, 1e99], 0.0) {
        assert!(p.y.iter().all(|v| v.is_finite()), "{p:?}");
        assert!(p.conf.iter().all(|v| !v.is_nan() && *v >= 0.0), "{p:?}");
    }
}
