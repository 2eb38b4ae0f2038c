"""The wall check (whisker.cad.verify.walls) measured on meshes: planted thin walls are found and named."""

from __future__ import annotations

import math

import cadquery as cq
import pytest

from whisker.cad.verify import part_features, walls
from whisker.cad.build import build_solids
from whisker.cad.verify.checks import to_mesh
from whisker.cad.solids.shapes import cone, cut_all, cylinder
from whisker.design import default_design

PLATE = ((-15.0, -15.0, 0.0), (15.0, 15.0, 6.0))


def _plate(hole_x: float):
    body = cq.Solid.makeBox(30, 30, 6, cq.Vector(*PLATE[0]))
    feats = {"lens cone": cone(4.0, 7.0, -1, 7), "M2 hole": cylinder(1.1, -1, 7, hole_x, 0),
             "plate edge": walls.outside_box(*PLATE)}
    part = cut_all(body, [feats["lens cone"], feats["M2 hole"]])
    return to_mesh(part, 0.01, 0.2), feats


def _cone_to_hole(hole_x: float) -> float:
    """Exact wall (mm) between the cone (r = 4 + 3 (z + 1)/8, widening upwards) and the hole: both
    rims on the top face z = 6 (the cone's normal from the hole's rim points above the plate)."""
    return (hole_x - 1.1) - (4.0 + 3.0 * 7.0 / 8.0)


def test_hole_moved_towards_the_cone_is_refused_naming_both():
    ok = walls.wall_check("plate", *_plate(10.0), min_wall=1.2)
    assert ok.ok, ok.line()
    bad = walls.wall_check("plate", *_plate(8.0), min_wall=1.2)
    assert not bad.ok
    line = bad.line()
    assert "\n" not in line and "lens cone" in line and "M2 hole" in line and "at (" in line
    assert bad.value == pytest.approx(_cone_to_hole(8.0), abs=0.05)


def test_hole_near_the_edge_is_refused_with_its_place():
    w = walls.thin_walls(*_plate(13.5), min_wall=1.2)
    assert [(x.a, x.b) for x in w] == [("M2 hole", "plate edge")]
    assert w[0].thickness == pytest.approx(15.0 - 13.5 - 1.1, abs=0.03)
    x, y, z = w[0].where
    assert x == pytest.approx(14.8, abs=0.1) and abs(y) < 0.3 and 0 <= z <= 6


@pytest.mark.parametrize("hole_x", [8.2, 8.6, 8.8])
def test_measured_wall_follows_the_geometry(hole_x):
    w = walls.thin_walls(*_plate(hole_x), min_wall=1.2)
    assert len(w) == 1 and {w[0].a, w[0].b} == {"lens cone", "M2 hole"}
    assert w[0].thickness == pytest.approx(_cone_to_hole(hole_x), abs=0.05)


def test_touching_features_are_one_opening_not_a_wall():
    body = cq.Solid.makeBox(30, 30, 6, cq.Vector(*PLATE[0]))
    feats = {"slot a": cq.Solid.makeBox(4, 2, 8, cq.Vector(-4, -1, -1)),
             "slot b": cq.Solid.makeBox(4, 2, 8, cq.Vector(0, -1, -1))}
    part = to_mesh(cut_all(body, list(feats.values())), 0.01, 0.2)
    assert walls.thin_walls(part, feats, 1.2) == []


def test_bad_features_and_limits_are_one_line():
    mesh, feats = _plate(10.0)
    with pytest.raises(ValueError, match="min_wall"):
        walls.thin_walls(mesh, feats, float("nan"))
    empty = cq.Solid.makeBox(1, 1, 1).cut(cq.Solid.makeBox(2, 2, 2, cq.Vector(-0.5, -0.5, -0.5)))
    with pytest.raises(ValueError, match="'nothing' is not a closed solid"):
        walls.thin_walls(mesh, {**feats, "nothing": empty}, 1.2)


@pytest.fixture(scope="module")
def default_parts():
    d = default_design()
    return d, build_solids(d)


@pytest.mark.parametrize("name", sorted(part_features.FEATURES))
def test_named_features_are_the_parts_cuts(default_parts, name):
    """Each named feature is cut from its part (no material inside it) and bounds it (touches it),
    so the features stay in step with the part modules."""
    d, solids = default_parts
    part = solids[name]
    for fname, f in part_features.FEATURES[name](d).items():
        assert part.intersect(f).Volume() < 1e-3, f"{name}: feature {fname!r} overlaps material"
        assert part.distance(f) < 1e-6, f"{name}: feature {fname!r} does not touch the part"


@pytest.mark.parametrize("name", sorted(part_features.FEATURES))
def test_default_parts_without_thin_walls(default_parts, name):
    d, solids = default_parts
    tol = (d.export.linear_tolerance, d.export.angular_tolerance)
    c = walls.wall_check(name, to_mesh(solids[name], *tol), part_features.FEATURES[name](d), d.print.min_wall)
    assert c.ok, c.line()


def test_camera_hole_moved_towards_the_lens_opening_is_refused_naming_both(default_parts):
    """The issue's planted thin wall: the mount's camera screw holes moved 1.5 mm towards the lens."""
    d, solids = default_parts
    tol = (d.export.linear_tolerance, d.export.angular_tolerance)
    feats = part_features.mount_features(d)
    moved = {}
    for name, f in feats.items():
        if name.startswith("camera M2 hole"):
            c = f.Center()
            f = f.translate(cq.Vector(-1.5 * math.copysign(1, c.x), 0, 0))
        moved[name] = f
    body = cylinder(d.mount.outer_radius, solids["mount"].BoundingBox().zmin, d.membrane.thickness)
    part = cut_all(body, [f for n, f in moved.items() if n != "outer rim"])
    c = walls.wall_check("mount", to_mesh(part, *tol), moved, d.print.min_wall)
    assert not c.ok
    assert "camera M2 hole" in c.detail and "lens" in c.detail and "at (" in c.detail
