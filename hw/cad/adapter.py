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
import numpy as np

from whisker.design import fasteners
from whisker.design import sizing
from whisker.design import Design

from whisker.design import flanges

from . import extras
from .shapes import cut_all, cylinder, polar_xy

# Cable channel direction in the adapter's top face (deg): the flat cable leaves at -y.
CABLE_DEG = 270.0


def sensor_angles(d: Design) -> list[float]:
    """Angles (deg) of the mount's screws, as mount.py places them."""
    return list(sizing.mounting_hole_angles(d))


def _points(r: float, angles) -> np.ndarray:
    a = np.radians(np.asarray(angles, float))
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)


def _min_gap(p: np.ndarray, q: np.ndarray) -> float:
    """Smallest distance (mm) between two sets of points (n x 2, m x 2)."""
    if not len(p) or not len(q):
        return math.inf
    return float(np.min(np.linalg.norm(p[:, None, :] - q[None, :, :], axis=-1)))


def _angles(d: Design, a, fl, r_c: float, cb_s: float, cb_r: float, insert_d: float, insert_wall: float):
    """(coupling angles, robot bolt angles, pin angle) in deg, 0.5 deg steps: the coupling screws
    keep out of the flat cable's channel (-y) and, like the bolts and the pin, as far as possible
    from the holes they share a plate with (the largest smallest margin over a wall; an insert's
    hole keeps the fastener table's insert wall, `insert_wall` mm)."""
    w = d.print.min_wall
    mount = _points(d.mount.mounting_bolt_radius, sensor_angles(d))
    cable_half = d.hole(d.mount.ribbon_width) / 2 + cb_s / 2 + w
    keep = math.degrees(math.asin(min(1.0, cable_half / r_c)))
    nb = fl.bolt_count
    best, best_key = None, None
    for c_off in np.arange(0.0, 360.0 / a.coupling_count, 0.5):
        c = c_off + 360.0 * np.arange(a.coupling_count) / a.coupling_count
        clear = float(np.min(np.abs((c - CABLE_DEG + 180) % 360 - 180))) >= keep
        cp = _points(r_c, c)
        margin = _min_gap(cp, mount) - cb_s - w   # a counterbore on each (one from each face)
        choice = (c, [], None)
        if nb:
            offs = np.arange(0.0, 360.0 / nb, 0.5)
            b = offs[:, None] + 360.0 * np.arange(nb)[None, :] / nb          # (offsets, bolts)
            mids = b + 180.0 / nb
            r_p = fl.pitch_diameter / 2

            def gap(angles):  # (offsets, n) -> distance of each point to the nearest insert
                pts = _points(r_p, angles)[:, :, None, :] - cp[None, None, :, :]
                return np.linalg.norm(pts, axis=-1).min(axis=-1)

            pin_gap = gap(mids) - (fl.pin_diameter + insert_d) / 2 - insert_wall
            k = np.argmax(pin_gap, axis=1)
            m_all = np.minimum(gap(b).min(axis=1) - (cb_r + insert_d) / 2 - insert_wall, pin_gap[np.arange(len(offs)), k])
            i = int(np.argmax(m_all))
            worst_b, choice = float(m_all[i]), (c, list(b[i]), float(mids[i, k[i]]))
            margin = min(margin, worst_b)
        key = (int(clear), round(margin, 6))
        if best_key is None or key > best_key:
            best, best_key = choice, key
    c, b, pin = best
    return [float(x) for x in c], [float(x) for x in b], pin


_LAYOUTS: dict[tuple[str, str | None], dict] = {}


def layout(d: Design, preset: str | None = None) -> dict:
    """Numbers of both plates (mm, deg): levels, radii, screws and their angles (remembered per
    design digest and preset: the angle search is the costly part)."""
    key = (d.digest(), preset)
    if key not in _LAYOUTS:
        if len(_LAYOUTS) > 32:
            _LAYOUTS.clear()
        _LAYOUTS[key] = _layout(d, preset)
    return dict(_LAYOUTS[key])


def _layout(d: Design, preset: str | None) -> dict:
    a = extras.section(d, "adapter", **({"preset": preset} if preset else {}))
    fl = flanges.flange(a.preset)
    w = d.print.min_wall
    sensor = fasteners.fastener(d.fasteners.mount_screw)
    robot = fasteners.fastener(fl.thread) if fl.bolt_count else None
    # Printed counterbores: the head plus the print clearance (DIN 974-1's drilled sizes are wider).
    cb_s = min(sensor.counterbore, d.hole(sensor.head_diameter))
    cb_r = min(robot.counterbore, d.hole(robot.head_diameter)) if robot else 0.0
    insert = fasteners.hole(d.fasteners.mount_screw, "insert")
    # coupling screws: counterbores outside the mount's outline, so a hex key reaches them from above
    r_c = d.mount.outer_radius + d.print.clearance + cb_s / 2
    coupling, bolts, pin = _angles(d, a, fl, r_c, cb_s, cb_r, insert.diameter, insert.wall(w))

    # adapter: counterbores from below (mount screws) and from the top (coupling screws, camera relief)
    t_a = max(sensor.head_height + 0.5 + a.under_head, a.relief_depth + w + sensor.head_height + 0.5)
    t_a = _stock_thickness(t_a, [(d.fasteners.mount_screw, d.fasteners.mount_joint, sensor.head_height + 0.5, None),
                                 (d.fasteners.mount_screw, "insert", sensor.head_height + 0.5, None)])
    top = sizing.mount_levels(d)["bottom"]
    r_a = r_c + cb_s / 2 + w + 0.1
    # flange plate: the robot bolts' counterbores from the top, the inserts' holes a wall above its bottom
    t_f = max(insert.depth + w, (robot.head_height + 0.5 + a.under_head) if robot else 0.0)
    if robot:
        t_f = _stock_thickness(t_f, [(fl.thread, "through", robot.head_height + 0.5, fl.thread_depth)])
    # the coupling inserts keep the fastener table's insert wall (hw/fasteners.csv) to the plate's rim
    r_f = max(fl.flange_diameter / 2, r_c + insert.diameter / 2 + insert.wall(w) + 0.1,
              (fl.pitch_diameter + cb_r) / 2 + w + 0.1 if robot else 0.0)
    return dict(settings=a, flange=fl, sensor=sensor, robot=robot, insert=insert,
                top=top, bottom=top - t_a, thickness=t_a, radius=r_a,
                plate_top=top - t_a, plate_bottom=top - t_a - t_f, plate_thickness=t_f, plate_radius=r_f,
                coupling_radius=r_c, coupling_angles=coupling, bolt_angles=bolts, pin_angle=pin,
                counterbore_sensor=cb_s, counterbore_robot=cb_r)


def _stock_thickness(t0: float, screws: list[tuple[str, str, float, float | None]]) -> float:
    """The thinnest plate >= t0 (0.1 mm steps) through which every screw (size, kind, head depth,
    engagement cap) has a stock length with its engagement in the fastener table's range (the
    clamp is the plate under its head)."""
    for k in range(0, 301):
        t = round(t0 + 0.1 * k, 3)
        try:
            for size, kind, head, cap in screws:
                fasteners.screw_length(size, kind, t - head, cap)
        except fasteners.FastenerError:
            continue
        return t
    names = ", ".join(f"{s} {k}" for s, k, _, _ in screws)
    raise fasteners.FastenerError(f"adapter: no plate from {t0:g} to {t0 + 30:g} mm thick lets stock "
                                  f"screws ({names}) engage within the table's range")


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
    from .walls import outside_ring

    L = layout(d, preset)
    return {"adapter rim": outside_ring(L["radius"], L["bottom"], L["top"])}


def plate_edges(d: Design, preset: str | None = None) -> dict[str, cq.Shape]:
    """The space around the flange plate's rim, for the wall check."""
    from .walls import outside_ring

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
