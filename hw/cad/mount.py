"""The PLA mount: membrane seat, coil cavity with magnet pockets, LED channel, camera seat.

Seen from the side, top to bottom (z in mm, sensor coordinates):
- a polygon seat, as deep as the membrane is thick, so the membrane's upper face is flush with the top;
- a flange the membrane's rim rests on (opening ``design.neck_radius``), undercut by
- the coil cavity (radius ``design.cavity_radius``), whose wall carries one radial magnet pocket per
  whisker at the coil-axis height (the magnet's face flush with the wall, ``actuation.gap`` from the
  coil) and, lower down, an inward-facing groove for the LED strip;
- a cone that narrows to the lens holder, then the camera board pocket (open at the bottom, with a
  slot for the flat cable) and M2 screw holes; blind M3 holes in the bottom face for a robot adapter;
  radial cable exits for the coil and LED wires.
"""

from __future__ import annotations

import cadquery as cq

from whisker import sizing
from whisker.design import Design

from .shapes import cut_all, cylinder, polar_xy, polygon_prism, radial_cylinder, revolved


def cavity_profile(d: Design, z: dict[str, float]) -> cq.Solid:
    """The open inside of the mount as one solid of revolution: lens opening, cone, coil cavity
    and, where the flange is narrower than the cavity, the undercut neck under the membrane.
    One revolved outline has no coincident walls, so its mesh stays manifold for any design."""
    r_cav, neck, r_lens = d.cavity_radius, d.neck_radius, sizing.lens_radius(d)
    top = [(r_cav, -d.mount.flange_thickness), (neck, -d.mount.flange_thickness)] if neck < r_cav - 1e-6 else []
    # A cavity narrower than the lens opening: the opening goes straight up past the lens holder first.
    holder = [(r_lens, sizing.lens_top_z(d))] if r_cav < r_lens and sizing.lens_top_z(d) < z["cylinder_bottom"] else []
    return revolved([(0.0, z["board_face"] - 0.01), (r_lens, z["board_face"] - 0.01), *holder,
                     (r_cav, z["cylinder_bottom"]), *top, (neck, z["seat"] + 0.5), (0.0, z["seat"] + 0.5)])


def mount(d: Design) -> cq.Shape:
    z = sizing.mount_levels(d)
    m, cam, clr = d.mount, d.camera, d.print.clearance
    body = cylinder(m.outer_radius, z["bottom"], z["top"])
    r_cav = d.cavity_radius
    tools = [
        polygon_prism(d.membrane.sides, d.membrane.inscribed_radius + clr, z["seat"], z["top"] + 1),
        cavity_profile(d, z),
        # LED strip groove, facing inwards
        cylinder(sizing.led_outer_radius(d), z["led_bottom"], z["led_top"]),
        # camera board pocket and flat-cable slot, both open at the bottom
        cq.Solid.makeBox(d.hole(cam.board_width), d.hole(cam.board_height), z["board_face"] - z["bottom"] + 1,
                         cq.Vector(-d.hole(cam.board_width) / 2, -d.hole(cam.board_height) / 2, z["bottom"] - 1)),
        cq.Solid.makeBox(m.ribbon_width, m.outer_radius + 1, cam.board_thickness + m.camera_recess + m.ribbon_thickness + 1,
                         cq.Vector(-m.ribbon_width / 2, -m.outer_radius - 1, z["bottom"] - 1)),
    ]
    tools += [radial_cylinder(r_cav - 0.5, sizing.pocket_outer_radius(d), d.hole(d.magnet.diameter), z["pocket"], a)
              for a in d.whisker_angles_deg]
    hx, hy = cam.hole_spacing_x / 2, cam.hole_spacing_y / 2
    tools += [cylinder(cam.hole_diameter / 2, z["board_face"] - 0.5, z["board_face"] + 5, sx * hx, sy * hy)
              for sx in (-1, 1) for sy in (-1, 1)]
    # Mounting holes start at +y; the flat cable leaves at -y.
    tools += [cylinder(d.hole(m.mounting_hole_diameter) / 2, z["bottom"] - 1, z["bottom"] + m.mounting_hole_depth,
                       *polar_xy(m.mounting_bolt_radius, a)) for a in sizing.mounting_hole_angles(d)]
    tools += [radial_cylinder(0, m.outer_radius + 1, d.hole(m.cable_exit_diameter), z["cable"], a)
              for a in sizing.cable_exit_angles(d)]
    return cut_all(body, tools)
