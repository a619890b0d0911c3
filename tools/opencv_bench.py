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

The script alternates: each round runs our criterion bench binary on the
gray MAD cases, then times OpenCV's gray cases, then the same for RGB (one
kind at a time, so that each pair is timed within some 20 seconds and sees
the same machine load). Both sides report the same statistics for a round,
from the same kind of samples: flat sampling, 100 samples of a fixed
number of calls each, about 20 ms a sample whatever the time of a call
(ours: criterion, its estimates.json and sample.json; OpenCV:
criterion_like_time, the same sampling in Python):

- median: the median over samples of each sample's time per call. On a
  loaded machine it includes the time given to other processes, the same
  share on both sides since the samples are equally long;
- least disturbed: the smallest per-call time of any sample, the closest
  to a run nobody interrupted.

The load of this 2-core machine and what the host runs beside it move both
figures by up to 2-3x between minutes (the same surface binary took
0.40 ms and 1.10 ms a call a few seconds apart), which is why both sides
are timed close together, on the same CPU, with samples of the same length.
Until 2026-12-03 OpenCV's samples were d, 2d, ... calls (criterion's
linear sampling) while criterion chose flat samples of ours on the loaded
machine, and before that OpenCV's figure was a median of single calls:
either way the two sides took different shares of the preemptions.

Both sides run pinned to one CPU (--cpu, default 0): the two virtual CPUs
of the project's 2-core machine ran the same code at speeds up to 1.6x
apart (2026-12-03: a scalar loop 41 us on CPU 0 and 55-68 us on CPU 1, the
gray MAD surface 0.35-0.39 ms and 0.48-0.55 ms, in the same minute), and
unpinned, the bench (a subprocess started while the script waits) and
OpenCV (in the script's process) could each land on either.

OpenCV writes into a preallocated result (matchTemplate's `result`
argument), as ours writes into a reused surface: a fresh 257 KB result
costs OpenCV some 76 page faults a call (glibc maps and unmaps it every
call), which is an allocation cost, not the matching. The script prints the
median over rounds of each statistic, the ratios ours / OpenCV TM_SQDIFF,
and the load average at each round's start. One thread for both.

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
import math
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


def criterion_like_time(fn, seconds, samples=100, warm_up=0.5):
    """Per-call time of fn() as criterion measures ours (the MAD benches
    use criterion's flat sampling): a warm-up of `warm_up` seconds gives
    the mean time of a call, then `samples` samples of the same number of
    calls each, as many as make all of them take about `seconds`; returns
    (median, least) over samples of the sample's time divided by its calls.

    Samples of equal length (seconds / samples, 20 ms by default) on both
    sides: on a loaded machine a sample takes its share of the time given
    to other processes, the same share on both sides (the median), and the
    least of them is as likely to have escaped every interruption on both
    sides; the median of single calls, which this replaced, left the
    preemption out of OpenCV's time only."""
    t0 = time.perf_counter()
    reps = 0
    while reps < 5 or time.perf_counter() - t0 < warm_up:
        fn()
        reps += 1
    per_call = (time.perf_counter() - t0) / reps
    n = max(1, math.ceil(seconds / (samples * per_call)))
    times = []
    for _ in range(samples):
        t = time.perf_counter()
        for _ in range(n):
            fn()
        times.append((time.perf_counter() - t) / n)
    return statistics.median(times), min(times)


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


def ours(exe, seconds, simd=None, kind=None):
    """One run of our MAD benches (those of one kind, "gray" or "RGB", if
    given): {case name: (median, least) per-call time (s)}.

    Criterion's median of its samples' per-iteration times, read from the
    estimates.json it writes (into a fresh CRITERION_HOME), and the
    smallest per-iteration time of a sample (its sample.json), so that both
    sides report the same statistics (criterion_like_time for OpenCV)."""
    import tempfile

    env = {**os.environ}
    if simd:
        env["BAYESTRACK_SIMD"] = simd
    cases = "^mad/(mad_search|MadSearch|mad_map_into|sad_windows)"
    if kind:
        cases += f".* {kind} "
    with tempfile.TemporaryDirectory() as home:
        subprocess.run(
            [exe, "--bench", "--warm-up-time", "0.5", "--measurement-time", str(seconds), cases],
            cwd=ROOT / "crates" / "appearance", check=True, capture_output=True, text=True,
            env={**env, "CRITERION_HOME": home})
        times = {}
        # <home>/mad/<case>/new/: the cases are in criterion group "mad"
        for bench in Path(home).glob("*/*/new/benchmark.json"):
            name = json.loads(bench.read_text())["full_id"].removeprefix("mad/")
            est = json.loads((bench.parent / "estimates.json").read_text())
            sample = json.loads((bench.parent / "sample.json").read_text())
            least = min(t / n for n, t in zip(sample["iters"], sample["times"]))
            times[name] = (est["median"]["point_estimate"] * 1e-9, least * 1e-9)
    if not times:
        sys.exit("no criterion estimates were written by the bench")
    return times


def opencv_cases(kinds=("gray", "RGB"), reuse=True):
    """{case name: callable} for OpenCV, writing into a preallocated result
    unless `reuse` is false."""
    import cv2
    import numpy as np

    cases = {}
    for kind in kinds:
        label, first, nxt, tpl = frames(kind == "RGB")
        shape = (first.shape[0] - tpl.shape[0] + 1, first.shape[1] - tpl.shape[1] + 1)
        out = np.empty(shape, np.float32)
        for mname, method in (("TM_SQDIFF", cv2.TM_SQDIFF), ("TM_CCORR", cv2.TM_CCORR)):
            for which, frame in (("next-frame", nxt), ("SAME-frame", first)):
                if reuse:
                    def run(frame=frame, method=method, tpl=tpl, out=out):
                        return cv2.minMaxLoc(cv2.matchTemplate(frame, tpl, method, result=out))
                else:
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
    ap.add_argument("--cpu", type=int, default=0,
                    help="pin both sides to this CPU (default 0; -1: leave unpinned)")
    ap.add_argument("--fresh-result", action="store_true",
                    help="let OpenCV allocate its result every call (as before 2026-12-03)")
    args = ap.parse_args()
    try:
        import cv2
    except ImportError:
        sys.exit("OpenCV is not installed: pip install opencv-python-headless numpy")
    cv2.setNumThreads(1)
    if args.cpu >= 0:
        # the bench subprocesses inherit the affinity
        os.sched_setaffinity(0, {args.cpu})
    if args.opencv_only:
        for k, fn in opencv_cases(reuse=not args.fresh_result).items():
            print(f"  {fmt(median_time(fn)):>12}  {k}")
        other_references()
        return
    exe = os.path.abspath(args.bench_exe) if args.bench_exe else bench_exe()
    print(f"OpenCV {cv2.__version__}, threads = {cv2.getNumThreads()}; ours: {os.path.basename(exe)}"
          f" (kernels: {args.simd or 'best level'}); OpenCV's result "
          f"{'allocated every call' if args.fresh_result else 'preallocated'}; "
          f"{f'both on CPU {args.cpu}' if args.cpu >= 0 else 'unpinned'}")
    kinds = ("gray", "RGB")
    cv = {kind: opencv_cases((kind,), reuse=not args.fresh_result) for kind in kinds}
    ours_t, cv_t = {}, {}
    for r in range(args.rounds):
        print(f"round {r + 1}/{args.rounds}: load average {os.getloadavg()[0]:.2f}", file=sys.stderr)
        for kind in kinds:
            for k, v in ours(exe, args.seconds, args.simd, kind).items():
                ours_t.setdefault(k, []).append(v)
            for k, fn in cv[kind].items():
                cv_t.setdefault(k, []).append(criterion_like_time(fn, args.seconds))
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    # (median, least disturbed), each the median over rounds
    med = {k: tuple(statistics.median(x) for x in zip(*v)) for k, v in ours_t.items()}
    cvm = {k: tuple(statistics.median(x) for x in zip(*v)) for k, v in cv_t.items()}
    print("\nmedian over rounds (median per-call time; least disturbed sample's):")
    for table in (cvm, med):
        for k in sorted(table):
            m, least = table[k]
            print(f"  {fmt(m):>12} {fmt(least):>12}  {k}")
    print("\nratio ours / OpenCV TM_SQDIFF (same frames, same run; < 1: ours faster),"
          " of the medians and of the least disturbed samples (medians over rounds;"
          " in brackets the range of the rounds' own ratios):")
    for k, t in sorted(med.items()):
        kind = "RGB" if " RGB " in k else "gray"
        which = "SAME-frame" if "SAME-frame" in k else "next-frame"
        if "white noise" in k:
            continue
        ref = [c for c in cvm if "TM_SQDIFF" in c and f" {kind} " in c and which in c]
        if ref:
            rounds = [[o[i] / c[i] for o, c in zip(ours_t[k], cv_t[ref[0]])] for i in (0, 1)]
            span = "  ".join(f"[{min(r):.2f}-{max(r):.2f}]" for r in rounds)
            print(f"  {t[0] / cvm[ref[0]][0]:6.2f}x {t[1] / cvm[ref[0]][1]:6.2f}x  {span}  {k}")
    print("\nother OpenCV references (histogram and frame-difference benches):")
    other_references()


if __name__ == "__main__":
    main()
