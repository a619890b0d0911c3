//! Tracking metrics: centre error, OTB overlap (IoU), success curve and AUC,
//! precision at 20 px, and the RMS feature-point error of paper 002 (eq. 6).
//!
//! Boxes follow the OTB convention (see `../shared/data/sequences/README.md`):
//! `(x, y)` is the 1-based top-left pixel, `(w, h)` the size.
//!
//! - centre: `(x + (w - 1) / 2, y + (h - 1) / 2)`; centre error is the
//!   Euclidean distance between the two centres;
//! - overlap: intersection over union with *inclusive* pixel bounds, as the
//!   OTB toolkit's `calcRectInt` computes it: the right edge of a box is
//!   `x + w - 1`, the intersection width is `max(0, min(r_a, r_b) -
//!   max(x_a, x_b) + 1)` (same for heights), the union is `w_a h_a + w_b h_b -
//!   intersection`;
//! - success curve: for `t = 0, 0.05, ..., 1` the fraction of scored frames
//!   with overlap `> t`; AUC: the mean of those 21 values (so a perfect
//!   tracker scores 20/21, as in the OTB toolkit);
//! - precision at 20 px: the fraction of scored frames with centre error
//!   `<= 20`;
//! - success rate at IoU 0.5: the fraction of scored frames with overlap
//!   `> 0.5` (strictly), the success curve's value at `t = 0.5`, as the
//!   benchmark's success plot counts it (a frame at exactly 0.5 fails);
//! - mean overlap of the frames with overlap: the mean IoU over the scored
//!   frames whose IoU is `> 0`, the benchmark's per-sequence "overlap
//!   score" (`overlapScores` of its result files; the frames the tracker
//!   lost are left out, so it is higher than AUC and the mean IoU).
//!
//! Frames whose ground truth is `None` (an OTB row `0,0,0,0`) are not scored:
//! they count in no numerator and no denominator. (The benchmark's own code
//! keeps them in the denominator as failures; every frame of the OTB
//! sequences we compare with is labelled, so the two agree there.)
//!
//! ```
//! use bayestrack_otb::metrics::{iou, score_otb};
//! use bayestrack_image::BBox;
//!
//! let a = BBox::new(1.0, 1.0, 10.0, 10.0);
//! let b = BBox::new(6.0, 1.0, 10.0, 10.0);
//! assert!((iou(&a, &b) - 50.0 / 150.0).abs() < 1e-12);
//! let s = score_otb(&[a, b], &[Some(a), None]).unwrap();
//! assert_eq!(s.frames_scored, 1);
//! // A perfect overlap passes every threshold but the last (1 is not > 1).
//! assert_eq!(s.auc, 20.0 / 21.0);
//! ```

use bayestrack_image::BBox;

use crate::error::OtbError;

/// The 21 overlap thresholds of the OTB success curve: `0, 0.05, ..., 1`.
pub const SUCCESS_THRESHOLDS: [f64; 21] = {
    let mut t = [0.0; 21];
    let mut i = 0;
    while i < 21 {
        t[i] = i as f64 / 20.0;
        i += 1;
    }
    t
};

/// Centre-error threshold of the OTB precision score, in pixels.
pub const PRECISION_THRESHOLD: f64 = 20.0;

/// Overlap threshold of the OTB success rate (`SUCCESS_THRESHOLDS[10]`).
pub const SUCCESS_RATE_THRESHOLD: f64 = 0.5;

/// Distance between the OTB centres of two boxes, in pixels.
pub fn center_error(a: &BBox, b: &BBox) -> f64 {
    let (ax, ay) = a.center();
    let (bx, by) = b.center();
    (ax - bx).hypot(ay - by)
}

/// OTB overlap of two boxes: intersection over union with inclusive pixel
/// bounds (see the module docs). Two empty boxes overlap 0. The result is in
/// `[0, 1]` for valid boxes.
pub fn iou(a: &BBox, b: &BBox) -> f64 {
    let iw = (a.x + a.width - 1.0).min(b.x + b.width - 1.0) - a.x.max(b.x) + 1.0;
    let ih = (a.y + a.height - 1.0).min(b.y + b.height - 1.0) - a.y.max(b.y) + 1.0;
    let inter = iw.max(0.0) * ih.max(0.0);
    let union = a.width * a.height + b.width * b.height - inter;
    if union > 0.0 && inter.is_finite() {
        (inter / union).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Fraction of overlaps strictly greater than `threshold`. An empty list
/// gives 0.
pub fn success_rate(overlaps: &[f64], threshold: f64) -> f64 {
    if overlaps.is_empty() {
        return 0.0;
    }
    overlaps.iter().filter(|&&o| o > threshold).count() as f64 / overlaps.len() as f64
}

/// OTB success curve of a list of overlaps: entry `i` is the fraction of
/// overlaps greater than `SUCCESS_THRESHOLDS[i]`. An empty list gives zeros.
pub fn success_curve(overlaps: &[f64]) -> [f64; 21] {
    SUCCESS_THRESHOLDS.map(|t| success_rate(overlaps, t))
}

/// Mean of the overlaps that are `> 0` (the benchmark's overlap score);
/// `None` when no overlap is positive.
pub fn mean_overlap_of_frames_with_overlap(overlaps: &[f64]) -> Option<f64> {
    let positive: Vec<f64> = overlaps.iter().copied().filter(|&o| o > 0.0).collect();
    (!positive.is_empty()).then(|| positive.iter().sum::<f64>() / positive.len() as f64)
}

/// Area under the success curve: the mean of its 21 values.
pub fn success_auc(curve: &[f64; 21]) -> f64 {
    curve.iter().sum::<f64>() / curve.len() as f64
}

/// Fraction of centre errors `<= threshold`. An empty list gives 0.
pub fn precision_at(center_errors: &[f64], threshold: f64) -> f64 {
    if center_errors.is_empty() {
        return 0.0;
    }
    center_errors.iter().filter(|&&e| e <= threshold).count() as f64 / center_errors.len() as f64
}

/// Per-frame and summary OTB scores of one tracker on one sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct OtbScore {
    /// Overlap per frame; `None` where the ground truth is unlabelled.
    pub overlaps: Vec<Option<f64>>,
    /// Centre error per frame (pixels); `None` where unlabelled.
    pub center_errors: Vec<Option<f64>>,
    /// Number of labelled (scored) frames.
    pub frames_scored: usize,
    /// Success curve at [`SUCCESS_THRESHOLDS`].
    pub success: [f64; 21],
    /// Mean of the success curve.
    pub auc: f64,
    /// Fraction of scored frames with centre error `<= 20` px.
    pub precision_20: f64,
    /// Fraction of scored frames with overlap `> 0.5` (the benchmark's
    /// success rate; equal to `success[10]`).
    pub success_rate_50: f64,
    /// Mean overlap over the scored frames with overlap `> 0` (the
    /// benchmark's overlap score, not the mean IoU); `None` when the box
    /// never overlaps the target.
    pub mean_overlap_of_frames_with_overlap: Option<f64>,
    /// Mean overlap over scored frames.
    pub mean_overlap: f64,
    /// Mean centre error over scored frames (pixels).
    pub mean_center_error: f64,
}

/// Scores predicted boxes against ground truth, OTB style. Frames whose
/// ground truth is `None` are skipped.
///
/// # Errors
/// [`OtbError::LengthMismatch`] if the lists differ in length;
/// [`OtbError::InvalidBox`] for a non-finite or negative-size box on a
/// scored frame; [`OtbError::NothingToScore`] if no frame is labelled.
pub fn score_otb(predicted: &[BBox], truth: &[Option<BBox>]) -> Result<OtbScore, OtbError> {
    if predicted.len() != truth.len() {
        return Err(OtbError::LengthMismatch {
            predicted: predicted.len(),
            truth: truth.len(),
        });
    }
    let mut overlaps = Vec::with_capacity(truth.len());
    let mut center_errors = Vec::with_capacity(truth.len());
    let mut scored_o = Vec::new();
    let mut scored_e = Vec::new();
    for (frame, (p, t)) in predicted.iter().zip(truth).enumerate() {
        let Some(t) = t else {
            overlaps.push(None);
            center_errors.push(None);
            continue;
        };
        for (which, b) in [("predicted", p), ("ground-truth", t)] {
            if !b.is_valid() {
                return Err(OtbError::InvalidBox {
                    frame,
                    which,
                    bbox: *b,
                });
            }
        }
        let o = iou(p, t);
        let e = center_error(p, t);
        overlaps.push(Some(o));
        center_errors.push(Some(e));
        scored_o.push(o);
        scored_e.push(e);
    }
    if scored_o.is_empty() {
        return Err(OtbError::NothingToScore {
            frames: truth.len(),
        });
    }
    let n = scored_o.len() as f64;
    let success = success_curve(&scored_o);
    Ok(OtbScore {
        frames_scored: scored_o.len(),
        auc: success_auc(&success),
        success,
        precision_20: precision_at(&scored_e, PRECISION_THRESHOLD),
        success_rate_50: success_rate(&scored_o, SUCCESS_RATE_THRESHOLD),
        mean_overlap_of_frames_with_overlap: mean_overlap_of_frames_with_overlap(&scored_o),
        mean_overlap: scored_o.iter().sum::<f64>() / n,
        mean_center_error: scored_e.iter().sum::<f64>() / n,
        overlaps,
        center_errors,
    })
}

/// The seven feature points and the centre point of paper 002 (sec. 4,
/// Fig. 5), in image coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FeaturePoints {
    /// The seven feature points (eyes and mouth), `[x, y]` each.
    pub points: [[f64; 2]; 7],
    /// The centre point `[x, y]`.
    pub center: [f64; 2],
}

/// RMS error of Xu, Gao and Yang 2015 (paper 002), eq. 6, exactly as printed:
/// `RMS = sqrt( (1/14) sum_{i=1..7} |P^_i - P_i|^2 + (1/2) |C^ - C|^2 )`,
/// i.e. the mean squared coordinate error over the 14 point coordinates plus
/// the mean squared coordinate error of the centre.
///
/// # Errors
/// [`OtbError::NonFinitePoint`] for a non-finite coordinate.
pub fn rms_error_eq6(estimated: &FeaturePoints, truth: &FeaturePoints) -> Result<f64, OtbError> {
    for (which, fp) in [("estimated", estimated), ("true", truth)] {
        for (index, p) in fp.points.iter().chain([&fp.center]).enumerate() {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(OtbError::NonFinitePoint { which, index });
            }
        }
    }
    let sq = |a: &[f64; 2], b: &[f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let points: f64 = estimated
        .points
        .iter()
        .zip(&truth.points)
        .map(|(a, b)| sq(a, b))
        .sum();
    Ok((points / 14.0 + 0.5 * sq(&estimated.center, &truth.center)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(x: f64, y: f64, w: f64, h: f64) -> BBox {
        BBox::new(x, y, w, h)
    }

    #[test]
    fn thresholds() {
        assert_eq!(SUCCESS_THRESHOLDS[0], 0.0);
        assert_eq!(SUCCESS_THRESHOLDS[1], 0.05);
        assert_eq!(SUCCESS_THRESHOLDS[10], 0.5);
        assert_eq!(SUCCESS_THRESHOLDS[20], 1.0);
    }

    #[test]
    fn iou_inclusive_bounds_by_hand() {
        // Identical boxes.
        assert_eq!(iou(&b(1., 1., 10., 10.), &b(1., 1., 10., 10.)), 1.0);
        // Shifted by 5 columns: intersection columns 6..=10 (5) x 10 rows.
        let v = iou(&b(1., 1., 10., 10.), &b(6., 1., 10., 10.));
        assert!((v - 50.0 / 150.0).abs() < 1e-15, "{v}");
        // Touching at one column: a covers 1..=10, b covers 10..=19.
        let v = iou(&b(1., 1., 10., 10.), &b(10., 1., 10., 10.));
        assert!((v - 10.0 / 190.0).abs() < 1e-15, "{v}");
        // Adjacent, no shared pixel.
        assert_eq!(iou(&b(1., 1., 10., 10.), &b(11., 1., 10., 10.)), 0.0);
        // Nested: 2x2 inside 4x4.
        assert!((iou(&b(1., 1., 4., 4.), &b(2., 2., 2., 2.)) - 0.25).abs() < 1e-15);
        // Diagonal offset: a 1..=4, b 3..=6 both ways: 2x2 = 4 of 16 + 16 - 4.
        assert!((iou(&b(1., 1., 4., 4.), &b(3., 3., 4., 4.)) - 4.0 / 28.0).abs() < 1e-15);
        // Empty boxes.
        assert_eq!(iou(&b(1., 1., 0., 0.), &b(1., 1., 0., 0.)), 0.0);
        assert_eq!(iou(&b(1., 1., 0., 5.), &b(1., 1., 3., 5.)), 0.0);
        // Symmetric.
        let (p, q) = (b(3.5, 2.0, 7.0, 9.0), b(1.0, 4.25, 6.0, 3.0));
        assert_eq!(iou(&p, &q), iou(&q, &p));
    }

    #[test]
    fn centre_error_by_hand() {
        // Centres (1 + 4.5, 1 + 4.5) = (5.5, 5.5) and (4 + 1.5, 5 + 1.5) = (5.5, 6.5).
        assert_eq!(center_error(&b(1., 1., 10., 10.), &b(4., 5., 4., 4.)), 1.0);
        // 3-4-5 triangle.
        assert_eq!(center_error(&b(1., 1., 5., 5.), &b(4., 5., 5., 5.)), 5.0);
    }

    #[test]
    fn success_curve_and_auc_by_hand() {
        // Overlaps 0, 0.5, 1: t = 0 -> 2/3 (0 is not > 0); t in (0, 0.5) -> 2/3;
        // t = 0.5 .. 0.95 -> 1/3 (only 1.0); t = 1 -> 0.
        let c = success_curve(&[0.0, 0.5, 1.0]);
        for (i, v) in c.iter().enumerate() {
            let want = match i {
                0..=9 => 2.0 / 3.0,
                10..=19 => 1.0 / 3.0,
                _ => 0.0,
            };
            assert!(
                (v - want).abs() < 1e-15,
                "t={} got {v}",
                SUCCESS_THRESHOLDS[i]
            );
        }
        // AUC = (10 * 2/3 + 10 * 1/3 + 0) / 21 = 10 / 21.
        assert!((success_auc(&c) - 10.0 / 21.0).abs() < 1e-15);
        assert_eq!(success_curve(&[]), [0.0; 21]);
    }

    #[test]
    fn precision_by_hand() {
        assert_eq!(precision_at(&[0.0, 19.9, 20.0, 20.1], 20.0), 0.75);
        assert_eq!(precision_at(&[], 20.0), 0.0);
    }

    #[test]
    fn score_skips_unlabelled_frames() {
        let gt = vec![
            Some(b(1., 1., 10., 10.)),
            None,
            Some(b(1., 1., 10., 10.)),
            Some(b(101., 101., 10., 10.)),
        ];
        let pred = vec![
            b(1., 1., 10., 10.),   // IoU 1, error 0
            b(500., 500., 1., 1.), // unlabelled: ignored
            b(6., 1., 10., 10.),   // IoU 1/3, error 5
            b(1., 1., 10., 10.),   // IoU 0, error 100 sqrt 2
        ];
        let s = score_otb(&pred, &gt).unwrap();
        assert_eq!(s.frames_scored, 3);
        assert_eq!(s.overlaps[1], None);
        assert_eq!(s.center_errors[1], None);
        assert!((s.precision_20 - 2.0 / 3.0).abs() < 1e-15);
        // Overlaps 1, 1/3, 0: t < 1/3 -> 2/3 (t = 0, 0.05 .. 0.30: 7 values),
        // 1/3 <= t < 1 -> 1/3 (0.35 .. 0.95: 13 values), t = 1 -> 0.
        let want_auc = (7.0 * 2.0 / 3.0 + 13.0 / 3.0) / 21.0;
        assert!((s.auc - want_auc).abs() < 1e-15, "{} vs {want_auc}", s.auc);
        assert!((s.mean_overlap - (1.0 + 1.0 / 3.0) / 3.0).abs() < 1e-15);
        let want_err = (5.0 + 100.0 * 2f64.sqrt()) / 3.0;
        assert!((s.mean_center_error - want_err).abs() < 1e-12);
    }

    #[test]
    fn success_rate_at_half_and_overlap_score_by_hand() {
        let t = b(1., 1., 10., 10.); // 100 pixels
        let gt = vec![Some(t), None, Some(t), Some(t), Some(t)];
        let pred = vec![
            t,                     // IoU 1: success
            t,                     // unlabelled: neither success nor failure
            b(1., 1., 10., 5.),    // 50 / (100 + 50 - 50) = 0.5 exactly: failure
            b(1., 1., 10., 6.),    // 60 / 100 = 0.6: success
            b(50., 50., 10., 10.), // IoU 0: failure, and no overlap
        ];
        let s = score_otb(&pred, &gt).unwrap();
        assert_eq!(s.frames_scored, 4);
        // 2 successes of 4 scored frames (not 3 of 4 with IoU >= 0.5, not
        // 3 of 5 with the unlabelled frame in, not 2 of 5 with it failing)
        assert_eq!(s.success_rate_50, 0.5);
        assert_eq!(s.success_rate_50, s.success[10]);
        // (1 + 0.5 + 0.6) / 3: the frame with IoU 0 is left out (with it: 0.525)
        let overlap = s.mean_overlap_of_frames_with_overlap.unwrap();
        assert!((overlap - 0.7).abs() < 1e-15, "{overlap}");
        assert!((s.mean_overlap - 0.525).abs() < 1e-15, "{}", s.mean_overlap);
        assert_eq!(success_rate(&[], 0.5), 0.0);
        assert_eq!(mean_overlap_of_frames_with_overlap(&[0.0, 0.0]), None);
    }

    #[test]
    fn score_rejects_bad_input() {
        let one = [b(1., 1., 2., 2.)];
        assert!(matches!(
            score_otb(&one, &[]),
            Err(OtbError::LengthMismatch {
                predicted: 1,
                truth: 0
            })
        ));
        assert!(matches!(
            score_otb(&[b(f64::NAN, 1., 2., 2.)], &[Some(one[0])]),
            Err(OtbError::InvalidBox {
                frame: 0,
                which: "predicted",
                ..
            })
        ));
        assert!(matches!(
            score_otb(&one, &[Some(b(1., 1., -2., 2.))]),
            Err(OtbError::InvalidBox {
                which: "ground-truth",
                ..
            })
        ));
        // A NaN prediction on an unlabelled frame is not scored, hence accepted
        // only if some other frame is labelled.
        assert!(matches!(
            score_otb(&[b(f64::NAN, 0., 0., 0.)], &[None]),
            Err(OtbError::NothingToScore { frames: 1 })
        ));
    }

    #[test]
    fn rms_eq6_by_hand() {
        let truth = FeaturePoints {
            points: [[10.0, 10.0]; 7],
            center: [0.0, 0.0],
        };
        assert_eq!(rms_error_eq6(&truth, &truth).unwrap(), 0.0);
        // Every point off by (3, 4): sum = 7 * 25, / 14 = 12.5; centre off by
        // (0, 2): 4 / 2 = 2. RMS = sqrt(14.5).
        let mut est = truth;
        for p in &mut est.points {
            p[0] += 3.0;
            p[1] += 4.0;
        }
        est.center = [0.0, 2.0];
        let v = rms_error_eq6(&est, &truth).unwrap();
        assert!((v - 14.5f64.sqrt()).abs() < 1e-15, "{v}");
        // A uniform shift d of all 8 points gives sqrt(|d|^2 / 2 + |d|^2 / 2) = |d|.
        let mut est = truth;
        for p in est.points.iter_mut().chain([&mut est.center]) {
            p[0] += 6.0;
            p[1] -= 8.0;
        }
        assert!((rms_error_eq6(&est, &truth).unwrap() - 10.0).abs() < 1e-12);
        est.points[3][1] = f64::INFINITY;
        assert!(matches!(
            rms_error_eq6(&est, &truth),
            Err(OtbError::NonFinitePoint {
                which: "estimated",
                index: 3
            })
        ));
    }
}
