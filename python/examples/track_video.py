"""Track an object in a video with bayestrack.Tracker, OpenCV-style.

    python track_video.py SEQUENCE_FOLDER [TRACKER] [key=value ...]
    python track_video.py clip.mp4 ncc-scale --init 120,80,40,60   # needs cv2

A sequence folder (OTB layout: img/ and groundtruth_rect.txt, e.g.
../shared/data/sequences/Crossing) is read with bayestrack.otb and scored;
a video file is read with cv2.VideoCapture (initial box from --init, 0-based
x,y,w,h as OpenCV's). Options after the tracker are its `key=value`
options (see bayestrack.tracker_options(name)).
"""

import argparse
import time

import bayestrack as bt
from bayestrack import otb


def value(text):
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(text, text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seq")
    ap.add_argument("tracker", nargs="?", default="ncc-scale")
    ap.add_argument("options", nargs="*", help="key=value tracker options")
    ap.add_argument("--init", help="x,y,w,h (0-based) for a video file")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    options = dict((k, value(v)) for k, v in (o.split("=", 1) for o in args.options))
    tracker = bt.Tracker(args.tracker, seed=args.seed, **options)

    if args.init is None:
        seq = otb.load_sequence(args.seq)  # BGR frames, decoded one at a time
        frames, init, gt = iter(seq), seq.init_box, seq.groundtruth
    else:
        import cv2

        cap = cv2.VideoCapture(args.seq)
        frames = iter(lambda: cap.read()[1], None)
        init, gt = tuple(float(v) for v in args.init.split(",")), None

    boxes, lost = [init], 0
    start = time.perf_counter()
    tracker.init(next(frames), init)
    for frame in frames:
        ok, box = tracker.update(frame)  # the GIL is released meanwhile
        boxes.append(box)
        lost += not ok
    seconds = time.perf_counter() - start
    print(f"{tracker!r}: {len(boxes)} frames, {len(boxes) / seconds:.0f} fps, lost on {lost}")
    if gt is not None:
        s = otb.score(gt, boxes)
        print(f"success AUC {s['success_auc']:.3f}  precision@20 {s['precision_20']:.3f}  "
              f"SR@0.5 {s['success_rate_50']:.3f}")


if __name__ == "__main__":
    main()
