"""The coil former (bobbin) and the winding space it leaves: pure geometry, no CadQuery.

One source for the coil as it can be made. The CAD part (whisker.cad.solids.bobbin), the coil calculator
(whisker.coil: the winding window, so the turns, resistance and force), the sizing rules (how far a
coil reaches: whisker.design.sizing) and the mount's cavity (whisker.design.Design.cavity_radius) all read it.

Whisker 0 in sensor coordinates (mm); the coil's axis is radial (x), at ``design.coil_axis_z``. Along
the axis, from the sensor's centre outwards:

- the *tab* (the inner flange), ``bobbin.tab`` thick, centred on the rod (x = ring radius R): the rod
  ends in a blind socket in it, outside the winding; two lead holes beside the socket; its lower face
  is the marker face the camera sees;
- the *core* (``coil.inner_diameter``) carrying the winding, ``coil.length`` long;
- the *outer flange*, ``bobbin.flange`` thick, ``coil.outer_diameter`` across.

The winding is the full annulus between tab and flange, from the core out to ``bobbin.rim_margin``
under the flanges' rim. Its outer face is ``actuation.gap`` from the magnet's face.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Former:
    """Whisker 0's former at rest (mm): x ranges along the radial coil axis, z heights."""

    tab: tuple[float, float]
    core: tuple[float, float]
    flange: tuple[float, float]
    tab_top: float
    tab_bottom: float
    half_width: float          # y half-extent of tab and flanges (coil.outer_diameter / 2)
    axis_z: float
    socket_diameter: float
    socket_bottom: float
    bore: float
    lead_y: float              # lead holes at y = +-lead_y, x = R
    lead_hole: float
    winding_inner_diameter: float
    winding_outer_diameter: float

    @property
    def outer_x(self) -> float:
        return self.flange[1]

    @property
    def winding_length(self) -> float:
        return self.core[1] - self.core[0]


def socket_diameter(d) -> float:
    """The rod's socket in the resin tab: the rod + 2 x print.clearance when that is at most 0.1 mm,
    else the rod + 0.2 mm (a resin print holds tighter than the FDM parts' clearance), mm."""
    return d.hole(d.whiskers.rod_diameter) if d.print.clearance <= 0.1 else d.whiskers.rod_diameter + 0.2


def layout(d) -> Former:
    b, c, R = d.bobbin, d.coil, d.whiskers.ring_radius
    tab0, tab1 = R - b.tab / 2, R + b.tab / 2
    core1 = tab1 + c.length
    axis = -(c.drop + c.outer_diameter / 2)
    tab_top = min(-c.drop / 2, axis + c.outer_diameter / 2 + b.socket_depth)
    sock = socket_diameter(d)
    return Former(tab=(tab0, tab1), core=(tab1, core1), flange=(core1, core1 + b.flange), tab_top=tab_top,
                  tab_bottom=-(c.drop + c.outer_diameter), half_width=c.outer_diameter / 2, axis_z=axis,
                  socket_diameter=sock, socket_bottom=-(d.whiskers.rod_length - d.whiskers.protrusion
                                                        - d.membrane.thickness),
                  bore=max(b.min_wall, c.inner_diameter - 2 * b.min_wall),
                  lead_y=sock / 2 + b.min_wall + b.lead_hole / 2, lead_hole=b.lead_hole,
                  winding_inner_diameter=c.inner_diameter,
                  winding_outer_diameter=c.outer_diameter - 2 * b.rim_margin)


def inner_offset(d) -> float:
    """How far the former reaches inwards from the rod (the tab's inner face), mm."""
    return d.bobbin.tab / 2


def winding_face_offset(d) -> float:
    """Rod to the winding's outer face (where actuation.gap to the magnet starts), mm."""
    return d.bobbin.tab / 2 + d.coil.length


def outer_offset(d) -> float:
    """Rod to the outer flange's face, mm."""
    return winding_face_offset(d) + d.bobbin.flange


def window(d) -> tuple[float, float, float]:
    """The winding window: (inner radius, outer radius, length), mm."""
    f = layout(d)
    return f.winding_inner_diameter / 2, f.winding_outer_diameter / 2, f.winding_length


def envelope_points(d, tilt_deg: float = 0.0) -> np.ndarray:
    """Points on whisker 0's former and winding (x radial, y tangential, z), tilted by tilt_deg about
    the pivot (retraction positive: tip in, coil out), mm. The envelope is the tab (a box) and the
    flanged cylinder; their corners, end circles and edges hold every extreme point a distance from
    the sensor axis can reach, also above a height cut (sizing.coil_reach)."""
    f = layout(d)
    r = f.half_width
    phi = np.linspace(0, 2 * np.pi, 73)[:-1]
    s = np.linspace(f.core[0], f.outer_x, 9)
    S, P = np.meshgrid(s, phi)
    cyl = np.column_stack([S.ravel(), (r * np.sin(P)).ravel(), (f.axis_z + r * np.cos(P)).ravel()])
    # the tab's box: its 12 edges, sampled
    xs, ys, zs = f.tab, (-r, r), (f.tab_bottom, f.tab_top)
    t = np.linspace(0, 1, 9)
    edges = []
    for y in ys:
        for z in zs:
            edges.append(np.column_stack([xs[0] + t * (xs[1] - xs[0]), np.full_like(t, y), np.full_like(t, z)]))
    for x in xs:
        for z in zs:
            edges.append(np.column_stack([np.full_like(t, x), ys[0] + t * (ys[1] - ys[0]), np.full_like(t, z)]))
        for y in ys:
            edges.append(np.column_stack([np.full_like(t, x), np.full_like(t, y), zs[0] + t * (zs[1] - zs[0])]))
    p = np.vstack([cyl, *edges])
    return tilt(d, p, tilt_deg)


def tilt(d, p: np.ndarray, tilt_deg: float) -> np.ndarray:
    """Points of whisker 0 rotated by tilt_deg about its pivot (the rotation of
    whisker.cad.solids.reference._tilt: retraction positive moves what is below the pivot outwards)."""
    R, zp = d.whiskers.ring_radius, d.membrane.thickness / 2
    b = math.radians(-tilt_deg)
    xr, zr = p[:, 0] - R, p[:, 2] - zp
    return np.column_stack([R + xr * math.cos(b) + zr * math.sin(b), p[:, 1], zp - xr * math.sin(b) + zr * math.cos(b)])
