"""Camera -> tracker -> states, frame by frame: the pipeline `whisker live` and the grasp
controller share.

`LivePipeline.step(frame)` tracks one frame (whisker.tracking.Tracker), feeds the displacement to a
state estimator (whisker.states) and returns a `LiveFrame` with the labels, the displacement and
the processing time. `annotate` draws the states and displacement arrows on the frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from whisker.states import STATE_NAMES

STATE_BGR = ((0, 200, 0), (0, 0, 255), (255, 128, 0))      # rest green, contact red, dynamic blue


@dataclass
class LiveFrame:
    index: int
    time_s: float
    labels: np.ndarray          # (n,) int8 REST/CONTACT/DYNAMIC
    dx_px: np.ndarray           # (n,) NaN where lost
    dy_px: np.ndarray
    valid: np.ndarray           # (n,) bool
    process_s: float            # tracking + state, this frame
    result: object = None       # the TrackResult

    def record(self) -> dict:
        """The JSON-ready record of this frame (whisker states, px, ms)."""
        def r(v):
            return None if not np.isfinite(v) else round(float(v), 3)
        return {"frame": int(self.index), "t": round(float(self.time_s), 4),
                "states": [STATE_NAMES[int(s)] for s in self.labels],
                "dx": [r(v) for v in self.dx_px], "dy": [r(v) for v in self.dy_px],
                "valid": [bool(v) for v in self.valid], "ms": round(self.process_s * 1e3, 3)}


class LivePipeline:
    """A calibrated tracker and a state estimator. `expected` (n, 2) px may be passed per frame
    (the displacement the own actuation command should cause), for estimators that use it."""

    def __init__(self, tracker, estimator, clock=time.perf_counter):
        self.tracker, self.estimator, self.clock = tracker, estimator, clock

    def step(self, frame, expected=None) -> LiveFrame:
        t0 = self.clock()
        res = self.tracker.track(frame.image)
        labels = self.estimator.update(frame.time_s, res.dx_px, res.dy_px, expected)
        dt = self.clock() - t0
        return LiveFrame(frame.index, frame.time_s, labels, res.dx_px, res.dy_px, np.asarray(res.valid, bool), dt, res)


def annotate(image, live: LiveFrame, baseline_xy):
    """The tracking drawing (rest centres, arrows) plus each whisker's state beside its marker."""
    import cv2

    from whisker.commands.track import annotate as track_annotate

    out = track_annotate(image, live.result, baseline_xy)
    if out is None:
        return None
    pos = live.result.track_px if live.result.track_px is not None else live.result.positions_px
    for i, s in enumerate(live.labels):
        p = pos[i] if np.all(np.isfinite(pos[i])) else (baseline_xy[i] if baseline_xy is not None else None)
        if p is None or not np.all(np.isfinite(p)):
            continue
        cv2.putText(out, STATE_NAMES[int(s)], (int(p[0]) + 8, int(p[1]) + 14), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    STATE_BGR[int(s)], 1, cv2.LINE_AA)
    return out
