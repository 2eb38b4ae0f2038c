"""The build-scatter study (whisker.coil.tolerance, its table whisker.coil.tolerance_table) and the end stop
(whisker.design.stop)."""

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.coil import tolerance as T
from whisker.coil import tolerance_table as TT
from whisker.design import load_design


@pytest.fixture(scope="module")
def tol():
    return TT.load_tolerances()


def test_table_names_every_factor_with_a_source(tol):
    assert set(TT.FACTORS) <= set(tol)
    for t in tol.values():
        assert t.lo <= t.hi and t.source.strip() and t.level in TT.LEVELS


@settings(max_examples=60, deadline=None)
@given(lo=st.floats(-10, 10), width=st.floats(0, 10), u=st.lists(st.floats(0, 1), min_size=1, max_size=20))
def test_unit_draws_map_into_the_range(lo, width, u):
    t = TT.Tolerance("x", "whisker", "offset", lo, lo + width, "mm", "x", "s")
    v = TT.to_values(t, np.array(u))
    assert np.all(v >= lo - 1e-9) and np.all(v <= lo + width + 1e-9)
    # monotone: a larger draw never gives a smaller value
    order = np.argsort(u, kind="stable")
    assert np.all(np.diff(v[order]) >= -1e-12)


@settings(max_examples=15, deadline=None)
@given(sensors=st.integers(1, 40), n=st.integers(1, 8), seed=st.integers(0, 1000))
def test_draws_are_in_the_unit_cube_and_shared_per_sensor(tol, sensors, n, seed):
    u = T.draws(tol, sensors, n, seed)
    for f in TT.FACTORS:
        assert u[f].shape == (sensors * n,) and np.all((u[f] >= 0) & (u[f] <= 1))
        per = u[f].reshape(sensors, n)
        if tol[f].level == "sensor":
            assert np.all(per == per[:, :1])     # one magnet bag, one mix: every whisker shares the draw


def test_nominal_draws_give_the_design(tol):
    d = load_design()
    w = T.physical(d, tol, T.nominal_draws(tol, d), 0.836)
    assert w.gap[0] == pytest.approx(d.actuation.gap)
    assert w.remanence[0] == pytest.approx(d.magnet.remanence)
    assert w.stiffness[0] == pytest.approx(0.836)
    assert w.temperature[0] == pytest.approx(20.0)


@settings(max_examples=20, deadline=None)
@given(e=st.floats(0.5, 2.0), t=st.floats(-0.5, 0.5))
def test_stiffness_scales_with_modulus_and_thickness_cubed(tol, e, t):
    d = load_design()
    u = T.nominal_draws(tol, d)
    te, tt = tol["ecoflex_modulus"], tol["membrane_thickness"]
    u = dict(u, ecoflex_modulus=np.array([(e - te.lo) / (te.hi - te.lo)]),
             membrane_thickness=np.array([(t - tt.lo) / (tt.hi - tt.lo)]))
    w = T.physical(d, tol, u, 1.0)
    t0 = d.membrane.thickness
    assert w.stiffness[0] == pytest.approx(e * ((t0 + t) / t0) ** 3, rel=1e-9)


def test_vectorised_physics_matches_the_scalar_equilibrium(tol):
    """The study's pull-in current and tilt at nominal values agree with whisker.coil.tilt."""
    from whisker.coil import current_A, equilibrium, pull_in
    d = load_design(overrides=["actuation.end_stop=false", "actuation.gap=2.5"])
    nom = T.nominal_draws(tol, d)
    k = T.nominal_stiffness(d)[0]
    amps = 0.9 * pull_in(d)[0]
    r = T.evaluate(d, tol, nom, T.Drive("current", amps=amps), k)
    assert r["pull_in_A"][0] == pytest.approx(pull_in(d)[0], rel=2e-3)
    eq = equilibrium(d, amps)
    assert math.degrees(r["tilt_rad"][0]) == pytest.approx(eq.theta_deg, abs=0.1)
    # and the voltage drive's nominal current is the coil report's
    rv = T.evaluate(d, tol, nom, T.Drive("voltage"), k)
    assert rv["current_A"][0] == pytest.approx(current_A(d, d.actuation.voltage), rel=0.01)


def test_default_design_yield_at_least_99_percent():
    """Issue 27's must-show, at a small but real sample (300 sensors x 8 whiskers)."""
    d = load_design()
    r = T.study(d, 300, T.Drive("bringup"), seed=3)
    assert r.end_stop and r.p_coil_on_magnet == 0.0
    assert r.yield_ >= 0.99
    assert r.holding["holding_torque_Nmm"] > 0


def test_without_the_stop_the_old_default_fails():
    """The study can fail: the former default (no stop, 2.5 mm, 15 deg) snaps in most builds."""
    d = load_design(overrides=["actuation.end_stop=false", "actuation.gap=2.5", "whiskers.max_deflection_deg=15"])
    r = T.study(d, 100, seed=1)
    assert r.p_coil_on_magnet > 0.2 and r.yield_ < 0.5
    assert r.pull_in_margin_nominal < 0.2


def test_sobol_ranks_the_stiffness_inputs():
    s = T.sobol(load_design(), base=32)
    names = [r["factor"] for r in s["indices"]]
    assert set(names) >= {"ecoflex_modulus", "membrane_thickness", "remanence"}
    assert all(np.isfinite(r["ST"]) for r in s["indices"])
    assert s["indices"][0]["ST"] >= s["indices"][-1]["ST"]


def test_min_above_max_is_refused_in_one_line(tmp_path):
    from whisker.resources import hw_dir
    bad = tmp_path / "tol.csv"
    text = (hw_dir() / "tolerances.csv").read_text().replace("remanence,sensor,absolute,1.17,1.47",
                                                             "remanence,sensor,absolute,1.47,1.17")
    bad.write_text(text)
    with pytest.raises(TT.ToleranceError, match=r"remanence.*min 1.47 > max 1.17") as err:
        TT.load_tolerances(bad)
    assert "\n" not in str(err.value)


def test_cli_refuses_min_above_max_and_leaves_outputs(tmp_path):
    from whisker.resources import hw_dir
    bad = tmp_path / "tol.csv"
    bad.write_text((hw_dir() / "tolerances.csv").read_text().replace("turns,whisker,factor,0.97,1.03",
                                                                     "turns,whisker,factor,1.03,0.97"))
    out = tmp_path / "out"
    out.mkdir()
    (out / "tolerance.json").write_text("old")
    exe = shutil.which("whisker", path=str(__import__("pathlib").Path(sys.executable).parent))
    p = subprocess.run([exe, "coil", "tolerance", "--tolerances", str(bad), "--sensors", "10", "--out", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 2
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "min 1.03 > max 0.97" in lines[0]
    assert (out / "tolerance.json").read_text() == "old"


def test_stop_geometry_and_refusal():
    from whisker.design.stop import end_stop
    from whisker.design.validation import DesignError
    d = load_design()
    s = end_stop(d)
    assert s.post_length_mm > 0 and s.rim_clearance_mm > 0
    assert s.gap_mm == pytest.approx(d.actuation.gap - (d.pivot_z - d.coil_axis_z) * math.sin(math.radians(11)))
    with pytest.raises(DesignError, match="flange meets the magnet"):
        end_stop(load_design(overrides=["actuation.gap=1.5"]))


def test_tilt_clamps_at_the_stop_with_a_holding_torque():
    from whisker.coil import current_A, equilibrium
    from whisker.coil.tilt import holding_at_stop, stop_reach_current_A
    d = load_design()
    i_reach = stop_reach_current_A(d)
    below, above = equilibrium(d, 0.95 * i_reach), equilibrium(d, 1.2 * i_reach)
    assert below.stable and not below.at_stop and below.theta_deg < d.whiskers.max_deflection_deg
    assert above.stable and above.at_stop and above.theta_deg == pytest.approx(d.whiskers.max_deflection_deg)
    h = holding_at_stop(d, current_A(d, 3.0))
    assert h["holding_torque_Nmm"] == pytest.approx(equilibrium(d, current_A(d, 3.0)).holding_torque_Nmm, rel=1e-6)
    assert h["post_force_mN"] > h["tip_force_mN"] > 0


def test_coil_report_shows_margin_holding_and_yield():
    from whisker.coil.report import build_report, format_report
    rep = build_report(load_design())
    b = rep["build"]
    assert b["end_stop"] and b["holding"]["post_force_mN"] > 0 and b["pull_in_margin"] is not None
    assert b["drives"]["bringup"]["yield"] >= 0.99 and b["drives"]["voltage"]["p_coil_on_magnet"] == 0.0
    text = format_report(rep)
    assert "MARGIN AND BUILD YIELD" in text and "margin to pull-in in coil current" in text
    assert f"{b['sensors']} built sensors" in text
