"""Marker detection: one camera frame in, the red markers' candidate centres out, for every method.

The detectors behind `whisker.vision.tracking.Tracker` (its module doc describes each method and
docs/tracking.md measures them); `assign` matches candidates to whiskers without identity swaps
(Hungarian method, gated). Pixel coordinates throughout.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

METHODS = ("paper", "contour", "blob", "roi", "fit")

# The authors' HSV thresholds (OpenCV hue 0..180), from their public whiskerTrack.py.
HSV_RED = (((0, 80, 60), (10, 255, 255)), ((170, 80, 60), (180, 255, 255)))
PAPER_KERNEL = 10          # px, the paper's erosion kernel (10x10 ones)
ODD_KERNEL = 5             # px, ellipse for close/open in the better methods
REDNESS_THRESHOLD = 30     # grey levels of redness that count as marker (benchmarks: 30 vs 20/40)
STATUS = ("ok", "lost", "merged", "border", "bad-frame")


@dataclass
class Detections:
    """Full-frame candidates, in tracking pixel coordinates."""
    xy: np.ndarray       # (M, 2)
    area: np.ndarray     # (M,) px^2
    border: np.ndarray   # (M,) bool, touches the image edge

    @staticmethod
    def empty() -> "Detections":
        return Detections(np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool))


def load_calibration(path) -> tuple[np.ndarray, np.ndarray]:
    """(mtx, dist) from a standard-model lens .npz (`whisker.vision.lens.load_lens` reads every model).

    A fisheye file is refused here (its 4 coefficients mean something else to cv2.undistortPoints).
    """
    from whisker.vision.lens import load_lens

    lens = load_lens(path)
    if lens.fisheye:
        raise ValueError(f"calibration file {path} is a fisheye-model lens; read it with whisker.vision.lens.load_lens")
    return lens.mtx, lens.dist


def load_mask(mask, shape=None) -> np.ndarray:
    """A region-of-interest mask as uint8 0/255 (H, W) from a path or an array; nonzero = keep."""
    if isinstance(mask, (str, Path)):
        import cv2

        img = cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"mask {mask} is not a readable image")
        mask = img
    m = np.asarray(mask)
    if m.ndim == 3:
        m = m.max(axis=2)
    if m.ndim != 2 or m.size == 0:
        raise ValueError(f"mask must be a 2-D image, got shape {m.shape}")
    if shape is not None and m.shape != tuple(shape):
        raise ValueError(f"mask is {m.shape[1]}x{m.shape[0]} px but frames are {shape[1]}x{shape[0]} px")
    if not m.any():
        raise ValueError("mask is empty (all zero): nothing would be tracked")
    return np.where(m > 0, 255, 0).astype(np.uint8)


# ---- detectors: image (uint8 BGR) -> Detections -----------------------------------------------

def _hsv_mask(img):
    import cv2

    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    (l1, h1), (l2, h2) = HSV_RED
    return cv2.bitwise_or(cv2.inRange(hsv, l1, h1), cv2.inRange(hsv, l2, h2))


def _contour_detections(binary, shape, area_range=None) -> Detections:
    import cv2

    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    h, w = shape
    xy, area, border = [], [], []
    for c in contours:
        m = cv2.moments(c)
        if m["m00"] <= 0:
            continue
        if area_range is not None and not (area_range[0] <= m["m00"] <= area_range[1] * 3):
            continue
        x, y, bw, bh = cv2.boundingRect(c)
        xy.append((m["m10"] / m["m00"], m["m01"] / m["m00"]))
        area.append(m["m00"])
        border.append(x <= 0 or y <= 0 or x + bw >= w or y + bh >= h)
    if not xy:
        return Detections.empty()
    return Detections(np.array(xy, float), np.array(area, float), np.array(border, bool))


def detect_paper(img, roi_mask=None, **_) -> Detections:
    """The paper: HSV red mask, 10x10 erosion, findContours, centroid from moments."""
    import cv2

    m = _hsv_mask(img)
    if roi_mask is not None:
        m = cv2.bitwise_and(m, roi_mask)
    m = cv2.erode(m, np.ones((PAPER_KERNEL, PAPER_KERNEL), np.uint8))
    return _contour_detections(m, img.shape[:2])


def _ellipse(n):
    import cv2

    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (n, n))


def detect_contour(img, roi_mask=None, area_range=(30.0, 600.0), **_) -> Detections:
    """HSV red mask, close then open with an odd ellipse, area filter, contour moments."""
    import cv2

    m = _hsv_mask(img)
    if roi_mask is not None:
        m = cv2.bitwise_and(m, roi_mask)
    k = _ellipse(ODD_KERNEL)
    m = cv2.morphologyEx(cv2.morphologyEx(m, cv2.MORPH_CLOSE, k), cv2.MORPH_OPEN, k)
    return _contour_detections(m, img.shape[:2], area_range)


def redness(img):
    """R - max(G, B), saturated at 0 (uint8 H x W): how red a pixel is, independent of brightness of grey/white/purple."""
    import cv2

    b, g, r = cv2.split(img)
    return cv2.subtract(r, cv2.max(b, g))


def detect_blob(img, roi_mask=None, area_range=(30.0, 600.0), threshold=REDNESS_THRESHOLD, **_) -> Detections:
    """Redness threshold, 5x5 open, connected components (area, fill and aspect filter), weighted centroids."""
    import cv2

    red = redness(img)
    if roi_mask is not None:
        red = cv2.bitwise_and(red, roi_mask)
    _, binary = cv2.threshold(red, threshold, 255, cv2.THRESH_BINARY)
    binary = cv2.morphologyEx(binary, cv2.MORPH_OPEN, _ellipse(ODD_KERNEL))
    # findContours rather than connectedComponentsWithStats: the same blobs, ~100x faster in OpenCV 5 here
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    h, w = red.shape
    xy, area, border = [], [], []
    lo, hi = area_range
    for c in contours:
        x, y, bw, bh = cv2.boundingRect(c)
        a = cv2.contourArea(c) + 0.5 * cv2.arcLength(c, True)  # ~ pixel count of the blob
        if a < lo or a > 3 * hi or max(bw, bh) > 3 * min(bw, bh) or a < 0.4 * bw * bh:
            continue  # specks, wires and streaks; very large blobs are kept only up to 3x (merges)
        x0, y0 = max(x - 2, 0), max(y - 2, 0)
        x1, y1 = min(x + bw + 2, w), min(y + bh + 2, h)
        crop = img[y0:y1, x0:x1].astype(np.float32)
        wgt = 2 * crop[..., 2] - crop[..., 1] - crop[..., 0] - 2 * threshold  # as the ROI windows
        if roi_mask is not None:
            wgt *= roi_mask[y0:y1, x0:x1] > 0
        np.maximum(wgt, 0, out=wgt)
        mass = float(wgt.sum())
        if mass <= 0:
            continue
        cx = float(wgt.sum(axis=0) @ np.arange(x0, x1)) / mass
        cy = float(wgt.sum(axis=1) @ np.arange(y0, y1)) / mass
        xy.append((cx, cy))
        area.append(a)
        border.append(x <= 0 or y <= 0 or x + bw >= w or y + bh >= h)
    if not xy:
        return Detections.empty()
    return Detections(np.array(xy, float), np.array(area, float), np.array(border, bool))


DETECTORS = {"paper": detect_paper, "contour": detect_contour, "blob": detect_blob, "roi": detect_blob,
             "fit": detect_blob}


def assign(det_xy, ref_xy, gate) -> np.ndarray:
    """Whisker -> detection index (-1 if none) minimising the total distance (Hungarian method).

    ref_xy (N, 2) may contain NaN rows (unknown reference: that whisker takes no detection).
    Pairs farther apart than `gate` are never made.
    """
    from scipy.optimize import linear_sum_assignment

    n = len(ref_xy)
    out = np.full(n, -1, int)
    if len(det_xy) == 0 or n == 0:
        return out
    d = np.hypot(ref_xy[:, None, 0] - det_xy[None, :, 0], ref_xy[:, None, 1] - det_xy[None, :, 1])
    ok = np.isfinite(d) & (d <= gate)
    if not ok.any():
        return out
    cost = np.where(ok, d, gate * 10.0 + 1e3)
    rows, cols = linear_sum_assignment(cost)
    for r, c in zip(rows, cols):
        if ok[r, c]:
            out[r] = c
    return out
