//! Property tests: the appearance cues and searches on random images and
//! windows (inside, across and outside the frame) and random parameters.
//! Nothing panics; what comes back `Ok` is finite.

use bayestrack_appearance::{
    Candidate, Cue, Frame, HistogramCue, HistogramDistance, IfdCue, MadCue, RgbHistogram, Scratch,
    centroid_in, histogram_search, mad_search, ncc,
};
use bayestrack_image::{Image, Rect};
use proptest::prelude::*;

use bayestrack_testkit::strategies::{cases, image_f32, image_u8, rect};

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
