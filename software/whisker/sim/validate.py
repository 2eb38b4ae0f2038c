"""Refuse impossible scenes before they run, and flag unphysical runs after.

`check(scene, design, plan)` is called by `whisker sim` for `--explain` and for the run alike, so a
scene `--explain` accepts is a scene the run accepts (tests/test_sim_validate.py checks that over
generated scenes). It refuses, with one line naming the key and what to do:

- a time-stepped scene of zero duration, or a time step beyond the integrator's stability limit
  (the same conditions simulate.py and mj.py enforce at run time);
- more steps or memory than the stated limits (:data:`MAX_STEPS`, :data:`MAX_BYTES`; raise them
  with WHISKER_SIM_MAX_STEPS / WHISKER_SIM_MAX_GB);
- a path that puts the whisker tips below the table top (facing down, table enabled);
- an object that overlaps the membrane, a whisker or another object at t = 0 (MuJoCo's own
  collision detection on the built scene, so irregular compound objects are judged exactly).

`run_flags(scene, result)` lists what makes a finished run unphysical: energy rising without input
(no actuation, no path motion) and objects leaving the scene (thrown beyond the table or through
it). `whisker sim` writes them into summary.json and exits with status 1.
"""

from __future__ import annotations

import math
import os

import numpy as np

from whisker.sim.scene import SceneError

#: default limits of one run; environment variables raise them
MAX_STEPS = 20_000_000
MAX_BYTES = 2 * 1024 ** 3
#: bytes held per time step while a run is prepared: the time grid, the level table (n) and the arm
#: table (4 values), float64
_BYTES_PER_STEP_BASE = 8 * (1 + 4)
#: m of penetration at t = 0 counted as an overlap (MuJoCo's resting contacts sit at ~0)
OVERLAP_TOL_M = 1e-4
#: mm an object may end from where it started before it counts as thrown out of the scene (the
#: sensor reaches ~50 mm; the MuJoCo table is 2 m across), and how far below the table top is "through it"
LEFT_SCENE_MM = 500.0
THROUGH_TABLE_MM = 10.0
#: a run whose total energy grows by more than this fraction (and 1 mJ) without input is flagged
ENERGY_RISE_TOL = (1e-3, 0.05)


def limits() -> tuple[int, int]:
    """(max steps, max bytes) of one run, from WHISKER_SIM_MAX_STEPS / WHISKER_SIM_MAX_GB if set."""
    steps, nbytes = MAX_STEPS, MAX_BYTES
    try:
        if os.environ.get("WHISKER_SIM_MAX_STEPS"):
            steps = int(float(os.environ["WHISKER_SIM_MAX_STEPS"]))
        if os.environ.get("WHISKER_SIM_MAX_GB"):
            nbytes = int(float(os.environ["WHISKER_SIM_MAX_GB"]) * 1024 ** 3)
    except ValueError:
        raise SceneError("WHISKER_SIM_MAX_STEPS / WHISKER_SIM_MAX_GB must be numbers") from None
    return steps, nbytes


def steps_of(scene) -> int:
    """Time steps of the scene's own run (0 for a static solve)."""
    return int(math.ceil(scene.scene.duration / scene.scene.timestep - 1e-9))


def check(scene, design, plan) -> None:
    """Raise SceneError (one line) when `scene` cannot run as planned; see the module doc."""
    from whisker.sim.contract import MissingModule

    info = scene.scene
    stepped = plan.solver in ("free", "mujoco")
    timed = stepped and scene.experiment.kind == "none"   # an experiment times its own attempts
    if timed and info.duration <= 0:
        raise SceneError("scene.duration must be > 0 s for time stepping (the scene moves: "
                         f"{plan.solver} solver); give a duration or let nothing move for a static solve")
    try:
        from whisker.coil.kinematics import whisker_body

        body = whisker_body(design)
    except MissingModule:
        body = None
    if stepped and body is not None:
        dt = info.timestep
        if plan.solver == "free" and scene.fidelity.integrator == "euler" and dt * body.omega_n >= 2.0:
            raise SceneError(f"scene.timestep {dt:g} s is beyond the explicit integrator's stability limit "
                             f"2/omega_n = {2 / body.omega_n:.3g} s; use fidelity.integrator = 'implicit' or a "
                             "smaller step")
        if plan.solver == "mujoco" and dt * body.omega_n > 0.5:
            raise SceneError(f"scene.timestep {dt:g} s is too large for the whisker spring in MuJoCo "
                             f"(dt x omega_n = {dt * body.omega_n:.2g} > 0.5); use <= {0.5 / body.omega_n:.2g} s")
    if timed:
        _check_size(scene, design)
    if scene.table.enabled and scene.sensor.facing == "down":
        low = [(i, w[3]) for i, w in enumerate(scene.sensor.path) if w[3] < 0]
        if low:
            i, h = low[0]
            raise SceneError(f"sensor.path waypoint {i}: tip height {h:g} mm puts the tips below the table top; "
                             "use a height >= 0 mm (0 = touching) or disable the table")
    if plan.built("contact") and scene.experiment.kind == "none" and scene.objects:
        _check_overlaps(scene, design, plan, body)


def _check_size(scene, design) -> None:
    steps = steps_of(scene)
    max_steps, max_bytes = limits()
    n = design.whiskers.count
    nbytes = steps * (_BYTES_PER_STEP_BASE + 8 * n)
    if steps > max_steps:
        raise SceneError(f"{steps:.3g} time steps (scene.duration {scene.scene.duration:g} s / scene.timestep "
                         f"{scene.scene.timestep:g} s) is over the limit of {max_steps:.3g}; use a larger "
                         "timestep or a shorter duration, or raise the limit with WHISKER_SIM_MAX_STEPS=N")
    if nbytes > max_bytes:
        raise SceneError(f"the run would need about {nbytes / 1024 ** 3:.3g} GiB ({steps:.3g} steps x {n} whiskers), "
                         f"over the limit of {max_bytes / 1024 ** 3:.3g} GiB; use a larger timestep or raise "
                         "the limit with WHISKER_SIM_MAX_GB=N")


def _check_overlaps(scene, design, plan, body) -> None:
    """Objects penetrating the sensor (membrane, rods, tips) or each other at t = 0, by MuJoCo."""
    try:
        from whisker.sim.mj import MjScene
    except ImportError:  # pragma: no cover - MuJoCo is a dependency; the run would say so
        return
    if body is None:
        return
    sim = MjScene(scene, design, plan, body)
    m, d, mj = sim.model, sim.data, sim.mujoco

    def owner(geom: int) -> str:
        name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_GEOM, geom) or ""
        if name == "table":
            return "table"
        body_name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[geom])) or ""
        if body_name.startswith("obj:"):
            return body_name
        if name.startswith("rod") or name.startswith("tip"):
            return f"whisker {name[3:]}"
        return name or "the sensor"

    for k in range(d.ncon):
        c = d.contact[k]
        if c.dist >= -OVERLAP_TOL_M:
            continue
        a, b = owner(int(c.geom1)), owner(int(c.geom2))
        if "table" in (a, b) or a == b:
            continue
        objs = sorted(x for x in (a, b) if x.startswith("obj:"))
        others = [x for x in (a, b) if not x.startswith("obj:")]
        what = f"object {objs[0][4:]!r}"
        with_ = f"object {objs[1][4:]!r}" if len(objs) == 2 else others[0]
        raise SceneError(f"{what} overlaps {with_} by {-c.dist * 1e3:.2f} mm at t = 0; move it "
                         "(objects.pos), make it smaller or start the sensor path higher")


def run_flags(scene, result) -> list[str]:
    """Why a finished plain run is unphysical (empty: nothing to flag)."""
    flags = []
    no_input = not scene.acts and not scene.sensor.moves and scene.scene.initial_tilt_deg == 0
    e = np.asarray(result.energy_J, dtype=float)
    if no_input and e.size > 1 and np.all(np.isfinite(e)):
        rise = float(e[-1] - e[0])
        if rise > max(ENERGY_RISE_TOL[0], ENERGY_RISE_TOL[1] * abs(float(e[0]))):
            flags.append(f"whisker energy rose by {rise:.3g} J without input (no actuation, no path motion)")
    info = getattr(result, "info", None) or {}
    if no_input and "mujoco_energy_J" in info:
        e0 = float(info.get("mujoco_energy_start_J", float("nan")))
        peak = float(info.get("mujoco_energy_max_J", float("nan")))
        if math.isfinite(e0) and math.isfinite(peak) and peak - e0 > max(ENERGY_RISE_TOL[0], ENERGY_RISE_TOL[1] * abs(e0)):
            flags.append(f"scene energy rose from {e0:.3g} J to {peak:.3g} J without input")
    objs = getattr(result, "objects_mm", None)
    if objs is not None and len(objs):
        first, last = np.asarray(objs)[0], np.asarray(objs)[-1]
        for name, p0, p in zip(result.object_names, first, last):
            gone = not np.all(np.isfinite(p)) or float(np.linalg.norm(p - p0)) > LEFT_SCENE_MM
            if gone or (scene.table.enabled and p[2] < -THROUGH_TABLE_MM):
                flags.append(f"object {name!r} left the scene (from {np.round(p0, 1).tolist()} to "
                             f"{np.round(p, 1).tolist()} mm)")
    return flags
