"""What a rest frame says about the camera: image orientation, marker radius and ring scale, in px.

``measure(design, image)`` finds the N markers without the design's orientation (blob candidates of
marker size lying on a ring around the principal point), fits a circle to their (undistorted)
centres, and reads:

* ``image_up_deg``: the sensor direction at the top of the image (whisker.vision.geometry's convention: a
  sensor direction phi appears at the image angle phi - image_up - 90 deg). The ring is symmetric
  under a turn of 360/N deg, so the orientation is known modulo 360/N; the value nearest the design's
  ``tracking.image_up_deg`` is reported (it is the mean over the markers, circular with period 360/N);
* ``marker_radius_px``: the median equivalent radius sqrt(area / pi) of the markers' thresholded
  blobs (what the tracker's windows and area checks use, and what the design's marker_diameter was
  calibrated as), and ``edge_radius_px``: the median radius of a blurred-disc fit to every marker
  (the ``fit`` tracker's model, whisker.vision.subpixel: the half-contrast edge, on the raw frame). The authors' markers
  have soft edges, so the edge radius is well below the blob radius there;
* ``ring_radius_px`` and ``mm_per_px`` = whiskers.ring_radius / ring_radius_px, at the marker plane
  (undistorted pixels when a lens calibration is given).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np


class RestGeometryError(ValueError):
    """The rest frame does not show the N markers on a ring; one line."""


@dataclass(frozen=True)
class RestGeometry:
    image_up_deg: float
    image_up_design_deg: float
    marker_radius_px: float
    marker_radius_design_px: float
    edge_radius_px: float
    ring_radius_px: float
    mm_per_px: float
    mm_per_px_design: float
    centre_px: tuple
    orientation_spread_deg: float    # RMS of the per-marker orientation about the mean

    def to_dict(self) -> dict:
        return asdict(self)

    def lines(self) -> list[str]:
        return [f"image_up_deg {self.image_up_deg:.2f} (design {self.image_up_design_deg:g}, "
                f"{self.image_up_deg - self.image_up_design_deg:+.2f} deg; markers scatter {self.orientation_spread_deg:.2f} deg)",
                f"marker radius {self.marker_radius_px:.2f} px (design {self.marker_radius_design_px:.2f} px, "
                f"{100 * (self.marker_radius_px / self.marker_radius_design_px - 1):+.1f} %); half-contrast edge "
                f"radius {self.edge_radius_px:.2f} px",
                f"ring radius {self.ring_radius_px:.2f} px -> {self.mm_per_px:.5f} mm/px (design {self.mm_per_px_design:.5f}, "
                f"{100 * (self.mm_per_px / self.mm_per_px_design - 1):+.2f} %)"]


def _circle(xy) -> tuple[np.ndarray, float]:
    """Least-squares circle (Kasa): centre (2,), radius."""
    A = np.column_stack([2 * xy, np.ones(len(xy))])
    b = np.sum(xy * xy, axis=1)
    (cx, cy, c), *_ = np.linalg.lstsq(A, b, rcond=None)
    return np.array([cx, cy]), float(math.sqrt(max(c + cx * cx + cy * cy, 0.0)))


def measure(design, image, calibration=None, mask=None) -> RestGeometry:
    """Measure the rest frame `image` (BGR uint8); see the module doc."""
    from whisker.vision.subpixel import MarkerWindows
    from whisker.vision.tracking import Tracker

    n = design.whiskers.count
    trk = Tracker(design, "fit", calibration=calibration, mask=mask)
    why = trk.check_frame(image)
    if why:
        raise RestGeometryError(f"rest frame: {why}")
    det = trk.detect(image)
    a0 = math.pi * trk.marker_r ** 2
    keep = (det.area > 0.3 * a0) & (det.area < 3.0 * a0) & ~det.border
    xy, area = det.xy[keep], det.area[keep]
    if len(xy) < n:
        raise RestGeometryError(f"rest frame: {len(xy)} marker-sized red blobs, the design has {n} markers "
                                "(light, mask or marker colour)")
    K = trk.mtx if trk.mtx is not None else None
    centre0 = np.array([K[0, 2], K[1, 2]]) if K is not None else np.array([(image.shape[1] - 1) / 2,
                                                                             (image.shape[0] - 1) / 2])
    r0 = design.whiskers.ring_radius / design.mm_per_px
    out = trk.to_output(xy)
    rad = np.hypot(*(out - centre0).T)
    near = np.abs(rad - r0) < 0.4 * r0
    if near.sum() < n:
        raise RestGeometryError(f"rest frame: only {int(near.sum())} marker-sized blobs within 40 % of the design's "
                                f"ring radius ({r0:.0f} px) of the image centre; {n} needed")
    idx = np.flatnonzero(near)
    if len(idx) > n:   # the N blobs of the most similar size
        med = np.median(area[idx])
        idx = idx[np.argsort(np.abs(area[idx] - med))[:n]]
    pts_raw, pts = xy[idx], out[idx]
    centre, ring_r = _circle(pts)
    # orientation: phi - beta - 90 = screen angle, modulo the spacing s
    s = 360.0 / n
    ang = np.degrees(np.arctan2(pts[:, 1] - centre[1], pts[:, 0] - centre[0]))
    phi0 = design.whiskers.first_angle_deg
    beta_k = (phi0 - 90.0 - ang - design.tracking.image_up_deg)   # offsets from the design's value
    z = np.exp(2j * np.pi * beta_k / s)
    off = s * np.angle(z.mean()) / (2 * np.pi)
    spread = float(np.sqrt(np.mean(((beta_k - off + s / 2) % s - s / 2) ** 2)))
    beta = design.tracking.image_up_deg + off
    # marker radius: disc fit on the raw frame at every marker
    img, m = trk._prepare(image)
    # the fit starts between the blob radius and a soft edge
    fit = MarkerWindows(trk.marker_r, trk.marker_r * 0.75, trk.threshold)
    fit.refine(img, m, pts_raw.copy(), iters=6)
    rho, accepted = fit.last_fit
    if accepted.sum() < max(1, n // 2):
        raise RestGeometryError(f"rest frame: the disc fit was refused at {int((~accepted).sum())} of {n} markers; "
                                "the marker radius cannot be measured (blur, markers not round?)")
    r_edge = float(np.median(rho[accepted]))
    r_blob = float(np.median(np.sqrt(area[idx] / math.pi)))
    return RestGeometry(float(beta), float(design.tracking.image_up_deg), r_blob,
                        float(design.coil.marker_diameter / 2 / design.mm_per_px), r_edge, ring_r,
                        float(design.whiskers.ring_radius / ring_r), float(design.mm_per_px),
                        (float(centre[0]), float(centre[1])), spread)
