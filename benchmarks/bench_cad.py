"""CAD benchmark: what STL accuracy costs, and how long a full build takes.

1. Tessellation: for a grid of linear (mm) and angular (rad) tolerances, export every printable part
   of the default design and measure export time, STL size and the mesh-vs-CAD volume error
   (the CAD solid's exact volume is the reference). The accuracy bar: linear tolerance <= 0.05 mm (a
   quarter of a 0.2 mm layer), worst volume error <= 0.25 %, rod-hole diameter error <= 0.005 mm
   (far below a printer's +-0.1 mm). The default in hw/sensor.toml [export] must meet the bar and
   export within 20 % of the fastest setting that does (timing noise makes closer calls meaningless).
2. Build speed: the full default build (every part, STL + STEP + checks) from a cold process, and the
   no-op rebuild, each as a subprocess the way `make stl` runs it.
3. Sweep speed: time per design point of `whisker cad sweep` on 1 and on 2 worker processes (joblib),
   over the same 12 cells, and the speed-up between them measured in one run.

Writes benchmarks/results/cad.md, cad_tessellation.csv and cad_tessellation.png.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cadquery as cq  # noqa: E402
import trimesh  # noqa: E402

from common import RESULTS, machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402
from whisker.cad.verify import checks  # noqa: E402
from whisker.cad.parts import PARTS  # noqa: E402
from whisker.design import default_design  # noqa: E402

LINEAR = [0.5, 0.1, 0.05, 0.01, 0.005, 0.001]
ANGULAR = [0.5, 0.3, 0.2, 0.1]


def rod_hole_error(mesh: trimesh.Trimesh, d) -> float:
    """Largest error (mm) of the membrane mould's rod-socket diameters measured on the mesh."""
    sockets = checks.describe_circles(checks.holes(checks.section(mesh, -d.rod_below_membrane / 2)))
    want = d.hole(d.whiskers.rod_diameter)
    return max(abs(dia - want) for _, _, dia in sockets)


def tessellation_rows(d) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for lin in LINEAR:
            for ang in ANGULAR:
                # Fresh solids each time: OpenCascade keeps a shape's first triangulation and reuses it.
                solids = {p.name: p.build(d) for p in PARTS if p.printable}
                t_total, size, worst = 0.0, 0, 0.0
                hole_err = math.nan
                for name, shape in solids.items():
                    path = Path(tmp) / f"{name}.stl"
                    t = time.perf_counter()
                    cq.exporters.export(cq.Workplane().add(shape), str(path), tolerance=lin, angularTolerance=ang)
                    t_total += time.perf_counter() - t
                    size += path.stat().st_size
                    mesh = trimesh.load_mesh(path)
                    worst = max(worst, abs(mesh.volume - shape.Volume()) / shape.Volume())
                    if name == "mold_base":
                        hole_err = rod_hole_error(mesh, d)
                rows.append({"linear_tolerance_mm": lin, "angular_tolerance_rad": ang, "export_s": round(t_total, 4),
                             "stl_MB": round(size / 1e6, 3), "worst_volume_error_pct": worst * 100,
                             "rod_hole_diameter_error_mm": hole_err})
    return rows


def meets_bar(r: dict) -> bool:
    return (r["linear_tolerance_mm"] <= 0.05 and r["worst_volume_error_pct"] <= 0.25
            and r["rod_hole_diameter_error_mm"] <= 0.005)


def build_timings() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "whisker.cli", "cad", "build", "--out", tmp, "-q"]
        for _ in range(3):  # a source edited between the two runs forces a rebuild: measure again
            t = time.perf_counter()
            subprocess.run(cmd + ["--force"], check=True, capture_output=True)
            full = time.perf_counter() - t
            t = time.perf_counter()
            out = subprocess.run(cmd, check=True, capture_output=True, text=True)
            noop = time.perf_counter() - t
            if "up to date" in out.stdout:
                return {"full_build_s": full, "noop_s": noop}
    raise RuntimeError("the second build was never a no-op: are the sources changing?")


SWEEP_COUNTS, SWEEP_RADII = [4, 8, 12, 16], [8.0, 14.0, 20.0]


def sweep_timings() -> dict:
    from whisker.cad.verify.sweep import sweep

    sweep([8], [12.0], workers=2)  # warm the worker pool's imports once, outside the timing
    out = {}
    for workers in (1, 2):
        t = time.perf_counter()
        rows = sweep(SWEEP_COUNTS, SWEEP_RADII, workers=workers)
        out[workers] = (time.perf_counter() - t) / len(rows)
    return {"per_design_1_s": out[1], "per_design_2_s": out[2], "speedup": out[1] / out[2], "cells": len(rows)}


def main() -> None:
    d = default_design()
    rows = tessellation_rows(d)
    write_csv("cad_tessellation.csv", rows)
    ok = [r for r in rows if meets_bar(r)]
    choice = min(ok, key=lambda r: r["export_s"]) if ok else None
    current = next((r for r in rows if r["linear_tolerance_mm"] == d.export.linear_tolerance
                    and r["angular_tolerance_rad"] == d.export.angular_tolerance), None)
    timings = build_timings()
    sweep_t = sweep_timings()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ang in ANGULAR:
        rs = [r for r in rows if r["angular_tolerance_rad"] == ang]
        axes[0].loglog([r["export_s"] * 1e3 for r in rs], [max(r["worst_volume_error_pct"], 1e-6) for r in rs], "o-",
                       label=f"angular {ang} rad")
        axes[1].loglog([r["linear_tolerance_mm"] for r in rs], [r["stl_MB"] for r in rs], "o-", label=f"angular {ang} rad")
        for r in rs:
            axes[0].annotate(f"{r['linear_tolerance_mm']:g}", (r["export_s"] * 1e3, max(r["worst_volume_error_pct"], 1e-6)),
                             fontsize=7)
    axes[0].set_xlabel("STL export time, all printable parts (ms)")
    axes[0].set_ylabel("worst mesh-vs-CAD volume error (%)")
    axes[0].set_title("accuracy against time (labels: linear tolerance, mm)")
    axes[1].set_xlabel("linear tolerance (mm)")
    axes[1].set_ylabel("STL size, all printable parts (MB)")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    save_figure(fig, "cad_tessellation.png")

    table = markdown_table(rows, ["linear_tolerance_mm", "angular_tolerance_rad", "export_s", "stl_MB",
                                  "worst_volume_error_pct", "rod_hole_diameter_error_mm"],
                           {"export_s": ".3f", "worst_volume_error_pct": ".4f", "rod_hole_diameter_error_mm": ".4f"})
    lines = [
        "# CAD: tessellation accuracy against time, and build speed", "",
        f"Machine: {machine_line()}. Default design, its {sum(1 for p in PARTS if p.printable)} printable parts "
        f"({', '.join(p.name for p in PARTS if p.printable)}). Reference: the CAD solids' exact",
        "volumes (OpenCascade). Rod-hole error: mould rod sockets measured on the mesh against rod + 2 x clearance.", "",
        table, "",
        "![tessellation](cad_tessellation.png)", "",
        "Accuracy bar: linear tolerance <= 0.05 mm (a quarter layer), worst volume error <= 0.25 %, rod-hole",
        "diameter error <= 0.005 mm. The default must meet it and export within 20 % of the fastest setting that does.",
        f"Fastest setting meeting the bar in this run: linear {choice['linear_tolerance_mm']} mm, angular "
        f"{choice['angular_tolerance_rad']} rad, {choice['export_s']:.3f} s." if choice else "No setting met the bar.",
        f"Current default ([export] in hw/sensor.toml): linear {d.export.linear_tolerance} mm, angular "
        f"{d.export.angular_tolerance} rad"
        + (f": {current['worst_volume_error_pct']:.4f} % volume error, {current['rod_hole_diameter_error_mm']:.4f} mm hole "
           f"error, {current['stl_MB']} MB, {current['export_s']:.3f} s; meets the rule: "
           f"{'yes' if meets_bar(current) and choice and current['export_s'] <= 1.2 * choice['export_s'] else 'NO'}."
           if current else "."), "",
        "## Build speed (subprocesses, as `make stl` runs them)", "",
        f"- full default build, every part, STL + STEP + assembly + all checks: {timings['full_build_s']:.1f} s (target < 30 s)",
        f"- `make stl` again with nothing changed (no-op): {timings['noop_s']:.2f} s (target < 2 s)", "",
        "## Sweep speed (`whisker cad sweep`, joblib)", "",
        f"{sweep_t['cells']} cells (counts {SWEEP_COUNTS} x radii {SWEEP_RADII} mm), solids + every check, no export:", "",
        "| workers | s per design point |", "|---|---|",
        f"| 1 | {sweep_t['per_design_1_s']:.2f} |", f"| 2 | {sweep_t['per_design_2_s']:.2f} |", "",
        f"Speed-up 1 -> 2 workers: {sweep_t['speedup']:.2f}x (measured in one run on this 2-core machine). The full "
        f"`make sweep` (15 counts x 22 radii = 330 points) takes about {330 * sweep_t['per_design_2_s'] / 60:.0f} min "
        "on 2 cores.", "",
    ]
    path = write_text("cad.md", "\n".join(lines))
    print(f"wrote {path}, {RESULTS / 'cad_tessellation.csv'}, {RESULTS / 'cad_tessellation.png'}")
    print("\n".join(lines[-4:]))


if __name__ == "__main__":
    main()
