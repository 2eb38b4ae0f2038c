"""The sections of a design file (hw/sensor.toml): one pydantic model per ``[section]``, each field with
its unit and bounds in its description. :class:`whisker.design.Design` puts them together and derives
what several modules need; the values marked "auto" are sized by the rules in :mod:`whisker.design.sizing`.

Units: millimetres, grams, seconds, volts, amperes, ohms, degrees, degrees Celsius, unless a field's
description says otherwise.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator


def _auto_or(lo: float, hi: float, unit: str, integer: bool = False, auto: str = "sized from the ring") -> BeforeValidator:
    """A value that is either "auto" (its rule in whisker.design.sizing decides) or a number in (lo, hi]."""
    def check(v):
        if v == "auto":
            return v
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and lo < v <= hi
        if not ok or (integer and v != int(v)):
            kind = "a whole number" if integer else "a number"
            raise ValueError(f'must be "auto" ({auto}) or {kind} in ({lo:g}, {hi:g}] {unit}')
        return int(v) if integer else float(v)
    return BeforeValidator(check)


# Sizes that follow the ring by default (hw/sensor.toml says "auto"; whisker.design.sizing holds the rules).
AutoMm = Annotated[Literal["auto"] | float, _auto_or(0, 1000, "mm")]
AutoCount = Annotated[Literal["auto"] | int, _auto_or(0, 64, "", integer=True)]
AutoTurns = Annotated[Literal["auto"] | int, _auto_or(0, 100000, "turns", integer=True)]
AutoOhm = Annotated[Literal["auto"] | float, _auto_or(0, 1e6, "ohm")]
# "auto" stays in the design and is resolved by whisker.mechanics.membrane.design_stiffness_Nmm_per_rad (the
# finite-element model sits in the layer above the design model, like driver.series_resistance's rule).
AutoStiffness = Annotated[Literal["auto"] | float, _auto_or(0, 1e4, "N*mm/rad", auto="the membrane model")]
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
    end_stop: bool = Field(False, description=(
        "a post on the bobbin's outer flange meets the magnet's face at whiskers.max_deflection_deg: "
        "retraction (and pull-in) ends on it, coil clear of the magnet (whisker.design.stop)"))


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
        from whisker.design.camera_boards import CameraBoardError, profile
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
        from whisker.design.camera_boards import profile
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
                         "one source of the bed, height, nozzle, layer and filament numbers (whisker.design.printer)")
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
        from whisker.design.printer import ProfileError, load_profile
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
        from whisker.design.printer import load_profile
        have = float(getattr(load_profile(info.data["profile"]), info.field_name))
        if v is not None and abs(v - have) > 1e-9 * max(1.0, abs(have)):
            raise ValueError(f"comes from the printer profile {info.data['profile']} ({have:g} there); "
                             "edit the profile or set print.profile")
        return have


class Export(_Section):
    linear_tolerance: float = Field(gt=0, le=1, description="mm")
    angular_tolerance: float = Field(gt=0, le=1.5, description="rad")


class Mechanics(_Section):
    rotational_stiffness: AutoStiffness = Field(description=(
        "N*mm/rad about a whisker's pivot; auto: the membrane's finite-element model from its geometry and "
        "the silicone's data (whisker.mechanics.membrane), a number overrides it (e.g. `whisker calibrate stiffness`)"))
    damping_ratio: float = Field(ge=0, le=100, description="dimensionless")
    rod_density: float = Field(gt=0, le=25, description="g/cm^3")
    rod_modulus: float = Field(125.0, gt=0, le=1000, description="GPa, Young's modulus of the rod in bending")
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
        "duty (whisker.coil.driver.series_resistance_ohm)"))

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
        "V measured across a coil at 100 % PWM duty; 0 = from the driver model (whisker.coil.driver)"))
    max_coil_voltage: float = Field(gt=0, le=50, description="V, coil rating: higher levels are refused")
    pwm_frequency: float = Field(ge=10, le=100000, description="Hz, PWM on the H-bridge inputs")
    guard_margin: float = Field(ge=0, le=200, description="C below the first thermal limit where a coil is cut")
    guard_derate_band: float = Field(ge=0, le=200, description="C below the cut-off where derating starts")
    guard_hysteresis: float = Field(gt=0, le=200, description="C a cut coil cools below the cut-off before re-use")
    guard_period: float = Field(gt=0, le=1, description="s between thermal-guard updates")
    safe_levels: tuple[Annotated[float, Field(gt=0, le=1)], ...] = Field((), description=(
        "per whisker, the largest |level| measured safe at bring-up (whisker calibrate stiffness); higher "
        "levels are refused; () = the rating only"))
    grasp_levels: tuple[Annotated[float, Field(gt=0, le=1)], ...] = Field((), description=(
        "per whisker, the retract level set at bring-up (whisker calibrate stiffness): reaches the end stop "
        "hot, with margin; () = actuation.voltage for every whisker"))


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
        from whisker.design.fasteners import FastenerError, fastener
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
        from whisker.design.flanges import flanges  # the table's loader (hw/flanges.csv), loaded on use
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
    stop_post_diameter: float = Field(1.0, gt=0, le=10, description=(
        "mm, the end-stop post on the outer flange (actuation.end_stop); its length follows from the stop tilt"))


class WindingJig(_Section):
    shank_diameter: float = Field(6.0, gt=0, le=13, description="mm, for a drill chuck")
    shank_length: float = Field(25.0, gt=0, le=100, description="mm")
    disc_diameter: float = Field(24.0, gt=0, le=100, description="mm")
    disc_thickness: float = Field(4.0, gt=0, le=20, description="mm")
    flag_length: float = Field(6.0, gt=0, le=50, description="mm the counting flag reaches past the disc")
    flag_width: float = Field(3.0, gt=0, le=20, description="mm")
    counter_magnet: tuple[float, float] = Field((3.0, 2.0), description="mm, counting magnet diameter x height")
