"""Score every registered tracker on OTB sequence folders (one-pass
evaluation, frame 1 from ground truth), as `cargo xtask otb` does.

    python evaluate_otb.py ../shared/data/sequences/Crossing ../shared/data/sequences/Couple
"""

import sys

import bayestrack as bt
from bayestrack import otb


def one_pass(name, seq):
    tracker = bt.Tracker(name)
    boxes = [seq.init_box]
    for i, frame in enumerate(seq):
        if i == 0:
            tracker.init(frame, seq.init_box)
        else:
            boxes.append(tracker.update(frame)[1])
    return otb.score(seq.groundtruth, boxes)


def main(folders):
    print(f"{'sequence':12} {'tracker':22} {'AUC':>6} {'P@20':>6} {'SR@0.5':>7}")
    for folder in folders:
        seq = otb.load_sequence(folder)
        for name in bt.tracker_names():
            try:
                s = one_pass(name, seq)
            except ValueError as e:  # e.g. a skin-colour tracker on gray frames
                print(f"{seq.name:12} {name:22} {e}")
                continue
            print(f"{seq.name:12} {name:22} {s['success_auc']:6.3f} {s['precision_20']:6.3f} "
                  f"{s['success_rate_50']:7.3f}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["../shared/data/sequences/Crossing"])
