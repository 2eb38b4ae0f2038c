"""Marker tracking: the paper's pipeline and faster, more exact ones, with identities that never swap.

The detectors themselves live in `whisker.vision.markers` and the subpixel window centroid and disc
fit of ``roi`` and ``fit`` in `whisker.vision.subpixel`; this module holds the tracker that identifies,
follows and refines them frame to frame.

Methods (all return one position per whisker; see docs/tracking.md for measured accuracy and speed):

``paper``    exactly the paper's pipeline: BGR -> HSV, red mask (the authors' thresholds
             H 0-10 or 170-180, S >= 80, V >= 60, from their public code), erosion with a 10x10
             kernel of ones, ``cv2.findContours``, centroid from ``cv2.moments``. The even kernel
             shifts every centroid by half a pixel in x and y (cancels in displacements) and the
             erosion removes most of a ~13 px marker, so noise splits or deletes markers.
``contour``  the same HSV mask, then close-then-open with an odd 5x5 ellipse (no shift; removes wires
             up to 4 px wide), an area filter, contour moments.
``blob``     full-frame "redness" R - max(G, B) (cv2 saturating ops), threshold, 5x5 open, connected
             components with an area/shape filter, then the intensity-weighted centroid of the
             redness above the threshold (subpixel, uses every grey level, not a binary shape).
``roi``      the blob centroid computed only in a small window around each marker's last position
             (all windows in one numpy gather, re-centred once if the marker moved); a whisker whose
             window fails (lost, merged, at the border) falls back to a full-frame ``blob`` search.
``fit``      ``roi``, then a least-squares fit of a blurred disc to each marker (2 Gauss-Newton steps,
             all markers at once): the most exact and the slowest of the subpixel methods.

Identity: whisker i is the marker nearest the design's projected rest position of whisker i
(`whisker.vision.geometry.project`, so the mirror of the up-looking camera and tracking.image_up_deg are
taken into account), refined by the median offset of the ring. Frame to frame, detections are
matched to the previous positions (or the rest baseline) with the Hungarian method
(`scipy.optimize.linear_sum_assignment`) and a distance gate below half the marker spacing, so a
marker can never take over a neighbour's identity: it is flagged invalid instead.

Per-whisker status: ``ok``, ``lost`` (nothing within the gate), ``merged`` (one blob where two
markers should be, or two whiskers on one spot), ``border`` (touches the image edge: centroid
truncated), ``bad-frame`` (the frame itself is unusable; `TrackResult.message` says why).
`Tracker.track` never raises on a bad frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker.vision import geometry
from whisker.vision.markers import DETECTORS, METHODS, REDNESS_THRESHOLD, Detections, assign, load_mask
from whisker.vision.subpixel import MarkerWindows

class CalibrationError(ValueError):
    """The rest frames do not show every marker often enough; one line naming the whiskers."""


@dataclass
class TrackResult:
    """One frame. positions_px: (N, 2) marker centres (undistorted if a calibration is used), NaN
    where invalid; valid: (N,) bool; status: per whisker (see module doc); dx_px, dy_px: (N,)
    displacement from the rest baseline (NaN when invalid or not calibrated); message: why a whole
    frame was refused ('' otherwise)."""
    positions_px: np.ndarray
    valid: np.ndarray
    status: list
    dx_px: np.ndarray
    dy_px: np.ndarray
    method: str
    message: str = ""
    detections: int = 0
    track_px: np.ndarray | None = None  # positions in the coordinates of the tracked (raw or remapped) frame
    fit_refused: int = 0                # 'fit' method: valid markers whose disc fit was refused (kept their centroid)

    @property
    def all_valid(self) -> bool:
        return bool(np.all(self.valid))


# ---- the tracker ---------------------------------------------------------------------------------

@dataclass
class _Baseline:
    track_xy: np.ndarray   # (N, 2) rest positions in tracking coordinates
    out_xy: np.ndarray     # (N, 2) rest positions in output (undistorted) coordinates
    area: np.ndarray       # (N,) blob area at rest, px^2
    frames: int


class Tracker:
    """Track the N markers of a design in camera frames.

    design: the Design (whisker count, ring, camera, tracking section). method: one of METHODS.
    calibration: a lens for undistortion: a path to a lens .npz (`whisker calibrate camera`'s or the
    authors'), a `whisker.vision.lens.Lens`, or a (mtx, dist[, model]) tuple; standard, rational and
    fisheye models. undistort: "points" (track on the raw frame, undistort the centroids with
    cv2.undistortPoints: exact and cheap) or "image" (remap every frame first, as the authors' code
    does). mask: region-of-interest image (path or array), nonzero = track here. k_source: "design"
    (k = design.mm_per_px) or "ring" (k = ring radius / measured rest radius, after calibrate()).
    marker_radius_px: the markers' radius in the frame, px, as the blob detectors see it (equivalent
    radius of the thresholded blob; measured on a rest frame with `whisker.vision.rest_geometry.measure`);
    default: the design's marker diameter / 2 / mm_per_px. edge_radius_px: the radius of the marker's
    half-contrast edge (the disc fit's model, where `fit` starts); default: marker_radius_px.
    """

    def __init__(self, design, method: str = "roi", *, calibration=None, undistort: str = "points",
                 mask=None, k_source: str = "design", threshold: int = REDNESS_THRESHOLD,
                 marker_radius_px: float | None = None, edge_radius_px: float | None = None):
        if method not in METHODS:
            raise ValueError(f"unknown tracking method {method!r}; choose one of {', '.join(METHODS)}")
        if undistort not in ("points", "image"):
            raise ValueError(f"undistort must be 'points' or 'image', got {undistort!r}")
        if k_source not in ("design", "ring"):
            raise ValueError(f"k_source must be 'design' or 'ring', got {k_source!r}")
        if not 1 <= int(threshold) <= 254:
            raise ValueError(f"threshold must be 1..254 grey levels, got {threshold}")
        self.design = design
        self.method = method
        self.n = design.whiskers.count
        self.threshold = int(threshold)
        self.k_source = k_source
        from whisker.vision.lens import as_lens

        self.lens = as_lens(calibration)   # any lens model (whisker.vision.lens): standard, rational, fisheye
        self.mtx = None if self.lens is None else geometry.camera_matrix(design, self.lens.mtx)
        self.dist = None if self.lens is None else self.lens.dist
        self.undistort = undistort if self.dist is not None else "none"
        self.mask = None if mask is None else load_mask(mask)
        self.shape = self.mask.shape if self.mask is not None else (design.camera.height_px, design.camera.width_px)
        self._maps = None
        k = design.mm_per_px
        if marker_radius_px is not None and not (math.isfinite(marker_radius_px) and 1.0 <= marker_radius_px <= 100.0):
            raise ValueError(f"marker_radius_px must be 1..100 px, got {marker_radius_px}")
        # the marker's radius in the frame: measured (whisker.vision.rest_geometry) or the design's
        self.marker_r = design.coil.marker_diameter / 2.0 / k if marker_radius_px is None else float(marker_radius_px)
        if edge_radius_px is not None and not (math.isfinite(edge_radius_px) and 0.5 <= edge_radius_px <= 100.0):
            raise ValueError(f"edge_radius_px must be 0.5..100 px, got {edge_radius_px}")
        edge_r = self.marker_r if edge_radius_px is None else float(edge_radius_px)   # disc fit's start
        a0 = math.pi * self.marker_r ** 2
        self.area_range = (0.25 * a0, 4.0 * a0)
        # predicted rest positions in tracking coordinates (distorted unless frames are remapped)
        xyz = geometry.rest_marker_xyz(design)
        dist = self.dist if self.undistort == "points" else None
        self.predicted = geometry.project(design, xyz, mtx=self.mtx, dist=dist,
                                          model=self.lens.model if self.lens is not None else "standard")
        if self.n > 1:
            dd = np.hypot(*(self.predicted[:, None, :] - self.predicted[None, :, :]).transpose(2, 0, 1))
            self.spacing = float(np.min(dd[~np.eye(self.n, dtype=bool)]))
        else:
            self.spacing = float("inf")
        self.gate = min(design.tracking.marker_search_px, 0.45 * self.spacing)
        self.windows = MarkerWindows(self.marker_r, edge_r, self.threshold)   # the roi / fit methods' windows
        self._merge_d2 = (2 * self.marker_r) ** 2
        self._diag = np.eye(self.n, dtype=bool)
        self._area0 = self._design_area()
        self.baseline: _Baseline | None = None
        self._last = np.full((self.n, 2), np.nan)

    # -- coordinates ---------------------------------------------------------------------------
    def _prepare(self, img):
        if self.undistort == "image":
            import cv2

            if self._maps is None:
                from whisker.vision.lens import undistort_maps

                h, w = img.shape[:2]
                self._maps = undistort_maps(self.lens, (w, h), self.mtx)
            if self.mask is not None:
                img = cv2.bitwise_and(img, img, mask=self.mask)
            return cv2.remap(img, *self._maps, cv2.INTER_LINEAR), None
        return img, self.mask

    def to_output(self, xy) -> np.ndarray:
        """Tracking coordinates -> output pixel coordinates (undistorted when points are undistorted)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if self.undistort != "points" or len(xy) == 0:
            return xy.copy()
        from whisker.vision.lens import undistort_points

        out = np.full_like(xy, np.nan)
        ok = np.all(np.isfinite(xy), axis=1)
        if ok.any():
            out[ok] = undistort_points(self.lens, xy[ok], P=self.mtx)
        return out

    @property
    def k(self) -> float:
        """mm per pixel used for geometry: the design's, or measured from the rest ring."""
        if self.k_source == "ring" and self.baseline is not None:
            b = self.baseline.out_xy
            r = np.hypot(*(b - b.mean(axis=0)).T)
            return self.design.whiskers.ring_radius / float(np.mean(r))
        return self.design.mm_per_px

    # -- frame checks ----------------------------------------------------------------------------
    def check_frame(self, image) -> str:
        """'' if `image` can be tracked, else one line saying what is wrong with it."""
        if image is None:
            return "frame is None (no image was read)"
        if not isinstance(image, np.ndarray):
            return f"frame is a {type(image).__name__}, not a numpy array"
        if image.size == 0:
            return f"frame is empty (shape {image.shape})"
        if image.dtype != np.uint8:
            return f"frame dtype is {image.dtype}, expected uint8"
        if image.ndim != 3 or image.shape[2] != 3:
            return f"frame shape is {image.shape}, expected (H, W, 3) BGR"
        if self.mask is not None or self.baseline is not None:
            if image.shape[:2] != tuple(self.shape):
                return f"frame is {image.shape[1]}x{image.shape[0]} px, expected {self.shape[1]}x{self.shape[0]}"
        elif min(image.shape[:2]) < 16:
            return f"frame is only {image.shape[1]}x{image.shape[0]} px"
        return ""

    def _bad(self, message: str) -> TrackResult:
        nan = np.full(self.n, np.nan)
        return TrackResult(np.full((self.n, 2), np.nan), np.zeros(self.n, bool), ["bad-frame"] * self.n,
                           nan, nan.copy(), self.method, message)

    # -- detection + identity ----------------------------------------------------------------------
    def detect(self, image) -> Detections:
        """Full-frame candidates with this tracker's method (the 'roi' method uses 'blob' here)."""
        img, mask = self._prepare(image)
        return DETECTORS[self.method](img, roi_mask=mask, area_range=self.area_range, threshold=self.threshold)

    def _identify(self, det: Detections, ref, area_ref):
        """Assign detections to whiskers; returns raw positions (N,2) and statuses."""
        pos = np.full((self.n, 2), np.nan)
        status = ["lost"] * self.n
        idx = assign(det.xy, ref, self.gate)
        counts = np.bincount(idx[idx >= 0], minlength=max(len(det.xy), 1))
        for i, j in enumerate(idx):
            if j < 0:
                continue
            if det.border[j]:
                status[i] = "border"
            elif det.area[j] > 1.6 * area_ref[i] or counts[j] > 1:
                status[i] = "merged"
            else:
                pos[i] = det.xy[j]
                status[i] = "ok"
        # a whisker with no detection of its own next to an oversized blob that another whisker
        # took: one blob where two markers should be -> both merged
        lost = [i for i in range(self.n) if status[i] == "lost" and np.all(np.isfinite(ref[i]))]
        if lost and len(det.xy):
            owner = np.full(len(det.xy), -1)
            owner[idx[idx >= 0]] = np.flatnonzero(idx >= 0)
            own_area = np.where(owner >= 0, area_ref[np.maximum(owner, 0)], np.nanmedian(area_ref))
            big = det.area > 1.2 * own_area
            for i in lost:
                near = big & (np.hypot(det.xy[:, 0] - ref[i, 0], det.xy[:, 1] - ref[i, 1]) < 2.5 * self.marker_r)
                for j in np.flatnonzero(near):
                    status[i] = "merged"
                    if owner[j] >= 0:
                        status[owner[j]] = "merged"
        for i in range(self.n):
            if status[i] == "merged":
                pos[i] = np.nan
        return pos, status

    def _initial_refs(self, det: Detections):
        """Design prediction, shifted by the ring's median offset (the camera is never exactly centred)."""
        ref = self.predicted.copy()
        idx = assign(det.xy, ref, 0.45 * self.spacing)
        if (idx >= 0).sum() >= max(1, self.n // 2):
            ref = ref + np.median(det.xy[idx[idx >= 0]] - ref[idx >= 0], axis=0)
        return ref

    def _design_area(self):
        return np.full(self.n, math.pi * self.marker_r ** 2 * 1.5)

    # -- calibration ---------------------------------------------------------------------------------
    def calibrate(self, frames) -> _Baseline:
        """Rest baseline: per-whisker median position over K rest frames (images or Frame objects).

        Raises CalibrationError (one line) if a whisker is found in fewer than half of the frames.
        """
        track, areas, n_frames, shape = [], [], 0, None
        for f in frames:
            img = getattr(f, "image", f)
            msg = self.check_frame(img)
            if msg:
                continue
            shape = img.shape[:2]
            n_frames += 1
            det = self.detect(img)
            pos, status = self._identify(det, self._initial_refs(det), self._design_area())
            area = np.full(self.n, np.nan)
            idx = assign(det.xy, pos, 1.0)
            area[idx >= 0] = det.area[idx[idx >= 0]]
            pos = self._zero_with_method(img, pos)
            track.append(pos)
            areas.append(area)
        if n_frames == 0:
            raise CalibrationError("calibration: no usable rest frame (every frame was empty or malformed)")
        track = np.array(track)
        found = np.sum(np.all(np.isfinite(track), axis=2), axis=0)
        bad = [i for i in range(self.n) if found[i] * 2 < n_frames or found[i] == 0]
        if bad:
            raise CalibrationError(
                f"calibration: whisker(s) {bad} found in fewer than half of the {n_frames} rest frame(s) "
                f"(found {found.tolist()}); check the light, the mask, the method and tracking.image_up_deg")
        with np.errstate(all="ignore"):
            base = np.nanmedian(track, axis=0)
            area = np.nanmedian(np.array(areas), axis=0)
        area = np.where(np.isfinite(area), area, self._design_area())
        self.shape = shape
        self.baseline = _Baseline(base, self.to_output(base), area, n_frames)
        self._last = base.copy()
        return self.baseline

    def _zero_with_method(self, image, pos):
        """Rest positions located as `track` locates frames: the ``roi`` window centroid (and the
        ``fit`` disc fit) started at the detector's positions. The detector's centroid (redness
        R - max(G, B)) differs from the window's (2R - G - B) and the fit's by up to ~0.01 px, an
        offset that would stay in every displacement (issue 31: ~1e-4 rad of absolute tilt)."""
        if self.method not in ("roi", "fit"):
            return pos
        img, mask = self._prepare(image)
        ok = np.all(np.isfinite(pos), axis=1)
        if not ok.any():
            return pos
        out = pos.copy()
        rpos, rok, _ = self.windows.roi(img, mask, pos[ok])
        sub = pos[ok]
        moved = rok & (np.hypot(*(rpos - sub).T) < 1.0)   # the window found the same marker
        sub[moved] = rpos[moved]
        if self.method == "fit":
            sub[moved] = self.windows.refine(img, mask, sub[moved]) if moved.any() else sub[moved]
        out[ok] = sub
        return out

    def reset(self) -> None:
        """Forget the frame-to-frame state (the next frame is matched against the rest baseline)."""
        self._last = self.baseline.track_xy.copy() if self.baseline is not None else np.full((self.n, 2), np.nan)

    # -- tracking --------------------------------------------------------------------------------------
    def _refs(self):
        ref = self._last.copy()
        if self.baseline is not None:
            miss = np.isnan(ref).any(axis=1)
            if miss.any():
                ref[miss] = self.baseline.track_xy[miss]
        return ref

    def track(self, image) -> TrackResult:
        """Positions, validity and displacements of every marker in one frame. Never raises on bad frames."""
        msg = self.check_frame(image)
        if msg:
            return self._bad(msg)
        img, mask = self._prepare(image)
        ref = self._refs()
        area_ref = self.baseline.area if self.baseline is not None else self._area0
        pos = np.full((self.n, 2), np.nan)
        status = ["lost"] * self.n
        ndet = 0
        if self.method in ("roi", "fit") and not np.isnan(ref).any():
            rpos, rok, mass = self.windows.roi(img, mask, ref)
            # a marker of normal size has mass ~ area * (contrast - threshold); compare to the others
            good = sorted(mass[rok].tolist())
            if len(good) >= 2:
                med = good[len(good) // 2]
                rok &= (mass > 0.3 * med) & (mass < 1.7 * med)
            pos[rok] = rpos[rok]
            status = ["ok" if f else "lost" for f in rok.tolist()]
            # two whiskers on one spot: both merged
            diff = pos[:, None, :] - pos[None, :, :]
            close = (diff[..., 0] ** 2 + diff[..., 1] ** 2) < self._merge_d2
            close[self._diag] = False
            if close.any():
                for i in np.flatnonzero(close.any(axis=1)):
                    status[i] = "merged"
                    pos[i] = np.nan
            need = [i for i in range(self.n) if status[i] != "ok"]
            if need:
                det = DETECTORS["blob"](img, roi_mask=mask, area_range=self.area_range, threshold=self.threshold)
                ndet = len(det.xy)
                sub_ref = ref.copy()
                sub_ref[[i for i in range(self.n) if i not in need]] = np.nan
                # detections already explained by a tracked marker are not available
                if len(det.xy):
                    taken = np.zeros(len(det.xy), bool)
                    for i in range(self.n):
                        if status[i] == "ok":
                            taken |= np.hypot(*(det.xy - pos[i]).T) < 2 * self.marker_r
                    keep = ~taken
                    det = Detections(det.xy[keep], det.area[keep], det.border[keep])
                p2, s2 = self._identify(det, sub_ref, area_ref)
                for i in need:
                    if status[i] == "merged" and s2[i] == "lost":
                        continue
                    pos[i], status[i] = p2[i], s2[i]
        else:
            det = DETECTORS[self.method](img, roi_mask=mask, area_range=self.area_range, threshold=self.threshold)
            ndet = len(det.xy)
            if not np.all(np.isfinite(ref)):
                ref = np.where(np.isfinite(ref), ref, self._initial_refs(det))
            pos, status = self._identify(det, ref, area_ref)
        valid = np.array([s == "ok" for s in status]) & ~np.isnan(pos).any(axis=1)
        refused = 0
        if self.method == "fit" and valid.any():
            pos[valid] = self.windows.refine(img, mask, pos[valid])
            refused = int(np.sum(~self.windows.last_fit[1]))
        self._last[valid] = pos[valid]
        out = self.to_output(pos)
        out[~valid] = np.nan
        if self.baseline is not None:
            d = out - self.baseline.out_xy
            dx, dy = d[:, 0], d[:, 1]
        else:
            dx = dy = np.full(self.n, np.nan)
        track_px = pos.copy()
        track_px[~valid] = np.nan
        return TrackResult(out, valid, status, dx, dy, self.method, "", ndet, track_px, refused)

    def deflection(self, result: TrackResult, model: str = "paper"):
        """Geometry of a TrackResult: `whisker.vision.geometry.deflection` with this tracker's k."""
        return geometry.deflection(self.design, result.dx_px, result.dy_px, model=model,
                                   whisker=np.arange(self.n), k=self.k, mtx=self.mtx)
