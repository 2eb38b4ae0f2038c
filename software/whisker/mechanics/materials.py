"""The membrane silicone's material data: ``hw/materials/<name>.toml`` (the design's ``membrane.material``).

Each file names its sources (datasheet, hyperelastic fit). The code reads every field it relies on;
a missing or non-numeric field is refused with one line naming the file and the field.

Units: MPa (= N/mm^2), so that moments come out in N mm with lengths in mm.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path


class MaterialError(ValueError):
    """A material file that cannot be used. The message is one line naming the file and field."""


@dataclass(frozen=True)
class Silicone:
    """Linear-elastic (small-strain) constants of a cast silicone, MPa, and where they came from."""

    name: str
    shear_modulus_MPa: float        # mu, the small-strain limit of the hyperelastic fit
    bulk_modulus_MPa: float         # K
    modulus_100_MPa: float          # datasheet: nominal stress at 100 % elongation
    modulus_100_range_MPa: tuple[float, float]  # published scatter of the same quantity
    fit_stretch: float
    source: str
    path: str

    @property
    def youngs_modulus_MPa(self) -> float:
        """E = 9 K mu / (3 K + mu), MPa."""
        k, mu = self.bulk_modulus_MPa, self.shear_modulus_MPa
        return 9 * k * mu / (3 * k + mu)

    @property
    def poisson_ratio(self) -> float:
        k, mu = self.bulk_modulus_MPa, self.shear_modulus_MPa
        return (3 * k - 2 * mu) / (2 * (3 * k + mu))

    def shear_modulus_for(self, modulus_100_MPa: float) -> float:
        """The neo-Hookean shear modulus for another 100 % modulus (batch scatter), MPa."""
        return neo_hookean_shear_modulus(modulus_100_MPa, self.fit_stretch)


def neo_hookean_shear_modulus(nominal_stress_MPa: float, stretch: float) -> float:
    """mu from one uniaxial point of an incompressible neo-Hookean solid, MPa.

    Nominal (engineering) stress P = mu (lambda - lambda^-2) (Treloar, The Physics of Rubber
    Elasticity, 3rd ed. 1975, ch. 4), so mu = P / (lambda - lambda^-2).
    """
    if not stretch > 1.0:
        raise MaterialError(f"fit stretch {stretch!r} must exceed 1")
    return nominal_stress_MPa / (stretch - stretch ** -2)


def material_path(name: str) -> Path:
    """``hw/materials/<slug>.toml`` for a material name ("Ecoflex 00-30" -> ecoflex_00_30.toml)."""
    from whisker.resources import hw_dir

    slug = re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")
    return hw_dir() / "materials" / f"{slug}.toml"


def _number(data: dict, section: str, key: str, where: Path, positive: bool = True) -> float:
    sec = data.get(section)
    if not isinstance(sec, dict):
        raise MaterialError(f"material file {where}: missing section [{section}]")
    if key not in sec:
        raise MaterialError(f"material file {where}: missing field {section}.{key}")
    v = sec[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
        raise MaterialError(f"material file {where}: {section}.{key} must be a positive number (got {v!r})")
    return float(v)


def _text(data: dict, section: str, key: str, where: Path) -> str:
    v = (data.get(section) or {}).get(key) if section else data.get(key)
    if not isinstance(v, str) or not v.strip():
        name = f"{section}.{key}" if section else key
        raise MaterialError(f"material file {where}: missing field {name}")
    return v


def load_silicone(path: str | Path) -> Silicone:
    """Read a silicone's material file. Raises :class:`MaterialError` (one line) on a missing field."""
    from whisker.files import read_toml

    path = Path(path)
    data = read_toml(path, "material", MaterialError)
    name = _text(data, "", "name", path)
    source = _text(data, "datasheet", "source", path)
    model = _text(data, "hyperelastic", "model", path)
    if model != "neo-Hookean":
        raise MaterialError(f"material file {path}: hyperelastic.model {model!r} is not supported (neo-Hookean)")
    m100 = _number(data, "datasheet", "modulus_100", path)
    stretch = _number(data, "hyperelastic", "fit_stretch", path)
    if stretch <= 1.0:
        raise MaterialError(f"material file {path}: hyperelastic.fit_stretch must exceed 1 (got {stretch!r})")
    bulk = _number(data, "hyperelastic", "bulk_modulus", path)
    lo = _number(data, "scatter", "modulus_100_min", path)
    hi = _number(data, "scatter", "modulus_100_max", path)
    if lo > hi:
        raise MaterialError(f"material file {path}: scatter.modulus_100_min ({lo:g}) exceeds modulus_100_max ({hi:g})")
    mu = neo_hookean_shear_modulus(m100, stretch)
    if bulk <= mu:
        raise MaterialError(f"material file {path}: hyperelastic.bulk_modulus ({bulk:g} MPa) must exceed the shear "
                            f"modulus ({mu:.3g} MPa): a silicone is nearly incompressible")
    return Silicone(name=name, shear_modulus_MPa=mu, bulk_modulus_MPa=bulk, modulus_100_MPa=m100,
                    modulus_100_range_MPa=(lo, hi), fit_stretch=stretch, source=source, path=str(path))


def silicone_for(name: str) -> Silicone:
    """The material file of a design's ``membrane.material``; an unknown name -> one line listing the known."""
    path = material_path(name)
    if not path.is_file():
        known = sorted(p.stem for p in path.parent.glob("*.toml"))
        raise MaterialError(f"membrane.material {name!r}: no material file {path.name} in {path.parent} "
                            f"(known: {', '.join(known) or 'none'})")
    return load_silicone(path)
