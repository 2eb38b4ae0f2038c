"""The HAT's schematic (hw/pcb/generated/hat/schematic/, made by `make pcb` through
whisker.pcb.schematic): it exists for the committed design, draws every coil connector and bridge of the
committed netlist, joins exactly the circuit's pins (KiCad's own netlist of the drawing), and a second
drawing gives the same bytes. KiCad 9 (kicad-cli, kicad-symbols) is needed to draw and to read it back;
CI installs it through scripts/system-deps."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.design import default_design
from whisker.pcb import board as hat_board
from whisker.pcb import hat, kicad, schematic

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # kinparse: pyparsing's old names

HAVE_KICAD, WHY = kicad.kicad_status()
HAVE_SYMBOLS = (schematic.SYMBOL_DIR / "Device.kicad_sym").exists()
needs_kicad = pytest.mark.skipif(not (HAVE_KICAD and HAVE_SYMBOLS),
                                 reason=f"KiCad 9 with its symbol libraries absent: {WHY}")
ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "hw" / "pcb" / "generated" / "hat"
SHEETS = GENERATED / "schematic"


def _netlist_refs() -> tuple[list[str], list[str]]:
    """(coil connector refs, bridge refs) of the committed SKiDL netlist hat.net: the connectors valued
    W<whisker>, the parts valued DRV8833...."""
    comps = re.findall(r'\(comp\s*\(ref "([^"]+)"\)\s*\(value "([^"]*)"\)', (GENERATED / "hat.net").read_text())
    assert comps, "no components parsed from hat.net"
    coils = [ref for ref, value in comps if ref.startswith("J") and re.fullmatch(r"W\d+", value)]
    bridges = [ref for ref, value in comps if value.startswith("DRV8833")]
    return coils, bridges


def _svg_texts(svg: Path) -> set[str]:
    """The texts KiCad's SVG plot carries (invisible <text> elements beside the stroked glyphs)."""
    return set(re.findall(r"<text[^>]*>([^<]*)</text>", svg.read_text()))


def test_committed_schematic_draws_every_coil_connector_and_bridge():
    summary = json.loads((GENERATED / "hat_summary.json").read_text())
    files = summary["schematic"]["files"]
    assert sorted(p.name for p in SHEETS.iterdir()) == files
    assert summary["schematic"]["kicad_erc"]["errors"] == 0
    coils, bridges = _netlist_refs()
    d = default_design()
    assert len(coils) == d.whiskers.count and len(bridges) == hat.bridges_needed(d.whiskers.count)
    sch_refs = set()
    for sch in SHEETS.glob("*.kicad_sch"):
        sch_refs |= set(re.findall(r'\(property "Reference" "([^"]+)"', sch.read_text()))
    assert set(coils) | set(bridges) <= sch_refs
    svg_texts = set().union(*[_svg_texts(p) for p in SHEETS.glob("*.svg")])
    assert set(coils) | set(bridges) <= svg_texts
    # one sheet per bridge, with its own coil connectors on it (W<i> labels them)
    for k, u in enumerate(bridges):
        texts = _svg_texts(SHEETS / f"hat-bridge{k + 1}.svg")
        assert u in texts
        for i in (2 * k, 2 * k + 1):
            if i < d.whiskers.count:
                assert {f"J{10 + i}", f"W{i}", f"COIL{i}_A", f"COIL{i}_B"} <= texts


@needs_kicad
def test_drawing_joins_exactly_the_circuits_pins(tmp_path):
    """KiCad's netlist of the committed drawing is the circuit's; a label moved to another net is found."""
    circuit = hat.build_circuit(hat_board.hat_design(default_design()))
    schematic.check_connectivity(circuit, SHEETS / "hat.kicad_sch")
    bad = tmp_path / "schematic"
    shutil.copytree(SHEETS, bad)
    sheet = bad / "hat_bridge1.kicad_sch"
    text = sheet.read_text()
    assert '(label "COIL0_A"' in text
    sheet.write_text(text.replace('(label "COIL0_A"', '(label "COIL0_B"', 1))
    with pytest.raises(schematic.SchematicFailed, match="COIL0_"):
        schematic.check_connectivity(circuit, bad / "hat.kicad_sch")


@needs_kicad
def test_schematic_regenerates_byte_for_byte(tmp_path):
    """Drawing the committed design again gives the committed sheets and SVGs, byte for byte."""
    circuit = hat.build_circuit(hat_board.hat_design(default_design()))
    res = schematic.draw(circuit, tmp_path / "schematic")
    assert res["files"] == sorted(p.name for p in SHEETS.iterdir())
    for name in res["files"]:
        assert (tmp_path / "schematic" / name).read_bytes() == (SHEETS / name).read_bytes(), name


@needs_kicad
def test_a_wrong_symbol_is_refused_in_one_line_and_leaves_the_old_outputs(tmp_path, monkeypatch):
    """A symbol whose pins do not carry the part's pin numbers stops the build before routing; the
    previous output folder stays as it was."""
    out = tmp_path / "hat"
    out.mkdir()
    (out / "hat_summary.json").write_text("previous build\n")
    monkeypatch.setitem(schematic.SYMBOLS, "bridge", ("Device", "R"))   # 2 pins for the DRV8833's 17
    with pytest.raises(schematic.SchematicFailed, match=r"^U\d+: symbol R has 0 pins numbered \d+$"):
        hat_board.build_hat(default_design(), out, log=lambda m: None)
    assert [p.name for p in out.iterdir()] == ["hat_summary.json"]
    assert (out / "hat_summary.json").read_text() == "previous build\n"
    assert [p.name for p in tmp_path.iterdir()] == ["hat"]   # no staging folder left behind


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 400), st.floats(0, 280)), min_size=1, max_size=20),
       st.floats(0, 10))
def test_crop_svg_keeps_every_path_point(points, pad):
    """The cropped viewBox holds every path point with `pad` mm around it (less where the page edge is)."""
    d = " ".join(f"{x:.4f},{y:.4f}" for x, y in points)
    text = ('<svg width="420.0000mm" height="297.0000mm" viewBox="0.0000 0.0000 420.0000 297.0000">'
            f'<path d="M {d}" /></svg>')
    out = schematic.crop_svg(text, pad_mm=pad)
    x0, y0, w, h = map(float, re.search(r'viewBox="([^"]+)"', out).group(1).split())
    for x, y in points:
        assert x0 - 1e-3 <= x <= x0 + w + 1e-3 and y0 - 1e-3 <= y <= y0 + h + 1e-3
    assert x0 == pytest.approx(max(0.0, min(p[0] for p in points) - pad), abs=1e-3)
    assert x0 + w == pytest.approx(max(p[0] for p in points) + pad, abs=1e-3)
