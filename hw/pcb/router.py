"""Negotiated-congestion routing of the HAT's signal nets (PathFinder) on the maze grid of whisker.pcb.maze.

PathFinder (L. McMurchie and C. Ebeling, "PathFinder: a negotiation-based performance-driven router for
FPGAs", FPGA '95): every net is routed on its own, allowed to use grid states that other nets' copper
already claims, at a price. A state's price is ``(1 + h) * (1 + p * n)``: ``n`` is how many other nets
claim it now (present congestion), ``p`` grows by ``PRES_GROWTH`` after every pass, and ``h`` (history)
grows by ``HIST_STEP`` on every state found shared at the end of a pass. Nets that share a state are
ripped up and routed again, until no state is shared; then every net keeps the clearance from every
other by construction.

What a net claims is a keep-out, not its own cells: the states where another net's track centre (or via
centre) would come closer than the clearance to this net's tracks and vias, i.e. its track centres and
via centres dilated by ``clearance + both half widths + MARGIN`` (Euclidean distance transform of the
grid). The dilation is of the path's grid points; a point ``SAG`` further covers the segment between
two neighbouring points (its sagitta, 0.007 mm at these radii). Fixed copper (pads, fan-out tracks and
vias, the board edge, holes) is a hard obstacle, exactly as whisker.pcb.maze measures it.

Multi-pad nets grow as trees from their first pad towards the nearest remaining pad. Nets are routed in
the order of their pad bounding box (smallest first), in every pass. Same input, same output: no
randomness, ties broken in that order.
"""

from __future__ import annotations

import math

import numpy as np

from . import maze
from .maze import BLOCKED, HOLE_EXTRA, LAYERS, MARGIN, STEP, Grid, RouteFailed

__all__ = ["route", "RouteFailed"]

PRES_START = 0.5     # present-congestion factor of the first pass
PRES_GROWTH = 1.6    # its growth per pass
HIST_STEP = 0.5      # history cost added to a shared state per pass
PASSES = 60
SAG = 0.01           # mm: a grid point's dilation also covers the segments to its neighbours


def route(copper_items: list[dict], spec: dict, nets: list[str], log=print) -> tuple[list[dict], list[dict]]:
    """Tracks and vias (kicad_job spec entries) joining every pad of each net in `nets`.

    `copper_items`: the ``kicad_job copper`` dump of the unrouted board (pads, pre-placed tracks and
    vias, with their nets). Raises RouteFailed naming the nets left unrouted or still sharing room.
    """
    board = _Board(copper_items, spec, sorted(nets, key=lambda nm: _bbox_size(copper_items, nm)))
    board.negotiate(log)
    return board.emit()


class _Board:
    def __init__(self, items, spec, order):
        import shapely

        b, r = spec["board"], spec["rules"]
        outline = [(0, 0), (b["width"], 0), (b["width"], b["height"]), (0, b["height"])]
        self.grid = grid = Grid(b["width"], b["height"], r, outline)
        self.n = grid.nx * grid.ny
        net_id = {nm: k for k, nm in enumerate(sorted({it.get("net", "") for it in items} | set(order)))}
        half = grid.w / 2
        r_tt, r_tv = grid.clr + half + MARGIN, grid.clr + grid.via_d / 2 + MARGIN  # from a geometry edge
        pads: dict[str, list] = {}
        for it in items:
            if it["kind"] not in ("pad", "track", "via"):
                continue
            net = it.get("net", "")
            nid = net_id[net] if net else BLOCKED
            extra = HOLE_EXTRA if not net else 0.0
            if it["kind"] == "pad":
                polys = [shapely.Polygon(p) for p in it["polys"] if len(p) >= 3]
                if not polys:
                    continue
                geom = shapely.union_all(polys)
                if it["layer"] in LAYERS:
                    grid.mark(LAYERS.index(it["layer"]), geom, nid, r_tt + extra, r_tv + extra,
                              smd=not it.get("through", False))
                    if net:
                        pads.setdefault(net, []).append((it, geom, LAYERS.index(it["layer"])))
            elif it["kind"] == "track":
                if it["layer"] in LAYERS:
                    geom = shapely.LineString([it["start"], it["end"]]).buffer(it["width"] / 2)
                    grid.mark(LAYERS.index(it["layer"]), geom, nid, r_tt, r_tv)
            else:
                geom = shapely.Point(it["at"]).buffer(it["radius"])
                for k in range(len(LAYERS)):
                    grid.mark(k, geom, nid, r_tt, r_tv)
        wide = spec.get("wide_nets", {})
        self.nets = {}
        self.unroutable = []
        for net in order:
            width = max(grid.w, round(wide.get(net, grid.w), 2))
            free_t, free_v = grid.free(net_id[net], width / 2 - half)
            groups, centres = self._pad_cells(pads.get(net, []), free_t)
            ids = sorted(groups, key=_pad_key)
            if len(ids) < 2:
                continue
            if any(not groups[p] for p in ids):
                self.unroutable.append(net)
                continue
            self.nets[net] = {"width": width, "free": (free_t, free_v), "groups": groups, "centres": centres,
                              "ids": ids, "keep": self._radii(width)}
        self.occ_t = np.zeros(2 * self.n, np.int32)   # other nets' keep-outs for a track centre
        self.occ_v = np.zeros(2 * self.n, np.int32)   # ... for a via centre
        self.hist_t = np.zeros(2 * self.n)
        self.hist_v = np.zeros(2 * self.n)
        self.routes: dict[str, dict] = {}

    def _pad_cells(self, pads, free_t):
        """The grid states inside each pad (by pad id, all its layers) and the pads' centres."""
        import shapely

        grid, n = self.grid, self.n
        groups: dict[str, set] = {}
        centres: dict[str, tuple] = {}
        for it, geom, layer in pads:
            inner = geom.buffer(-0.02)
            x0, y0, x1, y1 = inner.bounds
            i0, i1 = int(math.ceil(x0 / STEP)), int(math.floor(x1 / STEP))
            j0, j1 = int(math.ceil(y0 / STEP)), int(math.floor(y1 / STEP))
            cells = set()
            if i1 >= i0 and j1 >= j0:
                xs, ys = np.meshgrid(np.arange(i0, i1 + 1) * STEP, np.arange(j0, j1 + 1) * STEP)
                inside = shapely.contains_xy(inner, xs, ys)
                for jj, ii in zip(*np.nonzero(inside)):
                    s = layer * n + (j0 + int(jj)) * grid.nx + (i0 + int(ii))
                    if free_t[s]:
                        cells.add(s)
            groups.setdefault(it["id"], set()).update(cells)
            centres[it["id"]] = tuple(it["at"])
        return groups, centres

    def _radii(self, width):
        """Keep-out radii (mm) of a net of track `width`: (track->track centre, track->via centre,
        via->track centre, via->via centre); the other net's track is the default width."""
        g = self.grid
        return (g.clr + width / 2 + g.w / 2 + MARGIN + SAG, g.clr + width / 2 + g.via_d / 2 + MARGIN + SAG,
                g.clr + g.via_d / 2 + g.w / 2 + MARGIN + SAG, g.clr + g.via_d + MARGIN + SAG)

    # ---- claims ----------------------------------------------------------------------------------

    def _keepout(self, net, states, vias):
        """Flat states (track centres, via centres) that the copper of `net`'s route keeps other nets from."""
        from scipy import ndimage

        g, n = self.grid, self.n
        r_tt, r_tv, r_vt, r_vv = self.nets[net]["keep"]
        reach = int(math.ceil(max(r_tt, r_tv, r_vt, r_vv) / STEP)) + 1
        st = np.asarray(states, np.int64)
        layer, rem = st // n, st % n
        jj, ii = rem // g.nx, rem % g.nx
        vi = np.asarray([c % g.nx for c in vias], np.int64)
        vj = np.asarray([c // g.nx for c in vias], np.int64)
        i0, i1 = max(0, ii.min() - reach), min(g.nx - 1, ii.max() + reach)
        j0, j1 = max(0, jj.min() - reach), min(g.ny - 1, jj.max() + reach)
        shape = (j1 - j0 + 1, i1 - i0 + 1)
        wj, wi = np.mgrid[j0:j1 + 1, i0:i1 + 1]
        base = wj * g.nx + wi

        def dist(mask):
            if not mask.any():
                return np.full(shape, np.inf)
            return ndimage.distance_transform_edt(~mask) * STEP

        via_mask = np.zeros(shape, bool)
        via_mask[vj - j0, vi - i0] = True
        d_via = dist(via_mask)
        keep_t, keep_v = [], []
        for k in range(len(LAYERS)):
            m = np.zeros(shape, bool)
            sel = layer == k
            m[jj[sel] - j0, ii[sel] - i0] = True
            d_tr = dist(m)
            keep_t.append(k * n + base[(d_tr < r_tt) | (d_via < r_vt)])
            keep_v.append(k * n + base[(d_tr < r_tv) | (d_via < r_vv)])
        return np.concatenate(keep_t), np.concatenate(keep_v)

    def _claim(self, net, sign):
        r = self.routes[net]
        self.occ_t[r["keep_t"]] += sign
        self.occ_v[r["keep_v"]] += sign

    def _others(self, net):
        """Other nets' claims as seen by `net`'s centre (a wider track keeps its extra half width more)."""
        extra = self.nets[net]["width"] / 2 - self.grid.w / 2
        if extra <= 0:
            return self.occ_t, self.occ_v
        from scipy import ndimage

        k = int(math.ceil(extra / STEP))
        yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
        disk = (xx ** 2 + yy ** 2) * STEP ** 2 <= extra ** 2
        foot = np.stack([np.zeros_like(disk), disk, np.zeros_like(disk)])
        occ = ndimage.maximum_filter(self.occ_t.reshape(2, self.grid.ny, self.grid.nx), footprint=foot,
                                     mode="constant", cval=0)
        return occ.ravel(), self.occ_v

    # ---- one net ---------------------------------------------------------------------------------

    def _route_net(self, net, pres):
        g, n, info = self.grid, self.n, self.nets[net]
        occ_t, occ_v = self._others(net)
        cost_t = (1.0 + self.hist_t) * (1.0 + pres * occ_t)
        cost_v = (1.0 + self.hist_v) * (1.0 + pres * occ_v)
        free_t, free_v = info["free"]
        groups, ids = info["groups"], info["ids"]
        tree = set(groups[ids[0]])
        todo = ids[1:]
        paths, vias = [], []
        while todo:
            targets = set()
            for p in todo:
                targets |= groups[p]
            # start from tree states no other net claims, when there are any (a source costs nothing)
            src = sorted(tree)
            calm = [s for s in src if occ_t[s] == 0]
            path = maze.astar(g, free_t, free_v, calm or src, targets, [info["centres"][p] for p in todo],
                              cost_t, cost_v)
            if path is None:
                return None
            reached = next(p for p in todo if path[-1] in groups[p])
            todo = [p for p in todo if p != reached]
            tree |= set(path) | groups[reached]
            for a, b in zip(path, path[1:]):
                if a // n != b // n:
                    vias.append(a % n)
                    # a via's hole keeps other vias of its own net away too (hole-to-hole)
                    tree.update(k * n + a % n for k in range(len(LAYERS)))
            paths.append(path)
        states = sorted({s for p in paths for s in p})
        keep_t, keep_v = self._keepout(net, states, vias)
        return {"paths": paths, "states": np.asarray(states, np.int64), "vias": vias, "keep_t": keep_t,
                "keep_v": keep_v}

    def _shared(self, net):
        """(track states, via states) of `net`'s route that another net claims."""
        r, n = self.routes[net], self.n
        self._claim(net, -1)
        occ_t, occ_v = self._others(net)
        bad_t = r["states"][occ_t[r["states"]] > 0]
        vs = np.asarray([k * n + c for c in r["vias"] for k in range(len(LAYERS))], np.int64)
        bad_v = vs[occ_v[vs] > 0] if len(vs) else vs
        self._claim(net, +1)
        return bad_t, bad_v

    # ---- negotiation -----------------------------------------------------------------------------

    def negotiate(self, log):
        if self.unroutable:
            raise RouteFailed(f"router left {len(self.unroutable)} net(s) unrouted (no free cell in a pad): "
                              f"{', '.join(self.unroutable)}")
        pres = PRES_START
        todo = list(self.nets)
        for k in range(PASSES):
            failed = []
            for net in todo:
                if net in self.routes:
                    self._claim(net, -1)
                    del self.routes[net]
                r = self._route_net(net, pres)
                if r is None:
                    failed.append(net)
                    continue
                self.routes[net] = r
                self._claim(net, +1)
            if failed:
                raise RouteFailed(f"router left {len(failed)} net(s) unrouted (no path): {', '.join(failed)}")
            shared = {}
            for net in self.nets:
                bad_t, bad_v = self._shared(net)
                if len(bad_t) or len(bad_v):
                    shared[net] = (bad_t, bad_v)
            log(f"pcb: routing pass {k + 1}: {len(self.nets) - len(shared)}/{len(self.nets)} nets clear"
                + (f", {len(shared)} sharing room" if shared else ""))
            if not shared:
                return
            for bad_t, bad_v in shared.values():
                self.hist_t[bad_t] += HIST_STEP
                self.hist_v[bad_v] += HIST_STEP
            pres *= PRES_GROWTH
            todo = [net for net in self.nets if net in shared]
        raise RouteFailed(f"router left {len(shared)} net(s) sharing room after {PASSES} passes: "
                          f"{', '.join(shared)}")

    def emit(self):
        g = self.grid
        tracks, vias = [], []
        for net in self.nets:
            r = self.routes[net]
            width = self.nets[net]["width"]
            for path in r["paths"]:
                segs, vs = maze.segments(path, g)
                for layer, (i0, j0), (i1, j1) in segs:
                    a = [round(i0 * STEP, 4), round(j0 * STEP, 4)]
                    b = [round(i1 * STEP, 4), round(j1 * STEP, 4)]
                    tracks.append({"start": a, "end": b, "width": width, "layer": LAYERS[layer], "net": net})
                for i, j in vs:
                    vias.append({"at": [round(i * STEP, 4), round(j * STEP, 4)], "diameter": g.via_d,
                                 "drill": g.via_drill, "net": net})
        return tracks, vias


def _bbox_size(items, net):
    pts = [it["at"] for it in items if it["kind"] == "pad" and it.get("net") == net]
    if not pts:
        return 0.0
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    return (max(xs) - min(xs)) + (max(ys) - min(ys))


def _pad_key(pid: str):
    ref, num = pid.split(":", 1)
    head = ref.rstrip("0123456789")
    return head, int(ref[len(head):] or 0), int(num) if num.isdigit() else 0, num
