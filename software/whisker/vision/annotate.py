"""The paper's drawing of a tracked frame: rest and current marker centres with arrows (`whisker track
--show`, `whisker live`)."""

from __future__ import annotations


def annotate(image, result, baseline_xy):
    """The paper's drawing: rest centres (white), current centres, yellow arrows; lost markers red.
    Every whisker is labelled with its index (a lost one in red at its rest centre).

    Drawn in the tracked frame's coordinates (raw frame unless --undistort image)."""
    import cv2
    import numpy as np

    out = image.copy() if image is not None else None
    if out is None or out.ndim != 3:
        return None
    pos = result.track_px if result.track_px is not None else result.positions_px
    h, w = out.shape[:2]
    ref = np.asarray(baseline_xy, float) if baseline_xy is not None else np.asarray(pos, float)
    centre = np.nanmean(ref, axis=0) if np.any(np.isfinite(ref)) else np.array([w / 2, h / 2])

    def label(i, at, colour):
        """Every whisker's index, outside its marker (radially away from the ring's centre), inside the image."""
        v = np.asarray(at, float) - centre
        v = v / (np.hypot(*v) or 1.0)
        x = int(np.clip(at[0] + 16 * v[0] - 4, 2, w - 12))
        y = int(np.clip(at[1] + 16 * v[1] + 4, 12, h - 3))
        cv2.putText(out, str(i), (x, y), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(out, str(i), (x, y), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv2.LINE_AA)

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
            label(i, p, (0, 255, 255))
        elif b is not None and np.all(np.isfinite(b)):
            x, y = int(round(b[0])), int(round(b[1]))
            cv2.line(out, (x - 5, y - 5), (x + 5, y + 5), (0, 0, 255), 2)
            cv2.line(out, (x - 5, y + 5), (x + 5, y - 5), (0, 0, 255), 2)
            label(i, b, (0, 0, 255))
    return out
