"""Reference parts that are bought or cast, not printed: membrane, rod, coil, magnet.

They place the real components in the assembly and let the checks test fits and collisions.
All functions take the design and return a CadQuery solid in sensor coordinates (mm):
z = 0 on the membrane's lower face, whisker i at ``design.whisker_angles_deg[i]``.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

from .shapes import ORIGIN, Z, cut_all, cylinder, polar_xy, polygon_prism, radial_cylinder


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


def coil(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """Disc coil with a radial axis hanging `coil.drop` below the membrane, with a socket for the rod."""
    c, w = d.coil, d.whiskers
    r0 = w.ring_radius - c.length / 2
    body = radial_cylinder(r0, r0 + c.length, c.outer_diameter, d.coil_axis_z, 0.0)
    socket = cylinder(w.rod_diameter / 2, -d.rod_below_membrane, 0.0, w.ring_radius, 0.0)
    return _tilt(body.cut(socket), d, angle_deg, tilt_deg)


def magnet(d: Design, angle_deg: float = 0.0) -> cq.Shape:
    """NdFeB disc in the mount wall, its face `actuation.gap` outside the coil's outer face."""
    r = d.cavity_radius
    return radial_cylinder(r, r + d.magnet.height, d.magnet.diameter, d.coil_axis_z, angle_deg)


def wound_coil(d: Design, angle_deg: float = 0.0, tilt_deg: float = 0.0) -> cq.Shape:
    """The coil as it can be made: the bobbin (whisker.cad.bobbin) and its winding, a full annulus
    between the rod tab and the flange, with the rod in the tab outside the winding.

    Not yet the coil the checks use (:func:`coil`): its outer flange lies ``bobbin.tab / 2 +
    coil.length / 2 + bobbin.flange`` farther out than the coil centred on the rod, so the magnets,
    the cavity and the seat's opening must move out with it (whisker.sizing) before it replaces it.
    """
    from . import bobbin

    body = bobbin.bobbin(d).fuse(bobbin.winding_envelope(d)).clean()
    return _tilt(body, d, angle_deg, tilt_deg)
