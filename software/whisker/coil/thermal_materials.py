"""The sensor's materials for heat: conductivity, density, specific heat and the temperature each may
reach (hw/materials/thermal.csv, every value with its source named in the file).

The design says which row each part is made of (``[thermal]`` bobbin_material, rod_glue, magnet_glue,
enamel, rod_material, mount_material; ``[membrane] material``; the magnet's row is "NdFeB " +
``[magnet] grade``). Every column the network relies on is read and checked; a missing column, an
empty cell, a non-number or an unknown material is refused with one line (``DesignError``).
Units: W/(m K), g/cm^3, J/(g K), C.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from whisker.design.validation import DesignError
from whisker.resources import hw_dir

MATERIALS = hw_dir() / "materials" / "thermal.csv"
COLUMNS = ("name", "conductivity_W_mK", "density_g_cm3", "specific_heat_J_gK", "max_service_C", "limit_kind",
           "source")


@dataclass(frozen=True)
class Material:
    name: str
    conductivity_W_mK: float
    density_g_cm3: float
    specific_heat_J_gK: float
    max_service_C: float          # math.inf: no limit of its own
    limit_kind: str
    source: str

    @property
    def volumetric_heat_J_per_mm3K(self) -> float:
        """rho c, J/(mm^3 K) (g/cm^3 x J/(g K) / 1000)."""
        return self.density_g_cm3 * self.specific_heat_J_gK * 1e-3


def _number(path, row, col, text, positive=True) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise DesignError(f"{path} material {row!r}: {col} = {text!r} is not a number") from None
    if not math.isfinite(v) or (positive and v <= 0):
        raise DesignError(f"{path} material {row!r}: {col} = {text!r} must be a finite number > 0")
    return v


@lru_cache(maxsize=4)
def materials(path: Path = MATERIALS) -> dict[str, Material]:
    """Every row of the thermal material table by name; one-line DesignError on a bad file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as err:
        raise DesignError(f"thermal material table {path}: {err.strerror or err}") from None
    body = "\n".join(ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#"))
    reader = csv.DictReader(io.StringIO(body))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
    if missing:
        raise DesignError(f"{path}: missing column {missing[0]!r} (needs {', '.join(COLUMNS)})")
    out: dict[str, Material] = {}
    for rec in reader:
        name = (rec.get("name") or "").strip()
        for col in COLUMNS:
            if rec.get(col) is None or not str(rec[col]).strip():
                raise DesignError(f"{path} material {name or '?'!r}: missing field {col!r}")
        lim = rec["max_service_C"].strip()
        out[name] = Material(
            name=name,
            conductivity_W_mK=_number(path, name, "conductivity_W_mK", rec["conductivity_W_mK"]),
            density_g_cm3=_number(path, name, "density_g_cm3", rec["density_g_cm3"]),
            specific_heat_J_gK=_number(path, name, "specific_heat_J_gK", rec["specific_heat_J_gK"]),
            max_service_C=math.inf if lim.lower() == "none" else _number(path, name, "max_service_C", lim, False),
            limit_kind=rec["limit_kind"].strip(), source=rec["source"].strip())
    if not out:
        raise DesignError(f"{path}: no materials")
    return out


# part role -> (how to say it, where the design names its row)
ROLES = {
    "winding": ("copper winding", None),
    "enamel": ("enamel", "thermal.enamel"),
    "bobbin": ("bobbin", "thermal.bobbin_material"),
    "rod_glue": ("rod glue", "thermal.rod_glue"),
    "rod": ("rod", "thermal.rod_material"),
    "membrane": ("membrane", "membrane.material"),
    "magnet": ("magnet", "magnet.grade"),
    "magnet_glue": ("magnet glue", "thermal.magnet_glue"),
    "mount": ("mount", "thermal.mount_material"),
    "air": ("cavity air", None),
}


def row_name(design, role: str) -> str:
    """The table row the design's part `role` is made of."""
    th = design.thermal
    return {"winding": "copper", "enamel": th.enamel, "bobbin": th.bobbin_material, "rod_glue": th.rod_glue,
            "rod": th.rod_material, "membrane": design.membrane.material, "magnet": f"NdFeB {design.magnet.grade}",
            "magnet_glue": th.magnet_glue, "mount": th.mount_material, "air": "air"}[role]


def material(design, role: str, path: Path | None = None) -> Material:
    """The material of the design's part `role` (a key of ROLES); unknown row -> one-line DesignError."""
    table = materials(Path(path) if path is not None else MATERIALS)
    name = row_name(design, role)
    if name not in table:
        where = ROLES[role][1] or role
        raise DesignError(f"{where} = {name!r}: not in the thermal material table "
                          f"{path or MATERIALS} (known: {', '.join(table)})")
    return table[name]


def design_materials(design, path: Path | None = None) -> dict[str, Material]:
    """Every role's material for `design`, checked once."""
    return {role: material(design, role, path) for role in ROLES}


# the design fields that may override a row's limit (None: the table's)
_OVERRIDES = {"magnet": ("magnet", "max_temperature"), "mount": ("thermal", "pla_softening"),
              "enamel": ("thermal", "enamel_class")}


def limit_C(design, role: str, path: Path | None = None) -> float:
    """The highest temperature the part `role` may reach, C (math.inf: none): the table's max_service_C,
    unless the design overrides it ([magnet] max_temperature, [thermal] pla_softening / enamel_class)."""
    if role in _OVERRIDES:
        sec, key = _OVERRIDES[role]
        v = getattr(getattr(design, sec), key)
        if v is not None:
            return float(v)
    return material(design, role, path).max_service_C
