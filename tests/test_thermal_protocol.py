"""whisker.drive.thermal_protocol: the paper's grasp through the guard on the thermal network, and the
holding level the grasp command uses by default."""

from __future__ import annotations

import numpy as np
import pytest

from whisker.design import default_design
from whisker.drive.guard import volts_to_levels
from whisker.drive.thermal_protocol import Protocol, fit_hold_level, run_protocol

D = default_design()
LEVEL = float(volts_to_levels(D, [D.actuation.voltage])[0])


def test_protocol_timing_is_the_simulators_and_the_closed_loops():
    from whisker.sensing.grasp_control import ControlParams
    from whisker.sim import protocol as sp

    p = Protocol()
    assert p.close_s == sp.T_CLOSE
    assert p.lift_s == pytest.approx(sp.T_LIFT)
    cp = ControlParams(full_level=LEVEL, grasp_height_mm=2.0, start_height_mm=17.0)
    assert p.lift_mm == cp.lift_mm and p.lift_mm / p.lift_mm_s == pytest.approx(cp.lift_s)
    assert [ph for ph, *_ in p.phases(1.0, 0.5)] == ["close", "lift", "hold", "release"]
    with pytest.raises(ValueError, match="hold_s"):
        Protocol(hold_s=float("nan"))


def test_fitted_holding_level_fits_and_a_higher_one_does_not():
    hold = fit_hold_level(D, LEVEL, resolution=0.005)
    assert 0 < hold <= LEVEL
    ok = run_protocol(D, LEVEL, hold)
    assert ok.fits and ok.trips == 0
    if hold < LEVEL - 0.01:
        over = run_protocol(D, LEVEL, min(LEVEL, hold + 0.02))
        assert not over.fits and over.first_reduced_s is not None
    # every material stays below its derate band while it fits (within the last update before the
    # release: one guard period at ~15 K/s)
    band = D.drive.guard_margin + D.drive.guard_derate_band
    for k, peak in ok.peaks().items():
        assert peak <= ok.limits_C[k] - band + 0.5, k


def test_the_weaker_resin_needs_a_lower_holding_level():
    green = default_design("thermal.bobbin_material=standard resin green")
    h_green = fit_hold_level(green, LEVEL, resolution=0.005)
    h_cured = fit_hold_level(D, LEVEL, resolution=0.005)
    assert h_green < h_cured
    r = run_protocol(green, LEVEL)                       # full level all through: the guard steps in
    assert not r.fits and r.first_reduced_s < Protocol().close_s + Protocol().lift_s + Protocol().hold_s
    # the coils cool after the release: the last sample is cooler than the peak
    w = r.materials_C["bobbin (standard resin green)"]
    assert w[-1] < w.max() - 0.5                        # (slowly: a time constant of ~30 s)


def test_grasp_command_holds_at_the_fitted_level_by_default():
    from whisker.commands.sensor.grasp import build_sequence
    from whisker.drive.thermal_protocol import Protocol as P

    steps = build_sequence(D, "all", 0, LEVEL, None, 1.0, 3.0, 1.0, 0.0)
    hold = [s for s in steps if s.phase == "hold"][0]
    expect = fit_hold_level(D, LEVEL, P(close_s=1.0, lift_mm=0.0, hold_s=3.0, release_s=0.0), resolution=0.005)
    assert np.allclose(hold.levels, expect) and expect < LEVEL
    given = build_sequence(D, "all", 0, LEVEL, 0.4, 1.0, 3.0, 1.0, 0.0)
    assert np.allclose([s for s in given if s.phase == "hold"][0].levels, 0.4)
