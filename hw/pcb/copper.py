"""Copper connectivity of a routed board, from its geometry alone (not from the net labels).

``kicad_job.py copper`` dumps every pad, track, via and filled zone with its polygon and layer; here
items that touch on a shared copper layer are joined (union-find over a shapely STRtree), through
pads and vias join all layers. :func:`check_pin_map` then asks the board what the pin map says: each
coil connector's two pins reach its bridge's two outputs, each bridge input reaches the GPIO header pin
(or the PCA9685 output) that ``whisker.drive.pins.pin_map`` gives, and no two of those signals share
copper.
"""

from __future__ import annotations

from whisker.drive.pins import HEADER_PIN

COPPER = ("F.Cu", "In1.Cu", "In2.Cu", "B.Cu")


def _geoms(items: list[dict]):
    from shapely.geometry import LineString, Point, Polygon

    for it in items:
        k = it["kind"]
        if k == "track":
            g = LineString([it["start"], it["end"]]).buffer(it["width"] / 2)
            layers = (it["layer"],)
        elif k == "via":
            g = Point(it["at"]).buffer(it["radius"])
            layers = COPPER
        else:
            polys = [Polygon(p) for p in it["polys"] if len(p) >= 3]
            if not polys:
                continue
            g = polys[0]
            for p in polys[1:]:
                g = g.union(p)
            layers = COPPER if it.get("through") else (it["layer"],)
        yield it, g.buffer(0), layers


def clusters(items: list[dict]) -> dict[str, int]:
    """pad id ("REF:PAD") -> copper cluster number (equal numbers = joined by copper)."""
    from shapely.strtree import STRtree

    geo = list(_geoms(items))
    parent = list(range(len(geo)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for layer in COPPER:
        idx = [i for i, (_it, _g, ls) in enumerate(geo) if layer in ls]
        shapes = [geo[i][1] for i in idx]
        if not shapes:
            continue
        tree = STRtree(shapes)
        for a_local, ga in enumerate(shapes):
            for b_local in tree.query(ga, predicate="intersects"):
                if b_local > a_local:
                    ra, rb = find(idx[a_local]), find(idx[int(b_local)])
                    if ra != rb:
                        parent[ra] = rb
    out: dict[str, int] = {}
    for i, (it, _g, _ls) in enumerate(geo):
        if it["kind"] == "pad":
            out.setdefault(it["id"], find(i))
    return out


def check_pin_map(design, cl: dict[str, int]) -> list[str]:
    """Problems (empty = the copper realises the pin map) for the HAT of whisker.pcb.hat."""
    from whisker.drive.pins import pin_map

    from .hat import DRV8833_CHANNEL, DRV8833_PINS, PCA9685_PINS

    num = {name: str(k) for k, name in DRV8833_PINS.items()}
    led = {name: str(k) for k, name in PCA9685_PINS.items()}
    problems = []
    seen: dict[int, str] = {}

    def same(a, b, what):
        if a not in cl or b not in cl:
            problems.append(f"{what}: pad {a if a not in cl else b} is not on the board")
        elif cl[a] != cl[b]:
            problems.append(f"{what}: {a} and {b} are not joined by copper")

    def unique(pad, what):
        c = cl.get(pad)
        if c is None:
            return
        if c in seen and seen[c] != what:
            problems.append(f"{what} shares copper with {seen[c]}")
        seen.setdefault(c, what)

    for ch in pin_map(design):
        u = f"U{ch.module + 1}"
        fwd, bwd, _sense, (out1, out2) = DRV8833_CHANNEL[ch.channel]
        j = f"J{10 + ch.whisker}"
        same(f"{j}:1", f"{u}:{num[out1]}", f"coil {ch.whisker} pin 1")
        same(f"{j}:2", f"{u}:{num[out2]}", f"coil {ch.whisker} pin 2")
        if ch.bus == "gpio":
            src_f, src_b = f"J1:{HEADER_PIN[ch.forward]}", f"J1:{HEADER_PIN[ch.backward]}"
        else:
            x = f"U{21 + ch.address - design.wiring.pca9685_address}"
            src_f, src_b = f"{x}:{led[f'LED{ch.forward}']}", f"{x}:{led[f'LED{ch.backward}']}"
        same(src_f, f"{u}:{num[fwd]}", f"coil {ch.whisker} forward input")
        same(src_b, f"{u}:{num[bwd]}", f"coil {ch.whisker} backward input")
        for pad, what in ((f"{j}:1", f"coil {ch.whisker} A"), (f"{j}:2", f"coil {ch.whisker} B"),
                          (src_f, f"coil {ch.whisker} forward"), (src_b, f"coil {ch.whisker} backward")):
            unique(pad, what)
    return problems


def vias_on_smd_pads(items: list[dict]) -> list[str]:
    """One line per via whose copper (a disc of its radius) overlaps an SMD pad of any net, its own too.

    An unfilled via in or touching an SMD pad wicks the solder away from the joint during reflow; fabs
    take it only as the paid "via-in-pad, filled and capped" option. The router and the plane fan-out
    keep vias beside the pads (whisker.pcb.maze.Grid.mark, smd=True; whisker.pcb.kicad.fanout); this is
    the check on the board's copper. Through-hole pads may carry vias (their barrel is a hole anyway)."""
    from shapely.geometry import Point, Polygon
    from shapely.strtree import STRtree

    pads = []
    for it in items:
        if it["kind"] == "pad" and not it.get("through") and it["layer"] in ("F.Cu", "B.Cu"):
            polys = [Polygon(p) for p in it["polys"] if len(p) >= 3]
            if polys:
                pads.append((it, polys))
    shapes = [g for _it, polys in pads for g in polys]
    owner = [it for it, polys in pads for _g in polys]
    tree = STRtree(shapes)
    out = []
    for via in (it for it in items if it["kind"] == "via"):
        c, r = Point(via["at"]), via["radius"]
        hit = sorted({owner[int(k)]["id"] for k in tree.query(c, predicate="dwithin", distance=r)
                      if shapes[int(k)].distance(c) < r})
        if hit:
            out.append(f"via at ({via['at'][0]:.3f}, {via['at'][1]:.3f}) mm, net {via.get('net') or '-'}, "
                       f"on SMD pad(s) {', '.join(hit)}")
    return out
