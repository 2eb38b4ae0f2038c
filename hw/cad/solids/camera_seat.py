"""The camera seat from a board profile (hw/camera_boards.toml): the pocket, the screw holes and the
board itself, placed so the lens's optical axis is the sensor axis (x = y = 0) and the flat cable
leaves towards -y (the mount's cable slot). Units: mm, sensor coordinates.

mount.py cuts :func:`seat_tools` once the design selects a profile (``camera.board``); until then
the profile is passed in. The board's front face is at ``board_face`` (z); its optical centre is
``profile.lens.optical_centre_height`` above it.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import camera_boards
from whisker.design import fasteners
from whisker.design import sizing
from whisker.design import Design

from whisker.cad.solids.shapes import cylinder

CABLE_DEG = 270.0  # the flat cable leaves towards -y


def placement(profile: camera_boards.Profile) -> camera_boards.Placement:
    return camera_boards.placement(profile, CABLE_DEG)


def board(d: Design, profile: camera_boards.Profile, board_face: float) -> dict[str, cq.Shape]:
    """The board (with its holes) and its lens holder, in place (the reference parts)."""
    p = placement(profile)
    (cx, cy), (w, h) = p.board_centre, p.board_size
    t = profile.board.thickness
    pcb = cq.Solid.makeBox(w, h, t, cq.Vector(cx - w / 2, cy - h / 2, board_face - t))
    pcb = pcb.cut(*[cylinder(profile.holes.diameter / 2, board_face - t - 1, board_face + 1, x, y) for x, y in p.holes])
    hw_, hh = p.holder_size
    holder = cq.Solid.makeBox(hw_, hh, profile.lens.holder_height, cq.Vector(-hw_ / 2, -hh / 2, board_face))
    return {"camera board": pcb, "lens holder": holder}


def _pocket(d: Design, p: camera_boards.Placement) -> tuple[float, float, float, float]:
    (cx, cy), (w, h) = p.board_centre, p.board_size
    w, h = d.hole(w), d.hole(h)
    return cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2


def seat_tools(d: Design, profile: camera_boards.Profile, board_face: float, bottom: float,
               screw: str = "M2", joint: str = "tap", depth: float = 5.0) -> dict[str, cq.Shape]:
    """Named solids to cut from the mount: the board pocket (open at the bottom, print clearance
    all round) and one screw hole per board hole (``fasteners.hole(screw, joint)``)."""
    p = placement(profile)
    x0, y0, x1, y1 = sizing.camera_pocket_box(d) if d.camera.board == profile.name else _pocket(d, p)
    tools = {"camera pocket": cq.Solid.makeBox(x1 - x0, y1 - y0, board_face - bottom + 1, cq.Vector(x0, y0, bottom - 1))}
    hole = fasteners.hole(screw, joint)
    for i, (x, y) in enumerate(p.holes):
        tools[f"camera {screw} hole {i}"] = cylinder(hole.diameter / 2, board_face - 0.5, board_face + depth, x, y)
    return tools
