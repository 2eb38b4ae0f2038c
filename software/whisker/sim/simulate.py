"""Run one scene with exactly the effects its plan builds (static solve, own integrator or MuJoCo).

:func:`simulate` returns a :class:`Result` (arrays, SI angles, mm positions); I/O lives in
whisker.sim.run (the run folder) and the CLI.
"""

from __future__ import annotations

import math

import numpy as np

from whisker.sim.drive import Drive
from whisker.sim.effects.plan import plan as make_plan
from whisker.sim.graph import Plan
from whisker.coil.kinematics import (WhiskerBody, energy_J, gravity_torque, marker_positions_mm,
                                    static_equilibrium, step_free, tip_positions_mm, whisker_body)
from whisker.sim.mj import MjScene
from whisker.sim.result import Result, SimulationError, check_finite  # noqa: F401 (public here)
from whisker.sim.scene import Scene, SceneError
from whisker.sim.drive import levels_at, levels_table, poses_table


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
    return _mujoco(scene, design, plan, body, progress, record_hz)


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
        from whisker.sim.effects.airflow import AirflowDrag
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
        check_finite("whisker tilt", theta, t)
    res = _pack(plan, design, body, scene, np.array(rec_t), np.array(rec_th), np.array(rec_om),
                np.array(rec_lv), steps=steps)
    if drive.heating:
        res.temperature_C = np.array(rec_T)
    return res


def _pack(plan, design, body, scene, t, theta, omega, levels, steps) -> Result:
    e = energy_J(body, theta, omega, scene.sensor.facing).sum(axis=-1)   # (T,) all whiskers
    check_finite("energy", e, float(t[-1]) if len(t) else 0.0)
    poses = poses_table(scene, t)
    return Result(plan=plan, t_s=t, theta_rad=theta, tips_mm=tip_positions_mm(design, theta),
                  markers_mm=marker_positions_mm(design, theta), energy_J=e, levels=levels,
                  sensor_pose=poses, steps=steps)


def _mujoco(scene, design, plan, body, progress, record_hz):
    dt = scene.scene.timestep
    duration = scene.scene.duration
    if duration <= 0:
        raise SceneError("scene.duration must be > 0 s for a contact scene")
    if dt * body.omega_n > 0.5:
        raise SceneError(f"scene.timestep {dt:g} s is too large for the whisker spring in MuJoCo "
                         f"(dt x omega_n = {dt * body.omega_n:.2g} > 0.5); use <= {0.5 / body.omega_n:.2g} s")
    sim = MjScene(scene, design, plan, body)
    steps = int(math.ceil(duration / dt - 1e-9))
    every = max(1, int(round(1.0 / (record_hz * dt))))
    chunk = max(1, min(scene.contact.chunk, every))
    times = np.arange(steps + 1) * dt
    arm = sim.arm_table(times)
    levels = levels_table(scene, design.whiskers.count, times)
    # chunk boundaries: every `chunk` steps, at every recording, at every waypoint and level change
    cuts = set(range(0, steps + 1, chunk)) | set(range(0, steps + 1, every)) | {steps}
    for w in scene.sensor.path:
        cuts.add(min(steps, int(round(w[0] / dt))))
    for ev in scene.actuation.schedule:
        cuts.add(min(steps, int(math.ceil(ev.t / dt - 1e-9))))
    cuts = sorted(cuts)
    rec = {"t": [], "th": [], "om": [], "lv": [], "obj": [], "E": [], "nc": [], "T": []}
    for a, b in zip(cuts, cuts[1:] + [None]):
        if a % every == 0 or a == steps:
            th = sim.theta()
            if not (np.all(np.isfinite(th)) and np.all(np.isfinite(sim.data.qvel))):
                raise SimulationError(f"MuJoCo state became non-finite at t = {sim.t:.4g} s; use a smaller "
                                      "scene.timestep or a softer contact")
            rec["t"].append(a * dt); rec["th"].append(th); rec["om"].append(sim.omega()); rec["lv"].append(levels[a])
            rec["obj"].append(sim.objects_mm()); rec["nc"].append(sim.data.ncon); rec["T"].append(sim.drive.T.copy())
            rec["E"].append(float(sim.data.energy.sum()))
            if progress and a % (every * 50) == 0:
                progress(a / steps)
        if b is None:
            break
        sim.advance(levels[a], arm[a], arm[b], b - a)
        sim.t = b * dt
    theta = np.array(rec["th"])
    omega = np.array(rec["om"])
    # MuJoCo's joint limit is a soft constraint: a rigid path pushing a whisker against a held object
    # can drive it past the stop. The mount's stop is hard: report the excess and clamp the reading.
    over = float(np.degrees(max(0.0, np.abs(theta).max() - body.stop_rad))) if theta.size else 0.0
    theta = np.clip(theta, -body.stop_rad, body.stop_rad)
    e_wh = energy_J(body, theta, omega, scene.sensor.facing).sum(axis=-1)
    res = Result(plan=plan, t_s=np.array(rec["t"]), theta_rad=theta, tips_mm=tip_positions_mm(design, theta),
                 markers_mm=marker_positions_mm(design, theta), energy_J=e_wh, levels=np.array(rec["lv"]),
                 objects_mm=np.array(rec["obj"]), object_names=[o.name for o in scene.objects],
                 sensor_pose=poses_table(scene, np.array(rec["t"])), contacts=np.array(rec["nc"]),
                 steps=steps, info={"mujoco_energy_J": rec["E"][-1], "mujoco_energy_max_J": max(rec["E"]),
                       "mujoco_energy_start_J": rec["E"][0],
                       "stop_violation_max_deg": over})
    if sim.drive.heating:
        res.temperature_C = np.array(rec["T"])
    return res
