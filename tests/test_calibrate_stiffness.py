"""`whisker calibrate stiffness` on the simulator: the paper's Fig. 4 protocol recovers the stiffness."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from whisker.drive.actuation import Actuator
from whisker.design import default_design, design_from_dict, load_design
from whisker.drive.guard import ThermalGuard
from whisker.bringup.stiffness import StiffnessError, curve_deg, fit, measure_tilts, steps_volts
from whisker.vision.tracking import Tracker
from whisker.bringup.wiring import Harness, MiswiredSim, SimCamera, VirtualClock

D = default_design()


def _device(**changes):
    data = D.to_dict()
    for key, value in changes.items():
        section, name = key.split("__")
        data[section][name] = value
    return design_from_dict(data)


def _tracked_tilts(device, noise=3.0, harness=None):
    clock = VirtualClock()
    backend = MiswiredSim(device, harness or Harness.correct(device.whiskers.count), clock=clock)
    act = Actuator(device, backend, guard=ThermalGuard(device, clock=clock, policy="cut"), watchdog=False,
                   clock=clock)
    volts = steps_volts(D)
    with act:
        tilts = measure_tilts(act, SimCamera(device, backend, noise_sigma=noise).grab, Tracker(D, "roi"), volts,
                              settle_s=0.6, sleep=clock.sleep)
    return volts, tilts


@pytest.mark.parametrize("k_true", [1.1, 1.6])
def test_simulated_stiffness_is_recovered_within_5_percent(k_true):
    device = _device(mechanics__rotational_stiffness=k_true)
    volts, tilts = _tracked_tilts(device)
    assert np.isfinite(tilts).all()
    assert np.all(tilts[0::2] > 0) and np.all(tilts[1::2] < 0)      # retraction for +V, extension for -V
    rng = np.random.default_rng(0)
    noisy = tilts + rng.normal(0.0, 0.1, tilts.shape)               # tilt noise of a worse camera, deg
    for t in (tilts, noisy):
        res = fit(D, volts, t)
        assert res["rotational_stiffness_Nmm_per_rad"] == pytest.approx(k_true, rel=0.05), res
    # the design's gap is the device's: the fitted gap (identified or not) stays near it
    assert abs(fit(D, volts, tilts)["gap_mm"] - D.actuation.gap) < 0.1


def test_rest_gap_is_identified_from_both_polarities():
    device = _device(mechanics__rotational_stiffness=1.2, actuation__gap=2.2)
    volts, tilts = _tracked_tilts(device)
    res = fit(D, volts, tilts)
    assert res["gap_identified"] and res["gap_mm"] == pytest.approx(2.2, abs=0.05), res
    assert res["rotational_stiffness_Nmm_per_rad"] == pytest.approx(1.2, rel=0.05)
    # the fitted curve passes through the measured means
    model = curve_deg(D, res["rotational_stiffness_Nmm_per_rad"], res["gap_mm"], volts)
    assert np.max(np.abs(model - tilts.mean(axis=1))) < 0.2
    # fitting one polarity only cannot tell the gap from the stiffness as well
    one = fit(D, volts[0::2], tilts[0::2])
    assert one["gap_interval_mm"][1] - one["gap_interval_mm"][0] >= res["gap_interval_mm"][1] - res["gap_interval_mm"][0]


def test_coils_that_never_move_or_move_backwards_are_refused():
    volts = steps_volts(D)
    with pytest.raises(StiffnessError, match="do not move"):
        fit(D, volts, np.zeros((len(volts), 8)))
    device = _device(mechanics__rotational_stiffness=1.6)
    _, tilts = _tracked_tilts(device, noise=0.0)
    with pytest.raises(StiffnessError, match="opposite sign"):
        fit(D, volts, -tilts)


def test_cli_writes_the_override_plot_and_report(tmp_path):
    out = tmp_path / "fitted.toml"
    res = run_cli("calibrate", "stiffness", "--backend", "sim", "--sim-set", "mechanics.rotational_stiffness=1.5",
                  "--out", str(out), "-q", "--fixed-gap")
    assert res.returncode == 0, res.stderr
    fitted = load_design(out)
    assert fitted.mechanics.rotational_stiffness == pytest.approx(1.5, rel=0.05)
    assert fitted.actuation.gap == D.actuation.gap
    rep = json.loads((tmp_path / "fitted.stiffness.json").read_text())
    assert rep["points"] >= 60 and len(rep["tilts_deg"]) == 10
    assert (tmp_path / "fitted.stiffness.png").read_bytes()[:4] == b"\x89PNG"
    # a coil that never moves: one line, exit 1, the earlier file kept
    res = run_cli("calibrate", "stiffness", "--backend", "sim", "--sim-miswire", "//0,1,2,3,4,5,6,7",
                  "--out", str(out), "-q")
    assert res.returncode == 1 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert load_design(out).mechanics.rotational_stiffness == fitted.mechanics.rotational_stiffness


def test_warm_coils_draw_less_current_and_the_fit_knows():
    from whisker.drive.guard import coil_current_A

    device = _device(mechanics__rotational_stiffness=1.6)
    volts, tilts = _tracked_tilts(device, noise=0.0)
    cold = fit(D, volts, tilts, fit_gap=False)["rotational_stiffness_Nmm_per_rad"]
    warm = fit(D, volts, tilts, fit_gap=False, temperatures_C=np.full(tilts.shape, 60.0))
    ratio = float(coil_current_A(D, 1.0, 60.0) / coil_current_A(D, 1.0, 20.0))
    assert ratio < 0.95
    assert warm["rotational_stiffness_Nmm_per_rad"] == pytest.approx(cold * ratio, rel=1e-6)
