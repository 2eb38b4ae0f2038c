"""Two-piece mould for casting the membrane (printable).

The base holds the membrane-shaped cavity, as deep as the membrane is thick, with a blind socket
per rod in its floor: a rod standing in its socket ends exactly ``rod_below_membrane`` under the
membrane. The lid closes the cavity, guides every rod through a hole at the ring radius, and has
a pour opening in the centre and a vent over each polygon corner (where air is trapped).
Three registration pins at uneven angles let the lid sit only one way, so its rod holes line up.
"""

from __future__ import annotations

import math

import cadquery as cq

from whisker.design import Design

from .shapes import cut_all, cylinder, polar_xy, polygon_points, polygon_prism

# Uneven so the lid cannot be put on turned: the polygon flats nearest these angles (deg).
PIN_ANGLES_DEG = (0.0, 90.0, 200.0)


def outer_radius(d: Design) -> float:
    """mold.wall around the cavity's corners, and at least room at a flat for a pin hole with
    print.min_wall to the cavity and to the edge, mm."""
    pin = d.hole(d.mold.pin_diameter) + 2 * d.print.min_wall + 0.1
    return max(d.membrane_circumradius + d.mold.wall, d.membrane.inscribed_radius + pin)


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
    r = (d.membrane.inscribed_radius + outer_radius(d)) / 2
    return [polar_xy(r, a) for a in pin_angles(d)]


def mold_base(d: Design) -> cq.Shape:
    """Base: floor + walls, cavity z in [0, thickness], rod sockets in the floor, pins on top."""
    m, t = d.mold, d.membrane.thickness
    body = cylinder(outer_radius(d), -m.floor, t)
    cavity = polygon_prism(d.membrane.sides, d.membrane.inscribed_radius, 0.0, t + 1)
    sockets = [cylinder(d.hole(d.whiskers.rod_diameter) / 2, -d.rod_below_membrane, 0.5,
                        *polar_xy(d.whiskers.ring_radius, a)) for a in d.whisker_angles_deg]
    base = cut_all(body, [cavity, *sockets])
    pins = [cylinder(m.pin_diameter / 2, t - 0.01, t + m.pin_height, x, y) for x, y in pin_positions(d)]
    return base.fuse(*pins).clean()


def mold_lid(d: Design) -> cq.Shape:
    """Lid: plate on the base's top face with rod guides, pour opening, vents and pin holes."""
    m, t = d.mold, d.membrane.thickness
    z0, z1 = t, t + m.lid_thickness
    body = cylinder(outer_radius(d), z0, z1)
    tools = [cylinder(d.hole(d.whiskers.rod_diameter) / 2, z0 - 1, z1 + 1, *polar_xy(d.whiskers.ring_radius, a))
             for a in d.whisker_angles_deg]
    tools.append(cylinder(m.pour_diameter / 2, z0 - 1, z1 + 1))
    rv = d.membrane_circumradius - m.vent_diameter
    tools += [cylinder(m.vent_diameter / 2, z0 - 1, z1 + 1, x * rv / math.hypot(x, y), y * rv / math.hypot(x, y))
              for x, y in polygon_points(d.membrane.sides, d.membrane.inscribed_radius)]
    tools += [cylinder(d.hole(m.pin_diameter) / 2, z0 - 1, z0 + m.pin_height + 0.5, x, y) for x, y in pin_positions(d)]
    return cut_all(body, tools)
