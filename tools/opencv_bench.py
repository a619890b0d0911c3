#!/usr/bin/env python3
"""OpenCV reference timings for the bayestrack-appearance criterion benches.

Same sizes as crates/appearance/benches/appearance.rs, one thread:
  - template matching of a 30x20 template over a 320x240 gray frame
    (cv2.matchTemplate, TM_SQDIFF and TM_CCORR, + cv2.minMaxLoc for the best
    position, which is what mad_search returns);
  - a 3x256 per-channel histogram of a 40x40 window (cv2.calcHist x 3);
  - absolute frame difference of 320x240 gray frames (cv2.absdiff).

Usage: pip install opencv-python-headless numpy; python3 tools/opencv_bench.py
Prints one line per case: median time over repeated runs.
"""

import time

import cv2
import numpy as np


def median_time(fn, min_total=1.0, min_reps=20):
    """Median wall time of fn() in seconds, repeated for about min_total s."""
    fn()  # warm-up
    times = []
    start = time.perf_counter()
    while len(times) < min_reps or time.perf_counter() - start < min_total:
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2]


def fmt(seconds):
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.3f} ms"
    return f"{seconds * 1e6:.2f} us"


def main():
    cv2.setNumThreads(1)
    rng = np.random.default_rng(1)
    ys, xs = np.mgrid[0:240, 0:320]
    scene = (xs * 0.5 + np.sin(ys * 0.07) * 40.0 + 60.0).astype(np.uint32)
    scene = ((scene + rng.integers(0, 256, scene.shape) // 8) % 256).astype(np.uint8)
    noise = rng.integers(0, 256, (240, 320), dtype=np.uint8)
    print(f"OpenCV {cv2.__version__}, threads = {cv2.getNumThreads()}")
    for name, frame in [("scene", scene), ("noise", noise)]:
        tpl = frame[117:137, 201:231].copy()  # 30 wide, 20 high
        for method, mname in [(cv2.TM_SQDIFF, "TM_SQDIFF"), (cv2.TM_CCORR, "TM_CCORR")]:
            def run():
                res = cv2.matchTemplate(frame, tpl, method)
                return cv2.minMaxLoc(res)
            loc = run()
            best = loc[2] if method == cv2.TM_SQDIFF else loc[3]
            print(f"matchTemplate {mname} 30x20 over 320x240 ({name}) + minMaxLoc: "
                  f"{fmt(median_time(run))}  best={best}")
    rgb = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    win = rgb[80:120, 100:140]
    def hist():
        return [cv2.calcHist([win], [c], None, [256], [0, 256]) for c in range(3)]
    print(f"calcHist 3x256 of a 40x40 window: {fmt(median_time(hist))}")
    g0 = rng.integers(0, 256, (240, 320), dtype=np.uint8)
    g1 = rng.integers(0, 256, (240, 320), dtype=np.uint8)
    out = np.empty_like(g0)
    print(f"absdiff 320x240 gray u8: {fmt(median_time(lambda: cv2.absdiff(g1, g0, out)))}")
    def absdiff_f32():
        d = cv2.absdiff(g1, g0)
        return d.astype(np.float32) * (1.0 / 255.0)
    print(f"absdiff 320x240 gray u8 -> f32 in [0, 1]: {fmt(median_time(absdiff_f32))}")


if __name__ == "__main__":
    main()
