"""Thermal network of the whole sensor: a node per part, conductances and heat capacities from the
design's geometry (whisker.design.former, whisker.coil.winding, [mount], [membrane]) and the material
table (hw/materials/thermal.csv, whisker.coil.thermal_materials). Units: C, W, J/K, W/K, s, mm.

Nodes. Per whisker i (5 each): ``winding`` (copper + enamel, and the bobbin's core and outer flange,
which sit inside and against the winding), ``bobbin`` (the rod tab of the resin bobbin),
``rod`` (the carbon-fibre rod from its glued socket in the tab up through the membrane),
``membrane`` (the whisker's share of the Ecoflex membrane, an annulus around the rod), ``magnet``
(the NdFeB disc in its glued pocket). Shared (2): ``cavity air`` (the closed air under the membrane)
and ``mount`` (the PLA wall). The outside air is a fixed node at ``[thermal] ambient``.

Conductances (each formula's source in :func:`conductances`):

- winding -> bobbin: conduction through the winding along its axis to the tab face (uniformly
  heated slab, mean-to-face L/(3 k A)) in series with the tab's resin;
  the winding's transverse conductivity from Maxwell's formula for parallel cylinders in a matrix
  (copper in enamel: k = k_m (k_f + k_m + phi (k_f - k_m)) / (k_f + k_m - phi (k_f - k_m)));
- bobbin -> rod: the resin around the socket, the glue annulus ln(r_s/r_r)/(2 pi k L), the rod from
  the socket's middle to the membrane's mid-plane (L / (k A));
- rod -> outside: the 63 mm protrusion as a fin, sqrt(h P k A) tanh(m L_c) (Incropera eq. 3.81,
  corrected length L + D/4);
- rod -> membrane: the membrane share as an annular fin with an adiabatic rim (the neighbours'
  symmetry), efficiency eta from Incropera eq. 3.96 (Bessel functions); the node holds the fin's
  mean temperature, so G = eta h A / (1 - eta) in series with the faces' h A;
- surfaces -> cavity air and mount -> outside: convection ``[thermal] convection_coefficient``;
  radiation linearised, 4 eps sigma T_m^3 (T_m midway between ambient and the first limit), from
  the coil and bobbin to the mount wall and from outer faces to the outside;
- magnet -> mount: the glue layer behind it (``mount.glue_gap``) and the PLA to the wall's middle.

Heat: I^2 R(T) in each winding, R(T) = R20 (1 + alpha (T - 20)) (whisker.coil). The network is
linear in the temperatures for a given current, C dT/dt = A T + b, and is integrated implicitly
(backward Euler, sub-steps of at most ``max_substep_s``), stable for any step; the benchmark
(benchmarks/bench_thermal.py) measures its error against a tight ODE solution and the finite-element
model (whisker.coil.thermal_fe).

Limits: each node carries the materials that reach its temperature (the winding: its enamel and the
bobbin resin it touches; the bobbin: resin and the rod's glue; the rod: the rod, its glue and the
Ecoflex it passes through; the membrane: Ecoflex; the magnet: NdFeB, its glue and the PLA pocket; the
mount: PLA). The weakest (smallest headroom) sets the limit (:meth:`ThermalNetwork.headroom`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker import coil as _coil
from whisker.coil import thermal_materials as tm

SIGMA = 5.670374419e-8  # W/(m^2 K^4), Stefan-Boltzmann
KELVIN = 273.15
PER_WHISKER = ("winding", "bobbin", "rod", "membrane", "magnet")
SHARED = ("cavity air", "mount")
# node -> the part roles whose material reaches that node's temperature (first: the node's own)
NODE_MATERIALS = {
    "winding": ("enamel", "bobbin"),
    "bobbin": ("bobbin", "rod_glue"),
    "rod": ("rod", "rod_glue", "membrane"),
    "membrane": ("membrane",),
    "magnet": ("magnet", "magnet_glue", "mount"),
    "cavity air": (),
    "mount": ("mount",),
}


def maxwell_conductivity(k_fibre: float, k_matrix: float, fraction: float) -> float:
    """Transverse conductivity of parallel cylinders (volume fraction `fraction`) in a matrix, W/(m K).

    Maxwell (Rayleigh's first term) for cylinders: k = k_m (k_f + k_m + phi (k_f - k_m)) /
    (k_f + k_m - phi (k_f - k_m)) (e.g. Hashin & Shtrikman's lower bound in 2-D); between k_m and k_f.
    """
    if not (0.0 <= fraction < 1.0) or k_fibre <= 0 or k_matrix <= 0:
        raise ValueError(f"maxwell_conductivity: need 0 <= fraction < 1 and k > 0 (got {fraction}, "
                         f"{k_fibre}, {k_matrix})")
    d = k_fibre - k_matrix
    return k_matrix * (k_fibre + k_matrix + fraction * d) / (k_fibre + k_matrix - fraction * d)


def fin_conductance_W_per_K(h: float, k: float, diameter_mm: float, length_mm: float) -> float:
    """Heat a pin fin (the rod above the membrane) takes from its root per kelvin, W/K.

    G = sqrt(h P k A) tanh(m L_c), m = sqrt(h P / (k A)), L_c = L + D/4 (Incropera 7th ed. eq. 3.81 with
    the corrected length, Table 3.4 case A)."""
    D, L = diameter_mm * 1e-3, length_mm * 1e-3
    P, A = math.pi * D, math.pi * D * D / 4.0
    m = math.sqrt(h * P / (k * A))
    return math.sqrt(h * P * k * A) * math.tanh(m * (L + D / 4.0))


def annular_fin_efficiency(h: float, k: float, thickness_mm: float, r1_mm: float, r2_mm: float) -> float:
    """Efficiency of an annular fin of thickness t, convection h (the sum of both faces' h) and an
    adiabatic rim at r2 (Incropera 7th ed. eq. 3.96 / Table 3.5), 0..1."""
    from scipy.special import i0, i1, k0, k1

    t, r1, r2 = thickness_mm * 1e-3, r1_mm * 1e-3, r2_mm * 1e-3
    if r2 <= r1:
        return 1.0
    m = math.sqrt(h / (k * t))
    num = k1(m * r1) * i1(m * r2) - i1(m * r1) * k1(m * r2)
    den = i0(m * r1) * k1(m * r2) + k0(m * r1) * i1(m * r2)
    return float(min(1.0, (2.0 * r1 / m) / (r2 * r2 - r1 * r1) * num / den))


def winding_face_resistance_K_per_W(length_mm: float, k: float, area_mm2: float) -> float:
    """Mean temperature of a uniformly heated slab of `length_mm` to its one cooled face (the other
    adiabatic): L / (3 k A), K/W (T(x) parabolic: mean - face = q L^2 / (3 k), Q = q L A)."""
    return (length_mm * 1e-3) / (3.0 * k * area_mm2 * 1e-6)


@dataclass(frozen=True)
class Geometry:
    """What the network reads from the design for one whisker (mm, mm^2, mm^3)."""

    winding_ri: float
    winding_ro: float
    winding_length: float
    coil_ro: float
    flange: float
    tab_x: float
    tab_y: float
    tab_z: float
    bore_r: float
    rod_r: float
    socket_r: float
    socket_depth: float
    rod_socket_to_membrane_mid: float
    rod_in_cavity: float
    rod_total_below: float
    protrusion: float
    membrane_t: float
    membrane_r2: float
    magnet_r: float
    magnet_h: float
    glue_gap: float
    clearance: float
    cavity_r: float
    cavity_h: float
    mount_ro: float
    copper_mass_g: float
    enamel_mass_g: float
    copper_fill: float


def geometry(design) -> Geometry:
    from whisker.design.former import layout

    d, c, b = design, design.coil, design.bobbin
    f = layout(d)
    w = _coil.winding(d)
    t = d.membrane.thickness
    sock_depth = f.tab_top - f.socket_bottom
    n = d.whiskers.count
    m = d.membrane
    polygon_area = m.sides * m.inscribed_radius ** 2 * math.tan(math.pi / m.sides)
    ri, ro = f.winding_inner_diameter / 2.0, w.wound_outer_diameter_mm / 2.0
    return Geometry(
        winding_ri=ri, winding_ro=ro, winding_length=f.winding_length, coil_ro=c.outer_diameter / 2.0,
        flange=b.flange, tab_x=f.tab[1] - f.tab[0], tab_y=2 * f.half_width, tab_z=f.tab_top - f.tab_bottom,
        bore_r=f.bore / 2.0, rod_r=d.whiskers.rod_diameter / 2.0, socket_r=f.socket_diameter / 2.0,
        socket_depth=sock_depth, rod_socket_to_membrane_mid=sock_depth / 2.0 - f.tab_top + t / 2.0,
        rod_in_cavity=-f.tab_top, rod_total_below=d.rod_below_membrane + t, protrusion=d.whiskers.protrusion,
        membrane_t=t, membrane_r2=math.sqrt(polygon_area / n / math.pi), magnet_r=d.magnet.diameter / 2.0,
        magnet_h=d.magnet.height, glue_gap=d.mount.glue_gap, clearance=d.print.clearance,
        cavity_r=d.cavity_radius, cavity_h=-d.camera_z, mount_ro=float(d.mount.outer_radius),
        copper_mass_g=w.copper_mass_g, enamel_mass_g=w.enamel_mass_g,
        copper_fill=w.turns * math.pi * c.wire_diameter ** 2 / 4.0 / ((ro - ri) * f.winding_length))


def limits_by_node(design) -> dict[str, list[tuple[str, str, float]]]:
    """node -> [(role, material name, limit C), ...] of the materials that reach its temperature."""
    out = {}
    for node, roles in NODE_MATERIALS.items():
        out[node] = [(r, tm.row_name(design, r), tm.limit_C(design, r)) for r in roles
                     if math.isfinite(tm.limit_C(design, r))]
    return out


class ThermalNetwork:
    """The sensor's thermal network (module docstring). State: node temperatures (C), shape (5 n + 2,):
    whisker i's nodes at 5 i .. 5 i + 4 in the order of PER_WHISKER, then cavity air, mount.

    ``exchange`` = False cuts the cavity air and the mount out (every surface sees the ambient
    directly, radiation to the ambient): the configuration of the finite-element check.
    """

    def __init__(self, design, *, exchange: bool = True, max_substep_s: float = 0.05):
        self.design = design
        self.n = int(design.whiskers.count)
        self.mat = tm.design_materials(design)
        self.geo = geometry(design)
        self.ambient_C = float(design.thermal.ambient)
        self.exchange = bool(exchange)
        self.max_substep_s = float(max_substep_s)
        self.r20_ohm = float(_coil.resistance_ohm(design, 20.0))
        self.alpha = _coil.ALPHA20_PER_K
        lim = limits_by_node(design)
        self.node_limits = lim
        self.limit_table = [(node, role, name, c) for node, items in lim.items() for role, name, c in items]
        first = min(self.limit_table, key=lambda r: r[3])
        self.limit_node, self.limit_role, self.limit_name, self.limit_C = first
        self.limit_label = label(first)
        # the lowest limit at the winding's own temperature (the hottest node: its resistance there)
        self.winding_limit_C = min(c for _r, _n, c in lim["winding"]) if lim["winding"] else self.limit_C
        self.size = 5 * self.n + 2
        self.C, self.G, self.g_amb = self._build()
        self.winding_idx = np.arange(self.n) * 5
        self._base = None

    # ---- the parts ------------------------------------------------------------------------------
    def _h(self):
        th = self.design.thermal
        tm_K = (self.ambient_C + min(self.limit_C, self.ambient_C + 100.0)) / 2.0 + KELVIN
        h_rad = 4.0 * float(th.emissivity) * SIGMA * tm_K ** 3
        return float(th.convection_coefficient), h_rad

    def capacities_J_per_K(self) -> dict[str, float]:
        """Heat capacity of each of one whisker's nodes and of the shared nodes, J/K."""
        g, M = self.geo, self.mat
        core = math.pi * (g.winding_ri ** 2 - g.bore_r ** 2) * g.winding_length
        flange = math.pi * g.coil_ro ** 2 * g.flange
        rim = math.pi * (g.coil_ro ** 2 - g.winding_ro ** 2) * 0.0
        tab = g.tab_x * g.tab_y * g.tab_z - math.pi * g.socket_r ** 2 * g.socket_depth
        rod_v = math.pi * g.rod_r ** 2 * g.rod_total_below
        glue_v = math.pi * (g.socket_r ** 2 - g.rod_r ** 2) * g.socket_depth
        a_p = math.pi * (g.membrane_r2 ** 2 - g.rod_r ** 2)
        mag_v = math.pi * g.magnet_r ** 2 * g.magnet_h
        cav_v = math.pi * g.cavity_r ** 2 * g.cavity_h
        wall_v = math.pi * (g.mount_ro ** 2 - g.cavity_r ** 2) * g.cavity_h
        rc = {k: v.volumetric_heat_J_per_mm3K for k, v in M.items()}
        return {
            "winding": (g.copper_mass_g * M["winding"].specific_heat_J_gK + g.enamel_mass_g * M["enamel"].specific_heat_J_gK
                        + (core + flange + rim) * rc["bobbin"]),
            "bobbin": tab * rc["bobbin"],
            "rod": rod_v * rc["rod"] + glue_v * rc["rod_glue"],
            "membrane": a_p * g.membrane_t * rc["membrane"],
            "magnet": mag_v * rc["magnet"],
            "cavity air": cav_v * rc["air"],
            "mount": wall_v * rc["mount"],
        }

    def winding_conductivity_W_mK(self) -> float:
        """Transverse conductivity of the winding (copper in its enamel, Maxwell), W/(m K)."""
        return maxwell_conductivity(self.mat["winding"].conductivity_W_mK, self.mat["enamel"].conductivity_W_mK,
                                    min(self.geo.copper_fill, 0.9))

    def conductances(self) -> dict[str, float]:
        """Every conductance of one whisker (and its shares of the shared ones), W/K."""
        g, M = self.geo, self.mat
        h, hr = self._h()
        k_w = self.winding_conductivity_W_mK()
        k_b, k_g, k_r = M["bobbin"].conductivity_W_mK, M["rod_glue"].conductivity_W_mK, M["rod"].conductivity_W_mK
        k_m, k_mg = M["membrane"].conductivity_W_mK, M["magnet_glue"].conductivity_W_mK
        k_pla = M["mount"].conductivity_W_mK
        mm2 = 1e-6
        face = math.pi * (g.winding_ro ** 2 - g.winding_ri ** 2)
        # winding -> tab: the winding along its axis, then the resin from the tab face to the tab's middle
        r_w = winding_face_resistance_K_per_W(g.winding_length, k_w, face)
        r_tab = winding_face_resistance_K_per_W(g.tab_x, k_b, g.tab_y * g.tab_z)
        # tab -> rod: resin around the socket (tab cross-section's equivalent radius), glue annulus,
        # rod from the socket's middle to the membrane's mid-plane
        r_eq = max(math.sqrt(g.tab_x * g.tab_y / math.pi), g.socket_r * 1.01)
        L_s = g.socket_depth * 1e-3
        r_resin = math.log(r_eq / g.socket_r) / (2 * math.pi * k_b * L_s)
        r_glue = math.log(g.socket_r / g.rod_r) / (2 * math.pi * k_g * L_s)
        a_rod = math.pi * g.rod_r ** 2 * mm2
        r_rod = g.rod_socket_to_membrane_mid * 1e-3 / (k_r * a_rod)
        # rod -> outside: half the membrane thickness of rod, then the protrusion as a fin
        g_fin = fin_conductance_W_per_K(h + hr, k_r, 2 * g.rod_r, g.protrusion)
        g_rod_out = 1.0 / (g.membrane_t / 2.0 * 1e-3 / (k_r * a_rod) + 1.0 / g_fin)
        # rod -> membrane (annular fin, both faces), membrane faces -> outside (upper) / cavity (lower)
        a_p = math.pi * (g.membrane_r2 ** 2 - g.rod_r ** 2) * mm2
        h_up, h_down = h + hr, h + (hr if not self.exchange else 0.0)
        eta = annular_fin_efficiency(h_up + h_down, k_m, g.membrane_t, g.rod_r, g.membrane_r2)
        hA = (h_up + h_down) * a_p
        g_rod_mem = hA * eta / max(1.0 - eta, 1e-9)
        # coil + bobbin surfaces in the cavity (flange face and rim, winding side, the tab's free faces)
        a_coil = (2 * math.pi * g.winding_ro * g.winding_length + math.pi * g.coil_ro ** 2
                  + 2 * math.pi * g.coil_ro * g.flange + math.pi * (g.coil_ro ** 2 - g.winding_ro ** 2)) * mm2
        a_tab = (2 * g.tab_x * g.tab_z + 2 * g.tab_y * g.tab_z + 2 * g.tab_x * g.tab_y - face
                 - math.pi * g.socket_r ** 2) * mm2
        a_rod_cav = 2 * math.pi * g.rod_r * g.rod_in_cavity * mm2
        # magnet: its face in the cavity; glue behind it and the pocket's air gap around it to the PLA,
        # then the PLA to the wall's middle
        a_mag_face = math.pi * g.magnet_r ** 2 * mm2
        wall_t = g.mount_ro - g.cavity_r
        g_glue = k_mg * a_mag_face / (g.glue_gap * 1e-3)
        a_side = 2 * math.pi * g.magnet_r * g.magnet_h * mm2
        g_side = M["air"].conductivity_W_mK * a_side / (g.clearance * 1e-3)
        g_pla = k_pla * (a_mag_face + a_side) / (max(wall_t - g.magnet_h - g.glue_gap, 0.1) / 2.0 * 1e-3 + 1e-6)
        g_mag_mount = 1.0 / (1.0 / (g_glue + g_side) + 1.0 / g_pla)
        n = self.n
        a_wall_in = (2 * math.pi * g.cavity_r * g.cavity_h + math.pi * g.cavity_r ** 2) * mm2
        a_wall_out = (2 * math.pi * g.mount_ro * g.cavity_h + math.pi * (g.mount_ro ** 2 - g.cavity_r ** 2)) * mm2
        return {
            "winding-bobbin": 1.0 / (r_w + r_tab),
            "bobbin-rod": 1.0 / (r_resin + r_glue + r_rod),
            "rod-outside": g_rod_out,
            "rod-membrane": g_rod_mem,
            "membrane-outside": h_up * a_p,
            "membrane-cavity": h_down * a_p,
            "winding-cavity": h * a_coil,
            "winding-mount (radiation)": hr * a_coil,
            "bobbin-cavity": h * a_tab,
            "bobbin-mount (radiation)": hr * a_tab,
            "rod-cavity": h * a_rod_cav,
            "magnet-cavity": h * a_mag_face,
            "magnet-mount": g_mag_mount,
            "cavity-mount (share)": h * a_wall_in / n,
            "mount-outside (share)": (h + hr) * a_wall_out / n,
        }

    def _build(self):
        """(C (size,), G (size, size) symmetric conductance matrix between nodes, g_amb (size,) to outside)."""
        cap = self.capacities_J_per_K()
        gc = self.conductances()
        n, N = self.n, self.size
        C = np.zeros(N)
        G = np.zeros((N, N))
        ga = np.zeros(N)
        air, wall = 5 * n, 5 * n + 1

        def link(a, b, g):
            if b is None:
                ga[a] += g
            else:
                G[a, b] += g
                G[b, a] += g

        cav = air if self.exchange else None
        mnt = wall if self.exchange else None
        for i in range(n):
            w, b, r, m, q = 5 * i, 5 * i + 1, 5 * i + 2, 5 * i + 3, 5 * i + 4
            for k, name in enumerate(PER_WHISKER):
                C[5 * i + k] = cap[name]
            link(w, b, gc["winding-bobbin"])
            link(b, r, gc["bobbin-rod"])
            link(r, None, gc["rod-outside"])
            link(r, m, gc["rod-membrane"])
            link(m, None, gc["membrane-outside"])
            link(m, cav, gc["membrane-cavity"])
            link(w, cav, gc["winding-cavity"])
            link(w, mnt, gc["winding-mount (radiation)"])
            link(b, cav, gc["bobbin-cavity"])
            link(b, mnt, gc["bobbin-mount (radiation)"])
            link(r, cav, gc["rod-cavity"])
            link(q, cav, gc["magnet-cavity"])
            link(q, mnt, gc["magnet-mount"])
            if self.exchange:
                link(air, wall, gc["cavity-mount (share)"])
                link(wall, None, gc["mount-outside (share)"])
        C[air], C[wall] = cap["cavity air"], cap["mount"]
        if not self.exchange:  # unused nodes: pinned to ambient by a large conductance
            ga[air] = ga[wall] = 1e6
        return C, G, ga

    # ---- dynamics ----------------------------------------------------------------------------------
    def initial_state(self, temperature_C: float | None = None) -> np.ndarray:
        return np.full(self.size, self.ambient_C if temperature_C is None else float(temperature_C))

    def _system(self):
        if self._base is None:
            L = np.diag(self.G.sum(axis=1) + self.g_amb) - self.G       # conductance Laplacian + outside
            self._base = (L, self.g_amb * self.ambient_C)
        return self._base

    def heat_W(self, state: np.ndarray, currents_A) -> np.ndarray:
        """Joule heat of each winding at the state's winding temperatures, W (n,)."""
        i = np.asarray(currents_A, dtype=float)
        return i * i * self.r20_ohm * (1.0 + self.alpha * (state[self.winding_idx] - 20.0))

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
        wi = self.winding_idx
        b = src.copy()
        diag = np.zeros(self.size)
        if power_W is not None:
            b[wi] += np.asarray(power_W, dtype=float)
        elif volts is not None:
            v = np.asarray(volts, dtype=float)
            f0 = 1.0 + self.alpha * (x[wi] - 20.0)
            p0 = v * v / (self.r20_ohm * f0)
            dp = -p0 * self.alpha / f0                 # dP/dT < 0: a warmer coil takes less at a fixed voltage
            b[wi] += p0 - dp * x[wi]
            diag[wi] = dp
        else:
            i = np.asarray(currents_A, dtype=float)
            if i.shape != (self.n,) or not np.all(np.isfinite(i)):
                raise ValueError(f"ThermalNetwork.step_state: currents must be {self.n} finite numbers")
            p0 = i * i * self.r20_ohm
            b[wi] += p0 * (1.0 - 20.0 * self.alpha)
            diag[wi] = p0 * self.alpha               # dP/dT: heat that grows with the temperature
        steps = max(1, math.ceil(dt / self.max_substep_s))
        h = dt / steps
        M = self._implicit_matrix(h).copy()
        M[wi, wi] -= diag[wi]
        ch = self.C / h
        for _ in range(steps):
            x = np.linalg.solve(M, ch * x + b)
        return np.minimum(x, 5000.0)

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
        wi = self.winding_idx
        b = src.copy()
        M = L.copy()
        if power_W is not None:
            b[wi] += np.asarray(power_W, dtype=float)
        else:
            i = np.asarray(currents_A, dtype=float)
            p0 = i * i * self.r20_ohm
            b[wi] += p0 * (1.0 - 20.0 * self.alpha)
            M[wi, wi] -= p0 * self.alpha
        return np.linalg.solve(M, b)

    # ---- limits ------------------------------------------------------------------------------------
    def node_temperatures(self, state) -> dict[str, np.ndarray]:
        """node name -> temperatures (n,) per whisker, or (1,) for the shared ones, C."""
        x = np.asarray(state)
        out = {name: x[k:5 * self.n:5] for k, name in enumerate(PER_WHISKER)}
        out["cavity air"] = x[5 * self.n:5 * self.n + 1]
        out["mount"] = x[5 * self.n + 1:5 * self.n + 2]
        return out

    def winding_C(self, state) -> np.ndarray:
        return np.asarray(state)[self.winding_idx]

    def material_temperatures(self, state) -> dict[str, float]:
        """Highest temperature each limited material reaches anywhere in `state`, C ("role (material)")."""
        nt = self.node_temperatures(state)
        out: dict[str, float] = {}
        for node, items in self.node_limits.items():
            for role, name, _ in items:
                key = f"{tm.ROLES[role][0]} ({name})"
                out[key] = max(out.get(key, -math.inf), float(np.max(nt[node])))
        return out

    def _limit_index(self):
        """(indices (rows, n) into the state, limits (rows,), labels (rows,)) of every limited material."""
        if getattr(self, "_lim_idx", None) is None:
            idx, lims, labels = [], [], []
            names = list(PER_WHISKER)
            for node, items in self.node_limits.items():
                if node in names:
                    col = np.arange(self.n) * 5 + names.index(node)
                else:
                    col = np.full(self.n, 5 * self.n + list(SHARED).index(node))
                for role, name, lim in items:
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
        """Capacities, conductances and limits, for reports and docs."""
        return {"capacities_J_per_K": self.capacities_J_per_K(), "conductances_W_per_K": self.conductances(),
                "winding_conductivity_W_mK": self.winding_conductivity_W_mK(),
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
