"""The robot adapter's numbers without CadQuery: plate levels, radii, screws and their angles.

whisker.cad.solids.adapter builds the two plates (ISO 9409-1 flange plate and the adapter under the mount)
from these numbers; the ROS node's URDF (whisker.ros.urdf) reads the same levels for the tool flange
offset, so neither needs CadQuery for the numbers and no dimension is typed twice. Units: mm, deg,
sensor coordinates (z = 0 on the membrane's lower face).
"""

from __future__ import annotations

import math

import numpy as np

from whisker.design import Design, fasteners, flanges, sizing

from whisker.cad import extras

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
    from the holes they share a plate with (the largest smallest margin over a wall)."""
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


