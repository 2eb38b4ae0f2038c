"""Reference parts that are bought, cast or wound: membrane, rod, coil (bobbin + winding), magnet.

They place the real components in the assembly and let the checks test fits and collisions.
All functions take the design and return a CadQuery solid in sensor coordinates (mm):
z = 0 on the membrane's lower face, whisker i at ``design.whisker_angles_deg[i]``.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design
from whisker.design import sizing

from whisker.cad.solids.shapes import ORIGIN, Z, cut_all, cylinder, polar_xy, polygon_prism, radial_cylinder


def membrane(d: Design) -> cq.Shape:
    """The cast Ecoflex membrane: polygon prism with a rod hole (rod diameter) per whisker."""
    m = d.membrane
    body = polygon_prism(m.sides, m.inscribed_radius, 0.0, m.thickness)
    holes = [cylinder(d.whiskers.rod_diameter / 2, -1, m.thickness + 1, *polar_xy(d.whiskers.ring_radius, a))
             for a in d.whisker_angles_deg]
    return cut_all(body, holes)


def _tilt(shape: cq.Shape, d: Design, angle_deg: float, tilt_deg: float) -> cq.Shape:
    """Tilt a whisker-0 shape about its pivot (retraction positive: tip towards the centre),
    then turn it to whisker angle `angle_deg`."""
    pivot = cq.Vector(d.whiskers.ring_radius, 0, d.pivot_z)
    # Rotating by -tilt about +y moves the tip (above the pivot) towards -x, i.e. the centre.
    tilted = shape.rotate(pivot, pivot + cq.Vector(0, 1, 0), -tilt_deg) if tilt_deg else shape
    return tilted.rotate(ORIGIN, Z, angle_deg)


def rod(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """Carbon-fibre rod of whisker at `angle_deg`, tilted by `tilt_deg` (retraction positive)."""
    w = d.whiskers
    z0 = -d.rod_below_membrane
    body = cylinder(w.rod_diameter / 2, z0, z0 + w.rod_length, w.ring_radius, 0.0)
    return _tilt(body, d, angle_deg, tilt_deg)


def bobbin(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """The coil former (whisker.cad.solids.bobbin) of whisker `angle_deg`, tilted with its rod."""
    from whisker.cad.solids import bobbin as former
    return _tilt(former.bobbin(d), d, angle_deg, tilt_deg)


def winding(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """The copper on the bobbin: a full annulus between tab and flange (whisker.cad.solids.bobbin)."""
    from whisker.cad.solids import bobbin as former
    return _tilt(former.winding_envelope(d), d, angle_deg, tilt_deg)


def coil(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """The coil as it is made, one rigid piece: the bobbin and its winding, with the rod in the
    bobbin's tab outside the winding (whisker.design.former)."""
    from whisker.cad.solids import bobbin as former
    body = former.bobbin(d).fuse(former.winding_envelope(d)).clean()
    return _tilt(body, d, angle_deg, tilt_deg)


def coil_envelope(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """The coil's outside - bobbin tab and flanged winding, without the socket and lead holes - for
    the clearance checks (the same outside as :func:`coil`, a simpler solid to measure distances to)."""
    from whisker.design.former import layout

    f = layout(d)
    r = f.half_width
    tab = cq.Solid.makeBox(f.tab[1] - f.tab[0], 2 * r, f.tab_top - f.tab_bottom, cq.Vector(f.tab[0], -r, f.tab_bottom))
    body = tab.fuse(radial_cylinder(f.tab[1] - 0.01, f.outer_x, 2 * r, f.axis_z, 0.0)).clean()
    return _tilt(body, d, angle_deg, tilt_deg)


def magnet(d: Design, angle_deg: float = 0.0) -> cq.Shape:
    """NdFeB disc in the mount wall, its face `actuation.gap` outside the coil's outer face."""
    r = d.cavity_radius
    return radial_cylinder(r, r + d.magnet.height, d.magnet.diameter, d.coil_axis_z, angle_deg)


def led_strip(d: Design) -> cq.Shape:
    """The LED strip in its channel below the magnets, as bought: whole segments (sizing.led_strip,
    the BOM's length) cover that share of the channel, the gap centred at -y over the flat cable's
    side (a band at the channel's radius)."""
    z, m = sizing.mount_levels(d), d.mount
    ro = sizing.led_outer_radius(d) - d.print.clearance
    ri = ro - m.led_strip_thickness
    zc, w = (z["led_top"] + z["led_bottom"]) / 2, m.led_strip_width
    band = cq.Solid.makeCylinder(ro, w, cq.Vector(0, 0, zc - w / 2)).cut(cq.Solid.makeCylinder(ri, w, cq.Vector(0, 0, zc - w / 2)))
    circ, _, length = sizing.led_strip(d)
    arc = min(360.0, 360.0 * length / circ)
    if arc >= 360.0 - 1e-6:
        return band
    start = -90.0 + (360.0 - arc) / 2  # the gap is centred on -90 deg
    wedge = cq.Solid.makeCylinder(ro + 1, w + 2, cq.Vector(0, 0, zc - w / 2 - 1), cq.Vector(0, 0, 1), arc)
    wedge = wedge.rotate(cq.Vector(0, 0, 0), cq.Vector(0, 0, 1), start)
    return band.intersect(wedge)
