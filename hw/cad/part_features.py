"""Named features (the solids cut from a part, and the space around its edges) of the printed parts,
for the wall check (whisker.cad.walls). Units: mm, sensor coordinates.

The mount's are its own named tools (mount.mount_tools). The moulds' and the ring's repeat the
cutting tools of mold.py and ring.py with names; tests/test_walls.py checks that each is cut from
its part and touches it, so a tool changed in one place and not the other fails there.
"""

from __future__ import annotations

import math

import cadquery as cq

from whisker import sizing
from whisker.design import Design

from . import mold, mount, ring
from .shapes import cylinder, polar_xy, polygon_points, polygon_prism
from .walls import outside_ring

Features = dict[str, cq.Shape]


def mount_features(d: Design) -> Features:
    z = sizing.mount_levels(d)
    return {**mount.mount_tools(d), "outer rim": outside_ring(d.mount.outer_radius, z["bottom"], z["top"])}


def mold_base_features(d: Design) -> Features:
    t = d.membrane.thickness
    f: Features = {"membrane cavity": polygon_prism(d.membrane.sides, d.membrane.inscribed_radius, 0.0, t + 1),
                   "outer rim": outside_ring(mold.outer_radius(d), -d.mold.floor, t)}
    for i, a in enumerate(d.whisker_angles_deg):
        f[f"rod socket {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, -d.rod_below_membrane, 0.5,
                                        *polar_xy(d.whiskers.ring_radius, a))
    return f


def mold_lid_features(d: Design) -> Features:
    m, t = d.mold, d.membrane.thickness
    z0, z1 = t, t + m.lid_thickness
    f: Features = {"pour opening": cylinder(m.pour_diameter / 2, z0 - 1, z1 + 1),
                   "lid edge": outside_ring(mold.outer_radius(d), z0, z1)}
    for i, a in enumerate(d.whisker_angles_deg):
        f[f"rod guide {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, z0 - 1, z1 + 1,
                                       *polar_xy(d.whiskers.ring_radius, a))
    rv = d.membrane_circumradius - m.vent_diameter
    for i, (x, y) in enumerate(polygon_points(d.membrane.sides, d.membrane.inscribed_radius)):
        f[f"vent {i}"] = cylinder(m.vent_diameter / 2, z0 - 1, z1 + 1, x * rv / math.hypot(x, y),
                                  y * rv / math.hypot(x, y))
    for i, (x, y) in enumerate(mold.pin_positions(d)):
        f[f"pin hole {i}"] = cylinder(d.hole(m.pin_diameter) / 2, z0 - 1, z0 + m.pin_height + 0.5, x, y)
    return f


def ring_features(d: Design) -> Features:
    rr, z = ring.radii(d), ring.levels(d)
    f: Features = {"outer rim": outside_ring(rr["outer"], z["lid_top"], z["top"]),
                   "tube bore": cylinder(rr["tube_inner"], z["lid_top"] - 1, z["plate_bottom"])}
    if rr["opening"] > 0:
        f["pour opening"] = cylinder(rr["opening"], z["plate_bottom"] - 1, z["top"] + 1)
    for i, a in enumerate(d.whisker_angles_deg):
        f[f"rod socket {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, z["plate_bottom"] - 1,
                                        z["socket_bottom"], *polar_xy(d.whiskers.ring_radius, a))
    return f


#: Part name (whisker.cad.parts) -> its named features.
FEATURES = {"mount": mount_features, "mold_base": mold_base_features, "mold_lid": mold_lid_features,
            "whisker_ring": ring_features}


def all_printed(d: Design) -> dict[str, tuple[Features, float, list[str]]]:
    """Every printed part's (features, thinnest wall in mm, features that must not meet any other):
    the FDM parts at print.min_wall, the resin bobbin at bobbin.min_wall."""
    from . import adapter, bobbin, cover, winding_jig

    out = {name: (fn(d), d.print.min_wall, []) for name, fn in FEATURES.items()}
    out["adapter"] = ({**adapter.adapter_tools(d), **adapter.edges(d)}, d.print.min_wall, adapter.separate(d))
    out["cover"] = ({**cover.cover_tools(d), **cover.edges(d)}, d.print.min_wall, [])
    out["winding_jig"] = ({**winding_jig.jig_tools(d), **winding_jig.edges(d)}, d.print.min_wall, [])
    out["bobbin"] = ({**bobbin.bobbin_tools(d), **bobbin.edges(d)}, d.bobbin.min_wall, [])
    return out
