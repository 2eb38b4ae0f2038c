"""Camera model and whisker geometry: pure, vectorised functions (numpy in, numpy out).

Frames (all lengths mm, angles deg):

* sensor frame: z = 0 on the membrane's lower face, z up, whisker ``i`` at
  ``design.whisker_angles_deg[i]`` counter-clockwise from +x *seen from above*;
* camera: on the sensor axis at ``design.camera_z``, looking UP (+z); pinhole with focal length
  ``design.camera.focal_length_px`` and principal point at the image centre unless a measured
  camera matrix ``mtx`` is given; the sensor direction ``design.tracking.image_up_deg`` appears at
  the top of the image (towards -v).
* image: u to the right, v down, pixel centres at integer coordinates (OpenCV's convention).

Because the camera looks up from below, the image is a MIRROR of the top view: whisker indices,
counter-clockwise from above, run clockwise around the ring on screen. With the camera rotation
``beta = image_up_deg`` a sensor direction ``phi`` appears at the image angle
``atan2(v, u) = phi - beta - 90 deg`` (angle measured from +u towards +v, i.e. clockwise on screen).

Whisker deflection (the paper, section "Whisker Tracking"; k = mm per pixel at the marker plane,
l_u = pivot to tip, l_l = pivot to the tracked marker, p = marker displacement in px)::

    theta = arcsin(k * |p| / l_l)
    x_tip = -(l_u / l_l) * k * p_x      y_tip = -(l_u / l_l) * k * p_y      z_tip = l_u * cos(theta)

`deflection(..., model="paper")` evaluates exactly these (with p rotated from image axes into
the sensor frame, so x_tip, y_tip are sensor-frame millimetres). `model="exact"` drops the paper's
two approximations (constant k, marker moving in its rest plane): it intersects the camera ray
through the marker's pixel with the sphere of radius l_l about the whisker's pivot (the marker of
a rigid rod rotating about the pivot lies on that sphere) and reads theta and the tip from the
intersection. Both are closed-form; `benchmarks/bench_tracking.py` measures what the difference is.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


# ---- camera model ------------------------------------------------------------------------------

def camera_rotation(design) -> np.ndarray:
    """3x3 rotation taking sensor-frame vectors to camera-frame vectors (rows: X_c, Y_c, Z_c).

    X_c = image right (+u), Y_c = image down (+v), Z_c = optical axis = sensor +z. With
    beta = image_up_deg: Y_c = -(cos beta, sin beta, 0) and X_c = Y_c x Z_c = (-sin beta, cos beta, 0).
    """
    b = math.radians(design.tracking.image_up_deg)
    return np.array([[-math.sin(b), math.cos(b), 0.0],
                     [-math.cos(b), -math.sin(b), 0.0],
                     [0.0, 0.0, 1.0]])


def camera_matrix(design, mtx=None) -> np.ndarray:
    """3x3 intrinsic matrix: the measured `mtx` if given, else the design's pinhole (f, image centre)."""
    if mtx is not None:
        m = np.asarray(mtx, dtype=float)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)) or m[0, 0] <= 0 or m[1, 1] <= 0:
            raise ValueError(f"camera matrix mtx must be a finite 3x3 with positive focal lengths, got {m.tolist()}")
        return m
    c = design.camera
    return np.array([[c.focal_length_px, 0.0, (c.width_px - 1) / 2.0],
                     [0.0, c.focal_length_px, (c.height_px - 1) / 2.0],
                     [0.0, 0.0, 1.0]])


def rest_marker_xyz(design) -> np.ndarray:
    """(N, 3) marker centres at rest in the sensor frame, mm."""
    a = np.radians(design.whisker_angles_deg)
    r = design.whiskers.ring_radius
    return np.stack([r * np.cos(a), r * np.sin(a), np.full_like(a, design.marker_z)], axis=1)


def pivot_xyz(design) -> np.ndarray:
    """(N, 3) whisker pivots (membrane mid-plane on the ring), mm."""
    p = rest_marker_xyz(design)
    p[:, 2] = design.pivot_z
    return p


def tilted_marker_xyz(design, tilt_deg, azimuth_deg=None) -> np.ndarray:
    """(N, 3) marker centres of rods rotated rigidly about their pivots, mm.

    tilt_deg: (N,) or scalar tilt from vertical, deg. azimuth_deg: direction the TIP moves
    (CCW from +x, top view); default = towards the ring centre (retraction, the actuated grasp),
    so positive tilts move the markers radially outward.
    """
    n = design.whiskers.count
    t = np.radians(np.broadcast_to(np.asarray(tilt_deg, dtype=float), (n,)))
    if azimuth_deg is None:
        az = np.radians(np.asarray(design.whisker_angles_deg)) + np.pi
    else:
        az = np.radians(np.broadcast_to(np.asarray(azimuth_deg, dtype=float), (n,)))
    axis = np.stack([np.sin(t) * np.cos(az), np.sin(t) * np.sin(az), np.cos(t)], axis=1)
    return pivot_xyz(design) - design.l_l * axis


def project(design, xyz_mm, mtx=None, dist=None, model: str = "standard") -> np.ndarray:
    """Pixel coordinates (M, 2) of sensor-frame points (M, 3) mm through the design's camera.

    Pinhole: p_c = R (p - C), (u, v) = K (p_c / z_c). With `dist` the lens distortion of `model`
    (whisker.vision.lens: "standard"/"rational" = OpenCV's k1, k2, p1, p2[, k3 ...] by `cv2.projectPoints`,
    "fisheye" = k1..k4 by `cv2.fisheye.projectPoints`) is applied. Points at or behind the camera raise.
    """
    p = np.asarray(xyz_mm, dtype=float).reshape(-1, 3)
    if not np.all(np.isfinite(p)):
        raise ValueError("xyz_mm contains NaN or inf")
    R = camera_rotation(design)
    C = np.array([0.0, 0.0, design.camera_z])
    pc = (p - C) @ R.T
    if np.any(pc[:, 2] <= 1e-9):
        raise ValueError("a point lies at or below the camera's optical centre (camera_z); it cannot be imaged")
    K = camera_matrix(design, mtx)
    if dist is not None and (model == "fisheye" or np.any(np.asarray(dist, dtype=float) != 0)):
        import cv2

        from whisker.vision.lens import Lens, project as lens_project

        rvec, _ = cv2.Rodrigues(R)
        return lens_project(Lens(K, dist, model), p, rvec, -R @ C)
    x = pc[:, 0] / pc[:, 2]
    y = pc[:, 1] / pc[:, 2]
    return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)


def image_to_sensor(design, du_px, dv_px):
    """Rotate/mirror an image-axes vector (du, dv) into sensor-frame axes (same units)."""
    A = camera_rotation(design)[:2, :2]  # sensor xy -> image uv (orthogonal, det = +1)
    du = np.asarray(du_px, dtype=float)
    dv = np.asarray(dv_px, dtype=float)
    return A[0, 0] * du + A[1, 0] * dv, A[0, 1] * du + A[1, 1] * dv


def sensor_to_image(design, dx, dy):
    """Sensor-frame xy vector into image axes (inverse of `image_to_sensor`)."""
    A = camera_rotation(design)[:2, :2]
    dx = np.asarray(dx, dtype=float)
    dy = np.asarray(dy, dtype=float)
    return A[0, 0] * dx + A[0, 1] * dy, A[1, 0] * dx + A[1, 1] * dy


# ---- deflection ---------------------------------------------------------------------------------

class Deflection(NamedTuple):
    """Arrays of one shape. theta_deg: tilt from vertical; tip_x_mm, tip_y_mm: tip displacement
    from rest in the sensor frame (the paper's x_tip, y_tip); tip_z_mm: tip height above the pivot
    (the paper's z_tip = l_u cos theta); clamped: the arcsin argument exceeded 1 (or the ray missed
    the sphere) and theta was clamped to 90 deg; valid: the input was finite."""
    theta_deg: np.ndarray
    tip_x_mm: np.ndarray
    tip_y_mm: np.ndarray
    tip_z_mm: np.ndarray
    clamped: np.ndarray
    valid: np.ndarray


def _check_inputs(**arrays) -> None:
    for name, a in arrays.items():
        if np.any(np.isinf(a)):
            raise ValueError(f"{name} contains inf (a NaN marks a lost marker; inf is never valid)")


def paper_deflection(k, l_u, l_l, px, py) -> Deflection:
    """The paper's equations in whatever axes (px, py) are given (k mm/px, lengths mm).

    NaN displacements (lost markers) give NaN outputs with valid=False; an arcsin argument above 1
    is clamped to 1 (theta = 90 deg) and flagged. r = 0 gives theta = 0 exactly.
    """
    if not (math.isfinite(k) and k > 0 and math.isfinite(l_u) and l_u > 0 and math.isfinite(l_l) and l_l > 0):
        raise ValueError(f"k, l_u, l_l must be finite and positive, got k={k}, l_u={l_u}, l_l={l_l}")
    px = np.asarray(px, dtype=float)
    py = np.asarray(py, dtype=float)
    _check_inputs(dx_px=px, dy_px=py)
    px, py = np.broadcast_arrays(px, py)
    valid = np.isfinite(px) & np.isfinite(py)
    s = k * np.hypot(px, py) / l_l
    with np.errstate(invalid="ignore"):
        clamped = valid & (s > 1.0)
        theta = np.arcsin(np.minimum(s, 1.0))
    lever = l_u / l_l
    return Deflection(np.degrees(theta), -lever * k * px, -lever * k * py, l_u * np.cos(theta),
                      clamped, valid)


def deflection(design, dx_px, dy_px, *, model: str = "paper", whisker=None, k: float | None = None,
               mtx=None) -> Deflection:
    """Whisker tilt and tip displacement from marker pixel displacements (image axes, px).

    model="paper": the paper's equations with k = `k` or design.mm_per_px, the displacement rotated
    from image axes into the sensor frame. model="exact": camera ray / pivot-sphere intersection
    (needs `whisker`, the index or (M,) indices broadcasting with dx_px; the rest pixel is the
    design's projection, `mtx` optionally replaces the design's pinhole intrinsics).
    """
    dx = np.asarray(dx_px, dtype=float)
    dy = np.asarray(dy_px, dtype=float)
    _check_inputs(dx_px=dx, dy_px=dy)
    if model == "paper":
        sx, sy = image_to_sensor(design, dx, dy)
        return paper_deflection(design.mm_per_px if k is None else float(k), design.l_u, design.l_l, sx, sy)
    if model != "exact":
        raise ValueError(f"unknown deflection model {model!r}; choose 'paper' or 'exact'")
    if whisker is None:
        raise ValueError("model='exact' needs the whisker index (whisker=...)")
    idx = np.asarray(whisker)
    n = design.whiskers.count
    if idx.dtype.kind not in "iu" or np.any((idx < 0) | (idx >= n)):
        raise ValueError(f"whisker index must be an integer in 0..{n - 1}")
    dx, dy, idx = np.broadcast_arrays(dx, dy, idx)
    rest_uv = project(design, rest_marker_xyz(design), mtx=mtx)
    u = rest_uv[idx, 0] + dx
    v = rest_uv[idx, 1] + dy
    return exact_deflection(design, u, v, idx, mtx=mtx)


def exact_deflection(design, u_px, v_px, whisker, mtx=None) -> Deflection:
    """Exact rigid-rod deflection from the marker's (undistorted) pixel position.

    Ray from the camera centre C through pixel (u, v): X(t) = C + t d. The marker lies on the sphere
    |X - P| = l_l about the whisker's pivot P, on the half nearer the camera: the smaller root of
    t^2 |d|^2 + 2 t (m.d) + |m|^2 - l_l^2 = 0, m = C - P. If the ray misses the sphere the closest
    point is used and `clamped` is set. theta = atan2(|(P - X)_xy|, (P - X)_z); tip = P + l_u (P - X) / l_l.
    """
    u = np.asarray(u_px, dtype=float)
    v = np.asarray(v_px, dtype=float)
    _check_inputs(u_px=u, v_px=v)
    u, v, idx = np.broadcast_arrays(u, v, np.asarray(whisker))
    valid = np.isfinite(u) & np.isfinite(v)
    K = camera_matrix(design, mtx)
    R = camera_rotation(design)
    yc = (v - K[1, 2]) / K[1, 1]
    xc = (u - K[0, 2] - K[0, 1] * yc) / K[0, 0]
    dcam = np.stack([xc, yc, np.ones_like(xc)], axis=-1)
    d = dcam @ R  # camera -> sensor: R^T d_c (row vectors)
    C = np.array([0.0, 0.0, design.camera_z])
    P = pivot_xyz(design)[idx]
    m = C - P
    ll = design.l_l
    a = np.einsum("...i,...i", d, d)
    b = np.einsum("...i,...i", m, d)
    c = np.einsum("...i,...i", m, m) - ll * ll
    disc = b * b - a * c
    with np.errstate(invalid="ignore"):
        clamped = valid & (disc < 0)
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
    X = C + t[..., None] * d
    rel = P - X  # pivot minus marker: along the rod, towards the tip
    # atan2 of the horizontal and vertical parts: accurate at small angles, where arccos is not
    horiz = np.hypot(rel[..., 0], rel[..., 1])
    theta_r = np.where(clamped, np.pi / 2, np.arctan2(horiz, rel[..., 2]))
    cos_t = np.cos(theta_r)
    theta = np.degrees(theta_r)
    lever = design.l_u / ll
    tip_x = lever * rel[..., 0]
    tip_y = lever * rel[..., 1]
    nan = ~valid
    theta, tip_x, tip_y = (np.where(nan, np.nan, q) for q in (theta, tip_x, tip_y))
    tip_z = np.where(nan, np.nan, design.l_u * cos_t)
    return Deflection(theta, tip_x, tip_y, tip_z, clamped, valid)


# ---- the numbering sense of the markers in the image ------------------------------------------

class NumberingError(ValueError):
    """Marker positions that are not numbered around the ring (one-line message)."""


def sense_from_positions(xy: np.ndarray) -> int:
    """+1 if the whisker index increases with atan2(y, x) about the markers' centroid, else -1.

    ``xy``: (W, 2) rest positions in the same coordinates as the displacements. Refuses positions
    that are not in angular order (a numbering that is not a ring cannot be rotated by a shift).
    """
    xy = np.asarray(xy, dtype=float)
    if xy.ndim != 2 or xy.shape[1] != 2 or len(xy) < 3:
        raise NumberingError(f"need (W >= 3, 2) rest positions, got shape {xy.shape}")
    c = xy - xy.mean(axis=0)
    ang = np.arctan2(c[:, 1], c[:, 0])
    step = np.angle(np.exp(1j * (np.roll(ang, -1) - ang)))
    if not (np.all(step > 0) or np.all(step < 0)):
        raise NumberingError("whisker rest positions are not numbered around the ring "
                           f"(angle steps {np.round(np.degrees(step), 1).tolist()} deg)")
    return 1 if step[0] > 0 else -1
