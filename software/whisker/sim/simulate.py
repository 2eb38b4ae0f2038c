"""Run one scene with exactly the effects its plan builds (static solve, own integrator or MuJoCo).

:func:`simulate` returns a :class:`Result` (arrays, SI angles, mm positions); I/O lives in
whisker.sim.run (the run folder) and the CLI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from whisker.sim.effects import Plan, levels_at, levels_table, plan as make_plan, pose_at, poses_table
from whisker.sim.kinematics import (WhiskerBody, energy_J, gravity_torque, magnetic_torque,
                                    marker_positions_mm, static_equilibrium, step_free,
                                    tip_positions_mm, whisker_body)
from whisker.sim.scene import Scene, SceneError


class SimulationError(RuntimeError):
    """The run became non-physical (NaN, energy blow-up); one line saying what and when."""


@dataclass
class Result:
    plan: Plan
    t_s: np.ndarray                     # (T,)
    theta_rad: np.ndarray               # (T, N, 2): radial (+ retract), tangential
    tips_mm: np.ndarray                 # (T, N, 3) sensor frame
    markers_mm: np.ndarray              # (T, N, 3) sensor frame
    energy_J: np.ndarray                # (T,) whiskers' mechanical energy
    levels: np.ndarray                  # (T, N)
    temperature_C: np.ndarray | None = None   # (T, N) when heating is built
    objects_mm: np.ndarray | None = None      # (T, M, 3) world positions of the objects
    object_names: list[str] = field(default_factory=list)
    sensor_pose: np.ndarray | None = None     # (T, 4) x, y, tip height, yaw
    contacts: np.ndarray | None = None        # (T,) number of active contacts
    steps: int = 0
    info: dict = field(default_factory=dict)

    @property
    def theta_deg(self) -> np.ndarray:
        return np.degrees(self.theta_rad)


def _check_finite(name: str, arr, t: float) -> None:
    if not np.all(np.isfinite(arr)):
        raise SimulationError(f"{name} became non-finite at t = {t:.4g} s (time step too large or a "
                              f"broken parameter); try a smaller scene.timestep")


class Drive:
    """Currents of the coils from levels, the coil torque, and the coil heating when built.

    Currents are recomputed only when the levels or the temperatures change; the magnetics model
    is sampled once on `fidelity.magnetics_lookup` gaps over the reachable range and interpolated
    (0 = call whisker.magnetics every time); temperatures advance every `fidelity.heating_interval`.
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
            self.T = np.full(n, float(self.thermal.ambient_C))
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
            self.T = np.array([self.thermal.step(float(T), float(i), self._heat_acc)
                               for T, i in zip(self.T, self._I_rms)])
            self._heat_acc = 0.0
            self._key = None                       # resistance changed: recompute currents
            _check_finite("coil temperature", self.T, 0.0)

    def torque(self, body: WhiskerBody, theta_r, I) -> np.ndarray:
        if not self.on or not np.any(I):
            return np.zeros_like(theta_r)
        if self._lut is None:
            return magnetic_torque(self.design, body, theta_r, I, self.model)
        gap = body.gap0_mm - body.lever_m * 1e3 * np.sin(theta_r)
        k = np.interp(gap, *self._lut)
        return I * k * body.lever_m * np.cos(theta_r)


def simulate(scene: Scene, design=None, plan: Plan | None = None, progress=None,
             record_hz: float | None = None, body: WhiskerBody | None = None) -> Result:
    """Simulate `scene`; `progress(fraction)` is called now and then for long runs.

    record_hz: default the scene's ``outputs.record_hz`` (at least the camera's fps when it is on).
    """
    if record_hz is None:
        record_hz = max(scene.outputs.record_hz, scene.camera.fps if scene.camera.enabled else 0.0)
    from whisker.sim.scene import scene_design

    design = design if design is not None else scene_design(scene)
    plan = plan if plan is not None else make_plan(scene, design)
    body = body if body is not None else whisker_body(design)
    if plan.solver == "static":
        return _static(scene, design, plan, body)
    if plan.solver == "free":
        return _free(scene, design, plan, body, progress, record_hz)
    from whisker.sim.mj import run_mujoco
    return run_mujoco(scene, design, plan, body, progress, record_hz)


def _static(scene, design, plan, body) -> Result:
    n = design.whiskers.count
    lv = levels_at(scene, n, 0.0)
    drive = Drive(scene, design, plan)          # no lookup table: the solve calls the model directly
    I = drive.currents(lv)
    theta = np.zeros((1, n, 2))
    if drive.on:
        eq = static_equilibrium(design, body, I, facing=scene.sensor.facing, model=scene.fidelity.magnetics)
        theta[0, :, 0] = eq.theta_rad
    return _pack(plan, design, body, scene, np.zeros(1), theta, np.zeros_like(theta), lv[None], steps=0)


def _free(scene, design, plan, body, progress, record_hz) -> Result:
    n = design.whiskers.count
    dt = scene.scene.timestep
    duration = scene.scene.duration
    if duration <= 0:
        raise SceneError("scene.duration must be > 0 s for time stepping (or let nothing move for a static solve)")
    method = scene.fidelity.integrator
    if method == "euler" and dt * body.omega_n >= 2.0:
        raise SceneError(f"scene.timestep {dt:g} s is beyond the explicit integrator's stability limit "
                         f"2/omega_n = {2 / body.omega_n:.3g} s; use fidelity.integrator = 'implicit' or a smaller step")
    steps = int(math.ceil(duration / dt - 1e-9))
    every = max(1, int(round(1.0 / (record_hz * dt))))
    drive = Drive(scene, design, plan, body)
    theta = np.zeros((n, 2))
    theta[:, 0] = math.radians(scene.scene.initial_tilt_deg)
    omega = np.zeros((n, 2))
    facing = scene.sensor.facing
    rec_t, rec_th, rec_om, rec_lv, rec_T = [], [], [], [], []
    # event times are honoured exactly: levels are sampled at the start of each step
    table = levels_table(scene, n, np.arange(steps + 1) * dt)
    wind = None
    if plan.built("airflow"):
        from whisker.sim.airflow import AirflowDrag
        wind = AirflowDrag(design, scene.airflow, seed=scene.scene.seed)
    for k in range(steps + 1):
        t = k * dt
        lv = table[k]
        if k % every == 0 or k == steps:
            rec_t.append(t); rec_th.append(theta.copy()); rec_om.append(omega.copy()); rec_lv.append(lv)
            rec_T.append(drive.T.copy())
            if progress and k % (every * 50) == 0:
                progress(k / steps)
        if k == steps:
            break
        I = drive.currents(lv)
        tau = np.zeros((n, 2))
        tau[:, 0] = drive.torque(body, theta[:, 0], I)
        tau += gravity_torque(body, theta, facing)
        if wind is not None:
            tau += wind.torque(t)
            wind.step(dt)
        theta, omega = step_free(body, theta, omega, tau, dt, method)
        drive.heat(dt)
        _check_finite("whisker tilt", theta, t)
    res = _pack(plan, design, body, scene, np.array(rec_t), np.array(rec_th), np.array(rec_om),
                np.array(rec_lv), steps=steps)
    if drive.heating:
        res.temperature_C = np.array(rec_T)
    return res


def _pack(plan, design, body, scene, t, theta, omega, levels, steps) -> Result:
    e = energy_J(body, theta, omega, scene.sensor.facing).sum(axis=-1)   # (T,) all whiskers
    _check_finite("energy", e, float(t[-1]) if len(t) else 0.0)
    poses = poses_table(scene, t)
    return Result(plan=plan, t_s=t, theta_rad=theta, tips_mm=tip_positions_mm(design, theta),
                  markers_mm=marker_positions_mm(design, theta), energy_J=e, levels=levels,
                  sensor_pose=poses, steps=steps)
