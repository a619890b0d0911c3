"""OTB evaluation: scores as ``bayestrack-otb`` computes them and tracking
sequences read as ``bayestrack track --seq`` reads them.

::

    from bayestrack import Tracker, otb

    seq = otb.load_sequence("sequences/Crossing")   # frames decoded on demand
    tracker = Tracker("ncc-scale")
    boxes = [seq.init_box]
    for i, frame in enumerate(seq):
        if i == 0:
            tracker.init(frame, seq.init_box)
        else:
            boxes.append(tracker.update(frame)[1])
    print(otb.score(seq.groundtruth, boxes)["success_auc"])
"""

from ._bayestrack import FrameIter, TrackingSequence, format_box, load_sequence, score

Sequence = TrackingSequence
"""A tracking sequence on disk (:func:`load_sequence`)."""

__all__ = ["score", "load_sequence", "Sequence", "TrackingSequence", "FrameIter", "format_box"]
