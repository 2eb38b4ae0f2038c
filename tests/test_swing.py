"""Every solid of the assembly against every other over the whole swing, the wound coil and its
leads included (whisker.cad.assembly.swing, whisker.design.leads)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from whisker.design import former
from whisker.design import leads
from whisker.cad.solids import mount, reference
from whisker.cad.assembly import swing
from whisker.design import default_design


def _run(d):
    return {c.name: c for c in swing.swing_check(d, mount.mount(d), reference.membrane(d))}


@pytest.fixture(scope="module")
def default():
    return default_design()


def test_default_assembly_has_no_overlap_anywhere_over_the_swing(default):
    checks = _run(default)
    assert all(c.ok for c in checks.values()), [c.line() for c in checks.values() if not c.ok]
    assert checks["solids overlapping over the swing"].value == 0.0
    assert checks["rod, bobbin and winding overlap"].value <= 1e-4


def test_a_flange_swinging_into_its_magnet_is_found_and_named():
    # 1 mm from the winding to the magnet leaves 0.65 mm to the flange: retracting 15 deg moves the
    # flange's lower corner out by ~1.8 mm, into the magnet
    d = default_design("actuation.gap=1.0", "actuation.end_stop=false", "whiskers.max_deflection_deg=15")
    c = _run(d)["solids overlapping over the swing"]
    assert not c.ok and "bobbin" in c.detail and "magnet" in c.detail and "tilt +" in c.detail
    assert "\n" not in c.line() and "actuation.gap" in c.line()


def test_the_end_stop_post_is_what_meets_the_magnet(default):
    """The default's swing ends on the stop: the post touches its magnet there and, just past it, is the
    only thing inside it; a stop tilt beyond the flange's reach is refused by the design, in one line."""
    from whisker.design.validation import DesignError

    (c,) = swing.end_stop_check(default)
    assert c.ok and c.value == 0.0 and "post in the magnet" in c.detail
    assert swing.end_stop_check(default_design("actuation.end_stop=false")) == []
    with pytest.raises(DesignError, match="flange meets the magnet"):
        swing.end_stop_check(default_design("whiskers.max_deflection_deg=15"))


def test_a_lead_through_a_wall_without_an_exit_is_found(monkeypatch, default):
    # route every lead to the wall straight under its own coil, where there is no cable exit
    monkeypatch.setattr(leads, "exit_of", lambda d, i: d.whisker_angles_deg[i])
    c = _run(default)["solids overlapping over the swing"]
    assert not c.ok and "lead" in c.detail and "mount" in c.detail


def test_lead_length_covers_both_swing_ends():
    d = default_design()
    rep = leads.length_report(d)
    theta = d.whiskers.max_deflection_deg
    free = [[leads.free_length(d, i, s, t) for t in (-theta, 0.0, theta)] for i in range(d.whiskers.count) for s in (-1, 1)]
    assert rep["longest_free_mm"] == pytest.approx(max(map(max, free)))
    assert rep["swing_slack_mm"] == pytest.approx(max(max(f) - min(f) for f in free))
    assert 0.1 < rep["swing_slack_mm"] < rep["longest_free_mm"]
    # the stub's end swings with the coil: it is the rest point turned about the pivot
    f = former.layout(d)
    rest = np.array([[d.whiskers.ring_radius, f.lead_y, f.tab_bottom - leads.STUB_MM]])
    assert leads.path(d, 0, 1, theta)[1] == pytest.approx(former.tilt(d, rest, theta)[0])
    short = default_design(f"bom.coil_lead_length={math.floor(rep['needed_to_outside_mm']) - 1}")
    c = _run(short)["coil lead length for the full swing"]
    assert not c.ok and "bom.coil_lead_length" in c.line()


def test_lead_solid_is_the_swept_polyline(default):
    p = leads.path(default, 3, -1, 7.0)
    r = swing.lead_diameter(default) / 2
    length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    s = swing.lead_solid(default, 3, -1, 7.0)
    # a cylinder per segment and a ball at each bend (the end caps are half balls)
    assert s.isValid() and s.Volume() == pytest.approx(math.pi * r * r * length, rel=0.02)
    bb = s.BoundingBox()
    assert (bb.xmin, bb.ymin, bb.zmin) == pytest.approx(tuple(p.min(axis=0) - r), abs=r + 1e-6)


@pytest.mark.parametrize("count, radius", [(6, 10.0), (12, 12.0)])
def test_off_paper_rings_still_build_and_go_together_with_the_wound_coil(count, radius):
    """6 @ 10 mm and 12 @ 12 mm: every solid check (the swing included) and mesh check passes, and
    every assembly step reaches its place; the crowding bound (the tab's inner face) leaves room."""
    from whisker.design import sizing
    from whisker.cad.assembly import sequence
    from whisker.cad.build import build_solids, evaluate

    d = default_design(f"whiskers.count={count}", f"whiskers.ring_radius={radius}")
    assert sizing.crowding_bound_radius(d) < radius
    results = evaluate(d)
    assert all(c.ok for c in results), [c.line() for c in results if not c.ok]
    assert {c.name for c in results} >= {"solids overlapping over the swing", "coil clearance over full deflection"}
    steps = sequence.check_sequence(d, build_solids(d)["mount"], "robot")
    assert all(c.ok for c in steps), [c.line() for c in steps if not c.ok]
