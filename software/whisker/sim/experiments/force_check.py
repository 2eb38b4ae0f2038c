"""The tip-force estimate (whisker.sensing.contact_force) against the simulator: a known force on one whisker's tip.

`applied_force_trial` holds the grasp scene's sensor still in MuJoCo (whisker.sim.experiments.closed_loop.SimGraspRig,
the object far below the tips), pushes one whisker's tip with a constant force in the sensor plane
(MuJoCo ``xfrc_applied``: the force at the tip point, re-aimed every few steps as the rod tilts),
optionally with that whisker's coil driven, lets it settle, renders the camera frame, tracks it and
estimates the force. The estimate from the true marker pixels (no tracking) is reported too, so the
error splits into the model's part (rigid rod, spring k theta, coil torque model, weight left out)
and the tracker's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ForceTrial:
    whisker: int
    level: float
    applied_mN: np.ndarray          # (2,) sensor frame
    estimated_mN: np.ndarray        # (2,) from the tracked frame
    model_mN: np.ndarray            # (2,) from the true marker pixels
    theta_deg: float                # true tilt in MuJoCo

    @staticmethod
    def _err(est, app) -> tuple[float, float]:
        f = float(np.hypot(*app))
        mag = (float(np.hypot(*est)) - f) / f
        ang = math.degrees(math.atan2(est[1], est[0]) - math.atan2(app[1], app[0]))
        return 100.0 * mag, (ang + 180.0) % 360.0 - 180.0

    @property
    def error(self) -> tuple[float, float]:
        """(magnitude error %, direction error deg) of the tracked estimate."""
        return self._err(self.estimated_mN, self.applied_mN)

    @property
    def model_error(self) -> tuple[float, float]:
        return self._err(self.model_mN, self.applied_mN)


def applied_force_trial(scene, design, obj, force_mN: float, direction_deg: float, *, whisker: int = 0,
                        level: float = 0.0, settle_s: float = 0.5, seed: int = 0, chunk: int = 5,
                        noise_sigma: float = 2.0) -> ForceTrial:
    """One trial: `force_mN` at `direction_deg` (CCW from sensor +x, in the sensor plane) on `whisker`'s
    tip, its coil at `level` (others off), settled for `settle_s` s. See the module doc."""
    import mujoco

    from whisker.sensing.contact_force import ForceModel, tip_force
    from whisker.sim.experiments.closed_loop import SimGraspRig
    from whisker.sim.contract import marker_pixels
    from whisker.coil.kinematics import marker_positions_mm
    from whisker.sim.experiments.paper import Placement

    n = design.whiskers.count
    rig = SimGraspRig(scene, design, obj, [whisker], Placement(), seed=seed, noise_sigma=noise_sigma)
    sim = rig.sim
    m, d = sim.model, sim.data
    wid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"w{whisker}")
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "sensor")
    top = rig.body.rod_top_m
    a = math.radians(direction_deg)
    f_sensor = 1e-3 * force_mN * np.array([math.cos(a), math.sin(a), 0.0])       # N
    levels = np.zeros(n)
    levels[whisker] = level
    arm = d.qpos[sim.arm_q].copy()
    steps = int(round(settle_s / rig.dt))
    done = 0
    while done < steps:
        R = d.xmat[sid].reshape(3, 3)
        F = R @ f_sensor
        tip = d.xpos[wid] + d.xmat[wid].reshape(3, 3) @ np.array([0.0, 0.0, top])
        d.xfrc_applied[wid, :3] = F
        d.xfrc_applied[wid, 3:] = np.cross(tip - d.xipos[wid], F)
        k = min(chunk, steps - done)
        sim.advance(levels, arm, arm, k)
        done += k
    d.xfrc_applied[wid] = 0.0
    _, img = rig.frame()
    res = rig.tracker.track(img)
    model = ForceModel.from_design(design)
    est = tip_force(model, res.dx_px, res.dy_px, levels, sim.drive.T)
    rest = marker_pixels(design, marker_positions_mm(design, np.zeros((n, 2))))
    true = marker_pixels(design, marker_positions_mm(design, sim.theta())) - rest
    ideal = tip_force(model, true[:, 0], true[:, 1], levels, sim.drive.T)
    th = sim.theta()[whisker]
    return ForceTrial(whisker, level, f_sensor[:2] * 1e3, np.array([est.fx_mN[whisker], est.fy_mN[whisker]]),
                      np.array([ideal.fx_mN[whisker], ideal.fy_mN[whisker]]),
                      math.degrees(math.acos(math.cos(th[0]) * math.cos(th[1]))))
