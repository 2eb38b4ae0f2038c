"""Membrane benchmark: what accuracy costs for the membrane's tilt stiffness (N mm/rad).

The finite-element model of whisker.mechanics.membrane on the default design's membrane, refined
from a 4 mm to a 1.5 mm mesh (triangle edge; the rods' circles at a quarter of it, one prism layer
per half mesh size through the 3 mm, at least two). For each mesh: unknowns, the per-whisker stiffness
with every whisker driven (the design's value) and with one driven, the change from the previous
mesh, the error against the finest mesh, and the wall time of one solve (assembly, factorisation,
condensation). The result must converge: under 2 % change at the last refinement.

Then, at the default mesh: the bulk modulus's influence (K = 100 mu against the data file's 1 GPa),
the closed-form check (a thin clamped plate with a rigid hub, Kirchhoff, as in tests/test_membrane.py),
the coupling matrix of the default design, and the paper's sensor (16 mm membrane, its 600-turn 7 ohm
coil, 3 V) through whisker.coil's equilibrium beside the authors' ~15 deg.

Writes benchmarks/results/membrane.md and membrane.csv. ``--reuse`` takes the refinement rows from the
last membrane.csv (the finest mesh's solve takes minutes) and reruns everything else.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import RESULTS, machine_line, markdown_table, write_csv, write_text  # noqa: E402
from whisker.design import default_design  # noqa: E402
from whisker.mechanics import membrane as M  # noqa: E402
from whisker.mechanics.materials import silicone_for  # noqa: E402

SIZES = (4.0, 3.0, 2.5, 2.0, 1.5)
# the paper's sensor: its membrane and coil, the gap this project assumed for it, and no end stop
PAPER = ("membrane.inscribed_radius=16", "coil.turns=600", "coil.resistance=7", "actuation.gap=2.5",
         "actuation.end_stop=false")


def paper_rows(d_default) -> list[dict]:
    """Tilt at 3 V for the paper's sensor and the default design, every whisker or one driven."""
    from whisker.coil import current_A, equilibrium

    rows = []
    for label, sets in (("paper's sensor: 16 mm membrane, 600 turns, 7 ohm, 2.5 mm gap, no stop", PAPER),
                        ("default design: 19.5 mm membrane, 370 turns (bobbin)", ())):
        d = default_design(*sets) if sets else d_default
        i = current_A(d, d.actuation.voltage)
        for mode, k in (("all driven", M.rotational_stiffness_Nmm_per_rad(d)),
                        ("one driven", M.single_whisker_stiffness_Nmm_per_rad(d))):
            eq = equilibrium(d, i, stiffness_Nmm_per_rad=k)
            v_pull = eq.pull_in_current_A * d.coil.resistance if eq.pull_in_current_A else math.inf
            if eq.at_stop:   # the stop holds it: say so, and where the free whisker would have snapped
                free = equilibrium(default_design(*sets, "actuation.end_stop=false"), i, stiffness_Nmm_per_rad=k)
                fv = free.pull_in_current_A * d.coil.resistance if free.pull_in_current_A else math.inf
                tilt = f"{eq.theta_deg:.1f} on the end stop (without it: pull-in {fv:.2f} V)"
            else:
                tilt = f"{eq.theta_deg:.1f}" if eq.stable else f"snaps (pull-in {v_pull:.2f} V)"
            rows.append({"sensor": label, "whiskers driven": mode, "k_Nmm_per_rad": round(k, 3),
                         "tilt_at_3V_deg": tilt, "authors_deg": "~15"})
    from whisker.coil import fit_stiffness
    for turns in (600, 413):   # the paper's turns, and the turns its 7 ohm implies (docs/coil.md)
        d = default_design(*PAPER[:1], f"coil.turns={turns}", *PAPER[2:])
        k = fit_stiffness(d, [(3.0, 15.0)])["rotational_stiffness_Nmm_per_rad"]
        rows.append({"sensor": f"paper's sensor with {turns} turns, 7 ohm", "whiskers driven": "-",
                     "k_Nmm_per_rad": round(k, 3), "tilt_at_3V_deg": "15.0: the k the authors' frame implies "
                     "(fit-stiffness 3:15, a comparison, not used)", "authors_deg": "~15"})
    return rows


def main() -> None:
    d = default_design()
    g = M.MembraneGeometry.from_design(d)
    mat = silicone_for(d.membrane.material)
    mu, K = mat.shear_modulus_MPa, mat.bulk_modulus_MPa
    rows, prev = [], None
    reuse = "--reuse" in sys.argv and (RESULTS / "membrane.csv").is_file()
    if reuse:  # the refinement rows of the last run (its solves take minutes); the checks below rerun
        import csv
        rows = [{k: (float(v) if k not in ("layers", "unknowns", "elements") else int(v)) if v != "" else None
                 for k, v in r.items()} for r in csv.DictReader((RESULTS / "membrane.csv").open())]
        if tuple(r["mesh_mm"] for r in rows) != SIZES:
            rows, reuse = [], False
    for h in (() if reuse else SIZES):
        print(f"mesh {h} mm ...", flush=True)
        r = M.tilt_stiffness(g, mu, K, h)
        rows.append({"mesh_mm": h, "layers": r.layers, "unknowns": r.dofs, "elements": r.elements,
                     "k_all_Nmm_per_rad": r.all_driven_Nmm_per_rad, "k_one_Nmm_per_rad": r.single_Nmm_per_rad,
                     "seconds": round(r.seconds, 2),
                     "change_pct": None if prev is None else 100 * (r.all_driven_Nmm_per_rad / prev - 1)})
        prev = r.all_driven_Nmm_per_rad
    fine = rows[-1]
    prev = None
    for row in rows:
        row["change_pct"] = None if prev is None else 100 * (row["k_all_Nmm_per_rad"] / prev - 1)
        prev = row["k_all_Nmm_per_rad"]
    for row in rows:
        row["err_all_pct"] = 100 * (row["k_all_Nmm_per_rad"] / fine["k_all_Nmm_per_rad"] - 1)
        row["err_one_pct"] = 100 * (row["k_one_Nmm_per_rad"] / fine["k_one_Nmm_per_rad"] - 1)
    write_csv("membrane.csv", rows)
    last = abs(rows[-1]["change_pct"])
    timing = ("refinement rows from the previous run (`--reuse`)" if reuse else "refinement rows from this run")
    assert last < 2.0, f"not converged: {last:.2f} % change at the last refinement"

    h0 = M.DEFAULT_MESH_SIZE_MM
    base_layers = M.mesh_layers(g.thickness, h0)
    thick_layers = M.tilt_stiffness(g, mu, K, h0, layers=2 * base_layers)
    soft_bulk = M.tilt_stiffness(g, mu, 100 * mu, h0).all_driven_Nmm_per_rad
    nominal = M.tilt_stiffness(g, mu, K, h0).all_driven_Nmm_per_rad

    from whisker.mechanics.fem import Inclusion, Plate, solve
    from whisker.mechanics.plate import hub_tilt_stiffness
    a, b, t, E, nu = 10.0, 2.5, 0.25, 1.0, 0.3
    outline = tuple((a * math.cos(x), a * math.sin(x)) for x in np.linspace(0, 2 * np.pi, 96, endpoint=False))
    t0 = time.perf_counter()
    fem_k = solve(Plate(outline, t, (Inclusion(0.0, 0.0, b),), None), E / (2 * (1 + nu)), E / (3 * (1 - 2 * nu)),
                  1.5, 0.5, 1, axes=[(0.0, 1.0, 0.0)]).stiffness[0, 0]
    plate_s = time.perf_counter() - t0
    kirchhoff = hub_tilt_stiffness(a, b, t, E, nu)

    Kd = M.stiffness_matrix(d)
    C = M.coupling(d)
    n = len(Kd)
    kmat = markdown_table([{"whisker": i, **{str(j): f"{Kd[i, j]:.4f}" for j in range(n)}} for i in range(n)],
                          ["whisker", *map(str, range(n))])
    cmat = " | ".join(f"{C[j, 0]:.3f}" for j in range(n))

    cols = ["mesh_mm", "layers", "unknowns", "elements", "k_all_Nmm_per_rad", "k_one_Nmm_per_rad", "change_pct",
            "err_all_pct", "err_one_pct", "seconds"]
    fmt = {"k_all_Nmm_per_rad": ".4f", "k_one_Nmm_per_rad": ".4f", "err_all_pct": "+.2f", "err_one_pct": "+.2f",
           "seconds": ".1f"}
    for row in rows:
        row["change_pct"] = "" if row["change_pct"] in (None, "") else f"{float(row['change_pct']):+.2f}"
    text = f"""# Membrane stiffness: accuracy against cost

{machine_line()}. `benchmarks/bench_membrane.py`; model `whisker.mechanics.membrane` (scikit-fem, P2-P1
mixed tetrahedra over a Triangle mesh, the rods rigid, the rim glued on the seat ledge outside
{g.clamp_radius:g} mm). Default design: {d.membrane.sides}-gon membrane {g.inscribed_radius:g} mm, {g.thickness:g} mm
thick, {n} rods of {g.rod_diameter:g} mm on {g.ring_radius:g} mm; {mat.name}: mu = {mu:.4f} MPa (neo-Hookean from the
datasheet's 100 % modulus), K = {K:g} MPa (nu = {mat.poisson_ratio:.5f}).

k_all: per-whisker stiffness with every whisker driven by the same moment (the design's value);
k_one: one whisker driven, its neighbours free. Errors against the finest mesh ({fine['mesh_mm']:g} mm); {timing}.
Seconds are wall time on a machine shared with other jobs (load ~6 per core when measured): compare
them with each other, not with an idle machine.

{markdown_table(rows, cols, fmt)}

Converged: {last:.2f} % change at the last refinement (limit 2 %). Default mesh
(`DEFAULT_MESH_SIZE_MM`): **{h0:g} mm**, {next(r['err_all_pct'] for r in rows if r['mesh_mm'] == h0):+.2f} % from the finest
mesh in {next(r['seconds'] for r in rows if r['mesh_mm'] == h0):.1f} s, run once per membrane geometry and then read
from the cache (`~/.cache/whisker/membrane/`) or the shipped table (`hw/materials/membrane_stiffness.json`).

| check | value |
| --- | --- |
| bulk modulus K = 100 mu instead of {K:g} MPa (default mesh) | k_all {soft_bulk:.4f} against {nominal:.4f} ({100 * (soft_bulk / nominal - 1):+.2f} %) |
| {2 * base_layers} prism layers instead of {base_layers} (default mesh; through-thickness refinement) | k_all {thick_layers.all_driven_Nmm_per_rad:.4f} against {nominal:.4f} ({100 * (thick_layers.all_driven_Nmm_per_rad / nominal - 1):+.2f} %), k_one {thick_layers.single_Nmm_per_rad:.4f} ({thick_layers.seconds:.1f} s) |
| closed form: plate r = {a:g} mm clamped, rigid hub r = {b:g} mm, t = {t:g} mm, nu = {nu:g} (Kirchhoff, `whisker.mechanics.plate`) | FEM / closed form = {fem_k / kirchhoff:.4f} ({plate_s:.1f} s) |

## Coupling (default design)

Tilt of each whisker per tilt of whisker 0 when only whisker 0 is driven (`whisker.mechanics.membrane.coupling`):

| whisker | {' | '.join(map(str, range(n)))} |
| --- | {' | '.join(['---'] * n)} |
| tilt / tilt of 0 | {cmat} |

Stiffness matrix K (N mm/rad; M = K theta, retraction positive):

{kmat}

## The paper's sensor beside the authors' ~15 deg at 3 V

Whisker tilt at 3 V at the coil from whisker.coil's equilibrium (its force table, the gap closing as the
whisker tilts) with the model's stiffness; not a fit.

{markdown_table(paper_rows(d), ["sensor", "whiskers driven", "k_Nmm_per_rad", "tilt_at_3V_deg", "authors_deg"])}
"""
    write_text("membrane.md", text)
    print(text)


if __name__ == "__main__":
    main()
