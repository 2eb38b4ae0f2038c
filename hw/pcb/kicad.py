"""From the HAT circuit to a routed, checked KiCad 9 board, headless.

Steps (``route_board``): placement spec (whisker.pcb.layout) -> pcbnew builds the board in the system
python3 (``kicad_job.py``: KiCad's module lives there, not in the virtualenv) -> every GND/VM pad gets
its via to its plane (``fanout``, checked against every pad and via for clearance) -> the copper of
that board (pads as pcbnew shapes them) -> the signal nets routed by whisker.pcb.router (deterministic
negotiated-congestion routing over an A* maze search; the pure-Python ``freeroute`` port mis-scaled its
session, ignored pre-placed copper and dropped the 0.65 mm-pitch nets) -> the board rebuilt with those
tracks, zones filled ->
``kicad-cli pcb drc`` as the gate.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

from whisker.errors import EnvironmentFault

from . import copper, router

JOB = Path(__file__).with_name("kicad_job.py")
SYSTEM_PYTHON = os.environ.get("WHISKER_KICAD_PYTHON", "/usr/bin/python3")
KICAD_VERSION = "9.0"
INSTALL_HINT = ("KiCad 9 is needed for the board (kicad-cli and its python3 module): "
                "run scripts/system-deps (Debian: apt-get install -t bookworm-backports kicad kicad-footprints)")
KEEP_WORK = bool(os.environ.get("WHISKER_KEEP_PCB_WORK"))


class KicadMissing(EnvironmentFault):
    """KiCad 9 (kicad-cli, pcbnew for the system python3, footprints) is not installed."""


class BoardFailed(RuntimeError):
    """Routing or DRC did not give a clean board (one line)."""


def kicad_cli() -> str:
    return shutil.which("kicad-cli") or ""


def kicad_status() -> tuple[bool, str]:
    """(ok, one line): kicad-cli 9.x and pcbnew in the system python3."""
    cli = kicad_cli()
    if not cli:
        return False, INSTALL_HINT
    try:
        ver = subprocess.run([cli, "version"], capture_output=True, text=True, timeout=60).stdout.strip()
    except (OSError, subprocess.SubprocessError) as err:
        return False, f"kicad-cli does not run ({err}); {INSTALL_HINT}"
    if not ver.startswith(KICAD_VERSION):
        return False, f"kicad-cli {ver} found, {KICAD_VERSION}.x needed; {INSTALL_HINT}"
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import pcbnew; print(pcbnew.Version())"],
                           capture_output=True, text=True, timeout=120)
    if probe.returncode != 0:
        return False, f"{SYSTEM_PYTHON} cannot import pcbnew; {INSTALL_HINT}"
    return True, f"kicad-cli {ver}, pcbnew {probe.stdout.strip()}"


def require_kicad() -> None:
    ok, line = kicad_status()
    if not ok:
        raise KicadMissing(line)


def run_job(op: str, tmp: Path, **kw) -> dict:
    """Run one kicad_job op in the system python3; returns its JSON result (if any)."""
    job = {"op": op, **{k: str(v) for k, v in kw.items()}}
    job["result"] = str(tmp / f"{op}.result.json")
    path = tmp / f"{op}.job.json"
    path.write_text(json.dumps(job))
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHONHOME", "PYTHONPATH"))}
    proc = subprocess.run([SYSTEM_PYTHON, str(JOB), str(path)], capture_output=True, text=True, env=env,
                          timeout=900)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["?"])[-1]
        raise BoardFailed(f"pcbnew job {op!r} failed: {tail}")
    res = Path(job["result"])
    return json.loads(res.read_text()) if res.exists() else {}


# --------------------------------------------------------------------------------------------------
# fanout: a via from every GND / VM pad to its plane
# --------------------------------------------------------------------------------------------------

def fanout(spec: dict, pads: list[dict]) -> tuple[list[dict], list[dict]]:
    """(tracks, vias) joining each SMD pad on a plane net to its plane.

    A pad whose footprint has a through-hole (thermal-via) pad on the same net is joined to that pad
    by a short track inward; any other pad gets a via outward (away from its footprint's centre),
    moved further out or sideways until it clears every other pad, track and via by the clearance,
    and every SMD pad (its own net's too: no via in or at a pad) by the clearance.
    """
    from shapely.geometry import LineString, Point, box

    r = spec["rules"]
    clr, via_d, w = r["clearance"], r["via_diameter"], min(r["track_width"], 0.3)
    power = set(spec["power_nets"])
    obstacles = []   # (net, geometry) on the top layer (vias also on every layer)
    for p in pads:
        x0, y0, x1, y1 = p["bbox"]
        obstacles.append((p["net"], box(x0, y0, x1, y1), p))
    tracks, vias = [], []

    def clear(net, geom):
        for onet, og, *_ in obstacles:
            if onet != net and geom.distance(og) < clr:
                return False
        return True

    # no via copper on or near an SMD pad of any net, its own included (via-in-pad wicks the solder away
    # from the joint): the same rule as the router's grid (whisker.pcb.maze.Grid.mark, smd=True)
    smd_boxes = [box(*p["bbox"]) for p in pads if not p["through"]]

    def off_smd(via):
        return all(via.distance(b) >= clr for b in smd_boxes)

    through_by, on_plane = {}, {}
    for p in pads:
        if p["through"] and p["net"]:
            through_by.setdefault((p["ref"], p["net"]), []).append(p)
    for p in pads:  # exposed pads carrying thermal vias: on the plane already, and a target for tracks
        ths = through_by.get((p["ref"], p["net"]), [])
        if not p["through"] and any(box(*t["bbox"]).intersects(box(*p["bbox"])) for t in ths):
            on_plane.setdefault((p["ref"], p["net"]), []).append(p)
    # neighbouring pins of one part on the same plane net (a row of address straps, say) are joined by a
    # track along the row and share one via: only the first pin of each such group needs room for a via
    done_group: set = set()
    group_of: dict[int, int] = {}
    smd = [p for p in pads if p["net"] in power and not p["through"] and not p["bottom"] and p["pad"]]
    for i, a in enumerate(smd):
        for j in range(i):
            b = smd[j]
            if a["ref"] == b["ref"] and a["net"] == b["net"] and \
                    math.dist(a["at"], b["at"]) <= 0.7 and not on_plane.get((a["ref"], a["net"])):
                g = group_of.get(id(b), id(b))
                group_of[id(a)] = g
                group_of.setdefault(id(b), g)
                tracks.append({"start": list(b["at"]), "end": list(a["at"]), "width": w, "layer": "F.Cu",
                               "net": a["net"]})
                obstacles.append((a["net"], LineString([b["at"], a["at"]]).buffer(w / 2), None))
                break
    for p in pads:
        if p["net"] not in power or p["through"] or p["bottom"] or not p["pad"]:
            continue
        g = group_of.get(id(p))
        if g is not None and g in done_group:
            continue
        (px, py), (fx, fy) = p["at"], p["fp_at"]
        x0, y0, x1, y1 = p["bbox"]
        hx, hy = (x1 - x0) / 2, (y1 - y0) / 2
        dx, dy = px - fx, py - fy
        if p["ref"][0] in "RC":  # a passive's pad: away from the part's centre
            horizontal = abs(dx) >= abs(dy)
        elif hx > 1.3 * hy:      # an IC pin is long along its way out of the package
            horizontal = True
        elif hy > 1.3 * hx:
            horizontal = False
        else:                  # square-ish (a passive's pad): away from the part's centre
            horizontal = abs(dx) >= abs(dy)
        axis = (1.0 if dx >= 0 else -1.0, 0.0) if horizontal else (0.0, 1.0 if dy >= 0 else -1.0)
        anchors = on_plane.get((p["ref"], p["net"]))
        if anchors and any(a is p for a in anchors):
            continue  # an exposed pad with its own thermal vias: already on the plane
        if anchors:
            target = max(anchors, key=lambda a: (a["bbox"][2] - a["bbox"][0]) * (a["bbox"][3] - a["bbox"][1]))
            ax, ay = axis
            reach = hx if ax else hy
            # inward along the pad's axis until inside the anchor's copper
            tx0, ty0, tx1, ty1 = target["bbox"]
            if ax:
                end = (min(max(px, tx0 + 0.3), tx1 - 0.3), py)
            else:
                end = (px, min(max(py, ty0 + 0.3), ty1 - 0.3))
            if tx0 <= end[0] <= tx1 and ty0 <= end[1] <= ty1 and reach >= 0:
                tracks.append({"start": [px, py], "end": list(end), "width": w, "layer": "F.Cu", "net": p["net"]})
                obstacles.append((p["net"], LineString([(px, py), end]).buffer(w / 2), None))
                continue
        placed = False
        reach = hx if axis[0] else hy
        perp = (axis[1], axis[0])
        for extra in (0.0, 0.5, 1.0, 1.6, 2.4):
            for side in (0.0, 0.7, -0.7, 1.4, -1.4):
                d = reach + clr + via_d / 2 + 0.05 + extra
                vx = px + axis[0] * d + perp[0] * side
                vy = py + axis[1] * d + perp[1] * side
                via = Point(vx, vy).buffer(via_d / 2)
                path = [(px, py), (px + axis[0] * d, py + axis[1] * d), (vx, vy)]
                line = LineString(path).buffer(w / 2)
                if not (clear(p["net"], via) and clear(p["net"], line) and off_smd(via)):
                    continue
                bx0, by0, bx1, by1 = via.bounds
                if bx0 < 0.6 or by0 < 0.6 or bx1 > spec["board"]["width"] - 0.6 or by1 > spec["board"]["height"] - 0.6:
                    continue
                for a, b in zip(path, path[1:]):
                    if a != b:
                        tracks.append({"start": list(a), "end": list(b), "width": w, "layer": "F.Cu", "net": p["net"]})
                vias.append({"at": [vx, vy], "diameter": via_d, "drill": r["via_drill"], "net": p["net"]})
                obstacles.append((p["net"], via, None))
                obstacles.append((p["net"], line, None))
                if g is not None:
                    done_group.add(g)
                placed = True
                break
            if placed:
                break
        if not placed and g is not None:
            continue  # another pin of its group may still find room
        if not placed:
            raise BoardFailed(f"no room for the {p['net']} via of {p['ref']} pad {p['pad']}")
    return tracks, vias


# --------------------------------------------------------------------------------------------------
# routing
# --------------------------------------------------------------------------------------------------

# --------------------------------------------------------------------------------------------------
# DRC
# --------------------------------------------------------------------------------------------------

def drc(board: Path, out_json: Path) -> dict:
    """kicad-cli pcb drc (all severities, zones refilled): counts of errors, warnings, unconnected."""
    proc = subprocess.run([kicad_cli(), "pcb", "drc", "--format", "json", "--severity-all",
                           "--units", "mm", "-o", str(out_json), str(board)],
                          capture_output=True, text=True, timeout=900)
    if not out_json.exists():
        raise BoardFailed(f"kicad-cli pcb drc wrote no report: {proc.stderr.strip()[-200:]}")
    rep = json.loads(out_json.read_text())
    viol = rep.get("violations", [])
    errors = [v for v in viol if v.get("severity") == "error"]
    warnings = [v for v in viol if v.get("severity") == "warning"]
    unconnected = rep.get("unconnected_items", [])
    return {"errors": len(errors), "warnings": len(warnings), "unconnected": len(unconnected),
            "error_types": sorted({v.get("type", "?") for v in errors}),
            "warning_types": sorted({v.get("type", "?") for v in warnings}),
            "first_error": (errors[0].get("description", "") if errors else ""),
            "first_unconnected": (unconnected[0].get("items", [{}])[0].get("description", "") if unconnected else "")}


def route_board(spec: dict, work: Path, log=print) -> dict:
    """Build, fan out, route and check the board in `work`; returns paths and the DRC counts."""
    work.mkdir(parents=True, exist_ok=True)
    spec_path = work / "spec.json"
    spec_path.write_text(json.dumps(spec, indent=1))
    log("pcb: placing parts (pcbnew)")
    first = run_job("build", work, spec=spec_path, board=work / "placed.kicad_pcb", dsn="")
    tracks, vias = fanout(spec, first["pads"])
    spec2 = {**spec, "tracks": [*spec.get("tracks", []), *tracks], "vias": [*spec.get("vias", []), *vias]}
    spec_path.write_text(json.dumps(spec2, indent=1))
    board0 = work / "unrouted.kicad_pcb"
    run_job("build", work, spec=spec_path, board=board0, dsn="")
    items = run_job("copper", work, board=board0)["items"]
    nets = sorted({it["net"] for it in items if it["kind"] == "pad" and it.get("net")} - set(spec["power_nets"]))
    log(f"pcb: routing {len(nets)} signal nets (whisker.pcb.router: PathFinder, A* on a {router.STEP} mm grid)")
    try:
        r_tracks, r_vias = router.route(items, spec2, nets, log=log)
    except router.RouteFailed as err:
        raise BoardFailed(str(err)) from None
    spec3 = {**spec2, "tracks": [*spec2["tracks"], *r_tracks], "vias": [*spec2["vias"], *r_vias]}
    spec_path.write_text(json.dumps(spec3, indent=1))
    run_job("build", work, spec=spec_path, board=work / "routed_unfilled.kicad_pcb", dsn="")
    routed = work / "board.kicad_pcb"
    run_job("fill", work, board=work / "routed_unfilled.kicad_pcb", out=routed)
    log("pcb: kicad-cli pcb drc")
    report = drc(routed, work / "drc.json")
    # KiCad's DRC allows a via in a pad of its own net: the no-via-in-SMD-pad rule is checked on the copper
    on_pads = copper.vias_on_smd_pads(run_job("copper", work, board=routed)["items"])
    return {"board": routed, "drc": report, "fanout_vias": len(vias), "routed_tracks": len(r_tracks),
            "routed_vias": len(r_vias), "vias_on_smd_pads": on_pads}


if __name__ == "__main__":  # pragma: no cover - manual runs
    print(kicad_status()[1], file=sys.stderr)
