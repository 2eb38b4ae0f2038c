"""The PLA mount: membrane seat, coil cavity with magnet pockets, LED channel, camera seat.

Seen from the side, top to bottom (z in mm, sensor coordinates):
- a polygon seat, as deep as the membrane is thick, so the membrane's upper face is flush with the top;
- a flange the membrane's rim rests on (opening ``design.neck_radius``), undercut by
- the coil cavity (radius ``design.cavity_radius``), whose wall carries one radial magnet pocket per
  whisker at the coil-axis height (the magnet's face flush with the wall, ``actuation.gap`` from the
  coil) and, lower down, an inward-facing groove for the LED strip;
- a cone that narrows to a round opening over the lens holder's pocket, then the camera board pocket
  (open at the bottom, with a slot for the flat cable) placed from the board's profile so the lens
  is on the sensor axis, and its screw holes; holes for the robot adapter's and the camera cover's
  screws in the bottom face (fastener table: insert, tap or through); radial cable exits.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import camera_boards
from whisker.design import fasteners
from whisker.design import sizing
from whisker.design import Design

from whisker.cad.solids import camera_seat
from whisker.cad.solids.shapes import cut_all, cylinder, polar_xy, polygon_prism, radial_cylinder, revolved


def cavity_profile(d: Design, z: dict[str, float]) -> cq.Solid:
    """The open inside of the mount as one solid of revolution: the round opening over the lens
    holder's pocket (straight up to the optical centre), the cone, the coil cavity and, where the
    flange is narrower than the cavity, the undercut neck under the membrane. One revolved outline
    has no coincident walls, so its mesh stays manifold for any design."""
    r_cav, neck, r_lens = d.cavity_radius, d.neck_radius, sizing.lens_radius(d)
    top = [(r_cav, -d.mount.flange_thickness), (neck, -d.mount.flange_thickness)] if neck < r_cav - 1e-6 else []
    z0 = sizing.holder_top_z(d) - 0.01
    straight = [(r_lens, sizing.lens_top_z(d))] if sizing.lens_top_z(d) < z["cylinder_bottom"] else []
    return revolved([(0.0, z0), (r_lens, z0), *straight,
                     (r_cav, z["cylinder_bottom"]), *top, (neck, z["seat"] + 0.5), (0.0, z["seat"] + 0.5)])


def mount_tools(d: Design) -> dict[str, cq.Shape]:
    """Every solid cut from the mount, by name (the wall check names them)."""
    z = sizing.mount_levels(d)
    m, cam, clr = d.mount, d.camera, d.print.clearance
    prof = camera_boards.profile(cam.board)
    hw_, hh = camera_seat.placement(prof).holder_size
    tools: dict[str, cq.Shape] = {
        "membrane seat": polygon_prism(d.membrane.sides, d.membrane.inscribed_radius + clr, z["seat"], z["top"] + 1),
        "lens opening, cone and coil cavity": cavity_profile(d, z),
        "lens holder pocket": cq.Solid.makeBox(hw_ + 2 * clr, hh + 2 * clr, sizing.holder_top_z(d) - z["board_face"] + 0.02,
                                               cq.Vector(-hw_ / 2 - clr, -hh / 2 - clr, z["board_face"] - 0.01)),
        # LED strip groove, facing inwards
        "LED groove": cylinder(sizing.led_outer_radius(d), z["led_bottom"], z["led_top"]),
        "flat-cable slot": cq.Solid.makeBox(m.ribbon_width, m.outer_radius + 1,
                                            cam.board_thickness + m.camera_recess + m.ribbon_thickness + 1,
                                            cq.Vector(-m.ribbon_width / 2, -m.outer_radius - 1, z["bottom"] - 1)),
    }
    f = d.fasteners
    _, engaged = fasteners.screw_length(f.camera_screw, f.camera_joint, cam.board_thickness)
    tools.update(camera_seat.seat_tools(d, prof, z["board_face"], z["bottom"], f.camera_screw, f.camera_joint,
                                        depth=engaged + 0.5))
    for i, a in enumerate(d.whisker_angles_deg):
        tools[f"magnet pocket {i}"] = radial_cylinder(d.cavity_radius - 0.5, sizing.pocket_outer_radius(d),
                                                      d.hole(d.magnet.diameter), z["pocket"], a)
    # Robot adapter screws come up from below (the first hole at +y; the flat cable leaves at -y).
    for k, a in enumerate(sizing.mounting_hole_angles(d)):
        tools[f"mounting hole {k}"] = cylinder(d.mounting_hole_diameter / 2, z["bottom"] - 1,
                                               z["bottom"] + m.mounting_hole_depth, *polar_xy(m.mounting_bolt_radius, a))
    for k, a in enumerate(sizing.cable_exit_angles(d)):
        tools[f"cable exit {k}"] = radial_cylinder(0, m.outer_radius + 1, d.hole(m.cable_exit_diameter), z["cable"], a)
    # The camera cover's screws (bench use without the adapter), beside the board pocket.
    from whisker.cad.solids import cover
    cl = cover.layout(d)
    _, engaged = fasteners.screw_length(f.cover_screw, f.cover_joint, cl["thickness"] - cl["screw"].head_height - 0.5)
    hole = fasteners.hole(f.cover_screw, f.cover_joint)
    for k, (x, y) in enumerate(cl["screws"]):
        tools[f"cover screw {k}"] = cylinder(hole.diameter / 2, z["bottom"] - 1, z["bottom"] + (hole.depth or engaged + 0.5),
                                             x, y)
    return tools


def mount(d: Design) -> cq.Shape:
    z = sizing.mount_levels(d)
    body = cylinder(d.mount.outer_radius, z["bottom"], z["top"])
    return cut_all(body, mount_tools(d).values())
