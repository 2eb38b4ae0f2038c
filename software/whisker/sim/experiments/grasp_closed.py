"""Open loop against closed loop on the same simulated grasps (`make sim-grasp-closed`).

For every object of the grasp scene, every configuration (8/4/2 whiskers) and the same `attempts`
placements (drawn as in whisker.sim.experiments.paper.grasp_table), the paper's open-loop protocol and the
closed-loop controller (whisker.sensing.grasp_control) each run on `whisker.sim.experiments.closed_loop.SimGraspRig`.
Per cell: success (Wilson 95 % interval), wins-losses of closed vs open on the same placements with
the exact two-sided McNemar p-value (scipy.stats.binomtest), coil energy per attempt and per
successful grasp, peak coil temperature, time to grip (start to lift), and the paired Wilcoxon
signed-rank p-values (scipy.stats.wilcoxon) for energy and peak temperature. Fail-safe aborts
(contact before actuation, lost marker, dropped frames) are counted.
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np

from whisker.sim.experiments.closed_loop import OpenLoopController, SimGraspRig, free_closing_px, run_grasp
from whisker.sim.experiments.paper import configurations, draw_placement, experiment_objects, wilson_interval


def _mcnemar(a: list[bool], b: list[bool]) -> tuple[int, int, float]:
    """(b wins, a wins, exact two-sided p) on paired outcomes."""
    from scipy.stats import binomtest

    wins = sum(1 for x, y in zip(a, b) if y and not x)
    losses = sum(1 for x, y in zip(a, b) if x and not y)
    p = 1.0 if wins + losses == 0 else float(binomtest(wins, wins + losses, 0.5).pvalue)
    return wins, losses, p


def _wilcoxon(x, y) -> float:
    from scipy.stats import wilcoxon

    d = np.asarray(y, float) - np.asarray(x, float)
    if d.size < 2 or np.all(d == 0):
        return 1.0
    return float(wilcoxon(x, y, zero_method="zsplit").pvalue)


def _one_grasp(scene, design, obj, cfg, placement, k: int, mode: str, fps: float, body, params, open_guard: bool,
               locate_noise=None):
    """One attempt of `mode` ("open" or "closed") at `placement` (seed k): a GraspRun. With
    `locate_noise`, a closed-loop run carries `locate`: where the object sits along the holding whiskers
    at the grip (whisker.sim.experiments.grasp_locate)."""
    from whisker.drive.guard import ThermalGuard
    from whisker.sensing.grasp_control import GraspController

    n = design.whiskers.count
    rig = SimGraspRig(scene, design, obj, cfg, placement, fps=fps, seed=k, body=body)
    ctl = (OpenLoopController(n, cfg, rig.params(),
                              guard=ThermalGuard(design, clock=lambda: 0.0) if open_guard else None)
           if mode == "open" else
           GraspController(n, cfg, rig.params(**(params or {})), free_closing_px(design),
                           guard=ThermalGuard(design, clock=lambda: 0.0)))
    hook = None
    if locate_noise is not None and mode == "closed":
        from whisker.sim.experiments.grasp_locate import GripLocator

        hook = GripLocator(design, locate_noise, seed=k)
    r = run_grasp(rig, ctl, hold_height_mm=scene.experiment.hold_height, on_frame=hook)
    if hook is not None:
        from whisker.sim.experiments.grasp_locate import summary

        r.locate = summary(hook.rows())
    r.process_ms = [float(np.mean(r.process_ms))] if r.process_ms else []     # the mean is all the table keeps
    return r


def closed_loop_table(scene, design, *, attempts: int, fps: float = 15.0, configs=None, objects=None,
                      progress=None, params: dict | None = None, open_guard: bool = True, n_jobs: int = 1,
                      locate_noise=None) -> dict:
    """See the module doc. `open_guard` (default): the open loop's levels pass through the same thermal
    guard as the closed loop's, as on the hardware, whose actuator always applies one; False: the bare
    paper protocol (a simulator-only reference). `n_jobs`: joblib worker processes for the attempts
    (every attempt runs on simulated time, so the table is the same for any count). `locate_noise`: a
    tracker tilt-error bank (rad, (F, 2)); when given, every run gets a column "locate": for closed-loop
    runs where the object sits along the holding whiskers at the grip (whisker.sim.experiments.grasp_locate)."""
    from joblib import Parallel, delayed

    from whisker.coil.kinematics import whisker_body

    objs = experiment_objects(scene)
    if not objs:
        raise ValueError("the scene has no objects to grasp (add [[objects]] tables; see "
                         "whisker/sim/scenes/grasp.toml)")
    if objects:
        objs = [o for o in objs if o.name in objects]
        if not objs:
            raise ValueError(f"none of the objects {objects} is in the scene")
    cfgs = configs or configurations(scene, design)
    body = whisker_body(design)
    rows, runs = [], []
    cells = []
    for oi, o in enumerate(objs):
        rng = np.random.default_rng([scene.scene.seed, oi])
        places = [draw_placement(scene, design, rng) for _ in range(attempts)]
        cells += [(o, cfg, places) for cfg in cfgs]
    jobs = [(o, cfg, pl, k, mode) for o, cfg, places in cells for k, pl in enumerate(places) for mode in ("open", "closed")]
    results = []
    gen = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_one_grasp)(scene, design, o, cfg, pl, k, mode, fps, body, params, open_guard, locate_noise)
        for o, cfg, pl, k, mode in jobs)
    for j, r in enumerate(gen):
        results.append(r)
        if progress and j % 2 == 1:
            progress((j + 1) / len(jobs))
    it = iter(results)
    for o, cfg, places in cells:
        res = {"open": [], "closed": []}
        for k in range(len(places)):
            for mode in ("open", "closed"):
                r = next(it)
                res[mode].append(r)
                runs.append({"object": o.name, "whiskers": len(cfg), "placement": k, "mode": mode,
                             "success": r.success, "lift_mm": round(r.lift_mm, 2), "energy_J": round(r.energy_J, 4),
                             "peak_C": round(r.peak_C, 2),
                             "time_to_grip_s": None if r.time_to_grip_s is None else round(r.time_to_grip_s, 3),
                             "outcome": r.outcome, "frames": r.frames,
                             "process_ms_mean": round(float(np.mean(r.process_ms)), 3) if r.process_ms else 0.0})
                if locate_noise is not None:
                    runs[-1]["locate"] = getattr(r, "locate", "")
        so = [r.success for r in res["open"]]
        sc = [r.success for r in res["closed"]]
        w, l, p = _mcnemar(so, sc)
        eo = [r.energy_J for r in res["open"]]
        ec = [r.energy_J for r in res["closed"]]
        po = [r.peak_C for r in res["open"]]
        pc = [r.peak_C for r in res["closed"]]
        both = [i for i in range(attempts) if so[i] and sc[i]]
        row = {"object": o.name, "mass_g": o.mass, "whiskers": len(cfg), "attempts": attempts,
               "open_success": int(sum(so)), "closed_success": int(sum(sc)),
               "open_ci": wilson_interval(int(sum(so)), attempts), "closed_ci": wilson_interval(int(sum(sc)), attempts),
               "closed_wins": w, "closed_losses": l, "mcnemar_p": p,
               "open_energy_J": float(np.mean(eo)), "closed_energy_J": float(np.mean(ec)),
               "open_energy_per_success_J": float(np.sum(eo) / sum(so)) if sum(so) else math.inf,
               "closed_energy_per_success_J": float(np.sum(ec) / sum(sc)) if sum(sc) else math.inf,
               "energy_both_held_open_J": float(np.mean([eo[i] for i in both])) if both else math.nan,
               "energy_both_held_closed_J": float(np.mean([ec[i] for i in both])) if both else math.nan,
               "energy_p": _wilcoxon(eo, ec),
               "open_peak_C": float(np.max(po)), "closed_peak_C": float(np.max(pc)),
               "peak_p": _wilcoxon(po, pc),
               "open_grip_s": float(np.mean([r.time_to_grip_s for r in res["open"] if r.time_to_grip_s is not None] or [math.nan])),
               "closed_grip_s": float(np.mean([r.time_to_grip_s for r in res["closed"] if r.time_to_grip_s is not None] or [math.nan])),
               "aborts": sum(1 for r in res["closed"] if any(e[1] == "abort" for e in r.events)),
               "missed": sum(1 for r in res["closed"] if r.outcome.startswith("missed")),
               "regrips": sum(int(any(e[1] == "regrip" for e in r.events)) for r in res["closed"])}
        rows.append(row)
    return {"fps": fps, "attempts": attempts, "rows": rows, "runs": runs, "open_guard": open_guard}


def _fmt_e(v: float) -> str:
    return "-" if not math.isfinite(v) else f"{v:.2f}"


def closed_loop_markdown(tab: dict) -> str:
    """The table beside the paper's open-loop numbers (whisker.sim.experiments.repeat.PAPER_GRASP)."""
    from whisker.sim.experiments.repeat import PAPER_GRASP

    which = ("both through the same thermal guard" if tab.get("open_guard", True)
             else "open loop = the bare paper protocol without a guard, closed loop through the thermal guard")
    out = [f"Open loop vs closed loop ({which}), {tab['attempts']} common placements per cell, "
           f"camera {tab['fps']:g} frames/s. "
           "success %: sim open / sim closed / paper (open loop); W-L: placements closed holds and open drops, and "
           "the reverse (exact McNemar p); energy: coil Joule heat per attempt and per successful grasp (J), "
           "paired Wilcoxon p per attempt; peak: hottest coil (C); grip: start to lift (s); aborts: fail-safe stops.",
           "",
           "| object | whiskers | success % open / closed / paper | W-L (p) | J/attempt open / closed (p) | "
           "J/success open / closed | peak C open / closed | grip s open / closed | aborts |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in tab["rows"]:
        col = {8: 0, 4: 1, 2: 2}.get(r["whiskers"])
        paper = PAPER_GRASP[r["object"]][col] if r["object"] in PAPER_GRASP and col is not None else None
        n = r["attempts"]
        out.append(f"| {r['object']} ({r['mass_g']:g} g) | {r['whiskers']} | {100 * r['open_success'] / n:.0f} / "
                   f"{100 * r['closed_success'] / n:.0f} / {'-' if paper is None else f'{paper:g}'} | "
                   f"{r['closed_wins']}-{r['closed_losses']} ({r['mcnemar_p']:.2g}) | "
                   f"{r['open_energy_J']:.2f} / {r['closed_energy_J']:.2f} ({r['energy_p']:.2g}) | "
                   f"{_fmt_e(r['open_energy_per_success_J'])} / {_fmt_e(r['closed_energy_per_success_J'])} | "
                   f"{r['open_peak_C']:.1f} / {r['closed_peak_C']:.1f} | {r['open_grip_s']:.2f} / {r['closed_grip_s']:.2f} | "
                   f"{r['aborts']} |")
    so = sum(r["open_success"] for r in tab["rows"])
    sc = sum(r["closed_success"] for r in tab["rows"])
    eo = sum(r["open_energy_J"] * r["attempts"] for r in tab["rows"])
    ec = sum(r["closed_energy_J"] * r["attempts"] for r in tab["rows"])
    nt = sum(r["attempts"] for r in tab["rows"])
    out.append(f"| **all** | | {100 * so / nt:.0f} / {100 * sc / nt:.0f} / | | {eo / nt:.2f} / {ec / nt:.2f} | "
               f"{_fmt_e(eo / so if so else math.inf)} / {_fmt_e(ec / sc if sc else math.inf)} | | | "
               f"{sum(r['aborts'] for r in tab['rows'])} |")
    return "\n".join(out) + "\n" + _totals_by_count(tab["rows"])


def _totals_by_count(rows) -> str:
    """Success per whisker count over the objects (the mean of the objects' rates, as the paper's
    totals), open / closed, beside the paper's open-loop totals."""
    from whisker.sim.experiments.repeat import PAPER_GRASP_TOTAL

    counts = sorted({r["whiskers"] for r in rows}, reverse=True)
    cells = []
    for c in counts:
        rs = [r for r in rows if r["whiskers"] == c]
        o = 100 * float(np.mean([r["open_success"] / r["attempts"] for r in rs]))
        k = 100 * float(np.mean([r["closed_success"] / r["attempts"] for r in rs]))
        col = {8: 0, 4: 1, 2: 2}.get(c)
        paper = f"{PAPER_GRASP_TOTAL[col]:g}" if col is not None and col < len(PAPER_GRASP_TOTAL) else "-"
        cells.append(f"{c} whiskers {o:.0f} / {k:.0f} / {paper}")
    return "\nTotals over the objects, success % open / closed / paper: " + "; ".join(cells) + ".\n"


def closed_loop_csv(tab: dict) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(tab["runs"][0]))
    w.writeheader()
    w.writerows(tab["runs"])
    return buf.getvalue()


def closed_loop_json(tab: dict) -> str:
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, tuple):
            return [clean(x) for x in v]
        return v
    return json.dumps({"fps": tab["fps"], "attempts": tab["attempts"], "open_guard": tab.get("open_guard", True),
                       "rows": [{k: clean(v) for k, v in r.items()} for r in tab["rows"]]}, indent=1)
