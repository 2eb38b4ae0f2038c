"""The build-scatter study's tolerance table: ``hw/tolerances.csv`` read, checked, and drawn from.

One row per tolerance: its name (one of `FACTORS`, the factors whisker.coil.tolerance's model reads),
its level (``sensor``: a built sensor draws it once for all its whiskers; ``whisker``: each whisker
draws its own), its kind (``absolute`` value, ``offset`` from the design's value, or ``factor`` on it),
its range (min, max, in its unit), what it applies to, and its source. Every value is drawn uniformly
in its range (the sources give ranges, not distributions): `to_values` maps unit draws onto it.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker.design.wire import CoilError

LEVELS = ("sensor", "whisker")
KINDS = ("absolute", "offset", "factor")
COLUMNS = ("name", "level", "kind", "min", "max", "unit", "applies_to", "source")
#: factors the model reads (a table must give each of them)
FACTORS = ("remanence", "magnet_height", "gap_print", "glue_layer", "ecoflex_modulus", "membrane_thickness",
           "rod_glue_height", "turns", "resistance", "driver_drop", "coil_temperature", "stop_post",
           "current_sense", "calibration")


class ToleranceError(CoilError):
    """A bad tolerance table or study request; one line naming what is wrong."""


@dataclass(frozen=True)
class Tolerance:
    name: str
    level: str
    kind: str
    lo: float
    hi: float
    unit: str
    applies_to: str
    source: str


def default_path() -> Path:
    from whisker.resources import hw_dir
    return hw_dir() / "tolerances.csv"


def load_tolerances(path: str | Path | None = None) -> dict[str, Tolerance]:
    """The tolerance table (hw/tolerances.csv by default); every column checked, one-line errors."""
    p = Path(path) if path is not None else default_path()
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise ToleranceError(f"tolerance table {p} does not exist") from None
    rows = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.DictReader(rows)
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
    if missing:
        raise ToleranceError(f"{p}: missing column(s) {', '.join(missing)}")
    out: dict[str, Tolerance] = {}
    for k, r in enumerate(reader, start=1):
        name = (r["name"] or "").strip()
        where = f"{p.name} row {k} ({name or '?'})"
        try:
            lo, hi = float(r["min"]), float(r["max"])
        except (TypeError, ValueError):
            raise ToleranceError(f"{where}: min and max must be numbers (got {r['min']!r}, {r['max']!r})") from None
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ToleranceError(f"{where}: min and max must be finite (got {lo!r}, {hi!r})")
        if lo > hi:
            raise ToleranceError(f"{where}: min {lo:g} > max {hi:g}")
        if r["level"] not in LEVELS:
            raise ToleranceError(f"{where}: level must be one of {', '.join(LEVELS)} (got {r['level']!r})")
        if r["kind"] not in KINDS:
            raise ToleranceError(f"{where}: kind must be one of {', '.join(KINDS)} (got {r['kind']!r})")
        if r["kind"] == "factor" and lo <= 0:
            raise ToleranceError(f"{where}: a factor's range must be positive (got min {lo:g})")
        if not (r["source"] or "").strip():
            raise ToleranceError(f"{where}: no source given")
        if name in out:
            raise ToleranceError(f"{where}: {name!r} appears twice")
        out[name] = Tolerance(name, r["level"], r["kind"], lo, hi, r["unit"], r["applies_to"], r["source"])
    absent = [f for f in FACTORS if f not in out]
    if absent:
        raise ToleranceError(f"{p}: no row for {', '.join(absent)}")
    return out


def to_values(tol: Tolerance, u):
    """Map unit-interval draws u in [0, 1] to the tolerance's range (uniform): lo + u (hi - lo)."""
    u = np.asarray(u, dtype=float)
    return tol.lo + u * (tol.hi - tol.lo)
