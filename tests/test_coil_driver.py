"""whisker.coil.driver and the `whisker coil` CLI."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given, settings, strategies as st

from whisker.coil import driver as DR
from whisker.design import default_design

from conftest import run_cli

D = default_design()


def test_l298_drop_reproduces_the_datasheet_points():
    br = DR.bridge("L298N")
    assert br.drop_V(1.0) == pytest.approx(1.35 + 1.20)   # V_CEsat(H) + V_CEsat(L) typ at 1 A
    assert br.drop_V(2.0) == pytest.approx(2.0 + 1.7)     # ... at 2 A
    assert br.drop_V(1.0, "max") == pytest.approx(1.7 + 1.6)
    assert 1.4 < br.drop_V(0.43) < 2.0                    # does not vanish at low current
    assert br.drop_V(0.0) == 0.0
    assert DR.bridge("DRV8833").drop_V(0.43) < 0.2
    with pytest.raises(DR.DriverError, match="unknown driver"):
        DR.bridge("LM358")


def test_supply_for_coil_voltage_round_trip():
    for name in DR.BRIDGES:
        br = DR.bridge(name)
        vs = DR.supply_for_coil_voltage(br, 3.0, 7.0)
        assert DR.coil_current_A(br, vs, 7.0) * 7.0 == pytest.approx(3.0)


def test_preferred_series():
    assert len(set(DR.E96)) == 96 and DR.E96[0] == 1.0 and DR.E96[-1] == 9.76
    assert DR.nearest_preferred(4.44, "E24", "up") == pytest.approx(4.7)
    assert DR.nearest_preferred(4.44, "E24", "down") == pytest.approx(4.3)
    assert DR.nearest_preferred(16.6, "E96") == pytest.approx(16.5)
    with pytest.raises(DR.DriverError, match="positive"):
        DR.nearest_preferred(0.0)


@settings(max_examples=50, deadline=None)
@given(v=st.floats(1e-3, 1e7), series=st.sampled_from(["E24", "E96"]))
def test_property_preferred_value_close(v, series):
    up = DR.nearest_preferred(v, series, "up")
    near = DR.nearest_preferred(v, series)
    step = 1.5 / 1.3 if series == "E24" else 10 ** (1 / 96) * 1.01  # E24: 1.3 -> 1.5 is the widest step
    assert v * (1 - 1e-12) <= up <= v * step * 1.01
    assert abs(math.log(near / v)) <= math.log(step) / 2 + 1e-9


def test_plan_at_5V_and_12V():
    p5 = DR.plan(D, supply_V=5.0)
    assert p5["coil_V_full_on"] < 3.2 and p5["supply_for_direct_V"] > 4.5
    assert all(p["method"] != "divider" or p["warning"] == "infeasible" for p in p5["plans"])
    p12 = DR.plan(D, supply_V=12.0)
    div = [p for p in p12["plans"] if p["method"] == "divider" and p["warning"] != "infeasible"]
    assert div and any("does not regulate" in p["warning"] for p in div)
    ser = next(p for p in p12["plans"] if p["method"] == "series")
    direct = next(p for p in p12["plans"] if p["method"] == "direct")
    # a series resistor from a higher supply holds the current (force) better than direct drive
    assert abs(ser["force_change_hot_pct"]) < abs(direct["force_change_hot_pct"])
    pwm = next(p for p in p12["plans"] if p["method"] == "pwm")
    assert pwm["current_cold_A"] == pytest.approx(3.0 / D.coil.resistance)
    assert pwm["coil_heat_W"] > 2.5 * ser["coil_heat_W"]   # RMS heating at duty ~1/3
    low = DR.plan(D, supply_V=4.0)
    assert any("needed" in w for w in low["warnings"])


def test_plan_at_the_default_7V5_supply():
    """The default 7.5 V supply: 5.10 V at the 5.87 ohm coil fully on, so the paper's 3 V is PWM duty
    0.588 and the coil heats 1/0.588 = 1.7x a steady 3 V (the price of the L298's 5.8 V minimum supply)."""
    p = DR.plan(D)
    rc = D.coil.resistance
    assert p["supply_V"] == 7.5 and p["warnings"] == []
    assert p["coil_V_full_on"] == pytest.approx(5.10, abs=0.01)
    pwm = next(x for x in p["plans"] if x["method"] == "pwm")
    duty = 3.0 / p["coil_V_full_on"]
    assert f"PWM duty {duty:.3f}" in pwm["detail"] and pwm["detail"].startswith("PWM duty 0.588")
    assert pwm["coil_heat_W"] == pytest.approx((3.0 / rc) ** 2 * rc / duty, rel=1e-3)


def test_compare_drivers_mosfets_drop_less():
    rows = {r["driver"]: r for r in DR.compare_drivers(D)}
    assert rows["TB6612FNG"]["drop_V"] < rows["L298N"]["drop_V"]
    assert rows["DRV8833"]["supply_for_target_V"] < rows["L298N"]["supply_for_target_V"]


def test_cli_report_json_and_files(tmp_path):
    res = run_cli("coil", "report", "--json", "--out", str(tmp_path))
    assert res.returncode == 0, res.stderr
    rep = json.loads(res.stdout, parse_constant=lambda c: (_ for _ in ()).throw(AssertionError(c)))
    assert rep["winding"]["fits"] is True and rep["winding"]["turns"] == D.coil.turns == 370
    assert rep["thermal"]["limit"] == "bobbin (standard resin post-cured)"   # the thermal network's first limit
    for name in ("report.txt", "report.json", "force.png", "temperature.png"):
        assert (tmp_path / name).stat().st_size > 100
    assert "DOES NOT FIT" not in (tmp_path / "report.txt").read_text()   # the default winds what fits
    paper = run_cli("coil", "report", "--turns", "600", "--out", str(tmp_path / "paper"))
    assert paper.returncode == 0 and "DOES NOT FIT" in (tmp_path / "paper" / "report.txt").read_text()


def test_cli_shortcuts_and_refusals():
    res = run_cli("coil", "report", "--turns", "max")
    assert res.returncode == 0 and "FITS" in res.stdout and "DOES NOT FIT" not in res.stdout
    bad = run_cli("coil", "report", "--wire", "-0.1")
    assert bad.returncode == 2 and "coil.wire_diameter" in bad.stderr and bad.stderr.count("\n") == 1
    fit = run_cli("coil", "fit-stiffness", "3:15")
    assert fit.returncode == 0 and "mechanics.rotational_stiffness=" in fit.stdout
    bad = run_cli("coil", "fit-stiffness", "3:-15")
    assert bad.returncode == 2 and "opposite sign" in bad.stderr
