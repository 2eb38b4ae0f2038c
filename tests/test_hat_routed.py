"""The routed HAT (hw/pcb/generated/hat/hat.kicad_pcb, made by `make pcb`; KiCad 9 needed to read it,
which CI installs through scripts/system-deps). The pin map is checked on the board's copper: pcbnew
reports every pad, track, via and filled plane as geometry and whisker.pcb.copper joins what touches,
without looking at net names. The slow test routes the default board again from the design and
compares its Gerber and drill files byte for byte with the committed ones. The 6- and 12-coil boards
(`make hat-sizes`) are kept as summaries: the test checks they are current and passed the DRC gate;
benchmarks/bench_hat.py routes all three again (pin map on copper, Gerbers' sha256, route time)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from whisker.design import default_design
from whisker.pcb import board as hat_board
from whisker.pcb import copper, fab, kicad, router

HAVE_KICAD, WHY = kicad.kicad_status()
needs_kicad = pytest.mark.skipif(not HAVE_KICAD, reason=f"KiCad 9 absent: {WHY}")
ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "hw" / "pcb" / "generated" / "hat"


SIZES = hat_board.SIZES   # folder -> design overrides (make pcb, make hat-sizes)


@pytest.mark.parametrize("folder", sorted(SIZES))
def test_committed_board_is_current(folder):
    """The committed routed board (for 6 and 12 coils: its summary) was made from today's placement and
    today's routing/export code, passed the DRC gate, and lists the sha256 of its Gerber/drill files."""
    d = default_design(*SIZES[folder])
    _c, _r, spec = hat_board.prepare(d)
    summary = json.loads((GENERATED.parent / folder / "hat_summary.json").read_text())
    assert summary["whiskers"] == d.whiskers.count
    assert summary.get("input_digest") == hat_board.input_digest(spec), \
        f"run `make {'pcb' if folder == 'hat' else 'hat-sizes'}` and commit"
    assert summary["drc"]["errors"] == 0 and summary["drc"]["unconnected"] == 0
    drc = json.loads((GENERATED.parent / folder / "drc.json").read_text())
    assert drc == summary["drc"]
    assert sorted(summary["gerbers_sha256"]) == summary["gerbers"]
    assert any(n.endswith(".drl") for n in summary["gerbers"])
    if folder == "hat":   # the default board keeps its Gerbers: they are the files the summary hashes
        gerbers = GENERATED / "gerbers"
        assert sorted(p.name for p in gerbers.iterdir()) == summary["gerbers"]
        for n in summary["gerbers"]:
            assert hashlib.sha256((gerbers / n).read_bytes()).hexdigest() == summary["gerbers_sha256"][n], n


@needs_kicad
def test_pin_map_on_the_copper_of_the_routed_board(tmp_path):
    """Every coil connector reaches its bridge's outputs, every bridge input the GPIO pin (or PCA9685
    output) of whisker.drive.pins.pin_map, and no two of those signals share copper."""
    res = kicad.run_job("copper", tmp_path, board=GENERATED / "hat.kicad_pcb")
    cl = copper.clusters(res["items"])
    d = hat_board.hat_design(default_design())
    assert copper.check_pin_map(d, cl) == []
    # and the check can fail on this board: cut one routed coil track and its coil is reported
    items = res["items"]
    pad = next(it for it in items if it["kind"] == "pad" and it["id"] == "J10:1")
    cut = [it for it in items if not (it["kind"] == "track" and it.get("net") == pad["net"])]
    assert any("coil 0 pin 1" in p for p in copper.check_pin_map(d, copper.clusters(cut)))


def test_router_keeps_clearance_on_a_toy_board():
    """Two nets crossing a wall with one gap: the router goes through the gap, keeping the clearance
    from the wall's copper, and a second identical run gives the same tracks (deterministic)."""
    import shapely

    def rect(x0, y0, x1, y1):
        return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]

    items = [{"kind": "pad", "id": "A:1", "layer": "F.Cu", "net": "S", "at": [1.0, 1.0], "polys": [rect(0.5, 0.5, 1.5, 1.5)]},
             {"kind": "pad", "id": "B:1", "layer": "F.Cu", "net": "S", "at": [9.0, 1.0], "polys": [rect(8.5, 0.5, 9.5, 1.5)]},
             {"kind": "pad", "id": "W:1", "layer": "F.Cu", "net": "X", "at": [5.0, 2.0], "polys": [rect(4.8, 0.0, 5.2, 4.0)]},
             {"kind": "pad", "id": "W:2", "layer": "B.Cu", "net": "X", "at": [5.0, 2.0], "polys": [rect(4.8, 0.0, 5.2, 4.0)]}]
    spec = {"board": {"width": 10.0, "height": 6.0},
            "rules": {"clearance": 0.2, "track_width": 0.2, "via_diameter": 0.45, "via_drill": 0.2,
                      "edge_clearance": 0.2}}
    tracks, vias = router.route(items, spec, ["S"], log=lambda m: None)
    assert tracks and tracks == router.route(items, spec, ["S"], log=lambda m: None)[0]
    wall = shapely.box(4.8, 0.0, 5.2, 4.0)
    for t in tracks:
        seg = shapely.LineString([t["start"], t["end"]])
        assert seg.distance(wall) >= 0.2 + t["width"] / 2 - 1e-9
        assert seg.bounds[3] <= 6.0 - 0.2 - t["width"] / 2 + 1e-9
    assert max(max(t["start"][1], t["end"][1]) for t in tracks) > 4.0   # it went round the wall


def test_router_negotiates_two_crossing_nets_apart():
    """Two nets whose straight paths cross, pads on the top layer only: the first pass lets them share
    room, the negotiation then moves them apart, and the result keeps the clearance between every track
    and via of different nets (checked with shapely on the segments, not on the router's grid)."""
    import shapely

    def pad(pid, net, x, y):
        return {"kind": "pad", "id": pid, "layer": "F.Cu", "net": net, "at": [x, y],
                "polys": [[[x - 0.4, y - 0.4], [x + 0.4, y - 0.4], [x + 0.4, y + 0.4], [x - 0.4, y + 0.4]]]}

    # long enough runs that B.Cu (vias beside the SMD pads, at F.Cu's extra cost saved) pays for both nets
    items = [pad("A:1", "S", 1.0, 5.0), pad("B:1", "S", 9.0, 5.0), pad("C:1", "T", 5.0, 0.8), pad("D:1", "T", 5.0, 9.2)]
    rules = {"clearance": 0.2, "track_width": 0.2, "via_diameter": 0.45, "via_drill": 0.2, "edge_clearance": 0.2}
    spec = {"board": {"width": 10.0, "height": 10.0}, "rules": rules}
    log: list[str] = []
    tracks, vias = router.route(items, spec, ["S", "T"], log=log.append)
    assert "sharing room" in log[0] and log[-1].endswith("2/2 nets clear"), log
    assert {t["net"] for t in tracks} == {"S", "T"} and vias   # one of them changes layer to cross
    copper = [(t["net"], {t["layer"]}, shapely.LineString([t["start"], t["end"]]), t["width"] / 2) for t in tracks]
    copper += [(v["net"], {"F.Cu", "B.Cu"}, shapely.Point(v["at"]), v["diameter"] / 2) for v in vias]
    for na, la, ga, ra in copper:
        for nb, lb, gb, rb in copper:
            if na != nb and la & lb:
                assert ga.distance(gb) >= rules["clearance"] + ra + rb - 1e-9, (na, nb)


@needs_kicad
@pytest.mark.slow
def test_default_board_routes_again_to_the_same_gerbers(tmp_path):
    """Route the default design from scratch (the router is deterministic): DRC 0 errors / 0 unconnected
    and Gerber + drill files identical to the committed ones, byte for byte."""
    _c, _r, spec = hat_board.prepare(default_design())
    res = kicad.route_board(spec, tmp_path / "work", log=lambda m: None)
    assert res["drc"]["errors"] == 0 and res["drc"]["unconnected"] == 0, res["drc"]
    board = tmp_path / "hat.kicad_pcb"   # the file name is in the Gerbers (project name, GUID)
    shutil.copy(res["board"], board)
    names = fab.gerbers(board, tmp_path / "g")
    assert names == sorted(p.name for p in (GENERATED / "gerbers").iterdir())
    for n in names:
        assert (tmp_path / "g" / n).read_bytes() == (GENERATED / "gerbers" / n).read_bytes(), n
