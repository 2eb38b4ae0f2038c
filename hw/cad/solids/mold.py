"""Two-piece mould for casting the membrane (printable).

The base holds the membrane-shaped cavity, as deep as the membrane is thick, with a blind socket
per rod in its floor. The lid closes the cavity, guides every rod through a hole at the ring
radius, and has a pour opening in the centre and a vent at each polygon corner: the cavity's top
face is flat (the lid), so its high points are that whole face and the places a pour from the centre
fills last are the corners, where air is trapped. Each vent reaches its corner, and the whisker
ring's tube stands inside the vents' circle, so the pourer sees every vent from above and pours
until each one shows silicone. Three registration pins at uneven angles let the lid sit only one
way, so its rod holes line up; their holes go through the lid (no thin roof over a pin).

Each rod is located axially by a *stop*: it stands on the floor of its socket in the base, so its
lower end is exactly ``rod_below_membrane`` under the membrane (that end carries the bobbin). The
whisker ring (ring.py) only keeps the rods upright: its sockets end ``mold.rod_slack`` above a
nominal rod's tip, so a rod cut up to that much too long still reaches its stop, and one cut short
still stands in the ring's socket. Carbon fibre (1.55 g/cm^3) is denser than Ecoflex 00-30 (1.07),
so a rod does not float off its stop while the silicone cures.

Parting: the cured membrane comes out of the base upwards, the direction the rods leave their
sockets. The cavity's side walls have ``mold.draft_deg`` of draft (the cavity widens upwards); the
cavity is the nominal polygon at mid-thickness, so the cast membrane is within
(thickness / 2) tan(draft) of the reference membrane, top and bottom (whisker.cad.verify.mold_checks
measures both on the mesh).
"""

from __future__ import annotations

import math

import cadquery as cq

from whisker.design import Design

from whisker.cad.solids.shapes import cut_all, cylinder, polar_xy, polygon_points

# Uneven so the lid cannot be put on turned: the polygon flats nearest these angles (deg).
PIN_ANGLES_DEG = (0.0, 90.0, 200.0)
# The cavity tool reaches this far above the base's top face (a clean cut), mm.
OVERSHOOT = 1.0


def draft_offset(d: Design, z: float) -> float:
    """How much wider (mm, inscribed radius) the drafted cavity is at height z than the nominal
    polygon: (z - thickness / 2) tan(draft)."""
    return (z - d.membrane.thickness / 2) * math.tan(math.radians(d.mold.draft_deg))


def cavity_inscribed_radius(d: Design, z: float) -> float:
    """Inscribed radius of the drafted cavity at height z, mm."""
    return d.membrane.inscribed_radius + draft_offset(d, z)


def outer_radius(d: Design) -> float:
    """mold.wall around the cavity's widest corners, and at least room at a flat for a pin hole with
    print.min_wall to the cavity and to the edge, mm."""
    t = d.membrane.thickness
    top = cavity_inscribed_radius(d, t)
    pin = d.hole(d.mold.pin_diameter) + 2 * d.print.min_wall + 0.1
    return max(top / math.cos(math.pi / d.membrane.sides) + d.mold.wall, top + pin)


def pin_angles(d: Design) -> list[float]:
    """The pins sit on the middles of polygon flats (the most material), deg."""
    n = d.membrane.sides
    flats = [360.0 * k / n for k in range(n)]
    out: list[float] = []
    for want in PIN_ANGLES_DEG:
        free = [f for f in flats if f not in out]
        out.append(min(free, key=lambda f: abs((f - want + 180) % 360 - 180)))
    return out


def pin_positions(d: Design) -> list[tuple[float, float]]:
    r = (cavity_inscribed_radius(d, d.membrane.thickness) + outer_radius(d)) / 2
    return [polar_xy(r, a) for a in pin_angles(d)]


def cavity(d: Design) -> cq.Solid:
    """The membrane cavity: a polygon frustum from the floor (z = 0) to above the base's top, its
    side walls leaning out by mold.draft_deg (ruled loft between the two polygons)."""
    z0, z1 = 0.0, d.membrane.thickness + OVERSHOOT
    wires = [cq.Wire.makePolygon([cq.Vector(x, y, z) for x, y in
                                  polygon_points(d.membrane.sides, cavity_inscribed_radius(d, z))], close=True)
             for z in (z0, z1)]
    return cq.Solid.makeLoft(wires, True)


def base_tools(d: Design) -> dict[str, cq.Shape]:
    """The named solids cut from the base (the wall check names them)."""
    tools: dict[str, cq.Shape] = {"membrane cavity": cavity(d)}
    for i, a in enumerate(d.whisker_angles_deg):
        # blind: the socket's floor is the rod's stop
        tools[f"rod socket {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, -d.rod_below_membrane, 0.5,
                                            *polar_xy(d.whiskers.ring_radius, a))
    return tools


def lid_tools(d: Design) -> dict[str, cq.Shape]:
    """The named solids cut from the lid (the wall check names them)."""
    m, t = d.mold, d.membrane.thickness
    z0, z1 = t, t + m.lid_thickness
    tools: dict[str, cq.Shape] = {"pour opening": cylinder(m.pour_diameter / 2, z0 - 1, z1 + 1)}
    for i, a in enumerate(d.whisker_angles_deg):
        tools[f"rod guide {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, z0 - 1, z1 + 1,
                                           *polar_xy(d.whiskers.ring_radius, a))
    # over the corners of the cavity's top face, each vent's rim at its corner (the last place to fill)
    rv = cavity_inscribed_radius(d, t) / math.cos(math.pi / d.membrane.sides) - m.vent_diameter / 2
    for i, (x, y) in enumerate(polygon_points(d.membrane.sides, d.membrane.inscribed_radius)):
        r = math.hypot(x, y)
        tools[f"vent {i}"] = cylinder(m.vent_diameter / 2, z0 - 1, z1 + 1, x * rv / r, y * rv / r)
    for i, (x, y) in enumerate(pin_positions(d)):
        # through the lid: a blind pocket would leave lid_thickness - pin_height of roof (0.5 mm at 4 / 3 mm)
        tools[f"pin hole {i}"] = cylinder(d.hole(m.pin_diameter) / 2, z0 - 1, z1 + 1, x, y)
    return tools


def mold_base(d: Design) -> cq.Shape:
    """Base: floor + walls, drafted cavity z in [0, thickness], rod sockets in the floor, pins on top."""
    m, t = d.mold, d.membrane.thickness
    body = cylinder(outer_radius(d), -m.floor, t)
    base = cut_all(body, base_tools(d).values())
    pins = [cylinder(m.pin_diameter / 2, t - 0.01, t + m.pin_height, x, y) for x, y in pin_positions(d)]
    return base.fuse(*pins).clean()


def mold_lid(d: Design) -> cq.Shape:
    """Lid: plate on the base's top face with rod guides, pour opening, vents and pin holes."""
    m, t = d.mold, d.membrane.thickness
    body = cylinder(outer_radius(d), t, t + m.lid_thickness)
    return cut_all(body, lid_tools(d).values())
