"""`whisker print check`: a printable part is printable only when a real slicer says so.

Every printable part's exported STL (already in its printing pose, see ``parts.print_transform``) is
checked by outside tools, and their OUTPUT is read, never just their exit status (PrusaSlicer 2.5
exits 0 for non-manifold meshes and too-tall parts, admesh always exits 0; DESIGN.md section 4):

1. ``fits printer``: the STL's bounding box against the printer profile's bed and maximum height
   (the slicer itself only aborts for too-wide parts: "Objects could not fit on the bed");
2. ``prusa-slicer --info``: must report ``manifold = yes`` and no ``open_edges``;
3. ``admesh`` (second opinion): no facets with disconnected edges, no degenerate facets, no
   backwards edges, no facets it had to reverse;
4. overhang check (trimesh + shapely): downward faces flatter than the profile's
   ``support_material_threshold`` (deg from horizontal), grouped into regions; a region whose every
   point lies within ``MAX_BRIDGE_MM / 2`` of its edge is a bridge/arch, anything wider needs supports;
5. slicing with the printer profile (supports on only where step 4 asks for them): the G-code must
   exist and have layers; its comments give the estimated print time and the filament in grams
   (``; estimated printing time (normal mode)``, ``; total filament used [g]``), and
   ``;TYPE:Support material`` shows whether the slicer generated supports.

Results go into ``manifest.json`` (``parts.<name>.print`` and a top-level ``print`` summary) and a
print report ``print_report.md`` / ``print_report.json`` beside it. Functions that run tools take the
tool path; parsing is pure and tested on the tools' real output.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
import trimesh

from whisker.design import Design
from whisker.files import atomic_write_json, atomic_write_text
from whisker.design.printer import PrinterProfile, load_profile

INSTALL_HINT = ("install it with: sudo apt-get install prusa-slicer admesh (Debian/Ubuntu); "
                "CI installs both from .ci/apt-packages")
# Bridges/arches up to this span print without supports in PLA with part cooling (mm). A common
# rule of thumb (PrusaSlicer prints such spans as "Bridge infill"); horizontal holes up to ~10 mm
# likewise print as arches without support.
MAX_BRIDGE_MM = 10.0
# Overhang faces smaller than this in total are tessellation noise (mm^2).
MIN_OVERHANG_AREA = 0.5
# Coarse slicing (tests): fewer, thicker layers and no infill; valid for "does it slice", NOT for
# time and grams. The report says "coarse" wherever these were used.
COARSE_ARGS = ("--layer-height", "0.3", "--first-layer-height", "0.3", "--perimeters", "1",
               "--top-solid-layers", "1", "--bottom-solid-layers", "1", "--fill-density", "0%", "--skirts", "0")
SLICE_TIMEOUT_S = 600
# Printed once to find print.clearance, not part of a sensor: listed, not counted in the sensor total.
CALIBRATION_PARTS = frozenset({"tolerance_coupon", "board_holder"})


class ToolMissing(RuntimeError):
    """prusa-slicer or admesh is not installed; the message says how to install it."""


def find_tool(name: str) -> str:
    """Path of an outside tool. ``WHISKER_PRUSA_SLICER`` / ``WHISKER_ADMESH`` override the lookup."""
    env = os.environ.get(f"WHISKER_{name.upper().replace('-', '_')}")
    exe = shutil.which(env or name)
    if not exe:
        where = f" (WHISKER_{name.upper().replace('-', '_')}={env})" if env else " on PATH"
        raise ToolMissing(f"{name} not found{where}: the print check needs it; {INSTALL_HINT}")
    return exe


# ---- parsing the tools' output (pure) --------------------------------------------------------

def parse_info(text: str) -> dict[str, str]:
    """``prusa-slicer --info`` output -> {key: value} (``manifold``, ``open_edges``, ``size_z`` ...)."""
    out: dict[str, str] = {}
    for line in text.splitlines():
        m = re.match(r"^\s*([a-z_]+)\s*=\s*(.+?)\s*$", line)
        if m:
            out[m.group(1)] = m.group(2)
    return out


def parse_admesh(text: str) -> dict[str, float]:
    """admesh's report -> counts of the ORIGINAL mesh (before its repairs) and its statistics."""
    keys = {"Number of facets": "facets", "Facets with 1 disconnected edge": "disconnected_1",
            "Facets with 2 disconnected edges": "disconnected_2", "Facets with 3 disconnected edges": "disconnected_3",
            "Total disconnected facets": "disconnected", "Number of parts": "parts",
            "Degenerate facets": "degenerate", "Edges fixed": "edges_fixed", "Facets removed": "facets_removed",
            "Facets added": "facets_added", "Facets reversed": "facets_reversed",
            "Backwards edges": "backwards_edges", "Normals fixed": "normals_fixed"}
    out: dict[str, float] = {}
    for line in text.splitlines():
        label, sep, rest = line.partition(":")
        key = keys.get(label.strip())
        if sep and key:
            nums = re.findall(r"-?\d+(?:\.\d+)?", rest)
            if nums:
                out[key] = float(nums[0])  # the "Original" column where there are two
    return out


def parse_duration(text: str) -> float:
    """PrusaSlicer's ``1d 2h 3m 4s`` -> seconds."""
    parts = re.findall(r"(\d+)\s*([dhms])", text)
    if not parts:
        raise ValueError(f"no duration in {text!r}")
    return float(sum(int(n) * {"d": 86400, "h": 3600, "m": 60, "s": 1}[u] for n, u in parts))


def parse_gcode(text: str) -> dict:
    """The facts a check needs from PrusaSlicer G-code: layers, top Z, time, filament, supports."""
    out: dict = {"layers": 0, "max_z_mm": 0.0, "support_material": False}
    for line in text.splitlines():
        if line.startswith(";LAYER_CHANGE"):
            out["layers"] += 1
        elif line.startswith(";Z:"):
            out["max_z_mm"] = max(out["max_z_mm"], float(line[3:]))
        elif line.startswith(";TYPE:Support material"):
            out["support_material"] = True
        elif line.startswith("; estimated printing time (normal mode)"):
            out["time_text"] = line.split("=", 1)[1].strip()
            out["time_s"] = parse_duration(out["time_text"])
        elif line.startswith("; total filament used [g]"):
            out["filament_g"] = float(line.split("=", 1)[1])
        elif line.startswith("; filament used [mm]"):
            out["filament_mm"] = float(line.split("=", 1)[1])
        elif line.startswith("; filament used [cm3]"):
            out["filament_cm3"] = float(line.split("=", 1)[1])
    return out


# ---- the checks -----------------------------------------------------------------------------------

@dataclass
class PartPrint:
    """Everything the print check found for one part; ``reasons`` is empty when it is printable."""

    name: str
    stl: str
    ok: bool = True
    reasons: list[str] = field(default_factory=list)
    size_mm: list[float] = field(default_factory=list)
    info: dict = field(default_factory=dict)
    admesh: dict = field(default_factory=dict)
    overhang: dict = field(default_factory=dict)
    supports: bool = False
    bed_contact_mm2: float = 0.0
    gcode: dict = field(default_factory=dict)
    coarse: bool = False
    slice_s: float = 0.0

    def fail(self, reason: str) -> None:
        self.ok = False
        self.reasons.append(reason)

    def line(self) -> str:
        if not self.ok:
            return f"{self.name}: NOT printable: {'; '.join(self.reasons)}"
        g = self.gcode
        return (f"{self.name}: {g.get('layers', 0)} layers, {g.get('time_text', '?')}, "
                f"{g.get('filament_g', math.nan):.2f} g, supports {'yes' if self.supports else 'no'}")


def fits_printer(extent: Iterable[float], p: PrinterProfile) -> tuple[bool, str]:
    """Does an (x, y, z) extent in mm fit the bed (either way round in xy) and the height?"""
    x, y, z = (float(v) for v in extent)
    if z > p.max_height:
        return False, (f"too tall for the printer: {z:.1f} mm > max_print_height {p.max_height:g} mm "
                       f"(profile {p.path.name})")
    if not ((x <= p.bed_x and y <= p.bed_y) or (y <= p.bed_x and x <= p.bed_y)):
        return False, (f"too wide for the printer: {x:.1f} x {y:.1f} mm > bed {p.bed_x:g} x {p.bed_y:g} mm "
                       f"(profile {p.path.name})")
    return True, ""


def overhangs(mesh: trimesh.Trimesh, threshold_deg: float, bed_z: float = 0.0, first_layer: float = 0.2,
              max_bridge: float = MAX_BRIDGE_MM) -> dict:
    """Overhang regions of a mesh in its printing pose (z up, bed at ``bed_z``).

    A face overhangs when it faces down and its slope from the horizontal is below
    ``threshold_deg`` (PrusaSlicer's ``support_material_threshold`` convention). Faces on the bed are
    not overhangs. Connected overhang faces form a region; the region, projected on the bed, is a
    bridge when ``buffer(-max_bridge/2)`` leaves nothing (every point within max_bridge/2 of an edge).
    Returns total and unbridgeable area (mm^2), region count, the largest unbridgeable region and
    ``needs_supports``.
    """
    import shapely
    from shapely.geometry import Polygon

    nz = mesh.face_normals[:, 2]
    slope = np.degrees(np.arccos(np.clip(-nz, -1.0, 1.0)))  # 0 = flat ceiling, 90 = vertical wall
    low = mesh.triangles[:, :, 2].max(axis=1) <= bed_z + first_layer / 2
    over = np.flatnonzero((nz < 0) & (slope < threshold_deg) & ~low)
    result = {"threshold_deg": threshold_deg, "max_bridge_mm": max_bridge, "area_mm2": 0.0, "regions": 0,
              "unsupported_area_mm2": 0.0, "largest_unbridgeable": None, "needs_supports": False}
    if len(over) == 0:
        return result
    adj = mesh.face_adjacency
    keep = np.isin(adj, over).all(axis=1)
    groups = trimesh.graph.connected_components(adj[keep], nodes=over, min_len=1)
    area = mesh.area_faces
    result["area_mm2"] = round(float(area[over].sum()), 3)
    worst = None
    for g in groups:
        a = float(area[g].sum())
        if a < MIN_OVERHANG_AREA:
            continue
        result["regions"] += 1
        tris = mesh.triangles[g][:, :, :2]
        poly = shapely.union_all([Polygon(t).buffer(1e-6) for t in tris if Polygon(t).area > 1e-12])
        if poly.is_empty or poly.buffer(-max_bridge / 2).is_empty:
            continue
        result["unsupported_area_mm2"] += a
        z = float(mesh.triangles[g][:, :, 2].min())
        b = poly.bounds
        if worst is None or a > worst["area_mm2"]:
            worst = {"area_mm2": round(a, 2), "z_mm": round(z, 2),
                     "extent_mm": [round(b[2] - b[0], 2), round(b[3] - b[1], 2)]}
    result["unsupported_area_mm2"] = round(result["unsupported_area_mm2"], 3)
    result["largest_unbridgeable"] = worst
    result["needs_supports"] = worst is not None
    return result


def bed_contact_mm2(mesh: trimesh.Trimesh, first_layer: float = 0.2) -> float:
    """Area of the downward faces lying on the bed (the first layer's footprint), mm^2.
    A small footprint on a tall part warns of poor adhesion; the report lists it."""
    z0 = float(mesh.bounds[0, 2])
    on_bed = (mesh.triangles[:, :, 2].max(axis=1) <= z0 + first_layer / 2) & (mesh.face_normals[:, 2] < -0.99)
    return round(float(mesh.area_faces[on_bed].sum()), 2)


def _run(cmd: list[str], timeout: float = SLICE_TIMEOUT_S) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def check_part(name: str, stl: Path, profile: PrinterProfile, gcode_out: Path, slicer: str, admesh: str,
               coarse: bool = False) -> PartPrint:
    """Run every check on one STL (in printing pose) and slice it; never raises for a bad part."""
    res = PartPrint(name=name, stl=str(stl), coarse=coarse)
    try:
        mesh = trimesh.load_mesh(stl)  # process=True merges vertices: overhang regions need adjacency
    except Exception as err:  # noqa: BLE001 - any unreadable file is a failed check with its reason
        res.fail(f"cannot read {stl.name}: {err}")
        return res
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        res.fail(f"{stl.name} holds no triangles")
        return res
    res.size_mm = [round(float(v), 3) for v in mesh.extents]
    ok, why = fits_printer(mesh.extents, profile)
    if not ok:
        res.fail(why)

    info = _run([slicer, "--loglevel=1", "--info", str(stl)], timeout=120)
    res.info = parse_info(info.stdout)
    if res.info.get("manifold") != "yes":
        res.fail(f"prusa-slicer --info: manifold = {res.info.get('manifold', 'not reported')}"
                 + (f", open_edges = {res.info['open_edges']}" if "open_edges" in res.info else "")
                 + " (holes in the mesh: a face or faces are missing)")
    elif int(res.info.get("open_edges", "0")) > 0:
        res.fail(f"prusa-slicer --info: open_edges = {res.info['open_edges']}")

    am = _run([admesh, str(stl)], timeout=120)
    res.admesh = parse_admesh(am.stdout)
    if "disconnected" not in res.admesh:
        res.fail(f"admesh gave no report: {(am.stdout + am.stderr).strip()[-200:]}")
    else:
        bad = {k: int(res.admesh[k]) for k in ("disconnected", "degenerate", "backwards_edges", "facets_reversed")
               if res.admesh.get(k, 0) > 0}
        if bad:
            res.fail("admesh: " + ", ".join(f"{k.replace('_', ' ')} = {v}" for k, v in bad.items()))

    res.overhang = overhangs(mesh, profile.support_threshold_deg, float(mesh.bounds[0, 2]),
                             profile.first_layer_height)
    res.supports = bool(res.overhang["needs_supports"])
    res.bed_contact_mm2 = bed_contact_mm2(mesh, profile.first_layer_height)
    if not res.ok:
        return res  # a broken or oversized mesh is not sliced: its numbers would mean nothing

    cmd = [slicer, "--loglevel=1", "--load", str(profile.path), *(("--support-material",) if res.supports else ()),
           *(COARSE_ARGS if coarse else ()), "--export-gcode", "--output", str(gcode_out), str(stl)]
    gcode_out.unlink(missing_ok=True)
    t0 = time.perf_counter()
    try:
        sl = _run(cmd)
    except subprocess.TimeoutExpired:
        res.fail(f"prusa-slicer did not finish in {SLICE_TIMEOUT_S} s")
        return res
    res.slice_s = round(time.perf_counter() - t0, 2)
    said = (sl.stdout + sl.stderr)
    if "could not fit" in said:
        res.fail("prusa-slicer: Objects could not fit on the bed")
    elif not gcode_out.exists() or gcode_out.stat().st_size == 0:
        tail = " | ".join(ln for ln in said.strip().splitlines()[-3:])
        res.fail(f"prusa-slicer wrote no G-code (exit {sl.returncode}): {tail}")
    else:
        g = parse_gcode(gcode_out.read_text(errors="replace"))
        res.gcode = g
        if g["layers"] == 0:
            res.fail("prusa-slicer: the G-code has no layers")
        for key, what in (("time_s", "; estimated printing time"), ("filament_g", "; total filament used [g]")):
            if key not in g:
                res.fail(f"prusa-slicer: the G-code has no '{what}' comment")
            elif not math.isfinite(g[key]) or g[key] <= 0:
                res.fail(f"prusa-slicer: {what} = {g[key]} (nothing would be printed)")
        top = res.size_mm[2] if res.size_mm else 0.0
        if res.ok and g["max_z_mm"] < top - 1.0:
            res.fail(f"prusa-slicer: the G-code ends at z = {g['max_z_mm']:.1f} mm, the part is {top:.1f} mm tall")
    return res


# ---- whole exports folder ----------------------------------------------------------------------

def fmt_duration(s: float) -> str:
    s = int(round(s))
    h, m = divmod(s // 60, 60)
    return f"{h}h {m:02d}m" if h else f"{m}m {s % 60:02d}s"


def summarise(results: list[PartPrint]) -> dict:
    """Totals over the printable parts of one sensor (calibration parts such as the coupon apart)."""
    ok = [r for r in results if r.ok]
    sensor = [r for r in ok if r.name not in CALIBRATION_PARTS]
    return {"parts": len(results), "printable": len(ok), "all_ok": len(ok) == len(results),
            "sensor_parts": [r.name for r in sensor],
            "total_time_s": round(sum(r.gcode.get("time_s", 0.0) for r in sensor), 1),
            "total_filament_g": round(sum(r.gcode.get("filament_g", 0.0) for r in sensor), 2),
            "total_filament_mm": round(sum(r.gcode.get("filament_mm", 0.0) for r in sensor), 1),
            "calibration_parts": sorted(CALIBRATION_PARTS & {r.name for r in results}),
            "supports_needed": [r.name for r in results if r.supports]}


def report_markdown(design: Design, profile: PrinterProfile, results: list[PartPrint], summary: dict,
                    slicer_version: str) -> str:
    coarse = any(r.coarse for r in results)
    lines = [f"# Print report: {design.whiskers.count} whiskers on a {design.whiskers.ring_radius:g} mm ring",
             "",
             f"Design digest `{design.digest()}`; printer profile `{profile.path.name}` "
             f"(bed {profile.bed_x:g} x {profile.bed_y:g} mm, height {profile.max_height:g} mm, "
             f"{profile.nozzle_diameter:g} mm nozzle, {profile.layer_height:g} mm layers, "
             f"filament {profile.filament_density:g} g/cm^3); {slicer_version}.",
             ""]
    if coarse:
        lines += ["**Coarse slicing** (0.3 mm layers, 1 perimeter, no infill): the parts slice, but the times "
                  "and grams below are NOT estimates of a real print.", ""]
    lines += ["| part | size x y z (mm) | on bed (mm^2) | layers | print time | filament (g) | supports | "
              "overhang check | result |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        g, oh = r.gcode, r.overhang
        worst = oh.get("largest_unbridgeable") if oh else None
        ohs = (f"{worst['area_mm2']:.0f} mm^2 unbridgeable at z {worst['z_mm']:.1f}" if worst
               else f"{oh['regions']} regions, {oh['area_mm2']:.0f} mm^2, all bridges/arches <= {MAX_BRIDGE_MM:g} mm"
               if oh and oh.get("regions") else "none")
        sup = ("yes" if r.supports else "no") + (" (slicer: none generated)" if r.supports and g and not g.get("support_material") else "")
        size = " x ".join(f"{v:.1f}" for v in r.size_mm) or "-"
        t = fmt_duration(g["time_s"]) if "time_s" in g else "-"
        grams = f"{g['filament_g']:.2f}" if "filament_g" in g else "-"
        result = "ok" if r.ok else "FAILED: " + "; ".join(r.reasons)
        lines.append(f"| {r.name} | {size} | {r.bed_contact_mm2:.0f} | {g.get('layers', '-')} | {t} | {grams} | {sup} | {ohs} | {result} |")
    lines += ["", f"**Whole sensor: {fmt_duration(summary['total_time_s'])} of printing, "
                  f"{summary['total_filament_g']:.1f} g of filament "
                  f"({summary['total_filament_mm'] / 1000:.2f} m)** for {', '.join(summary['sensor_parts'])}"
                  + (f" (not counted: {', '.join(summary['calibration_parts'])}, printed once to find "
                     "print.clearance)" if summary["calibration_parts"] else "")
                  + ("" if summary["all_ok"] else f"; {summary['parts'] - summary['printable']} part(s) FAILED") + ".",
              "",
              "Checks per part: fits the printer (bounding box vs profile), `prusa-slicer --info` manifold with no "
              "open edges, admesh finds no disconnected/degenerate/reversed facets, overhang check "
              f"(faces flatter than {profile.support_threshold_deg:g} deg from horizontal, wider than a "
              f"{MAX_BRIDGE_MM:g} mm bridge, need supports; parts that need them are sliced with supports), "
              "G-code with layers, time and grams read from its comments.", ""]
    return "\n".join(lines)


def slicer_version(slicer: str) -> str:
    out = _run([slicer, "--help"], timeout=60).stdout
    m = re.search(r"(PrusaSlicer-[^\s]+)", out)
    return m.group(1) if m else "PrusaSlicer (version unknown)"


def check_exports(design: Design, out: str | Path, coarse: bool = False, keep_gcode: bool = True,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Check and slice every printable part in ``out`` (a ``whisker cad build`` folder).

    Writes ``print_report.md``, ``print_report.json``, ``gcode/<part>.gcode`` and adds the results
    to ``manifest.json``. Returns the report dict (``summary.all_ok`` tells whether all passed).
    Raises :class:`ToolMissing` when prusa-slicer or admesh is not installed, FileNotFoundError
    when there is no build in ``out``.
    """
    out = Path(out)
    say = progress or (lambda msg: None)
    slicer, admesh = find_tool("prusa-slicer"), find_tool("admesh")
    manifest_path = out / "manifest.json"
    if not manifest_path.exists():
        raise FileNotFoundError(f"no build in {out}/ (run `whisker cad build --out {out}` or `make stl` first)")
    manifest = json.loads(manifest_path.read_text())
    if manifest.get("design_digest") != design.digest():
        raise ValueError(f"{out}/ holds a build of another design ({manifest.get('design_digest')}, this design is "
                         f"{design.digest()}): build it first with the same --design/--set options")
    profile = load_profile(design.print.profile)
    gdir = out / "gcode"
    gdir.mkdir(exist_ok=True)
    results = []
    for name, part in manifest["parts"].items():
        if not part.get("printable"):
            continue
        say(f"checking and slicing {name}")
        (gdir / f"{name}.gcode").unlink(missing_ok=True)  # never leave an older run's G-code beside a failure
        stl = part.get("files", {}).get("stl")
        if stl is None:
            results.append(PartPrint(name=name, stl="", ok=False, reasons=["no STL in the build (build with STL)"]))
            continue
        results.append(check_part(name, out / stl, profile, gdir / f"{name}.gcode", slicer, admesh, coarse))
        if not keep_gcode:
            (gdir / f"{name}.gcode").unlink(missing_ok=True)
    summary = summarise(results)
    version = slicer_version(slicer)
    report = {"generator": "whisker print check", "design_digest": design.digest(),
              "build_key": manifest.get("build_key"), "slicer": version, "coarse": coarse,
              "profile": {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(profile).items()
                          if k != "settings"},
              "summary": summary, "parts": {r.name: asdict(r) for r in results}}
    atomic_write_json(out / "print_report.json", report)
    atomic_write_text(out / "print_report.md", report_markdown(design, profile, results, summary, version))
    for r in results:
        manifest["parts"][r.name]["print"] = {
            "ok": r.ok, "reasons": r.reasons, "layers": r.gcode.get("layers"), "time_s": r.gcode.get("time_s"),
            "filament_g": r.gcode.get("filament_g"), "supports": r.supports, "coarse": r.coarse,
            "gcode": f"gcode/{r.name}.gcode" if keep_gcode and r.gcode else None}
    manifest["print"] = {"report": "print_report.md", "slicer": version, "profile": profile.path.name, **summary}
    atomic_write_json(manifest_path, manifest)
    return report
