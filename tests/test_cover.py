"""The camera cover: closes the pocket, relieves the flat cable, screws beside the pocket, walls."""

from __future__ import annotations

import pytest
from shapely.geometry import Point, box

from whisker.design import fasteners as fz
from whisker.cad.solids import cover
from whisker.cad.verify import walls
from whisker.cad.verify.checks import describe_circles, holes, section, to_mesh
from whisker.design import default_design


@pytest.fixture(scope="module")
def setup():
    d = default_design()
    return d, cover.layout(d), to_mesh(cover.cover(d), 0.01, 0.2)


def test_cover_closes_the_pocket_and_opens_a_cable_channel(setup):
    d, L, mesh = setup
    w, h = L["pocket"]
    # under the relief: one solid piece covering the whole pocket (no hole under the board)
    low = section(mesh, L["bottom"] + (L["thickness"] - L["settings"].relief_depth) / 2 + 0.3)
    pocket = box(-w / 2, -h / 2, w / 2, h / 2)
    solid = [p for p in low if p.buffer(0).contains(pocket.buffer(-0.01))]
    assert len(solid) == 1
    # in the relief: the cable channel reaches the -y edge, as wide as the flat cable slot
    top = section(mesh, L["top"] - 0.1)
    assert len(top) == 1
    edge_gap = top[0].exterior.intersection(box(-20, -L["half"][1] - 0.01, 20, -L["half"][1] + 0.01))
    assert not Point(0, -L["half"][1]).buffer(0.05).intersects(top[0])
    assert edge_gap.length == pytest.approx(2 * L["half"][0] - d.hole(d.mount.ribbon_width), abs=0.05)


def test_cover_screws_are_clearance_holes_with_stock_screws(setup):
    d, L, mesh = setup
    f = L["screw"]
    found = [c for c in describe_circles(holes(section(mesh, L["top"] - 0.5 * L["settings"].relief_depth)))
             if abs(c[2] - f.clear_medium) < 0.1]
    assert len(found) == 2
    for j in cover.joints(d):
        length, engaged = fz.screw_length(j.size, j.kind, j.clamp)
        lo, hi = fz.fastener(j.size).engagement(j.kind)
        assert lo <= engaged <= hi


def test_cover_walls(setup):
    d, L, mesh = setup
    c = walls.wall_check("cover", mesh, {**cover.cover_tools(d), **cover.edges(d)}, d.print.min_wall)
    assert c.ok, c.line()
