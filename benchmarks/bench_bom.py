"""BOM benchmark: how good the cheap material estimates are, and what the exact ones cost.

1. PLA per printed part of the default design, three estimates against PrusaSlicer (the reference:
   the printer profile in hw/printer/, full slice, ``; total filament used [g]``):
   - solid: CAD volume x density (100 % infill), an upper bound;
   - shell: density x (S + f (V - S)), S = min(V, area x perimeters x extrusion width) (whisker.bom);
   - slicer: PrusaSlicer on the part's STL in its printing pose.
2. Magnet wire per coil, three estimates against the coil calculator (whisker.coil.winding, the
   reference: layer-by-layer winding build-up):
   - mean turn: turns x pi x (outer + inner diameter) / 2;
   - from the measured resistance: coil.resistance / (ohm per metre of the bare wire at 20 C);
   - whisker.coil.winding.

Writes benchmarks/results/bom.md and bom.csv. Without prusa-slicer on PATH the slicer column is
left out, and the report says so.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import best_time_s, machine_line, markdown_table, write_csv, write_text  # noqa: E402
from whisker.part_measures import PRINTED_PARTS, cad_measures, pla_grams, print_settings  # noqa: E402
from whisker.design import default_design  # noqa: E402


def slice_grams(design, name: str, workdir: Path) -> tuple[float, float]:
    """(filament g, seconds) from PrusaSlicer for one printed part in its printing pose."""
    import cadquery as cq

    from whisker.cad.parts import BY_NAME, print_pose
    from whisker.design.printer import load_profile

    spec = BY_NAME[name]
    stl = workdir / f"{name}.stl"
    cq.exporters.export(print_pose(spec, spec.build(design)), str(stl),
                        tolerance=design.export.linear_tolerance,
                        angularTolerance=design.export.angular_tolerance)
    gcode = workdir / f"{name}.gcode"
    profile = load_profile(design.print.profile).path
    t = time.perf_counter()
    res = subprocess.run(["prusa-slicer", "--loglevel=1", "--load", str(profile), "-g", "-o", str(gcode),
                          str(stl)], capture_output=True, text=True, timeout=900)
    dt = time.perf_counter() - t
    text = gcode.read_text() if gcode.exists() else ""
    m = re.search(r"^; total filament used \[g\] = ([0-9.]+)", text, re.M)
    if res.returncode != 0 or not m:
        raise RuntimeError(f"prusa-slicer failed on {name}: {res.stderr.strip()[-300:]}")
    return float(m.group(1)), dt


def main() -> None:
    d = default_design()
    settings = print_settings(d)
    rho = d.print.filament_density
    t0 = time.perf_counter()
    volumes, areas = cad_measures(d)
    t_cad = time.perf_counter() - t0
    have_slicer = shutil.which("prusa-slicer") is not None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in PRINTED_PARTS:
            v, a = volumes[name], areas[name]
            solid = pla_grams(v, a, rho)
            shell = pla_grams(v, a, rho, settings)
            row = {"part": name, "volume_cm3": v / 1000, "area_cm2": a / 100, "solid_g": solid,
                   "shell_g": shell}
            if have_slicer:
                g, dt = slice_grams(d, name, Path(tmp))
                row.update({"slicer_g": g, "slicer_s": dt,
                            "solid_err_pct": 100 * (solid - g) / g, "shell_err_pct": 100 * (shell - g) / g})
            rows.append(row)
    t_solid = best_time_s(lambda: pla_grams(volumes["mount"], areas["mount"], rho), repeat=5, number=2000)
    t_shell = best_time_s(lambda: pla_grams(volumes["mount"], areas["mount"], rho, settings), repeat=5,
                          number=2000)

    # Magnet wire per coil.
    from whisker.coil import ohm_per_m, winding

    c = d.coil
    mean_turn = c.turns * math.pi * (c.outer_diameter + c.inner_diameter) / 2.0
    from_r = c.resistance / ohm_per_m(c.wire_diameter) * 1000.0
    w = winding(d)
    t_mean = best_time_s(lambda: c.turns * math.pi * (c.outer_diameter + c.inner_diameter) / 2.0,
                         repeat=5, number=10000)
    t_r = best_time_s(lambda: c.resistance / ohm_per_m(c.wire_diameter), repeat=5, number=2000)
    t_w = best_time_s(lambda: winding(d), repeat=5, number=50)
    wire_rows = [
        {"method": "mean turn", "wire_m": mean_turn / 1000, "err_pct": 100 * (mean_turn / w.wire_length_mm - 1),
         "us_per_call": t_mean * 1e6},
        {"method": "measured resistance / ohm per m", "wire_m": from_r / 1000,
         "err_pct": 100 * (from_r / w.wire_length_mm - 1), "us_per_call": t_r * 1e6},
        {"method": "whisker.coil.winding (reference)", "wire_m": w.wire_length_mm / 1000, "err_pct": 0.0,
         "us_per_call": t_w * 1e6},
    ]

    write_csv("bom.csv", [{**r, "table": "pla"} for r in rows])
    cols = ["part", "volume_cm3", "area_cm2", "solid_g", "shell_g"]
    fmt = {"volume_cm3": ".2f", "area_cm2": ".1f", "solid_g": ".1f", "shell_g": ".1f"}
    if have_slicer:
        cols += ["slicer_g", "solid_err_pct", "shell_err_pct", "slicer_s"]
        fmt.update({"slicer_g": ".2f", "solid_err_pct": "+.0f", "shell_err_pct": "+.0f", "slicer_s": ".1f"})
    tot = {k: sum(r[k] for r in rows) for k in ("solid_g", "shell_g", *(["slicer_g"] if have_slicer else []))}
    lines = ["# BOM estimates: cheap vs exact", "",
             f"Machine: {machine_line()}. Default design, printer profile `{d.print.profile}` "
             f"({settings.shell_mm:g} mm shell = perimeters x extrusion width, {settings.infill:.0%} infill, "
             f"PLA {rho:g} g/cm^3). Generated by `benchmarks/bench_bom.py`.", "",
             "## PLA per printed part", "",
             markdown_table(rows, cols, fmt), ""]
    if have_slicer:
        lines += [f"Totals: solid {tot['solid_g']:.1f} g, shell model {tot['shell_g']:.1f} g, "
                  f"PrusaSlicer {tot['slicer_g']:.1f} g "
                  f"(shell model {100 * (tot['shell_g'] / tot['slicer_g'] - 1):+.0f} %, "
                  f"solid {100 * (tot['solid_g'] / tot['slicer_g'] - 1):+.0f} %).", ""]
    else:
        lines += ["prusa-slicer is not on PATH: no slicer reference in this run.", ""]
    lines += [f"Cost: CAD volumes and areas of all parts {t_cad:.2f} s (builds the solids); solid estimate "
              f"{t_solid * 1e6:.2f} us/part, shell model {t_shell * 1e6:.2f} us/part"
              + (f"; PrusaSlicer {sum(r['slicer_s'] for r in rows):.0f} s for the {len(rows)} parts "
                 "(full slice, this machine was shared)." if have_slicer else "."), "",
              "The BOM (`make bom`) uses the shell model by default, and the slicer's grams when given "
              "`--print-report` from a full (not coarse) `whisker print check`. The solid bound is "
              "listed in every part's specification.", "",
              "## Magnet wire per coil", "",
              markdown_table(wire_rows, ["method", "wire_m", "err_pct", "us_per_call"],
                             {"wire_m": ".2f", "err_pct": "+.0f", "us_per_call": ".2f"}), "",
              f"Coil: {c.turns} turns of {c.wire_diameter:g} mm wire, {c.outer_diameter:g} x {c.length:g} mm, "
              f"{c.resistance:g} ohm measured. The calculator says the winding "
              f"{'fits' if w.fits else 'does NOT fit'} at fill factor {w.fill_factor:g}. When it does not fit, "
              "its layers build beyond the outer diameter and each turn is longer than the mean-turn "
              "estimate assumes. The BOM takes the calculator's length (plus leads and waste).", ""]
    write_text("bom.md", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
