"""The design explorer's tasks: what one worker computes, and the on-disk cache of finished tasks.

Two kinds of task, each a pure function of picklable inputs (a ``Design``, a ``Scene``), so joblib
and Dask run the same code on any worker:

- :func:`design_task`: the design's predictions from the calculators (coil, magnetics, thermal,
  driver rating, camera model) and, unless skipped, the CAD checks the feasibility sweep runs
  (``whisker.cad.build.evaluate``: solids, collisions over full deflection, mesh checks);
- :func:`grasp_task`: a chunk of the paper's grasp attempts (``whisker.sim.experiments.paper.grasp_attempt``)
  for one object and one set of active whiskers.

Seeds. Attempt ``i`` of object ``k`` uses the ``i``-th placement drawn from
``numpy.random.default_rng([scene.seed, k])``, exactly as ``grasp_table`` (``make sim-grasp``)
draws them, so the paper's design reproduces ``make sim-grasp`` cell for cell. A task's result is a
function of (design digest, object, whisker set, attempt range) alone: the table does not depend on
the chunk size, the number of workers or the order tasks finish. Every configuration and every design
sees the same placements (common random numbers), so differences between designs are paired, not
noise of different draws.

Every task returns ``{"ok": True, "value": ...}`` or ``{"ok": False, "error": "one line"}``: a
failure is reported with its design and never stops the others.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker.files import atomic_write_json


def guarded(fn, *args) -> dict:
    """``fn(*args)`` as ``{"ok": True, "value": ...}``, or its exception as one line."""
    try:
        return {"ok": True, "value": fn(*args)}
    except Exception as err:  # noqa: BLE001 - any failure of one task is reported, not raised
        return {"ok": False, "error": " ".join(f"{type(err).__name__}: {err}".split())}


# ---- design-level predictions ----------------------------------------------------------------

def resolution(design) -> dict:
    """Sensing resolution through the design's pinhole camera (whisker.vision.geometry).

    ``px_per_deg``: marker travel in the image per degree of tilt at rest (central difference over
    +-0.5 deg, every whisker, mean); ``tip_mm_per_px``: the tip travel one pixel of marker travel
    stands for, l_u (pi/180) / px_per_deg (small tilts: tip travel = l_u sin(theta)).
    """
    from whisker.vision.geometry import project, tilted_marker_xyz

    a = project(design, tilted_marker_xyz(design, 0.5))
    b = project(design, tilted_marker_xyz(design, -0.5))
    px_per_deg = float(np.mean(np.hypot(*(a - b).T)))
    return {"px_per_deg": px_per_deg, "tip_mm_per_px": design.l_u * math.pi / 180.0 / px_per_deg}


def predictions(design) -> dict:
    """Tilt, tip travel and force at the grasp voltage (``actuation.voltage``), heating, resolution.

    From the coil calculator's report (``whisker coil report``: whisker.coil.report.build_report) at
    20 C: steady tilt (stable root of k_rot theta = I k(gap) lever cos theta), tip travel l_u sin(theta)
    (mm), force on the coil at the rest gap (mN), coil power (W), time to the first thermal limit at
    that voltage continuous (s; inf if the steady temperature stays below it) and the safe continuous
    duty. Raises ``whisker.drive.guard.RatingError`` when the grasp voltage is beyond the coil's rating or
    what the driver delivers, and when the driver's current rating is exceeded (the design's refusal).
    """
    from whisker.drive import guard
    from whisker.coil.report import build_report

    v = float(design.actuation.voltage)
    guard.volts_to_levels(design, [v])
    guard.check_driver(design)
    rep = build_report(design, v)
    eq = rep["deflection"]["equilibrium"]
    t_lim = rep["thermal"]["time_to_first_limit_s"]
    return {"volts": v, "tilt_deg": eq["theta_deg"], "stable": bool(eq["stable"]),
            "tip_travel_mm": design.l_u * math.sin(math.radians(eq["theta_deg"])),
            "force_rest_mN": rep["force"]["force_at_rest_mN"], "coil_power_W": rep["electrical"]["power_20C_W"],
            "time_to_limit_s": math.inf if t_lim is None else t_lim,
            "thermal_limit": rep["thermal"]["limit"], "safe_duty_pct": 100.0 * rep["thermal"]["safe_duty"],
            **resolution(design)}


def cad_verdict(design) -> dict:
    """The feasibility sweep's verdict (whisker.cad.verify.sweep): ``evaluate`` runs every solid and mesh
    check without writing files; the first failed check is the refusal."""
    from whisker.cad.build import evaluate

    t0 = time.perf_counter()
    failed = [c for c in evaluate(design) if not c.ok]
    return {"ok": not failed, "reason": failed[0].line() if failed else "",
            "seconds": time.perf_counter() - t0}


def design_task(design, cad: bool) -> dict:
    """Predictions, then (``cad``) the CAD checks; a refusal is a value (``refusal``), not a failure."""
    from whisker.drive.guard import RatingError

    try:
        pred = predictions(design)
    except RatingError as err:
        return {"refusal": f"drive: {err}"}
    out = {"refusal": "", "predictions": pred, "cad": "skipped"}
    if cad:
        v = cad_verdict(design)
        out["cad"] = "ok" if v["ok"] else "refused"
        out["cad_seconds"] = v["seconds"]
        if not v["ok"]:
            out["refusal"] = f"CAD: {v['reason']}"
    return out


# ---- grasp attempts ----------------------------------------------------------------------------

def grasp_task(design, scene, obj_index: int, active: tuple[int, ...], start: int, stop: int) -> dict:
    """Attempts ``start..stop-1`` of object ``obj_index`` with whiskers ``active`` driven: held or not,
    and the lift (mm) of each (see the module docstring for the seeds)."""
    from whisker.sim.experiments.paper import draw_placement, grasp_attempt

    obj = scene_objects(scene)[obj_index]
    rng = np.random.default_rng([scene.scene.seed, obj_index])
    places = [draw_placement(scene, design, rng) for _ in range(stop)][start:]
    t0 = time.perf_counter()
    held, lift = [], []
    for pl in places:
        a = grasp_attempt(scene, design, obj, list(active), placement=pl)
        held.append(bool(a.success))
        lift.append(float(a.lift_mm))
    return {"held": held, "lift_mm": lift, "seconds": time.perf_counter() - t0}


def scene_objects(scene) -> list:
    """The grasp experiment's objects in the order ``make sim-grasp`` uses (their index seeds them)."""
    names = scene.experiment.objects
    if not names:
        return list(scene.objects)
    by_name = {o.name: o for o in scene.objects}
    return [by_name[n] for n in names]


def scene_key(scene) -> str:
    """8 hex digits of the scene without its attempt count (more attempts reuse the finished ones)."""
    d = scene.model_dump(mode="json")
    d["experiment"].pop("attempts", None)
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:8]


# ---- tasks and their cache -----------------------------------------------------------------------

@dataclass(frozen=True)
class Task:
    """One unit of work; ``name`` is its cache file under the design digest's folder."""
    kind: str                        # "design" or "grasp"
    point: int                       # a grid point with this design (for messages)
    digest: str
    obj: int = -1
    active: tuple[int, ...] = ()
    start: int = 0
    stop: int = 0

    def name(self, seed: int, scene: str, cad: bool) -> str:
        if self.kind == "design":
            return f"design-{'cad' if cad else 'nocad'}.json"
        wh = "-".join(map(str, self.active))
        return f"grasp-{scene}-seed{seed}-obj{self.obj}-w{wh}-a{self.start}-{self.stop}.json"


class TaskCache:
    """Finished tasks as JSON files ``<root>/<design digest>/<task name>``, each written atomically,
    so a killed run leaves only whole files and a rerun resumes where it stopped."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    def path(self, digest: str, name: str) -> Path:
        return self.root / digest / name

    def get(self, digest: str, name: str):
        try:
            return _unjsonable(json.loads(self.path(digest, name).read_text())["value"])
        except (FileNotFoundError, ValueError, KeyError):
            return None           # missing, or not a finished task's file: run it again

    def put(self, digest: str, name: str, value) -> None:
        atomic_write_json(self.path(digest, name), {"value": _jsonable(value)})


def _jsonable(v):
    """inf -> "inf" (JSON has none); everything else unchanged."""
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    return v


def _unjsonable(v):
    """The reverse of :func:`_jsonable`: "inf" -> inf."""
    if v in ("inf", "-inf"):
        return float(v)
    if isinstance(v, dict):
        return {k: _unjsonable(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_unjsonable(x) for x in v]
    return v
