"""The simulator's airflow effect (whisker.sim.effects.airflow): built only when asked, drag physics, OU statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ROOT, run_cli
from whisker.design import load_design
from whisker.sim import load_scene, plan, simulate
from whisker.sim.effects.airflow import AirflowDrag, AirflowSpec, lever_m2, mean_torque_Nm

SCENE = ROOT / "software/whisker/sim/scenes/airflow.toml"


@pytest.fixture(scope="module")
def design():
    return load_design()


def test_explain_names_the_airflow_effect_only_when_asked():
    res = run_cli("sim", str(SCENE), "--explain")
    assert res.returncode == 0, res.stderr
    assert "built   airflow     flow 8 m/s from 0.5 s to 2.5 s" in res.stdout
    assert "free:" in res.stdout                      # time stepping, not the static solve
    other = run_cli("sim", str(ROOT / "software/whisker/sim/scenes/step_response.toml"), "--explain")
    assert "skipped airflow     no airflow in the scene" in other.stdout
    bad = run_cli("sim", str(SCENE), "--explain", "--scene-set", "airflow.coherence=2")
    assert bad.returncode == 2 and "airflow.coherence" in bad.stderr


def test_airflow_moves_the_whiskers_only_while_it_blows(design):
    scene = load_scene(SCENE)
    res = simulate(scene, design, record_hz=200)
    th = np.degrees(np.hypot(res.theta_rad[..., 0], res.theta_rad[..., 1]))    # (T, n)
    before = th[res.t_s < 0.5]
    during = th[(res.t_s > 1.0) & (res.t_s < 2.5)]
    after = th[res.t_s > 2.9]
    assert np.max(before) < 1e-6 and np.max(after) < 0.2
    assert 1.0 < np.mean(during) < 15.0 and np.std(during) > 0.3      # deflected and fluctuating
    # without the flow the same scene solves statically at rest
    still = scene.model_copy(update={"airflow": AirflowSpec()})
    assert plan(still, design).solver == "static"


@settings(max_examples=25, deadline=None)
@given(u=st.floats(0.5, 40), cd=st.floats(0.5, 2.0))
def test_mean_drag_torque_is_the_textbook_formula(u, cd):
    design = load_design()
    spec = AirflowSpec(speed_m_s=u, drag_coefficient=cd, turbulence=0.0)
    d = design.whiskers.rod_diameter * 1e-3
    L, a = design.l_u * 1e-3, design.membrane.thickness / 2e3
    expect = 0.5 * 1.2 * cd * d * u * u * (L * L - a * a) / 2
    assert mean_torque_Nm(design, spec) == pytest.approx(expect, rel=1e-12)
    tau = AirflowDrag(design, spec).torque()
    assert np.allclose(np.hypot(tau[:, 0], tau[:, 1]), expect, rtol=1e-12)
    assert lever_m2(design) > 0


def test_flow_along_a_whisker_pushes_its_tip_outward(design):
    ang = design.whisker_angles_deg[0]
    tau = AirflowDrag(design, AirflowSpec(speed_m_s=5, turbulence=0, direction_deg=ang)).torque()
    # flow along +r of whisker 0: the tip goes to +r, which is a negative radial tilt, no tangential
    assert tau[0, 0] < 0 and abs(tau[0, 1]) < 1e-12 * abs(tau[0, 0])


@pytest.mark.parametrize("dt", [1e-4, 5e-3])
def test_fluctuation_statistics_do_not_depend_on_the_step(design, dt):
    spec = AirflowSpec(speed_m_s=10, turbulence=0.2, integral_time_s=0.02, coherence=0.0)
    wind = AirflowDrag(design, spec, seed=3)
    speeds = []
    for _ in range(int(20.0 / dt)):
        speeds.append(wind.speeds())
        wind.step(dt)
    s = np.array(speeds)
    assert np.mean(s) == pytest.approx(10.0, abs=0.15)
    assert np.std(s) == pytest.approx(2.0, rel=0.1)
    lag = int(round(0.02 / dt))                       # autocorrelation at one integral time = 1/e
    x = s[:, 0] - s[:, 0].mean()
    r = np.dot(x[:-lag], x[lag:]) / np.dot(x, x)
    assert r == pytest.approx(math.exp(-1), abs=0.1)
