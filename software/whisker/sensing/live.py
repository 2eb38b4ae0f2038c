"""Camera -> tracker -> states, frame by frame: the pipeline `whisker live` and the grasp
controller share.

`LivePipeline.step(frame)` tracks one frame (whisker.vision.tracking.Tracker), feeds the displacement to a
state estimator (whisker.sensing.states), estimates each whisker's tip force and contact direction from the
deflection and the membrane stiffness (whisker.sensing.contact_force) and returns a `LiveFrame` with the
labels, the displacement, the force and the processing time. `annotate` draws the states,
displacement arrows and force arrows on the frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from whisker.sensing.states import STATE_NAMES

STATE_BGR = ((0, 200, 0), (0, 0, 255), (255, 128, 0))      # rest green, contact red, dynamic blue
FORCE_BGR = (255, 0, 255)                                   # force arrows magenta
FORCE_PX_PER_MN = 15.0                                      # force arrow length, px per mN ...
FORCE_MAX_PX = 80.0                                         # ... at most this long


@dataclass
class LiveFrame:
    index: int
    time_s: float
    labels: np.ndarray          # (n,) int8 REST/CONTACT/DYNAMIC
    dx_px: np.ndarray           # (n,) NaN where lost
    dy_px: np.ndarray
    valid: np.ndarray           # (n,) bool
    process_s: float            # tracking + state + force, this frame
    result: object = None       # the TrackResult
    force: object = None        # whisker.sensing.contact_force.TipForce (sensor frame, mN), or None
    force_uv: np.ndarray | None = None   # (n, 2) the same force in image axes, mN (for the arrows)

    def record(self) -> dict:
        """The JSON-ready record of this frame (whisker states, px, tip force mN, direction deg, ms)."""
        def r(v, nd=3):
            return None if not np.isfinite(v) else round(float(v), nd)
        out = {"frame": int(self.index), "t": round(float(self.time_s), 4),
               "states": [STATE_NAMES[int(s)] for s in self.labels],
               "dx": [r(v) for v in self.dx_px], "dy": [r(v) for v in self.dy_px],
               "valid": [bool(v) for v in self.valid]}
        if self.force is not None:
            out["force_mN"] = [r(v, 3) for v in self.force.force_mN]
            out["direction_deg"] = [r(v, 1) for v in self.force.direction_deg]
        out["ms"] = round(self.process_s * 1e3, 3)
        return out


class LivePipeline:
    """A calibrated tracker and a state estimator. `expected` (n, 2) px may be passed per frame
    (the displacement the own actuation command should cause), for estimators that use it."""

    def __init__(self, tracker, estimator, clock=time.perf_counter, force_model=None):
        """force_model: a whisker.sensing.contact_force.ForceModel (e.g. ForceModel.from_design), or None for
        no force estimate."""
        self.tracker, self.estimator, self.clock = tracker, estimator, clock
        self.force_model = force_model

    def step(self, frame, expected=None, levels=None) -> LiveFrame:
        """One frame; `levels` (n,): the coil levels driving the whiskers now (for the force)."""
        from whisker.sensing.contact_force import tip_force

        t0 = self.clock()
        res = self.tracker.track(frame.image)
        labels = self.estimator.update(frame.time_s, res.dx_px, res.dy_px, expected)
        force = uv = None
        if self.force_model is not None:
            force = tip_force(self.force_model, res.dx_px, res.dy_px, levels)
            M = np.asarray(self.force_model.image_to_sensor)      # orthogonal: its transpose maps back
            uv = np.stack([force.fx_mN, force.fy_mN], axis=-1) @ M
        dt = self.clock() - t0
        return LiveFrame(frame.index, frame.time_s, labels, res.dx_px, res.dy_px, np.asarray(res.valid, bool), dt, res,
                         force, uv)


def annotate(image, live: LiveFrame, baseline_xy):
    """The tracking drawing (rest centres, displacement arrows) plus each whisker's state beside its
    marker and, when the frame has a force, a magenta arrow from the marker along the force on the
    tip (as the camera sees it, FORCE_PX_PER_MN px per mN, at most FORCE_MAX_PX) labelled in mN."""
    import cv2

    from whisker.vision.annotate import annotate as track_annotate

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
        if live.force_uv is None or not np.all(np.isfinite(live.force_uv[i])) or not np.all(np.isfinite(p)):
            continue
        f = float(live.force.force_mN[i])
        if f * FORCE_PX_PER_MN < 2.0:
            continue
        vec = live.force_uv[i] / f * min(f * FORCE_PX_PER_MN, FORCE_MAX_PX)
        a = (int(round(p[0])), int(round(p[1])))
        b = (int(round(p[0] + vec[0])), int(round(p[1] + vec[1])))
        cv2.arrowedLine(out, a, b, FORCE_BGR, 2, cv2.LINE_AA, 0, 0.3)
        cv2.putText(out, f"{f:.1f} mN", (b[0] + 4, b[1] + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, FORCE_BGR, 1, cv2.LINE_AA)
    return out
