"""The series resistor per coil (driver.series_resistance): design key, driver model, guard, BOM, netlist."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from test_actuation_doubles import FakeClock
from whisker import coil
from whisker.coil import driver
from whisker.design import DesignError, default_design
from whisker.drive.guard import (RatingError, ThermalGuard, check_levels, coil_current_A, full_scale_voltage,
                           max_level, volts_to_levels)

NO_RESISTOR = "driver.series_resistance=0"
L298N = driver.bridge("L298N")


def seven_ohm(*overrides):
    """The paper's measured 7 ohm coil: the driver arithmetic below (docs/wiring.md) is worked out for
    it; the default coil is the bobbin's 5.87 ohm ("auto", whisker.design.former), whose resistor is 3.9 ohm."""
    return default_design("coil.resistance=7.0", *overrides)


@pytest.fixture(scope="module")
def design():
    return seven_ohm()


# ---- design key --------------------------------------------------------------------------------

def test_default_is_auto_and_resolves_to_3_9_ohm():
    """The bobbin's 5.87 ohm coil (coil.resistance = "auto", whisker.design.former), 7.5 V, L298N typ (1.40 V +
    1.15 ohm I), 3.3 V rating: Rs >= 5.872 x 6.1/3.3 - 7.022 = 3.83 ohm -> 3.9 ohm, the next E24 value
    (3.6 would give more than 3.3 V at the coil). The paper's measured 7 ohm gives 5.1 ohm."""
    design = default_design()
    rc = design.coil.resistance
    assert design.driver.series_resistance == "auto" and rc == pytest.approx(5.872, abs=1e-3)
    assert driver.series_resistance_ohm(design) == 3.9
    assert rc * 6.1 / 3.3 - rc - 1.15 == pytest.approx(3.832, abs=1e-3)
    assert driver.coil_current_A(L298N, 7.5, rc, 3.6) * rc > 3.3  # the E24 value below is too small
    assert driver.series_resistance_ohm(default_design("coil.resistance=7.0")) == 5.1
    assert driver.series_resistance_ohm(default_design("driver.series_resistance=2.2")) == 2.2
    assert driver.series_resistance_ohm(default_design(NO_RESISTOR)) == 0.0


@pytest.mark.parametrize("value, match", [("-1", "driver.series_resistance"), ("nan", "driver.series_resistance"),
                                          ("manual", "driver.series_resistance"), ("5000", "driver.series_resistance"),
                                          ("true", "from 0 \\(none\\) to 1000")])
def test_bad_values_refused_on_one_line(value, match):
    with pytest.raises(DesignError, match=match) as err:
        seven_ohm(f"driver.series_resistance={value}")
    assert "\n" not in str(err.value)


def test_auto_is_zero_when_the_bare_bridge_is_within_the_rating():
    d = seven_ohm("driver.supply_voltage=5.0")  # 7 x 3.6 / 8.15 = 3.09 V <= 3.3 V
    assert driver.series_resistance_ohm(d) == 0.0
    assert full_scale_voltage(d) == pytest.approx(7.0 * 3.6 / 8.15, rel=1e-12)


# ---- properties of the auto value ------------------------------------------------------------------

@settings(max_examples=200, deadline=None)
@given(rc=st.floats(1.0, 50.0), vs=st.floats(4.5, 46.0), vmax=st.floats(0.5, 12.0),
       name=st.sampled_from(sorted(driver.BRIDGES)))
def test_auto_never_exceeds_the_rating_and_is_the_smallest_e24(rc, vs, vmax, name):
    br = driver.bridge(name)
    rs = driver.auto_series_resistance_ohm(br, vs, rc, vmax)
    v_full = driver.coil_current_A(br, vs, rc, rs) * rc
    assert math.isfinite(rs) and rs >= 0
    assert v_full <= vmax * (1 + 1e-9)
    if rs == 0:
        assert driver.coil_current_A(br, vs, rc) * rc <= vmax * (1 + 1e-9)
    else:
        below = driver.nearest_preferred(rs * (1 - 1e-6), "E24", "down")
        assert driver.coil_current_A(br, vs, rc, below) * rc > vmax  # the next smaller E24 value is too small
        assert round(rs / 10 ** math.floor(math.log10(rs)), 2) in driver.E24


@settings(max_examples=25, deadline=None)
@given(rc=st.floats(3.0, 20.0), vs=st.floats(5.8, 24.0))
def test_design_full_scale_within_rating_with_auto(rc, vs):
    d = seven_ohm(f"coil.resistance={rc!r}", f"driver.supply_voltage={vs!r}")
    assert full_scale_voltage(d) <= d.drive.max_coil_voltage * (1 + 1e-9)
    assert max_level(d) == pytest.approx(1.0) or driver.series_resistance_ohm(d) == 0
    check_levels(d, np.ones(d.whiskers.count))  # level 1 allowed: the hardware caps the voltage


@settings(max_examples=25, deadline=None)
@given(vs=st.floats(4.5, 24.0))
def test_zero_resistor_reproduces_the_bare_bridge(vs):
    """R_s = 0: full scale R (Vs - V0)/(R + r) and the guard's current V/R(T), as before the resistor."""
    d = seven_ohm(f"driver.supply_voltage={vs!r}", NO_RESISTOR)
    vfs = full_scale_voltage(d)
    assert vfs == pytest.approx(7.0 * (vs - 1.40) / (7.0 + 1.15), rel=1e-12)
    assert max_level(d) == pytest.approx(min(1.0, 3.3 / vfs))
    for t in (20.0, 55.0, 90.0):
        assert coil_current_A(d, vfs, t) == coil.current_A(d, vfs, t)


# ---- driver model with the default resistor ----------------------------------------------------

def test_default_numbers(design):
    """5.1 ohm: I = 6.1/(7 + 5.1 + 1.15) = 0.4604 A, 3.22 V at the coil, 1.08 W in the resistor (2 W part),
    3 V at level 0.931; at 3 V mean the coil takes 1.38 W (1.07x a steady 3 V, PWM without it 2.25 W)."""
    vfs = full_scale_voltage(design)
    assert vfs == pytest.approx(7.0 * 6.1 / 13.25, rel=1e-12) and vfs <= design.drive.max_coil_voltage
    assert max_level(design) == 1.0
    check_levels(design, np.ones(8))
    check_levels(design, -np.ones(8))
    lv = float(volts_to_levels(design, 3.0))
    assert lv == pytest.approx(3.0 / vfs) and 0.93 < lv < 0.932
    p_rs = driver.resistor_power_W(design)
    assert p_rs == pytest.approx((6.1 / 13.25) ** 2 * 5.1) and 1.0 < p_rs < 1.2
    assert driver.resistor_rating_W(p_rs) == 2.0
    i = vfs / 7.0
    coil_heat_3v = lv * i * i * 7.0
    bare = seven_ohm(NO_RESISTOR)
    bare_heat_3v = float(volts_to_levels(bare, 3.0)) * (full_scale_voltage(bare) / 7.0) ** 2 * 7.0
    assert coil_heat_3v == pytest.approx(1.381, abs=2e-3) and bare_heat_3v == pytest.approx(2.245, abs=2e-3)
    assert bare_heat_3v / coil_heat_3v > 1.6
    with pytest.raises(RatingError, match="above the coil rating"):
        volts_to_levels(design, 3.4)


def test_resistor_rating_choice():
    assert driver.resistor_rating_W(0.0) == 0.25
    assert driver.resistor_rating_W(0.6) == 1.0
    assert driver.resistor_rating_W(1.2) == 2.0
    assert driver.resistor_rating_W(1.21) == 3.0
    assert driver.resistor_rating_W(7.0) == 25.0
    with pytest.raises(driver.DriverError, match="more than a 50 W part"):
        driver.resistor_rating_W(31.0)
    with pytest.raises(driver.DriverError, match="finite"):
        driver.resistor_rating_W(float("nan"))


@settings(max_examples=30, deadline=None)
@given(t=st.floats(-20.0, 150.0), rs=st.sampled_from([0.0, 1.0, 5.1, 22.0]))
def test_guard_current_is_the_driver_current_at_temperature(t, rs):
    """With R_s > 0 the guard's peak current at T is the driver model's (Vs - V0)/(R(T) + Rs + r) exactly;
    with R_s = 0 it stays V_fs/R(T)."""
    d = seven_ohm(f"driver.series_resistance={rs!r}")
    vfs = full_scale_voltage(d)
    got = coil_current_A(d, vfs, t)
    if rs > 0:
        assert got == pytest.approx(driver.coil_current_A(L298N, 7.5, coil.resistance_ohm(d, t), rs), rel=1e-12)
    else:
        assert got == pytest.approx(vfs / coil.resistance_ohm(d, t), rel=1e-12)
    vec = coil_current_A(d, np.array([vfs, vfs / 2]), np.array([t, t]))
    assert vec.shape == (2,) and vec[1] == pytest.approx(got / 2)
    with pytest.raises(ValueError, match="finite"):
        coil_current_A(d, float("nan"), t) if rs > 0 else coil.current_A(d, float("nan"), t)


# ---- the guard both ways -------------------------------------------------------------------------

def _time_to_cut(design, level, dt=0.05, limit_s=120.0):
    clock = FakeClock()
    g = ThermalGuard(design, clock=clock, policy="cut")  # default current_fn: whisker.drive.guard.coil_current_A
    req = np.zeros(design.whiskers.count)
    req[0] = level
    t = 0.0
    while t < limit_s:
        a = g.allow(req)
        if a[0] == 0.0:
            return t, g
        clock.t = t = t + dt
    raise AssertionError(f"no cut within {limit_s} s")


def test_guard_uses_the_resistor_current(design):
    """The paper's 3 V with the resistor (level 0.931) heats the coil 1.63x less than PWM from the bare
    bridge (level 0.573), so the guard cuts it later; the cut temperature is the same."""
    lv_r = float(volts_to_levels(design, 3.0))
    bare = seven_ohm(NO_RESISTOR)
    lv_b = float(volts_to_levels(bare, 3.0))
    t_r, g_r = _time_to_cut(design, lv_r)
    t_b, g_b = _time_to_cut(bare, lv_b)
    assert 1.3 < t_r / t_b < 2.2
    # cut at the weakest material's cut-off (the headroom), not past it
    assert g_r.headroom_K[0] > g_r.margin_K - 1.0 and g_b.headroom_K[0] > g_b.margin_K - 1.0
    # the guard's heating of one step is the thermal model at sqrt(level) x the resistor-limited current
    g = ThermalGuard(design, clock=FakeClock(), policy="cut")
    req = np.zeros(8)
    req[0] = lv_r
    g.allow(req)
    t0 = float(g.temperatures[0])
    x0 = g.node_state.copy()
    g.clock.t = 0.01
    g.advance()
    vfs = full_scale_voltage(design)
    cur = np.zeros(8)
    cur[0] = math.sqrt(lv_r) * coil_current_A(design, vfs, t0)
    expect = float(g.thermal.winding_C(g.thermal.step_state(x0, cur, 0.01))[0])
    assert expect > t0
    assert g.temperatures[0] == pytest.approx(expect, rel=1e-9)
    # level 1 (a stuck output) is allowed by the rating and still cut by the guard before the limit
    t_full, g_full = _time_to_cut(design, 1.0)
    assert t_full < t_r and g_full.peak_C[0] < g_full.model.winding_limit_C   # the resin at the winding


# ---- BOM and netlist -----------------------------------------------------------------------------

def test_bom_carries_the_resistor():
    from whisker.bom import CoilWire, bom_rows
    from whisker.part_measures import MEMBRANE_PART, PRINTED_PARTS

    vols = {name: 1000.0 * (i + 1) for i, name in enumerate((*PRINTED_PARTS, MEMBRANE_PART))}

    def items(*over):
        return {r.item: r for r in bom_rows(seven_ohm(*over), vols, CoilWire(1000.0, "test"))}

    r = items()["series_resistor"]
    assert r.value == 8 and "5.1 ohm, 2 W" in r.specification and "1.08 W" in r.notes
    assert items("whiskers.count=5")["series_resistor"].value == 5
    bare = items(NO_RESISTOR)
    assert "series_resistor" not in bare
    # the coil supply follows the lower current: 8 x 0.46 A (+ quiescent) instead of 8 x 0.75 A
    assert "at least 5 A" in items()["coil_supply"].specification
    assert "at least 7 A" in bare["coil_supply"].specification


def test_netlist_carries_the_resistor():
    from whisker.pcb import netlist

    def pins(net):
        return {(p.part.ref, str(p.num)) for p in net.pins}

    board = netlist.build_circuit(seven_ohm("whiskers.count=3"))
    report = netlist.run_erc(board)
    assert report.errors == 0 and report.warnings == 0, report.messages
    assert sorted(r for r in board.parts if r.startswith("R")) == ["R1", "R2", "R3"]
    assert pins(board.nets["COIL0_OUTA"]) == {("U1", "7"), ("R1", "1")}  # OUT1 -> R1
    assert pins(board.nets["COIL0_A"]) == {("R1", "2"), ("L1", "1")}     # R1 -> coil A
    assert "5.1R 2W" in netlist.netlist_text(board)
    bare = netlist.build_circuit(seven_ohm("whiskers.count=3", NO_RESISTOR))
    assert not any(r.startswith("R") for r in bare.parts) and "COIL0_OUTA" not in bare.nets
    assert pins(bare.nets["COIL0_A"]) == {("U1", "7"), ("L1", "1")}
    assert netlist.run_erc(bare).errors == 0


def test_pinout_shows_the_resistor():
    from whisker.pcb import pinout

    rows = pinout.pinout_rows(seven_ohm())
    assert rows[0]["coil_terminal"] == "OUT1 -> R1 (5.1 ohm) -> coil A" and rows[1]["coil_terminal"] == "OUT2 -> coil B"
    assert pinout.pinout_rows(seven_ohm(NO_RESISTOR))[0]["coil_terminal"] == "OUT1 -> coil A"


def test_coil_plan_shows_the_designs_drive(design):
    """`whisker coil` (driver.plan): the design's resistor + PWM: duty 0.931 for 3 V, coil 1.38 W, the
    resistor and bridge 1.83 W; a design without the resistor has no such plan."""
    p = driver.plan(design)
    assert p["design_series_ohm"] == 5.1 and p["coil_V_full_on_design"] == pytest.approx(3.2226, abs=1e-4)
    ps = next(x for x in p["plans"] if x["method"] == "pwm+series")
    assert "PWM duty 0.931" in ps["detail"] and "heating 1.07x" in ps["detail"]
    assert ps["coil_heat_W"] == pytest.approx(1.381, abs=2e-3) and ps["wasted_W"] == pytest.approx(1.83, abs=0.01)
    pwm = next(x for x in p["plans"] if x["method"] == "pwm")
    assert pwm["coil_heat_W"] / ps["coil_heat_W"] == pytest.approx(1.626, abs=2e-3)
    assert ps["current_cold_A"] == pytest.approx(pwm["current_cold_A"])  # same mean current = same force
    assert not any(x["method"] == "pwm+series" for x in driver.plan(seven_ohm(NO_RESISTOR))["plans"])


def test_unbuildable_resistor_refused_by_bom_and_pcb(tmp_path):
    """46 V into a 1 ohm coil would burn ~119 W in its series resistor: both tools refuse on one line."""
    from conftest import run_cli

    over = ["--set", "driver.supply_voltage=46", "--set", "coil.resistance=1"]
    for cmd in (["hw", "bom", *over, "--out", str(tmp_path / "b.csv")], ["hw", "pcb", *over, "--out", str(tmp_path / "p")]):
        r = run_cli(*cmd)
        assert r.returncode == 2, r.stderr
        assert "more than a 50 W part" in r.stderr and "Traceback" not in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


def test_auto_is_zero_when_the_bare_bridge_sits_exactly_at_the_rating():
    """3.8 ohm on a DRV8876 (no drop, 0.7 ohm) from 4.5 V gives exactly 3.8 V: the exact resistor is 0 up to
    rounding (2e-16 ohm in floating point), so no resistor, not a 1e-16 ohm 'E24 value' (found by hypothesis)."""
    br = driver.bridge("DRV8876")
    assert driver.auto_series_resistance_ohm(br, 4.5, 3.8, 3.8) == 0.0
