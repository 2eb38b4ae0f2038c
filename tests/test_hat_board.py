"""The HAT's KiCad board (needs KiCad 9: pcbnew in the system python3 and kicad-cli; CI installs both
through scripts/system-deps, so these run there). Placement as pcbnew builds it, the plane fanout
(every GND/VM pad joined to its plane on copper: DRC finds no unconnected GND/VM item and no error on
the placed, plane-filled board) and stable Gerber/drill bytes. The routed board: tests/test_hat_routed.py."""

from __future__ import annotations

import json
import re

import pytest

from whisker.design import default_design
from whisker.pcb import copper, fab, hat, kicad, layout

HAVE_KICAD, WHY = kicad.kicad_status()
needs_kicad = pytest.mark.skipif(not HAVE_KICAD, reason=f"KiCad 9 absent: {WHY}")


@pytest.fixture(scope="module")
def placed(tmp_path_factory):
    if not HAVE_KICAD:
        pytest.skip(f"KiCad 9 absent: {WHY}")
    work = tmp_path_factory.mktemp("hat")
    d = default_design('driver.type="HAT"')
    spec, first = _place_and_fan_out(d, work)
    kicad.run_job("fill", work, board=work / "unrouted.kicad_pcb", out=work / "filled.kicad_pcb")
    return work, d, spec, first


def _place_and_fan_out(d, work):
    """Place the design's HAT (placed.kicad_pcb), fan its plane pads out (unrouted.kicad_pcb): (spec, pads)."""
    spec = layout.place(hat.build_circuit(d))
    (work / "spec.json").write_text(json.dumps(spec))
    first = kicad.run_job("build", work, spec=work / "spec.json", board=work / "placed.kicad_pcb", dsn="")
    tracks, vias = kicad.fanout(spec, first["pads"])
    (work / "spec.json").write_text(json.dumps({**spec, "tracks": tracks, "vias": vias}))
    kicad.run_job("build", work, spec=work / "spec.json", board=work / "unrouted.kicad_pcb", dsn="")
    return spec, first


@needs_kicad
def test_header_pins_land_where_the_hat_spec_says(placed):
    _work, _d, _spec, first = placed
    at = {p["pad"]: p["at"] for p in first["pads"] if p["ref"] == "J1"}
    mech = layout.hat_spec()["header"]
    cx, cy = mech["centre"]
    assert at["1"] == pytest.approx([cx - 9.5 * 2.54, cy + 1.27], abs=1e-3)
    assert at["2"] == pytest.approx([cx - 9.5 * 2.54, cy - 1.27], abs=1e-3)   # 5 V row at the edge
    assert at["40"] == pytest.approx([cx + 9.5 * 2.54, cy - 1.27], abs=1e-3)


@needs_kicad
def test_planes_join_every_gnd_and_vm_pad(placed):
    work, d, _spec, _first = placed
    rep = kicad.drc(work / "filled.kicad_pcb", work / "drc.json")
    assert rep["errors"] == 0, rep
    raw = json.loads((work / "drc.json").read_text())
    plane_unconnected = [u for u in raw["unconnected_items"]
                         if re.search(r"\[(GND|VM)\]", u["items"][0]["description"])]
    assert plane_unconnected == []
    # and on copper (geometry, not labels): all GND pads in one cluster, all VM pads in another
    res = kicad.run_job("copper", work, board=work / "filled.kicad_pcb")
    cl = copper.clusters(res["items"])
    nets = hat.pad_nets(hat.build_circuit(d))
    for net in ("GND", "VM"):
        pads = {f"{ref}:{num}" for ref, m in nets.items() for num, n in m.items() if n == net}
        assert len({cl[p] for p in pads if p in cl}) == 1, net
    gnd = {cl[f"{r}:{k}"] for r, m in nets.items() for k, n in m.items() if n == "GND" and f"{r}:{k}" in cl}
    vm = {cl[f"{r}:{k}"] for r, m in nets.items() for k, n in m.items() if n == "VM" and f"{r}:{k}" in cl}
    assert gnd.isdisjoint(vm)


@needs_kicad
def test_gerbers_and_drill_are_byte_stable(placed, tmp_path):
    work, *_ = placed
    a = fab.gerbers(work / "filled.kicad_pcb", tmp_path / "a")
    b = fab.gerbers(work / "filled.kicad_pcb", tmp_path / "b")
    assert a == b and any(n.endswith(".drl") for n in a) and any("Edge_Cuts" in n for n in a)
    for n in a:
        assert (tmp_path / "a" / n).read_bytes() == (tmp_path / "b" / n).read_bytes(), n
        assert "CreationDate" not in (tmp_path / "a" / n).read_text()


@needs_kicad
def test_twelve_coil_placement_has_no_drc_error(tmp_path):
    """12 coils (3 connectors up the left edge, two PCA9685s, four INA3221s): every part placed and
    every plane pad fanned out without a DRC error (courtyards, clearances) before routing."""
    d = default_design('driver.type="HAT"', "whiskers.count=12", 'wiring.expander="pca9685"',
                       "wiring.pca9685_address=0x44")
    _place_and_fan_out(d, tmp_path)
    rep = kicad.drc(tmp_path / "unrouted.kicad_pcb", tmp_path / "drc.json")
    assert rep["errors"] == 0, rep
