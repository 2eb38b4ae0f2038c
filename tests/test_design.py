"""The design model: the paper's values, overrides, and clear refusals."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings, strategies as st

from whisker.design import DesignError, apply_overrides, default_design, load_design


def test_default_is_the_papers_sensor():
    d = default_design()
    assert d.whiskers.count == 8 and d.whiskers.ring_radius == 12.0
    assert (d.whiskers.rod_diameter, d.whiskers.rod_length, d.whiskers.protrusion) == (1.0, 69.0, 63.0)
    assert (d.membrane.sides, d.membrane.inscribed_radius, d.membrane.thickness) == (8, 19.5, 3.0)  # the paper's 16 mm: docs/coil.md
    assert (d.coil.outer_diameter, d.coil.length) == (4.0, 4.0)
    assert (d.magnet.diameter, d.magnet.height) == (4.76, 1.59)


def test_derived_geometry_follows_the_parameters():
    d = default_design()
    assert d.l_u == pytest.approx(63 + 3 - 1.5)  # pivot at the membrane's mid-plane
    assert d.l_l == pytest.approx(1.5 + d.coil.drop + d.coil.outer_diameter)
    assert d.mm_per_px == pytest.approx(d.camera.distance / d.camera.focal_length_px)
    assert d.whisker_angles_deg == pytest.approx([45.0 * i for i in range(8)])
    d6 = default_design("whiskers.count=6", "whiskers.first_angle_deg=30")
    assert d6.whisker_angles_deg == pytest.approx([30, 90, 150, 210, 270, 330])


def test_overrides_parse_toml_values():
    d = default_design("whiskers.count=6", "whiskers.ring_radius=10", 'magnet.grade="N52"', "magnet.grade=N35")
    assert d.whiskers.count == 6 and isinstance(d.whiskers.count, int)
    assert d.whiskers.ring_radius == 10.0
    assert d.magnet.grade == "N35"


@pytest.mark.parametrize("override, names", [
    ("whiskers.cont=6", "cont"),
    ("whisker.count=6", "whisker"),
    ("whiskers.count=0", "whiskers.count"),
    ("whiskers.ring_radius=-1", "whiskers.ring_radius"),
    ("whiskers.ring_radius=nan", "whiskers.ring_radius"),
    ("whiskers.ring_radius=inf", "whiskers.ring_radius"),
    ("coil.inner_diameter=5", "coil.inner_diameter"),
    ("whiskers.rod_length=60", "whiskers.rod_length"),
    ("whiskers.count", "section.key=value"),
])
def test_bad_values_are_refused_with_the_parameter_named(override, names):
    with pytest.raises(DesignError) as err:
        default_design(override)
    msg = str(err.value)
    assert names in msg and "\n" not in msg


def test_missing_and_broken_files(tmp_path):
    with pytest.raises(DesignError, match="does not exist"):
        load_design(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[whiskers\ncount = 8")
    with pytest.raises(DesignError, match="not valid TOML"):
        load_design(bad)


def test_overrides_do_not_mutate_the_input():
    data = {"a": {"b": 1}}
    assert apply_overrides(data, ["a.b=2"]) == {"a": {"b": 2}}
    assert data == {"a": {"b": 1}}


def test_digest_changes_with_any_value():
    assert default_design().digest() == default_design().digest()
    assert default_design().digest() != default_design("print.clearance=0.25").digest()


@settings(max_examples=200, deadline=None)
@given(count=st.integers(-3, 80), radius=st.floats(allow_nan=True, allow_infinity=True),
       clearance=st.floats(-1, 3), deflection=st.floats(-10, 90))
def test_any_value_loads_or_is_refused_cleanly(count, radius, clearance, deflection):
    """The only failure mode of loading is a DesignError; a loaded design has finite derived values."""
    try:
        d = default_design(f"whiskers.count={count}", f"whiskers.ring_radius={radius!r}".replace("'", ""),
                           f"print.clearance={clearance!r}", f"whiskers.max_deflection_deg={deflection!r}")
    except DesignError as err:
        assert str(err) and "\n" not in str(err)
        return
    assert all(math.isfinite(v) for v in (d.l_u, d.l_l, d.mm_per_px, d.cavity_radius))
    assert len(d.whisker_angles_deg) == count
