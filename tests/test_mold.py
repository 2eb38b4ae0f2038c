"""The membrane mould: draft measured on the base's mesh, each rod's stop and axial slack measured
on the base's and the ring's meshes, and the mould's walls (whisker.cad.solids.mold, mold_checks)."""

from __future__ import annotations

import math

import pytest

from whisker.cad.solids import mold, ring
from whisker.cad.verify import mold_checks, part_features, walls
from whisker.cad.verify.checks import to_mesh
from whisker.design import DesignError, default_design

DESIGNS = {"default": (), "6 @ 10 mm": ("whiskers.count=6", "whiskers.ring_radius=10"),
           "12 @ 12 mm": ("whiskers.count=12", "whiskers.ring_radius=12")}


def _mesh(shape, d):
    return to_mesh(shape, d.export.linear_tolerance, d.export.angular_tolerance)


@pytest.fixture(scope="module", params=list(DESIGNS))
def built(request):
    d = default_design(*DESIGNS[request.param])
    return d, _mesh(mold.mold_base(d), d), _mesh(ring.whisker_ring(d), d), _mesh(mold.mold_lid(d), d)


def test_every_side_wall_has_the_draft_measured_on_the_mesh(built):
    d, base, _, _ = built
    drafts = mold_checks.side_wall_drafts(base, d)
    assert len(drafts) >= d.membrane.sides  # at least one face per polygon side
    assert drafts.min() == pytest.approx(d.mold.draft_deg, abs=0.05)
    assert drafts.max() == pytest.approx(d.mold.draft_deg, abs=0.05)
    # the cavity is the nominal polygon at mid-thickness, wider above and narrower below
    t = d.membrane.thickness
    grow = math.tan(math.radians(d.mold.draft_deg)) * t / 2
    assert mold_checks._inscribed(base, t - 1e-3) == pytest.approx(d.membrane.inscribed_radius + grow, abs=0.01)
    assert mold_checks._inscribed(base, 1e-3) == pytest.approx(d.membrane.inscribed_radius - grow, abs=0.01)


def test_every_rod_stands_on_its_stop_with_the_stated_slack(built):
    d, base, ring_mesh, _ = built
    found = mold_checks.stops_and_slack(base, ring_mesh, d)
    assert len(found) == d.whiskers.count
    for stop, slack in found:
        assert stop == pytest.approx(-d.rod_below_membrane, abs=0.01)   # the socket floor: the rod's lower end
        assert slack == pytest.approx(d.mold.rod_slack, abs=0.01)
    assert all(c.ok for c in mold_checks.release_checks(base, ring_mesh, d))


def test_mould_walls_pass_the_wall_check(built):
    d, base, _, lid = built
    for name, mesh in (("mold_base", base), ("mold_lid", lid)):
        c = walls.wall_check(name, mesh, part_features.FEATURES[name](d), d.print.min_wall)
        assert c.ok, c.line()


def test_slack_follows_the_design():
    d = default_design("mold.rod_slack=1.2")
    found = mold_checks.stops_and_slack(_mesh(mold.mold_base(d), d), _mesh(ring.whisker_ring(d), d), d)
    assert all(s == pytest.approx(1.2, abs=0.01) for _, s in found)


def test_a_mould_without_draft_is_refused():
    d = default_design()
    flat = default_design("mold.draft_deg=0")
    checks = mold_checks.release_checks(_mesh(mold.mold_base(flat), flat), _mesh(ring.whisker_ring(d), d), d)
    bad = [c for c in checks if not c.ok]
    assert [c.name for c in bad] == ["cavity side-wall draft (release upwards)"]
    assert bad[0].value == pytest.approx(0.0, abs=0.05) and "mold.draft_deg" in bad[0].line()


def test_a_draft_whose_membrane_outgrows_the_seat_is_refused():
    # 3 mm thick: (1.5 mm) tan(10 deg) = 0.26 mm > print.clearance 0.2 mm
    d = default_design("mold.draft_deg=10")
    checks = mold_checks.release_checks(_mesh(mold.mold_base(d), d), _mesh(ring.whisker_ring(d), d), d)
    bad = [c for c in checks if not c.ok]
    assert [c.name for c in bad] == ["cast membrane's top beyond the nominal polygon"]
    assert bad[0].value == pytest.approx(1.5 * math.tan(math.radians(10)), abs=0.01)


@pytest.mark.parametrize("bad", ["mold.draft_deg=-1", "mold.draft_deg=nan", "mold.rod_slack=-0.1"])
def test_bad_mould_values_are_one_line(bad):
    with pytest.raises(DesignError) as e:
        default_design(bad)
    assert "\n" not in str(e.value) and bad.split("=")[0] in str(e.value)
