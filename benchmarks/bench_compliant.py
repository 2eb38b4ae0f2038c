"""Compliant contact (issue 18): the grasp table rigid vs compliant vs the paper, the sensitivity of
each 8/4/2 cell to each material parameter across its published range, and the cost.

Writes benchmarks/results/sim_compliant.md and sim_compliant.csv (the table and the sensitivity
rows) atomically. Every run of an object sees the same placements as ``whisker sim grasp.toml``
(whisker.sim.experiments.paper.grasp_table's seeding: rng([seed, object index]) over the scene's objects), so the
rigid and compliant columns and every sensitivity row differ only by the contact model.

Run: .venv/bin/python benchmarks/bench_compliant.py   (make sim-sensitivity; part of make bench)
Env: COMPLIANT_ATTEMPTS (grasp table, default 100), SENS_ATTEMPTS (sensitivity rows, default 20).
Cost: simulated s per CPU s of one process (time.process_time, best of 3), one 8-whisker attempt
per object, compliant and rigid in the same run.
"""

from __future__ import annotations

import csv
import io
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from common import RESULTS, machine_line  # noqa: E402

from whisker.files import atomic_write_text  # noqa: E402
from whisker.sim import load_scene, scene_design  # noqa: E402
from whisker.sim.experiments import paper  # noqa: E402
from whisker.sim.effects.plan import plan  # noqa: E402
from whisker.coil.kinematics import whisker_body  # noqa: E402
from whisker.sim.materials import SWEPT  # noqa: E402
from whisker.sim.scene import scene_with_overrides  # noqa: E402
from whisker.sim.simulate import simulate  # noqa: E402

SCENE = ROOT / "software" / "whisker" / "sim" / "scenes" / "grasp.toml"
ATTEMPTS = int(os.environ.get("COMPLIANT_ATTEMPTS", "100"))
SENS_ATTEMPTS = int(os.environ.get("SENS_ATTEMPTS", "20"))


def placements(scene, design, n: int) -> dict[str, list]:
    """The grasp table's placements: rng([seed, index of the object in the scene's experiment objects])."""
    out = {}
    for oi, o in enumerate(paper.experiment_objects(scene)):
        rng = np.random.default_rng([scene.scene.seed, oi])
        out[o.name] = [paper.draw_placement(scene, design, rng) for _ in range(n)]
    return out


def cells(scene, design, body, names, places, progress=""):
    """{object: [held list per configuration]} for the objects `names`, at the given placements."""
    objs = {o.name: o for o in scene.objects}
    cfgs = paper.configurations(scene, design)
    out = {}
    for name in names:
        out[name] = [[paper.grasp_attempt(scene, design, objs[name], c, body=body, placement=pl).success
                      for pl in places[name]] for c in cfgs]
        print(f"  {progress} {name}: " + " / ".join(f"{100 * np.mean(h):.0f}" for h in out[name]), flush=True)
    return out


def pct(h) -> float:
    return 100.0 * float(np.mean(h))


def main() -> None:
    base = load_scene(SCENE)
    design = scene_design(base)
    body = whisker_body(design)
    rigid = scene_with_overrides(base, ["fidelity.compliance=off"])
    names = [o.name for o in paper.experiment_objects(base)]
    lines = [f"# Compliant contact: grasp table, sensitivity, cost\n",
             f"Machine: {machine_line()}. Scene `grasp.toml` (dt {base.scene.timestep:g} s, seed {base.scene.seed}); "
             "`whisker sim grasp.toml --explain` says which pairs are compliant (the experiment scene, all five "
             "objects):\n",
             "```\n" + plan(base, design).effect("compliance").reason + "\n```\n"]
    rows = []

    # --- the grasp table, rigid vs compliant vs paper ---------------------------------------------
    places = placements(base, design, ATTEMPTS)
    print(f"grasp table, {ATTEMPTS} attempts per cell", flush=True)
    t_r = cells(rigid, design, body, names, places, "rigid")
    t_c = cells(base, design, body, names, places, "compliant")
    from whisker.sim.experiments.repeat import PAPER_GRASP, PAPER_GRASP_TOTAL
    lines += [f"## Grasp table: {ATTEMPTS} attempts per cell, the same placements in every column\n",
              "Each cell: rigid / compliant (Wilson 95 % interval of the compliant rate) / paper (%); "
              "'changed': placements whose outcome differs between the two models.\n",
              "| object | 8 whiskers | 4 whiskers | 2 whiskers | changed (8/4/2) |", "| --- | --- | --- | --- | --- |"]
    tot_r, tot_c = np.zeros(3), np.zeros(3)
    for name in names:
        cs = []
        for k in range(3):
            r, c = pct(t_r[name][k]), pct(t_c[name][k])
            lo, hi = paper.wilson_interval(int(sum(t_c[name][k])), ATTEMPTS)
            cs.append(f"{r:.0f} / {c:.0f} [{lo:.0f}-{hi:.0f}] / {PAPER_GRASP[name][k]}")
            tot_r[k] += r / len(names)
            tot_c[k] += c / len(names)
            rows.append({"kind": "table", "object": name, "whiskers": (8, 4, 2)[k], "material": "", "parameter": "",
                         "value": "", "rigid_pct": r, "compliant_pct": c, "paper_pct": PAPER_GRASP[name][k],
                         "attempts": ATTEMPTS})
        ch = "/".join(str(sum(a != b for a, b in zip(t_r[name][k], t_c[name][k]))) for k in range(3))
        lines.append(f"| {name} | " + " | ".join(cs) + f" | {ch} |")
    lines.append("| total | " + " | ".join(f"{tot_r[k]:.0f} / {tot_c[k]:.0f} / {PAPER_GRASP_TOTAL[k]}" for k in range(3))
                 + " | |\n")
    order = all(a > b for a, b in zip(tot_c, tot_c[1:]))
    lines.append(f"Totals ordered 8 > 4 > 2 with compliant contact: {'yes' if order else 'NO'}.\n")

    # --- sensitivity -----------------------------------------------------------------------------
    sp = placements(base, design, SENS_ATTEMPTS)
    used = {o.name: o.material for o in base.objects if o.name in names}
    cap = base.contact.tip_material
    lines += [f"## Sensitivity: each parameter at the ends of its published range ({SENS_ATTEMPTS} attempts per cell)\n",
              "8 / 4 / 2 whiskers (%), the same placements in every row; 'nominal' is the scene's value. "
              "An object's material moves only that object; the tip cap moves every object.\n",
              "| material (objects) | parameter | value | " + " | ".join(names) + " |",
              "| --- | --- | --- |" + " --- |" * len(names)]
    print(f"sensitivity, {SENS_ATTEMPTS} attempts per cell", flush=True)
    nominal = cells(base, design, body, names, sp, "nominal")
    lines.append("| (scene) | nominal | | " + " | ".join(" / ".join(f"{pct(h):.0f}" for h in nominal[n]) for n in names) + " |")
    for mat_name in [cap, *[used[n] for n in names]]:
        if mat_name is None:
            continue
        mat = base.materials[mat_name]
        affected = names if mat_name == cap else [n for n in names if used[n] == mat_name]
        for par, rng_field in SWEPT.items():
            rng = getattr(mat, rng_field)
            if getattr(mat, par) is None or rng is None:
                continue
            if par == "friction" and all(o.friction is not None for o in base.objects if o.name in affected):
                continue                          # every object has its own pair value: the cap's is unused
            for v in rng:
                s = scene_with_overrides(base, [f"materials.{mat_name}.{par}={v!r}"])
                res = cells(s, design, body, affected, sp, f"{mat_name}.{par}={v:g}")
                row = []
                for n in names:
                    row.append(" / ".join(f"{pct(h):.0f}" for h in res[n]) if n in res else "")
                    for k, h in enumerate(res.get(n, [])):
                        rows.append({"kind": "sensitivity", "object": n, "whiskers": (8, 4, 2)[k], "material": mat_name,
                                     "parameter": par, "value": v, "rigid_pct": "", "compliant_pct": pct(h),
                                     "paper_pct": PAPER_GRASP[n][k], "attempts": SENS_ATTEMPTS})
                lines.append(f"| {mat_name} ({'all' if mat_name == cap else ', '.join(affected)}) | {par} | {v:g} | "
                             + " | ".join(row) + " |")
    lines.append("")

    # --- cost ------------------------------------------------------------------------------------
    lines += ["## Cost: one 8-whisker attempt per object, simulated s per CPU s (best of 3, one process)\n",
              "| object | rigid | compliant |", "| --- | --- | --- |"]
    tot = {"rigid": [0.0, 0.0], "compliant": [0.0, 0.0]}
    for o in paper.experiment_objects(base):
        out = []
        for label, sc in (("rigid", rigid), ("compliant", base)):
            s = paper.grasp_scene(sc, o, list(range(design.whiskers.count)), level=paper.grasp_level(design))
            p = plan(s, design)
            best = float("inf")
            for _ in range(3):
                t0 = time.process_time()
                r = simulate(s, design, p, body=body)
                best = min(best, time.process_time() - t0)
            tot[label][0] += float(r.t_s[-1])
            tot[label][1] += best
            out.append(f"{r.t_s[-1] / best:.1f}x")
        lines.append(f"| {o.name} | " + " | ".join(out) + " |")
    lines.append("| all five | " + " | ".join(f"{tot[k][0] / tot[k][1]:.1f}x" for k in ("rigid", "compliant"))
                 + " |\n")
    lines.append("Target: rigid scenes >= 20x real time on one core.\n")
    atomic_write_text(RESULTS / "sim_compliant.md", "\n".join(lines))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(RESULTS / "sim_compliant.csv", buf.getvalue())
    print("\n".join(lines))


if __name__ == "__main__":
    main()
