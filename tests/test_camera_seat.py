"""Every camera profile seats its board with the lens on the sensor axis, measured on meshes."""

from __future__ import annotations

import numpy as np
import pytest

from whisker.design import camera_boards
from whisker.cad.solids import camera_seat
from whisker.cad.verify.checks import holes, section, to_mesh
from whisker.cad.solids.shapes import cut_all, cylinder
from whisker.design import default_design

FACE, BOTTOM = -40.0, -42.0


@pytest.mark.parametrize("name", sorted(camera_boards.load_profiles()))
def test_profile_seats_with_the_lens_on_the_axis(name):
    d = default_design()
    prof = camera_boards.profile(name)
    tools = camera_seat.seat_tools(d, prof, FACE, BOTTOM)
    seat = to_mesh(cut_all(cylinder(22.0, BOTTOM, FACE + 8.0), tools.values()), 0.01, 0.2)
    parts = {k: to_mesh(v, 0.01, 0.2) for k, v in camera_seat.board(d, prof, FACE).items()}
    # the optical axis: the lens holder's centre, measured on its mesh
    holder = parts["lens holder"]
    assert np.abs(holder.bounds.mean(axis=0)[:2]).max() < 0.05
    # the board sits centred in its pocket with the print clearance all round (sections of both meshes)
    board = section(parts["camera board"], FACE - prof.board.thickness / 2)
    assert len(board) == 1
    pocket_poly = max(holes(section(seat, FACE - 0.5)), key=lambda p: p.area)
    assert pocket_poly.buffer(1e-3).contains(board[0].exterior.convex_hull)
    bx, by = np.array(board[0].exterior.convex_hull.centroid.coords[0])
    px, py = np.array(pocket_poly.centroid.coords[0])
    assert abs(bx - px) < 0.05 and abs(by - py) < 0.05
    # the seat's screw holes line up with the board's holes
    seat_holes = [h.centroid for h in holes(section(seat, FACE + 2.0))]
    board_holes = [h.centroid for h in holes(board)]
    assert len(seat_holes) == len(board_holes) == 4
    for b in board_holes:
        assert min(b.distance(s) for s in seat_holes) < 0.05
    # the connector edge faces -y, towards the mount's cable slot
    p = camera_seat.placement(prof)
    edge = p.to_sensor(prof.board.centre[0], prof.board.centre[1] + prof.board.height / 2)
    assert edge[1] == pytest.approx(by - prof.board.height / 2, abs=0.05)
