"""`whisker calibrate wiring` on the simulator: swapped, reversed and dead coils, and the pin-map fix."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import run_cli
from whisker.drive.actuation import Actuator
from whisker.design import default_design, design_from_dict, load_design
from whisker.drive.guard import ThermalGuard, volts_to_levels
from whisker.drive.pins import PinMapError, pin_map
from whisker.vision.tracking import Tracker
from whisker.bringup.wiring import (Harness, MiswiredSim, SimCamera, VirtualClock, WiringError, diagnose,
                                  override_for, pulse_coils, with_override)

D = default_design()
N = D.whiskers.count
# coils 1 and 3 swapped at the bridge outputs, coil 5's leads reversed
FAULT = Harness([0, 3, 2, 1, 4, 5, 6, 7], [1, 1, 1, 1, 1, -1, 1, 1])


def _device(design, harness):
    clock = VirtualClock()
    backend = MiswiredSim(design, harness, clock=clock)
    act = Actuator(design, backend, guard=ThermalGuard(design, clock=clock, policy="cut"), watchdog=False,
                   clock=clock)
    return backend, act, clock


def _diagnose(design, harness):
    backend, act, clock = _device(design, harness)
    with act:
        resp, rest = pulse_coils(act, SimCamera(design, backend).grab, Tracker(design, "roi"),
                                 float(volts_to_levels(design, 1.5)), settle_s=0.5, sleep=clock.sleep)
    return diagnose(resp, rest)


def _with(design, order, pol):
    data = design.to_dict()
    data["wiring"]["coil_order"], data["wiring"]["coil_polarity"] = list(order), list(pol)
    return design_from_dict(data)


def _retract_tilts_deg(design, harness):
    backend, act, clock = _device(design, harness)
    with act:
        act.retract()
        clock.sleep(1.0)
        act.tick()
        return np.degrees(backend.theta[:, 0])


def test_swapped_and_reversed_coils_are_diagnosed_exactly_and_fixed():
    assert np.any(_retract_tilts_deg(D, FAULT) < 0)      # the fault: whisker 5 extends when told to retract
    diag = _diagnose(D, FAULT)
    assert diag.swapped == [[1, 3]] and diag.reversed == [5] and diag.dead == []
    assert diag.marker_of == [0, 3, 2, 1, 4, 5, 6, 7]
    assert min(abs(m) for m in diag.moved_px) > 2.0 and max(diag.crosstalk_px) < 0.5
    order, pol = override_for(D, diag)
    fixed = _with(D, order, pol)
    tilts = _retract_tilts_deg(fixed, FAULT)
    assert np.all(tilts > 5.0), tilts                      # every whisker retracts
    assert np.ptp(tilts) < 0.1
    again = _diagnose(fixed, FAULT)
    assert again.ok and again.marker_of == list(range(N)), again.lines()
    # the override re-routes pins: whisker 3 now on the pins whisker 1 had, whisker 5's pins exchanged
    base, new = pin_map(D), pin_map(fixed)
    assert (new[3].forward, new[3].backward) == (base[1].forward, base[1].backward)
    assert (new[5].forward, new[5].backward) == (base[5].backward, base[5].forward)


def test_a_second_run_composes_with_the_existing_override():
    partial = _with(D, [0, 3, 2, 1, 4, 5, 6, 7], [1] * N)   # swap fixed, reversal not yet
    diag = _diagnose(partial, FAULT)
    assert diag.swapped == [] and diag.reversed == [5]
    order, pol = override_for(partial, diag)
    assert order == [0, 3, 2, 1, 4, 5, 6, 7] and pol == [1, 1, 1, 1, 1, -1, 1, 1]


def test_dead_coil_is_named_and_no_override_is_made():
    diag = _diagnose(D, Harness(list(range(N)), [1] * N, {2}))
    assert diag.dead == [2] and diag.swapped == [] and diag.reversed == []
    with pytest.raises(WiringError, match=r"\[2\] moved no marker"):
        override_for(D, diag)


def test_override_text_replaces_only_the_wiring_lines():
    text = "[whiskers]\ncount = 8\n\n[wiring]\nexpander = \"none\"\ncoil_order = [1, 0]\n\n[tracking]\nx = 1\n"
    out = with_override(text, [0, 1], [1, -1])
    assert out.count("coil_order") == 1 and "coil_polarity = [1, -1]" in out
    assert out.index("coil_polarity") < out.index("[tracking]") and "x = 1" in out and 'expander = "none"' in out
    assert "[wiring]" in with_override("[a]\nb = 1\n", [0], [1])


def test_bad_override_is_refused_in_one_line():
    with pytest.raises(PinMapError, match="permutation"):
        pin_map(_with(D, [0, 0, 2, 3, 4, 5, 6, 7], [1] * N))
    with pytest.raises(PinMapError, match="coil_polarity"):
        pin_map(_with(D, list(range(N)), [1, 2, 1, 1, 1, 1, 1, 1]))


def test_cli_writes_a_design_that_retracts_every_whisker(tmp_path):
    out = tmp_path / "fixed.toml"
    res = run_cli("calibrate", "wiring", "--backend", "sim", "--sim-miswire", "0,3,2,1,4,5,6,7/1,1,1,1,1,-1,1,1",
                  "--out", str(out), "-q")
    assert res.returncode == 0, res.stderr
    assert "swapped [[1, 3]], reversed [5]" in res.stdout
    fixed = load_design(out)
    assert list(fixed.wiring.coil_order) == [0, 3, 2, 1, 4, 5, 6, 7]
    assert list(fixed.wiring.coil_polarity) == [1, 1, 1, 1, 1, -1, 1, 1]
    assert np.all(_retract_tilts_deg(fixed, FAULT) > 5.0)
    res = run_cli("actuate", "retract", "--backend", "sim", "--design", str(out), "--duration", "0.2", "-q")
    assert res.returncode == 0, res.stderr


def test_cli_dead_coil_one_line_and_previous_file_kept(tmp_path):
    out = tmp_path / "fixed.toml"
    out.write_text("previous")
    res = run_cli("calibrate", "wiring", "--backend", "sim", "--sim-miswire", "0,1,2,3,4,5,6,7//6",
                  "--out", str(out), "-q")
    assert res.returncode == 1
    assert len(res.stderr.strip().splitlines()) == 1 and "[6] moved no marker" in res.stderr
    assert out.read_text() == "previous"
    res = run_cli("calibrate", "wiring", "--backend", "sim", "--sim-miswire", "0,0,2", "-q")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1


def test_crosstalk_is_measured_in_px_and_named():
    # channel 2's coil also pulls coil 3 with 30 % of its drive (a neighbour's field)
    leaky = Harness(list(range(N)), [1] * N, leak={(2, 3): 0.3})
    diag = _diagnose(D, leaky)
    assert diag.ok and diag.marker_of == list(range(N))
    assert [c[:2] for c in diag.crosstalk] == [[2, 3]]
    assert diag.crosstalk[0][2] == pytest.approx(0.3 * diag.moved_px[3], rel=0.25)
    assert "cross-talk: marker 3" in diag.lines()[2]


def test_a_camera_that_returns_nothing_is_refused():
    from whisker.vision.tracking import CalibrationError

    backend, act, clock = _device(D, FAULT)
    with act, pytest.raises(CalibrationError, match="no usable rest frame"):
        pulse_coils(act, lambda: None, Tracker(D, "roi"), 0.3, settle_s=0.1, sleep=clock.sleep)
