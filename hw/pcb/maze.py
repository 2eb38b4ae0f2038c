"""The grid and the maze search under whisker.pcb.router: an A* over (layer, y, x) states, two signal layers.

Why our own: the pure-Python ``freeroute`` port mis-scaled the session, ignored pre-placed copper and
dropped the 0.65 mm-pitch nets; no Freerouting jar is on a registry this project installs from. The
HAT is sparse (four layers, GND and VM on the inner planes, every plane pad already fanned out by
``whisker.pcb.kicad.fanout``), so a maze router on a 0.1 mm grid routes it, and its clearance test is
exact: every grid point a track centre may take is at least ``clearance + width/2 + MARGIN`` from any
other net's fixed copper, measured with shapely on the polygons pcbnew reports (pads as their real
shapes, the board edge, holes), so `kicad-cli pcb drc` is the check, not the definition.

No via touches an SMD pad, not even one of its own net (``Grid.mark(smd=True)``: via-in-pad wicks the
solder from the joint); vias of a net sit beside its SMD pads, a short track away (a fan-out), at the
same clearance as from other nets' copper. Through-hole pads take their own net's vias and tracks.

Layers F.Cu and B.Cu; a layer change is a via (cost ``VIA_COST`` grid steps). Moves are the 8 grid
neighbours; the margin covers the sagitta of a diagonal step between two checked grid points
(0.1 * sqrt(2) / 2 = 0.071 mm: a point 0.33 mm from both ends of the step is >= 0.322 mm from the
segment's middle). Every step's cost is multiplied by a per-state factor and every via's by a per-cell
factor: the congestion and history costs that whisker.pcb.router negotiates (all ones: plain A*). Same
input, same output: no randomness, ties broken by push order.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

STEP = 0.1          # mm, grid pitch
MARGIN = 0.05       # mm, over the DRC clearance (the diagonal-step sagitta, rounding)
VIA_COST = 8.0      # grid steps a via costs
TOP_COST = 1.5      # a step on F.Cu costs this much more: long runs go to B.Cu, F.Cu stays free for pad escapes
H_WEIGHT = 1.2      # weighted A* (paths within 20 % of the shortest, far fewer expansions)
MAX_EXPAND = 1_000_000
LAYERS = ("F.Cu", "B.Cu")
FREE, BLOCKED = -1, -2
HOLE_EXTRA = 0.1    # mm more around unplated (no-net) holes: hole clearance 0.25 > copper clearance


class RouteFailed(RuntimeError):
    pass


class Grid:
    """Per layer, two owner maps: ``t`` for track centres, ``v`` for via centres. A cell holds FREE,
    the one net whose copper is too near, or BLOCKED (two nets or the board edge)."""

    def __init__(self, width, height, rules, outline):
        import shapely

        self.nx, self.ny = int(math.floor(width / STEP)) + 1, int(math.floor(height / STEP)) + 1
        self.clr = rules["clearance"]
        self.w = rules["track_width"]
        self.via_d = rules["via_diameter"]
        self.via_drill = rules["via_drill"]
        self.t = [np.full((self.ny, self.nx), FREE, np.int32) for _ in LAYERS]
        self.v = [np.full((self.ny, self.nx), FREE, np.int32) for _ in LAYERS]
        xs, ys = np.meshgrid(np.arange(self.nx) * STEP, np.arange(self.ny) * STEP)
        edge = rules["edge_clearance"]
        inner_t = shapely.Polygon(outline).buffer(-(edge + self.w / 2 + MARGIN))
        inner_v = shapely.Polygon(outline).buffer(-(edge + self.via_d / 2 + MARGIN))
        ok_t = shapely.contains_xy(inner_t, xs, ys)
        ok_v = shapely.contains_xy(inner_v, xs, ys)
        for k in range(len(LAYERS)):
            self.t[k][~ok_t] = BLOCKED
            self.v[k][~ok_v] = BLOCKED

    # reach of a piece of copper (distance from its geometry) that a track / via centre must keep
    def reach(self, half_width_self: float) -> float:
        return self.clr + half_width_self + MARGIN

    def mark(self, layer: int, geom, net: int, r_track: float, r_via: float, smd: bool = False) -> None:
        """Claim the cells within `r_track` / `r_via` of `geom` for `net` (BLOCKED: for every net).

        ``smd``: `geom` is an SMD pad, and no via of any net, its own included, may come within `r_via`:
        a via in (or touching) an SMD pad wicks the solder away from the joint during reflow (fabs take it
        only as paid "via-in-pad, filled and capped"), so a via goes beside the pad with a short track."""
        import shapely

        for owner, r in ((self.t[layer], r_track), (self.v[layer], r_via)):
            x0, y0, x1, y1 = geom.bounds
            i0, i1 = max(0, int((x0 - r) / STEP)), min(self.nx - 1, int(math.ceil((x1 + r) / STEP)))
            j0, j1 = max(0, int((y0 - r) / STEP)), min(self.ny - 1, int(math.ceil((y1 + r) / STEP)))
            if i1 < i0 or j1 < j0:
                continue
            xs, ys = np.meshgrid(np.arange(i0, i1 + 1) * STEP, np.arange(j0, j1 + 1) * STEP)
            d = shapely.distance(geom, shapely.points(xs, ys))
            near = d < r
            win = owner[j0:j1 + 1, i0:i1 + 1]
            if net == BLOCKED or (smd and owner is self.v[layer]):
                win[near] = BLOCKED
                continue
            win[near & (win == FREE)] = net
            win[near & (win != net) & (win != FREE)] = BLOCKED

    def free(self, net: int, extra_half_width: float = 0.0):
        """Flat uint8 arrays (layer-major) of the cells a track / via of `net` may take."""
        from scipy import ndimage

        t, v = [], []
        for k in range(len(LAYERS)):
            ft = (self.t[k] == FREE) | (self.t[k] == net)
            fv = (self.v[k] == FREE) | (self.v[k] == net)
            if extra_half_width > 0:   # a wider track: its centre keeps the extra half width more
                n = int(math.ceil(extra_half_width / STEP))
                yy, xx = np.mgrid[-n:n + 1, -n:n + 1]
                disk = (xx ** 2 + yy ** 2) * STEP ** 2 <= extra_half_width ** 2
                ft = ndimage.binary_erosion(ft, structure=disk, border_value=0)
            t.append(ft.ravel())
            v.append(fv.ravel())
        return np.concatenate(t).astype(np.uint8), np.concatenate(v).astype(np.uint8)


def astar(grid: Grid, free_t, free_v, sources, targets, goal_pts, cost_t=None, cost_v=None):
    """Cheapest path (list of flat states) from any source state to any target state, or None.

    `cost_t` (per state, >= 1) multiplies the cost of stepping onto a state, `cost_v` (per state, >= 1)
    the cost of a via: the larger of its two layers' factors."""
    n2 = 2 * grid.nx * grid.ny
    tmask = np.zeros(n2, np.uint8)
    tmask[np.fromiter(targets, np.int64)] = 1
    goals = np.asarray(goal_pts, np.float64) / STEP
    if cost_t is None:
        cost_t = np.ones(n2)
    if cost_v is None:
        cost_v = np.ones(n2)
    path = _astar_core(free_t, free_v, cost_t, cost_v, np.asarray(sources, np.int64), tmask, goals,
                       grid.nx, grid.ny, VIA_COST, TOP_COST, H_WEIGHT, MAX_EXPAND)
    return None if len(path) == 0 else [int(s) for s in path]


def _astar_core_py(free_t, free_v, cost_t, cost_v, sources, tmask, goals, nx, ny, via_cost, top_cost, h_weight,
                   max_expand):
    """A* over (layer, y, x) states; numba compiles it (the pure-Python loop is ~50x slower, same result:
    ties are broken by push order)."""
    n = nx * ny
    r2 = math.sqrt(2.0)
    g = np.full(2 * n, np.inf)
    parent = np.full(2 * n, -1, np.int64)
    heap = [(0.0, 0, 0.0, 0)]
    heap.pop()
    cnt = 0
    for s in sources:
        if g[s] > 0.0:
            g[s] = 0.0
            rem = s % n
            i, j = rem % nx, rem // nx
            best = 1e18
            for k in range(goals.shape[0]):
                dx, dy = abs(i - goals[k, 0]), abs(j - goals[k, 1])
                d = max(dx, dy) + (r2 - 1.0) * min(dx, dy)
                best = min(best, d)
            heapq.heappush(heap, (best * h_weight, cnt, 0.0, s))
            cnt += 1
    di_ = np.array([1, -1, 0, 0, 1, 1, -1, -1])
    dj_ = np.array([0, 0, 1, -1, 1, -1, 1, -1])
    dc_ = np.array([1.0, 1.0, 1.0, 1.0, r2, r2, r2, r2])
    expanded = 0
    found = -1
    while len(heap) > 0:
        _f, _c, gc, s = heapq.heappop(heap)
        if gc > g[s]:
            continue
        if tmask[s]:
            found = s
            break
        expanded += 1
        if expanded > max_expand:
            break
        layer = s // n
        rem = s - layer * n
        j = rem // nx
        i = rem - j * nx
        mult = top_cost if layer == 0 else 1.0
        for m in range(9):
            if m < 8:
                ii, jj = i + di_[m], j + dj_[m]
                if ii < 0 or jj < 0 or ii >= nx or jj >= ny:
                    continue
                ns = layer * n + jj * nx + ii
                if free_t[ns] == 0:
                    continue
                ng = gc + dc_[m] * mult * cost_t[ns]
            else:
                ii, jj = i, j
                ns = (1 - layer) * n + rem
                if free_v[rem] == 0 or free_v[n + rem] == 0 or free_t[ns] == 0:
                    continue
                ng = gc + via_cost * max(cost_v[rem], cost_v[n + rem]) * cost_t[ns]
            if ng < g[ns]:
                g[ns] = ng
                parent[ns] = s
                best = 1e18
                for k in range(goals.shape[0]):
                    dx, dy = abs(ii - goals[k, 0]), abs(jj - goals[k, 1])
                    d = max(dx, dy) + (r2 - 1.0) * min(dx, dy)
                    best = min(best, d)
                heapq.heappush(heap, (ng + best * h_weight, cnt, ng, ns))
                cnt += 1
    if found < 0:
        return np.zeros(0, np.int64)
    out = [found]
    s = parent[found]
    while s != -1:
        out.append(s)
        s = parent[s]
    return np.array(out[::-1], np.int64)


try:
    import numba

    _astar_core = numba.njit(cache=True)(_astar_core_py)
except ImportError:  # pragma: no cover - numba is in the hw extra
    _astar_core = _astar_core_py


def segments(path, grid: Grid):
    """Path states -> straight runs per layer [(layer, (x0, y0), (x1, y1))] and via points."""
    n = grid.nx * grid.ny
    pts = []
    for s in path:
        layer, rem = divmod(s, n)
        j, i = divmod(rem, grid.nx)
        pts.append((layer, i, j))
    segs, vias = [], []
    k = 0
    while k < len(pts) - 1:
        l0, i0, j0 = pts[k]
        l1, i1, j1 = pts[k + 1]
        if l1 != l0:
            vias.append((i0, j0))
            k += 1
            continue
        di, dj = i1 - i0, j1 - j0
        m = k + 1
        while m + 1 < len(pts) and pts[m + 1][0] == l0 and \
                (pts[m + 1][1] - pts[m][1], pts[m + 1][2] - pts[m][2]) == (di, dj):
            m += 1
        segs.append((l0, (i0, j0), (pts[m][1], pts[m][2])))
        k = m
    return segs, vias
