"""Whisker kinematics, magnetics torque, static equilibrium and the hard cases (issue 8, step b)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import _sim_doubles

_sim_doubles.install()

from whisker.design import default_design  # noqa: E402
from whisker.sim import SceneError, actuation_backend, scene_from_dict, simulate  # noqa: E402
from whisker.sim.contract import current_A  # noqa: E402
from whisker.coil.kinematics import (energy_J, marker_positions_mm, static_equilibrium,  # noqa: E402
                                    step_free, tip_positions_mm, whisker_body)

D = default_design()
B = whisker_body(D)


def test_body_numbers_are_physical():
    # rod: 1.55 g/cm^3 x pi 0.5^2 x 69 mm^3 = 0.084 g
    assert B.rod_mass_kg == pytest.approx(1.55e-3 * math.pi * 0.25 * 69 * 1e-3, rel=1e-9)
    assert 0 < B.inertia_kgm2 < B.mass_kg * B.tip_m ** 2
    assert B.lever_m == pytest.approx((D.pivot_z - D.coil_axis_z) * 1e-3)
    assert 0 < B.stop_rad <= math.radians(D.whiskers.max_deflection_deg) + 1e-12


def test_tip_and_marker_geometry_at_rest_and_tilted():
    th = np.zeros((D.whiskers.count, 2))
    tips = tip_positions_mm(D, th)
    r = np.hypot(tips[:, 0], tips[:, 1])
    np.testing.assert_allclose(r, D.whiskers.ring_radius)
    np.testing.assert_allclose(tips[:, 2], D.pivot_z + D.l_u)
    th[:, 0] = math.radians(10)                          # retraction: tips inward, markers outward
    t2, m2 = tip_positions_mm(D, th), marker_positions_mm(D, th)
    assert np.all(np.hypot(t2[:, 0], t2[:, 1]) < D.whiskers.ring_radius)
    assert np.all(np.hypot(m2[:, 0], m2[:, 1]) > D.whiskers.ring_radius)
    # the paper's relation: tip displacement = -(l_u/l_l) x marker displacement
    m0 = marker_positions_mm(D, np.zeros_like(th))
    t0 = tip_positions_mm(D, np.zeros_like(th))
    np.testing.assert_allclose((t2 - t0)[:, :2], -(D.l_u / D.l_l) * (m2 - m0)[:, :2], atol=1e-9)


def test_static_equilibrium_balances_torque_and_grows_with_current():
    I = current_A(D, np.linspace(-3, 3, 25))
    eq = static_equilibrium(D, B, I, facing="up")
    inside = ~eq.at_stop
    assert np.all(np.abs(eq.residual_Nm[inside]) < 1e-9 * B.stiffness)
    assert np.all(np.diff(eq.theta_rad) >= -1e-12)       # monotone in current
    assert eq.theta_rad[12] == 0.0                        # no current, no tilt
    assert np.all(np.abs(eq.theta_rad) <= B.stop_rad + 1e-12)


@settings(max_examples=30, deadline=None)
@given(volts=st.floats(-12, 12), k=st.floats(0.05, 20.0), facing=st.sampled_from(["up", "down"]))
def test_static_equilibrium_finite_for_any_drive_and_stiffness(volts, k, facing):
    d = default_design(f"mechanics.rotational_stiffness={k}")
    b = whisker_body(d)
    eq = static_equilibrium(d, b, current_A(d, np.array([volts])), facing=facing)
    assert np.all(np.isfinite(eq.theta_rad)) and abs(eq.theta_rad[0]) <= b.stop_rad + 1e-12
    if not eq.at_stop[0]:
        assert abs(eq.residual_Nm[0]) < 1e-8


def test_static_solve_equals_settled_time_stepping():
    """A constant drive: the static solve (pruned time) equals the dynamic run once it settles."""
    base = {"actuation": {"schedule": [{"t": 0.0, "level": 1.0}]}, "sensor": {"facing": "down"},
            "fidelity": {"heating": "off"}}
    s_static = scene_from_dict({**base, "scene": {"duration": 0.0}})
    s_dyn = scene_from_dict({**base, "scene": {"duration": 2.0, "timestep": 1e-3}, "fidelity": {"solver": "dynamic", "heating": "off"}})
    d = default_design("drive.full_scale_voltage=0.8")               # level 1 = 0.8 V at the coil
    a = simulate(s_static, d)
    b = simulate(s_dyn, d)
    assert a.plan.solver == "static" and b.plan.solver == "free"
    assert a.theta_deg[0, 0, 0] > 1.0
    np.testing.assert_allclose(b.theta_deg[-1, :, 0], a.theta_deg[0, :, 0], atol=2e-3)


@pytest.mark.parametrize("dt", [1e-4, 5e-3, 0.05])
def test_implicit_integrator_stable_at_any_step_energy_bounded(dt):
    s = scene_from_dict({"scene": {"duration": 1.0, "timestep": dt, "initial_tilt_deg": 10.0},
                         "sensor": {"facing": "down"}})
    r = simulate(s, D)
    assert np.all(np.isfinite(r.theta_rad))
    assert r.energy_J.max() <= r.energy_J[0] * (1 + 1e-9)   # no input: energy only decays


def test_explicit_integrator_refuses_unstable_step():
    s = scene_from_dict({"scene": {"duration": 0.5, "timestep": 0.04, "initial_tilt_deg": 5.0},
                         "fidelity": {"integrator": "euler"}})
    with pytest.raises(SceneError, match="stability limit"):
        simulate(s, D)


def test_zero_damping_conserves_energy_roughly_with_small_step():
    d = default_design("mechanics.damping_ratio=0")
    b = whisker_body(d)
    th = np.full((1, 2), 0.1)
    om = np.zeros((1, 2))
    e0 = energy_J(b, th, om).sum()
    for _ in range(2000):
        th, om = step_free(b, th, om, np.zeros((1, 2)), 1e-4, "euler")
    assert abs(energy_J(b, th, om).sum() - e0) < 0.02 * e0


def test_strong_drive_rests_on_stop_without_nan():
    s = scene_from_dict({"scene": {"duration": 0.3, "timestep": 1e-3},
                         "actuation": {"schedule": [{"t": 0.05, "level": 1.0}]},
                         "fidelity": {"heating": "off"}})
    r = simulate(s, default_design("drive.full_scale_voltage=24", "drive.max_coil_voltage=24"))
    assert np.all(np.isfinite(r.theta_rad))
    np.testing.assert_allclose(r.theta_rad[-1, :, 0], B.stop_rad)


def test_backend_follows_levels_and_refuses_bad_input():
    now = [0.0]
    be = actuation_backend(D, clock=lambda: now[0])
    be.set_levels(np.full(D.whiskers.count, 0.3))
    now[0] = 1.5
    a = be.angles_deg()
    assert np.all(a > 0.5) and np.ptp(a) < 1e-9
    be.off()
    now[0] = 4.0
    assert np.all(np.abs(be.angles_deg()) < 0.05)
    with pytest.raises(ValueError, match="shape"):
        be.set_levels(np.zeros(3))
    with pytest.raises(ValueError, match=r"\[-1, 1\]"):
        be.set_levels(np.full(D.whiskers.count, 1.5))
    with pytest.raises(ValueError, match="finite"):
        be.set_levels(np.full(D.whiskers.count, np.nan))


def test_open_backend_sim_from_actuation_module():
    act = pytest.importorskip("whisker.drive.hbridge", reason="whisker.drive.hbridge (issue 7) not installed")
    be = act.open_backend("sim", D)
    be.set_levels(np.zeros(D.whiskers.count))
    be.off()


def test_whisker_actuate_cli_drives_the_simulator():
    pytest.importorskip("whisker.commands.sensor.actuate", reason="whisker actuate (issue 7) not installed")
    from conftest import run_cli

    res = run_cli("actuate", "retract", "--backend", "sim", "--duration", "0.2")
    assert res.returncode == 0, res.stderr


def test_heating_effect_warms_the_coil_and_weakens_the_pull():
    base = {"scene": {"duration": 6.0, "timestep": 5e-3}, "sensor": {"facing": "down"},
            "actuation": {"schedule": [{"t": 0.0, "level": 1.0}, {"t": 0.01, "level": 1.0}]}}
    d = default_design("drive.full_scale_voltage=1.0")               # level 1 = 1 V at the coil (short of the end stop)
    hot = simulate(scene_from_dict({**base, "fidelity": {"heating": "auto"}}), d)
    cold = simulate(scene_from_dict({**base, "fidelity": {"heating": "off"}}), d)
    assert hot.plan.built("heating") and not cold.plan.built("heating")
    assert hot.temperature_C[-1].min() - hot.temperature_C[0].max() > 5.0      # K
    assert hot.theta_deg[-1, 0, 0] < cold.theta_deg[-1, 0, 0] - 0.05            # hotter coil, less current


def test_pwm_heating_follows_the_rms_current_like_the_guard():
    """A coil held at duty d heats with I_rms = sqrt(d) x V_fs / R (whisker.drive.guard's definition), not
    with the mean current d x V_fs / R that sets the force: the sim and the guard agree on the rise."""
    from whisker.drive.guard import full_scale_voltage
    from whisker.sim.contract import coil_thermal, pwm_rms_current_A

    d = D
    level, t_end = 0.5, 1.0
    s = scene_from_dict({"scene": {"duration": t_end, "timestep": 1e-3}, "sensor": {"facing": "down"},
                         "actuation": {"schedule": [{"t": 0.0, "level": level}, {"t": 0.01, "level": level}]},
                         "fidelity": {"heating": "on"}})
    r = simulate(s, d)
    th = coil_thermal(d)
    T = float(th.ambient_C)
    h = s.fidelity.heating_interval
    for _ in range(int(round(t_end / h))):
        i_peak = float(current_A(d, full_scale_voltage(d), T))
        T = th.step(T, math.sqrt(level) * i_peak, h)
    assert r.temperature_C[-1, 0] == pytest.approx(T, abs=0.05 * (T - th.ambient_C))
    # mean-current heating would be d times smaller in power: clearly below
    assert pwm_rms_current_A(np.array([0.2]), np.array([0.25]))[0] == pytest.approx(0.4)
    assert pwm_rms_current_A(np.array([0.0, 0.3]), np.array([0.0, 1.0])).tolist() == [0.0, 0.3]
