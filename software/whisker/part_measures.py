"""The printed parts' volumes, surface areas and filament grams, for the bill of materials.

Measured on the CadQuery solids (`whisker.cad.parts`); grams from a solid or a shell model of the
printer profile, or from the slicer's report (`whisker print check`). See `whisker.bom` for how the
BOM uses them; benchmarks/results/bom.md compares the three estimates with the slicer.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from whisker.design import Design
from whisker.errors import BomError

#: Printed parts and the reference part the Ecoflex volume comes from (names of whisker.cad.parts).
PRINTED_PARTS = ("mount", "mold_base", "mold_lid", "whisker_ring", "adapter", "flange_plate", "cover", "winding_jig")
#: Printed once to set up the printer and the camera, not part of the sensor's PLA total.
CALIBRATION_PARTS = ("tolerance_coupon", "board_holder")
#: Printed on a resin printer (not PLA): one per whisker.
RESIN_PARTS = ("bobbin",)
MEMBRANE_PART = "membrane"


def cad_measures(design: Design) -> tuple[dict[str, float], dict[str, float]]:
    """(volumes mm^3, surface areas mm^2) of the printed parts and the membrane, measured on the
    CadQuery solids (whisker.cad.parts)."""
    from whisker.cad.parts import BY_NAME

    vols, areas = {}, {}
    for name in (*PRINTED_PARTS, *RESIN_PARTS, MEMBRANE_PART):
        try:
            shape = BY_NAME[name].build(design)
            vols[name], areas[name] = float(shape.Volume()), float(shape.Area())
        except Exception as err:  # OCC raises its own types; name the part and keep one line
            msg = str(err).splitlines()[0] if str(err) else type(err).__name__
            raise BomError(f"CAD part '{name}' cannot be built for this design ({msg}); "
                           "run `make stl` for the geometry checks") from err
    return vols, areas


def cad_volumes(design: Design) -> dict[str, float]:
    """Volumes (mm^3) of the printed parts and the membrane."""
    return cad_measures(design)[0]


@dataclass(frozen=True)
class PrintSettings:
    """What the shell model needs from the printer profile: shell thickness (mm), infill fraction."""

    shell_mm: float
    infill: float


def print_settings(design: Design) -> PrintSettings:
    """Shell = perimeters x extrusion_width, infill = fill_density, from the design's printer profile
    (whisker.design.printer; PrusaSlicer keys). An auto (0) or percentage width counts as 1.125 x nozzle,
    PrusaSlicer's automatic perimeter width."""
    from whisker.design.printer import load_profile

    prof = load_profile(design.print.profile)

    def num(key, default):
        text = (prof.get(key) or "").strip()
        try:
            return float(text.rstrip("%")) / (100.0 if text.endswith("%") else 1.0)
        except ValueError:
            return default

    width_text = (prof.get("perimeter_extrusion_width") or prof.get("extrusion_width") or "0").strip()
    width = 0.0 if width_text.endswith("%") else num("perimeter_extrusion_width", 0.0) or num("extrusion_width", 0.0)
    if width <= 0:
        width = 1.125 * prof.nozzle_diameter
    perimeters = num("perimeters", 2.0)
    infill = num("fill_density", 0.2)
    if not (0 <= infill <= 1) or perimeters < 0:
        raise BomError(f"printer profile {prof.path.name}: fill_density {infill} or perimeters {perimeters} "
                       "out of range")
    return PrintSettings(perimeters * width, infill)


def pla_grams(volume_mm3: float, area_mm2: float, density_g_cm3: float,
              settings: Optional[PrintSettings] = None) -> float:
    """Filament mass of one printed part, g.

    Without settings: solid, V x density (upper bound). With settings: shell model,
    density x (S + f (V - S)) with S = min(V, A x shell_mm) (walls, top and bottom alike).
    """
    if not (volume_mm3 > 0 and math.isfinite(volume_mm3)):
        raise BomError(f"part volume must be positive and finite, got {volume_mm3}")
    if settings is None:
        return volume_mm3 * density_g_cm3 / 1000.0
    if not (area_mm2 > 0 and math.isfinite(area_mm2)):
        raise BomError(f"part surface area must be positive and finite, got {area_mm2}")
    shell = min(volume_mm3, area_mm2 * settings.shell_mm)
    return density_g_cm3 * (shell + settings.infill * (volume_mm3 - shell)) / 1000.0


def read_print_report(path: str | Path, design: Optional[Design] = None) -> dict[str, float]:
    """Filament grams per printed part from the slicer report ``print_report.json``
    (``whisker print check``, whisker.cad.verify.printcheck): ``parts[name]["gcode"]["filament_g"]``.

    With `design`, a report of another design (``design_digest``) is refused. Raises BomError
    naming what is wrong.
    """
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as err:
        raise BomError(f"cannot read the print report {path}: {err}") from None
    if not isinstance(data, dict) or not isinstance(data.get("parts"), dict):
        raise BomError(f"{path}: no 'parts' mapping in the print report")
    if data.get("coarse"):
        raise BomError(f"{path} comes from a coarse slice, whose filament grams are not the real print's: "
                       "run the print check without --coarse")
    if design is not None and data.get("design_digest") not in (None, design.digest()):
        raise BomError(f"{path} is the print report of design {data.get('design_digest')}, not of this "
                       f"design ({design.digest()}): run the print check for this design first")
    grams: dict[str, float] = {}
    for name, rec in data["parts"].items():
        if not isinstance(rec, dict):
            continue
        g = rec.get("gcode") if isinstance(rec.get("gcode"), dict) else rec
        v = g.get("filament_g")
        if isinstance(v, (int, float)) and math.isfinite(v) and v >= 0:
            grams[name] = float(v)
    if not grams:
        raise BomError(f"{path}: no part has a finite filament_g value")
    return grams
