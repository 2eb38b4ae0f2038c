"""Thermal benchmark: the lumped coil, the thermal network and the finite-element conduction model side
by side, and the paper's grasp protocol through the guard.

1. Network vs finite elements (whisker.coil.thermal_fe, scikit-fem) at three grid sizes: volume-mean
   temperature rise of the winding, the bobbin's rod tab, the rod in the membrane and the membrane at 2 s
   and at steady state, 1.5 W in one winding (about 3 V on the wound coil), every free face convecting
   to the ambient (ThermalNetwork(exchange=False), the same boundary conditions). Grid convergence of
   the FE model (reference: the finest grid).
2. Accuracy vs cost: the one-node lumped model (whisker.coil.thermal.CoilThermal), the network and the
   FE model on the winding's rise (error against the finest FE grid), and the cost of one guard update
   of 8 coils (20 ms). The network's backward-Euler step against scipy's solve_ivp (Radau, rtol 1e-10).
3. The paper's protocol (whisker.drive.thermal_protocol: close 0.3 s, lift 30 mm at 60 mm/s, hold 2 s,
   release) on all 8 coils at the grasp level (3 V) through the guard: every material's peak temperature
   and its limit, with the default post-cured resin bobbin and with a bobbin left uncured ("green"),
   at full holding level and at the fitted holding level.

Writes benchmarks/results/thermal.md and thermal.csv (and thermal_protocol.png).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import best_time_s, machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402
from whisker.coil import thermal as lumped  # noqa: E402
from whisker.coil.thermal_fe import ConductionFE, network_means  # noqa: E402
from whisker.coil.thermal_network import ThermalNetwork  # noqa: E402
from whisker.design import default_design  # noqa: E402
from whisker.drive.guard import ThermalGuard, volts_to_levels  # noqa: E402
from whisker.drive.thermal_protocol import Protocol, fit_hold_level, run_protocol  # noqa: E402

POWER_W = 1.5
GRIDS = (0.3, 0.2, 0.15)
PARTS = ("winding", "bobbin", "rod", "membrane")


def fe_rows(d):
    out, fe_by_h = [], {}
    for h in GRIDS:
        t0 = time.perf_counter()
        fe = ConductionFE(d, h_mm=h, h_far_mm=max(h, 0.6))
        t1 = time.perf_counter()
        r = fe.run(POWER_W, 2.0, dt_s=0.02, report_every=100)
        t2 = time.perf_counter()
        fe_by_h[h] = r
        print(f"FE h={h}: {r.cells} cells, {r.dofs} dofs, build {t1 - t0:.1f} s, run {t2 - t1:.1f} s", flush=True)
        out.append({"h": h, "cells": r.cells, "dofs": r.dofs, "build_s": t1 - t0, "run_s": t2 - t1})
    net2, net_ss = network_means(d, POWER_W, [2.0])
    ref = fe_by_h[GRIDS[-1]]
    rows = []
    amb = float(d.thermal.ambient)
    for p in PARTS:
        r_net2, r_netss = net2[p][0] - amb, net_ss[p] - amb
        row = {"part": p, "network_2s_K": r_net2, "network_steady_K": r_netss}
        for h in GRIDS:
            r = fe_by_h[h]
            row[f"fe{h}_2s_K"] = r.mean_C[p][-1] - amb
            row[f"fe{h}_steady_K"] = r.steady_C[p] - amb
        row["err_2s_pct"] = 100 * (r_net2 / (ref.mean_C[p][-1] - amb) - 1)
        row["err_steady_pct"] = 100 * (r_netss / (ref.steady_C[p] - amb) - 1)
        rows.append(row)
    return rows, out, ref


LADDERS = ((1, 1), (1, 32), (2, 2), (3, 3), (4, 4), (6, 6), (8, 8), (12, 12), (16, 16), (32, 32))


def ladder_rows(d, ref):
    """The winding's and the tab's ladders (whisker.coil.thermal_parts) against their number of slices:
    the tab's mean rise at 2 s and at steady state, against 32 + 32 slices and the finest FE grid, and
    the cost of one 20 ms step of 8 coils."""
    from whisker.coil.thermal_network import TAB_NODES, WINDING_NODES

    amb = float(d.thermal.ambient)
    fe2, fess = ref.mean_C["bobbin"][-1] - amb, ref.steady_C["bobbin"] - amb
    got = {}
    for m, n in LADDERS:
        a, b = network_means(d, POWER_W, [2.0], winding_nodes=m, tab_nodes=n)
        net = ThermalNetwork(d, winding_nodes=m, tab_nodes=n)
        x, cur = net.initial_state(), np.full(net.n, 0.4)
        t = best_time_s(lambda: net.step_state(x, cur, 0.02), repeat=5, number=50)
        got[(m, n)] = (a["bobbin"][0] - amb, b["bobbin"] - amb, a["winding"][0] - amb, net.size, t)
    c2, css = got[LADDERS[-1]][:2]
    rows = []
    for (m, n), (t2, tss, w2, size, t) in got.items():
        rows.append({"winding_slices": m, "tab_slices": n, "nodes_8_coils": size,
                     "default": "yes" if (m, n) == (WINDING_NODES, TAB_NODES) else "",
                     "tab_2s_K": t2, "vs_32_2s_pct": 100 * (t2 / c2 - 1), "vs_fe_2s_pct": 100 * (t2 / fe2 - 1),
                     "tab_steady_K": tss, "vs_32_steady_pct": 100 * (tss / css - 1),
                     "vs_fe_steady_pct": 100 * (tss / fess - 1), "winding_2s_K": w2, "ms_per_step_8_coils": t * 1e3})
    return rows


def lumped_rise(d, t_s):
    """The one-node model with POWER_W constant: rise at t_s and at steady state (K)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    th = lumped.CoilThermal(d)
    f = lambda t, T: [(POWER_W - float(th.loss_W(T[0]))) / th.heat_capacity_J_per_K]  # noqa: E731
    s = solve_ivp(f, (0, t_s), [th.ambient_C], rtol=1e-10, atol=1e-10)
    ss = brentq(lambda T: POWER_W - float(th.loss_W(T)), th.ambient_C, 5000.0)
    return s.y[0, -1] - th.ambient_C, ss - th.ambient_C


def cost_rows(d, ref):
    amb = float(d.thermal.ambient)
    fe_w2, fe_wss = ref.mean_C["winding"][-1] - amb, ref.steady_C["winding"] - amb
    l2, lss = lumped_rise(d, 2.0)
    net2, netss = network_means(d, POWER_W, [2.0])
    n2, nss = net2["winding"][0] - amb, netss["winding"] - amb
    # one guard update (20 ms) of 8 coils
    th = lumped.CoilThermal(d)
    net = ThermalNetwork(d)
    x = net.initial_state()
    cur = np.full(8, 0.4)
    t_l = best_time_s(lambda: [th.step(40.0, 0.4, 0.02) for _ in range(8)], repeat=5, number=200)
    t_n = best_time_s(lambda: net.step_state(x, cur, 0.02), repeat=5, number=200)
    g = ThermalGuard(d, thermal=net, clock=lambda: 0.0)
    tt = [0.0]

    def upd():
        tt[0] += 0.02
        g.allow(np.full(8, 0.5), tt[0])
    t_g = best_time_s(upd, repeat=5, number=100)
    fe = ConductionFE(d, h_mm=0.3)
    t_fe = best_time_s(lambda: fe.run(POWER_W, 0.02, dt_s=0.02), repeat=2)
    return [
        {"model": "lumped one node (coil.thermal, the old guard model)", "rise_2s_K": l2, "err_2s_pct": 100 * (l2 / fe_w2 - 1),
         "rise_steady_K": lss, "err_steady_pct": 100 * (lss / fe_wss - 1), "ms_per_guard_update_8_coils": t_l * 1e3},
        {"model": f"thermal network, {net.size} nodes (coil.thermal_network)", "rise_2s_K": n2, "err_2s_pct": 100 * (n2 / fe_w2 - 1),
         "rise_steady_K": nss, "err_steady_pct": 100 * (nss / fe_wss - 1), "ms_per_guard_update_8_coils": t_n * 1e3},
        {"model": "the guard's whole update on the network (allow)", "rise_2s_K": n2, "err_2s_pct": 100 * (n2 / fe_w2 - 1),
         "rise_steady_K": nss, "err_steady_pct": 100 * (nss / fe_wss - 1), "ms_per_guard_update_8_coils": t_g * 1e3},
        {"model": f"finite elements h = 0.3 mm ({fe.dofs} dofs, 1 coil)", "rise_2s_K": float("nan"), "err_2s_pct": float("nan"),
         "rise_steady_K": float("nan"), "err_steady_pct": float("nan"), "ms_per_guard_update_8_coils": 8 * t_fe * 1e3},
        {"model": f"finite elements h = {GRIDS[-1]} mm (reference)", "rise_2s_K": fe_w2, "err_2s_pct": 0.0,
         "rise_steady_K": fe_wss, "err_steady_pct": 0.0, "ms_per_guard_update_8_coils": float("nan")},
    ]


def integrator_rows(d):
    from scipy.integrate import solve_ivp

    net = ThermalNetwork(d)
    I = np.full(net.n, 0.45)
    L, src = net._system()

    def rhs(t, x):
        heat, d = net._joule(x, I)
        return (src + heat + d * x - L @ x) / net.C

    rows = []
    for t_end in (2.0, 10.0):
        ref = net.winding_C(solve_ivp(rhs, (0, t_end), net.initial_state(), method="Radau", rtol=1e-10, atol=1e-10).y[:, -1])[0]
        for sub in (0.005, 0.02, 0.05, 0.2):
            m = ThermalNetwork(d, max_substep_s=sub)
            x = m.step_state(m.initial_state(), I, t_end)
            w = float(m.winding_C(x)[0])
            rows.append({"t_s": t_end, "substep_s": sub, "winding_C": w, "reference_C": float(ref), "err_K": w - float(ref)})
    return rows


def protocol_rows(d):
    lvl = float(volts_to_levels(d, [d.actuation.voltage])[0])
    rows, runs = [], {}
    for resin in ("standard resin post-cured", "standard resin green"):
        dd = default_design(f"thermal.bobbin_material={resin}")
        hold = fit_hold_level(dd, lvl)
        for label, hl in (("full", lvl), ("fitted", hold)):
            r = run_protocol(dd, lvl, hl)
            runs[(resin, label)] = r
            for k, peak in r.peaks().items():
                rows.append({"bobbin": resin, "holding": f"{label} {hl:.3f}", "material": k, "peak_C": peak,
                             "limit_C": r.limits_C[k], "derate_from_C": r.limits_C[k] - d.drive.guard_margin
                             - d.drive.guard_derate_band,
                             "guard_steps_in_s": "never" if r.first_reduced_s is None else f"{r.first_reduced_s:.2f}",
                             "fits": r.fits})
    return rows, runs, lvl


def plot_protocol(runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, label in zip(axes, ("full", "fitted")):
        r = runs[("standard resin post-cured", label)]
        for k, v in r.materials_C.items():
            if np.max(v) > 26:
                ax.plot(r.times_s, v, label=k)
        ax.axhline(r.limits_C["bobbin (standard resin post-cured)"], ls=":", color="grey")
        ax2 = ax.twinx()
        ax2.plot(r.times_s, r.allowed, color="k", lw=0.8, ls="--")
        ax2.set_ylim(0, 1.05)
        ax2.set_ylabel("level applied (dashed)")
        ax.set_title(f"protocol, {label} holding level")
        ax.set_xlabel("time, s")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("hottest temperature, C")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, "thermal_protocol.png")


def main():
    d = default_design()
    fe, fe_cost, ref = fe_rows(d)
    cost = cost_rows(d, ref)
    integ = integrator_rows(d)
    ladders = ladder_rows(d, ref)
    proto, runs, lvl = protocol_rows(d)
    plot_protocol(runs)
    f1 = {c: ".2f" for c in fe[0] if c != "part"}
    text = [
        "# Thermal: lumped vs network vs finite elements, and the paper's protocol",
        "",
        f"`python benchmarks/bench_thermal.py` ({machine_line()}). Models: whisker.coil.thermal (one node),",
        "whisker.coil.thermal_network (a node per part, the winding and the bobbin tab in slices),",
        "whisker.coil.thermal_fe (scikit-fem, hexahedral grid).",
        "",
        f"## 1. Network vs finite elements ({POWER_W:g} W in one winding, every free face to the ambient)",
        "",
        "Temperature rise (K) of each part's volume mean; error of the network against the finest grid.",
        "",
        markdown_table(fe, list(fe[0]), f1),
        "",
        "## 1b. The winding's and the tab's ladders against their number of slices",
        "",
        "The tab's mean rise (K) at 2 s and at steady state (1.5 W, as above) with the winding and the tab",
        "each cut into slices s_j = L (j / N)^2 from their common face (whisker.coil.thermal_parts), against",
        f"32 + 32 slices and the finest FE grid ({GRIDS[-1]} mm); the cost of one 20 ms step of 8 coils.",
        "1 + 1 is the single tab node of before (its link L / (2 k A) instead of L / (3 k A)); 1 + 32 slices",
        "only the tab: the lag is as much in the winding's own face layer as in the resin.",
        "",
        markdown_table(ladders, list(ladders[0]), {"tab_2s_K": ".2f", "vs_32_2s_pct": ".1f", "vs_fe_2s_pct": ".1f",
                                                   "tab_steady_K": ".1f", "vs_32_steady_pct": ".1f",
                                                   "vs_fe_steady_pct": ".1f", "winding_2s_K": ".2f",
                                                   "ms_per_step_8_coils": ".3f"}),
        "",
        "Finite-element grids (h: cell size near the coil, mm):",
        "",
        markdown_table(fe_cost, list(fe_cost[0]), {"build_s": ".1f", "run_s": ".1f"}),
        "",
        "## 2. Accuracy vs cost",
        "",
        "Winding rise (K) at 2 s and at steady state against the finest FE grid; cost of one 20 ms guard",
        "update of 8 coils (the FE row: one time step of the 0.3 mm model, times 8 coils).",
        "",
        markdown_table(cost, list(cost[0]), {"rise_2s_K": ".2f", "err_2s_pct": ".1f", "rise_steady_K": ".1f",
                                              "err_steady_pct": ".1f", "ms_per_guard_update_8_coils": ".3f"}),
        "",
        "The network's backward-Euler step (one call over t, sub-steps of at most `substep_s`) against solve_ivp",
        "(Radau, rtol 1e-10), 0.45 A in every winding:",
        "",
        markdown_table(integ, list(integ[0]), {"winding_C": ".3f", "reference_C": ".3f", "err_K": ".3f"}),
        "",
        f"## 3. The paper's protocol on 8 coils at {d.actuation.voltage:g} V (level {lvl:.3f}) through the guard",
        "",
        "Close 0.3 s at the grasp level, lift 30 mm at 60 mm/s and hold 2 s at the holding level, 3 s off.",
        "`fits`: the guard never reduces a level (every material stays below its derate band,",
        f"{d.drive.guard_margin:g} + {d.drive.guard_derate_band:g} C under its own limit). Peak of the hottest node",
        "each material touches.",
        "",
        markdown_table(proto, list(proto[0]), {"peak_C": ".1f", "limit_C": "g", "derate_from_C": "g"}),
        "",
        "![protocol](thermal_protocol.png)",
        "",
    ]
    write_text("thermal.md", "\n".join(text))
    write_csv("thermal.csv", fe)
    print("\n".join(text))


if __name__ == "__main__":
    main()
