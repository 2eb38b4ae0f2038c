"""whisker.coil.thermal: the lumped coil model's physics, limits, duty cycle and hard inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from whisker.coil import thermal as T
from whisker.design import default_design

D = default_design()
TH = T.CoilThermal(D)


def test_limit_is_the_lowest_of_magnet_pla_enamel():
    from whisker.coil.thermal_materials import limit_C
    assert TH.limit_C == min(limit_C(D, "magnet"), limit_C(D, "mount"), limit_C(D, "enamel")) == 55.0
    from whisker.design.model import design_from_dict
    data = D.to_dict()
    data["thermal"]["pla_softening"] = 120.0       # a design file may override a material's limit
    d = design_from_dict(data)
    th = T.CoilThermal(d)
    assert th.limit_C == limit_C(D, "magnet") == 80.0 and th.limit_name == "magnet max temperature"


def test_heat_capacity_is_mostly_copper_of_the_measured_resistance():
    # the bobbin's 5.87 ohm of 0.101 mm copper is 2.73 m, 0.194 g (the paper's 7 ohm: ~3.25 m, ~0.23 g,
    # DESIGN.md section 2)
    assert 0.18 < TH.copper_mass_g < 0.21
    assert TH.copper_mass_g * 0.385 < TH.heat_capacity_J_per_K < 1.3 * TH.copper_mass_g * 0.385


def test_no_current_stays_at_ambient_and_cools_towards_it():
    assert TH.step(TH.ambient_C, 0.0, 10.0) == pytest.approx(TH.ambient_C, abs=1e-12)
    hot = TH.step(100.0, 0.0, 5.0)
    assert TH.ambient_C < hot < 100.0
    assert TH.step(100.0, 0.0, 1e5) == pytest.approx(TH.ambient_C, abs=1e-6)


def test_step_is_dt_independent():
    a = TH.step(25.0, 0.4, 3.0)
    b = 25.0
    for _ in range(300):
        b = TH.step(b, 0.4, 0.01)
    assert abs(a - b) < 0.05


def test_step_refuses_bad_inputs_and_dt_zero_is_identity():
    assert TH.step(40.0, 0.4, 0.0) == 40.0
    for args in ((float("nan"), 0.1, 1.0), (25.0, float("inf"), 1.0), (25.0, 0.1, -1.0)):
        with pytest.raises(ValueError, match="finite|dt"):
            TH.step(*args)


def test_constant_current_runaway_stays_finite():
    # 3 A is far past the current where I^2 R20 alpha exceeds the cooling: runaway, but finite
    t = TH.step(25.0, 3.0, 1e4)
    assert math.isfinite(t) and t > 1000


def test_initial_heating_rate_and_adiabatic_bound():
    v = 3.0
    p = v * v / float(TH.resistance(TH.ambient_C))
    dt = 1e-3
    rate = (TH.step_voltage(TH.ambient_C, v, dt) - TH.ambient_C) / dt
    assert abs(rate / (p / TH.heat_capacity_J_per_K) - 1) < 1e-2
    # losses and the rising resistance only slow it down: never faster than adiabatic at cold power
    t = T.time_to_limit_s(D, v)
    assert t >= TH.heat_capacity_J_per_K * (TH.limit_C - TH.ambient_C) / p


def test_time_to_limit_matches_stepping():
    v = 3.0
    t_q = TH.time_to_C(TH.limit_C, v)
    t, temp = 0.0, TH.ambient_C
    while temp < TH.limit_C:
        temp = TH.step_voltage(temp, v, 0.005)
        t += 0.005
    assert abs(t - t_q) < 0.02 * t_q


def test_safe_duty_holds_the_limit():
    v = 3.0
    d = T.safe_duty(D, v)
    assert 0 < d < 1
    assert TH.steady_state_C(v, d) == pytest.approx(TH.limit_C, abs=0.05)
    assert TH.steady_state_C(v, min(1.0, d * 1.1)) > TH.limit_C
    assert T.time_to_limit_s(D, v, duty=d * 0.99) == math.inf


def test_zero_and_tiny_voltage():
    assert T.time_to_limit_s(D, 0.0) == math.inf
    assert T.safe_duty(D, 0.0) == 1.0
    assert TH.steady_state_C(0.0) == TH.ambient_C
    assert T.safe_duty(D, 0.1) == 1.0


def test_summary_has_no_inf_and_orders_the_limits():
    s = T.summary(D, 3.0)
    tl = s["time_to_limit_s"]
    assert tl["pla"] < tl["magnet"] < tl["enamel"]
    assert s["time_to_first_limit_s"] == tl["pla"]
    s0 = T.summary(D, 0.5)
    assert s0["time_to_first_limit_s"] is None  # never: reported as None, not inf


@settings(max_examples=25, deadline=None)
@given(v=st.floats(0.5, 6.0), duty=st.floats(0.01, 1.0))
def test_property_steady_state_balances(v, duty):
    ts = TH.steady_state_C(v, duty)
    assert math.isfinite(ts) and ts > TH.ambient_C
    p = duty * v * v / float(TH.resistance(ts))
    assert abs(p - float(TH.loss_W(ts))) < 1e-9 * max(1.0, p)
    # monotonic in voltage
    assert TH.steady_state_C(v * 1.05, duty) > ts


@settings(max_examples=20, deadline=None)
@given(h=st.floats(1.0, 200.0), ambient=st.floats(-20, 40))
def test_property_safe_duty_within_0_1(h, ambient):
    d = default_design(f"thermal.convection_coefficient={h}", f"thermal.ambient={ambient}")
    s = T.safe_duty(d, 3.0)
    assert 0.0 <= s <= 1.0


def test_churchill_chu_convection():
    h = T.churchill_chu_h(4.0, np.array([25.0, 55.0, 155.0]), 25.0)
    assert np.all(np.isfinite(h)) and np.all(np.diff(h) > 0)
    # no temperature difference: the conduction limit Nu = 0.6^2
    k_air = 0.0241 * ((25.0 + T.KELVIN) / T.KELVIN) ** 0.81
    assert h[0] == pytest.approx(0.36 * k_air / 4e-3)
    assert 8 < h[1] < 20  # textbook range for a few-mm cylinder at tens of kelvin
    cc = T.CoilThermal(D, convection="churchill_chu")
    # the design's constant coefficient is Churchill-Chu at the first limit: same safe duty
    assert abs(cc.safe_duty(3.0) / TH.safe_duty(3.0) - 1) < 0.02
    assert abs(cc.time_to_C(cc.limit_C, 3.0) / TH.time_to_C(TH.limit_C, 3.0) - 1) < 0.02
    t1 = cc.step(25.0, 0.43, 5.0)
    assert TH.ambient_C < t1 < 200
    with pytest.raises(ValueError, match="convection"):
        T.CoilThermal(D, convection="forced")


def test_time_to_limit_just_above_safe_duty_matches_stepping():
    # steady state only just above the limit: the integrand nearly diverges at the top end
    duty = TH.safe_duty(3.0) * 1.1
    t_q = TH.time_to_C(TH.limit_C, 3.0, duty)
    t, temp = 0.0, TH.ambient_C
    while temp < TH.limit_C:
        temp = TH.step_voltage(temp, 3.0, 0.05, duty)
        t += 0.05
    assert math.isfinite(t_q) and abs(t - t_q) < 0.01 * t_q + 0.05
