"""Bill of materials (whisker.bom): the committed hw/bom.csv is current, quantities follow the
design (6, 8, 12 whiskers), and broken inputs are refused with a message naming what is wrong."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from conftest import ROOT
from whisker.bom import BomError, CoilWire, awg, bom_csv, bom_rows, coil_wire, led_strip, make_bom
from whisker.part_measures import (MEMBRANE_PART, PRINTED_PARTS, PrintSettings, cad_measures, cad_volumes, pla_grams,
                                   print_settings, read_print_report)
from whisker.design import default_design
from whisker.drive.pins import PinMapError

EXPANDER = 'wiring.expander="pca9685"'


def _by_item(rows):
    return {r.item: r for r in rows}


def _fake_volumes(scale=1.0):
    return {name: 1000.0 * scale * (i + 1) for i, name in enumerate((*PRINTED_PARTS, MEMBRANE_PART))}


def test_committed_bom_is_current():
    committed = (ROOT / "hw" / "bom.csv").read_text()
    fresh = bom_csv(make_bom(default_design()))
    assert committed == fresh, "hw/bom.csv is out of date with the design: run `make bom` and commit it"


def test_bom_csv_columns_and_rows_parse():
    text = (ROOT / "hw" / "bom.csv").read_text()
    rows = list(csv.DictReader(io.StringIO(text)))
    for col in ("item", "description", "quantity", "unit", "specification", "example_source", "notes"):
        assert col in rows[0]
    items = {r["item"] for r in rows}
    assert {"rod", "coil", "magnet", "magnet_wire", "ecoflex", "pla", "h_bridge", "raspberry_pi",
            "camera", "led_strip", "screw_m3x10", "screw_m2x5"} <= items
    for r in rows:
        q = float(r["quantity"])
        assert math.isfinite(q) and q > 0, r


@pytest.fixture(scope="module")
def boms():
    return {n: _by_item(make_bom(default_design(f"whiskers.count={n}", *([EXPANDER] if n > 11 else []))))
            for n in (6, 8, 12)}


def test_quantities_follow_the_whisker_count(boms):
    for n, b in boms.items():
        for item in ("rod", "coil", "magnet"):
            assert b[item].value == n
        assert b["h_bridge"].value == math.ceil(n / 2)
    # 12 coils = twice 6: per-coil items double exactly, wire to rounding.
    assert boms[12]["h_bridge"].value == 2 * boms[6]["h_bridge"].value
    assert boms[12]["magnet_wire"].value == pytest.approx(2 * boms[6]["magnet_wire"].value, abs=0.11)
    assert boms[8]["magnet_wire"].value == pytest.approx(8 / 6 * boms[6]["magnet_wire"].value, abs=0.11)
    assert "pwm_expander" not in boms[6] and "pwm_expander" not in boms[8]
    assert boms[12]["pwm_expander"].value == 2  # 24 channels on 16-channel boards
    # 2 signal jumpers per coil + 1 Pi GND to the supply + 2 for the LED strip on the Pi's 5 V; the
    # expander adds 4 bus wires per board.
    assert boms[6]["jumpers"].value == 2 * 6 + 1 + 2
    assert boms[8]["jumpers"].value == 2 * 8 + 1 + 2
    assert boms[12]["jumpers"].value == 2 * 12 + 1 + 2 + 4 * 2
    # Supply current scales with N: N x 0.56 A (7.5 V - the L298's drop, into the series resistor + the
    # 5.87 ohm coil) + 0.106 A per module; one series resistor per coil.
    assert "7.5 V regulated, at least 4 A" in boms[6]["coil_supply"].specification   # 3.67 A
    assert "7.5 V regulated, at least 5 A" in boms[8]["coil_supply"].specification   # 4.89 A
    assert "at least 8 A" in boms[12]["coil_supply"].specification                   # 7.34 A
    assert all(boms[n]["series_resistor"].value == n for n in boms)


def test_material_quantities_come_from_cad_volumes():
    d = default_design()
    vol, area = cad_measures(d)
    assert vol == cad_volumes(d)
    b = _by_item(bom_rows(d, vol, coil_wire(d)))  # no areas/settings: solid upper bound
    ecoflex = vol[MEMBRANE_PART] / 1000 * d.membrane.density * (1 + d.bom.ecoflex_waste)
    assert b["ecoflex"].value == pytest.approx(ecoflex, abs=0.05)
    solid = sum(vol[p] for p in PRINTED_PARTS) / 1000 * d.print.filament_density * (1 + d.bom.pla_waste)
    assert b["pla"].value == pytest.approx(solid, abs=0.05)
    s = print_settings(d)
    assert s.shell_mm == pytest.approx(0.9) and s.infill == pytest.approx(0.15)  # 2 x 0.45 mm, 15 %
    shell = _by_item(bom_rows(d, vol, coil_wire(d), areas_mm2=area, settings=s))["pla"].value
    assert 0.3 * solid < shell < solid  # shells + sparse infill weigh less than solid parts
    w = coil_wire(d)
    wire = d.whiskers.count * (w.wire_length_mm + 2 * d.bom.coil_lead_length) * (1 + d.bom.wire_waste) / 1000
    assert b["magnet_wire"].value == pytest.approx(wire, abs=0.05)
    # A bigger waste allowance gives more material, nothing else changes.
    d2 = default_design("bom.ecoflex_waste=1.0")
    b2 = _by_item(bom_rows(d2, vol, w))
    assert b2["ecoflex"].value > b["ecoflex"].value and b2["rod"] == b["rod"]


def test_led_strip_runs_from_the_pis_5V_not_the_coil_supply():
    """A 5 V strip on the 7.5 V coil supply would be overdriven: it sits on the Pi's 5 V header pin."""
    for vs in ("7.5", "5", "12"):
        b = _by_item(bom_rows(default_design(f"driver.supply_voltage={vs}"), _fake_volumes(),
                              CoilWire(1000.0, "test")))
        assert b["led_strip"].specification.startswith("5 V 3528 LED strip")
        assert "Pi's 5V header pin 4" in b["led_strip"].notes and f"not the {vs} V coil supply" in b["led_strip"].notes
        assert "LED" not in b["coil_supply"].description and "LED" not in b["coil_supply"].notes


@settings(max_examples=20, deadline=None)
@given(vs=st.floats(4.0, 20.0), n=st.integers(1, 11), r=st.floats(3.0, 30.0))
def test_supply_current_is_every_coil_fully_on(vs, n, r):
    """I = N (Vs - V0) / (R + Rs + r_bridge) (L298N typ: V0 = 1.40 V, r = 1.15 ohm; Rs the series
    resistor, driver.series_resistance) + ceil(N/2) x 0.106 A, below the no-drop bound N Vs / R plus the
    quiescent current, and the BOM rounds it up."""
    from whisker.bom import supply_current_A
    from whisker.coil.driver import series_resistance_ohm

    d = default_design(f"driver.supply_voltage={vs!r}", f"whiskers.count={n}", f"coil.resistance={r!r}")
    i = supply_current_A(d)
    expect = n * (vs - 1.40) / (r + series_resistance_ohm(d) + 1.15) + math.ceil(n / 2) * 0.106
    assert i == pytest.approx(expect, rel=1e-9)
    assert i < n * vs / r + math.ceil(n / 2) * 0.106
    spec = _by_item(bom_rows(d, _fake_volumes(), CoilWire(1000.0, "test")))["coil_supply"].specification
    assert f"at least {math.ceil(i)} A" in spec


def test_led_strip_fits_its_channel():
    d = default_design()
    circ, segments, length = led_strip(d)
    assert circ == pytest.approx(2 * math.pi * (d.cavity_radius + d.mount.led_strip_thickness))
    assert length <= circ < length + d.bom.led_cut_pitch
    with pytest.raises(BomError, match="LED channel"):
        led_strip(default_design("bom.led_cut_pitch=1000"))


@settings(max_examples=20, deadline=None)
@given(n=st.integers(1, 11), scale=st.floats(0.01, 100), wire=st.floats(1.0, 1e5))
def test_bom_rows_identities(n, scale, wire):
    d = default_design(f"whiskers.count={n}")
    b = _by_item(bom_rows(d, _fake_volumes(scale), CoilWire(wire, "test")))
    assert b["rod"].value == b["coil"].value == b["magnet"].value == n
    assert b["h_bridge"].value == math.ceil(n / 2)
    assert b["jumpers"].value == 2 * n + 1 + 2 + (2 if n % 2 else 0)  # odd: spare IN3/IN4 to GND
    for r in b.values():
        assert math.isfinite(r.value) and r.value >= 0 and "\n" not in r.notes


@pytest.mark.parametrize("bad", [0.0, -5.0, float("nan"), float("inf"), None])
def test_bad_volumes_are_refused(bad):
    vol = _fake_volumes()
    if bad is None:
        del vol[MEMBRANE_PART]
    else:
        vol[MEMBRANE_PART] = bad
    with pytest.raises(BomError, match="membrane"):
        bom_rows(default_design(), vol, CoilWire(1000.0, "test"))


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_wire_length_is_refused(bad):
    with pytest.raises(BomError, match="wire length"):
        bom_rows(default_design(), _fake_volumes(), CoilWire(bad, "test"))


def test_too_many_coils_for_the_pi_is_refused():
    with pytest.raises(PinMapError, match="PCA9685"):
        bom_rows(default_design("whiskers.count=12"), _fake_volumes(), CoilWire(1000.0, "test"))


def test_print_report_is_read_and_checked(tmp_path):
    d = default_design()
    report = {"design_digest": d.digest(),
              "parts": {p: {"name": p, "gcode": {"filament_g": 10.0 + i}} for i, p in enumerate(PRINTED_PARTS)}}
    path = tmp_path / "print_report.json"
    path.write_text(json.dumps(report))
    grams = read_print_report(path, d)
    assert grams == {p: 10.0 + i for i, p in enumerate(PRINTED_PARTS)}
    b = _by_item(bom_rows(d, _fake_volumes(), CoilWire(1000.0, "test"), grams))
    assert "slicer 10.0 g" in b["print_mount"].specification and "slicer report" in b["pla"].notes
    # 10 + 11 + ... one gram more per printed part
    want = sum(10.0 + i for i in range(len(PRINTED_PARTS)))
    assert b["pla"].value == pytest.approx(want * (1 + d.bom.pla_waste), abs=0.05)
    report["coarse"] = True
    path.write_text(json.dumps(report))
    with pytest.raises(BomError, match="coarse"):
        read_print_report(path, d)
    report["coarse"] = False
    report["design_digest"] = "0000000000000000"
    path.write_text(json.dumps(report))
    with pytest.raises(BomError, match="another|not of this design"):
        read_print_report(path, d)
    path.write_text("{not json")
    with pytest.raises(BomError, match="cannot read"):
        read_print_report(path, d)
    path.write_text(json.dumps({"parts": {"mount": {"gcode": {"filament_g": float("nan")}}}}).replace("NaN", "NaN"))
    with pytest.raises(BomError, match="finite"):
        read_print_report(path)


def test_awg():
    assert awg(0.101) == 38 and awg(0.127) == 36 and awg(0.255) == 30


def test_cli_bom(tmp_path):
    from click.testing import CliRunner

    from whisker.commands.build.hw import cli

    out = tmp_path / "bom6.csv"
    res = CliRunner().invoke(cli, ["bom", "--set", "whiskers.count=6", "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = {r["item"]: r for r in csv.DictReader(out.open())}
    assert rows["rod"]["quantity"] == "6" and rows["h_bridge"]["quantity"] == "3"
    res = CliRunner().invoke(cli, ["bom", "--set", "whiskers.count=12", "--out", str(tmp_path / "bom12.csv")])
    assert res.exit_code == 2 and not (tmp_path / "bom12.csv").exists()
    assert "PCA9685" in res.output and len(res.output.strip().splitlines()) == 1


@settings(max_examples=30, deadline=None)
@given(v=st.floats(1.0, 1e6), ratio=st.floats(0.01, 100.0), shell=st.floats(0.0, 5.0), infill=st.floats(0.0, 1.0))
def test_pla_shell_model_bounds(v, ratio, shell, infill):
    a = v * ratio  # any surface-to-volume ratio, mm^-1
    solid = pla_grams(v, a, 1.24)
    g = pla_grams(v, a, 1.24, PrintSettings(shell, infill))
    assert infill * solid - 1e-9 <= g <= solid + 1e-9
    assert pla_grams(v, a, 1.24, PrintSettings(shell, 1.0)) == pytest.approx(solid)


@pytest.mark.parametrize("v,a", [(0.0, 1.0), (-1.0, 1.0), (float("nan"), 1.0), (1.0, 0.0), (1.0, float("inf"))])
def test_pla_bad_inputs(v, a):
    with pytest.raises(BomError):
        pla_grams(v, a, 1.24, PrintSettings(0.9, 0.15))


def test_cad_failure_is_one_line_bom_error(monkeypatch):
    import whisker.cad.parts as parts

    def broken(design):
        raise RuntimeError("BRep_API: command not done\nmore detail")

    spec = parts.BY_NAME["mold_lid"]
    monkeypatch.setitem(parts.BY_NAME, "mold_lid", type(spec)(spec.name, broken, spec.printable, spec.description))
    with pytest.raises(BomError, match=r"CAD part 'mold_lid' cannot be built .*BRep_API: command not done\)") as err:
        cad_measures(default_design())
    assert "\n" not in str(err.value)
