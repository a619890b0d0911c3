"""bayestrack.Tracker with OpenCV's calling convention, on a real sequence,
and bit for bit against the CLI (`bayestrack track`) on the same frames.

The real sequences are read from ``../shared/data/sequences`` next to the
repository (or ``$BAYESTRACK_SEQUENCES``); the CLI from
``target/debug/bayestrack`` (or ``$BAYESTRACK_CLI``), which ``cargo test
--workspace`` builds. Tests that need either say so when they skip.
"""

import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import bayestrack as bt
from bayestrack import otb

ROOT = Path(__file__).resolve().parents[2]
SEQUENCES = Path(os.environ.get("BAYESTRACK_SEQUENCES", ROOT.parent / "shared" / "data" / "sequences"))

try:
    import cv2
except ImportError:  # pragma: no cover - depends on the machine
    cv2 = None


def sequence_dir(name):
    d = SEQUENCES / name
    if not d.is_dir():
        pytest.skip(
            f"SKIPPED: the real sequences are not at {SEQUENCES} (expected ../shared/data/sequences "
            "next to the repository, or $BAYESTRACK_SEQUENCES); nothing checked"
        )
    return d


def cli():
    exe = Path(os.environ.get("BAYESTRACK_CLI", ROOT / "target" / "debug" / "bayestrack"))
    if not exe.is_file():
        pytest.skip(f"SKIPPED: no CLI at {exe} (run `cargo build` or set $BAYESTRACK_CLI)")
    return exe


def cli_boxes(tmp_path, seq_dir, tracker, frames=None, seed=0, sets=()):
    out = tmp_path / f"{tracker}.txt"
    cmd = [str(cli()), "track", "--seq", str(seq_dir), "--tracker", tracker, "--out", str(out),
           "--seed", str(seed)]
    if frames is not None:
        cmd += ["--frames", f"1..{frames}"]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True, capture_output=True)
    return out.read_text().splitlines()


def python_boxes(frames, init, tracker):
    """OpenCV's loop: init on the first frame, update on each later one."""
    boxes = [tuple(init)]
    for i, frame in enumerate(frames):
        if i == 0:
            assert tracker.init(frame, init) is None
            continue
        ok, box = tracker.update(frame)
        assert isinstance(ok, bool) and len(box) == 4
        boxes.append(box)
    return boxes


def test_opencv_calling_convention_on_a_real_sequence():
    """Crossing read as OpenCV reads it (cv2.imread: BGR, 0-based boxes),
    tracked with ``init``/``update``: the floors of tests/real_video.rs
    (measured AUC 0.775, P@20 1.0 from our own decoder)."""
    d = sequence_dir("Crossing")
    seq = otb.load_sequence(d)
    if cv2 is not None:
        frames = (cv2.imread(str(f)) for f in seq.files)
    else:  # our loader gives the same BGR layout
        print("cv2 is not installed: frames from bayestrack.otb.load_sequence")
        frames = iter(seq)
    tracker = bt.Tracker("ncc-scale")
    boxes = python_boxes(frames, seq.init_box, tracker)
    assert len(boxes) == len(seq) == 120
    s = otb.score(seq.groundtruth, boxes)
    assert s["success_auc"] >= 0.6, s["success_auc"]
    assert s["precision_20"] >= 0.9, s["precision_20"]
    # a box that stays where frame 1 put it scores far below
    still = otb.score(seq.groundtruth, [seq.init_box] * len(seq))
    assert still["success_auc"] < 0.1


@pytest.mark.parametrize(
    "name,tracker,frames,seed,options",
    [
        ("Crossing", "ncc-scale", None, 0, {}),
        ("Crossing", "hist-pf-scale", 40, 3, {"particles": 50}),
        ("Couple", "dcf", 30, 0, {"fdsst": True}),
    ],
)
def test_boxes_equal_the_cli_bit_for_bit(tmp_path, name, tracker, frames, seed, options):
    """Same frames (our decoder, handed over in OpenCV's BGR order), same
    seed and options: every box equals the CLI's file row for row."""
    d = sequence_dir(name)
    sets = [f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in options.items()]
    want = cli_boxes(tmp_path, d, tracker, frames, seed, sets)
    seq = otb.load_sequence(d, one_based=True)
    n = frames or len(seq)
    frames_iter = (seq[i] for i in range(n))
    t = bt.Tracker(tracker, seed=seed, one_based=True, **options)
    got = [otb.format_box(b) for b in python_boxes(frames_iter, seq.init_box, t)]
    assert len(got) == len(want) == n
    diffs = [(i, a, b) for i, (a, b) in enumerate(zip(got, want)) if a != b]
    assert not diffs, f"{len(diffs)} boxes differ from the CLI's, first {diffs[:3]}"


def test_cv2_gray_frames_equal_the_cli_bit_for_bit(tmp_path):
    """David (gray PNG) read by cv2 as a 2-D array: the same pixels as our
    decoder, so the same boxes as the CLI."""
    if cv2 is None:
        pytest.skip("SKIPPED: cv2 is not installed")
    d = sequence_dir("David")
    n = 60
    want = cli_boxes(tmp_path, d, "ncc-scale", n)
    seq = otb.load_sequence(d, one_based=True)
    frames = [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in seq.files[:n]]
    assert frames[0].ndim == 2
    assert np.array_equal(frames[0], seq[0])
    t = bt.Tracker("ncc-scale", one_based=True)
    got = [otb.format_box(b) for b in python_boxes(frames, seq.init_box, t)]
    assert got == want


def synthetic(h=120, w=160, n=8):
    """A textured square moving right 2 px a frame on a textured background."""
    rng = np.random.default_rng(5)
    bg = rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    patch = rng.integers(0, 256, size=(24, 24, 3), dtype=np.uint8)
    frames = []
    for k in range(n):
        f = bg.copy()
        x = 40 + 2 * k
        f[50:74, x:x + 24] = patch
        frames.append(f)
    return frames, (40.0, 50.0, 24.0, 24.0)


def run(frames, init, **kw):
    t = bt.Tracker("ncc-scale", **kw)
    boxes = python_boxes(frames, init, t)
    return boxes, t


def test_layouts_and_channel_orders_give_the_same_boxes():
    bgr, init = synthetic()
    rgb = [np.ascontiguousarray(f[:, :, ::-1]) for f in bgr]
    want, t = run(bgr, init)
    assert t.copied  # BGR is swapped into RGB: one copy
    # the target moves right 2 px a frame: the tracker follows (0-based box)
    assert abs(want[-1][0] - (40 + 2 * 7)) <= 1.0 and abs(want[-1][1] - 50) <= 1.0
    got, t = run(rgb, init, bgr=False)
    assert got == want and not t.copied  # C-contiguous RGB: read in place
    # a reversed view (negative strides) of the RGB arrays is the BGR frame
    got, t = run([f[:, :, ::-1] for f in rgb], init)
    assert got == want and t.copied
    # padded rows (a crop of a wider array) and Fortran order
    padded = []
    for f in bgr:
        big = np.zeros((f.shape[0], f.shape[1] + 7, 3), np.uint8)
        big[:, : f.shape[1]] = f
        padded.append(big[:, : f.shape[1]])
    assert not padded[0].flags.c_contiguous
    assert run(padded, init)[0] == want
    assert run([np.asfortranarray(f) for f in bgr], init)[0] == want
    assert run([np.asfortranarray(f) for f in rgb], init, bgr=False)[0] == want
    # 1-based boxes are the same boxes shifted by one
    one, _ = run(bgr, (41.0, 51.0, 24.0, 24.0), one_based=True)
    assert [(x - 1, y - 1, w, h) for x, y, w, h in one] == want


def test_gray_frames_are_read_in_place():
    bgr, init = synthetic()
    gray = [np.ascontiguousarray(f[:, :, 1]) for f in bgr]
    boxes, t = run(gray, init)
    assert not t.copied
    assert run([g[:, :, None] for g in gray], init)[0] == boxes  # (H, W, 1)
    assert run([np.asfortranarray(g) for g in gray], init)[0] == boxes


def test_every_registered_tracker_runs_through_the_python_api():
    bgr, init = synthetic(n=3)
    names = bt.tracker_names()
    assert "ncc-scale" in names and len(names) >= 10
    for name in names:
        t = bt.Tracker(name, seed=1)
        t.init(bgr[0], init)
        for f in bgr[1:]:
            ok, box = t.update(f)
            assert all(np.isfinite(box)), (name, box)
        assert t.name == name


def test_options_reach_the_tracker_and_bad_ones_raise_value_error():
    bgr, init = synthetic(n=2)
    t = bt.Tracker("ball-pf", seed=1, particles=70)
    t.init(bgr[0], init)
    t.update(bgr[1])
    assert t.particles == 70
    assert t.options == ["particles=70"]
    with pytest.raises(ValueError, match=r"unknown option `particle`.*particles \(1..=1000000\)"):
        bt.Tracker("ball-pf", particle=7)
    with pytest.raises(ValueError, match=r"bad value `0` for `particles`: expected 1..=1000000"):
        bt.Tracker("ball-pf", particles=0)
    with pytest.raises(ValueError, match="ncc-scale.*max_scale"):
        bt.Tracker("ncc-scale", max_scale=0.5)
    with pytest.raises(ValueError, match="hkpf.*particles"):
        bt.Tracker("hkpf", particles=7)
    with pytest.raises(ValueError, match="csrt.*ncc-scale"):
        bt.Tracker("csrt")
    with pytest.raises(TypeError, match="option particles"):
        bt.Tracker("ball-pf", particles=[1, 2])
    opts = bt.tracker_options("ball-pf70")
    assert {"key": "particles", "default": "70"}.items() <= next(
        o for o in opts if o["key"] == "particles").items()
    # booleans become true/false
    bt.Tracker("dcf", fdsst=True)
    with pytest.raises(ValueError, match="fdsst"):
        bt.Tracker("dcf", fdsst="maybe")


def test_bad_frames_and_boxes_raise_value_error():
    bgr, init = synthetic(n=2)
    t = bt.Tracker("ncc-scale")
    with pytest.raises(ValueError, match="update before init"):
        t.update(bgr[0])
    with pytest.raises(ValueError, match="uint8"):
        t.init(bgr[0].astype(np.float64), init)
    with pytest.raises(ValueError, match="uint8"):
        t.init([[1, 2], [3, 4]], init)
    with pytest.raises(ValueError, match="4 channels"):
        t.init(np.zeros((20, 20, 4), np.uint8), init)
    with pytest.raises(ValueError, match="shape"):
        t.init(np.zeros((20, 20, 3, 1), np.uint8), init)
    with pytest.raises(ValueError, match="empty"):
        t.init(np.zeros((0, 20), np.uint8), init)
    with pytest.raises(ValueError, match="NaN"):
        t.init(bgr[0], (np.nan, 1, 10, 10))
    with pytest.raises(ValueError, match="4 numbers"):
        t.init(bgr[0], (1, 10, 10))
    with pytest.raises(ValueError, match="has no area"):
        t.init(bgr[0], (10, 10, 0, 10))
    with pytest.raises(ValueError, match="outside"):
        t.init(bgr[0], (1000, 1000, 10, 10))
    # a box partly outside is clipped, as the CLI does
    t.init(bgr[0], (-5.0, 10.0, 20.0, 20.0))
    assert t.init_box == (0.0, 10.0, 15.0, 20.0)
    t.init(bgr[0], init)
    with pytest.raises(ValueError, match="the first frame was 160x120"):
        t.update(bgr[1][:100])
    with pytest.raises(ValueError, match="channel|3"):
        t.update(bgr[1][:, :, 0])
    # the tracker is still usable
    ok, box = t.update(bgr[1])
    assert all(np.isfinite(box))


def test_update_releases_the_gil():
    """Another Python thread runs while one long update runs in Rust."""
    h, w = 480, 640
    rng = np.random.default_rng(0)
    frame = rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    t = bt.Tracker("hist-pf-scale", seed=1, particles=20000)
    t.init(frame, (300.0, 200.0, 60.0, 60.0))
    start = time.perf_counter()
    t.update(frame)
    alone = time.perf_counter() - start
    ticks = []
    stop = threading.Event()

    def counter():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0)

    th = threading.Thread(target=counter)
    th.start()
    time.sleep(0.02)
    start = time.perf_counter()
    t.update(frame)
    end = time.perf_counter()
    stop.set()
    th.join()
    during = sum(start < x < end for x in ticks)
    # with the GIL held the other thread could not tick during the update
    assert during > 20, f"the other thread ticked {during} times in a {alone:.3f} s update"
