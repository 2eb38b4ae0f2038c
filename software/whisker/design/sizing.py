"""Sizes that follow the ring: the rules behind every design value set to ``"auto"``.

A design file may give a ring-dependent size as a number (it is then used as given) or as
``"auto"``; :func:`resolve_auto` replaces each ``"auto"`` by its rule, in the order of
:data:`RULES` (later rules read the values of earlier ones). Each rule is a pure function of the
design and says why it is what it is. For the paper's sensor (8 whiskers at R = 12 mm) the rules
give back the paper's sizes: membrane 16 mm, mount 22 mm, camera 35.2 mm below the markers.

The mount's layout (heights of its features, lens opening, pocket and LED radii) lives here too,
so that the design model can size the mount without CadQuery; ``whisker.cad.solids.mount`` builds the
solid from the same numbers.

Units: mm and degrees. Coordinates as everywhere: z = 0 on the membrane's lower face, z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from whisker.design.model import Design

# The membrane is a cast part: its size rounds up to half millimetres (a mould maker's step).
MEMBRANE_STEP_MM = 0.5
# Fewest sides of an "auto" membrane outline: fewer put the corners far out from the rods (a square's
# corners are 1.41 x its inscribed radius out). hw/sensor.toml pins the paper's octagon: on the sweep's
# smallest rings the membrane's side-count check measured one or two sides more than "auto" asked
# (not yet investigated), so "auto" is what to set for another whisker count, not yet the default.
MIN_MEMBRANE_SIDES = 5
# The mount's outer radius rounds up to whole millimetres (a printed body; the sizes stay readable).
MOUNT_STEP_MM = 1.0
# Tilts sampled over the swing when finding how far a coil reaches (31 gives < 0.01 mm error).
SWING_SAMPLES = 31


def ceil_step(x: float, step: float) -> float:
    """x rounded up to a multiple of step (a value already on the grid stays)."""
    return round(math.ceil(x / step - 1e-9) * step, 9)


def floor_step(x: float, step: float) -> float:
    return round(math.floor(x / step + 1e-9) * step, 9)


# ---- the mount's layout (mm) ---------------------------------------------------------------

def mount_levels(d: "Design") -> dict[str, float]:
    """Heights (z, mm) of the mount's features, shared by the model, its checks and the rules."""
    pocket_d = d.hole(d.magnet.diameter)
    led_top = d.coil_axis_z - pocket_d / 2 - d.mount.led_drop
    led_bottom = led_top - d.hole(d.mount.led_strip_width)
    cyl_bottom = led_bottom - d.print.min_wall
    board_face = d.camera_z - d.camera.lens_height
    bottom = board_face - d.camera.board_thickness - d.mount.camera_recess
    cable = cyl_bottom - d.mount.cable_exit_diameter / 2 - d.print.min_wall
    return dict(top=d.membrane.thickness, seat=0.0, pocket=d.coil_axis_z, pocket_top=d.coil_axis_z + pocket_d / 2,
                led_top=led_top, led_bottom=led_bottom, cylinder_bottom=cyl_bottom, cable=cable,
                board_face=board_face, bottom=bottom)


def lens_radius(d: "Design") -> float:
    """Radius of the opening above the camera board: the lens holder's half-diagonal + clearance."""
    return d.camera.lens_block / math.sqrt(2) + d.print.clearance


def pocket_outer_radius(d: "Design") -> float:
    """Radius where the magnet pockets end (magnet + glue gap behind it), mm."""
    return d.cavity_radius + d.magnet.height + d.mount.glue_gap


def led_outer_radius(d: "Design") -> float:
    return d.cavity_radius + d.mount.led_strip_thickness + d.print.clearance


def lens_top_z(d: "Design") -> float:
    """Top of the lens (it reaches up to the optical centre): the round opening goes straight up
    to here, then the cone widens, mm."""
    return d.camera_z


def holder_top_z(d: "Design") -> float:
    """Top of the lens holder's square pocket (the profile's holder height above the board), mm."""
    from whisker.design.camera_boards import profile
    return mount_levels(d)["board_face"] + min(profile(d.camera.board).lens.holder_height, d.camera.lens_height)


def cone_radius_at(d: "Design", z: float) -> float:
    """Radius of the mount's inner cone (lens opening up to the coil cavity) at height z, mm."""
    lv = mount_levels(d)
    z0, z1 = min(lens_top_z(d), lv["cylinder_bottom"]), lv["cylinder_bottom"]
    r0, r1 = lens_radius(d), d.cavity_radius
    if z1 <= z0:
        return max(r0, r1)
    t = min(1.0, max(0.0, (z - z0) / (z1 - z0)))
    return r0 + t * (r1 - r0)


def camera_pocket_box(d: "Design") -> tuple[float, float, float, float]:
    """The camera board pocket (x0, y0, x1, y1), mm: the board of camera.board placed with its lens
    on the sensor axis and its cable towards -y (whisker.design.camera_boards.placement), plus clearance."""
    from whisker.design.camera_boards import placement, profile
    p = placement(profile(d.camera.board), 270.0)
    (cx, cy), (w, h) = p.board_centre, p.board_size
    w, h = d.hole(w), d.hole(h)
    return cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2


def mounting_hole_angles(d: "Design") -> list[float]:
    """Robot mounting holes, deg: spaced evenly and symmetric about the camera's flat cable at -y,
    none on it (3 holes: 90, 210, 330 deg; 2 holes: 0, 180 deg)."""
    n = d.mount.mounting_hole_count
    return [(270.0 + 180.0 / n + 360.0 * k / n) % 360.0 for k in range(n)]


def cable_exit_angles(d: "Design") -> list[float]:
    """Radial cable exits, each midway between two neighbouring whiskers, deg."""
    n, k = d.whiskers.count, d.mount.cable_exit_count
    step = 360.0 / n
    return [d.whiskers.first_angle_deg + step / 2 + step * round(i * n / k) for i in range(k)]


# ---- how far a coil reaches over its swing ---------------------------------------------------

def coil_surface_points(d: "Design", tilt_deg: float) -> np.ndarray:
    """Points on whisker 0's coil as it is made - the bobbin and its winding (whisker.design.former) - (x
    radial, y tangential, z), tilted by tilt_deg about the pivot (retraction positive: tip in, coil
    out), mm. They hold every extreme point a distance from the sensor axis can reach."""
    from whisker.design.former import envelope_points
    return envelope_points(d, tilt_deg)


def coil_reach(d: "Design", z_min: float = -math.inf, tilts: bool = True) -> float:
    """Largest distance from the sensor axis that a coil reaches at heights >= z_min, over the full
    swing (or at rest when tilts is False), mm; -inf when no part of the coil rises that high."""
    theta = d.whiskers.max_deflection_deg
    best = -math.inf
    for t in (np.linspace(-theta, theta, SWING_SAMPLES) if tilts else [0.0]):
        p = coil_surface_points(d, float(t))
        p = p[p[:, 2] >= z_min]
        if len(p):
            best = max(best, float(np.max(np.hypot(p[:, 0], p[:, 1]))))
    return best


def coil_inner_chord_radius(d: "Design") -> float:
    """rho: distance from the axis of a coil's inner corners - the bobbin tab's inner face, its lower
    edge at +-D/2 - at full inward swing (extension, tip out, coil in), mm.

    Rotating the tab's inner lower edge (R - a, z_marker), a = bobbin.tab / 2, by the full deflection
    about the pivot (R, z_pivot) brings it to R - a cos(theta) - (z_pivot - z_marker) sin(theta).
    """
    from whisker.design.former import inner_offset
    th = math.radians(d.whiskers.max_deflection_deg)
    return d.whiskers.ring_radius - inner_offset(d) * math.cos(th) - (d.pivot_z - d.marker_z) * math.sin(th)


def crowding_bound_radius(d: "Design", count: int | None = None) -> float:
    """Smallest ring radius at which neighbouring coils clear each other at full inward swing, mm.

    Neighbours sit 360/N deg apart. At full inward swing (extension) their inner corners - the lower
    edge of the bobbin tab's inner face, +-D/2 either side of the coil axis - are rho from the sensor
    axis (:func:`coil_inner_chord_radius`). The chord between two neighbours' facing corners must
    leave the print clearance c:

        2 rho sin(pi/N) - D cos(pi/N) >= c,   rho = R - a cos(theta) - h sin(theta)

    so R >= (c/2 + (D/2) cos(pi/N)) / sin(pi/N) + a cos(theta) + h sin(theta), with a = bobbin.tab / 2
    (rod to the tab's inner face), h the pivot's height above the marker plane (the tab's lower face),
    D the coil diameter and theta the largest deflection. For N = 2 the two coils face each other
    head on: their lowest inner edges must stay c apart.
    """
    from whisker.design.former import inner_offset
    n = count or d.whiskers.count
    th = math.radians(d.whiskers.max_deflection_deg)
    clr = max(d.print.clearance, 0.05)
    if n <= 1:
        return 0.0
    swing_in = inner_offset(d) * math.cos(th) + (d.pivot_z - d.marker_z) * math.sin(th)
    if n == 2:
        return clr / 2 + swing_in
    a = math.pi / n
    return (clr / 2 + d.coil.outer_diameter / 2 * math.cos(a)) / math.sin(a) + swing_in


def coil_turns(d: "Design", auto: frozenset = frozenset()) -> int:
    """As many turns as fit the bobbin's winding window (whisker.design.former) at winding.fill_factor."""
    from whisker.design.former import window
    from whisker.design.validation import DesignError
    from whisker.design.wire import CoilError, max_turns_at_fill
    a1, a2, _ = window(d)
    if a2 <= a1:
        raise DesignError(f"coil.inner_diameter ({2 * a1:g} mm) must be smaller than coil.outer_diameter less "
                          f"2 x bobbin.rim_margin ({2 * a2:g} mm): the bobbin has no winding window")
    try:
        return max_turns_at_fill(d)
    except CoilError:  # the wire is thicker than the window: the design model refuses it, naming the wire
        return 1


def coil_resistance(d: "Design", auto: frozenset = frozenset()) -> float:
    """The 20 C resistance of coil.turns of the wire wound on the bobbin (whisker.design.wire, the model
    behind whisker.coil.winding)."""
    from whisker.design.wire import CoilError, resistance_20C_ohm
    try:
        return round(resistance_20C_ohm(d), 4)
    except CoilError:  # as in coil_turns: refused by the design model
        return 1.0


# ---- the rules --------------------------------------------------------------------------------

def led_strip(d: "Design") -> tuple[float, int, float]:
    """(channel circumference mm, whole strip segments that fit, strip length mm) of the LED channel:
    the strip is bought and cut in whole segments of bom.led_cut_pitch, so it covers
    segments x pitch of the 2 pi (cavity radius + strip thickness) channel. Raises DesignError
    when not one segment fits."""
    circ = 2 * math.pi * (d.cavity_radius + d.mount.led_strip_thickness)
    segments = math.floor(circ / d.bom.led_cut_pitch)
    if segments < 1:
        from whisker.design.validation import DesignError
        raise DesignError(f"the LED channel (circumference {circ:.1f} mm) is shorter than one strip segment "
                          f"(bom.led_cut_pitch = {d.bom.led_cut_pitch} mm)")
    return circ, segments, segments * d.bom.led_cut_pitch


def membrane_sides(d: "Design", auto: frozenset = frozenset()) -> int:
    """The smallest multiple of whiskers.count with at least MIN_MEMBRANE_SIDES sides: the outline
    then has the ring's symmetry, each rod faces the middle of a flat (shapes.polygon_points puts a
    flat at +x, whisker 0 at first_angle_deg = 0) and every rod is the same distance from the rim
    (same membrane stiffness). An octagon for 8 whiskers (the paper), a heptagon for 7."""
    n = d.whiskers.count
    return n * math.ceil(MIN_MEMBRANE_SIDES / n)


def membrane_inscribed_radius(d: "Design", auto: frozenset = frozenset()) -> float:
    """The seat's opening (membrane inscribed radius - seat ledge) must let every coil pass at rest
    (the membrane goes in from above carrying its rods and coils) and clear, by the print clearance,
    every part of a swinging coil that rises to the seat flange's underside; rounded up to 0.5 mm."""
    clr = d.print.clearance
    band = -(d.mount.flange_thickness + clr)
    need = max(coil_reach(d, tilts=False), coil_reach(d, z_min=band)) + clr
    return ceil_step(need + d.mount.seat_ledge, MEMBRANE_STEP_MM)


def camera_distance(d: "Design", auto: frozenset = frozenset()) -> float:
    """Keeps the marker ring the size it has in the authors' frames (camera.ring_radius_px), and so
    their margin to the image edge at every ring radius: distance = R f / ring_radius_px; on a small
    ring at least deep enough that the lens holder stays below the coil cavity."""
    keep_scale = d.whiskers.ring_radius * d.camera.focal_length_px / d.camera.ring_radius_px
    below_cavity = d.marker_z - mount_levels(d)["cylinder_bottom"]
    return round(max(keep_scale, below_cavity), 3)


def pour_diameter(d: "Design", auto: frozenset = frozenset()) -> float:
    """The largest opening up to mold.max_pour_diameter that leaves print.min_wall between the pour
    opening and the rod guides (the lid) and sockets (the whisker ring)."""
    room = 2 * (d.whiskers.ring_radius - d.hole(d.whiskers.rod_diameter) / 2 - d.print.min_wall)
    return floor_step(min(d.mold.max_pour_diameter, room), 0.001)


def _mounting_hole_needs(d: "Design") -> float:
    """Smallest bolt-circle radius at which every robot mounting hole keeps its wall
    (Design.mounting_hole_wall: print.min_wall, or the insert's wall from hw/fasteners.csv) from the
    camera board pocket, the flat-cable slot and the inner cone, mm."""
    from shapely.geometry import LineString, Point, box

    from whisker.design.validation import DesignError

    m, cam, w = d.mount, d.camera, d.mounting_hole_wall
    if m.mounting_hole_count == 0:
        return 0.0
    lv = mount_levels(d)
    hole_r = d.mounting_hole_diameter / 2
    x0, y0, x1, y1 = camera_pocket_box(d)
    far = 1000.0
    keep_out = (box(x0, y0, x1, y1)
                .union(box(-m.ribbon_width / 2, -far, m.ribbon_width / 2, 0.0))
                .union(Point(0, 0).buffer(cone_radius_at(d, lv["bottom"] + m.mounting_hole_depth), 128))
                .buffer(hole_r + w, 32))
    need = 0.0
    for a in mounting_hole_angles(d):
        ray = LineString([(0, 0), (far * math.cos(math.radians(a)), far * math.sin(math.radians(a)))])
        cut = ray.intersection(keep_out)
        r = max((math.hypot(x, y) for g in getattr(cut, "geoms", [cut]) for x, y in g.coords), default=0.0)
        if r > far / 2:
            raise DesignError(f"mount.mounting_hole_count = {m.mounting_hole_count} puts a robot mounting hole at "
                              f"{a % 360:g} deg, in the camera's flat-cable slot (-y): choose another count")
        need = max(need, r)
    return need


def mount_outer_radius(d: "Design", auto: frozenset = frozenset()) -> float:
    """The smallest whole-millimetre radius that leaves print.min_wall outside every inner feature:
    magnet pockets, LED channel, membrane seat, camera board pocket and the robot mounting holes."""
    w, m = d.print.min_wall, d.mount
    seat = (d.membrane.inscribed_radius + d.print.clearance) / math.cos(math.pi / d.membrane.sides)
    x0, y0, x1, y1 = camera_pocket_box(d)
    board = max(math.hypot(x, y) for x in (x0, x1) for y in (y0, y1))
    holes = 0.0
    if m.mounting_hole_count:
        bolt = _mounting_hole_needs(d) if "mount.mounting_bolt_radius" in auto else m.mounting_bolt_radius
        holes = bolt + d.mounting_hole_diameter / 2
    need = max(max(pocket_outer_radius(d), led_outer_radius(d), seat, board) + w,
               holes + (d.mounting_hole_wall if m.mounting_hole_count else 0.0))
    return ceil_step(need, MOUNT_STEP_MM)


def mounting_bolt_radius(d: "Design", auto: frozenset = frozenset()) -> float:
    """As far out as the outer wall allows (the hole's wall outside each hole: print.min_wall, or an
    insert's wall from hw/fasteners.csv), so the holes keep the
    most material to the camera pocket; rounded down to 0.1 mm. The robot flange's bolts are on
    another plate (whisker.cad.solids.adapter's flange plate), so every flange takes the same mount."""
    m = d.mount
    need = _mounting_hole_needs(d) if m.mounting_hole_count else 0.0
    out = floor_step(m.outer_radius - d.mounting_hole_diameter / 2 - d.mounting_hole_wall, 0.1)
    return round(max(need, out), 3)


def cable_exit_count(d: "Design", auto: frozenset = frozenset()) -> int:
    """One exit per four coils (eight 0.1 mm leads), so no lead runs more than a quarter turn round."""
    return max(1, math.ceil(d.whiskers.count / 4))


@dataclass(frozen=True)
class Rule:
    section: str
    key: str
    rule: Callable[["Design", frozenset], float]
    placeholder: float  # stands in while earlier rules are resolved; never reaches a part

    @property
    def name(self) -> str:
        return f"{self.section}.{self.key}"

    @property
    def reason(self) -> str:
        return " ".join((self.rule.__doc__ or "").split())


# In order: a rule may read the values of the rules before it. Each takes (design, names set to auto).
RULES: tuple[Rule, ...] = (
    Rule("coil", "turns", coil_turns, 1),
    Rule("coil", "resistance", coil_resistance, 1.0),
    Rule("membrane", "sides", membrane_sides, 8),
    Rule("membrane", "inscribed_radius", membrane_inscribed_radius, 10.0),
    Rule("camera", "distance", camera_distance, 30.0),
    Rule("mold", "pour_diameter", pour_diameter, 1.0),
    Rule("mount", "cable_exit_count", cable_exit_count, 1),
    Rule("mount", "outer_radius", mount_outer_radius, 500.0),
    Rule("mount", "mounting_bolt_radius", mounting_bolt_radius, 1.0),
)
BY_NAME = {r.name: r for r in RULES}


def resolve_auto(data: dict, validate: Callable[[dict], "Design"]) -> tuple[dict, dict[str, str]]:
    """Replace every ``"auto"`` in a design dict by its rule's value.

    ``validate`` turns a dict without ``"auto"`` into a Design (the rules read the design's
    derived properties). Returns the resolved dict and, for each resolved name, its rule's reason.
    """
    import copy

    out = copy.deepcopy(data)
    auto = frozenset(r.name for r in RULES if isinstance(out.get(r.section), dict) and out[r.section].get(r.key) == "auto")
    if not auto:
        return out, {}
    for r in RULES:
        if r.name in auto:
            out[r.section][r.key] = r.placeholder
    for r in RULES:
        if r.name in auto:
            value = r.rule(validate(out), auto)
            if not math.isfinite(value) or value <= 0:
                from whisker.design.validation import DesignError
                raise DesignError(f"{r.name} = \"auto\": its rule gives {value:.4g}, so this design has no room "
                                  f"for it ({r.reason})")
            out[r.section][r.key] = value
    return out, {name: BY_NAME[name].reason for name in sorted(auto)}
