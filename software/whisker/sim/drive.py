"""The coil drive of a built scene against time: the scene's timeline (coil levels and sensor poses:
piecewise constant levels, linear moves between waypoints; used by the plan for reach and heating) and
the drive that turns levels into currents, the coil torque on each whisker, and the coils' heating when
the plan builds it (used by the own integrator and by the MuJoCo model)."""

from __future__ import annotations

import math

import numpy as np

from whisker.sim.graph import Plan
from whisker.coil.kinematics import WhiskerBody, magnetic_torque
from whisker.sim.result import check_finite
from whisker.sim.scene import Scene, SceneError


class Drive:
    """Currents of the coils from levels, the coil torque, and the coil heating when built.

    Currents are recomputed only when the levels or the temperatures change; the magnetics model
    is sampled once on `fidelity.magnetics_lookup` gaps over the reachable range and interpolated
    (0 = call whisker.coil.magnetics every time); temperatures advance every `fidelity.heating_interval`.
    """

    def __init__(self, scene: Scene, design, plan: Plan, body: WhiskerBody | None = None):
        self.scene, self.design = scene, design
        from whisker.sim.contract import full_scale_voltage
        self.volts = full_scale_voltage(design) if plan.built("magnetics") else 0.0   # V at level 1
        self.on = plan.built("magnetics")
        self.heating = plan.built("heating")
        n = design.whiskers.count
        self.thermal = None
        if self.heating:
            from whisker.sim.contract import coil_thermal
            self.thermal = coil_thermal(design)
            self.state = self.thermal.initial_state()
            self.T = np.asarray(self.thermal.winding_C(self.state), dtype=float).copy()
        else:
            self.T = np.full(n, 20.0)
        self.model = scene.fidelity.magnetics
        self._key = None
        self._I = np.zeros(n)
        self._I_rms = np.zeros(n)                  # the heating current of the same levels
        self._heat_acc = 0.0
        self._lut = None
        if self.on and body is not None and scene.fidelity.magnetics_lookup > 0:
            from whisker.sim.contract import force_per_ampere_N
            s = math.sin(body.stop_rad) * body.lever_m * 1e3
            g = np.linspace(max(body.gap0_mm - s, 1e-3), body.gap0_mm + s, scene.fidelity.magnetics_lookup)
            self._lut = (g, force_per_ampere_N(design, g, model=self.model))

    def currents(self, levels: np.ndarray) -> np.ndarray:
        """Mean coil currents (A) of `levels`, which set the force; their PWM RMS currents, which set the
        heat (whisker.sim.contract.pwm_rms_current_A), are kept for :meth:`heat`."""
        from whisker.sim.contract import current_A, pwm_rms_current_A
        if not self.on:
            return np.zeros_like(levels)
        key = levels.tobytes()
        if key != self._key:
            self._I = np.asarray(current_A(self.design, levels * self.volts, self.T), dtype=float)
            self._I_rms = pwm_rms_current_A(self._I, levels)
            self._key = key
        return self._I

    def heat(self, dt: float) -> None:
        """Advance the coil temperatures by `dt` s with the levels of the last :meth:`currents` call."""
        if self.thermal is None:
            return
        self._heat_acc += dt
        if self._heat_acc >= self.scene.fidelity.heating_interval - 1e-12:
            self.state = self.thermal.step_state(self.state, self._I_rms, self._heat_acc)
            self.T = np.asarray(self.thermal.winding_C(self.state), dtype=float).copy()
            self._heat_acc = 0.0
            self._key = None                       # resistance changed: recompute currents
            check_finite("coil temperature", self.T, 0.0)

    def torque(self, body: WhiskerBody, theta_r, I) -> np.ndarray:
        if not self.on or not np.any(I):
            return np.zeros_like(theta_r)
        if self._lut is None:
            return magnetic_torque(self.design, body, theta_r, I, self.model)
        gap = body.gap0_mm - body.lever_m * 1e3 * np.sin(theta_r)
        k = np.interp(gap, *self._lut)
        return I * k * body.lever_m * np.cos(theta_r)


# ---- the scene's timeline: levels and poses against time ----------------------------------------

def levels_at(scene: Scene, n: int, t: float) -> np.ndarray:
    """Signed duty of each of `n` whiskers at time t from the schedule (piecewise constant)."""
    lv = np.zeros(n)
    for ev in scene.actuation.schedule:
        if ev.t > t:
            break
        idx = range(n) if ev.whiskers is None else ev.whiskers
        for i in idx:
            if not 0 <= i < n:
                raise SceneError(f"actuation.schedule: whisker {i} does not exist (the design has {n})")
            lv[i] = ev.level
    return lv


def levels_table(scene: Scene, n: int, times: np.ndarray) -> np.ndarray:
    """Levels (T, n) at each of `times` (vectorised :func:`levels_at`)."""
    times = np.asarray(times, dtype=float)
    out = np.zeros((len(times), n))
    for ev in scene.actuation.schedule:
        idx = list(range(n)) if ev.whiskers is None else ev.whiskers
        for i in idx:
            if not 0 <= i < n:
                raise SceneError(f"actuation.schedule: whisker {i} does not exist (the design has {n})")
        out[np.ix_(times >= ev.t, idx)] = ev.level
    return out


def poses_table(scene: Scene, times: np.ndarray) -> np.ndarray:
    """Poses (T, 4) at each of `times` (vectorised :func:`pose_at`)."""
    p = np.asarray(scene.sensor.path, dtype=float)
    times = np.asarray(times, dtype=float)
    if len(p) == 1:
        return np.repeat(p[:1, 1:], len(times), axis=0)
    return np.stack([np.interp(times, p[:, 0], p[:, k]) for k in range(1, 5)], axis=1)


def pose_at(scene: Scene, t: float) -> np.ndarray:
    """Sensor pose [x_mm, y_mm, tip_height_mm, yaw_deg] at time t (linear between waypoints)."""
    p = np.asarray(scene.sensor.path, dtype=float)
    if len(p) == 1:
        return p[0, 1:].copy()
    return np.array([np.interp(t, p[:, 0], p[:, k]) for k in range(1, 5)])


def path_samples(scene: Scene, duration: float) -> np.ndarray:
    p = np.asarray(scene.sensor.path, dtype=float)
    t_end = max(duration, p[-1, 0])
    ts = np.unique(np.concatenate([p[:, 0], np.linspace(0, t_end, 200)]))
    return np.array([pose_at(scene, t) for t in ts])
