"""No via on an SMD pad (issue 28): an unfilled via in or touching an SMD pad wicks the solder away from
the joint during reflow, and fabs take it only as paid "via-in-pad, filled and capped". The router's grid
(whisker.pcb.maze.Grid.mark, smd=True) and the plane fan-out (whisker.pcb.kicad.fanout) keep every via
beside the pads; whisker.pcb.copper.vias_on_smd_pads checks the board's copper (and gates `make pcb`).
The board routed before the rule had 40 of its 164 vias on SMD pads (U2 pin 9, U3 pins 9 and 16, ...)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from whisker.pcb import board as hat_board
from whisker.pcb import copper, kicad, maze, router

HAVE_KICAD, WHY = kicad.kicad_status()
ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "hw" / "pcb" / "generated"
RULES = {"clearance": 0.2, "track_width": 0.2, "via_diameter": 0.45, "via_drill": 0.2, "edge_clearance": 0.2}


def _square(pid, net, layer, x, y, half=0.4, through=False):
    return {"kind": "pad", "id": pid, "layer": layer, "net": net, "at": [x, y], "through": through,
            "polys": [[[x - half, y - half], [x + half, y - half], [x + half, y + half], [x - half, y + half]]]}


@pytest.mark.skipif(not HAVE_KICAD, reason=f"KiCad 9 absent (CI installs it): {WHY}")
def test_committed_default_board_has_no_via_on_an_smd_pad(tmp_path):
    """hw/pcb/generated/hat/hat.kicad_pcb (the only size whose board file is committed): every via's disc
    clears every SMD pad polygon that pcbnew reports, of any net; and the check sees a via put on a pad."""
    items = kicad.run_job("copper", tmp_path, board=GENERATED / "hat" / "hat.kicad_pcb")["items"]
    vias = [it for it in items if it["kind"] == "via"]
    assert len(vias) > 100
    assert copper.vias_on_smd_pads(items) == []
    # the check can fail on this board: a via beside U2 pin 9 (COIL3_FWD, 0.65 mm pitch), its disc
    # reaching 0.1 mm into the pad, is reported
    pad = next(it for it in items if it["kind"] == "pad" and it["id"] == "U2:9")
    xs = [p[0] for p in pad["polys"][0]]
    via = {**vias[0], "at": [max(xs) + vias[0]["radius"] - 0.1, pad["at"][1]], "net": pad["net"]}
    assert [line for line in copper.vias_on_smd_pads([*items, via]) if "U2:9" in line]


@pytest.mark.parametrize("folder", sorted(hat_board.SIZES))
def test_committed_board_summaries_have_no_via_on_an_smd_pad(folder):
    """Every size `make pcb` / `make hat-sizes` keeps (6, 8, 12 coils) passed the via-in-pad gate: its
    summary counts the vias on SMD pads of the routed board (test_hat_routed checks the summary is current)."""
    summary = json.loads((GENERATED / folder / "hat_summary.json").read_text())
    assert summary["vias_on_smd_pads"] == 0
    assert summary["routed"]["routed_vias"] > 0


def test_grid_blocks_vias_of_every_net_on_an_smd_pad():
    """An SMD pad takes its own net's track centres but no via centre of any net within clearance + via
    radius of its polygon; a through-hole pad takes its own net's vias."""
    import shapely

    grid = maze.Grid(4.0, 4.0, RULES, [(0, 0), (4, 0), (4, 4), (0, 4)])
    pad = shapely.box(1.6, 1.6, 2.4, 2.4)
    r_t = grid.reach(grid.w / 2)
    r_v = grid.reach(grid.via_d / 2)
    grid.mark(0, pad, 7, r_t, r_v, smd=True)
    grid.mark(1, shapely.box(0.6, 0.6, 1.0, 1.0), 7, r_t, r_v)          # a through pad's B.Cu copper
    j, i = int(2.0 / maze.STEP), int(2.0 / maze.STEP)
    assert grid.t[0][j, i] == 7 and grid.v[0][j, i] == maze.BLOCKED      # pad centre: track yes, via no
    k = int(round((2.4 + r_v + 0.05) / maze.STEP))                        # just beyond the via keep-out
    assert grid.v[0][j, k] == maze.FREE
    assert grid.v[0][j, int(round((2.4 + r_v - 0.05) / maze.STEP))] == maze.BLOCKED
    assert grid.v[1][int(0.8 / maze.STEP), int(0.8 / maze.STEP)] == 7   # through pad: own via allowed
    free_t, free_v = grid.free(7)
    n = grid.nx * grid.ny
    assert free_t[j * grid.nx + i] == 1 and free_v[j * grid.nx + i] == 0
    assert free_v[n + int(0.8 / maze.STEP) * grid.nx + int(0.8 / maze.STEP)] == 1


def test_router_puts_the_via_beside_smd_pads():
    """Pad A on F.Cu over pad B on B.Cu, same net: without the rule the cheapest route is one via inside
    both pads (what the router did while pads counted as through-hole); with SMD pads the via sits beside
    them, its disc at least the clearance from both polygons, joined by short tracks (a fan-out)."""
    import shapely

    spec = {"board": {"width": 6.0, "height": 6.0}, "rules": RULES}
    smd = [_square("A:1", "S", "F.Cu", 3.0, 3.0), _square("B:1", "S", "B.Cu", 3.0, 3.0)]
    tracks, vias = router.route(smd, spec, ["S"], log=lambda m: None)
    assert len(vias) == 1 and tracks
    square = shapely.box(2.6, 2.6, 3.4, 3.4)
    for v in vias:
        assert shapely.Point(v["at"]).distance(square) >= RULES["clearance"] + v["diameter"] / 2 - 1e-9
    as_items = [{"kind": "via", "at": v["at"], "radius": v["diameter"] / 2, "net": v["net"]} for v in vias]
    assert copper.vias_on_smd_pads([*smd, *as_items]) == []
    # the same pads taken as through-hole copper: nothing keeps the via out, and it lands in the pads
    th = [{**p, "through": True} for p in smd]
    _t, vias_th = router.route(th, spec, ["S"], log=lambda m: None)
    on = copper.vias_on_smd_pads([*smd, *({"kind": "via", "at": v["at"], "radius": v["diameter"] / 2,
                                            "net": v["net"]} for v in vias_th)])
    assert len(on) == 1 and "A:1, B:1" in on[0]


def test_plane_fanout_keeps_its_vias_off_smd_pads_of_its_own_net():
    """Two GND pads of two parts face each other 1 mm apart: each pad's first via spot (outward, the
    clearance past its pad) lands on the other part's pad. The fan-out moves both vias until their discs
    clear every SMD pad by the clearance (other nets' pads were kept clear before; its own net's now too)."""
    import shapely

    def pad(ref, num, x, fx):
        return {"ref": ref, "pad": num, "net": "GND", "at": [x, 5.0], "fp_at": [fx, 5.0],
                "bbox": [x - 0.25, 4.7, x + 0.25, 5.3], "through": False, "bottom": False}

    pads = [pad("R1", "1", 5.0, 4.5), pad("C1", "2", 6.0, 6.5)]
    spec = {"board": {"width": 12.0, "height": 10.0}, "power_nets": ["GND"],
            "rules": {**RULES, "track_width": 0.25}}
    tracks, vias = kicad.fanout(spec, pads)
    assert len(vias) == 2 and tracks
    for v in vias:
        for p in pads:
            gap = shapely.Point(v["at"]).distance(shapely.box(*p["bbox"])) - v["diameter"] / 2
            assert gap >= RULES["clearance"] - 1e-9, (v["at"], p["ref"])
