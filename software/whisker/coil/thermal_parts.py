"""The parts of the sensor's thermal network: what each node holds and how they connect, from the design's
geometry (whisker.design.former, whisker.coil.winding, [mount], [membrane]) and the material table
(hw/materials/thermal.csv, whisker.coil.thermal_materials). The network that steps and solves them is
whisker.coil.thermal_network. Units: C, W, J/K, W/K, mm (m inside the conductance formulas).

Nodes. Per whisker: ``winding`` (copper + enamel, and the bobbin's core and outer flange, which sit
inside and against the winding), the ``bobbin`` tab (the rod tab of the resin bobbin) as a ladder of
``tab_nodes`` slices, ``rod`` (the carbon-fibre rod from its glued socket in the tab up through the
membrane), ``membrane`` (the whisker's share of the Ecoflex membrane, an annulus around the rod),
``magnet`` (the NdFeB disc in its glued pocket). Shared (2): ``cavity air`` (the closed air under the
membrane) and ``mount`` (the PLA wall). The outside air is a fixed node at ``[thermal] ambient``.

The tab as a ladder. The winding presses on one face of the tab (x = tab[1]); the heat crosses the
tab's 2 mm of resin along the coil axis towards the rod's socket (in its middle) and its far face,
and leaves it through its free faces on the way: a 1-D fin. Resin diffuses slowly (alpha = k / (rho c)
= 1.1e-7 m^2/s: sqrt(alpha t) = 0.5 mm at 2 s), so one node for the whole tab (time constant 14 s)
misses how fast the resin next to the winding warms. The tab is cut into N slices of equal thickness
dx = L / N normal to that path, a node at each slice's centre (the implicit finite-difference / energy
balance method of Incropera, DeWitt, Bergman & Lavine, Fundamentals of Heat and Mass Transfer, 7th ed.,
sec. 5.10 and 4.4; the network's backward Euler is that implicit scheme): neighbours joined by
k A / dx, the winding joined to slice 0 through its own mean-to-face resistance and half a slice;
each slice holds its volume (less its share of the socket) and its free faces (the sides in
proportion to dx, the end faces on the end slices, less the socket's opening); the rod draws from the
slices the socket crosses, each its share of the socket's circle. N = 1 is the former single node
(with half the slab, L / (2 k A), from the face to the node instead of L / (3 k A)).
benchmarks/results/thermal.md gives the tab at 2 s and at steady state against N.

Conductances (:func:`conductances`):

- winding -> tab: conduction through the winding along its axis to the tab face (uniformly
  heated slab, mean-to-face L/(3 k A)), then the ladder above;
  the winding's transverse conductivity from Maxwell's formula for parallel cylinders in a matrix
  (copper in enamel: k = k_m (k_f + k_m + phi (k_f - k_m)) / (k_f + k_m - phi (k_f - k_m)));
- tab -> rod: the resin around the socket, the glue annulus ln(r_s/r_r)/(2 pi k L), the rod from
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

Limits: each node carries the materials that reach its temperature (the winding: its enamel and the
bobbin resin it touches; the tab slices: resin and the rod's glue; the rod: the rod, its glue and the
Ecoflex it passes through; the membrane: Ecoflex; the magnet: NdFeB, its glue and the PLA pocket; the
mount: PLA).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

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


def circle_strip_area_mm2(r_mm: float, centre_mm: float, a_mm: float, b_mm: float) -> float:
    """Area of a disc of radius r centred at `centre` between the lines x = a and x = b (a <= b), mm^2:
    F(b) - F(a) with F(u) = r^2 (asin t + t sqrt(1 - t^2) + pi/2), t = (u - c) / r clipped to [-1, 1]."""
    def F(u):
        t = min(1.0, max(-1.0, (u - centre_mm) / r_mm))
        return r_mm * r_mm * (math.asin(t) + t * math.sqrt(1.0 - t * t) + math.pi / 2.0)
    return F(b_mm) - F(a_mm)


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
    socket_x: float            # the socket's axis from the tab's face against the winding
    axis_in_tab: float         # the coil's axis above the tab's lower face
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
        socket_x=f.tab[1] - d.whiskers.ring_radius, axis_in_tab=f.axis_z - f.tab_bottom,
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


def film_coefficients_W_m2K(design, first_limit_C: float) -> tuple[float, float]:
    """(convection h, linearised radiation 4 eps sigma T_m^3), W/(m^2 K); T_m midway between the
    ambient and the first limit (at most 100 K above the ambient)."""
    th = design.thermal
    amb = float(th.ambient)
    tm_K = (amb + min(first_limit_C, amb + 100.0)) / 2.0 + KELVIN
    return float(th.convection_coefficient), 4.0 * float(th.emissivity) * SIGMA * tm_K ** 3


def winding_conductivity_W_mK(geo: Geometry, mat) -> float:
    """Transverse conductivity of the winding (copper in its enamel, Maxwell), W/(m K)."""
    return maxwell_conductivity(mat["winding"].conductivity_W_mK, mat["enamel"].conductivity_W_mK,
                                min(geo.copper_fill, 0.9))


def _tab_surface_mm2(g: Geometry) -> float:
    """The tab's free faces (less the winding's face on it and the socket's opening), mm^2."""
    face = math.pi * (g.winding_ro ** 2 - g.winding_ri ** 2)
    return (2 * g.tab_x * g.tab_z + 2 * g.tab_y * g.tab_z + 2 * g.tab_x * g.tab_y - face
            - math.pi * g.socket_r ** 2)


def capacities_J_per_K(g: Geometry, M) -> dict[str, float]:
    """Heat capacity of each of one whisker's parts (the tab whole) and of the shared nodes, J/K."""
    core = math.pi * (g.winding_ri ** 2 - g.bore_r ** 2) * g.winding_length
    flange = math.pi * g.coil_ro ** 2 * g.flange
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
                    + (core + flange) * rc["bobbin"]),
        "bobbin": tab * rc["bobbin"],
        "rod": rod_v * rc["rod"] + glue_v * rc["rod_glue"],
        "membrane": a_p * g.membrane_t * rc["membrane"],
        "magnet": mag_v * rc["magnet"],
        "cavity air": cav_v * rc["air"],
        "mount": wall_v * rc["mount"],
    }


@dataclass(frozen=True)
class Ladder:
    """A part cut into N slices along its conduction path (module docstring), slice 0 at the face where
    the winding meets the tab. Arrays of N."""

    cuts_mm: np.ndarray        # slice boundaries from that face, mm (N + 1)
    capacity: np.ndarray       # each slice's heat capacity, J/K
    g_step: np.ndarray         # slice j -> j + 1, W/K (N - 1)
    r_half_K_per_W: float      # slice 0's centre to the winding-tab face
    surface: np.ndarray        # free faces of each slice, m^2
    rod_share: np.ndarray      # share of the tab -> rod conductance each slice takes (the tab's; sums to 1)

    @cached_property
    def share(self) -> np.ndarray:
        """Each slice's share of the part's length (of the winding's wire, so of its heat and resistance)."""
        w = np.diff(self.cuts_mm)
        return w / w.sum()


def slice_cuts_mm(length_mm: float, n_slices) -> np.ndarray:
    """Slice boundaries s_j = L (j / N)^2 from the winding-tab face, mm (N + 1): thin where the heat
    enters (the first L / N^2), every slice thinner as N grows, so the ladder converges."""
    if not (isinstance(n_slices, (int, np.integer)) and n_slices >= 1):
        raise ValueError(f"thermal ladder: need an integer number of slices >= 1 (got {n_slices!r})")
    return length_mm * (np.arange(int(n_slices) + 1) / int(n_slices)) ** 2


def _series(widths_mm, k, areas_mm2):
    """Centre-to-centre conductances of neighbouring slices: two half slices in series, W/K (N - 1)."""
    r = (widths_mm / 2.0) * 1e-3 / (k * np.asarray(areas_mm2) * 1e-6)
    return 1.0 / (r[:-1] + r[1:])


def winding_ladder(g: Geometry, M, n_slices: int) -> Ladder:
    """The winding (with its core, and the outer flange on the last slice) in slices along its axis from
    the tab's face: uniformly heated, joined through the winding's transverse conductivity over its
    annulus. The free faces: the winding's side per slice, the flange's faces on the last."""
    cuts = slice_cuts_mm(g.winding_length, n_slices)
    w = np.diff(cuts)
    k_w = winding_conductivity_W_mK(g, M)
    face = math.pi * (g.winding_ro ** 2 - g.winding_ri ** 2)
    core = math.pi * (g.winding_ri ** 2 - g.bore_r ** 2) * g.winding_length
    flange = math.pi * g.coil_ro ** 2 * g.flange
    rc = M["bobbin"].volumetric_heat_J_per_mm3K
    body = (g.copper_mass_g * M["winding"].specific_heat_J_gK + g.enamel_mass_g * M["enamel"].specific_heat_J_gK
            + core * rc)
    capacity = body * w / g.winding_length
    capacity[-1] += flange * rc
    surface = 2 * math.pi * g.winding_ro * w
    surface[-1] += (math.pi * g.coil_ro ** 2 + 2 * math.pi * g.coil_ro * g.flange
                    + math.pi * (g.coil_ro ** 2 - g.winding_ro ** 2))
    return Ladder(cuts_mm=cuts, capacity=capacity, g_step=_series(w, k_w, np.full(w.size, face)),
                  r_half_K_per_W=(w[0] / 2.0) * 1e-3 / (k_w * face * 1e-6), surface=surface * 1e-6,
                  rod_share=np.zeros(w.size))


def spread_area_mm2(g: Geometry, depth_mm: float) -> float:
    """Cross-section the heat crosses `depth_mm` into the tab: the winding's footprint (a disc of its
    outer radius about the coil axis) grown by the depth (a 45-degree spreading cone), within the tab's
    y-z rectangle, mm^2 (numerical chord integral over z)."""
    rho = g.winding_ro + max(depth_mm, 0.0)
    z = np.linspace(0.0, g.tab_z, 2001)
    zm = 0.5 * (z[1:] + z[:-1]) - g.axis_in_tab
    chord = np.minimum(np.sqrt(np.clip(rho * rho - zm * zm, 0.0, None)), g.tab_y / 2.0)
    return float(2.0 * chord.sum() * (z[1] - z[0]))


def tab_ladder(g: Geometry, M, n_slices: int) -> Ladder:
    """The tab in slices from the winding's face to its far face (module docstring)."""
    cuts = slice_cuts_mm(g.tab_x, n_slices)
    w = np.diff(cuts)
    k_b = M["bobbin"].conductivity_W_mK
    area = g.tab_y * g.tab_z                                    # the tab's y-z section, mm^2
    # the spreading section at each slice's centre (at a quarter of the first: its mean for the entry)
    a_mid = np.array([spread_area_mm2(g, 0.5 * (a + b)) for a, b in zip(cuts[:-1], cuts[1:])])
    hole = np.array([circle_strip_area_mm2(g.socket_r, g.socket_x, a, b) for a, b in zip(cuts[:-1], cuts[1:])])
    face = math.pi * (g.winding_ro ** 2 - g.winding_ri ** 2)
    surface = (2 * g.tab_z + 2 * g.tab_y) * w - hole           # sides along the path, less the opening
    surface[0] += area - face                                  # the face against the winding, less it
    surface[-1] += area                                        # the far face
    return Ladder(cuts_mm=cuts, capacity=(area * w - hole * g.socket_depth) * M["bobbin"].volumetric_heat_J_per_mm3K,
                  g_step=_series(w, k_b, a_mid),
                  r_half_K_per_W=(w[0] / 2.0) * 1e-3 / (k_b * spread_area_mm2(g, w[0] / 4.0) * 1e-6),
                  surface=surface * 1e-6, rod_share=hole / hole.sum())


def conductances(g: Geometry, M, h: float, hr: float, n_whiskers: int, exchange: bool) -> dict[str, float]:
    """Every conductance of one whisker (and its shares of the shared ones), W/K; the tab's whole
    (its ladder: :func:`tab_ladder`). h, hr: convection and linearised radiation, W/(m^2 K)."""
    k_b, k_g, k_r = M["bobbin"].conductivity_W_mK, M["rod_glue"].conductivity_W_mK, M["rod"].conductivity_W_mK
    k_m, k_mg = M["membrane"].conductivity_W_mK, M["magnet_glue"].conductivity_W_mK
    k_pla = M["mount"].conductivity_W_mK
    mm2 = 1e-6
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
    h_up, h_down = h + hr, h + (hr if not exchange else 0.0)
    eta = annular_fin_efficiency(h_up + h_down, k_m, g.membrane_t, g.rod_r, g.membrane_r2)
    hA = (h_up + h_down) * a_p
    g_rod_mem = hA * eta / max(1.0 - eta, 1e-9)
    # coil + bobbin surfaces in the cavity (flange face and rim, winding side, the tab's free faces)
    a_coil = (2 * math.pi * g.winding_ro * g.winding_length + math.pi * g.coil_ro ** 2
              + 2 * math.pi * g.coil_ro * g.flange + math.pi * (g.coil_ro ** 2 - g.winding_ro ** 2)) * mm2
    a_tab = _tab_surface_mm2(g) * mm2
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
    n = n_whiskers
    a_wall_in = (2 * math.pi * g.cavity_r * g.cavity_h + math.pi * g.cavity_r ** 2) * mm2
    a_wall_out = (2 * math.pi * g.mount_ro * g.cavity_h + math.pi * (g.mount_ro ** 2 - g.cavity_r ** 2)) * mm2
    return {
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


def assemble(cap: dict, gc: dict, winding: Ladder, tab: Ladder, h: float, hr: float, n: int, exchange: bool):
    """(C (size,), G (size, size) symmetric conductance matrix between nodes, g_amb (size,) to the
    outside). Whisker i's nodes at K i .. K i + K - 1 (K = M + N + 3: the winding's M slices, the
    tab's N slices, rod, membrane, magnet), then cavity air, mount."""
    Mw, N = winding.capacity.size, tab.capacity.size
    K = Mw + N + 3
    size = K * n + 2
    C = np.zeros(size)
    G = np.zeros((size, size))
    ga = np.zeros(size)
    air, wall = K * n, K * n + 1

    def link(a, b, g):
        if b is None:
            ga[a] += g
        else:
            G[a, b] += g
            G[b, a] += g

    cav = air if exchange else None
    mnt = wall if exchange else None
    for i in range(n):
        ws = K * i + np.arange(Mw)
        ts = K * i + Mw + np.arange(N)
        r, m, q = K * i + Mw + N, K * i + Mw + N + 1, K * i + Mw + N + 2
        C[ws], C[ts] = winding.capacity, tab.capacity
        C[r], C[m], C[q] = cap["rod"], cap["membrane"], cap["magnet"]
        link(ws[0], ts[0], 1.0 / (winding.r_half_K_per_W + tab.r_half_K_per_W))
        for lad, nodes in ((winding, ws), (tab, ts)):
            for j, a in enumerate(nodes):
                if j + 1 < nodes.size:
                    link(a, nodes[j + 1], lad.g_step[j])
                if lad.rod_share[j] > 0:
                    link(a, r, gc["bobbin-rod"] * lad.rod_share[j])
                link(a, cav, h * lad.surface[j])
                link(a, mnt, hr * lad.surface[j])
        link(r, None, gc["rod-outside"])
        link(r, m, gc["rod-membrane"])
        link(m, None, gc["membrane-outside"])
        link(m, cav, gc["membrane-cavity"])
        link(r, cav, gc["rod-cavity"])
        link(q, cav, gc["magnet-cavity"])
        link(q, mnt, gc["magnet-mount"])
        if exchange:
            link(air, wall, gc["cavity-mount (share)"])
            link(wall, None, gc["mount-outside (share)"])
    C[air], C[wall] = cap["cavity air"], cap["mount"]
    if not exchange:  # unused nodes: pinned to ambient by a large conductance
        ga[air] = ga[wall] = 1e6
    return C, G, ga
