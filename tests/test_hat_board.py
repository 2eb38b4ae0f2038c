"""The HAT's KiCad board (needs KiCad 9: pcbnew in the system python3 and kicad-cli; CI installs both
through scripts/system-deps, so these run there). Placement as pcbnew builds it, the plane fanout
(every GND/VM pad joined to its plane on copper: DRC finds no unconnected GND/VM item and no error on
the placed, plane-filled board), stable Gerber/drill bytes, and the SES unit fix for freeroute."""

from __future__ import annotations

import json
import re

import pytest

from whisker.design import default_design
from whisker.pcb import copper, fab, hat, kicad, layout

HAVE_KICAD, WHY = kicad.kicad_status()
needs_kicad = pytest.mark.skipif(not HAVE_KICAD, reason=f"KiCad 9 absent: {WHY}")


def test_ses_resolution_fix():
    ses = "(session x (routes (resolution um 10) (network_out (net A (wire (path F.Cu 300 0 0 1000 0))))))"
    assert "(resolution um 1)" in kicad.fix_ses_resolution(ses)
    assert "1000 0" in kicad.fix_ses_resolution(ses)  # coordinates untouched


def test_router_dsn_keeps_planes_out_and_adds_keepouts():
    dsn = ("(pcb x (structure (rule (width 200) (clearance 200) (clearance 50 (type smd_smd))))\n"
           "  (network\n    (net GND\n      (pins U1-1 U2-1)\n    )\n    (net SIG\n      (pins U1-2 U2-2)\n    )\n  ))")
    spec = {"rules": {"router_clearance": 0.33}, "vias": [{"at": [1.0, 2.0], "diameter": 0.45}],
            "tracks": [{"start": [0, 0], "end": [1, 0], "width": 0.2, "layer": "F.Cu"}]}
    out = kicad.router_dsn(dsn, spec, ["GND"])
    assert "(net GND" not in out and "(net SIG" in out
    assert "(clearance 330.0)" in out and "(clearance 50 (type smd_smd))" in out
    assert out.count("(keepout") == 3   # the via on F.Cu and B.Cu, the track on F.Cu
    assert "(rect F.Cu 775.0 -2225.0 1225.0 -1775.0)" in out  # DSN y points up


@pytest.fixture(scope="module")
def placed(tmp_path_factory):
    if not HAVE_KICAD:
        pytest.skip(f"KiCad 9 absent: {WHY}")
    work = tmp_path_factory.mktemp("hat")
    d = default_design('driver.type="HAT"')
    spec = layout.place(hat.build_circuit(d))
    (work / "spec.json").write_text(json.dumps(spec))
    first = kicad.run_job("build", work, spec=work / "spec.json", board=work / "placed.kicad_pcb", dsn="")
    tracks, vias = kicad.fanout(spec, first["pads"])
    (work / "spec.json").write_text(json.dumps({**spec, "tracks": tracks, "vias": vias}))
    kicad.run_job("build", work, spec=work / "spec.json", board=work / "unrouted.kicad_pcb", dsn=work / "b.dsn")
    kicad.run_job("fill", work, board=work / "unrouted.kicad_pcb", out=work / "filled.kicad_pcb")
    return work, d, spec, first


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
