"""Property tests over the CAD parameter space: a design either passes every measured check, with
the right counts measured independently here, or is refused with a reason naming parameters."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import circles, run_cli, section_polygons
from whisker.cad.verify import checks
from whisker.cad.build import build_solids, evaluate
from whisker.design import DesignError, default_design


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(count=st.integers(2, 16), radius=st.floats(4.0, 25.0), clearance=st.sampled_from([0.0, 0.1, 0.2, 0.4]))
def test_feasible_or_clearly_refused(count, radius, clearance):
    try:
        d = default_design(f"whiskers.count={count}", f"whiskers.ring_radius={radius}", f"print.clearance={clearance}")
    except DesignError as err:
        assert "\n" not in str(err)
        return
    results = evaluate(d)
    failed = [c for c in results if not c.ok]
    for c in results:
        if c.ok and isinstance(c.value, float):
            assert math.isfinite(c.value), c.line()
    if failed:
        for c in failed:
            line = c.line()
            assert "\n" not in line and "[parameters:" in line, line
        return
    # Feasible: count the membrane's rod holes ourselves, on a mesh of the solid.
    mem = checks.to_mesh(build_solids(d)["membrane"], d.export.linear_tolerance, d.export.angular_tolerance)
    holes = circles(section_polygons(mem, d.membrane.thickness / 2))
    assert len(holes) == count
    assert all(abs(r - radius) < 0.05 for r, _, _ in holes)
    found = {c.name: c.value for c in results if c.part == "mount"}
    assert found["magnet pockets found"] == count  # never silently merged


def test_crowded_coils_are_refused_for_the_coils():
    """16 coils on an 8 mm ring overlap: the refusal names the coil clearance, not a side effect."""
    d = default_design("whiskers.count=16", "whiskers.ring_radius=8")
    failed = [c for c in evaluate(d) if not c.ok]
    assert failed and failed[0].name == "coil clearance over full deflection"
    assert "whiskers.count" in failed[0].parameters and "whiskers.ring_radius" in failed[0].parameters


