"""Coil benchmark: the calculator's other approximations, error against a reference and time per call.

1. Inductance: Wheeler's multilayer formula against the numerical cell method (whisker.coil
   .inductance_numeric_H) on four coil shapes; the cell method's own convergence (reference:
   Richardson extrapolation of 24 and 48 cells, the method being O(1/cells^2)).
2. Thermal integrator: ``CoilThermal.step`` (exponential Euler) with steps from 1 ms to 10 s against
   scipy's ``solve_ivp`` (Radau, rtol 1e-10) over 20 s at the paper's 0.43 A, and
   ``time_to_C`` (adaptive quadrature of dt = C dT / (P - loss)) against 1 ms stepping.
   The constant convection coefficient against Churchill-Chu h(T) (safe duty error, step cost).
3. Deflection: ``coil.equilibrium`` with the force table against the 12-node filament model.

Writes benchmarks/results/coil.md and coil.csv.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import best_time_s, machine_line, markdown_table, write_csv, write_text  # noqa: E402
from whisker import coil as C  # noqa: E402
from whisker.coil import thermal as T  # noqa: E402
from whisker.design import default_design  # noqa: E402

SHAPES = [  # name, turns, inner radius, outer radius, length (mm)
    ("paper coil, 600 t (4 x 4 mm, 1 mm bore)", 600, 0.5, 2.0, 4.0),
    ("411 t at fill 0.55", 411, 0.5, 2.0, 4.0),
    ("long thin solenoid", 200, 1.0, 1.1, 20.0),
    ("flat pancake", 300, 1.0, 5.0, 1.0),
]


def inductance_rows():
    rows = []
    for name, n, a1, a2, L in SHAPES:
        l24 = C.inductance_numeric_H(n, a1, a2, L, cells=24)
        l48 = C.inductance_numeric_H(n, a1, a2, L, cells=48)
        ref = (4 * l48 - l24) / 3
        for method, fn in [
            ("wheeler", lambda: C.wheeler_inductance_H(n, (a1 + a2) / 2, L, a2 - a1)),
            ("numeric 8 cells", lambda: C.inductance_numeric_H(n, a1, a2, L, cells=8)),
            ("numeric 16 cells", lambda: C.inductance_numeric_H(n, a1, a2, L, cells=16)),
            ("numeric 24 cells (default)", lambda: C.inductance_numeric_H(n, a1, a2, L, cells=24)),
        ]:
            val = fn()
            rows.append({"part": "inductance", "case": name, "method": method, "value": f"{val * 1e6:.4g} uH",
                         "rel_err": abs(val / ref - 1), "us_per_call": best_time_s(fn, repeat=3) * 1e6})
    return rows


def thermal_rows(d):
    from scipy.integrate import solve_ivp

    th = T.CoilThermal(d)
    I, t_end = 0.43, 20.0

    def rhs(_t, y):
        return [(I * I * float(th.resistance(y[0])) - float(th.loss_W(y[0]))) / th.heat_capacity_J_per_K]

    ref = solve_ivp(rhs, (0, t_end), [th.ambient_C], method="Radau", rtol=1e-10, atol=1e-10).y[0, -1]
    rows = []
    for dt in (0.001, 0.01, 0.1, 1.0, 10.0):
        steps = int(round(t_end / dt))

        def run(dt=dt, steps=steps):
            t = th.ambient_C
            for _ in range(steps):
                t = th.step(t, I, dt)
            return t

        val = run()
        rows.append({"part": "thermal", "case": f"{t_end:g} s at {I} A", "method": f"step dt = {dt:g} s",
                     "value": f"{val:.4f} C", "rel_err": abs((val - ref) / (ref - th.ambient_C)),
                     "us_per_call": best_time_s(run, repeat=3) * 1e6 / steps})
    t_q = th.time_to_C(th.limit_C, 3.0)
    t, temp, h = 0.0, th.ambient_C, 1e-3
    while temp < th.limit_C:
        prev = temp
        temp = th.step_voltage(temp, 3.0, h)
        t += h
    t_step = t - h * (temp - th.limit_C) / (temp - prev)
    rows.append({"part": "thermal", "case": "seconds to 55 C at 3 V", "method": "time_to_C (adaptive quad; ref: 1 ms steps)",
                 "value": f"{t_q:.4f} s", "rel_err": abs(t_q / t_step - 1),
                 "us_per_call": best_time_s(lambda: th.time_to_C(th.limit_C, 3.0), repeat=3) * 1e6})
    for conv in ("constant", "churchill_chu"):
        tc = T.CoilThermal(d, convection=conv)
        rows.append({"part": "thermal", "case": "3 V: s to 55 C / safe duty", "method": f"convection {conv}",
                     "value": f"{tc.time_to_C(tc.limit_C, 3.0):.3f} s / {tc.safe_duty(3.0) * 100:.2f} %",
                     "rel_err": abs(tc.safe_duty(3.0) / T.CoilThermal(d, convection="churchill_chu").safe_duty(3.0) - 1),
                     "us_per_call": best_time_s(lambda tc=tc: tc.step(40.0, 0.43, 0.01), repeat=3, number=200) * 1e6})
    return rows, ref


def deflection_rows(d):
    """At 1 V: below the end stop (at the stop both models return the stop's tilt and compare nothing)."""
    from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad

    rows = []
    volts = 1.0
    i = C.current_A(d, volts)
    ref = C.equilibrium(d, i, model="filament").theta_deg
    case = f"{volts:g} V, stiffness {design_stiffness_Nmm_per_rad(d):.3g} N mm/rad"
    for model in ("table", "filament"):
        val = C.equilibrium(d, i, model=model).theta_deg
        rows.append({"part": "deflection", "case": case, "method": f"equilibrium, {model}",
                     "value": f"{val:.5f} deg", "rel_err": abs(val / ref - 1),
                     "us_per_call": best_time_s(lambda m=model: C.equilibrium(d, i, model=m), repeat=3) * 1e6})
    return rows


def main() -> None:
    d = default_design()
    rows = inductance_rows()
    th_rows, ref = thermal_rows(d)
    rows += th_rows + deflection_rows(d)
    write_csv("coil.csv", rows)
    text = "\n".join([
        "# Coil calculator: approximations against references",
        "",
        "Written by `benchmarks/bench_coil.py` (`make bench`). Machine: " + machine_line() + ".",
        "",
        markdown_table(rows, ["part", "case", "method", "value", "rel_err", "us_per_call"],
                       {"rel_err": ".2e", "us_per_call": ".3g"}),
        "",
        "Inductance reference: the cell method extrapolated from 24 and 48 cells (Richardson, O(1/n^2)). "
        "Wheeler's formula, a microsecond instead of tens of milliseconds, is 4-8 % off on these shapes "
        "(it is meant for coils whose 6r, 9l and 10c terms are comparable); the report prints both. Thermal: relative error of the temperature rise after 20 s "
        f"(reference {ref:.4f} C from solve_ivp); the exponential-Euler step stays stable and accurate "
        "even at 10 s steps because it sub-steps at a tenth of the thermal time constant. Deflection: "
        "the table-backed solve reproduces the filament model to the table's accuracy.",
        "",
    ])
    write_text("coil.md", text)
    print(text)


if __name__ == "__main__":
    main()
