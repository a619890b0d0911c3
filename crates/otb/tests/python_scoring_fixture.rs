//! The fixture that pins `tools/opencv_trackers.py`'s scoring to ours:
//! `tools/fixtures/otb_scoring_boxes.csv` (ground truth and predicted boxes
//! per frame, an unlabelled row, an IoU of exactly 0.5, a centre error of
//! exactly 20 px) and `otb_scoring_expected.csv`, the scores
//! [`score_otb`] gives them. `tools/test_opencv_trackers.py` checks the
//! script's scores against the same file. `BLESS=1` rewrites the expected
//! file from [`score_otb`] (after a deliberate change of the metrics).

use std::path::PathBuf;

use bayestrack_image::BBox;
use bayestrack_otb::metrics::score_otb;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tools/fixtures")
}

#[test]
fn the_python_scoring_fixture_holds_our_scores() {
    let text = std::fs::read_to_string(fixtures().join("otb_scoring_boxes.csv")).unwrap();
    let mut truth = Vec::new();
    let mut boxes = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
        let gt = BBox::new(v[1], v[2], v[3], v[4]);
        truth.push((v[1..5] != [0.0; 4]).then_some(gt));
        boxes.push(BBox::new(v[5], v[6], v[7], v[8]));
    }
    let s = score_otb(&boxes, &truth).unwrap();
    // by hand: 7 labelled frames; IoUs 1, 1/3, 0.5 (not a success), 0, 0,
    // frame 7 and 8 (both > 0.5); centre errors <= 20 on all but frame 5
    assert_eq!(s.frames_scored, 7);
    assert_eq!(s.success_rate_50, 3.0 / 7.0);
    assert_eq!(s.precision_20, 6.0 / 7.0);
    assert!((s.overlaps[2].unwrap() - 1.0 / 3.0).abs() < 1e-15);
    assert_eq!(s.overlaps[3], Some(0.5));
    assert_eq!(s.center_errors[5], Some(20.0));
    let expected = format!(
        "success_rate_50,auc,precision_20,mean_iou,mean_overlap_of_frames_with_overlap,\
         mean_center_error,frames_scored\n{:?},{:?},{:?},{:?},{:?},{:?},{}\n",
        s.success_rate_50,
        s.auc,
        s.precision_20,
        s.mean_overlap,
        s.mean_overlap_of_frames_with_overlap.unwrap(),
        s.mean_center_error,
        s.frames_scored
    );
    let path = fixtures().join("otb_scoring_expected.csv");
    if std::env::var_os("BLESS").is_some() {
        std::fs::write(&path, &expected).unwrap();
    }
    let stored = std::fs::read_to_string(&path).unwrap();
    assert_eq!(stored, expected, "{} (BLESS=1 rewrites it)", path.display());
}
