"""Sizes that follow the ring (whisker.design.sizing): the rules, their provenance, and refusals of absurd
values before any CAD is built. Fast: no solids here (tests/test_cad_scaled.py builds them)."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given, settings, strategies as st

from conftest import run_cli
from whisker.design import sizing
from whisker.design import DesignError, default_design

AUTO = [r.name for r in sizing.RULES]


def test_rules_give_back_the_papers_sensor():
    d = default_design()
    # The paper's membrane is 16 mm and its mount 22 mm; the coil as it can be wound (a bobbin with
    # the rod in its tab, the winding outboard) reaches 5.35 mm past the rod, so the seat's opening
    # and the magnets move out (docs/coil.md, "Fitting the wound coil").
    assert d.membrane.inscribed_radius == 19.5
    # 24 mm: each robot insert keeps hw/fasteners.csv's insert_min_wall (2.3 mm) to the rim (issue 29)
    assert d.mount.outer_radius == 24.0
    assert d.mount.cable_exit_count == 2
    assert d.mold.pour_diameter == 6.0
    # 35.2 mm was calibrated on the authors' frames (0.1009 mm/px for the 12 mm ring)
    assert d.camera.distance == pytest.approx(35.2, abs=0.05)
    assert all(d.source(name).startswith("rule: ") for name in AUTO if name != "membrane.sides")
    assert d.membrane.sides == 8 and d.source("membrane.sides") == "file"
    assert d.source("whiskers.ring_radius") == "file"


def test_a_number_in_the_file_pins_the_value():
    d = default_design("membrane.inscribed_radius=18", "mount.outer_radius=25", "camera.distance=40")
    assert (d.membrane.inscribed_radius, d.mount.outer_radius, d.camera.distance) == (18.0, 25.0, 40.0)
    assert d.source("membrane.inscribed_radius") == "file"
    # the bolt circle follows the pinned outer radius, whatever the robot flange (its bolts are on
    # the adapter's flange plate, whisker.cad.solids.adapter)
    for preset in ("plain", "iso9409_50_4_m6", "iso9409_31_5_4_m5"):
        p = default_design("mount.outer_radius=25", f'adapter.preset="{preset}"')
        assert p.mount.mounting_bolt_radius == pytest.approx(25 - p.mounting_hole_diameter / 2
                                                             - p.mounting_hole_wall, abs=0.1)


def test_sizes_grow_with_the_ring():
    small, big = default_design("whiskers.ring_radius=7"), default_design("whiskers.ring_radius=20")
    assert small.membrane.inscribed_radius < 19.5 < big.membrane.inscribed_radius
    assert big.mount.outer_radius > 23 and big.camera.distance > 35.2 > small.camera.distance
    # the example: 5 whiskers at 13 mm needed an 18 mm membrane by hand; the rule gives room
    d = default_design("whiskers.count=5", "whiskers.ring_radius=13")
    assert d.neck_radius >= sizing.coil_reach(d, z_min=-(d.mount.flange_thickness + d.print.clearance)) + d.print.clearance


@settings(max_examples=60, deadline=None)
@given(count=st.integers(2, 16), radius=st.floats(4.0, 25.0))
def test_rules_keep_their_promises(count, radius):
    """Over the sweep's range every rule gives a finite value that does what its reason says."""
    d = default_design(f"whiskers.count={count}", f"whiskers.ring_radius={radius}")
    clr = d.print.clearance
    # the seat opening passes every coil at rest and clears the swinging coil under the flange
    assert d.neck_radius >= sizing.coil_reach(d, tilts=False) + clr - 1e-9
    assert d.neck_radius >= sizing.coil_reach(d, z_min=-(d.mount.flange_thickness + clr)) + clr - 1e-9
    # the mount keeps min_wall outside its inner features and its robot holes
    w = d.print.min_wall
    assert d.mount.outer_radius >= sizing.pocket_outer_radius(d) + w
    hole_r = d.mounting_hole_diameter / 2
    # a heat-set insert's hole keeps the fastener table's insert wall (hw/fasteners.csv), not only min_wall
    assert d.mount.outer_radius - d.mount.mounting_bolt_radius - hole_r >= d.mounting_hole_wall - 1e-9
    assert d.mounting_hole_wall >= w
    # with "auto" the membrane's outline has the ring's symmetry
    a = default_design(f"whiskers.count={count}", 'membrane.sides="auto"')
    assert a.membrane.sides % count == 0 and a.membrane.sides >= sizing.MIN_MEMBRANE_SIDES
    # the ring keeps its size in the image; the pour opening leaves min_wall to the rod guides
    if d.camera.distance > d.marker_z - sizing.mount_levels(d)["cylinder_bottom"] + 1e-6:
        assert d.whiskers.ring_radius / d.mm_per_px == pytest.approx(d.camera.ring_radius_px, rel=1e-3)
    assert d.whiskers.ring_radius - d.hole(d.whiskers.rod_diameter) / 2 - d.mold.pour_diameter / 2 >= w - 1e-6
    assert d.mount.cable_exit_count == math.ceil(count / 4)
    assert all(math.isfinite(v) for v in (d.membrane.inscribed_radius, d.mount.outer_radius, d.camera.distance))


def test_crowding_bound_formula():
    """2 rho sin(pi/N) - D cos(pi/N) = c exactly at the bound, rho at full inward swing."""
    d = default_design()
    for n in range(3, 17):
        r = sizing.crowding_bound_radius(d, n)
        dn = default_design(f"whiskers.count={n}", f"whiskers.ring_radius={r}")
        rho = sizing.coil_inner_chord_radius(dn)
        gap = 2 * rho * math.sin(math.pi / n) - d.coil.outer_diameter * math.cos(math.pi / n)
        assert gap == pytest.approx(d.print.clearance, abs=1e-9)
    # more whiskers need a larger ring
    bounds = [sizing.crowding_bound_radius(d, n) for n in range(2, 17)]
    assert bounds == sorted(bounds)


@pytest.mark.parametrize("override, named", [
    ("whiskers.ring_radius=1e308", "whiskers.ring_radius"),
    ("whiskers.ring_radius=0", "whiskers.ring_radius"),
    ("membrane.inscribed_radius=1e308", "membrane.inscribed_radius"),
    ("membrane.inscribed_radius=-3", "membrane.inscribed_radius"),
    ("mount.outer_radius=nan", "mount.outer_radius"),
    ("camera.distance=inf", "camera.distance"),
    ("mount.cable_exit_count=2.5", "mount.cable_exit_count"),
    ("coil.length=1e308", "coil.length"),
    ("mold.pour_diameter=\"big\"", "mold.pour_diameter"),
    ("coil.wire_diameter=5", "coil.wire_diameter"),  # `coil report` refuses it too (one wire does not fit)
])
def test_absurd_values_are_refused_by_the_design_model(override, named):
    with pytest.raises(DesignError) as err:
        default_design(override)
    assert named in str(err.value) and "\n" not in str(err.value)


def test_a_ring_too_small_for_a_pour_opening_is_refused_by_its_rule():
    with pytest.raises(DesignError, match="mold.pour_diameter"):
        default_design("whiskers.ring_radius=1.5")


def test_design_show_marks_file_and_rule_values(tmp_path):
    res = run_cli("design", "show", "--set", "whiskers.ring_radius=20", "--set", "mount.outer_radius=30")
    assert res.returncode == 0, res.stderr
    lines = {ln.split("=")[0].strip(): ln for ln in res.stdout.splitlines() if "=" in ln and not ln.startswith("#")}
    # each line ends "# <unit>; <source>" (design show prints the unit first)
    assert "; rule: " in lines["inscribed_radius"] and lines["outer_radius"].rstrip().endswith("; file")
    res = run_cli("design", "show", "--json")
    data = json.loads(res.stdout)
    assert data["sources"]["whiskers.count"] == "file"
    assert data["sources"]["camera.distance"].startswith("rule: ")
    assert data["design"]["membrane"]["inscribed_radius"] == 19.5


def test_absurd_ring_is_one_line_exit_2_without_cad(tmp_path):
    res = run_cli("cad", "build", "--set", "whiskers.ring_radius=1e308", "--out", str(tmp_path / "x"))
    assert res.returncode == 2
    assert len(res.stderr.strip().splitlines()) == 1 and "whiskers.ring_radius" in res.stderr
    assert "Traceback" not in res.stderr and not (tmp_path / "x").exists()
