"""Magnetics benchmark: what accuracy costs for the coil-magnet force k(gap) (N/A).

Every fidelity level of whisker.coil.magnetics, on the default design's coil and magnet, over 60 gaps
from 0.2 to 10 mm (log-spaced), in one run:

- the converged reference: the filament-loop model with 96 Gauss nodes per dimension (its own
  change from 64 nodes is printed: the reference error bar);
- magpylib 6, independently: ``getB`` (its closed-form cylinder field at the coil's nodes) and
  ``getFT`` (the coil as a Collection of Circle loops cut into segments);
- point dipole, dipole in the coil's on-axis field, the filament model at 1..24 nodes, and the
  tabulated fast path.

Error = largest |k / k_ref - 1| over the gaps. Time per evaluation = best-of-5 wall time of ONE
vectorised call over all the gaps divided by the number of gaps (for the table: a call with 100 000
gaps, and separately the time of one scalar call including Python overhead). Target for the fast
path: <= 2 us per evaluation, <= 0.5 % error.

A second sweep repeats the filament convergence on the hardest geometry: magnet radius equal to the
coil's outer radius at a 0.2 mm gap (the loop-kernel's log singularity sits at the shared edge).

Writes benchmarks/results/magnetics.md, magnetics.csv and magnetics.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import best_time_s, machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402
from whisker.coil import magnetics as M  # noqa: E402
from whisker.design import default_design  # noqa: E402

TARGET_US, TARGET_ERR = 2.0, 0.005
GAPS = np.geomspace(0.2, 10.0, 60)
REF_NODES = 96


def main() -> None:
    from tqdm import tqdm

    d = default_design()
    g = M.geometry(d)
    ref = M.k_filament(g, GAPS, nodes=REF_NODES)
    ref_self = float(np.max(np.abs(M.k_filament(g, GAPS, nodes=64) / ref - 1)))
    M.force_table(g)  # build the table before timing it

    cases = [
        ("dipole", "point dipole - point dipole", None, lambda x: M.k_dipole(g, x)),
        ("dipole_field", "dipole in the coil's on-axis field", None, lambda x: M.k_dipole_field(g, x)),
    ]
    for n in (1, 2, 3, 4, 6, 8, 12, 24):
        cases.append(("filament", f"filament loops, {n} nodes", n, (lambda n: lambda x: M.k_filament(g, x, nodes=n))(n)))
    cases.append(("table", "tabulated filament, cubic spline (fast path)", None, lambda x: M.force_per_ampere_N(d, x)))
    cases.append(("magpylib", "magpylib getB, 16 nodes", 16, lambda x: M.k_magpylib(g, x, nodes=16, method="getB")))
    cases.append(("magpylib", "magpylib getFT, 8 nodes, 64 segments", 8,
                  lambda x: M.k_magpylib(g, x, nodes=8, meshing=64, method="getFT")))
    cases.append(("magpylib", "magpylib getFT, 8 nodes, 256 segments", 8,
                  lambda x: M.k_magpylib(g, x, nodes=8, meshing=256, method="getFT")))

    rows, curves = [], {}
    big = np.random.default_rng(0).uniform(0.2, 10.0, 100_000)
    for model, label, nodes, fn in tqdm(cases, desc="models", file=sys.stderr):
        k = np.asarray(fn(GAPS))
        err = np.abs(k / ref - 1)
        slow = model == "magpylib"
        t_vec = best_time_s(lambda: fn(GAPS), repeat=1 if slow else 5) / len(GAPS)
        if model in ("table", "dipole", "dipole_field"):
            t_vec = best_time_s(lambda: fn(big), repeat=5) / len(big)
        t_one = best_time_s(lambda: fn(np.array([2.5])), repeat=1 if slow else 5, number=1 if slow else 200)
        rows.append({"model": model, "variant": label, "nodes": nodes or "",
                     "max_rel_err": float(np.max(err)), "mean_rel_err": float(np.mean(err)),
                     "us_per_eval_vectorised": t_vec * 1e6, "us_per_scalar_call": t_one * 1e6})
        curves[label] = err

    # hardest geometry: magnet radius = coil outer radius, 0.2 mm gap
    gh = M.CoilMagnet(g.coil_inner_radius, g.coil_outer_radius, g.coil_length, g.turns,
                      g.coil_outer_radius, g.magnet_height, g.remanence)
    hard_gaps = np.array([0.0, 0.2, 1.0])
    hard_ref = M.k_filament(gh, hard_gaps, nodes=512)
    hard = []
    for n in (4, 8, 16, 32, 64, 128, 256):
        e = np.abs(M.k_filament(gh, hard_gaps, nodes=n) / hard_ref - 1)
        hard.append({"nodes": n, "err_gap_0": float(e[0]), "err_gap_0.2": float(e[1]), "err_gap_1": float(e[2])})

    write_csv("magnetics.csv", rows)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    colours = {"dipole": "C0", "dipole_field": "C1", "filament": "C2", "table": "C3", "magpylib": "C4"}
    for r in rows:
        e = max(r["max_rel_err"], 1e-15)
        a1.scatter(r["us_per_eval_vectorised"], e, color=colours[r["model"]], s=25)
        short = {"filament": f"n={r['nodes']}", "magpylib": r["variant"].replace("magpylib ", "").replace(" nodes", "n")
                 .replace(" segments", "s")}.get(r["model"], r["model"])
        a1.annotate(short, (r["us_per_eval_vectorised"], e), fontsize=6, xytext=(4, 2), textcoords="offset points")
    for m, c in colours.items():
        a1.scatter([], [], color=c, label=m)
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.axhline(TARGET_ERR, color="red", ls=":", lw=1)
    a1.axvline(TARGET_US, color="red", ls=":", lw=1)
    a1.set_xlabel("time per evaluation (vectorised), us")
    a1.set_ylabel("max relative error vs converged filament, 0.2-10 mm")
    a1.set_title("accuracy vs cost")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=7, loc="upper right")
    for label, e in curves.items():
        if "nodes" in label and "filament" in label and not label.endswith((" 3 nodes", " 6 nodes")):
            a2.loglog(GAPS, np.maximum(e, 1e-16), label=label, lw=1)
        elif not label.startswith(("filament", "magpylib getFT, 8 nodes, 64")):
            a2.loglog(GAPS, np.maximum(e, 1e-16), label=label, lw=1.5)
    a2.axhline(TARGET_ERR, color="red", ls=":", lw=1)
    a2.set_xlabel("gap, mm")
    a2.set_ylabel("relative error")
    a2.set_title("error against gap")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend(fontsize=6)
    save_figure(fig, "magnetics.png")
    plt.close(fig)

    fast = next(r for r in rows if r["model"] == "table")
    ok = fast["us_per_eval_vectorised"] <= TARGET_US and fast["max_rel_err"] <= TARGET_ERR
    mp = [r for r in rows if r["model"] == "magpylib"]
    lines = [
        "# Magnetics: coil-magnet force models, accuracy against cost",
        "",
        "Written by `benchmarks/bench_magnetics.py` (`make bench`). Machine: " + machine_line() + ".",
        "",
        f"Default design: coil bore {2 * g.coil_inner_radius:g} mm, OD {2 * g.coil_outer_radius:g} mm, "
        f"length {g.coil_length:g} mm, {g.turns:g} turns; magnet {2 * g.magnet_radius:g} x {g.magnet_height:g} mm, "
        f"Br {g.remanence:g} T. {len(GAPS)} gaps, 0.2-10 mm, log-spaced.",
        "",
        f"Reference: filament-loop model with {REF_NODES} Gauss nodes per dimension; its change from 64 "
        f"nodes is {ref_self:.1e}. magpylib (independent closed-form cylinder field) agrees with it to "
        + ", ".join(f"{r['max_rel_err']:.1e} ({r['variant']})" for r in mp) + ".",
        "",
        markdown_table(rows, ["model", "variant", "max_rel_err", "mean_rel_err", "us_per_eval_vectorised",
                              "us_per_scalar_call"],
                       {"max_rel_err": ".2e", "mean_rel_err": ".2e", "us_per_eval_vectorised": ".3g",
                        "us_per_scalar_call": ".3g"}),
        "",
        f"**Fast path** (`model=\"table\"`, the default of `force_per_ampere_N`): "
        f"{fast['us_per_eval_vectorised']:.3g} us per evaluation vectorised, max error "
        f"{fast['max_rel_err']:.1e}: target (<= {TARGET_US:g} us, <= {TARGET_ERR * 100:g} %) "
        f"{'MET' if ok else 'NOT MET'}. A scalar call costs {fast['us_per_scalar_call']:.3g} us (Python overhead).",
        "",
        "What the numbers say: the point dipole is cheap but wrong by a factor at millimetre gaps "
        "(the coil and magnet are as large as the gap); putting the magnet's dipole into the coil's exact "
        "on-axis field does not help much, because the magnet is wider than the coil. The filament model "
        "converges exponentially on this geometry (the magnet's edge lies outside the winding), so a few "
        "nodes are enough for sub-0.1 % accuracy, and the table interpolates the converged model for less "
        "than a microsecond per gap.",
        "",
        "## Hardest geometry: magnet radius = coil outer radius",
        "",
        "The loop kernel has a log singularity where a coil filament meets the magnet's edge; Gauss "
        "quadrature still converges, algebraically instead of exponentially (reference: 512 nodes).",
        "",
        markdown_table(hard, ["nodes", "err_gap_0", "err_gap_0.2", "err_gap_1"],
                       {"err_gap_0": ".2e", "err_gap_0.2": ".2e", "err_gap_1": ".2e"}),
        "",
        "![accuracy vs cost](magnetics.png)",
        "",
    ]
    write_text("magnetics.md", "\n".join(lines))
    print("\n".join(lines[:12 + len(rows)]))
    if not ok:
        raise SystemExit("magnetics fast path misses its target")


if __name__ == "__main__":
    main()
