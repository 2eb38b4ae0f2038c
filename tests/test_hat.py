"""The driver HAT (whisker.pcb.hat/layout/board, whisker.coil.board): circuit + ERC for 6/8/12 coils,
refusals naming the limit with the old outputs untouched, the current-loop model against the L298N,
IPC-2221 widths, placement on the HAT outline, the committed outputs current, the copper check.
Board steps that need KiCad 9 (pcbnew, kicad-cli) are in tests/test_hat_board.py."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import ROOT
from whisker.coil import board as coil_board
from whisker.coil import driver as coil_driver
from whisker.design import default_design
from whisker.drive import guard
from whisker.drive.pins import HEADER_PIN, pin_map
from whisker.pcb import board as hat_board
from whisker.pcb import copper, hat, layout

HAT = 'driver.type="HAT"'
TWELVE = ("whiskers.count=12", 'wiring.expander="pca9685"', "wiring.pca9685_address=0x44")
GENERATED = ROOT / "hw" / "pcb" / "generated" / "hat"


def _design(*sets):
    return default_design(HAT, *sets)


@pytest.mark.parametrize("sets", [(), ("whiskers.count=6",), TWELVE, ("whiskers.count=5",)])
def test_circuit_erc_clean(sets):
    d = _design(*sets)
    h = hat.build_circuit(d)
    rep = hat.erc(h)
    assert rep.errors == 0 and rep.warnings == 0, rep.messages
    n = d.whiskers.count
    assert sum(1 for r in h.parts if r.startswith("J1") and len(r) == 3 or r in {f"J{10 + i}" for i in range(n)}) >= n
    assert {f"J{10 + i}" for i in range(n)} <= set(h.parts)
    assert sum(1 for r in h.parts if h.info[r]["kind"] == "bridge") == math.ceil(n / 2)
    assert sum(1 for r in h.parts if h.info[r]["kind"] == "monitor") == math.ceil(n / 3)


def test_nets_follow_the_pin_map():
    d = _design()
    nets = hat.pad_nets(hat.build_circuit(d))
    for ch in pin_map(d):
        fwd, bwd, sense, (o1, o2) = hat.DRV8833_CHANNEL[ch.channel]
        num = {v: str(k) for k, v in hat.DRV8833_PINS.items()}
        u = f"U{ch.module + 1}"
        assert nets["J1"][str(HEADER_PIN[ch.forward])] == nets[u][num[fwd]] == f"COIL{ch.whisker}_FWD"
        assert nets["J1"][str(HEADER_PIN[ch.backward])] == nets[u][num[bwd]]
        assert nets[f"J{10 + ch.whisker}"]["1"] == nets[u][num[o1]]
        assert nets[f"J{10 + ch.whisker}"]["2"] == nets[u][num[o2]]
        assert nets[u][num[sense]] == f"ISEN{ch.whisker}"


def test_twelve_coils_use_the_expander_and_monitor_addresses():
    d = _design(*TWELVE)
    h = hat.build_circuit(d)
    nets = hat.pad_nets(h)
    assert {"U21", "U22"} <= set(h.parts)                       # 24 PWM channels: two PCA9685
    a0 = {nets[f"U{11 + m}"]["5"] for m in range(4)}            # INA3221 A0 straps: 0x40..0x43
    assert a0 == {"GND", "+3V3", "I2C_SDA", "I2C_SCL"}


@pytest.mark.parametrize("sets, match", [
    (("drive.max_coil_voltage=10",), r"full-scale current 1\.7\d* A .* above the DRV8833's 1\.5 A"),
    (("whiskers.count=13", 'wiring.expander="pca9685"', "wiring.pca9685_address=0x44"),
     r"13 coils is more than the HAT carries: 12 \(4 INA3221"),
    (('driver.bridge="XYZ"',), r"unknown driver 'XYZ': no such bridge in hw/bridges.csv"),
    (('driver.current_monitor="FOO"',), r"unknown current monitor 'FOO'"),
    (("whiskers.count=12", 'wiring.expander="pca9685"'), r"collides with the HAT's INA3221"),
    (("driver.supply_voltage=12",), r"outside the DRV8833's 2\.7-10\.8 V"),
])
def test_refusals_name_the_limit_and_keep_old_outputs(tmp_path, sets, match):
    out = tmp_path / "hat"
    hat_board.build_hat(_design(), out, route=False, log=lambda m: None)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(hat.HatError, match=match):
        hat_board.build_hat(_design(*sets), out, route=False, log=lambda m: None)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_cli_refusal_is_one_line(tmp_path):
    from click.testing import CliRunner

    from whisker.commands.build.hw import cli

    res = CliRunner().invoke(cli, ["hat", "--no-route", "--set", "whiskers.count=14", "--set",
                                   'wiring.expander="pca9685"', "--set", "wiring.pca9685_address=0x44",
                                   "--out", str(tmp_path / "h")])
    assert res.exit_code == 2
    assert "more than the HAT carries: 12" in res.output and res.output.count("\n") <= 2
    assert not (tmp_path / "h").exists()


def test_current_loop_beats_the_l298n_by_four():
    """The issue's gate: the board's force spread at the grasp level (25-60 C, datasheet spread) is at
    most a quarter of the L298N modules'."""
    rows = {r["driver"].split()[0]: r for r in coil_board.compare(default_design())}
    assert rows["HAT"]["current_A"] == pytest.approx(rows["L298N"]["current_A"], rel=1e-9)  # same grasp
    assert rows["HAT"]["spread_pct"] <= rows["L298N"]["spread_pct"] / 4
    assert rows["L298N"]["current_low_A"] < rows["L298N"]["current_A"] < rows["L298N"]["current_high_A"]


def test_guard_follows_the_board():
    d = _design()
    t = np.array([20.0, 40.0, 60.0])
    i = guard.coil_current_A(d, 3.0, t)
    assert np.allclose(i, 3.0 / d.coil.resistance)          # regulated: no temperature dependence
    i_mod = guard.coil_current_A(default_design(), 3.0, t)
    assert i_mod[2] < i_mod[0]                               # the modules' current falls as the coil warms
    assert guard.full_scale_voltage(d) == pytest.approx(d.drive.max_coil_voltage)
    assert guard.driver_current_rating_A(d) == coil_driver.bridge("DRV8833").max_current_A
    assert coil_driver.series_resistance_ohm(d) == 0.0


def test_sense_resistor_fits_monitor_and_chopper():
    d = _design()
    rs = coil_board.sense_resistance_ohm(d)
    mon = coil_driver.monitor("INA3221")
    i_fs = coil_board.full_scale_current_A(d)
    lo, hi = coil_board.chopper_trip_A(d)
    assert i_fs * rs <= 0.95 * mon.full_scale_V
    assert lo >= coil_board.CHOPPER_MARGIN * i_fs and hi <= coil_driver.bridge("DRV8833").max_current_A


def test_tables_are_read_whole():
    """Every column of hw/bridges.csv is on the Bridge it makes (code reads every column it relies on)."""
    import csv

    from whisker.resources import hw_dir

    with open(hw_dir() / "bridges.csv") as fh:
        rows = list(csv.DictReader(l for l in fh if not l.startswith("#")))
    for r in rows:
        b = coil_driver.bridge(r["name"])
        assert b.drop_V(1.0, "min") <= b.drop_V(1.0, "typ") <= b.drop_V(1.0, "max")
        assert b.package == r["package"] and b.tsd_C == float(r["tsd_C"]) and b.channels == int(r["channels"])
    assert {"L298N", "TB6612FNG", "DRV8833", "DRV8874", "DRV8876"} <= set(coil_driver.BRIDGES)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.05, 20.0), st.floats(1.05, 3.0))
def test_ipc2221_width_grows_with_current(i, k):
    assert layout.ipc2221_width_mm(i * k) > layout.ipc2221_width_mm(i) > 0
    assert layout.ipc2221_width_mm(i, rise_K=30.0) < layout.ipc2221_width_mm(i, rise_K=10.0)


def test_ipc2221_chart_point():
    # IPC-2221 external chart: 1 A at 10 K rise in 1 oz copper needs about 12 mil (0.30 mm)
    assert layout.ipc2221_width_mm(1.0) == pytest.approx(0.30, abs=0.02)


@pytest.mark.parametrize("sets", [(), ("whiskers.count=6",), TWELVE])
def test_placement_on_the_hat(sets):
    d = _design(*sets)
    spec = layout.place(hat.build_circuit(d))
    mech = layout.hat_spec()
    w, h = mech["board"]["width"], mech["board"]["height"]
    assert (spec["board"]["width"], spec["board"]["height"]) == (65.0, 56.5)
    holes = [(p["x"], p["y"]) for p in spec["parts"] if p["ref"].startswith("H")]
    assert holes == [tuple(xy) for xy in mech["mounting_holes"]["positions"]]
    j1 = next(p for p in spec["parts"] if p["ref"] == "J1")
    assert (j1["x"], j1["y"]) == pytest.approx((32.5 - 9.5 * 2.54, 3.5 + 1.27))
    n = d.whiskers.count
    cons = [next(p for p in spec["parts"] if p["ref"] == f"J{10 + i}") for i in range(n)]
    # every connector on the board, away from the holes' keep-out, in whisker order along the U-shaped edge
    for c in cons:
        assert 0 < c["x"] < w and 0 < c["y"] < h
        for hx, hy in holes:
            assert math.hypot(c["x"] - hx, c["y"] - hy) > mech["mounting_holes"]["keepout_diameter"] / 2
    bottom = [c["x"] for c in cons if c["rot"] == 0.0]
    assert bottom == sorted(bottom)
    assert spec["rules"]["track_width"] >= spec["rules"]["coil_width"]


def test_committed_outputs_are_current():
    """hw/pcb/generated/hat/ is what `make pcb` makes from the default design (netlist, placement)."""
    from whisker.pcb.netlist import netlist_text

    circuit, _rep, spec = hat_board.prepare(default_design())
    assert (GENERATED / "placement.json").read_text() == json.dumps(spec, indent=1, sort_keys=True) + "\n", \
        "run `make pcb` and commit"
    assert (GENERATED / "hat.net").read_text() == netlist_text(circuit), "run `make pcb` and commit"


def _rect(x, y, w, h):
    return [[x, y], [x + w, y], [x + w, y + h], [x, y + h]]


def test_copper_clusters_follow_geometry_not_labels():
    items = [
        {"kind": "pad", "id": "A:1", "layer": "F.Cu", "polys": [_rect(0, 0, 1, 1)]},
        {"kind": "track", "id": "t0", "layer": "F.Cu", "start": [0.5, 0.5], "end": [5.5, 0.5], "width": 0.2},
        {"kind": "via", "id": "v0", "layer": "*", "at": [5.5, 0.5], "radius": 0.2},
        {"kind": "track", "id": "t1", "layer": "B.Cu", "start": [5.5, 0.5], "end": [5.5, 5.5], "width": 0.2},
        {"kind": "pad", "id": "B:1", "layer": "B.Cu", "polys": [_rect(5, 5, 1, 1)]},
        {"kind": "pad", "id": "C:1", "layer": "F.Cu", "polys": [_rect(5, 5, 1, 1)]},   # same spot, other layer
    ]
    cl = copper.clusters(items)
    assert cl["A:1"] == cl["B:1"] != cl["C:1"]
    items[3]["layer"] = "F.Cu"   # the same track on the top layer joins C instead of B
    cl = copper.clusters(items)
    assert cl["A:1"] == cl["C:1"] != cl["B:1"]


def test_pin_map_check_finds_a_swapped_coil():
    """check_pin_map on a synthetic 'board' where each pin-map pair is joined, then one swap."""
    d = _design("whiskers.count=2")
    num = {v: str(k) for k, v in hat.DRV8833_PINS.items()}
    cl, k = {}, 0
    for ch in pin_map(d):
        fwd, bwd, _s, (o1, o2) = hat.DRV8833_CHANNEL[ch.channel]
        j, u = f"J{10 + ch.whisker}", f"U{ch.module + 1}"
        for a, b in ((f"{j}:1", f"{u}:{num[o1]}"), (f"{j}:2", f"{u}:{num[o2]}"),
                     (f"J1:{HEADER_PIN[ch.forward]}", f"{u}:{num[fwd]}"),
                     (f"J1:{HEADER_PIN[ch.backward]}", f"{u}:{num[bwd]}")):
            cl[a] = cl[b] = k
            k += 1
    assert copper.check_pin_map(d, cl) == []
    cl["J10:1"], cl["J10:2"] = cl["J10:2"], cl["J10:1"]
    assert any("coil 0 pin 1" in p for p in copper.check_pin_map(d, cl))


def test_pins_match_kicad_symbols():
    """Pin numbers/names in hat.py against KiCad 9's symbol libraries (the datasheets' pinouts)."""
    import re

    libs = Path("/usr/share/kicad/symbols")
    if not (libs / "Driver_Motor.kicad_sym").exists():
        pytest.skip("kicad-symbols not installed (scripts/system-deps installs it; CI has it)")

    def pins(lib, name):
        t = (libs / lib).read_text()
        i = t.index(f'(symbol "{name}"')
        j = t.find('\n\t(symbol "', i + 10)
        return {m.group(2): m.group(1) for m in re.finditer(r'\(name "([^"]*)".*?\(number "([^"]*)"', t[i:j], re.S)}

    drv = pins("Driver_Motor.kicad_sym", "DRV8833PWP")
    for k, name in hat.DRV8833_PINS.items():
        ref = drv[str(k)].replace("~{", "n").replace("}", "")
        assert ref == ("GND" if name == "PAD" else name), (k, name, drv[str(k)])
    ina = pins("Power_Management.kicad_sym", "INA3221")
    assert {str(k): n for k, n in hat.INA3221_PINS.items()} == ina
    pca = pins("Driver_LED.kicad_sym", "PCA9685PW")
    assert {str(k): n.replace("~{", "").replace("}", "") for k, n in pca.items()} == \
        {str(k): n.replace("LED", "LED") for k, n in hat.PCA9685_PINS.items()}
