"""Contact direction and tip force of every whisker from its tracked deflection and the membrane stiffness.

A whisker is a rigid rod on the membrane, a torsional spring of stiffness k (N*mm/rad per tilt axis:
``mechanics.rotational_stiffness``, fitted on a built sensor by ``whisker calibrate stiffness``,
whisker.bringup.stiffness). At rest under a force at its tip the torques about the pivot balance::

    F_h l_u cos(theta) u  =  k theta u  -  tau_coil(theta_r) (-r)

F_h: the force's horizontal (sensor-plane) part at the tip; u: the unit direction the tip moved
(sensor frame); theta: the tilt from vertical; r: the whisker's outward radial unit vector;
tau_coil: the torque of the whisker's own coil (retracting, toward -r) at the driven level, from the
coil model (whisker.coil.torque_per_ampere_Nmm x the mean current of the PWM level,
whisker.drive.guard.coil_current_A). So the force is the vector  (k theta u + tau_coil r) / (l_u cos theta),
its direction that of the contact push on the tip (the object lies on the other side).

Tilt and tip direction come from the marker's pixel displacement by the paper's equations
(whisker.vision.geometry.paper_deflection: theta = arcsin(k_px |p| / l_l), tip = -(l_u / l_l) k_px p, p
rotated into the sensor frame). The whisker's weight is left out: for the paper's sensor m g c =
0.0016 N*mm against k = 1.3 N*mm/rad (0.1 % of the spring). Assumptions: the contact is at the tip (a
contact lower on the rod means a larger force than estimated, by l_u / contact height), the whisker is
at rest (no inertia or damping: a swinging whisker in airflow gives its spring force, not the
air's), and k is the same in every direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad


@dataclass(frozen=True)
class ForceModel:
    """What the estimate needs of the design (all lengths mm).

    stiffness_Nmm_per_rad: k per tilt axis. tip_mm: l_u, pivot to tip. marker_mm: l_l, pivot to the
    tracked marker. mm_per_px: marker-plane scale. image_to_sensor: (2, 2) matrix taking an
    image-axes vector (du, dv) to sensor-frame (x, y). radial: (n, 2) outward radial unit vector of
    each whisker, sensor frame. coil_torque: None, or f(levels (n,), theta_r (n,) rad) -> (n,)
    N*mm, the retracting torque of each whisker's own coil.
    """
    stiffness_Nmm_per_rad: float
    tip_mm: float
    marker_mm: float
    mm_per_px: float
    image_to_sensor: tuple
    radial: tuple
    coil_torque: Callable | None = None

    def __post_init__(self):
        for name in ("stiffness_Nmm_per_rad", "tip_mm", "marker_mm", "mm_per_px"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"ForceModel.{name} must be a finite positive number, got {v}")

    @classmethod
    def from_design(cls, design, *, stiffness_Nmm_per_rad: float | None = None, coil: bool = True) -> "ForceModel":
        """From a Design; `stiffness_Nmm_per_rad` overrides mechanics.rotational_stiffness (e.g. the
        value of a stiffness report). coil=False leaves the coil torque out."""
        from whisker.vision.geometry import camera_rotation

        A = camera_rotation(design)[:2, :2]          # sensor xy -> image uv; its transpose the inverse
        ang = np.radians(np.asarray(design.whisker_angles_deg, dtype=float))
        radial = tuple(map(tuple, np.stack([np.cos(ang), np.sin(ang)], axis=1)))
        k = float(design_stiffness_Nmm_per_rad(design) if stiffness_Nmm_per_rad is None else stiffness_Nmm_per_rad)
        return cls(k, float(design.l_u), float(design.l_l), float(design.mm_per_px), tuple(map(tuple, A.T)), radial,
                   coil_torque_fn(design) if coil else None)


def coil_torque_fn(design) -> Callable:
    """f(levels, theta_r, temperature_C=20) -> N*mm: retracting coil torque per whisker: the mean
    current of the PWM level (level x full-scale volts through whisker.drive.guard.coil_current_A at the
    coil's temperature, C: a warm coil draws less) x whisker.coil.torque_per_ampere_Nmm at the
    radial tilt."""
    from whisker.coil import torque_per_ampere_Nmm
    from whisker.drive.guard import coil_current_A, full_scale_voltage

    v_fs = full_scale_voltage(design)

    def torque(levels, theta_r, temperature_C=20.0):
        lv = np.asarray(levels, dtype=float)
        i = np.sign(lv) * np.asarray(coil_current_A(design, np.abs(lv) * v_fs, temperature_C), dtype=float)
        return i * np.asarray(torque_per_ampere_Nmm(design, np.asarray(theta_r, dtype=float)), dtype=float)
    return torque


class TipForce(NamedTuple):
    """Arrays of the input's shape (one per whisker). fx_mN, fy_mN: the horizontal force on the tip,
    sensor frame, mN; force_mN: its magnitude; direction_deg: its direction, CCW from sensor +x
    (0 where there is no force); theta_deg: tilt; valid: the marker was tracked (else NaN)."""
    fx_mN: np.ndarray
    fy_mN: np.ndarray
    force_mN: np.ndarray
    direction_deg: np.ndarray
    theta_deg: np.ndarray
    valid: np.ndarray


def tip_force(model: ForceModel, dx_px, dy_px, levels=None, temperature_C=20.0) -> TipForce:
    """Per-whisker tip force (mN) and direction from marker displacements (image axes, px).

    dx_px, dy_px: (n,) displacement of each marker from its rest position, px (NaN = lost marker ->
    NaN force, valid False). levels: (n,) signed PWM levels driving the coils now (None or 0: coils
    off). temperature_C: the coils' temperatures, C (scalar or (n,); e.g. the thermal guard's
    estimate), for their current. Formula and assumptions: module docstring. Zero displacement and no coil give exactly zero
    force; the direction of a pure spring force does not depend on the displacement's size.
    """
    dx = np.asarray(dx_px, dtype=float)
    dy = np.asarray(dy_px, dtype=float)
    if dx.shape != dy.shape:
        raise ValueError(f"dx_px and dy_px must have one shape, got {dx.shape} and {dy.shape}")
    if np.any(np.isinf(dx)) or np.any(np.isinf(dy)):
        raise ValueError("a displacement is infinite (NaN marks a lost marker; inf is never valid)")
    M = np.asarray(model.image_to_sensor, dtype=float)
    sx = M[0, 0] * dx + M[0, 1] * dy             # marker displacement, sensor frame, px
    sy = M[1, 0] * dx + M[1, 1] * dy
    valid = np.isfinite(sx) & np.isfinite(sy)
    r_px = np.hypot(sx, sy)
    a = model.mm_per_px / model.marker_mm        # sin(theta) per px
    s = np.minimum(a * r_px, 1.0)
    with np.errstate(invalid="ignore"):
        theta = np.arcsin(s)
        # k theta u, with u = -p / |p| (the tip moves opposite the marker): theta / |p| -> a as |p| -> 0
        small = r_px < 1e-9
        per_px = np.where(small, a, theta / np.where(small, 1.0, r_px))
    tx = -model.stiffness_Nmm_per_rad * per_px * sx   # N*mm, spring torque as a tip-direction vector
    ty = -model.stiffness_Nmm_per_rad * per_px * sy
    if model.coil_torque is not None and levels is not None:
        lv = np.broadcast_to(np.asarray(levels, dtype=float), dx.shape)
        if not (np.all(np.isfinite(lv)) and np.all(np.isfinite(temperature_C))):
            raise ValueError("coil levels and temperatures must be finite numbers")
        rad = np.asarray(model.radial, dtype=float).reshape(dx.shape + (2,))
        # radial tilt: the tip's move toward the centre (retraction +)
        with np.errstate(invalid="ignore"):
            th_r = np.arcsin(np.clip(a * (sx * rad[..., 0] + sy * rad[..., 1]), -1.0, 1.0))
        tc = np.where(lv != 0, model.coil_torque(lv, np.where(valid, th_r, 0.0), temperature_C), 0.0)
        tx = tx + tc * rad[..., 0]
        ty = ty + tc * rad[..., 1]
    lever = model.tip_mm * np.sqrt(np.maximum(1.0 - s * s, 1e-12))     # l_u cos(theta), mm
    fx = 1e3 * tx / lever
    fy = 1e3 * ty / lever
    nan = ~valid
    fx, fy = np.where(nan, np.nan, fx), np.where(nan, np.nan, fy)
    f = np.hypot(fx, fy)
    fx, fy = fx + 0.0, fy + 0.0                  # -0.0 -> 0.0: no force has direction 0, not 180 deg
    direction = np.where(nan, np.nan, np.degrees(np.arctan2(np.where(nan, 0.0, fy), np.where(nan, 0.0, fx))))
    return TipForce(fx, fy, f, direction, np.where(nan, np.nan, np.degrees(theta)), valid)
