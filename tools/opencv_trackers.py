#!/usr/bin/env python3
"""OpenCV's CSRT, KCF and MOSSE on OTB-layout sequences, scored as `cargo xtask otb` scores ours.

One pass per tracker and sequence, initialised from frame 1's ground truth,
exactly as crates/otb/src/suite.rs runs our trackers, and scored exactly as
crates/otb/src/metrics.rs scores them:

- boxes in the OTB convention, (x, y) the 1-based top-left pixel, (w, h) the
  size; OpenCV's 0-based boxes are shifted by one each way;
- overlap: IoU with inclusive pixel bounds (right edge x + w - 1, the
  intersection max(0, min(r_a, r_b) - max(x_a, x_b) + 1), as the OTB
  toolkit's calcRectInt); centre (x + (w - 1) / 2, y + (h - 1) / 2);
- success curve at the 21 thresholds 0, 0.05, ..., 1 (fraction of frames
  with IoU > t), AUC its mean; SR@0.5 the fraction with IoU > 0.5; P@20 the
  fraction with centre error <= 20 px;
- ground-truth rows `0,0,0,0` (David's unlabelled frames) and frames past
  the last row are not scored;
- frame 1's box is the ground truth it was initialised from (scored, as
  ours is);
- fps: frames over the seconds spent inside the tracker's init and update
  calls only (not decoding), with OpenCV on one thread (cv2.setNumThreads(1));
- a frame where the tracker reports failure keeps its previous box and
  counts in `lost_frames`.

Sequences are found as crates/otb/src/sequence.rs finds them: every folder
under the root with an `img/` sub-folder, sorted by name; frames are the
numbered .jpg/.jpeg/.png files of `img/` in number order (`0001.jpg`,
`img00001.png`); the ground truth is `groundtruth_rect.txt`, else the first
by name of the folder's `*_gt*.txt` / `groundtruth*.txt` files (David's
`david_gt.txt`), rows separated by commas, tabs or spaces. (The crate also
applies the OTB-100 table's start and end frames to folders with the
benchmark's layout; our three real sequences and the stress set run on all
their frames, as here.)

Writes under --out (default <project>/target/opencv/<parent>-<root>, e.g.
`data-sequences`, `stress-sequences`)
`results.csv` (the columns of `cargo xtask otb`'s results.csv), `results.md`
(its table: SR@0.5 / AUC / P@20 / fps per sequence and the mean) and
`boxes/<tracker>/<sequence>.txt`, and prints the table.

Usage:
  pip install opencv-contrib-python-headless numpy
  python3 tools/opencv_trackers.py [ROOT ...] [--trackers csrt,kcf,mosse] [--out DIR]
ROOT defaults to ../shared/data/sequences; the stress set is
target/stress/sequences (written by `cargo xtask stress`). Without cv2 the
script says so and exits 0.
"""

import argparse
import csv
import io
import math
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SEQUENCES = ROOT.parent / "shared" / "data" / "sequences"

THRESHOLDS = [i / 20.0 for i in range(21)]
PRECISION_THRESHOLD = 20.0
SUCCESS_RATE_THRESHOLD = 0.5
FRAME_EXTENSIONS = (".jpg", ".jpeg", ".png")
COLUMNS = [
    "sequence",
    "tracker",
    "success_rate_50",
    "auc",
    "precision_20",
    "mean_iou",
    "mean_overlap_of_frames_with_overlap",
    "mean_center_error",
    "fps",
    "frames_scored",
    "lost_frames",
    "error",
]


# ---------------------------------------------------------------- scoring


def center(b):
    x, y, w, h = b
    return (x + (w - 1.0) / 2.0, y + (h - 1.0) / 2.0)


def center_error(a, b):
    (ax, ay), (bx, by) = center(a), center(b)
    return math.hypot(ax - bx, ay - by)


def iou(a, b):
    """OTB overlap: inclusive pixel bounds, clamped to [0, 1]."""
    iw = min(a[0] + a[2] - 1.0, b[0] + b[2] - 1.0) - max(a[0], b[0]) + 1.0
    ih = min(a[1] + a[3] - 1.0, b[1] + b[3] - 1.0) - max(a[1], b[1]) + 1.0
    inter = max(iw, 0.0) * max(ih, 0.0)
    union = a[2] * a[3] + b[2] * b[3] - inter
    if union > 0.0 and math.isfinite(inter):
        return min(max(inter / union, 0.0), 1.0)
    return 0.0


def success_rate(overlaps, threshold):
    if not overlaps:
        return 0.0
    return sum(1 for o in overlaps if o > threshold) / len(overlaps)


def score_otb(predicted, truth):
    """The scores of metrics.rs's score_otb; truth rows None are skipped."""
    if len(predicted) != len(truth):
        raise ValueError(f"{len(predicted)} boxes for {len(truth)} ground-truth rows")
    overlaps, errors = [], []
    for p, t in zip(predicted, truth):
        if t is None:
            continue
        overlaps.append(iou(p, t))
        errors.append(center_error(p, t))
    if not overlaps:
        raise ValueError("no labelled frame to score")
    n = len(overlaps)
    curve = [success_rate(overlaps, t) for t in THRESHOLDS]
    positive = [o for o in overlaps if o > 0.0]
    return {
        "success_rate_50": success_rate(overlaps, SUCCESS_RATE_THRESHOLD),
        "auc": sum(curve) / len(curve),
        "precision_20": sum(1 for e in errors if e <= PRECISION_THRESHOLD) / n,
        "mean_iou": sum(overlaps) / n,
        "mean_overlap_of_frames_with_overlap": (sum(positive) / len(positive)) if positive else None,
        "mean_center_error": sum(errors) / n,
        "frames_scored": n,
        "success": curve,
    }


# ---------------------------------------------------------- sequences


def parse_ground_truth(text, path="ground truth"):
    """Rows of x y w h (commas, tabs or spaces); 0,0,0,0 is None."""
    rows = []
    for i, line in enumerate(text.lstrip("\ufeff").splitlines()):
        line = line.strip()
        if not line:
            continue
        fields = [f for f in re.split(r"[,\s]+", line) if f]
        if len(fields) != 4:
            raise ValueError(f"{path}:{i + 1}: expected 4 numbers, found {len(fields)}")
        v = [float(f) for f in fields]
        rows.append(None if v == [0.0, 0.0, 0.0, 0.0] else tuple(v))
    return rows


def ground_truth_file(seq_dir):
    standard = seq_dir / "groundtruth_rect.txt"
    if standard.is_file():
        return standard
    found = sorted(
        p
        for p in seq_dir.iterdir()
        if p.is_file()
        and p.name.lower().endswith(".txt")
        and ("_gt" in p.name.lower() or p.name.lower().startswith("groundtruth"))
    )
    return found[0] if found else None


def frame_number(name):
    digits = re.findall(r"\d+", Path(name).stem)
    return int(digits[-1]) if digits else None


def list_frames(seq_dir):
    files = [
        p
        for p in (seq_dir / "img").iterdir()
        if p.is_file() and p.suffix.lower() in FRAME_EXTENSIONS
    ]
    numbered = sorted((frame_number(p.name), p) for p in files if frame_number(p.name) is not None)
    return [p for _, p in numbered]


def list_sequences(root):
    return sorted(p for p in Path(root).iterdir() if p.is_dir() and (p / "img").is_dir())


# ---------------------------------------------------------------- trackers


def make_tracker(cv2, name):
    """CSRT, KCF or MOSSE, from the main module or cv2.legacy."""
    factory = {"csrt": "TrackerCSRT_create", "kcf": "TrackerKCF_create", "mosse": "TrackerMOSSE_create"}[name]
    for module in (cv2, getattr(cv2, "legacy", None)):
        if module is not None and hasattr(module, factory):
            return getattr(module, factory)()
    raise RuntimeError(f"this OpenCV ({cv2.__version__}) has no {factory} (install opencv-contrib-python-headless)")


def track(cv2, name, frames, init):
    """Boxes (OTB convention), tracker seconds and frames reported lost."""
    tracker = make_tracker(cv2, name)
    image = cv2.imread(str(frames[0]), cv2.IMREAD_COLOR)
    if image is None:
        raise RuntimeError(f"{frames[0]}: does not decode")
    x, y, w, h = init
    rect = (int(round(x - 1.0)), int(round(y - 1.0)), max(1, int(round(w))), max(1, int(round(h))))
    t0 = time.perf_counter()
    tracker.init(image, rect)
    seconds = time.perf_counter() - t0
    boxes, lost, last = [init], 0, init
    for path in frames[1:]:
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise RuntimeError(f"{path}: does not decode")
        t0 = time.perf_counter()
        ok, box = tracker.update(image)
        seconds += time.perf_counter() - t0
        if ok and box[2] > 0 and box[3] > 0:
            last = (float(box[0]) + 1.0, float(box[1]) + 1.0, float(box[2]), float(box[3]))
        else:
            lost += 1
        boxes.append(last)
    return boxes, seconds, lost


# ---------------------------------------------------------------- output


def number(v):
    """A CSV cell as the Rust suite writes it (shortest round-trip float)."""
    if v is None:
        return ""
    if isinstance(v, float):
        if math.isinf(v):
            return "inf"
        if v == int(v) and abs(v) < 1e16:
            return f"{v:.1f}"
        return repr(v)
    return str(v)


def short(v):
    return f"{v:g}" if v != int(v) else str(int(v))


def markdown_table(title, header, rows):
    line = lambda cells: "| " + " | ".join(cells) + " |\n"
    out = f"**{title}**\n\n" + line(header)
    out += line(["---"] + ["---:"] * (len(header) - 1))
    for r in rows:
        out += line(r)
    return out


def plain_table(title, header, rows):
    width = [max(len(r[i]) for r in [header] + rows) for i in range(len(header))]
    fmt = lambda r: "  " + "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, width)))
    total = sum(width) + 2 * (len(width) - 1)
    return "\n".join([title, fmt(header), "  " + "-" * total] + [fmt(r) for r in rows]) + "\n"


def summary_table(sequences, trackers, cells):
    """The suite's table: SR@0.5 / AUC / P@20 / fps per sequence and the mean."""
    header = ["tracker"] + sequences + ["mean"]
    rows = []
    for t in trackers:
        row, done = [t], []
        for s in sequences:
            c = cells.get((s, t))
            if c is None or c.get("error"):
                row.append("failed")
                continue
            done.append(c)
            row.append(f"{c['success_rate_50']:.3f} / {c['auc']:.3f} / {c['precision_20']:.3f} / {c['fps']:.0f}")
        if done:
            mean = lambda k: sum(c[k] for c in done) / len(done)
            text = f"{mean('success_rate_50'):.3f} / {mean('auc'):.3f} / {mean('precision_20'):.3f} / {mean('fps'):.0f}"
            row.append(text if len(done) == len(sequences) else f"{text} ({len(done)} seq.)")
        else:
            row.append("failed")
        rows.append(row)
    return "OpenCV one-pass evaluation: SR@0.5 / AUC / P@20 / fps", header, rows


def run(root, trackers, out):
    try:
        import cv2
    except ImportError:
        print(
            "opencv_trackers.py: OpenCV (cv2) is not installed; nothing to compare. "
            "Install it with: pip install opencv-contrib-python-headless numpy"
        )
        return 0
    cv2.setNumThreads(1)
    sequences = list_sequences(root)
    if not sequences:
        print(f"error: {root} holds no sequence folder with an img/ sub-folder", file=sys.stderr)
        return 1
    out.mkdir(parents=True, exist_ok=True)
    names, cells, failed = [], {}, 0
    for seq in sequences:
        frames = list_frames(seq)
        gt_path = ground_truth_file(seq)
        truth = parse_ground_truth(gt_path.read_text(), gt_path) if gt_path else []
        truth = (truth + [None] * len(frames))[: len(frames)]
        names.append(seq.name)
        for name in trackers:
            row = {"sequence": seq.name, "tracker": name, "error": ""}
            try:
                if not frames or truth[0] is None:
                    raise RuntimeError(f"{seq.name}: frame 1 is unlabelled or there are no frames")
                boxes, seconds, lost = track(cv2, name, frames, truth[0])
                score = score_otb(boxes, truth)
                row.update({k: v for k, v in score.items() if k != "success"})
                row["fps"] = len(frames) / seconds if seconds > 0 else math.inf
                row["lost_frames"] = lost
                box_dir = out / "boxes" / name
                box_dir.mkdir(parents=True, exist_ok=True)
                (box_dir / f"{seq.name}.txt").write_text(
                    "".join(",".join(short(v) for v in b) + "\n" for b in boxes)
                )
            except Exception as e:  # noqa: BLE001 - reported in the cell
                row["error"] = str(e)
                failed += 1
            cells[(seq.name, name)] = row
            if row["error"]:
                print(f"{seq.name:<24} {name:<8} failed: {row['error']}", file=sys.stderr)
            else:
                print(
                    f"{seq.name:<24} {name:<8} SR@0.5 {row['success_rate_50']:.3f}  AUC {row['auc']:.3f}  "
                    f"P@20 {row['precision_20']:.3f}  {row['fps']:>8.0f} fps",
                    file=sys.stderr,
                )
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for s in names:
        for t in trackers:
            c = cells[(s, t)]
            w.writerow([c.get(k) if k in ("sequence", "tracker", "error") else number(c.get(k)) for k in COLUMNS])
    (out / "results.csv").write_text(buf.getvalue())
    title, header, rows = summary_table(names, trackers, cells)
    (out / "results.md").write_text(markdown_table(title, header, rows))
    print(plain_table(title, header, rows))
    print(f"files: {out}  (OpenCV {cv2.__version__}, one thread)")
    return 1 if failed else 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("roots", nargs="*", type=Path, help="folders of OTB-layout sequences")
    ap.add_argument("--trackers", default="csrt,kcf,mosse", help="comma-separated: csrt, kcf, mosse")
    ap.add_argument("--out", type=Path, help="output folder (one root only; default target/opencv/<parent>-<root name>)")
    args = ap.parse_args(argv)
    roots = args.roots or [DEFAULT_SEQUENCES]
    trackers = [t.strip().lower() for t in args.trackers.split(",") if t.strip()]
    bad = [t for t in trackers if t not in ("csrt", "kcf", "mosse")]
    if bad:
        ap.error(f"unknown tracker(s) {', '.join(bad)} (known: csrt, kcf, mosse)")
    if args.out and len(roots) > 1:
        ap.error("--out takes one root")
    status = 0
    for root in roots:
        if not root.is_dir():
            print(f"error: {root} is not a folder", file=sys.stderr)
            status = 1
            continue
        resolved = root.resolve()
        out = args.out or ROOT / "target" / "opencv" / f"{resolved.parent.name}-{resolved.name}"
        status |= run(root, trackers, out)
    return status


if __name__ == "__main__":
    sys.exit(main())
