"""The paper's drawing of a tracked frame: rest and current marker centres with arrows (`whisker track
--show`, `whisker live`)."""

from __future__ import annotations


def annotate(image, result, baseline_xy):
    """The paper's drawing: rest centres (white), current centres, yellow arrows; lost markers red.

    Drawn in the tracked frame's coordinates (raw frame unless --undistort image)."""
    import cv2
    import numpy as np

    out = image.copy() if image is not None else None
    if out is None or out.ndim != 3:
        return None
    pos = result.track_px if result.track_px is not None else result.positions_px
    for i, ok in enumerate(result.valid):
        b = baseline_xy[i] if baseline_xy is not None else None
        if b is not None and np.all(np.isfinite(b)):
            cv2.circle(out, (int(round(b[0])), int(round(b[1]))), 3, (255, 255, 255), -1)
        if ok:
            p = pos[i]
            cv2.circle(out, (int(round(p[0])), int(round(p[1]))), 3, (255, 255, 0), -1)
            if b is not None and np.all(np.isfinite(b)):
                cv2.arrowedLine(out, (int(round(b[0])), int(round(b[1]))), (int(round(p[0])), int(round(p[1]))),
                                (0, 255, 255), 2, cv2.LINE_8, 0, 0.5)
            cv2.putText(out, str(i), (int(p[0]) + 6, int(p[1]) - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 255, 255), 1)
        elif b is not None and np.all(np.isfinite(b)):
            x, y = int(round(b[0])), int(round(b[1]))
            cv2.line(out, (x - 5, y - 5), (x + 5, y + 5), (0, 0, 255), 2)
            cv2.line(out, (x - 5, y + 5), (x + 5, y - 5), (0, 0, 255), 2)
    return out
