//! Property tests: the appearance cues and searches on random images and
//! windows (inside, across and outside the frame) and random parameters.
//! Nothing panics; what comes back `Ok` is finite.

use bayestrack_appearance::{
    Candidate, Cue, Frame, HistogramCue, HistogramDistance, IfdCue, MadCue, RgbHistogram, Scratch,
    centroid_in, histogram_search, mad_search, ncc,
};
use bayestrack_image::{Image, Rect};
use proptest::prelude::*;

use bayestrack_testkit::strategies::{cases, extreme_f32, image_f32, image_u8, rect};

/// A parameter of any sign and scale, sometimes not finite.
fn param() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => 0.01f64..100.0,
        2 => (-1.0f64..1.0, -300i32..300).prop_map(|(m, e)| m * 10f64.powi(e)),
        1 => any::<f64>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(128), ..ProptestConfig::default() })]

    #[test]
    fn cues_score_random_windows_with_finite_numbers_or_an_error(
        gray in image_u8(1),
        rgb in image_u8(3),
        ifd in image_f32(0.0, 1.0),
        template in image_u8(1),
        reference in image_u8(3),
        window in rect(),
        ref_window in rect(),
        sigma in param(),
        floor in param(),
        bins in 0usize..20,
    ) {
        let frame = Frame::new()
            .with_gray(gray.view())
            .with_rgb(rgb.view())
            .with_ifd(ifd.view());
        let candidate = Candidate::Window(window);
        let mut scratch = Scratch::new();
        let mut cues: Vec<Box<dyn Cue>> = vec![];
        if let Ok(c) = MadCue::new(template.clone(), sigma) {
            cues.push(Box::new(c));
        }
        if let Ok(h) = RgbHistogram::from_window(reference.view(), ref_window, bins) {
            for kind in [HistogramDistance::L2, HistogramDistance::Bhattacharyya] {
                if let Ok(c) = HistogramCue::new(h.clone(), kind, sigma, 8) {
                    cues.push(Box::new(c));
                }
            }
        }
        if let Ok(c) = IfdCue::new(floor, 8) {
            cues.push(Box::new(c));
        }
        for cue in &cues {
            if let Ok(l) = cue.log_likelihood(&frame, &candidate, &mut scratch) {
                prop_assert!(l.is_finite(), "{}: {l} at {window:?}", cue.name());
            }
            if let Ok(l) = cue.log_likelihood_or_zero(&frame, &candidate, &mut scratch) {
                prop_assert!(!l.is_nan() && l < f64::INFINITY, "{}: {l}", cue.name());
            }
        }
    }

    #[test]
    fn searches_on_random_images_are_finite_or_errors(
        gray in image_u8(1),
        template in image_u8(1),
        rgb in image_u8(3),
        region in rect(),
        size in (0usize..12, 0usize..12),
        bins in 0usize..20,
    ) {
        if let Ok(m) = mad_search(gray.view(), template.view(), region) {
            prop_assert!(m.mad.is_finite() && m.mad >= 0.0, "{m:?}");
        }
        if let Ok(h) = RgbHistogram::from_window(rgb.view(), region, bins) {
            for kind in [HistogramDistance::L2, HistogramDistance::Bhattacharyya] {
                if let Ok(m) = histogram_search(rgb.view(), &h, size.0, size.1, region, kind) {
                    prop_assert!(m.distance.is_finite(), "{m:?}");
                }
            }
        }
        if let Ok(Some((x, y))) = centroid_in(gray.view(), region) {
            prop_assert!(x.is_finite() && y.is_finite());
        }
    }

    #[test]
    fn ncc_of_random_patches_is_in_range_or_an_error(
        a in image_f32(-1e30, 1e30),
        b in image_f32(-1e30, 1e30),
    ) {
        if let Ok(c) = ncc(a.view(), b.view()) {
            prop_assert!(c.is_finite() && (-1.0 - 1e-9..=1.0 + 1e-9).contains(&c), "{c}");
        }
        let b2 = a.map(|v| v * 0.5 + 3.0);
        if let Ok(c) = ncc(a.view(), b2.view()) {
            prop_assert!(c.is_finite() && (-1.0 - 1e-9..=1.0 + 1e-9).contains(&c), "{c}");
        }
    }
}

#[test]
fn a_spread_whose_square_underflows_is_refused() {
    // sigma = 1e-200: 2 sigma^2 underflowed to 0, a perfect match scored
    // 0 / 0 = NaN and any other -inf, with Ok
    let template = Image::from_vec(2, 2, 1, vec![1u8, 2, 3, 4]).unwrap();
    assert!(MadCue::new(template.clone(), 1e-200).is_err());
    assert!(bayestrack_appearance::MadLikelihood::new(1e-200).is_err());
    let frame = Image::from_vec(4, 4, 3, vec![10u8; 48]).unwrap();
    let h = RgbHistogram::from_window(frame.view(), Rect::new(0, 0, 2, 2), 4).unwrap();
    assert!(HistogramCue::new(h.clone(), HistogramDistance::L2, 1e-200, 8).is_err());
    let cue = HistogramCue::new(h, HistogramDistance::L2, 1e-100, 8).unwrap();
    let view = Frame::new().with_rgb(frame.view());
    let l = cue
        .log_likelihood(
            &view,
            &Candidate::Window(Rect::new(1, 1, 2, 2)),
            &mut Scratch::new(),
        )
        .unwrap();
    assert!(l.is_finite(), "{l}");
    assert!(MadCue::new(template, 1e-100).is_ok());
}

#[test]
fn mad_on_float_images_with_nan_or_inf_is_an_error() {
    use bayestrack_appearance::{AppearanceError, mad};
    // issue 28: a NaN frame gave position (0, 0) and MAD inf with Ok
    let frame = Image::from_vec(6, 5, 1, vec![f32::NAN; 30]).unwrap();
    let template = Image::from_vec(2, 2, 1, vec![1.0f32, 2.0, 3.0, 4.0]).unwrap();
    let region = Rect::new(0, 0, 6, 5);
    assert!(matches!(
        mad_search(frame.view(), template.view(), region),
        Err(AppearanceError::NonFinite { .. })
    ));
    // one NaN pixel: the windows over it are not numbers
    let mut one = Image::from_vec(6, 5, 1, (0..30).map(|v| v as f32).collect()).unwrap();
    one.view_mut().row_mut(4)[5] = f32::NAN;
    assert!(mad_search(one.view(), template.view(), region).is_err());
    assert!(mad(one.view(), template.view(), 4, 3).is_err());
    assert!(mad(one.view(), template.view(), 0, 0).is_ok());
    let mut out = Image::new(5, 4, 1, 0f32).unwrap();
    assert!(
        bayestrack_appearance::mad_map_into(
            one.view(),
            template.view(),
            region,
            &mut out.view_mut()
        )
        .is_err()
    );
    // a NaN or infinite template is named
    let clean = Image::from_vec(6, 5, 1, vec![1.0f32; 30]).unwrap();
    for bad in [f32::NAN, f32::INFINITY] {
        let t = Image::from_vec(2, 2, 1, vec![1.0f32, bad, 3.0, 4.0]).unwrap();
        assert!(matches!(
            mad_search(clean.view(), t.view(), region),
            Err(AppearanceError::NonFinite {
                what: "MAD template"
            })
        ));
    }
    // finite values whose differences overflow f32
    let huge = Image::from_vec(6, 5, 1, vec![f32::MAX; 30]).unwrap();
    let neg = Image::from_vec(2, 2, 1, vec![-f32::MAX; 4]).unwrap();
    assert!(mad_search(huge.view(), neg.view(), region).is_err());
}

#[test]
fn an_f32_histogram_patch_with_nan_is_an_error() {
    // NaN was counted in bin 0
    let mut h = RgbHistogram::new(4).unwrap();
    let patch = Image::from_vec(2, 1, 3, vec![10.0f32, f32::NAN, 30.0, 1.0, 2.0, 3.0]).unwrap();
    assert!(h.compute_f32(patch.view()).is_err());
    assert_eq!(h.pixels(), 0);
    let ok = Image::from_vec(2, 1, 3, vec![10.0f32, 20.0, 30.0, 1.0, 2.0, 3.0]).unwrap();
    h.compute_f32(ok.view()).unwrap();
    assert_eq!(h.pixels(), 2);
}

/// A 1-channel (or `ch`-channel) `f32` image of 1 to 9 pixels a side with
/// values at the edges of `f32`: NaN, infinities, `f32::MAX`, subnormals.
fn extreme_image(ch: usize) -> impl Strategy<Value = Image<f32>> {
    (1usize..10, 1usize..10).prop_flat_map(move |(w, h)| {
        prop::collection::vec(
            prop_oneof![3 => 0.0f32..255.0, 1 => extreme_f32()],
            w * h * ch,
        )
        .prop_map(move |data| Image::from_vec(w, h, ch, data).unwrap())
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    /// Issue 28: the float searches and scores on images holding NaN, inf,
    /// `f32::MAX` or subnormals answer with finite numbers or an error.
    #[test]
    fn float_searches_on_extreme_images_are_finite_or_errors(
        frame in extreme_image(1),
        template in extreme_image(1),
        rgb in extreme_image(3),
        region in rect(),
    ) {
        use bayestrack_appearance::{NccSearch, NccTemplate, mad, mad_map_into};
        if let Ok(m) = mad_search(frame.view(), template.view(), region) {
            prop_assert!(m.mad.is_finite() && m.mad >= 0.0, "{m:?}");
        }
        if let Ok(m) = mad(frame.view(), template.view(), region.x, region.y) {
            prop_assert!(m.is_finite() && m >= 0.0, "{m}");
        }
        let (tw, th) = (template.width(), template.height());
        if region.width >= tw && region.height >= th {
            let mut out = Image::new(region.width - tw + 1, region.height - th + 1, 1, 0f32).unwrap();
            if mad_map_into(frame.view(), template.view(), region, &mut out.view_mut()).is_ok() {
                prop_assert!(out.as_slice().iter().all(|v| v.is_finite() && *v >= 0.0));
            }
        }
        if frame.width() == template.width()
            && frame.height() == template.height()
            && let Ok(c) = ncc(frame.view(), template.view())
        {
            prop_assert!(c.is_finite() && (-1.0..=1.0).contains(&c), "{c}");
        }
        if let Ok(t) = NccTemplate::new(template.view()) {
            prop_assert!(t.values().iter().all(|v| v.is_finite()));
            let mut out = Vec::new();
            if let Ok(m) = NccSearch::new().map_into(frame.view(), &t, region, &mut out) {
                prop_assert!(m.score.is_finite(), "{m:?}");
                prop_assert!(out.iter().all(|v| v.is_finite()));
            }
        }
        let mut h = RgbHistogram::new(4).unwrap();
        if h.compute_f32(rgb.view()).is_ok() {
            prop_assert!(rgb.as_slice().iter().all(|v| v.is_finite()));
            prop_assert_eq!(h.pixels() as usize, rgb.width() * rgb.height());
        }
    }
}

#[test]
fn an_online_gaussian_never_holds_inf_or_nan() {
    use bayestrack_appearance::OnlineGaussian;
    // std = 1e200 had variance inf; 1e308 after -1e308 made mean and
    // variance inf and NaN, with Ok
    assert!(OnlineGaussian::new(0.0, 1e200, 0.5).is_err());
    let mut g = OnlineGaussian::new(-1e308, 1.0, 0.5).unwrap();
    assert!(g.update(1e308).is_err());
    assert_eq!((g.mean(), g.std(), g.count()), (-1e308, 1.0, 0));
    assert!(OnlineGaussian::from_samples(&[1e308, -1e308, 1e308], 0.5).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn online_gaussians_stay_finite_or_refuse(
        mean in bayestrack_testkit::strategies::extreme_f64(),
        std in bayestrack_testkit::strategies::extreme_f64(),
        rate in bayestrack_testkit::strategies::extreme_f64(),
        xs in prop::collection::vec(bayestrack_testkit::strategies::extreme_f64(), 0..8),
    ) {
        use bayestrack_appearance::OnlineGaussian;
        let Ok(mut g) = OnlineGaussian::new(mean, std, rate) else {
            return Ok(());
        };
        for x in xs {
            let _ = g.update(x);
            prop_assert!(g.mean().is_finite() && g.std().is_finite() && g.std() >= 0.0, "{g:?}");
        }
    }
}

#[test]
fn float_maps_with_nan_are_errors() {
    use bayestrack_appearance::{PriorityIfd, SkinModel, interframe_difference};
    // each returned NaN in its output map with Ok
    let a = Image::from_vec(3, 2, 1, vec![0.1f32, f32::NAN, 0.3, 0.4, 0.5, 0.6]).unwrap();
    let b = Image::from_vec(3, 2, 1, vec![0.2f32; 6]).unwrap();
    assert!(interframe_difference(a.view(), b.view()).is_err());
    assert!(interframe_difference(b.view(), b.view()).is_ok());
    assert!(PriorityIfd::new(a.view()).is_err());
    let mut p = PriorityIfd::new(b.view()).unwrap();
    assert!(p.reset(a.view()).is_err());
    let hsv = Image::from_vec(2, 1, 3, vec![0.1f32, 0.5, 0.5, f32::NAN, 0.5, 0.5]).unwrap();
    let skin = SkinModel::new(0.05, 0.5, 0.05).unwrap();
    let mut out = Image::new(2, 1, 1, 0f32).unwrap();
    assert!(skin.map_hsv_into(hsv.view(), &mut out.view_mut()).is_err());
}
