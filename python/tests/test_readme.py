"""The README's examples run as written (python/README.md's first two code
blocks; the video one on a synthetic clip written with cv2)."""

import os
import re
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


def test_the_three_line_kalman_example_runs():
    code = blocks()[0]
    assert len(code.strip().splitlines()) == 3
    scope = {}
    exec(code, scope)
    assert scope["means"].shape == (100, 2, 1) and np.isfinite(scope["covs"]).all()


def test_the_three_line_tracker_example_runs(tmp_path):
    cv2 = pytest.importorskip("cv2", reason="SKIPPED: cv2 is not installed")
    code = blocks()[1]
    assert len(code.strip().splitlines()) == 4  # the import line and three
    clip = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"MJPG"), 25, (320, 240))
    if not writer.isOpened():
        pytest.skip("SKIPPED: this cv2 cannot write an MJPG AVI")
    rng = np.random.default_rng(3)
    bg = rng.integers(0, 256, size=(240, 320, 3), dtype=np.uint8)
    patch = rng.integers(0, 256, size=(60, 40, 3), dtype=np.uint8)
    for k in range(20):
        f = bg.copy()
        f[80:140, 120 + k:160 + k] = patch
        writer.write(f)
    writer.release()
    scope = {}
    exec(code.replace("clip.mp4", str(clip)), scope)
    x, y, w, h = scope["box"]
    # the patch moved 19 px right in 20 frames (lossy JPEG frames)
    assert abs(x - 139) <= 2 and abs(y - 80) <= 2, scope["box"]
