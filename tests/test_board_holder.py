"""The calibration board holder (hw/cad/solids/board_holder.py): its board face on the marker plane, in the mount."""

from __future__ import annotations

import pytest

from whisker.cad.solids.board_holder import PAPER_MM, board_face_z, board_holder
from whisker.cad.solids.mount import mount
from whisker.cad.parts import BY_NAME
from whisker.design import default_design


@pytest.mark.parametrize("overrides", [(), ("whiskers.count=6", "whiskers.ring_radius=10")])
def test_holder_face_on_the_marker_plane_and_free_of_the_mount(overrides):
    d = default_design(*overrides)
    h = board_holder(d)
    assert h.isValid()
    bb = h.BoundingBox()
    assert bb.zmin == pytest.approx(d.marker_z + PAPER_MM, abs=1e-6) == pytest.approx(board_face_z(d))
    assert bb.zmax == pytest.approx(d.membrane.thickness, abs=1e-6)        # flush with the mount's top
    # it passes the flange and never touches the mount (at most a sliver of rounding)
    assert h.intersect(mount(d)).Volume() < 1e-3
    # the pedestal face is what the camera sees: wider than a few board squares (4 mm)
    assert 2 * (d.neck_radius - d.print.clearance) > 5 * 4.0
    assert BY_NAME["board_holder"].printable
