#!/usr/bin/env python3
"""tools/opencv_trackers.py scores boxes exactly as the otb crate does.

tools/fixtures/otb_scoring_boxes.csv holds ground truth and predicted boxes
(an unlabelled 0,0,0,0 row, an IoU of exactly 0.5, a centre error of exactly
20 px, fractional boxes); tools/fixtures/otb_scoring_expected.csv holds the
scores that crates/otb's score_otb gives them (checked and written by
crates/otb/tests/python_scoring_fixture.rs). Run with pytest or plainly:
  python3 tools/test_opencv_trackers.py
Needs neither cv2 nor numpy.
"""

import csv
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import opencv_trackers as ot  # noqa: E402

FIXTURES = Path(__file__).resolve().parent / "fixtures"


def load_boxes():
    truth, boxes = [], []
    with open(FIXTURES / "otb_scoring_boxes.csv") as f:
        for row in csv.DictReader(f):
            gt = tuple(float(row[k]) for k in ("gt_x", "gt_y", "gt_w", "gt_h"))
            truth.append(None if gt == (0.0, 0.0, 0.0, 0.0) else gt)
            boxes.append(tuple(float(row[k]) for k in ("x", "y", "w", "h")))
    return truth, boxes


def test_scores_match_the_otb_crate():
    truth, boxes = load_boxes()
    got = ot.score_otb(boxes, truth)
    with open(FIXTURES / "otb_scoring_expected.csv") as f:
        expected = next(csv.DictReader(f))
    for key, value in expected.items():
        want = float(value)
        assert abs(got[key] - want) <= 1e-12 * max(1.0, abs(want)), (key, got[key], want)


def test_edge_cases_by_hand():
    a = (1.0, 1.0, 10.0, 10.0)
    assert ot.iou(a, (6.0, 1.0, 10.0, 10.0)) == 50.0 / 150.0
    assert ot.iou(a, (1.0, 1.0, 20.0, 10.0)) == 0.5
    assert ot.success_rate([0.5], 0.5) == 0.0  # strictly greater
    assert ot.center_error(a, (21.0, 1.0, 10.0, 10.0)) == 20.0
    s = ot.score_otb([a, a], [a, None])
    assert s["frames_scored"] == 1 and s["auc"] == 20.0 / 21.0


def test_ground_truth_rows_and_frame_order():
    rows = ot.parse_ground_truth("1,2,3,4\n\n0,0,0,0\n5\t6 7,8\n")
    assert rows == [(1.0, 2.0, 3.0, 4.0), None, (5.0, 6.0, 7.0, 8.0)]
    with tempfile.TemporaryDirectory() as d:
        seq = Path(d) / "David"
        (seq / "img").mkdir(parents=True)
        for n in (10, 2, 1):
            (seq / "img" / f"img{n:05d}.png").write_bytes(b"")
        (seq / "david_gt.txt").write_text("1,1,2,2\n")
        assert [p.name for p in ot.list_frames(seq)] == ["img00001.png", "img00002.png", "img00010.png"]
        assert ot.ground_truth_file(seq).name == "david_gt.txt"
        (seq / "groundtruth_rect.txt").write_text("1,1,2,2\n")
        assert ot.ground_truth_file(seq).name == "groundtruth_rect.txt"
        assert ot.list_sequences(d) == [seq]


if __name__ == "__main__":
    for name, fn in sorted(globals().items()):
        if name.startswith("test_") and callable(fn):
            fn()
            print(f"{name}: ok")
