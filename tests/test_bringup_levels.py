"""Per-whisker levels from bring-up (whisker calibrate stiffness): the actuation refuses a level above a
whisker's measured safe level, and retracts each whisker at its own grasp level."""

from __future__ import annotations

import numpy as np
import pytest

from test_actuation import make
from whisker.bringup.stiffness import bringup_levels
from whisker.coil import pull_in
from whisker.design import default_design
from whisker.drive.guard import RatingError, check_levels, full_scale_voltage


def test_without_a_stop_the_safe_level_keeps_20_percent_below_pull_in():
    d = default_design("actuation.end_stop=false")
    ks = [0.836, 0.6, 1.2, None, 0.836, 0.836, 0.836, 0.836]
    lv = bringup_levels(d, ks)
    i_fs = full_scale_voltage(d) / d.coil.resistance
    for k, s in zip(ks, lv["safe_levels"]):
        if k is None:
            assert s == pytest.approx(1.0)
            continue
        assert s * i_fs * 1.2 == pytest.approx(min(pull_in(d, k)[0], 1.2 * i_fs), rel=1e-3)
    # a softer whisker pulls in sooner: a lower safe level
    assert lv["safe_levels"][1] < lv["safe_levels"][0] < lv["safe_levels"][2]


def test_with_the_stop_a_stiff_whisker_gets_a_higher_grasp_level():
    d = default_design()
    lv = bringup_levels(d, [0.836, 1.3, 3.0] + [0.836] * 5)
    base = d.actuation.voltage / full_scale_voltage(d)
    assert lv["grasp_levels"][0] >= base - 1e-9          # never below actuation.voltage's level
    assert lv["grasp_levels"][1] > lv["grasp_levels"][0]
    assert 2 in lv["short_of_stop"] and lv["grasp_levels"][2] == pytest.approx(1.0)


def test_actuation_refuses_above_a_whiskers_safe_level_in_one_line():
    safe = "[0.5, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9]"
    d = default_design(f"drive.safe_levels={safe}")
    act, be, _ = make(d)
    with act:
        act.apply(np.full(8, 0.5))
        with pytest.raises(RatingError) as err:
            act.apply(np.array([0.6] + [0.5] * 7))
        assert "whisker 0" in str(err.value) and "safe level 0.5" in str(err.value)
        assert "\n" not in str(err.value)
        assert np.all(act.requested == 0.5)          # the refused request changed nothing
    with pytest.raises(RatingError, match="entries for 8 whiskers"):
        check_levels(default_design("drive.safe_levels=[0.5, 0.5]"), np.zeros(8))


def test_retract_uses_each_whiskers_grasp_level():
    g = [0.7, 0.8, 0.9, 0.95, 0.7, 0.8, 0.9, 0.95]
    d = default_design(f"drive.grasp_levels={g}")
    act, _, _ = make(d)
    with act:
        out = act.retract()
        assert np.allclose(act.requested, g)
        assert np.all(out <= np.asarray(g) + 1e-12)
