"""The assembly sequence (hw/assembly_sequence.toml) checked by sweeping each step (whisker.cad.assembly.sequence)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from whisker.cad.solids import mount
from whisker.cad.assembly import sequence
from whisker.design import DesignError, default_design


@pytest.mark.parametrize("variant", sequence.VARIANTS)
def test_default_design_goes_together(variant):
    d = default_design()
    checks = sequence.check_sequence(d, mount.mount(d), variant)
    assert len(checks) == 5 and all(c.ok for c in checks), [c.line() for c in checks if not c.ok]


def test_coils_wider_than_the_seat_opening_are_refused_naming_the_step():
    """An 18 mm membrane's seat opens to 17.2 mm: the winding's outer face (17.0 mm from the axis,
    17.1 at its rim) would pass, the bobbin's outer flange (17.35 mm, 17.46 at its corners) does not.
    The membrane's size is pinned: its "auto" rule widens the seat to pass the flanges."""
    from whisker.design import former

    d = default_design("membrane.inscribed_radius=18")
    f = former.layout(d)
    winding_rim = math.hypot(f.core[1], f.winding_outer_diameter / 2)
    flange_rim = math.hypot(f.outer_x, f.half_width)
    assert winding_rim < d.neck_radius < flange_rim
    checks = sequence.check_sequence(d, mount.mount(d), "robot")
    failed = [c for c in checks if not c.ok]
    assert [c.name for c in failed] == ["assembly step 3: membrane with rods and coils onto the seat"]
    line = failed[0].line()
    assert "\n" not in line and "coil" in line and "runs into the mount" in line and "bobbin.flange" in line


def test_magnets_that_cannot_pass_the_seat_opening_are_refused():
    # a 2.5 mm opening: a 4.76 mm magnet cannot pass
    d = default_design("mount.seat_ledge=13.5", "membrane.inscribed_radius=16")
    failed = [c for c in sequence.check_sequence(d, mount.mount(d), "bench") if not c.ok]
    assert failed[0].name.startswith("assembly step 1: magnets") and "no such path" in failed[0].detail


def test_sweep_is_the_hull_along_the_path():
    import manifold3d

    cube = manifold3d.Manifold.cube((1, 1, 1))
    swept = sequence.sweep(cube, [("+z", 4.0), ("+x", 2.0)], {})
    assert swept.volume() == pytest.approx(1 + 4 + 2, abs=1e-6)   # an L of unit cross-section


def test_bad_sequences_are_one_line():
    d = default_design()
    steps = sequence.load_steps()
    with pytest.raises(DesignError, match="needs magnets into their pockets first"):
        sequence.check_sequence(d, mount.mount(d), "robot", steps[1:])
    with pytest.raises(DesignError, match="unknown assembly variant 'boat'; known: robot, bench"):
        sequence.check_sequence(d, mount.mount(d), "boat")
    bad = [dataclasses.replace(steps[0], parts=("gearbox",))]
    with pytest.raises(DesignError, match="unknown part 'gearbox'"):
        sequence.check_sequence(d, mount.mount(d), "robot", bad)
