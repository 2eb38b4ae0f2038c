"""The sensor's thermal network: its state, its implicit time step and steady state, each material
against its own limit, and the answers at a constant voltage (the coil report, the explorer,
`whisker coil thermal`). The nodes, capacities and conductances come from the design's geometry and the
material table in whisker.coil.thermal_parts (its docstring names every formula's source).
Units: C, W, J/K, W/K, s.

Heat: I^2 R(T) in each winding, R(T) = R20 (1 + alpha (T - 20)) (whisker.coil). The network is
linear in the temperatures for a given current, C dT/dt = A T + b, and is integrated implicitly
(backward Euler, sub-steps of at most ``max_substep_s``), stable for any step; the benchmark
(benchmarks/bench_thermal.py) measures its error against a tight ODE solution and the finite-element
model (whisker.coil.thermal_fe), and the bobbin tab's ladder against its number of slices.

Limits: each node carries the materials that reach its temperature (whisker.coil.thermal_parts,
NODE_MATERIALS; the tab's at its hottest slice). The weakest (smallest headroom) sets the limit
(:meth:`ThermalNetwork.headroom`).
"""

from __future__ import annotations

import math

import numpy as np

from whisker import coil as _coil
from whisker.coil import thermal_materials as tm
from whisker.coil import thermal_parts as tp

# Slices of the winding's and the bobbin tab's ladders (whisker.coil.thermal_parts): the tab's mean
# rise at 2 s is within 5 % and at steady state within 1 % of 32 slices each (benchmarks/results/
# thermal.md, table 1b), at 0.5 ms per 20 ms step of 8 coils.
WINDING_NODES = 6
TAB_NODES = 6


class ThermalNetwork:
    """The sensor's thermal network (whisker.coil.thermal_parts). State: node temperatures (C), shape
    (K n + 2,), K = M + N + 3: whisker i's M winding slices from K i (the first against the tab), its N
    tab slices (the first against the winding), rod, membrane, magnet; then cavity air, mount.

    ``exchange`` = False cuts the cavity air and the mount out (every surface sees the ambient
    directly, radiation to the ambient): the configuration of the finite-element check.
    """

    def __init__(self, design, *, exchange: bool = True, max_substep_s: float = 0.05,
                 winding_nodes: int = WINDING_NODES, tab_nodes: int = TAB_NODES):
        self.design = design
        self.n = int(design.whiskers.count)
        self.mat = tm.design_materials(design)
        self.geo = tp.geometry(design)
        self.ambient_C = float(design.thermal.ambient)
        self.exchange = bool(exchange)
        self.max_substep_s = float(max_substep_s)
        self.r20_ohm = float(_coil.resistance_ohm(design, 20.0))
        self.alpha = _coil.ALPHA20_PER_K
        lim = tp.limits_by_node(design)
        self.node_limits = lim
        self.limit_table = [(node, role, name, c) for node, items in lim.items() for role, name, c in items]
        first = min(self.limit_table, key=lambda r: r[3])
        self.limit_node, self.limit_role, self.limit_name, self.limit_C = first
        self.limit_label = label(first)
        # the lowest limit at the winding's own temperature (the hottest node: its resistance there)
        self.winding_limit_C = min(c for _r, _n, c in lim["winding"]) if lim["winding"] else self.limit_C
        self.winding = tp.winding_ladder(self.geo, self.mat, winding_nodes)
        self.tab = tp.tab_ladder(self.geo, self.mat, tab_nodes)
        self.winding_nodes, self.tab_nodes = self.winding.capacity.size, self.tab.capacity.size
        self.per_whisker = self.winding_nodes + self.tab_nodes + 3
        self.size = self.per_whisker * self.n + 2
        h, hr = self.film_coefficients_W_m2K()
        self.C, self.G, self.g_amb = tp.assemble(self.capacities_J_per_K(), self.conductances(), self.winding,
                                                 self.tab, h, hr, self.n, self.exchange)
        self._base = None

    # ---- the parts (whisker.coil.thermal_parts) ----------------------------------------------------
    def film_coefficients_W_m2K(self) -> tuple[float, float]:
        """(convection, linearised radiation), W/(m^2 K)."""
        return tp.film_coefficients_W_m2K(self.design, self.limit_C)

    def capacities_J_per_K(self) -> dict[str, float]:
        """Heat capacity of each of one whisker's parts (the tab whole) and of the shared nodes, J/K."""
        return tp.capacities_J_per_K(self.geo, self.mat)

    def winding_conductivity_W_mK(self) -> float:
        """Transverse conductivity of the winding (copper in its enamel, Maxwell), W/(m K)."""
        return tp.winding_conductivity_W_mK(self.geo, self.mat)

    def conductances(self) -> dict[str, float]:
        """Every conductance of one whisker (the tab's whole) and its shares of the shared ones, W/K."""
        h, hr = self.film_coefficients_W_m2K()
        return tp.conductances(self.geo, self.mat, h, hr, self.n, self.exchange)

    def columns(self, node: str) -> np.ndarray:
        """Indices into the state of `node` (a name of thermal_parts.PER_WHISKER or SHARED): (rows, n),
        one row per node (the winding and the tab: one per slice, from their common face)."""
        cache = self.__dict__.setdefault("_colcache", {})
        if node not in cache:
            cache[node] = self._columns(node)
        return cache[node]

    def _columns(self, node: str) -> np.ndarray:
        K, Mw, N, n = self.per_whisker, self.winding_nodes, self.tab_nodes, self.n
        base = np.arange(n) * K
        if node == "winding":
            return base[None, :] + np.arange(Mw)[:, None]
        if node == "bobbin":
            return base[None, :] + Mw + np.arange(N)[:, None]
        if node in tp.PER_WHISKER:
            return base[None, :] + Mw + N + tp.PER_WHISKER.index(node) - 2
        if node in tp.SHARED:
            return np.full((1, n), K * n + tp.SHARED.index(node))
        raise KeyError(f"ThermalNetwork: no node {node!r}")

    # ---- dynamics ----------------------------------------------------------------------------------
    def initial_state(self, temperature_C: float | None = None) -> np.ndarray:
        return np.full(self.size, self.ambient_C if temperature_C is None else float(temperature_C))

    def _system(self):
        if self._base is None:
            L = np.diag(self.G.sum(axis=1) + self.g_amb) - self.G       # conductance Laplacian + outside
            self._base = (L, self.g_amb * self.ambient_C)
        return self._base

    def _joule(self, x, currents_A=None, power_W=None, volts=None):
        """(b, d) of the windings' Joule heat, linear in the state about `x`: heat = b + d * T (W per
        node). Winding slice j holds the share f_j of the wire: with a current its heat is I^2 R20 f_j
        (1 + alpha (T_j - 20)), exact and implicit; with a fixed power f_j P; with a fixed voltage
        f_j V^2 / R(T_mean), linearised about x's mean."""
        W = self.columns("winding")
        f = self.winding.share[:, None]              # each slice's share of the wire
        b = np.zeros(self.size)
        d = np.zeros(self.size)
        if power_W is not None:
            b[W] += np.asarray(power_W, dtype=float) * f
        elif volts is not None:
            v = np.asarray(volts, dtype=float)
            f0 = 1.0 + self.alpha * (self.winding_C(x) - 20.0)
            p0 = v * v / (self.r20_ohm * f0)
            dp = -p0 * self.alpha / f0                 # dP/dT < 0: a warmer coil takes less at a fixed voltage
            b[W] += (p0 - dp * self.winding_C(x)) * f
            d[W] = dp * f
        else:
            i = np.asarray(currents_A, dtype=float)
            if i.shape != (self.n,) or not np.all(np.isfinite(i)):
                raise ValueError(f"ThermalNetwork.step_state: currents must be {self.n} finite numbers")
            p0 = i * i * self.r20_ohm
            b[W] += p0 * (1.0 - 20.0 * self.alpha) * f
            d[W] = p0 * self.alpha * f               # dP/dT: heat that grows with the temperature
        return b, d

    def heat_W(self, state: np.ndarray, currents_A) -> np.ndarray:
        """Joule heat of each winding at the state's winding temperatures, W (n,)."""
        i = np.asarray(currents_A, dtype=float)
        return i * i * self.r20_ohm * (1.0 + self.alpha * (self.winding_C(state) - 20.0))

    def step_state(self, state, currents_A, dt_s: float, power_W=None, volts=None) -> np.ndarray:
        """State after dt_s with constant RMS currents (n,) in the windings, or a constant `power_W`
        (n,) (the finite-element check), or constant `volts` (n,) across each winding (V^2/R(T),
        linearised about the step's start). Backward Euler, sub-steps <= max_substep_s; with a
        current R(T) is implicit (the Joule term is linear in the winding temperature)."""
        x = np.asarray(state, dtype=float)
        dt = float(dt_s)
        if not math.isfinite(dt) or dt < 0:
            raise ValueError(f"ThermalNetwork.step_state: dt must be finite and >= 0 (got {dt_s!r})")
        if x.shape != (self.size,) or not np.all(np.isfinite(x)):
            raise ValueError(f"ThermalNetwork.step_state: state must be {self.size} finite temperatures")
        if dt == 0:
            return x.copy()
        _, src = self._system()
        heat, d = self._joule(x, currents_A, power_W, volts)
        b = src + heat
        steps = max(1, math.ceil(dt / self.max_substep_s))
        h = dt / steps
        solve = self._block_solver(h, d)
        ch = self.C / h
        for _ in range(steps):
            x = solve(ch * x + b)
        return np.minimum(x, 5000.0)

    def _blocks(self, h):
        """The pattern of C/h + L (h None: L alone): the whiskers' diagonal blocks (n, K, K), block ->
        shared (n, K, s), shared -> block (n, s, K) and shared (s, s); whiskers meet only through the
        shared nodes (cavity air, mount). Cached per h."""
        cache = self.__dict__.setdefault("_bcache", {})
        out = cache.get(h)
        if out is None:
            A = self._system()[0] if h is None else self._implicit_matrix(h)
            n, K = self.n, self.per_whisker
            nK = n * K
            blocks = A[:nK, :nK].reshape(n, K, n, K)[np.arange(n), :, np.arange(n), :].copy()
            out = (blocks, A[:nK, nK:].reshape(n, K, -1).copy(), A[nK:, :nK].reshape(-1, n, K).transpose(1, 0, 2).copy(),
                   A[nK:, nK:].copy())
            if len(cache) > 64:
                cache.clear()
            cache[h] = out
        return out

    def _block_solver(self, h, d):
        """x -> (C/h + L - diag(d))^-1 x (h None: (L - diag(d))^-1 x): the whiskers' blocks solved
        together (batched LAPACK), the shared nodes through their Schur complement. Cheaper than a
        dense solve of the whole network, and free of the threaded BLAS a dense solve of ~100 nodes
        calls. The last solver is kept (the guard steps with the same h and currents)."""
        key = (h, d.tobytes())
        last = self.__dict__.get("_last_solver")
        if last is not None and last[0] == key:
            return last[1]
        blocks, E, F, S = self._blocks(h)
        n, K = self.n, self.per_whisker
        nK = n * K
        dd = d[:nK].reshape(n, K)
        if np.any(dd):
            blocks = blocks.copy()
            blocks[:, np.arange(K), np.arange(K)] -= dd
        inv = np.linalg.inv(blocks)
        Z = inv @ E
        schur = S - np.einsum("isk,ikt->st", F, Z)

        def solve(r):
            y = np.einsum("ijk,ik->ij", inv, r[:nK].reshape(n, K))
            sh = np.linalg.solve(schur, r[nK:] - np.einsum("isk,ik->s", F, y))
            return np.concatenate([(y - Z @ sh).ravel(), sh])
        self._last_solver = (key, solve)
        return solve

    def _implicit_matrix(self, h: float) -> np.ndarray:
        """C/h + L for the sub-step h (cached: the guard calls with the same h every update)."""
        cache = self.__dict__.setdefault("_mcache", {})
        m = cache.get(h)
        if m is None:
            L, _ = self._system()
            m = np.diag(self.C / h) + L
            if len(cache) > 64:
                cache.clear()
            cache[h] = m
        return m

    def steady_state(self, currents_A=None, power_W=None) -> np.ndarray:
        """Steady node temperatures at constant RMS currents (or powers), C (inf where runaway)."""
        L, src = self._system()
        heat, d = self._joule(self.initial_state(), currents_A, power_W)
        return self._block_solver(None, d)(src + heat)

    # ---- limits ------------------------------------------------------------------------------------
    def node_temperatures(self, state) -> dict[str, np.ndarray]:
        """node name -> temperatures (n,) per whisker, or (1,) for the shared ones, C; the tab
        ("bobbin"): the mean of its slices by heat capacity (its volume mean, the finite-element
        check's quantity). :meth:`tab_C` gives each slice."""
        x = np.asarray(state)
        out = {name: x[self.columns(name)[0]] for name in tp.PER_WHISKER}
        out["winding"] = self.winding_C(x)
        out["bobbin"] = self.tab.capacity @ self.tab_C(x) / self.tab.capacity.sum()
        for name in tp.SHARED:
            out[name] = x[self.columns(name)[0, :1]]
        return {k: out[k] for k in (*tp.PER_WHISKER, *tp.SHARED)}

    def tab_C(self, state) -> np.ndarray:
        """Each slice of each whisker's tab, (tab_nodes, n), C (row 0 against the winding)."""
        return np.asarray(state)[self.columns("bobbin")]

    def winding_C(self, state) -> np.ndarray:
        """Each winding's mean temperature over its wire (the resistance's), C (n,)."""
        return self.winding.share @ np.asarray(state)[self.columns("winding")]

    def material_temperatures(self, state) -> dict[str, float]:
        """Highest temperature each limited material reaches anywhere in `state`, C ("role (material)")."""
        x = np.asarray(state)
        out: dict[str, float] = {}
        for node, items in self.node_limits.items():
            for role, name, _ in items:
                key = f"{tm.ROLES[role][0]} ({name})"
                out[key] = max(out.get(key, -math.inf), float(np.max(x[self.material_columns(node, role)])))
        return out

    def material_columns(self, node: str, role: str) -> np.ndarray:
        """The rows of :meth:`columns` where the material of `role` sits: every slice, but the rod's
        glue only in the tab's slices its socket crosses."""
        cols = self.columns(node)
        if node == "bobbin" and role == "rod_glue":
            return cols[self.tab.rod_share > 0]
        return cols

    def _limit_index(self):
        """(indices (rows, n) into the state, limits (rows,), labels (rows,)) of every limited material
        at every node it reaches (each tab slice a row)."""
        if getattr(self, "_lim_idx", None) is None:
            idx, lims, labels = [], [], []
            for node, items in self.node_limits.items():
                for role, name, lim in items:
                    for col in self.material_columns(node, role):
                        idx.append(col)
                        lims.append(lim)
                        labels.append(f"{tm.ROLES[role][0]} ({name}, {lim:g} C) at the {node}")
            self._lim_idx = (np.array(idx), np.array(lims, dtype=float), labels)
        return self._lim_idx

    def headroom(self, state) -> tuple[np.ndarray, list[str]]:
        """Per whisker: the smallest (limit - temperature) over every material that reaches one of its
        nodes or a shared node, K, and which material and node it is (the weakest sets the limit)."""
        idx, lims, labels = self._limit_index()
        room = lims[:, None] - np.asarray(state)[idx]
        k = np.argmin(room, axis=0)
        return room[k, np.arange(self.n)], [labels[j] for j in k]

    def describe(self) -> dict:
        """Capacities, conductances (with the winding's and the tab's ladders) and limits, for reports."""
        ladders = {name: {"slices": int(lad.capacity.size), "capacity_J_per_K": lad.capacity.tolist(),
                          "slice_to_slice_W_per_K": lad.g_step.tolist(), "surface_m2": lad.surface.tolist()}
                   for name, lad in (("winding", self.winding), ("bobbin", self.tab))}
        ladders["bobbin"]["rod_share"] = self.tab.rod_share.tolist()
        return {"capacities_J_per_K": self.capacities_J_per_K(), "conductances_W_per_K": self.conductances(),
                "winding_to_tab_W_per_K": 1.0 / (self.winding.r_half_K_per_W + self.tab.r_half_K_per_W),
                "ladders": ladders, "winding_conductivity_W_mK": self.winding_conductivity_W_mK(),
                "limits": [{"node": n, "role": r, "material": m, "limit_C": c} for n, r, m, c in self.limit_table],
                "first_limit": self.limit_label}


def label(row) -> str:
    node, role, name, lim = row
    return f"{tm.ROLES[role][0]} ({name}, {lim:g} C)"


# ---- answers at a constant voltage (the coil report, the explorer, `whisker coil thermal`) ----------

def steady_state_at_volts(net: ThermalNetwork, volts, duty: float = 1.0) -> np.ndarray:
    """Steady state with `volts` (scalar or (n,)) across the windings at a PWM `duty` (mean power
    duty V^2/R(T)): fixed-point iteration on R(T), which converges because P falls as T rises."""
    v = np.broadcast_to(np.asarray(volts, dtype=float), (net.n,))
    tw = np.full(net.n, net.ambient_C)
    for _ in range(200):
        p = duty * v * v / (net.r20_ohm * (1.0 + net.alpha * (tw - 20.0)))
        x = net.steady_state(power_W=p)
        new = net.winding_C(x)
        if np.max(np.abs(new - tw)) < 1e-6:
            break
        tw = new
    return x


def run_at_volts(net: ThermalNetwork, volts, t_end_s: float, duty: float = 1.0, dt_s: float = 0.02,
                 state=None):
    """(times (k,), states (k, size)) at `volts` across the windings from `state` (ambient)."""
    v = np.broadcast_to(np.asarray(volts, dtype=float), (net.n,)) * math.sqrt(duty)
    x = net.initial_state() if state is None else np.asarray(state, dtype=float)
    steps = max(1, math.ceil(t_end_s / dt_s))
    h = t_end_s / steps
    ts, xs = [0.0], [x]
    for k in range(steps):
        x = net.step_state(x, None, h, volts=v)
        ts.append((k + 1) * h)
        xs.append(x)
    return np.array(ts), np.array(xs)


def time_to_limits_s(net: ThermalNetwork, volts, duty: float = 1.0, t_max_s: float = 3600.0) -> dict[str, float]:
    """Seconds from ambient at `volts` (every whisker driven) until each limited material reaches its
    limit ("role (material)" -> s, math.inf if never within t_max_s or at steady state). Steps grow with
    time (2 % of the time elapsed, 10 ms at least); a crossing is interpolated inside its step."""
    v = np.broadcast_to(np.asarray(volts, dtype=float), (net.n,)) * math.sqrt(duty)
    limits = {f"{tm.ROLES[r][0]} ({name})": lim for _n, r, name, lim in net.limit_table}
    out = {k: math.inf for k in limits}
    steady = net.material_temperatures(steady_state_at_volts(net, volts, duty))
    todo = {k for k in limits if steady[k] > limits[k]}
    x, t = net.initial_state(), 0.0
    prev = net.material_temperatures(x)
    while todo and t < t_max_s:
        h = max(0.01, 0.02 * t)
        x = net.step_state(x, None, h, volts=v)
        cur = net.material_temperatures(x)
        for k in list(todo):
            if cur[k] >= limits[k]:
                a = (limits[k] - prev[k]) / max(cur[k] - prev[k], 1e-12)
                out[k] = t + h * min(max(a, 0.0), 1.0)
                todo.discard(k)
        prev, t = cur, t + h
    return out


def safe_duty(net: ThermalNetwork, volts, margin_K: float = 0.0) -> float:
    """Highest continuous PWM duty (0..1) at `volts` on every coil whose steady state keeps every
    material at least margin_K below its limit (bisection on the steady state)."""
    def ok(d):
        room, _ = net.headroom(steady_state_at_volts(net, volts, d))
        return float(np.min(room)) >= margin_K

    if ok(1.0):
        return 1.0
    if not ok(0.0):
        return 0.0
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def summary(design, volts: float) -> dict:
    """Everything the coil report prints about heating at `volts` across every coil, continuous, from
    the thermal network (finite numbers or None for "never")."""
    net = ThermalNetwork(design)
    times = time_to_limits_s(net, volts)
    first_key = min(times, key=times.get)
    t_first = times[first_key]
    if math.isinf(t_first):
        first_key = net.limit_label.split(" (")[0] + " (" + net.limit_name + ")"
    ss = steady_state_at_volts(net, volts)
    mats = net.material_temperatures(ss)
    cap = net.capacities_J_per_K()
    p_cold = volts * volts / float(_coil.resistance_ohm(design, net.ambient_C))
    lim_of = {f"{tm.ROLES[r][0]} ({name})": lim for _n, r, name, lim in net.limit_table}
    return {
        "volts": volts, "ambient_C": net.ambient_C, "model": "thermal network (whisker.coil.thermal_network)",
        "limit": first_key, "limit_C": lim_of.get(first_key, net.limit_C),
        "weakest_material": net.limit_label,
        "heat_capacity_J_per_K": cap["winding"], "copper_mass_g": net.geo.copper_mass_g,
        "power_cold_W": p_cold, "heating_rate_cold_K_per_s": p_cold / cap["winding"],
        "steady_state_C": float(np.max(net.winding_C(ss))),
        "steady_state_by_material_C": {k: float(v) for k, v in mats.items()},
        "time_to_first_limit_s": None if math.isinf(t_first) else t_first,
        "time_to_limit_s": {k: (None if math.isinf(v) else v) for k, v in times.items()},
        "limits_C": lim_of,
        "safe_duty": safe_duty(net, volts),
    }
