"""Camera board profiles (hw/camera_boards.toml) and their placement on the sensor axis."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from whisker.design import camera_boards as cb

REQUIRED = ("rpi_v1_3", "rpi_v2", "rpi_v3", "ov5647_m12")


def test_required_profiles_name_their_drawings():
    ps = cb.load_profiles()
    assert set(REQUIRED) <= set(ps)
    for p in ps.values():
        assert len(p.drawing) > 20
        assert len(p.hole_positions()) == 4


def test_pi_boards_have_the_lens_off_the_hole_centre():
    for name in ("rpi_v1_3", "rpi_v2", "rpi_v3"):
        assert cb.profile(name).lens_offset_from_holes > 5.0


def test_unknown_profile_lists_the_known_ones():
    with pytest.raises(cb.CameraBoardError) as e:
        cb.profile("rpi_v9")
    msg = str(e.value)
    assert "\n" not in msg and "'rpi_v9'" in msg and all(n in msg for n in REQUIRED)


@given(name=st.sampled_from(REQUIRED), cable=st.sampled_from([0.0, 90.0, 180.0, 270.0]))
def test_placement_puts_the_lens_on_the_axis_and_keeps_distances(name, cable):
    p = cb.profile(name)
    pl = cb.placement(p, cable)
    assert pl.to_sensor(*p.lens.offset) == pytest.approx((0.0, 0.0), abs=1e-12)
    # a rigid motion: every hole keeps its distance to the lens
    for h_board, h_sensor in zip(p.hole_positions(), pl.holes):
        assert math.dist(h_board, p.lens.offset) == pytest.approx(math.hypot(*h_sensor), abs=1e-9)
    # the connector edge's midpoint lies in the cable direction from the board centre
    cx, cy = pl.board_centre
    edge = pl.to_sensor(p.board.centre[0], p.board.centre[1] + p.board.height / 2)
    ang = math.degrees(math.atan2(edge[1] - cy, edge[0] - cx)) % 360
    assert abs((ang - cable + 180) % 360 - 180) < 1e-6


def test_placement_refuses_oblique_cables():
    with pytest.raises(cb.CameraBoardError, match="multiples of 90"):
        cb.placement(cb.profile("rpi_v2"), 45.0)


def test_inconsistent_profile_is_one_line(tmp_path):
    bad = tmp_path / "b.toml"
    bad.write_text('[profiles.x]\ntitle = "x"\ndrawing = "some drawing name"\n'
                   'board = { width = 10.0, height = 10.0, thickness = 1.0, centre = [0.0, 0.0] }\n'
                   'holes = { spacing_x = 21.0, spacing_y = 12.5, diameter = 2.2 }\n'
                   'lens = { offset = [0.0, 0.0], holder = [4.0, 4.0], holder_height = 2.0, optical_centre_height = 3.0 }\n'
                   'connector = { side = "+y", kind = "FFC" }\n')
    with pytest.raises(cb.CameraBoardError) as e:
        cb.load_profiles(bad)
    assert "\n" not in str(e.value) and "outside the board outline" in str(e.value)


def test_describe_lists_every_profile():
    lines = cb.describe()
    assert len(lines) == len(cb.load_profiles()) and all("lens" in ln for ln in lines)
