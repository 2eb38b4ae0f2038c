"""Driver wiring (whisker.pcb): SKiDL circuit from the pin map, ERC counted (0 errors on the
default design, a deliberately wrong net fails), committed outputs current, CLI refusals."""

from __future__ import annotations

import csv
import json
import re

import pytest
from hypothesis import given, settings, strategies as st

from conftest import ROOT, run_cli
from whisker.design import default_design
from whisker.pcb import build as pcb_build
from whisker.pcb import netlist, pinout
from whisker.drive.pins import HEADER_PIN, PinMapError, modules_needed, pin_map

EXPANDER = 'wiring.expander="pca9685"'
GENERATED = ROOT / "hw" / "pcb" / "generated"


def _net_pins(net):
    return {(p.part.ref, str(p.num)) for p in net.pins}


@pytest.fixture(scope="module")
def default_board():
    return netlist.build_circuit(default_design())


def test_default_design_erc_clean(default_board):
    report = netlist.run_erc(default_board)
    assert report.errors == 0 and report.warnings == 0, report.messages


@pytest.mark.parametrize("overrides", [("whiskers.count=5",), ("whiskers.count=6",), ("whiskers.count=11",),
                                       ("whiskers.count=12", EXPANDER), ("whiskers.count=17", EXPANDER)])
def test_other_designs_erc_clean(overrides):
    d = default_design(*overrides)
    board = netlist.build_circuit(d)
    report = netlist.run_erc(board)
    assert report.errors == 0 and report.warnings == 0, report.messages
    n = d.whiskers.count
    assert sum(1 for r in board.parts if r.startswith("L")) == n
    assert sum(1 for r in board.parts if re.fullmatch(r"U\d", r) or re.fullmatch(r"U\d\d", r)) == modules_needed(n)


def test_two_outputs_joined_fails_erc():
    board = netlist.build_circuit(default_design())
    board.nets["COIL0_FWD"] += board.nets["COIL1_FWD"]  # two Pi GPIO outputs on one net
    report = netlist.run_erc(board)
    assert report.errors >= 1 and not report.ok
    assert any("OUTPUT connected to OUTPUT" in m for m in report.messages)


def test_bridge_outputs_shorted_fails_erc():
    board = netlist.build_circuit(default_design())
    u = board.parts["U1"]
    u["OUT1"] += u["OUT3"]
    assert netlist.run_erc(board).errors >= 1


def test_erc_counts_reset_between_runs(default_board):
    bad = netlist.build_circuit(default_design())
    bad.nets["COIL0_FWD"] += bad.nets["COIL0_BWD"]
    assert netlist.run_erc(bad).errors >= 1
    assert netlist.run_erc(default_board).errors == 0  # the counts of the bad run do not leak


def test_build_refuses_erc_errors_and_keeps_old_output(tmp_path, monkeypatch):
    d = default_design()
    out = tmp_path / "pcb"
    pcb_build.build(d, out, draw=False)
    before = (out / "pinout.csv").read_text()
    real = netlist.build_circuit

    def broken(design):
        board = real(design)
        board.nets["COIL2_FWD"] += board.nets["COIL3_BWD"]
        return board

    monkeypatch.setattr(netlist, "build_circuit", broken)
    with pytest.raises(pcb_build.ErcFailed, match=r"ERC found \d+ error"):
        pcb_build.build(d, out, draw=False)
    assert (out / "pinout.csv").read_text() == before


def test_nets_follow_the_pin_map(default_board):
    for ch in pin_map(default_design()):
        fwd = _net_pins(default_board.nets[f"COIL{ch.whisker}_FWD"])
        assert ("J1", str(HEADER_PIN[ch.forward])) in fwd
        assert (f"U{ch.module + 1}", {"A": "1", "B": "3"}[ch.channel]) in fwd  # IN1 / IN3
        coil = _net_pins(default_board.nets[f"COIL{ch.whisker}_A"])
        assert (f"L{ch.whisker + 1}", "1") in coil


def test_expander_nets():
    d = default_design("whiskers.count=12", EXPANDER)
    board = netlist.build_circuit(d)
    sda = _net_pins(board.nets["I2C_SDA"])
    assert ("J1", "3") in sda and ("U101", "4") in sda and ("U102", "4") in sda
    ch = pin_map(d)[9]
    fwd = _net_pins(board.nets["COIL9_FWD"])
    assert (f"U{101 + ch.address - 0x40}", str(7 + ch.forward)) in fwd  # PWMn is pin 7 + n


def test_netlist_is_balanced_kicad_export(default_board):
    text = netlist.netlist_text(default_board)
    depth = 0
    for c in text:
        depth += (c == "(") - (c == ")")
        assert depth >= 0
    assert depth == 0 and text.lstrip().startswith("(export")
    assert len(re.findall(r"\(comp\b", text)) == len(default_board.parts)
    assert len(re.findall(r"\(net\b", text)) == len(default_board.nets)


def _stable(text):
    return re.sub(r'\(tool "[^"]*"\)', "", text)


def test_committed_outputs_are_current(tmp_path):
    d = default_design()
    assert (GENERATED / "pinout.csv").read_text() == pinout.pinout_csv(d), "run `make pcb` and commit"
    assert (GENERATED / "pinout.md").read_text() == pinout.pinout_markdown(d), "run `make pcb` and commit"
    fresh = netlist.netlist_text(netlist.build_circuit(d))
    assert _stable((GENERATED / "driver.net").read_text()) == _stable(fresh), "run `make pcb` and commit"
    summary = json.loads((GENERATED / "summary.json").read_text())
    assert summary["erc_errors"] == 0 and summary["whiskers"] == d.whiskers.count


def test_pinout_rows():
    for n in (6, 8):
        d = default_design(f"whiskers.count={n}")
        rows = pinout.pinout_rows(d)
        assert len(rows) == 2 * n
        assert len({r["source"] for r in rows}) == 2 * n
        assert all(r["header_pin"] for r in rows)
    rows6 = pinout.pinout_rows(default_design("whiskers.count=6"))
    assert [r["source"] for r in rows6] == [r["source"] for r in pinout.pinout_rows(default_design())][:12]


def test_cli_pcb(tmp_path):
    from click.testing import CliRunner

    from whisker.commands.build.hw import cli

    out = tmp_path / "pcb6"
    res = CliRunner().invoke(cli, ["pcb", "--set", "whiskers.count=6", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "ERC 0 errors" in res.output
    for f in ("pinout.csv", "pinout.md", "wiring.png", "driver.net", "erc.txt", "summary.json"):
        assert (out / f).stat().st_size > 0
    assert (out / "wiring.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(list(csv.DictReader((out / "pinout.csv").open()))) == 12
    res = CliRunner().invoke(cli, ["pcb", "--set", "whiskers.count=12", "--out", str(tmp_path / "pcb12")])
    assert res.exit_code == 2 and "PCA9685" in res.output and not (tmp_path / "pcb12").exists()
    res = CliRunner().invoke(cli, ["pins", "--set", "whiskers.count=12", "--set", EXPANDER])
    assert res.exit_code == 0 and "PCA9685@0x41" in res.output


def test_entry_point_refuses_too_many_coils():
    res = run_cli("hw", "pins", "--set", "whiskers.count=12")
    assert res.returncode == 2
    assert res.stderr.strip().startswith("pins refused: 12 coils need 24 GPIO") and "PCA9685" in res.stderr


@settings(max_examples=12, deadline=None)
@given(n=st.integers(1, 40), expander=st.booleans())
def test_any_wireable_design_is_erc_clean_and_follows_the_pin_map(n, expander):
    overrides = [f"whiskers.count={n}"] + ([EXPANDER] if expander else [])
    d = default_design(*overrides)
    if n > 11 and not expander:
        with pytest.raises(PinMapError, match="PCA9685"):
            netlist.build_circuit(d)
        return
    board = netlist.build_circuit(d)
    report = netlist.run_erc(board)
    assert report.errors == 0 and report.warnings == 0, report.messages
    for ch in pin_map(d):
        for signal, src in (("FWD", ch.forward), ("BWD", ch.backward)):
            pins = _net_pins(board.nets[f"COIL{ch.whisker}_{signal}"])
            assert len(pins) == 2  # exactly one source and one module input
            if ch.bus == "gpio":
                assert ("J1", str(HEADER_PIN[src])) in pins
            else:
                assert (f"U{101 + ch.address - 0x40}", str(7 + src)) in pins


def test_supply_above_logic_range_keeps_module_regulators():
    d = default_design("driver.supply_voltage=9")
    board = netlist.build_circuit(d)
    assert netlist.run_erc(board).errors == 0
    assert "+9V" in board.nets and ("U1", "13") not in _net_pins(board.nets["+9V"])  # VLOGIC not on 9 V
    assert {("U1", "13"), ("U1", "5"), ("U1", "6")} <= _net_pins(board.nets["U1_5V"])
    assert "keep the 5V-EN jumper fitted" in pinout.pinout_markdown(d)
    assert "Cautions" not in pinout.pinout_markdown(d)
    assert "Cautions" not in pinout.pinout_markdown(default_design())  # 7.5 V: within the datasheet
    assert "Cautions" in pinout.pinout_markdown(default_design("driver.supply_voltage=5"))  # < VIH + 2.5 V


def test_default_supply_wiring(default_board):
    """The default 7.5 V supply feeds VS only (each module's 78M05 makes its logic 5 V); the 5 V LED
    strip sits on the Pi's 5 V header pin, never on the coil supply."""
    nets = default_board.nets
    supply = _net_pins(nets["+7.5V"])
    assert ("PS1", "1") in supply and all(("U%d" % k, "11") in supply for k in range(1, 5))
    assert not any(ref == "D1" or pin == "13" for ref, pin in supply)  # no LED, no VLOGIC on 7.5 V
    assert _net_pins(nets["+5V_PI"]) == {("J1", "4"), ("D1", "1")}
    assert ("D1", "2") in _net_pins(nets["GND"]) and ("J1", "6") in _net_pins(nets["GND"])
    for k in range(1, 5):
        assert {(f"U{k}", "13"), (f"U{k}", "5"), (f"U{k}", "6")} <= _net_pins(nets[f"U{k}_5V"])
    md = pinout.pinout_markdown(default_design())
    assert "LED strip + -> Pi 5V (header pin 4)" in md and "coil supply +7.5 V -> every module's +12V (VS) terminal;" in md


@pytest.mark.parametrize("vs", ["5", "6.5", "9"])
def test_led_strip_on_the_pi_at_any_supply(vs):
    board = netlist.build_circuit(default_design(f"driver.supply_voltage={vs}"))
    assert netlist.run_erc(board).errors == 0
    assert _net_pins(board.nets["+5V_PI"]) == {("J1", "4"), ("D1", "1")}
    assert ("D1", "1") not in _net_pins(board.nets[f"+{vs}V"])


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # kinparse uses pyparsing's old camelCase names
def test_committed_netlist_parses_as_kicad_and_matches_the_circuit(default_board):
    kinparse = pytest.importorskip("kinparse", reason="kinparse (KiCad netlist parser) not installed")
    nl = kinparse.parse_netlist((GENERATED / "driver.net").read_text())
    assert {p.ref for p in nl.parts} == set(default_board.parts)
    parsed = {n.name: {(p.ref, p.num) for p in n.pins} for n in nl.nets}
    built = {name: _net_pins(net) for name, net in default_board.nets.items()}
    assert parsed == built
