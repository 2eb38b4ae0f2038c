"""Named features (the solids cut from a part, and the space around its edges) of the printed parts,
for the wall check (whisker.cad.walls). Units: mm, sensor coordinates.

These repeat the cutting tools of mount.py, mold.py and ring.py with names. They are kept in step
by tests/test_walls.py, which cuts them from each part's body and compares the volume with the part
(so a tool changed in one place and not the other fails there). The parts should build from these
named tools once their modules are free to change (issue 13 is reshaping them).
"""

from __future__ import annotations

import math

import cadquery as cq

from whisker import sizing
from whisker.design import Design

from . import mold, mount, ring
from .shapes import cylinder, polar_xy, polygon_points, polygon_prism, radial_cylinder
from .walls import outside_ring

Features = dict[str, cq.Shape]


def mount_features(d: Design) -> Features:
    z = sizing.mount_levels(d)
    m, cam = d.mount, d.camera
    f: Features = {
        "membrane seat": polygon_prism(d.membrane.sides, d.membrane.inscribed_radius + d.print.clearance,
                                       z["seat"], z["top"] + 1),
        "lens cone and coil cavity": mount.cavity_profile(d, z),
        "LED groove": cylinder(sizing.led_outer_radius(d), z["led_bottom"], z["led_top"]),
        "camera pocket": cq.Solid.makeBox(d.hole(cam.board_width), d.hole(cam.board_height),
                                          z["board_face"] - z["bottom"] + 1,
                                          cq.Vector(-d.hole(cam.board_width) / 2, -d.hole(cam.board_height) / 2,
                                                    z["bottom"] - 1)),
        "flat-cable slot": cq.Solid.makeBox(m.ribbon_width, m.outer_radius + 1,
                                            cam.board_thickness + m.camera_recess + m.ribbon_thickness + 1,
                                            cq.Vector(-m.ribbon_width / 2, -m.outer_radius - 1, z["bottom"] - 1)),
        "outer rim": outside_ring(m.outer_radius, z["bottom"], z["top"]),
    }
    for i, a in enumerate(d.whisker_angles_deg):
        f[f"magnet pocket {i}"] = radial_cylinder(d.cavity_radius - 0.5, sizing.pocket_outer_radius(d),
                                                  d.hole(d.magnet.diameter), z["pocket"], a)
    hx, hy = cam.hole_spacing_x / 2, cam.hole_spacing_y / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            f[f"camera M2 hole ({sx * hx:+g}, {sy * hy:+g})"] = cylinder(
                cam.hole_diameter / 2, z["board_face"] - 0.5, z["board_face"] + 5, sx * hx, sy * hy)
    for k, a in enumerate(sizing.mounting_hole_angles(d)):
        f[f"mounting hole {k}"] = cylinder(d.hole(m.mounting_hole_diameter) / 2, z["bottom"] - 1,
                                           z["bottom"] + m.mounting_hole_depth, *polar_xy(m.mounting_bolt_radius, a))
    for k, a in enumerate(sizing.cable_exit_angles(d)):
        f[f"cable exit {k}"] = radial_cylinder(0, m.outer_radius + 1, d.hole(m.cable_exit_diameter), z["cable"], a)
    return f


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
