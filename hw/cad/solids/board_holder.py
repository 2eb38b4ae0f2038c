"""Calibration board holder: sets a patch of the ChArUco board at the marker plane in the mount.

It takes the membrane's place in the seat (the same polygon, ``print.clearance`` smaller, as thick
as the membrane, so its upper face sits flush with the mount's top) and carries a cylindrical
pedestal down through the flange opening (``design.neck_radius``, minus the clearance) to the
marker plane (``design.marker_z``, the coils' lower faces the camera tracks). A patch of the board
from ``whisker calibrate board`` glued on the pedestal's lower face is then where the markers will
be: ``whisker calibrate camera --plane-view FRAME`` measures the mm per pixel there. A through hole
in the centre lets a finger push the holder out from below.

Built before the membrane goes in (the magnets may be in place: the pedestal stays inside the neck).
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

from whisker.cad.solids.shapes import cut_all, cylinder, polygon_prism

PAPER_MM = 0.1          # thickness of the printed board patch (80 g/m^2 office paper is ~0.1 mm)
PUSH_HOLE_MM = 6.0      # diameter of the central push-out hole


def board_holder(d: Design) -> cq.Shape:
    """The holder in sensor coordinates (z = 0 on the membrane's lower face, pedestal below)."""
    c = d.print.clearance
    plate = polygon_prism(d.membrane.sides, d.membrane.inscribed_radius - c, 0.0, d.membrane.thickness)
    # the paper's face, not the print's, lies on the marker plane
    pedestal = cylinder(d.neck_radius - c, d.marker_z + PAPER_MM, 0.0 + 1e-3)
    body = plate.fuse(pedestal).clean()
    if d.neck_radius - c < PUSH_HOLE_MM:   # a small pedestal keeps its whole face for the board
        return body
    return cut_all(body, [cylinder(PUSH_HOLE_MM / 2, d.marker_z - 1.0, d.membrane.thickness + 1.0)])


def board_face_z(d: Design) -> float:
    """Height of the pedestal's lower face (where the paper goes), mm."""
    return d.marker_z + PAPER_MM
