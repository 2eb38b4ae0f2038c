"""The thermal guard: a coil held on is limited and cut before its limit; ratings are refused."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from test_actuation_doubles import DoubleThermal, FakeClock, coil_model, double_current_A
from whisker.drive.actuation import Actuator
from whisker.drive.hbridge import mock_backend
from whisker.design import default_design
from whisker.drive.guard import (RatingError, ThermalGuard, check_driver, check_levels, full_scale_voltage,
                           max_level, volts_to_levels)


NO_RESISTOR = "driver.series_resistance=0"  # the bare bridge: the numbers before the series resistor


@pytest.fixture(scope="module")
def design():
    return default_design()


def hold(guard, clock, levels, seconds, dt=0.02, rooms=None):
    """Request `levels` every dt for `seconds`; return times, temperatures and allowed levels (and
    each coil's headroom below its weakest material, K, appended to `rooms` if given)."""
    ts, temps, allowed = [], [], []
    for _ in range(int(round(seconds / dt))):
        a = guard.allow(levels, clock.advance(dt))
        ts.append(clock.t)
        temps.append(guard.temperatures.copy())
        allowed.append(a)
        if rooms is not None:
            rooms.append(guard.headroom_K.copy())
    return np.array(ts), np.array(temps), np.array(allowed)


def test_cut_before_limit_then_hysteresis(design):
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, policy="cut")
    levels = np.zeros(8)
    levels[2] = 1.0  # coil 2 held at full level, the others off
    rooms = []
    ts, temps, allowed = hold(g, clock, levels, 120.0, rooms=rooms)
    room = np.array(rooms)[:, 2]
    on = allowed[:, 2] > 0
    first_cut = int(np.argmin(on))
    assert on[0] and not on[first_cut], "the coil was never cut"
    # cut just before the weakest material's cut-off (one update ahead), never past it, not before needed
    assert room.min() >= g.margin_K - 1e-9
    assert g.margin_K < room[first_cut] < g.margin_K + 1.0
    # off until it has cooled by the hysteresis, then allowed again (duty cycling)
    resume = first_cut + int(np.argmax(on[first_cut:]))
    assert resume > first_cut and room[resume] > g.margin_K + g.hysteresis_K >= room[resume - 1]
    assert g.trips[2] >= 2 and np.all(g.trips[[0, 1, 3, 4, 5, 6, 7]] == 0)
    # untouched coils only see the shared cavity air warm a little
    assert np.all(temps[:, [0, 1, 3, 4, 5, 6, 7]] < g.ambient_C + 3.0)
    assert temps[:, 2].max() > g.ambient_C + 20.0


def test_cut_time_matches_the_model(design):
    """The guard's estimate is the coil model's: the cut comes when the model reaches the cut-off."""
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, policy="cut")
    rooms = []
    ts, temps, allowed = hold(g, clock, np.full(8, 1.0), 60.0, dt=0.01, rooms=rooms)
    t_cut = ts[int(np.argmin(allowed[:, 0] > 0))]
    # reference: the thermal network stepped directly with the full-duty current
    t, x, vfs = 0.0, thermal.initial_state(), full_scale_voltage(design)
    while thermal.headroom(x)[0][0] > g.margin_K:
        x = thermal.step_state(x, current(design, vfs, thermal.winding_C(x)), 0.001)
        t += 0.001
    # the guard cuts one guard period (0.02 s) ahead of the model's crossing, within one 0.01 s update
    assert t_cut == pytest.approx(t - design.drive.guard_period, abs=0.02)
    assert np.array(rooms).min() >= g.margin_K - 1e-9


def test_derate_keeps_coil_below_cut(design):
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, policy="derate")
    rooms = []
    ts, temps, allowed = hold(g, clock, np.full(8, 1.0), 200.0, dt=0.1, rooms=rooms)
    room = np.array(rooms)
    assert room.min() > g.margin_K
    assert np.all(g.trips == 0)
    # full level while cool, reduced once inside the band, steady and positive at the end
    assert np.all(allowed[0] == 1.0)
    assert 0 < allowed[-1, 0] < 1.0
    assert room[-1, 0] < g.margin_K + g.band_K
    assert abs(temps[-1, 0] - temps[-50, 0]) < 0.5


def test_watchdog_cuts_a_coil_left_on(design):
    """Real time, no caller ticks: the watchdog thread alone cuts a fast-heating coil."""
    thermal = DoubleThermal(design, speedup=3.0)  # ~44 K/s: reaches the cut-off in ~0.6 s
    guard = ThermalGuard(design, thermal=thermal, current_fn=double_current_A, policy="cut")
    be = mock_backend(design)
    with Actuator(design, be, guard=guard, current_fn=double_current_A) as act:
        act.retract(level=1.0 if max_level(design) >= 1 else max_level(design), which="opposite")
        assert be.factory.pin(be.channels[0].forward).state > 0
        deadline = time.monotonic() + 10.0
        while guard.trips[0] == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert guard.trips[0] >= 1 and guard.trips[4] >= 1
        time.sleep(0.05)
        # tripped coils stay off (cooling to the resume temperature takes seconds here)
        assert guard.tripped[0] and guard.tripped[4]
        assert be.factory.pin(be.channels[0].forward).state == 0
        assert be.factory.pin(be.channels[4].forward).state == 0
        assert act.requested[0] > 0  # still requested: the guard, not the caller, switched it off
        assert guard.peak_C.max() < guard.limit_C


def test_large_clock_jump_stays_finite(design):
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, policy="cut")
    g.allow(np.full(8, 0.5), clock())
    g.allow(np.full(8, 0.5), clock.advance(1000.0))
    assert np.all(np.isfinite(g.temperatures))
    with pytest.raises(ValueError, match="backwards"):
        g.allow(np.zeros(8), clock.advance(-1.0))


def test_broken_model_is_not_silent(design):
    class NaNThermal(DoubleThermal):
        def step(self, temperature_C, current_A, dt_s):
            return float("nan") if current_A > 0 else temperature_C

    clock = FakeClock()
    g = ThermalGuard(design, thermal=NaNThermal(design), current_fn=double_current_A, clock=clock)
    g.allow(np.full(8, 0.5), clock())
    with pytest.raises(FloatingPointError, match="coil 0"):
        g.allow(np.full(8, 0.5), clock.advance(0.1))
    # an actuator whose guard fails switches the coils off
    clock2 = FakeClock()
    g2 = ThermalGuard(design, thermal=NaNThermal(design), current_fn=double_current_A, clock=clock2)
    be = mock_backend(design)
    act = Actuator(design, be, guard=g2, watchdog=False, clock=clock2, current_fn=double_current_A)
    act.retract(level=0.5)
    clock2.advance(0.1)
    with pytest.raises(FloatingPointError):
        act.tick()
    assert all(p.state == 0 for p in be.factory.pins.values())
    with pytest.raises(RuntimeError, match="thermal guard failed"):
        act.retract(level=0.5)  # no more commands once the guard has failed
    assert all(p.state == 0 for p in be.factory.pins.values())
    act.close()


def test_derating_does_not_flood_the_log(design):
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock)
    rows = []
    act = Actuator(design, mock_backend(design), guard=g, watchdog=False, clock=clock,
                   log=lambda t, p, r, a: rows.append(a.copy()))
    act.retract(level=max_level(design))  # the largest level the coil rating allows
    for _ in range(3000):  # 60 s of 20 ms guard updates, deep in the derate band
        clock.advance(0.02)
        act.tick()
    assert g.headroom_K.min() < g.margin_K + g.band_K
    assert 10 < len(rows) < 300  # derating steps are logged at 0.01 resolution, not every update
    assert np.all(np.abs(np.diff(np.array(rows)[1:, 0])) >= Actuator.LOG_RESOLUTION - 1e-12)
    act.close()


def test_guard_parameters_refused(design):
    with pytest.raises(ValueError, match="policy"):
        ThermalGuard(design, thermal=coil_model(design)[0], current_fn=coil_model(design)[1], policy="pray")
    hot = default_design("drive.guard_margin=40")
    with pytest.raises(ValueError, match="not above ambient"):
        ThermalGuard(hot, thermal=coil_model(hot)[0], current_fn=coil_model(hot)[1])
    with pytest.raises(ValueError, match="finite"):
        ThermalGuard(design, thermal=coil_model(design)[0], current_fn=coil_model(design)[1],
                     initial_C=float("nan"))
    g = ThermalGuard(design, thermal=coil_model(design)[0], current_fn=coil_model(design)[1])
    with pytest.raises(ValueError, match="8 finite"):
        g.allow([0.1] * 7)


def test_starting_hot_is_cut_immediately(design):
    g = ThermalGuard(design, thermal=coil_model(design)[0], current_fn=coil_model(design)[1],
                     clock=FakeClock(), initial_C=70.0)
    assert np.all(g.allow(np.full(8, 0.5)) == 0)


def test_state_file_carries_heat_to_the_next_run(design, tmp_path):
    state = tmp_path / "coils.json"
    clock = FakeClock()
    thermal, current = coil_model(design)
    g = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, state_file=state, policy="cut")
    hold(g, clock, np.full(8, 1.0), 3.0)
    hot = g.temperatures.copy()
    assert hot.min() > g.ambient_C + 5
    g.save_state()
    data = json.loads(state.read_text())
    assert np.allclose(data["temperatures_C"], hot)
    g2 = ThermalGuard(design, thermal=thermal, current_fn=current, state_file=state)
    assert np.all(g2.temperatures > g.ambient_C + 1) and np.all(g2.temperatures <= hot + 1e-9)
    # an hour later: ambient
    data["wall_time_s"] -= 7200
    state.write_text(json.dumps(data))
    g3 = ThermalGuard(design, thermal=thermal, current_fn=current, state_file=state)
    assert np.allclose(g3.temperatures, g.ambient_C)
    state.write_text("{broken")
    with pytest.raises(ValueError, match="unreadable coil state"):
        ThermalGuard(design, thermal=thermal, current_fn=current, state_file=state)


# ---- ratings ----------------------------------------------------------------------------------

def test_level_above_rating_refused():
    d = default_design("drive.full_scale_voltage=6.0", "drive.max_coil_voltage=3.0")
    assert max_level(d) == pytest.approx(0.5)
    check_levels(d, np.full(8, 0.5))
    with pytest.raises(RatingError, match="whisker 5.*3.06 V at the coil"):
        check_levels(d, [0, 0, 0, 0, 0, -0.51, 0, 0])
    with pytest.raises(RatingError, match="above the coil rating"):
        volts_to_levels(d, np.full(8, 3.01))
    assert volts_to_levels(d, np.full(8, -3.0)) == pytest.approx(np.full(8, -0.5))


def test_volts_beyond_full_scale_refused(design):
    d = default_design("drive.max_coil_voltage=10")
    with pytest.raises(RatingError, match="100 % duty"):
        volts_to_levels(d, np.full(8, full_scale_voltage(d) + 0.1))
    with pytest.raises(ValueError, match="finite"):
        volts_to_levels(design, [np.nan] * 8)


def test_driver_check(design):
    assert check_driver(design) == pytest.approx(
        full_scale_voltage(design) / design.coil.resistance)
    with pytest.raises(RatingError, match="L298N.s 2 A per channel"):
        check_driver(default_design("coil.resistance=1.5", "driver.supply_voltage=12"))


@settings(max_examples=40, deadline=None)
@given(levels=st.lists(st.floats(-1, 1, allow_nan=False), min_size=8, max_size=8),
       temp=st.floats(0, 200))
def test_allowed_never_exceeds_request(levels, temp):
    d = default_design()
    thermal, current = coil_model(d)
    g = ThermalGuard(d, thermal=thermal, current_fn=current, clock=FakeClock(), initial_C=temp)
    req = np.array(levels)
    a = g.allow(req)
    assert np.all(np.abs(a) <= np.abs(req) + 1e-15)
    assert np.all(a * req >= 0)  # never reverses a coil
    if temp >= g.cut_C:
        assert np.all(a == 0)


def test_full_scale_voltage_from_driver_model_or_measured():
    from whisker.coil import driver

    design = default_design(NO_RESISTOR)  # the bare bridge (tests/test_series_resistor.py: with one)
    br = driver.bridge(design.driver.type)
    i = driver.coil_current_A(br, design.driver.supply_voltage, design.coil.resistance)
    assert full_scale_voltage(design) == pytest.approx(i * design.coil.resistance)
    # 7.5 V minus a bipolar bridge's ~2.3 V at 0.75 A: above the 3.3 V coil rating at level 1
    assert 4.9 < full_scale_voltage(design) < 5.5
    assert full_scale_voltage(default_design("drive.full_scale_voltage=3.2")) == 3.2
    with pytest.raises(RatingError, match="below the L298N's drop"):
        full_scale_voltage(default_design("driver.supply_voltage=1.0", NO_RESISTOR))


# ---- the default supply (driver.supply_voltage = 7.5 V) ------------------------------------------

def test_default_supply_limits_level_and_reaches_the_papers_3V():
    """Without the series resistor (driver.series_resistance = 0): 7.5 V into an L298N: 5.24 V at the coil at level 1, so level 1 is refused, the paper's 3 V is a
    level below 1 and the rating's 3.3 V is the largest level (whisker.coil.driver typ drop 1.40 V +
    1.15 ohm x I: I = (7.5 - 1.40) / (7 + 1.15) = 0.748 A, 0.748 A x 7 ohm = 5.24 V)."""
    design = default_design("coil.resistance=7.0", NO_RESISTOR)  # the paper's measured coil
    vfs = full_scale_voltage(design)
    assert vfs == pytest.approx((7.5 - 1.40) / (7.0 + 1.15) * 7.0, rel=1e-9)
    assert vfs > design.drive.max_coil_voltage
    top = max_level(design)
    assert top == pytest.approx(design.drive.max_coil_voltage / vfs) and 0.62 < top < 0.64
    level_3v = float(volts_to_levels(design, design.actuation.voltage))
    assert design.actuation.voltage == 3.0 and level_3v == pytest.approx(3.0 / vfs) and 0.57 < level_3v < top
    check_levels(design, np.full(8, top))
    check_levels(design, np.full(8, level_3v))
    with pytest.raises(RatingError, match="whisker 0 means 5.24 V at the coil.*largest level 0.63"):
        check_levels(design, np.full(8, 1.0))
    with pytest.raises(RatingError, match="whisker 0 means"):
        check_levels(design, np.full(8, top + 1e-6))
    # the old 5 V default reached 3 V only near full duty (level 0.97)
    assert float(volts_to_levels(default_design("coil.resistance=7.0", "driver.supply_voltage=5", NO_RESISTOR), 3.0)) \
        == pytest.approx(0.970, abs=1e-3)


@settings(max_examples=40, deadline=None)
@given(vs=st.floats(4.0, 24.0), volts=st.floats(-3.3, 3.3))
def test_volts_to_levels_round_trips_at_any_supply(vs, volts):
    """level = volts / V_fs with V_fs = R (Vs - V0) / (R + r) from the L298N model; within the rating
    and the full scale the round trip is exact, above either it is refused, never clipped."""
    d = default_design("coil.resistance=7.0", f"driver.supply_voltage={vs!r}", NO_RESISTOR)
    vfs = full_scale_voltage(d)
    assert vfs == pytest.approx(7.0 * (vs - 1.40) / (7.0 + 1.15), rel=1e-9)
    assert max_level(d) == pytest.approx(min(1.0, 3.3 / vfs))
    if abs(volts) <= vfs:
        lv = float(volts_to_levels(d, volts))
        assert lv * vfs == pytest.approx(volts, abs=1e-12)
        assert abs(lv) <= max_level(d) + 1e-12
        check_levels(d, np.full(8, lv))
    else:
        with pytest.raises(RatingError, match="100 % duty"):
            volts_to_levels(d, volts)


@settings(max_examples=8, deadline=None)
@given(vs=st.floats(5.0, 12.0), frac=st.floats(0.3, 1.0))
def test_derate_settles_without_trips_at_any_supply(vs, frac):
    """At a higher supply one guard period of the full request heats a coil more; the trip look-ahead
    uses the derated level, so a coil held at any allowed level still settles inside the band."""
    d = default_design(f"driver.supply_voltage={vs!r}")
    clock = FakeClock()
    thermal, current = coil_model(d)
    g = ThermalGuard(d, thermal=thermal, current_fn=current, clock=clock, policy="derate")
    lv = frac * max_level(d)
    rooms = []
    ts, temps, allowed = hold(g, clock, np.full(8, lv), 150.0, dt=0.1, rooms=rooms)
    room = np.array(rooms)
    assert room.min() > g.margin_K
    assert np.all(g.trips == 0)
    assert 0 < allowed[-1, 0] < lv and room[-1, 0] < g.margin_K + g.band_K
