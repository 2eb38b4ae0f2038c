"""The coils' leads: where they run and how long they must be for the full swing (pure geometry).

Each coil has two 0.1 mm leads. They leave the winding over the bobbin tab's top, run down through
its two lead holes beside the rod (a drop of glue at the lower end is the strain relief: the free
lead starts at the tab, never at the winding) and leave the tab's lower face, beside the marker.
From there each lead runs free to the nearest cable exit (whisker.design.sizing.cable_exit_angles), enters
it 1 mm inside the cone wall and leaves the mount through it.

The free part is modelled taut: a straight line from the hole's lower end, which swings with the
coil, to the exit's entry, which is fixed. Its length changes over the swing; the lead must be as
long as the longest taut path, and the slack it carries at the other end hangs (not modelled).
whisker.cad.leads sweeps these polylines into wire solids and checks them against every solid of
the assembly over the swing. Units: mm, whisker i at design.whisker_angles_deg[i].
"""

from __future__ import annotations

import math

import numpy as np

from whisker.design import former
from whisker.design import sizing

# The lead holes' lower ends lie this far below the marker face: the glued stub of the strain relief.
STUB_MM = 0.5
# The exit's entry point lies this far inside the cone wall, on the exit's axis.
ENTRY_INSIDE_MM = 1.0
SWING_SAMPLES = 7


def open_radius(d, z: float) -> float:
    """Radius (mm) within which the mount is open at height z below the coil cavity, in every
    direction: the outline that whisker.cad.solids.mount.cavity_profile revolves - the lens opening (straight
    up to the optical centre when that lies below the cavity), then the cone out to the cavity's
    radius - and, below the lens holder pocket's top, that square pocket's inscribed half-width."""
    lv = sizing.mount_levels(d)
    r_lens, z_top = sizing.lens_radius(d), lv["cylinder_bottom"]
    outline = [(sizing.holder_top_z(d), r_lens)]
    if sizing.lens_top_z(d) < z_top:
        outline.append((sizing.lens_top_z(d), r_lens))
    outline.append((z_top, d.cavity_radius))
    zs, rs = zip(*outline)
    r = float(np.interp(z, zs, rs))
    if z < sizing.holder_top_z(d):  # in the lens holder's square pocket: its inscribed half-width
        from whisker.design.camera_boards import placement, profile
        r = min(r, min(placement(profile(d.camera.board), 270.0).holder_size) / 2 + d.print.clearance)
    return r


def exit_of(d, i: int) -> float:
    """Angle (deg) of the cable exit nearest whisker i."""
    a = d.whisker_angles_deg[i]
    return min(sizing.cable_exit_angles(d), key=lambda e: abs((e - a + 180) % 360 - 180))


def _rotz(p: np.ndarray, angle_deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])


def path(d, i: int, side: int, tilt_deg: float = 0.0) -> np.ndarray:
    """The lead's polyline (k x 3, mm): top of its lead hole, lower end of the glued stub (both
    swing with the coil), the exit's entry (fixed), out through the mount's wall."""
    f = former.layout(d)
    R = d.whiskers.ring_radius
    y = side * f.lead_y
    body = np.array([[R, y, f.tab_top], [R, y, f.tab_bottom - STUB_MM]])
    body = _rotz(former.tilt(d, body, tilt_deg), d.whisker_angles_deg[i])
    z = sizing.mount_levels(d)["cable"]
    e = math.radians(exit_of(d, i))
    # the two leads side by side in the exit, a quarter of its diameter either side of its axis
    off = side * d.mount.cable_exit_diameter / 4
    radii = (open_radius(d, z) - ENTRY_INSIDE_MM, d.mount.outer_radius + 1.0)
    fixed = np.array([[r * math.cos(e) - off * math.sin(e), r * math.sin(e) + off * math.cos(e), z] for r in radii])
    return np.vstack([body, fixed])


def free_length(d, i: int, side: int, tilt_deg: float) -> float:
    """Taut free length (mm): the glued stub's end to the exit's entry."""
    p = path(d, i, side, tilt_deg)
    return float(np.linalg.norm(p[2] - p[1]))


def swing_tilts(d, samples: int = SWING_SAMPLES) -> np.ndarray:
    t = d.whiskers.max_deflection_deg
    return np.linspace(-t, t, samples)


def tips_meet_deg(d) -> float:
    """Tilt (deg) at which the tips of whiskers retracting together reach the sensor axis:
    asin(R / l_u); beyond it they touch each other (the swing checks stop at the membrane)."""
    return math.degrees(math.asin(min(1.0, d.whiskers.ring_radius / d.l_u)))


def length_report(d) -> dict:
    """The leads' free length over the swing: the longest taut path (the length each lead needs
    from the tab to the exit), the slack that swing end leaves at the other (max - min), and the
    lead length the BOM allows against what the longest path needs out through the wall, mm."""
    rows = []
    for i in range(d.whiskers.count):
        for side in (-1, 1):
            ls = [free_length(d, i, side, float(t)) for t in (-d.whiskers.max_deflection_deg, 0.0,
                                                               d.whiskers.max_deflection_deg)]
            rows.append({"whisker": i, "side": side, "extended_mm": ls[0], "rest_mm": ls[1], "retracted_mm": ls[2]})
    longest = max(max(r["extended_mm"], r["rest_mm"], r["retracted_mm"]) for r in rows)
    slack = max(max(r["extended_mm"], r["retracted_mm"], r["rest_mm"]) - min(r["extended_mm"], r["retracted_mm"], r["rest_mm"])
                for r in rows)
    f = former.layout(d)
    through_wall = d.mount.outer_radius + 1.0 - (open_radius(d, sizing.mount_levels(d)["cable"]) - ENTRY_INSIDE_MM)
    fixed = (f.tab_top - f.tab_bottom) + STUB_MM + 2 * d.coil.outer_diameter  # through the tab, off the winding
    need = fixed + longest + through_wall
    return {"longest_free_mm": longest, "swing_slack_mm": slack, "needed_to_outside_mm": need,
            "bom_lead_mm": d.bom.coil_lead_length, "rows": rows}
