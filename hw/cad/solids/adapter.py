"""Robot adapter (printable, FDM) in two plates: the mount on a robot's ISO 9409-1 tool flange.

Why two plates: the robot's bolts must be tightened from above, and on a small flange (ISO
9409-1-31.5-4-M5: bolts on a 31.5 mm circle) they lie under the mount, out of reach once it is on.
So the plate that carries the robot's pattern goes on the robot first, alone:

- ``flange_plate`` (bolted to the robot): the flange's bolt pattern (hw/flanges.csv,
  ``adapter.preset``) as ISO 273 clearance holes counterbored from its top (DIN 974-1, the heads
  below its top face), the centring spigot that fits the flange's H7 bore and the positioning-pin
  hole below; ``plain`` has none (a blank to drill). Heat-set inserts in its top face take the
  coupling screws.
- ``adapter`` (under the mount): the mount's own screws (``mount.mounting_hole_*``,
  ``fasteners.mount_screw`` in ``fasteners.mount_joint``) come up from its bottom face through
  clearance holes, counterbored from below; ``adapter.coupling_count`` coupling screws (the same
  size) go down through it outside the mount, counterbored from the top, into the flange plate's
  inserts; a relief in its top face for the camera board's back and the flat cable, open to -y.

Assembly: the flange plate is bolted to the robot; the adapter is screwed to the mount from below;
the sensor is set on the flange plate and the coupling screws are driven with a hex key reaching
straight down past the mount (their counterbores lie outside the mount's outline by
``print.clearance``, tested). One mount and one adapter fit every flange; changing robots means
printing another flange plate. Units: mm, sensor coordinates (z = 0 on the membrane's lower face).
"""

from __future__ import annotations

import math

import cadquery as cq

from whisker.design import Design, fasteners, flanges

from whisker.cad.solids.shapes import cut_all, cylinder, polar_xy

# The plates' numbers (levels, radii, screw angles) without CadQuery: whisker.ros.urdf reads them too.
from whisker.cad.solids.adapter_layout import CABLE_DEG, _angles, _layout, _min_gap, _points, _stock_thickness, layout, sensor_angles  # noqa: F401


def adapter_tools(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The named solids cut from the adapter (under the mount)."""
    L = layout(d, preset)
    a, top, bot, s = L["settings"], L["top"], L["bottom"], L["sensor"]
    tools: dict[str, cq.Shape] = {}
    for k, ang in enumerate(sensor_angles(d)):
        x, y = polar_xy(d.mount.mounting_bolt_radius, ang)
        tools[f"mount screw {k}"] = cylinder(s.clear_medium / 2, bot - 1, top + 1, x, y).fuse(
            cylinder(L["counterbore_sensor"] / 2, bot - 1, bot + s.head_height + 0.5, x, y)).clean()
    for k, ang in enumerate(L["coupling_angles"]):
        x, y = polar_xy(L["coupling_radius"], ang)
        tools[f"coupling screw {k}"] = cylinder(s.clear_medium / 2, bot - 1, top + 1, x, y).fuse(
            cylinder(L["counterbore_sensor"] / 2, top - s.head_height - 0.5, top + 1, x, y)).clean()
    if a.relief_depth > 0:
        cam, m = d.camera, d.mount
        w, h = d.hole(cam.board_width), d.hole(cam.board_height)
        relief = cq.Solid.makeBox(w, h, a.relief_depth + 1, cq.Vector(-w / 2, -h / 2, top - a.relief_depth))
        channel = cq.Solid.makeBox(d.hole(m.ribbon_width), L["radius"] + 1, a.relief_depth + 1,
                                   cq.Vector(-d.hole(m.ribbon_width) / 2, -L["radius"] - 1, top - a.relief_depth))
        tools["camera relief"] = relief.fuse(channel).clean()
    return tools


def plate_tools(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The named solids cut from the flange plate (on the robot)."""
    L = layout(d, preset)
    fl, top, bot = L["flange"], L["plate_top"], L["plate_bottom"]
    tools: dict[str, cq.Shape] = {}
    if L["robot"]:
        r = L["robot"]
        for k, ang in enumerate(L["bolt_angles"]):
            x, y = polar_xy(fl.pitch_diameter / 2, ang)
            tools[f"robot bolt {k}"] = cylinder(r.clear_medium / 2, bot - fl.centring_depth - 1, top + 1, x, y).fuse(
                cylinder(L["counterbore_robot"] / 2, top - r.head_height - 0.5, top + 1, x, y)).clean()
        # the pin on the pitch circle between two bolts, the middle farthest from the coupling inserts
        px, py = polar_xy(fl.pitch_diameter / 2, L["pin_angle"])
        pin_depth = min(6.0, L["plate_thickness"] - d.print.min_wall)
        tools["positioning pin"] = cylinder(fl.pin_diameter / 2, bot - fl.centring_depth - 1, bot + pin_depth, px, py)
    ins = L["insert"]
    for k, ang in enumerate(L["coupling_angles"]):
        x, y = polar_xy(L["coupling_radius"], ang)
        tools[f"coupling insert {k}"] = cylinder(ins.diameter / 2, top - ins.depth, top + 1, x, y)
    return tools


def adapter(d: Design, preset: str | None = None) -> cq.Shape:
    """The adapter under the mount."""
    L = layout(d, preset)
    return cut_all(cylinder(L["radius"], L["bottom"], L["top"]), adapter_tools(d, preset).values())


def flange_plate(d: Design, preset: str | None = None) -> cq.Shape:
    """The flange plate on the robot, under the adapter."""
    L = layout(d, preset)
    body = cylinder(L["plate_radius"], L["plate_bottom"], L["plate_top"])
    fl = L["flange"]
    if fl.centring_diameter > 0:
        # spigot into the flange's H7 centring bore, 0.05 mm radial play for a printed fit
        body = body.fuse(cylinder(fl.centring_diameter / 2 - 0.05, L["plate_bottom"] - fl.centring_depth,
                                  L["plate_bottom"] + 0.01)).clean()
    return cut_all(body, plate_tools(d, preset).values())


def edges(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The space around the adapter's rim, for the wall check."""
    from whisker.cad.verify.walls import outside_ring

    L = layout(d, preset)
    return {"adapter rim": outside_ring(L["radius"], L["bottom"], L["top"])}


def plate_edges(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The space around the flange plate's rim, for the wall check."""
    from whisker.cad.verify.walls import outside_ring

    L = layout(d, preset)
    return {"plate rim": outside_ring(L["plate_radius"], L["plate_bottom"], L["plate_top"])}


def separate(d: Design, preset: str | None = None) -> list[str]:
    """Features of the adapter that must not meet any other (each screw has its own hole)."""
    return [n for n in adapter_tools(d, preset) if n.startswith(("mount screw", "coupling screw"))]


def plate_separate(d: Design, preset: str | None = None) -> list[str]:
    """Features of the flange plate that must not meet any other."""
    return [n for n in plate_tools(d, preset) if n.startswith(("robot bolt", "positioning pin", "coupling insert"))]


def joints(d: Design, preset: str | None = None) -> list[fasteners.Joint]:
    """The adapter's screws as fastener joints (for the BOM and the engagement check)."""
    L = layout(d, preset)
    fl, s = L["flange"], L["sensor"]
    out = [fasteners.Joint("mount to adapter", d.fasteners.mount_screw, d.fasteners.mount_joint,
                           d.mount.mounting_hole_count, L["thickness"] - s.head_height - 0.5, None),
           fasteners.Joint("adapter to flange plate", d.fasteners.mount_screw, "insert", len(L["coupling_angles"]),
                           L["thickness"] - s.head_height - 0.5, None)]
    if fl.bolt_count:
        out.append(fasteners.Joint(f"flange plate to robot ({fl.designation})", fl.thread, "through", fl.bolt_count,
                                   L["plate_thickness"] - L["robot"].head_height - 0.5, fl.thread_depth))
    return out


def bolt_circle_error(found: list[tuple[float, float, float]], fl: "flanges.Flange") -> float:
    """Largest radial error (mm) of found (r, angle, dia) circles from the preset's pitch circle."""
    return max((abs(r - fl.pitch_diameter / 2) for r, _, _ in found), default=math.inf)
