"""The enamelled copper wire and how much of it a winding window holds: pure geometry and material
constants, at the design layer because the design's "auto" turns and resistance follow from them
(whisker.design.sizing). The coil calculator (whisker.coil) builds its full winding report on these.

Material constants (sources):
- copper resistivity at 20 C: 1/58 ohm*mm^2/m = 0.017241 (IEC 60028, annealed copper standard);
  temperature coefficient 0.00393 /K at 20 C (IEC 60028); density 8.89 g/cm^3 (IEC 60028);
  specific heat 0.385 J/(g K).
- enamel build: IEC 60317-0-1 overall diameters; for 0.100 mm wire grade 1 is 0.108-0.117 mm
  (Elektrisola's table), grade 2 up to 0.125, grade 3 up to 0.132; the mid-range relative increase
  at 0.1 mm (12.5 / 19.5 / 26.5 %) is scaled as d^-0.3 for other sizes (thin wires carry relatively
  more enamel). Check your wire's datasheet if it matters.
"""

from __future__ import annotations

import math

import numpy as np

RHO20_OHM_MM2_PER_M = 1.0 / 58.0  # IEC 60028
ALPHA20_PER_K = 0.00393           # IEC 60028
COPPER_DENSITY_G_CM3 = 8.89       # IEC 60028
COPPER_SPECIFIC_HEAT = 0.385      # J/(g K)
ENAMEL_DENSITY_G_CM3 = 1.3        # polyurethane / polyester-imide enamels, ~1.2-1.4
ENAMEL_SPECIFIC_HEAT = 1.7        # J/(g K), polymer
ORTHOCYCLIC_PACKING = math.pi / (2.0 * math.sqrt(3.0))  # 0.9069, hexagonal packing of circles
_ENAMEL_INCREASE_AT_0P1 = {1: 0.125, 2: 0.195, 3: 0.265}


class CoilError(ValueError):
    """A coil request that cannot be computed; the one-line message names the input."""


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise CoilError(f"{name} must be a positive finite number (got {value!r})")
    return v


def enamel_overall_diameter_mm(wire_diameter_mm: float, grade: int = 1) -> float:
    """Overall (enamelled) wire diameter, mm, IEC 60317-0-1 mid-range (see the module docstring)."""
    d = _positive("wire_diameter", wire_diameter_mm)
    if grade not in _ENAMEL_INCREASE_AT_0P1:
        raise CoilError(f"enamel grade must be 1, 2 or 3 (got {grade!r})")
    return d * (1.0 + _ENAMEL_INCREASE_AT_0P1[grade] * (0.1 / d) ** 0.3)


def ohm_per_m(wire_diameter_mm: float, temperature_C: float = 20.0) -> float:
    """Resistance of bare copper wire per metre at temperature, ohm/m."""
    d = _positive("wire_diameter", wire_diameter_mm)
    return RHO20_OHM_MM2_PER_M / (math.pi * d * d / 4.0) * (1.0 + ALPHA20_PER_K * (temperature_C - 20.0))


def temperature_factor(temperature_C) -> np.ndarray:
    """R(T)/R(20 C) of copper; refuses temperatures at or below the linear model's zero (-234.5 C)."""
    t = np.asarray(temperature_C, dtype=float)
    if not np.all(np.isfinite(t)) or np.any(t <= -234.0):
        raise CoilError(f"temperature_C must be finite and above -234 C (got {temperature_C!r})")
    return 1.0 + ALPHA20_PER_K * (t - 20.0)


def _build(turns: float, wire_d: float, fill: float, length: float) -> float:
    """Radial depth (mm) of `turns` at copper fill `fill` on a former of `length`."""
    return turns * math.pi * wire_d ** 2 / 4.0 / (fill * length)


def wire_length_mm(inner_radius_mm: float, turns: float, wire_d: float, fill: float, length: float) -> float:
    """Wire length (mm) of `turns` wound from `inner_radius_mm` outwards at copper fill `fill` on a former
    of `length` (mm): turns x the mean turn's circumference."""
    build = _build(turns, wire_d, fill, length)
    return turns * (2.0 * math.pi * (inner_radius_mm + build / 2.0))


def turns_per_layer(length_mm: float, overall_diameter_mm: float) -> int:
    """Enamelled turns side by side on a former of `length_mm`; refuses a former shorter than one wire."""
    tpl = int(math.floor(length_mm / overall_diameter_mm))
    if tpl < 1:
        raise CoilError(f"coil.length {length_mm} mm is shorter than one enamelled wire ({overall_diameter_mm:.3f} mm)")
    return tpl


def max_turns_at_fill(design) -> int:
    """Turns of the design's wire that fit the former's window at winding.fill_factor."""
    from whisker.design.former import window

    a1, a2, L = window(design)
    d = design.coil.wire_diameter
    turns_per_layer(L, enamel_overall_diameter_mm(d, design.winding.enamel_grade))
    a_cu = math.pi * d * d / 4.0
    window_mm2 = (a2 - a1) * L
    return int(math.floor(design.winding.fill_factor * window_mm2 / a_cu + 1e-9))


def resistance_20C_ohm(design) -> float:
    """Resistance at 20 C (ohm) of coil.turns of the design's wire wound on the former at winding.fill_factor."""
    from whisker.design.former import window

    a1, _, L = window(design)
    c, w = design.coil, design.winding
    turns_per_layer(L, enamel_overall_diameter_mm(c.wire_diameter, w.enamel_grade))
    return ohm_per_m(c.wire_diameter) * wire_length_mm(a1, c.turns, c.wire_diameter, w.fill_factor, L) / 1000.0
