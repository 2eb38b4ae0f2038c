"""Robot adapter plate (printable, FDM): the mount on a robot's ISO 9409-1 tool flange.

Under the mount's bottom face (sensor coordinates, mm) a round plate carries
- the robot's bolt pattern (hw/flanges.csv, ``adapter.preset``): ISO 273 clearance holes on the
  pitch circle, counterbored from the top (DIN 974-1) so the heads sit below the mount, the
  centring spigot that fits the flange's H7 bore and the positioning-pin hole; ``plain`` has none;
- the mount's own screws (``mount.mounting_hole_*``), coming up from the robot face through
  clearance holes, counterbored from below, into the mount (``fasteners.mount_screw`` in ``fasteners.mount_joint``);
- a relief in the top face for the camera board's back and the flat cable, open towards -y.

The robot bolts are turned to the angle farthest from the mount's screws. Assembly: the robot
screws go into their counterbores first, then the mount is screwed on from below, then the unit is
bolted to the robot with a hex key reaching past the mount (whisker.cad.sequence checks it).
"""

from __future__ import annotations

import math

import cadquery as cq
import numpy as np

from whisker import fasteners, sizing
from whisker.design import Design

from . import extras
from .shapes import cut_all, cylinder, polar_xy


def sensor_angles(d: Design) -> list[float]:
    """Angles (deg) of the mount's screws, as mount.py places them."""
    return list(sizing.mounting_hole_angles(d))


def bolt_offset(d: Design, count: int, pitch_radius: float = 0.0, hole_radius: float = 0.0) -> float:
    """Angle (deg) of the first robot bolt: the pattern farthest from the mount's screws whose bolts
    keep out of the flat cable's channel at -y (0.5 deg steps)."""
    if count == 0:
        return 0.0
    s = np.array(sensor_angles(d))
    half = d.hole(d.mount.ribbon_width) / 2 + hole_radius + d.print.min_wall
    keep_out = math.degrees(math.asin(min(1.0, half / pitch_radius))) if pitch_radius > 0 else 0.0
    best, best_key = 0.0, (-1, -1.0)
    for off in np.arange(0.0, 360.0 / count, 0.5):
        b = off + 360.0 * np.arange(count) / count
        gap = float(np.min(np.abs((b[:, None] - s[None, :] + 180) % 360 - 180))) if len(s) else 180.0
        cable = float(np.min(np.abs((b - 270.0 + 180) % 360 - 180)))
        key = (int(cable >= keep_out), gap)
        if key > best_key:
            best, best_key = float(off), key
    return best


def layout(d: Design, preset: str | None = None) -> dict:
    """Numbers of the plate (mm, deg): thickness, radius, top/bottom z, bolt angles, screws."""
    a = extras.section(d, "adapter", **({"preset": preset} if preset else {}))
    fl = extras.flange(a.preset)
    sensor = fasteners.fastener(d.fasteners.mount_screw)
    robot = fasteners.fastener(fl.thread) if fl.bolt_count else None
    # Printed counterbores: the head plus the print clearance (DIN 974-1's drilled sizes are wider).
    cb_s = min(sensor.counterbore, d.hole(sensor.head_diameter))
    cb_r = min(robot.counterbore, d.hole(robot.head_diameter)) if robot else 0.0
    off = bolt_offset(d, fl.bolt_count, fl.pitch_diameter / 2, cb_r / 2)
    angles = [off + 360.0 * k / fl.bolt_count for k in range(fl.bolt_count)]
    head = max(sensor.head_height, robot.head_height if robot else 0.0)
    t = head + 0.5 + a.under_head
    if robot:
        # counterbores from both faces that overlap in plan are stacked, a wall apart
        gap = min(math.dist(polar_xy(fl.pitch_diameter / 2, b), polar_xy(d.mount.mounting_bolt_radius, s))
                  for b in angles for s in sensor_angles(d)) if sensor_angles(d) else math.inf
        if gap < (cb_r + cb_s) / 2 + d.print.min_wall:
            t = max(t, robot.head_height + sensor.head_height + 1.0 + d.print.min_wall)
    t = _stock_thickness(t, d, sensor, robot, fl)
    top = sizing.mount_levels(d)["bottom"]
    radius = max(fl.flange_diameter / 2, d.mount.outer_radius, d.mount.mounting_bolt_radius + cb_s / 2 + d.print.min_wall + 0.1,
                 (fl.pitch_diameter + cb_r) / 2 + d.print.min_wall + 0.1 if robot else 0.0)
    return dict(settings=a, flange=fl, sensor=sensor, robot=robot, thickness=t, top=top, bottom=top - t,
                radius=radius, bolt_angles=angles, counterbore_sensor=cb_s, counterbore_robot=cb_r)


def _stock_thickness(t0: float, d: Design, sensor, robot, fl) -> float:
    """The thinnest plate >= t0 (0.1 mm steps) for which both screw sets have a stock length with
    their engagement in the fastener table's range (the clamp is the plate under each head)."""
    for k in range(0, 301):
        t = round(t0 + 0.1 * k, 3)
        try:
            fasteners.screw_length(d.fasteners.mount_screw, d.fasteners.mount_joint, t - sensor.head_height - 0.5)
            if robot:
                fasteners.screw_length(fl.thread, "through", t - robot.head_height - 0.5, fl.thread_depth)
        except fasteners.FastenerError:
            continue
        return t
    raise fasteners.FastenerError(f"adapter: no plate from {t0:g} to {t0 + 30:g} mm thick lets stock "
                                  f"{d.fasteners.mount_screw} and {fl.thread or '-'} screws engage within the table's range")


def adapter_tools(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The named solids cut from the plate (and the space around it, for the wall check)."""
    L = layout(d, preset)
    a, fl, top, bot = L["settings"], L["flange"], L["top"], L["bottom"]
    tools: dict[str, cq.Shape] = {}
    if L["robot"]:
        r = L["robot"]
        for k, ang in enumerate(L["bolt_angles"]):
            x, y = polar_xy(fl.pitch_diameter / 2, ang)
            tools[f"robot bolt {k}"] = cylinder(r.clear_medium / 2, bot - fl.centring_depth - 1, top + 1, x, y).fuse(
                cylinder(L["counterbore_robot"] / 2, top - r.head_height - 0.5, top + 1, x, y)).clean()
        # the pin between the two bolts whose middle is farthest from the mount's screws and the cable
        mids = [b + 180.0 / fl.bolt_count for b in L["bolt_angles"]]
        avoid = sensor_angles(d) + [270.0]
        mid = max(mids, key=lambda m: min((abs((m - s + 180) % 360 - 180) for s in avoid), default=180.0))
        px, py = polar_xy(fl.pitch_diameter / 2, mid)
        pin_depth = min(6.0, L["thickness"] - a.relief_depth - d.print.min_wall)
        tools["positioning pin"] = cylinder(fl.pin_diameter / 2, bot - fl.centring_depth - 1, bot + pin_depth, px, py)
    s = L["sensor"]
    for k, ang in enumerate(sensor_angles(d)):
        x, y = polar_xy(d.mount.mounting_bolt_radius, ang)
        tools[f"mount screw {k}"] = cylinder(s.clear_medium / 2, bot - fl.centring_depth - 1, top + 1, x, y).fuse(
            cylinder(L["counterbore_sensor"] / 2, bot - fl.centring_depth - 1, bot + s.head_height + 0.5, x, y)).clean()
    if a.relief_depth > 0:
        cam, m = d.camera, d.mount
        w, h = d.hole(cam.board_width), d.hole(cam.board_height)
        relief = cq.Solid.makeBox(w, h, a.relief_depth + 1, cq.Vector(-w / 2, -h / 2, top - a.relief_depth))
        channel = cq.Solid.makeBox(d.hole(m.ribbon_width), L["radius"] + 1, a.relief_depth + 1,
                                   cq.Vector(-d.hole(m.ribbon_width) / 2, -L["radius"] - 1, top - a.relief_depth))
        tools["camera relief"] = relief.fuse(channel).clean()
    return tools


def adapter(d: Design, preset: str | None = None) -> cq.Shape:
    L = layout(d, preset)
    body = cylinder(L["radius"], L["bottom"], L["top"])
    fl = L["flange"]
    if fl.centring_diameter > 0:
        # spigot into the flange's H7 centring bore, 0.05 mm radial play for a printed fit
        body = body.fuse(cylinder(fl.centring_diameter / 2 - 0.05, L["bottom"] - fl.centring_depth,
                                  L["bottom"] + 0.01)).clean()
    return cut_all(body, adapter_tools(d, preset).values())


def edges(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The space around the plate's rim, for the wall check."""
    from .walls import outside_ring

    L = layout(d, preset)
    return {"plate rim": outside_ring(L["radius"], L["bottom"], L["top"])}


def separate(d: Design, preset: str | None = None) -> list[str]:
    """Features that must not meet any other (each screw and the pin has its own hole)."""
    return [n for n in adapter_tools(d, preset) if n.startswith(("robot bolt", "mount screw", "positioning pin"))]


def joints(d: Design, preset: str | None = None) -> list[fasteners.Joint]:
    """The adapter's screws as fastener joints (for the BOM and the engagement check)."""
    L = layout(d, preset)
    a, fl = L["settings"], L["flange"]
    t = L["thickness"]
    out = [fasteners.Joint("mount to adapter", d.fasteners.mount_screw, d.fasteners.mount_joint,
                           d.mount.mounting_hole_count,
                           t - L["sensor"].head_height - 0.5, None)]
    if fl.bolt_count:
        out.append(fasteners.Joint(f"adapter to robot ({fl.designation})", fl.thread, "through", fl.bolt_count,
                                   t - L["robot"].head_height - 0.5, fl.thread_depth))
    return out


def bolt_circle_error(found: list[tuple[float, float, float]], fl: "extras.Flange") -> float:
    """Largest radial error (mm) of found (r, angle, dia) circles from the preset's pitch circle."""
    return max((abs(r - fl.pitch_diameter / 2) for r, _, _ in found), default=math.inf)
