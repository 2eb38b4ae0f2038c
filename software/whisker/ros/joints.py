"""The joint-space quantities the ROS 2 node publishes, from one frame's geometry and force.

Pure numpy (no rclpy), so they are tested without ROS. Conventions as in `whisker.ros.node`'s
docstring and docs/ros2.md: joint ``whisker_<i>`` turns about the axis r x z at the whisker's pivot,
+ = retraction (tip towards the centre).
"""

from __future__ import annotations

import math

import numpy as np


def joint_quantities(geo, force, radial):
    """(radial_tilt_rad, effort_Nm, force_N, lever_m, moment_Nm) per whisker.

    geo: a `whisker.vision.geometry` result (theta_deg, tip_x_mm, tip_y_mm, tip_z_mm per whisker);
    force: a `whisker.sensing.contact_force` estimate (fx_mN, fy_mN); radial: (N, 2) unit vectors from
    the sensor centre to each whisker. radial_tilt: the tilt signed by the tip's move towards the centre,
    rad (0 where the tip has not moved); force_N: (N, 3) in sensor axes; lever_m: pivot -> tip (N, 3);
    moment_Nm = lever x force; effort_Nm: its component about the joint axis r x z.
    """
    radial = np.asarray(radial, dtype=float)
    n = len(radial)
    theta = np.radians(np.asarray(geo.theta_deg, dtype=float))
    tip = np.stack([geo.tip_x_mm, geo.tip_y_mm], axis=1)                     # tip moved, sensor xy, mm
    r_tip = np.hypot(tip[:, 0], tip[:, 1])
    inward = -np.sum(tip * radial, axis=1)                                  # tip's move towards the centre
    with np.errstate(invalid="ignore", divide="ignore"):
        radial_tilt = np.where(r_tip > 1e-12, theta * inward / np.where(r_tip > 1e-12, r_tip, 1.0), 0.0)
    f = np.stack([force.fx_mN, force.fy_mN, np.zeros(n)], axis=1) * 1e-3    # N, sensor axes
    lever = np.stack([tip[:, 0], tip[:, 1], np.asarray(geo.tip_z_mm, float)], axis=1) * 1e-3   # pivot->tip, m
    moment = np.cross(lever, f)                                              # N m about the pivot
    axis = np.stack([radial[:, 1], -radial[:, 0], np.zeros(n)], axis=1)     # joint axis r x z
    effort = np.sum(moment * axis, axis=1)
    return radial_tilt, effort, f, lever, moment


def quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the URDF rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)
