#!/usr/bin/env python3
"""Our MAD search and surface against OpenCV's matchTemplate, in one run.

The cases are those of crates/appearance/benches/appearance.rs (bench_mad):
a 30x20 template cut from frame 1 of a real sequence (David, gray; Couple,
RGB; both in ../shared/data/sequences) and searched over the whole 320x240
frame 2 (a tracker's case: the template comes from the previous frame), the
same-frame search (labelled: the template is in the frame, so bounds prune
nearly everything), and the full MAD surface. OpenCV has no absolute-
difference mode: its closest are TM_SQDIFF and TM_CCORR (+ cv2.minMaxLoc for
the best position, which is what mad_search returns).

The script alternates: each round runs our criterion bench binary (only the
MAD cases, short warm-up and measurement), then times OpenCV on the same
frames, so both see the same machine load. Both sides report the same
statistic for a round: criterion's median per-call time for ours (read from
its estimates.json: the median over samples of d, 2d, ... calls of each
sample's time per call), and the same sampling for OpenCV
(criterion_like_time; it was the median of single calls, which on a loaded
machine leaves out the time given to other processes and so flattered
OpenCV); the script prints the median over rounds of each and the
ratio ours / OpenCV TM_SQDIFF. One thread for both.

On a machine with AVX-512, --simd avx2 caps our kernels at AVX2 (the
bench reads BAYESTRACK_SIMD; OpenCV keeps its own dispatch) to time the
path an AVX2-only machine runs.

Usage:
  pip install opencv-python-headless numpy
  python3 tools/opencv_bench.py [--rounds 5] [--bench-exe PATH] [--simd avx2]
Without --bench-exe it builds the bench with
  cargo bench -p bayestrack-appearance --bench appearance --no-run
and runs the executable cargo reports.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEQ = ROOT.parent / "shared" / "data" / "sequences"


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


def criterion_like_time(fn, seconds, samples=100):
    """Per-call time of fn() as criterion measures ours: samples of d, 2d,
    ..., samples*d calls each (criterion's linear sampling, d chosen so that
    they take about `seconds` in all), the median over samples of the
    sample's time divided by its calls.

    On an idle machine this equals median_time(). On a loaded one it does
    not: a single call of a millisecond mostly runs between two preemptions,
    so the median of single calls leaves the time given to other processes
    out, while a sample of many calls (criterion's) takes its share in;
    with the same statistic on both sides the ratio stays fair."""
    fn()  # warm-up
    t0 = time.perf_counter()
    reps = 0
    while reps < 5 or time.perf_counter() - t0 < 0.2:
        fn()
        reps += 1
    per_call = (time.perf_counter() - t0) / reps
    # Fewer samples (at least 10) where 100 of at least d = 1, 2, ... calls
    # would take longer than `seconds` (criterion runs over its time then).
    samples = max(10, min(samples, int((2 * seconds / per_call) ** 0.5)))
    d = max(1, round(seconds / (per_call * samples * (samples + 1) / 2)))
    times = []
    for i in range(1, samples + 1):
        n = i * d
        t = time.perf_counter()
        for _ in range(n):
            fn()
        times.append((time.perf_counter() - t) / n)
    return statistics.median(times)


def fmt(seconds):
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.3f} ms"
    return f"{seconds * 1e6:.2f} us"


def lcg_noise(shape, seed):
    """The benches' noise: s = s * 1664525 + 1013904223 (mod 2^32), s >> 24."""
    import numpy as np

    out = np.empty(int(np.prod(shape)), dtype=np.uint8)
    s = seed
    for i in range(out.size):
        s = (s * 1_664_525 + 1_013_904_223) & 0xFFFFFFFF
        out[i] = s >> 24
    return out.reshape(shape)


def rendered(dx, dy, ch, seed):
    """The benches' rendered frame (the Rust bench computes in f32; values
    can differ by one at rounding edges)."""
    import numpy as np

    n = lcg_noise((240, 320, ch), seed).astype(np.uint32)
    ys, xs = np.mgrid[0:240, 0:320].astype(np.float32)
    out = np.empty((240, 320, ch), dtype=np.uint8)
    for c in range(ch):
        base = ((xs - dx) * np.float32(0.5) + np.sin((ys - dy) * np.float32(0.07)) * 40
                + 60 + 30 * c).astype(np.uint32)
        out[..., c] = ((base + n[..., c] // 8) % 256).astype(np.uint8)
    return out[..., 0] if ch == 1 else out


def frames(rgb):
    """(label, frame 1, frame 2, template) as in the Rust bench."""
    import cv2

    if rgb:
        seq, f0, f1, x, y = "Couple", "img/0001.jpg", "img/0002.jpg", 48, 67
    else:
        seq, f0, f1, x, y = "David", "img/img00001.png", "img/img00002.png", 143, 95
    flag = cv2.IMREAD_COLOR if rgb else cv2.IMREAD_GRAYSCALE
    a = cv2.imread(str(SEQ / seq / f0), flag)
    b = cv2.imread(str(SEQ / seq / f1), flag)
    if a is not None and b is not None:
        if rgb:  # our frames are RGB; the order of channels does not change timings
            a, b = cv2.cvtColor(a, cv2.COLOR_BGR2RGB), cv2.cvtColor(b, cv2.COLOR_BGR2RGB)
        label = f"{seq} frames 1->2"
    else:
        ch = 3 if rgb else 1
        a, b = rendered(0, 0, ch, 1), rendered(3, 2, ch, 2)
        label = "rendered pair (no ../shared data)"
    return label, a, b, a[y:y + 20, x:x + 30].copy()


def bench_exe():
    out = subprocess.run(
        ["cargo", "bench", "-p", "bayestrack-appearance", "--bench", "appearance", "--no-run",
         "--message-format=json"],
        cwd=ROOT, check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        if msg.get("reason") == "compiler-artifact" and msg.get("executable") \
                and msg["target"]["name"] == "appearance":
            return msg["executable"]
    sys.exit("could not find the appearance bench executable in cargo's output")


def ours(exe, seconds, simd=None):
    """One run of our MAD benches: {case name: criterion's median (s)}.

    Criterion's median of its samples' per-iteration times, read from the
    estimates.json it writes (into a fresh CRITERION_HOME), so that both
    sides report the same statistic (criterion_like_time for OpenCV)."""
    import tempfile

    env = {**os.environ}
    if simd:
        env["BAYESTRACK_SIMD"] = simd
    with tempfile.TemporaryDirectory() as home:
        subprocess.run(
            [exe, "--bench", "--warm-up-time", "0.5", "--measurement-time", str(seconds),
             "mad_search|MadSearch|mad_map_into"],
            cwd=ROOT / "crates" / "appearance", check=True, capture_output=True, text=True,
            env={**env, "CRITERION_HOME": home})
        times = {}
        for bench in Path(home).glob("*/new/benchmark.json"):
            name = json.loads(bench.read_text())["full_id"]
            est = json.loads((bench.parent / "estimates.json").read_text())
            times[name] = est["median"]["point_estimate"] * 1e-9
    if not times:
        sys.exit("no criterion estimates were written by the bench")
    return times


def opencv_cases():
    import cv2

    cases = {}
    for rgb in (False, True):
        label, first, nxt, tpl = frames(rgb)
        kind = "RGB" if rgb else "gray"
        for mname, method in (("TM_SQDIFF", cv2.TM_SQDIFF), ("TM_CCORR", cv2.TM_CCORR)):
            for which, frame in (("next-frame", nxt), ("SAME-frame", first)):
                def run(frame=frame, method=method, tpl=tpl):
                    return cv2.minMaxLoc(cv2.matchTemplate(frame, tpl, method))
                cases[f"matchTemplate {mname} {kind} {which} ({label}) + minMaxLoc"] = run
    return cases


def other_references():
    """OpenCV-only references for the histogram and frame-difference benches
    (same sizes as crates/appearance/benches), printed once."""
    import cv2
    import numpy as np

    rng = np.random.default_rng(1)
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=2.0, help="criterion measurement time")
    ap.add_argument("--bench-exe", help="the built appearance bench executable")
    ap.add_argument("--simd", choices=["scalar", "sse2", "avx2", "avx512"],
                    help="cap our kernels at this level (BAYESTRACK_SIMD)")
    ap.add_argument("--opencv-only", action="store_true",
                    help="time OpenCV alone (no cargo needed)")
    args = ap.parse_args()
    try:
        import cv2
    except ImportError:
        sys.exit("OpenCV is not installed: pip install opencv-python-headless numpy")
    cv2.setNumThreads(1)
    if args.opencv_only:
        for k, fn in opencv_cases().items():
            print(f"  {fmt(median_time(fn)):>12}  {k}")
        other_references()
        return
    exe = os.path.abspath(args.bench_exe) if args.bench_exe else bench_exe()
    print(f"OpenCV {cv2.__version__}, threads = {cv2.getNumThreads()}; ours: {os.path.basename(exe)}"
          f" (kernels: {args.simd or 'best level'})")
    cv = opencv_cases()
    ours_t, cv_t = {}, {}
    for r in range(args.rounds):
        for k, v in ours(exe, args.seconds, args.simd).items():
            ours_t.setdefault(k, []).append(v)
        for k, fn in cv.items():
            cv_t.setdefault(k, []).append(criterion_like_time(fn, args.seconds))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    med = {k: statistics.median(v) for k, v in ours_t.items()}
    cvm = {k: statistics.median(v) for k, v in cv_t.items()}
    print("\nmedian over rounds:")
    for k in sorted(cvm):
        print(f"  {fmt(cvm[k]):>12}  {k}")
    for k in sorted(med):
        print(f"  {fmt(med[k]):>12}  {k}")
    print("\nratio ours / OpenCV TM_SQDIFF (same frames, same run; < 1: ours faster):")
    for k, t in sorted(med.items()):
        kind = "RGB" if " RGB " in k else "gray"
        which = "SAME-frame" if "SAME-frame" in k else "next-frame"
        if "white noise" in k:
            continue
        ref = [v for c, v in cvm.items() if "TM_SQDIFF" in c and f" {kind} " in c and which in c]
        if ref:
            print(f"  {t / ref[0]:6.2f}x  {k}")
    print("\nother OpenCV references (histogram and frame-difference benches):")
    other_references()


if __name__ == "__main__":
    main()
