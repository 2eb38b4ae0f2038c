"""Printing: what the cheaper slicing variants cost in accuracy, and what the checks cost in time.

A. Slicing each printable part of the default design three ways with PrusaSlicer:
   - "full": the printer profile (hw/printer/prusa_mk3s_pla_0.2mm.ini), the reference;
   - "coarse": the tests' settings (printcheck.COARSE_ARGS: 0.3 mm layers, 1 perimeter, no infill);
   - "auto supports": the profile with PrusaSlicer's automatic supports switched on (what the slicer
     would add if it, not the overhang check, decided supports).
   Wall time per slice (one run each; slicing takes seconds, so timer noise is small against it),
   estimated print time and filament grams, and the error of each variant against "full".
B. The checks that run before slicing, per part, best of 3: `prusa-slicer --info`, admesh, and the
   overhang check (trimesh + shapely), against the full slice's time.

Writes benchmarks/results/print.md and print.csv (atomically). Needs prusa-slicer and admesh.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import best_time_s, machine_line, markdown_table, write_csv, write_text  # noqa: E402

import trimesh  # noqa: E402

from whisker.cad.verify import printcheck as pc  # noqa: E402
from whisker.cad.build import build  # noqa: E402
from whisker.cad.parts import PARTS  # noqa: E402
from whisker.design import default_design  # noqa: E402
from whisker.design.printer import load_profile  # noqa: E402

VARIANTS = {"full": (), "coarse": pc.COARSE_ARGS, "auto supports": ("--support-material",)}


def slice_once(slicer: str, profile: Path, stl: Path, gcode: Path, extra: tuple[str, ...]) -> tuple[float, dict]:
    t = time.perf_counter()
    subprocess.run([slicer, "--loglevel=1", "--load", str(profile), *extra, "-g", "-o", str(gcode), str(stl)],
                   capture_output=True, text=True, check=True, timeout=pc.SLICE_TIMEOUT_S)
    dt = time.perf_counter() - t
    return dt, pc.parse_gcode(gcode.read_text())


def main() -> None:
    slicer, admesh = pc.find_tool("prusa-slicer"), pc.find_tool("admesh")
    d = default_design()
    profile = load_profile(d.print.profile)
    rows, checks = [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        build(d, out, ("stl",))
        for spec in (p for p in PARTS if p.printable):
            stl = out / f"{spec.name}.stl"
            ref = None
            for variant, extra in VARIANTS.items():
                dt, g = slice_once(slicer, profile.path, stl, out / f"{spec.name}.gcode", extra)
                ref = ref or g
                rows.append({"part": spec.name, "variant": variant, "slice_s": round(dt, 2),
                             "layers": g["layers"], "print_time_min": round(g["time_s"] / 60, 1),
                             "filament_g": g["filament_g"], "supports": g["support_material"],
                             "time_error_pct": round(100 * (g["time_s"] / ref["time_s"] - 1), 1),
                             "grams_error_pct": round(100 * (g["filament_g"] / ref["filament_g"] - 1), 1)})
                print(rows[-1], flush=True)
            mesh = trimesh.load_mesh(stl)
            full_s = next(r["slice_s"] for r in rows if r["part"] == spec.name and r["variant"] == "full")
            checks.append({
                "part": spec.name, "faces": len(mesh.faces),
                "info_s": round(best_time_s(lambda: subprocess.run([slicer, "--loglevel=1", "--info", str(stl)],
                                                                   capture_output=True), 3), 3),
                "admesh_s": round(best_time_s(lambda: subprocess.run([admesh, str(stl)], capture_output=True), 3), 3),
                "overhang_s": round(best_time_s(lambda: pc.overhangs(mesh, profile.support_threshold_deg), 3), 3),
                "full_slice_s": full_s})
    write_csv("print.csv", rows)
    totals = {}
    for r in rows:
        if r["part"] in pc.CALIBRATION_PARTS:
            continue
        t = totals.setdefault(r["variant"], {"variant": r["variant"], "slice_s": 0.0, "print_time_min": 0.0,
                                             "filament_g": 0.0})
        for k in ("slice_s", "print_time_min", "filament_g"):
            t[k] = round(t[k] + r[k], 2)
    full = totals["full"]
    for t in totals.values():
        t["time_error_pct"] = round(100 * (t["print_time_min"] / full["print_time_min"] - 1), 1)
        t["grams_error_pct"] = round(100 * (t["filament_g"] / full["filament_g"] - 1), 1)
        t["slice_speedup"] = round(full["slice_s"] / t["slice_s"], 2)
    text = "\n".join([
        "# Printing: slicing variants and check costs", "",
        f"Machine: {machine_line()}; {pc.slicer_version(slicer)}; profile `{profile.path.name}`; "
        f"default design ({d.whiskers.count} whiskers). Timings are wall-clock on a shared machine; "
        "compare them within this table only.", "",
        "## A. Slicing variants (reference: full profile)", "",
        "Sensor parts (" + ", ".join(dict.fromkeys(r["part"] for r in rows if r["part"] not in pc.CALIBRATION_PARTS))
        + "; the calibration prints are not counted):", "",
        markdown_table(list(totals.values()), ["variant", "slice_s", "slice_speedup", "print_time_min",
                                                "time_error_pct", "filament_g", "grams_error_pct"]), "",
        "Per part:", "",
        markdown_table(rows, ["part", "variant", "slice_s", "layers", "print_time_min", "time_error_pct",
                              "filament_g", "grams_error_pct", "supports"]), "",
        "Reading: coarse slicing is what the tests use to prove that every part slices; its print time "
        "and grams are far from the real print's, so the report's numbers always come from the full "
        "profile. PrusaSlicer's automatic supports add support material to every small horizontal hole "
        "(magnet pockets, screw holes, cable exits, LED groove); the overhang check treats those as "
        "bridges/arches (docs/printing.md), so the report slices without them.", "",
        "## B. Cost of the checks before slicing (best of 3)", "",
        markdown_table(checks, ["part", "faces", "info_s", "admesh_s", "overhang_s", "full_slice_s"]), "",
    ])
    write_text("print.md", text)
    print(text)


if __name__ == "__main__":
    main()
