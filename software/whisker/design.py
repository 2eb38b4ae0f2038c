"""The design model: every dimension of the sensor, validated, in one object.

`load_design()` reads a TOML design file (default: ``hw/sensor.toml``, the paper's sensor), applies
``section.key=value`` overrides and returns a frozen, validated :class:`Design`. Every other module
(CAD, coil calculator, BOM, tracking, simulator) takes a ``Design`` and derives what it needs from
it; no dimension is typed twice. Derived quantities (pivot height, l_u, l_l, mm per pixel, whisker
angles, cavity radius ...) are properties here so that every module derives them the same way.

Units: millimetres, grams, seconds, volts, amperes, ohms, degrees, degrees Celsius, unless a field's
description says otherwise. Coordinates: z = 0 on the membrane's lower face, z up, sensor axis = z.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Annotated, Any, Iterable, Literal

from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, PrivateAttr, ValidationError, field_validator,
                      model_validator)

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]


class DesignError(ValueError):
    """A design that cannot be built. The message is one line naming the parameter(s)."""


def _default_design_path() -> Path:
    # hw/sensor.toml in a clone, the copy shipped in the wheel otherwise (whisker.resources).
    from whisker.resources import default_design_path

    return default_design_path()


DEFAULT_DESIGN = _default_design_path()

def _auto_or(lo: float, hi: float, unit: str, integer: bool = False) -> BeforeValidator:
    """A value that is either "auto" (its rule in whisker.sizing decides) or a number in (lo, hi]."""
    def check(v):
        if v == "auto":
            return v
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and lo < v <= hi
        if not ok or (integer and v != int(v)):
            kind = "a whole number" if integer else "a number"
            raise ValueError(f'must be "auto" (sized from the ring) or {kind} in ({lo:g}, {hi:g}] {unit}')
        return int(v) if integer else float(v)
    return BeforeValidator(check)


# Sizes that follow the ring by default (hw/sensor.toml says "auto"; whisker.sizing holds the rules).
AutoMm = Annotated[Literal["auto"] | float, _auto_or(0, 1000, "mm")]
AutoCount = Annotated[Literal["auto"] | int, _auto_or(0, 64, "", integer=True)]
AutoTurns = Annotated[Literal["auto"] | int, _auto_or(0, 100000, "turns", integer=True)]
AutoOhm = Annotated[Literal["auto"] | float, _auto_or(0, 1e6, "ohm")]
# Finite physical bounds for plain sizes: a part on this printer is never a metre long.
Mm = Annotated[float, Field(gt=0, le=1000)]


class _Section(BaseModel):
    # Unknown keys are typos: refuse them instead of silently ignoring a user's value.
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Whiskers(_Section):
    count: int = Field(ge=1, le=64, description="number of whiskers")
    ring_radius: float = Field(ge=1, le=100, description="mm, circle of rod centres")
    rod_diameter: float = Field(gt=0, le=20, description="mm")
    rod_length: float = Field(gt=0, le=1000, description="mm, whole rod")
    protrusion: float = Field(gt=0, le=1000, description="mm of rod above the membrane's upper face")
    max_deflection_deg: float = Field(gt=0, lt=45, description="deg, largest tilt about the pivot")
    first_angle_deg: float = Field(ge=-360, le=360, description="deg, whisker 0 from +x, CCW")


class Membrane(_Section):
    sides: int = Field(ge=3, le=64, description="regular polygon side count")
    inscribed_radius: AutoMm = Field(description="mm; auto: the seat opening passes and clears the coils")
    thickness: float = Field(gt=0, le=50, description="mm")
    material: str = "Ecoflex 00-30"
    density: float = Field(gt=0, le=25, description="g/cm^3")


class Coil(_Section):
    outer_diameter: float = Field(gt=0, le=50, description="mm")
    inner_diameter: float = Field(gt=0, le=50, description="mm, winding bore")
    length: float = Field(gt=0, le=50, description="mm along the (radial) coil axis")
    drop: float = Field(ge=0, le=50, description="mm from the membrane's lower face to the coil's top")
    wire_diameter: float = Field(gt=0, le=5, description="mm, bare copper")
    turns: AutoTurns = Field(description="turns; auto: as many as fit the bobbin's window at winding.fill_factor")
    resistance: AutoOhm = Field(description="ohm at 20 C; auto: the winding's (coil.turns of the wire on the "
                                "bobbin); or your coil's measured value")
    marker_diameter: float = Field(gt=0, le=50, description="mm, red dot on the coil's lower face")


class Magnet(_Section):
    diameter: float = Field(gt=0, le=50, description="mm")
    height: float = Field(gt=0, le=50, description="mm along the magnetisation")
    grade: str = "N42"
    remanence: float = Field(gt=0, lt=2, description="T")
    max_temperature: float = Field(gt=0, le=400, description="C")


class Actuation(_Section):
    gap: float = Field(gt=0, le=50, description="mm between the winding's outer face and the magnet face at rest")
    voltage: float = Field(gt=0, le=50, description="V at the coil for grasping")


class Camera(_Section):
    distance: AutoMm = Field(description="mm, marker plane to the lens's optical centre; auto: the ring "
                             "keeps ring_radius_px in the image")
    ring_radius_px: float = Field(gt=1, le=10000, description="px, the ring's radius in the (undistorted) image "
                                  "that camera.distance = auto keeps")
    edge_margin_px: float = Field(ge=0, le=1000, description="px a marker at full deflection keeps from the image edge")
    focal_length_px: float = Field(gt=0, le=100000, description="px")
    width_px: int = Field(ge=16, le=100000)
    height_px: int = Field(ge=16, le=100000)
    board: str = Field("ov5647_m12", min_length=1, description=(
        "camera board profile (hw/camera_boards.toml): the one source of the board's outline, holes, lens "
        "offset and holder; `whisker design show` lists them"))
    # Read from the board profile; a design file may repeat them only with the profile's values.
    board_width: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    board_height: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    board_thickness: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    lens_height: float | None = Field(default=None, validate_default=True,
                                      description="mm, board front face to optical centre, from the profile")
    lens_block: float | None = Field(default=None, validate_default=True,
                                     description="mm, the lens holder's larger side, from the profile")
    hole_spacing_x: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    hole_spacing_y: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    hole_diameter: float | None = Field(default=None, validate_default=True,
                                        description="mm, the board's holes, from the profile")

    @field_validator("board")
    @classmethod
    def _board_known(cls, v: str) -> str:
        from whisker.camera_boards import CameraBoardError, profile
        try:
            profile(v)
        except CameraBoardError as err:
            raise ValueError(str(err)) from None
        return v

    @field_validator("board_width", "board_height", "board_thickness", "lens_height", "lens_block",
                     "hole_spacing_x", "hole_spacing_y", "hole_diameter")
    @classmethod
    def _from_board(cls, v: float | None, info) -> float | None:
        if "board" not in info.data:
            return v  # the profile's own error is reported
        from whisker.camera_boards import profile
        p = profile(info.data["board"])
        have = {"board_width": p.board.width, "board_height": p.board.height, "board_thickness": p.board.thickness,
                "lens_height": p.lens.optical_centre_height, "lens_block": max(p.lens.holder),
                "hole_spacing_x": p.holes.spacing_x, "hole_spacing_y": p.holes.spacing_y,
                "hole_diameter": p.holes.diameter}[info.field_name]
        if v is not None and abs(v - have) > 1e-9 * max(1.0, abs(have)):
            raise ValueError(f"comes from the camera board profile {info.data['board']} ({have:g} there); "
                             "edit hw/camera_boards.toml or set camera.board")
        return float(have)


class Mount(_Section):
    outer_radius: AutoMm = Field(description="mm; auto: min wall outside every inner feature, whole mm")
    glue_gap: float = Field(ge=0, le=10, description="mm behind each magnet")
    led_strip_width: float = Field(gt=0, le=50, description="mm")
    led_strip_thickness: float = Field(gt=0, le=20, description="mm")
    led_drop: float = Field(ge=0, le=50, description="mm from the pockets' lower edge to the LED channel")
    seat_ledge: float = Field(gt=0, le=20, description="mm of the membrane's rim resting on the seat flange")
    flange_thickness: float = Field(gt=0, le=20, description="mm, seat flange above the (wider) coil cavity")
    camera_recess: float = Field(ge=0, le=50, description="mm below the camera board")
    mounting_hole_count: int = Field(ge=0, le=12)
    mounting_hole_depth: float = Field(gt=0, le=100, description="mm, blind; the hole's diameter comes from "
                                       "fasteners.mount_screw / mount_joint")
    mounting_bolt_radius: AutoMm = Field(description="mm; auto: as far out as the outer wall allows")
    cable_exit_diameter: float = Field(gt=0, le=20, description="mm")
    cable_exit_count: AutoCount = Field(description="auto: one per four coils")
    ribbon_width: float = Field(gt=0, le=100, description="mm")
    ribbon_thickness: float = Field(gt=0, le=20, description="mm")


class Mold(_Section):
    wall: float = Field(gt=0, le=50, description="mm")
    floor: float = Field(gt=0, le=50, description="mm")
    lid_thickness: float = Field(gt=0, le=50, description="mm")
    pin_diameter: float = Field(gt=0, le=20, description="mm")
    pin_height: float = Field(gt=0, le=20, description="mm")
    pour_diameter: AutoMm = Field(description="mm; auto: the largest up to max_pour_diameter inside the ring")
    max_pour_diameter: float = Field(gt=0, le=100, description="mm, the pour opening a cup's spout needs")
    vent_diameter: float = Field(gt=0, le=20, description="mm")
    draft_deg: float = Field(ge=0, le=15, description="deg, draft of the cavity's side walls (release upwards)")
    rod_slack: float = Field(ge=0, le=10, description="mm of axial play above each rod's tip in the ring's socket")


class Ring(_Section):
    hole_depth: float = Field(gt=0, le=100, description="mm")
    plate_thickness: float = Field(gt=0, le=100, description="mm")
    tube_wall: float = Field(gt=0, le=50, description="mm")
    margin: float = Field(gt=0, le=50, description="mm")


class Print(_Section):
    clearance: float = Field(ge=0, le=2, description="mm, radial, added to holes and pockets")
    min_wall: float = Field(gt=0, le=20, description="mm")
    profile: str = Field(min_length=1, description="PrusaSlicer printer profile .ini (relative to hw/): the "
                         "one source of the bed, height, nozzle, layer and filament numbers (whisker.printer)")
    coupon_clearances: tuple[float, ...] = Field(min_length=1, max_length=12,
                                                 description="mm, radial clearances tried on the tolerance coupon")
    # Read from the profile; a design file may repeat them only with the profile's values.
    bed_x: float | None = Field(default=None, validate_default=True, description="mm, from the profile's bed_shape")
    bed_y: float | None = Field(default=None, validate_default=True, description="mm, from the profile's bed_shape")
    max_height: float | None = Field(default=None, validate_default=True, description="mm, max_print_height")
    nozzle_diameter: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    layer_height: float | None = Field(default=None, validate_default=True, description="mm, from the profile")
    filament_density: float | None = Field(default=None, validate_default=True, description="g/cm^3, from the profile")

    @field_validator("profile")
    @classmethod
    def _profile_readable(cls, v: str) -> str:
        from whisker.printer import ProfileError, load_profile
        try:
            load_profile(v)
        except ProfileError as err:
            raise ValueError(str(err)) from None
        return v

    @field_validator("coupon_clearances")
    @classmethod
    def _clearances(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        if any(not (0.0 <= c <= 1.0) for c in v) or len(set(v)) != len(v):
            raise ValueError("each clearance must be in [0, 1] mm and appear once")
        return tuple(sorted(v))

    @field_validator("bed_x", "bed_y", "max_height", "nozzle_diameter", "layer_height", "filament_density")
    @classmethod
    def _from_profile(cls, v: float | None, info) -> float | None:
        if "profile" not in info.data:
            return v  # the profile's own error is reported
        from whisker.printer import load_profile
        have = float(getattr(load_profile(info.data["profile"]), info.field_name))
        if v is not None and abs(v - have) > 1e-9 * max(1.0, abs(have)):
            raise ValueError(f"comes from the printer profile {info.data['profile']} ({have:g} there); "
                             "edit the profile or set print.profile")
        return have


class Export(_Section):
    linear_tolerance: float = Field(gt=0, le=1, description="mm")
    angular_tolerance: float = Field(gt=0, le=1.5, description="rad")


class Mechanics(_Section):
    rotational_stiffness: float = Field(gt=0, le=1e4, description="N*mm/rad about a whisker's pivot")
    damping_ratio: float = Field(ge=0, le=100, description="dimensionless")
    rod_density: float = Field(gt=0, le=25, description="g/cm^3")
    tip_friction: float = Field(ge=0, le=10, description="Coulomb coefficient of the tips")


class Thermal(_Section):
    ambient: float = Field(ge=-50, le=100, description="C")
    pla_softening: float = Field(gt=0, le=400, description="C")
    enamel_class: float = Field(gt=0, le=400, description="C")
    convection_coefficient: float = Field(20.0, gt=0, le=1000, description="W/(m^2 K), coil surface to air")
    emissivity: float = Field(0.9, ge=0, le=1, description="coil surface (enamel)")
    rod_conductance: float = Field(0.0015, ge=0, le=100, description="W/K, coil to membrane through the rod")
    former_specific_heat: float = Field(0.8, gt=0, le=100, description="J/(g K), core in the coil bore (the rod)")


class Driver(_Section):
    type: str = Field(description="H-bridge module name")
    supply_voltage: float = Field(gt=0, le=100, description="V into the H-bridge")
    series_resistance: Literal["auto"] | float = Field("auto", description=(
        "ohm, resistor in series with each coil between the H-bridge output and the coil; 0 = none; "
        "'auto' = the smallest E24 value that keeps a cold coil at <= drive.max_coil_voltage at 100 % "
        "duty (whisker.driver.series_resistance_ohm)"))

    @field_validator("series_resistance", mode="before")
    @classmethod
    def _series_resistance(cls, v):
        if v == "auto":
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 <= v <= 1000):
            raise ValueError("must be \"auto\" or a resistance in ohm from 0 (none) to 1000")
        return float(v)


class Drive(_Section):
    full_scale_voltage: float = Field(ge=0, le=50, description=(
        "V measured across a coil at 100 % PWM duty; 0 = from the driver model (whisker.driver)"))
    max_coil_voltage: float = Field(gt=0, le=50, description="V, coil rating: higher levels are refused")
    pwm_frequency: float = Field(ge=10, le=100000, description="Hz, PWM on the H-bridge inputs")
    guard_margin: float = Field(ge=0, le=200, description="C below the first thermal limit where a coil is cut")
    guard_derate_band: float = Field(ge=0, le=200, description="C below the cut-off where derating starts")
    guard_hysteresis: float = Field(gt=0, le=200, description="C a cut coil cools below the cut-off before re-use")
    guard_period: float = Field(gt=0, le=1, description="s between thermal-guard updates")


class Wiring(_Section):
    expander: Literal["none", "pca9685"] = Field(
        description="none: coils on Pi GPIO (2 per coil, <= 11 coils); pca9685: I2C PWM expander(s)")
    pca9685_address: int = Field(ge=0x40, le=0x6F, description="I2C address of the first PCA9685")
    coil_order: tuple[int, ...] = Field((), description=(
        "pin-map override (whisker calibrate wiring): coil_order[i] = pin-map channel driving whisker i; () = i"))
    coil_polarity: tuple[int, ...] = Field((), description=(
        "pin-map override: +1/-1 per whisker, -1 swaps that channel's forward/backward pins; () = all +1"))


class Bom(_Section):
    wire_waste: float = Field(ge=0, le=5, description="fraction of magnet wire added for practice/scrap")
    coil_lead_length: float = Field(ge=0, le=10000, description="mm of magnet wire per coil lead (2 leads per coil)")
    ecoflex_waste: float = Field(ge=0, le=5, description="fraction of Ecoflex added (cup, sprue, vents)")
    pla_waste: float = Field(ge=0, le=5, description="fraction of PLA added (brim, purge, failed prints)")
    led_cut_pitch: float = Field(gt=0, le=1000, description="mm between the LED strip's cut marks")


class Tracking(_Section):
    image_up_deg: float = Field(ge=-360, le=360, description=(
        "deg, direction in the sensor frame (CCW from +x, seen from above) that appears at the top "
        "of the camera image"))
    marker_search_px: float = Field(gt=0, le=200, description=(
        "px, largest marker motion between two frames that frame-to-frame matching accepts"))


class Winding(_Section):
    enamel_grade: int = Field(1, ge=1, le=3, description="IEC 60317 enamel grade (1 thin .. 3 thick)")
    fill_factor: float = Field(0.55, gt=0, lt=0.907, description="copper area / winding window area")


Joint = Literal["insert", "tap", "through"]


class Fasteners(_Section):
    """Each fastened joint's screw (hw/fasteners.csv) and how it holds in the printed part:
    insert (heat-set), tap (thread-forming into a pilot) or through (a clearance hole and a nut)."""

    camera_screw: str = Field("M2", description="camera board to the mount")
    camera_joint: Joint = "tap"
    mount_screw: str = Field("M3", description="mount to the robot adapter, from below")
    mount_joint: Joint = "insert"
    cover_screw: str = Field("M2", description="camera cover to the mount, from below")
    cover_joint: Joint = "tap"

    @field_validator("camera_screw", "mount_screw", "cover_screw")
    @classmethod
    def _known(cls, v: str) -> str:
        from whisker.fasteners import FastenerError, fastener
        try:
            fastener(v)
        except FastenerError as err:
            raise ValueError(str(err)) from None
        return v


class Adapter(_Section):
    preset: str = Field("iso9409_50_4_m6", description="robot flange, a row of hw/flanges.csv (ISO 9409-1) or plain")
    under_head: float = Field(4.0, gt=0, le=50, description="mm of plate under each screw head at least")
    relief_depth: float = Field(2.5, ge=0, le=20, description="mm, top-face pocket for the board's back and cable")
    coupling_count: int = Field(4, ge=2, le=12, description="screws from the adapter into the flange plate")

    @field_validator("preset")
    @classmethod
    def _known_flange(cls, v: str) -> str:
        from whisker.cad.extras import flanges  # the table's loader (hw/flanges.csv), loaded on use
        if v not in flanges():
            raise ValueError(f"unknown flange {v!r}; known: {', '.join(flanges())}")
        return v


class Cover(_Section):
    thickness: float = Field(2.0, gt=0, le=20, description="mm under the relief")
    relief_depth: float = Field(2.5, ge=0, le=20, description="mm, room for the board's back and the flat cable")
    margin: float = Field(4.5, gt=0, le=30, description="mm of cover around the pocket (grows to hold the screws)")


class Bobbin(_Section):
    flange: float = Field(0.35, gt=0, le=5, description="mm, outer flange thickness (resin print)")
    rim_margin: float = Field(0.15, ge=0, le=2, description="mm of flange outside the outermost turn")
    tab: float = Field(2.0, gt=0, le=10, description="mm, rod tab thickness along the coil axis")
    socket_depth: float = Field(2.0, gt=0, le=20, description="mm of rod above the coil axis in the tab, at most")
    lead_hole: float = Field(0.35, gt=0, le=2, description="mm, the two lead holes beside the rod")
    min_wall: float = Field(0.3, gt=0, le=5, description="mm, the resin process's thinnest wall")


class WindingJig(_Section):
    shank_diameter: float = Field(6.0, gt=0, le=13, description="mm, for a drill chuck")
    shank_length: float = Field(25.0, gt=0, le=100, description="mm")
    disc_diameter: float = Field(24.0, gt=0, le=100, description="mm")
    disc_thickness: float = Field(4.0, gt=0, le=20, description="mm")
    flag_length: float = Field(6.0, gt=0, le=50, description="mm the counting flag reaches past the disc")
    flag_width: float = Field(3.0, gt=0, le=20, description="mm")
    counter_magnet: tuple[float, float] = Field((3.0, 2.0), description="mm, counting magnet diameter x height")


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
        """Replace every "auto" by its rule (whisker.sizing) before the model is built."""
        if not isinstance(data, dict):
            return handler(data)
        from whisker.sizing import resolve_auto

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
        # measured on the solids by whisker.cad.checks instead.
        if self.coil.inner_diameter >= self.coil.outer_diameter:
            raise ValueError("coil.inner_diameter must be smaller than coil.outer_diameter")
        from whisker.fasteners import FastenerError, hole
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
        from whisker.coil import enamel_overall_diameter_mm  # the same wire model as `whisker coil report`

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
        winding's outer face on the bobbin (whisker.former), mm."""
        from whisker.former import winding_face_offset
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
        from whisker.fasteners import hole
        f = self.fasteners
        return hole(f.mount_screw, f.mount_joint).diameter

    @property
    def camera_screw_hole(self) -> float:
        """The mount's camera screw holes as modelled (fasteners.camera_screw / camera_joint), mm."""
        from whisker.fasteners import hole
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


def one_line_errors(err: ValidationError) -> str:
    """A pydantic ValidationError as one line: ``key.path: message (got value); ...``.

    The offending input is shown unless it is a whole section (a dict), which would flood the line.
    """
    msgs = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        inp = e.get("input")
        shown = "" if isinstance(inp, dict) else f" (got {inp!r})"
        msgs.append(f"{loc}: {msg}{shown}" if loc else msg)
    return "; ".join(msgs)


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
