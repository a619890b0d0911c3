"""bayestrack.otb: scores as the otb crate computes them (checked against an
independent numpy transcription of the OTB formulas), sequences read as the
CLI reads them, and reproduce_table in quick mode."""

import os
from pathlib import Path

import numpy as np
import pytest

import bayestrack as bt
from bayestrack import otb

ROOT = Path(__file__).resolve().parents[2]
SEQUENCES = Path(os.environ.get("BAYESTRACK_SEQUENCES", ROOT.parent / "shared" / "data" / "sequences"))


def sequence_dir(name):
    d = SEQUENCES / name
    if not d.is_dir():
        pytest.skip(
            f"SKIPPED: the real sequences are not at {SEQUENCES} (expected ../shared/data/sequences "
            "next to the repository, or $BAYESTRACK_SEQUENCES); nothing checked"
        )
    return d


def numpy_otb(gt, boxes):
    """The OTB benchmark's formulas (Wu, Lim, Yang 2013; see the sequences'
    README): IoU with inclusive pixel bounds, success = fraction of IoU > t
    for t = 0, 0.05, ..., 1, AUC = its mean, precision = fraction of centre
    errors <= 20 px with centres (x + (w-1)/2, y + (h-1)/2)."""
    gt, boxes = np.asarray(gt, float), np.asarray(boxes, float)
    x0 = np.maximum(gt[:, 0], boxes[:, 0])
    y0 = np.maximum(gt[:, 1], boxes[:, 1])
    x1 = np.minimum(gt[:, 0] + gt[:, 2] - 1, boxes[:, 0] + boxes[:, 2] - 1)
    y1 = np.minimum(gt[:, 1] + gt[:, 3] - 1, boxes[:, 1] + boxes[:, 3] - 1)
    inter = np.clip(x1 - x0 + 1, 0, None) * np.clip(y1 - y0 + 1, 0, None)
    union = gt[:, 2] * gt[:, 3] + boxes[:, 2] * boxes[:, 3] - inter
    iou = inter / union
    c = lambda b: np.stack([b[:, 0] + (b[:, 2] - 1) / 2, b[:, 1] + (b[:, 3] - 1) / 2], 1)
    err = np.linalg.norm(c(gt) - c(boxes), axis=1)
    curve = np.array([(iou > t).mean() for t in np.linspace(0, 1, 21)])
    return iou, err, curve


def test_score_agrees_with_the_otb_formulas():
    rng = np.random.default_rng(11)
    gt = np.column_stack([rng.uniform(1, 200, 300), rng.uniform(1, 200, 300),
                          rng.uniform(5, 60, 300), rng.uniform(5, 60, 300)])
    boxes = gt + rng.normal(0, 8, size=gt.shape)
    boxes[:, 2:] = np.abs(boxes[:, 2:]) + 1
    s = otb.score(gt, boxes)
    iou, err, curve = numpy_otb(gt, boxes)
    assert s["frames_scored"] == 300
    np.testing.assert_allclose(s["overlaps"], iou, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s["center_errors"], err, rtol=0, atol=1e-9)
    np.testing.assert_allclose(s["success_curve"], curve, rtol=0, atol=1e-12)
    assert abs(s["success_auc"] - curve.mean()) <= 1e-12
    assert abs(s["precision_20"] - (err <= 20).mean()) <= 1e-12
    assert abs(s["success_rate_50"] - (iou > 0.5).mean()) <= 1e-12
    assert abs(s["mean_overlap"] - iou.mean()) <= 1e-12
    # same boxes: every overlap is 1, so 20 of the 21 thresholds pass
    s = otb.score(gt, gt)
    assert s["success_auc"] == 20 / 21 and s["precision_20"] == 1.0
    # the scores do not depend on the box convention (0- or 1-based)
    t = otb.score(gt - [1, 1, 0, 0], boxes - [1, 1, 0, 0])
    assert abs(t["success_auc"] - otb.score(gt, boxes)["success_auc"]) <= 1e-12


def test_unlabelled_rows_are_not_scored():
    gt = [(10, 10, 20, 20), None, (0, 0, 0, 0), (np.nan,) * 4, (12, 10, 20, 20)]
    boxes = [(10, 10, 20, 20)] * 5
    s = otb.score(gt, boxes)
    assert s["frames_scored"] == 2
    assert np.isnan(s["overlaps"][1:4]).all() and s["overlaps"][0] == 1.0
    arr = np.array([(10, 10, 20, 20), (0, 0, 0, 0), (12, 10, 20, 20)], float)
    assert otb.score(arr, np.array(boxes[:3]))["frames_scored"] == 2


def test_score_errors_are_value_errors_with_our_messages():
    with pytest.raises(ValueError, match="3 predicted boxes.*2|differ|length|3.*2"):
        otb.score([(1, 1, 5, 5)] * 2, [(1, 1, 5, 5)] * 3)
    with pytest.raises(ValueError, match=r"gt\[0\].*NaN"):
        otb.score([(1, np.nan, 5, 5)], [(1, 1, 5, 5)])
    with pytest.raises(ValueError, match=r"boxes\[0\].*NaN"):
        otb.score([(1, 1, 5, 5)], [(1, np.inf, 5, 5)])
    with pytest.raises(ValueError, match=r"shape \(N, 4\)"):
        otb.score(np.zeros((3, 5)), np.zeros((3, 5)))
    with pytest.raises(ValueError, match="labelled|nothing|no frame"):
        otb.score([None, None], [(1, 1, 5, 5)] * 2)
    with pytest.raises(ValueError, match="negative|invalid|box"):
        otb.score([(1, 1, 5, 5)], [(1, 1, -5, 5)])


def test_load_sequence_reads_frames_on_demand_as_the_cli_does():
    d = sequence_dir("Crossing")
    seq = otb.load_sequence(d)
    assert len(seq) == 120 and seq.name == "Crossing"
    assert seq.groundtruth.shape == (120, 4) and seq.labelled.all()
    one = otb.load_sequence(d, one_based=True)
    np.testing.assert_array_equal(one.groundtruth - [1, 1, 0, 0], seq.groundtruth)
    row = (d / "groundtruth_rect.txt").read_text().splitlines()[0].replace(",", " ").split()
    assert one.init_box == tuple(float(v) for v in row)
    bgr = seq[0]
    assert bgr.shape == (240, 360, 3) and bgr.dtype == np.uint8
    rgb = otb.load_sequence(d, bgr=False)[0]
    np.testing.assert_array_equal(bgr[:, :, ::-1], rgb)
    np.testing.assert_array_equal(seq[-1], seq[119])
    with pytest.raises(IndexError):
        seq[120]
    # iterating decodes one frame at a time
    it = iter(seq)
    first, second = next(it), next(it)
    np.testing.assert_array_equal(first, bgr)
    assert not np.array_equal(first, second)
    assert sum(1 for _ in it) == 118


def test_gray_sequence_with_unlabelled_frames():
    d = sequence_dir("David")
    seq = otb.load_sequence(d)
    assert len(seq) == 462
    assert seq[0].shape == (240, 320)  # gray stays 2-D
    # only every 5th frame is labelled
    assert 80 <= seq.labelled.sum() <= 100
    assert np.isnan(seq.groundtruth[~seq.labelled]).all()
    try:
        import cv2
    except ImportError:
        return
    png = cv2.imread(str(seq.files[3]), cv2.IMREAD_GRAYSCALE)
    np.testing.assert_array_equal(png, seq[3])


def test_load_sequence_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        otb.load_sequence(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no PNG/JPEG frames"):
        otb.load_sequence(tmp_path / "empty")
    frames = tmp_path / "frames"
    frames.mkdir()
    (frames / "0001.png").write_bytes(b"not a png")
    with pytest.raises(OSError, match="ground-truth"):
        otb.load_sequence(frames)
    seq = otb.load_sequence(frames, require_groundtruth=False)
    assert len(seq) == 1 and not seq.labelled.any() and seq.init_box is None
    with pytest.raises(ValueError, match="0001.png"):
        seq[0]
    (frames / "groundtruth_rect.txt").write_text("1,2,three,4\n")
    with pytest.raises(ValueError, match="groundtruth_rect.txt:1"):
        otb.load_sequence(frames)


def test_reproduce_table_quick_mode(tmp_path):
    names = bt.experiment_names()
    assert names[0] == "hikpf" and "ball" in names
    rows = bt.reproduce_table("hikpf", out=str(tmp_path))
    if not isinstance(rows, list):  # pandas
        rows = rows.to_dict("records")
    assert rows and all("table" in r for r in rows)
    assert (tmp_path / "hikpf").is_dir()
    with pytest.raises(ValueError, match="unknown experiment `nope`"):
        bt.reproduce_table("nope")
    with pytest.raises(ValueError, match="valid keys"):
        bt.reproduce_table("hikpf", no_such_option=1)
