"""Every printed part against its own wall limit, measured on its mesh: print.min_wall, or the
fastener table's insert_min_wall (hw/fasteners.csv) around a heat-set insert's hole (issue 29)."""

from __future__ import annotations

import pytest

from whisker.cad.verify import part_features, walls
from whisker.cad.build import wall_checks
from whisker.cad.verify.checks import to_mesh
from whisker.cad.parts import PARTS
from whisker.design import default_design, fasteners

from test_walls import _plate

#: The default design and the two off-paper designs the bench tried.
DESIGNS = {"default": (), "7@11mm": ("whiskers.count=7", "whiskers.ring_radius=11", 'membrane.sides="auto"'),
           "10@17mm": ("whiskers.count=10", "whiskers.ring_radius=17", 'membrane.sides="auto"')}


def test_a_feature_with_its_own_limit_is_held_to_it():
    """The plate's M2 hole 1.8 mm from the cone passes the general 1.2 mm and fails an insert's 2.3 mm."""
    mesh, feats = _plate(9.55)  # 1.825 mm from the cone (test_walls._cone_to_hole)
    assert walls.wall_check("plate", mesh, feats, 1.2).ok
    bad = walls.wall_check("plate", mesh, feats, 1.2, limits={"M2 hole": 2.3})
    assert not bad.ok and bad.limit == ">= 2.3" and "M2 hole" in bad.detail
    with pytest.raises(ValueError, match="no such"):
        walls.thin_walls(mesh, feats, 1.2, limits={"no such": 2.0})


def test_insert_holes_carry_the_tables_wall():
    d = default_design()
    table = fasteners.fastener(d.fasteners.mount_screw)
    own = part_features.insert_walls(d)
    assert d.fasteners.mount_joint == "insert"
    assert own["mount"] and set(own["mount"].values()) == {table.insert_min_wall}
    assert own["flange_plate"] and set(own["flange_plate"].values()) == {table.insert_min_wall}
    assert table.insert_min_wall > d.print.min_wall  # else the test shows nothing


def test_the_benchs_mount_is_refused_at_the_insert():
    """The mount the bench measured (outer radius 23 mm, bolt circle 19.8 mm: 1.2 mm outside each
    insert's hole) fails its insert's wall, naming the hole."""
    d = default_design("mount.outer_radius=23", "mount.mounting_bolt_radius=19.8")
    feats, minw, sep, own = part_features.all_printed(d)["mount"]
    spec = next(s for s in PARTS if s.name == "mount")
    mesh = to_mesh(spec.build(d), d.export.linear_tolerance, d.export.angular_tolerance)
    c = walls.wall_check("mount", mesh, feats, minw, separate=sep, limits=own)
    assert not c.ok and "mounting hole" in c.detail and c.value < 1.3


@pytest.mark.parametrize("name", list(DESIGNS))
def test_every_printed_part_meets_its_own_wall(name):
    d = default_design(*DESIGNS[name])
    printed = part_features.all_printed(d)
    tol = (d.export.linear_tolerance, d.export.angular_tolerance)
    meshes = {s.name: to_mesh(s.build(d), *tol) for s in PARTS if s.name in printed}
    assert set(meshes) == set(printed)
    found = wall_checks(d, meshes)
    assert len(found) == len(printed)
    bad = [c.line() for c in found if not c.ok]
    assert not bad, bad


def test_coupon_label_glyphs_keep_a_wall_between_them():
    """Engraved with the font's spacing, "0.1" left 0.01 mm of plate between "0" and "."."""
    import itertools

    from whisker.cad.solids import coupon

    d = default_design()
    lay = coupon.layout(d)
    for c, x in zip(d.print.coupon_clearances, coupon.column_x(d)):
        glyphs = coupon.label_glyphs(d, c, x, lay["label_y"], lay["plate_t"])
        assert len(glyphs) == len(coupon.label(c))
        for a, b in itertools.combinations(glyphs, 2):
            assert a.distance(b) >= d.print.min_wall - 1e-6


def test_mould_lid_pin_holes_have_no_roof():
    """The registration pins' holes go through the lid (a blind pocket left 0.5 mm of roof)."""
    from conftest import section_polygons
    from whisker.cad.solids import mold
    from whisker.cad.verify.checks import describe_circles, holes

    d = default_design()
    lid = to_mesh(mold.mold_lid(d), d.export.linear_tolerance, d.export.angular_tolerance)
    top = d.membrane.thickness + d.mold.lid_thickness
    found = describe_circles(holes(section_polygons(lid, top - 0.05)))
    pins = [p for p in found if abs(p[2] - d.hole(d.mold.pin_diameter)) < 0.05]
    assert len(pins) == len(mold.pin_positions(d))
