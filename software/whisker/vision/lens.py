"""A lens calibration and the few operations every module needs from it, for both OpenCV lens models.

A calibration is a camera matrix ``mtx`` (3x3, px) and distortion coefficients ``dist`` in one of
two OpenCV models:

``standard``  OpenCV's pinhole model with radial/tangential (k1, k2, p1, p2[, k3[, k4, k5, k6]])
              coefficients: ``cv2.projectPoints`` / ``cv2.undistortPoints``. With 8 coefficients it is
              the *rational* model (``cv2.CALIB_RATIONAL_MODEL``). The authors' calibration_data.npz
              is a standard-model file (5 coefficients) and carries no model name.
``fisheye``   OpenCV's equidistant fisheye model (k1..k4 on theta_d = theta (1 + k1 theta^2 + ...)):
              ``cv2.fisheye.*``. A 160 deg lens is often better described by it.

The .npz written by ``whisker calibrate camera`` holds ``mtx``, ``dist``, ``model`` (one of
``MODELS``), ``image_size`` (width, height px) and ``rms_px`` (held-out reprojection error); files
without ``model`` are read as ``standard``.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

MODELS = ("standard", "rational", "fisheye")


@dataclass(frozen=True)
class Lens:
    """mtx: 3x3 camera matrix (px); dist: distortion coefficients; model: one of MODELS;
    image_size: (width, height) px the calibration was made at, or None if unknown."""
    mtx: np.ndarray
    dist: np.ndarray
    model: str = "standard"
    image_size: tuple[int, int] | None = None

    def __post_init__(self):
        mtx = np.asarray(self.mtx, dtype=float)
        dist = np.asarray(self.dist, dtype=float).ravel()
        if self.model not in MODELS:
            raise ValueError(f"lens model must be one of {', '.join(MODELS)}, got {self.model!r}")
        if mtx.shape != (3, 3) or not np.all(np.isfinite(mtx)) or mtx[0, 0] <= 0 or mtx[1, 1] <= 0:
            raise ValueError("lens mtx must be a finite 3x3 camera matrix with positive focal lengths")
        if not np.all(np.isfinite(dist)):
            raise ValueError("lens dist coefficients must be finite")
        if self.fisheye and dist.size != 4:
            raise ValueError(f"a fisheye lens has 4 distortion coefficients, got {dist.size}")
        if not self.fisheye and dist.size < 4:
            raise ValueError(f"a standard lens has >= 4 distortion coefficients, got {dist.size}")
        object.__setattr__(self, "mtx", mtx)
        object.__setattr__(self, "dist", dist)

    @property
    def fisheye(self) -> bool:
        return self.model == "fisheye"


def as_lens(calibration) -> Lens | None:
    """A Lens from a Lens, a path to an .npz, a (mtx, dist) or (mtx, dist, model) tuple, or None."""
    if calibration is None or isinstance(calibration, Lens):
        return calibration
    if isinstance(calibration, (str, Path)):
        return load_lens(calibration)
    parts = tuple(calibration)
    if len(parts) == 2:
        return Lens(parts[0], parts[1])
    if len(parts) == 3:
        return Lens(parts[0], parts[1], str(parts[2]))
    raise ValueError("calibration must be a path, a Lens, or (mtx, dist[, model])")


def load_lens(path) -> Lens:
    """Read a lens .npz (see module doc); one-line ValueError naming the file and the problem."""
    path = Path(path)
    try:
        with np.load(path) as z:
            mtx = np.asarray(z["mtx"], dtype=float)
            dist = np.asarray(z["dist"], dtype=float).ravel()
            model = str(z["model"]) if "model" in z.files else "standard"
            size = tuple(int(v) for v in np.asarray(z["image_size"]).ravel()) if "image_size" in z.files else None
    except FileNotFoundError:
        raise ValueError(f"calibration file {path} does not exist") from None
    except KeyError as err:
        raise ValueError(f"calibration file {path} has no array {err}; it needs 'mtx' and 'dist'") from None
    except Exception as err:  # zipfile/pickle errors: not an npz
        raise ValueError(f"calibration file {path} is not a readable .npz ({type(err).__name__})") from None
    try:
        return Lens(mtx, dist, model, size if size and len(size) == 2 and min(size) > 0 else None)
    except ValueError as err:
        raise ValueError(f"calibration file {path}: {err}") from None


def lens_bytes(lens: Lens, **extra) -> bytes:
    """The .npz bytes of `lens` plus `extra` arrays (rms_px, views ...); write with whisker.files."""
    buf = io.BytesIO()
    size = np.asarray(lens.image_size if lens.image_size else (0, 0), dtype=int)
    np.savez(buf, mtx=lens.mtx, dist=lens.dist, model=np.array(lens.model), image_size=size,
             **{k: np.asarray(v) for k, v in extra.items()})
    return buf.getvalue()


def project(lens: Lens, obj_xyz, rvec, tvec) -> np.ndarray:
    """Pixels (M, 2) of object points (M, 3) seen with pose (rvec, tvec), through the lens model."""
    import cv2

    obj = np.asarray(obj_xyz, dtype=np.float64).reshape(-1, 1, 3)
    rvec = np.asarray(rvec, dtype=np.float64).reshape(3, 1)
    tvec = np.asarray(tvec, dtype=np.float64).reshape(3, 1)
    if lens.fisheye:
        uv, _ = cv2.fisheye.projectPoints(obj, rvec, tvec, lens.mtx, lens.dist)
    else:
        uv, _ = cv2.projectPoints(obj, rvec, tvec, lens.mtx, lens.dist)
    return uv.reshape(-1, 2)


def undistort_points(lens: Lens, xy, P=None) -> np.ndarray:
    """Distorted pixels (M, 2) -> ideal pinhole pixels with matrix P (normalized coordinates if None)."""
    import cv2

    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 1, 2)
    if len(pts) == 0:
        return np.zeros((0, 2))
    if lens.fisheye:
        out = cv2.fisheye.undistortPoints(pts, lens.mtx, lens.dist, P=P)
    else:
        out = cv2.undistortPoints(pts, lens.mtx, lens.dist, P=P)
    return out.reshape(-1, 2)


def undistort_maps(lens: Lens, size_wh, P=None):
    """cv2.remap maps (CV_16SC2) that undistort a (width, height) frame onto the pinhole with matrix P."""
    import cv2

    P = lens.mtx if P is None else P
    if lens.fisheye:
        return cv2.fisheye.initUndistortRectifyMap(lens.mtx, lens.dist, np.eye(3), P, tuple(size_wh), cv2.CV_16SC2)
    return cv2.initUndistortRectifyMap(lens.mtx, lens.dist, None, P, tuple(size_wh), cv2.CV_16SC2)


def undistort_image(lens: Lens, img, P=None):
    """The frame `img` remapped onto the ideal pinhole with matrix P (default: the lens's own mtx)."""
    import cv2

    h, w = img.shape[:2]
    m1, m2 = undistort_maps(lens, (w, h), P)
    return cv2.remap(img, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


def field_of_view_deg(lens: Lens, size_wh) -> dict:
    """Horizontal, vertical and diagonal field of view (deg) of a (width, height) frame: the angles
    between the rays through opposite image edges (centre row/column) and corners."""
    w, h = size_wh
    cx, cy = lens.mtx[0, 2], lens.mtx[1, 2]
    pairs = {"horizontal": ((-0.5, cy), (w - 0.5, cy)), "vertical": ((cx, -0.5), (cx, h - 0.5)),
             "diagonal": ((-0.5, -0.5), (w - 0.5, h - 0.5))}
    out = {}
    for name, (a, b) in pairs.items():
        n = undistort_points(lens, np.array([a, b]))
        rays = np.column_stack([n, np.ones(2)])
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        out[name] = float(np.degrees(np.arccos(np.clip(rays[0] @ rays[1], -1.0, 1.0))))
    return out
