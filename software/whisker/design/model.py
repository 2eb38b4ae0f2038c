"""The design model: every dimension of the sensor, validated, in one object.

`load_design()` reads a TOML design file (default: ``hw/sensor.toml``, the paper's sensor), applies
``section.key=value`` overrides and returns a frozen, validated :class:`Design`. Every other module
(CAD, coil calculator, BOM, tracking, simulator) takes a ``Design`` and derives what it needs from
it; no dimension is typed twice. Derived quantities (pivot height, l_u, l_l, mm per pixel, whisker
angles, cavity radius ...) are properties here so that every module derives them the same way. The
sections' fields (units, bounds, "auto") are in :mod:`whisker.design.sections`.

Units: millimetres, grams, seconds, volts, amperes, ohms, degrees, degrees Celsius, unless a field's
description says otherwise. Coordinates: z = 0 on the membrane's lower face, z up, sensor axis = z.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any, Iterable

from pydantic import Field, PrivateAttr, ValidationError, model_validator

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from whisker.design.validation import DesignError, one_line_errors
from whisker.design.sections import (Actuation, Adapter, Bobbin, Bom, Camera, Coil, Cover, Drive, Driver, Export, Fasteners,
                                     Magnet, Mechanics, Membrane, Mold, Mount, Print, Ring, Thermal, Tracking, Whiskers,
                                     Winding, WindingJig, Wiring, _Section)


def _default_design_path() -> Path:
    # hw/sensor.toml in a clone, the copy shipped in the wheel otherwise (whisker.resources).
    from whisker.resources import default_design_path

    return default_design_path()


DEFAULT_DESIGN = _default_design_path()


class Design(_Section):
    """The whole sensor. Build one with :func:`load_design`."""

    whiskers: Whiskers
    membrane: Membrane
    coil: Coil
    magnet: Magnet
    actuation: Actuation
    camera: Camera
    mount: Mount
    mold: Mold
    ring: Ring
    print: Print
    export: Export
    winding: Winding
    drive: Drive
    tracking: Tracking
    wiring: Wiring
    bom: Bom
    mechanics: Mechanics
    thermal: Thermal
    driver: Driver
    fasteners: Fasteners = Field(default_factory=Fasteners)
    adapter: Adapter = Field(default_factory=Adapter)
    cover: Cover = Field(default_factory=Cover)
    bobbin: Bobbin = Field(default_factory=Bobbin)
    winding_jig: WindingJig = Field(default_factory=WindingJig)

    # "section.key" -> the rule's reason, for every value a rule sized (empty: all from the file).
    _rules: dict[str, str] = PrivateAttr(default_factory=dict)

    @model_validator(mode="wrap")
    @classmethod
    def _resolve_auto(cls, data: Any, handler) -> "Design":
        """Replace every "auto" by its rule (whisker.design.sizing) before the model is built."""
        if not isinstance(data, dict):
            return handler(data)
        from whisker.design.sizing import resolve_auto

        resolved, rules = resolve_auto(data, handler)
        design = handler(resolved)
        design._rules = rules
        return design

    def __eq__(self, other: object) -> bool:
        # Equal values are equal designs, whether a value came from the file or from a rule.
        return isinstance(other, Design) and self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(self.digest())

    def source(self, name: str) -> str:
        """Where a value came from: "rule: <reason>" or "file" ("section.key")."""
        return f"rule: {self._rules[name]}" if name in self._rules else "file"

    @model_validator(mode="after")
    def _buildable(self) -> "Design":
        # Only relations without which no solid can be built; everything the CAD can measure is
        # measured on the solids by whisker.cad.verify.checks instead.
        if self.coil.inner_diameter >= self.coil.outer_diameter:
            raise ValueError("coil.inner_diameter must be smaller than coil.outer_diameter")
        from whisker.design.fasteners import FastenerError, hole
        try:  # an insert deeper than the mount's blind hole, a tapped hole too shallow to engage
            hole(self.fasteners.mount_screw, self.fasteners.mount_joint, wall=self.mount.mounting_hole_depth)
        except FastenerError as err:
            raise ValueError(f"fasteners.mount_joint / mount.mounting_hole_depth: {err}") from None
        if self.rod_below_membrane <= 0:
            raise ValueError(
                "whiskers.rod_length must exceed whiskers.protrusion + membrane.thickness "
                f"(rod ends {-self.rod_below_membrane:.3g} mm above the membrane's lower face)")
        if self.rod_below_membrane <= self.coil.drop:
            raise ValueError(
                "whiskers.rod_length - whiskers.protrusion - membrane.thickness must exceed "
                f"coil.drop: the rod ends {self.rod_below_membrane:.3g} mm below the membrane, "
                f"above the coil ({self.coil.drop:.3g} mm)")
        if self.whiskers.rod_diameter >= self.coil.outer_diameter:
            raise ValueError("whiskers.rod_diameter must be smaller than coil.outer_diameter")
        from whisker.design.wire import enamel_overall_diameter_mm  # the same wire model as `whisker coil report`

        wire = enamel_overall_diameter_mm(self.coil.wire_diameter, self.winding.enamel_grade)
        depth = (self.coil.outer_diameter - self.coil.inner_diameter) / 2
        if wire > min(self.coil.length, depth):
            raise ValueError(f"coil.wire_diameter: one enamelled wire ({wire:.3g} mm) does not fit the winding "
                             f"window (coil.length {self.coil.length:g} mm, radial depth {depth:.3g} mm)")
        return self

    # ---- derived geometry (mm) -------------------------------------------------------------
    @property
    def whisker_angles_deg(self) -> list[float]:
        """Angle of each whisker from +x, counter-clockwise seen from above, deg."""
        n = self.whiskers.count
        return [(self.whiskers.first_angle_deg + 360.0 * i / n) % 360.0 for i in range(n)]

    @property
    def pivot_z(self) -> float:
        """Whisker pivot: the membrane's mid-plane (the paper's assumption), mm."""
        return self.membrane.thickness / 2.0

    @property
    def rod_below_membrane(self) -> float:
        """Rod length below the membrane's lower face, mm."""
        w = self.whiskers
        return w.rod_length - w.protrusion - self.membrane.thickness

    @property
    def coil_axis_z(self) -> float:
        """Height of the (radial) coil axis, mm."""
        return -(self.coil.drop + self.coil.outer_diameter / 2.0)

    @property
    def marker_z(self) -> float:
        """Height of the marker plane (the coils' lower faces the camera sees), mm."""
        return -(self.coil.drop + self.coil.outer_diameter)

    @property
    def l_u(self) -> float:
        """Pivot to whisker tip, mm (the paper's l_u)."""
        return self.whiskers.protrusion + self.membrane.thickness - self.pivot_z

    @property
    def l_l(self) -> float:
        """Pivot to the tracked marker on the coil's lower face, mm (the paper's l_l)."""
        return self.pivot_z - self.marker_z

    @property
    def mm_per_px(self) -> float:
        """k: mm per pixel at the marker plane from the pinhole model, mm/px."""
        return self.camera.distance / self.camera.focal_length_px

    @property
    def camera_z(self) -> float:
        """Height of the lens's optical centre, mm."""
        return self.marker_z - self.camera.distance

    @property
    def cavity_radius(self) -> float:
        """Radius of the mount's coil cavity = where the magnets' faces sit: actuation.gap beyond the
        winding's outer face on the bobbin (whisker.design.former), mm."""
        from whisker.design.former import winding_face_offset
        return self.whiskers.ring_radius + winding_face_offset(self) + self.actuation.gap

    @property
    def neck_radius(self) -> float:
        """Radius of the opening under the membrane (inside the seat flange), mm.

        The flange leaves `mount.seat_ledge` of the membrane's rim to rest on, and never opens wider
        than the coil cavity: on a small ring it reaches in to cover the magnet pockets.
        """
        return min(self.membrane.inscribed_radius - self.mount.seat_ledge, self.cavity_radius)

    @property
    def membrane_circumradius(self) -> float:
        """Distance from centre to a membrane polygon vertex, mm."""
        m = self.membrane
        return m.inscribed_radius / math.cos(math.pi / m.sides)

    @property
    def mounting_hole_diameter(self) -> float:
        """The mount's robot-adapter holes as modelled: the fastener table's hole for
        fasteners.mount_screw / mount_joint (no print clearance added: inserts and thread-forming
        screws must grip, ISO 273 clearance holes already have theirs), mm."""
        from whisker.design.fasteners import hole
        f = self.fasteners
        return hole(f.mount_screw, f.mount_joint).diameter

    @property
    def mounting_hole_wall(self) -> float:
        """Thinnest wall around the mount's robot-adapter holes, mm: print.min_wall, or the fastener
        table's insert_min_wall where the joint is a heat-set insert (a hot insert bulges a thinner wall)."""
        from whisker.design.fasteners import hole
        f = self.fasteners
        return hole(f.mount_screw, f.mount_joint).wall(self.print.min_wall)

    @property
    def camera_screw_hole(self) -> float:
        """The mount's camera screw holes as modelled (fasteners.camera_screw / camera_joint), mm."""
        from whisker.design.fasteners import hole
        f = self.fasteners
        return hole(f.camera_screw, f.camera_joint).diameter

    def hole(self, nominal: float) -> float:
        """Printed hole diameter for a part of `nominal` diameter: nominal + 2 x clearance, mm."""
        return nominal + 2.0 * self.print.clearance

    def derived(self) -> dict[str, Any]:
        """The derived quantities other modules read, with units in their names."""
        return {"l_u_mm": self.l_u, "l_l_mm": self.l_l, "mm_per_px": self.mm_per_px,
                "pivot_z_mm": self.pivot_z, "marker_z_mm": self.marker_z, "camera_z_mm": self.camera_z,
                "coil_axis_z_mm": self.coil_axis_z, "cavity_radius_mm": self.cavity_radius,
                "neck_radius_mm": self.neck_radius, "rod_below_membrane_mm": self.rod_below_membrane,
                "whisker_angles_deg": self.whisker_angles_deg}

    # ---- identity -------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")

    def digest(self) -> str:
        """Stable hash of the resolved design (for build caching and provenance)."""
        blob = json.dumps(self.to_dict(), sort_keys=True).encode()
        return hashlib.sha256(blob).hexdigest()[:16]


# ---- loading -------------------------------------------------------------------------------

def parse_value(text: str) -> Any:
    """Parse an override's value as a TOML value (6, 10.5, true, "N52"); bare words are strings."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(data: dict[str, Any], overrides: Iterable[str]) -> dict[str, Any]:
    """Return a copy of `data` with ``section.key=value`` overrides applied."""
    out = json.loads(json.dumps(data))
    for item in overrides:
        if "=" not in item:
            raise DesignError(f"override {item!r}: expected section.key=value")
        key, text = item.split("=", 1)
        parts = key.strip().split(".")
        node = out
        for p in parts[:-1]:
            if not isinstance(node.get(p), dict):
                raise DesignError(f"override {key!r}: no section {p!r} in the design")
            node = node[p]
        if parts[-1] not in node:
            raise DesignError(f"override {key!r}: no parameter {parts[-1]!r} in [{'.'.join(parts[:-1])}]")
        node[parts[-1]] = parse_value(text.strip())
    return out


def design_from_dict(data: dict[str, Any]) -> Design:
    try:
        return Design.model_validate(data)
    except ValidationError as err:
        raise DesignError(one_line_errors(err)) from None


def load_design(path: str | Path | None = None, overrides: Iterable[str] = ()) -> Design:
    """Load and validate a design file (default: the paper's sensor) with optional overrides.

    Raises :class:`DesignError` with a one-line message naming the offending parameter(s).
    """
    from whisker.files import read_toml

    data = read_toml(Path(path) if path else DEFAULT_DESIGN, "design", DesignError)
    return design_from_dict(apply_overrides(data, overrides))


def default_design(*overrides: str) -> Design:
    """The paper's sensor, optionally with overrides (convenience for tests and notebooks)."""
    return load_design(None, overrides)
