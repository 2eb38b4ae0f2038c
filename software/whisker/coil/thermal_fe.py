"""Finite-element conduction model of one whisker's coil, bobbin, rod and membrane: the finer model the
thermal network (whisker.coil.thermal_network) is checked against. Needs scikit-fem (the library of
the membrane model): ``pip install 'whisker-array[fem]'``.

Geometry (mm) from the same design readers as the network (whisker.coil.thermal_parts.geometry,
whisker.design.former): the winding (an annulus about the radial coil axis), the bobbin's core,
outer flange and rod tab (resin, with the rod's socket), the glue annulus in the socket, the rod
from the socket's floor to the membrane's upper face, and the whisker's share of the membrane (a
disc of the network's radius about the rod, 3 mm thick). Half of it (y >= 0; the plane through the
rod and the coil axis is a plane of symmetry) on a tensor-product hexahedral grid whose lines pass
through every face of the parts (trilinear ElementHex1); each cell takes the material of its centre,
cells of air are removed.

Boundaries: convection with the network's coefficients to the ambient on every free face (h plus
the linearised radiation, as ThermalNetwork(exchange=False)), adiabatic on the symmetry plane, the
membrane disc's rim (its neighbours' symmetry) and the bore; the 63 mm of rod above the membrane
enter as the same fin conductance on the rod's upper end face. Heat: a uniform power in the winding.
Transient: M dT/dt + K T = f, backward Euler with a sparse LU (scipy) of (M/dt + K).
Units inside: mm, W, J, K (k in W/(mm K), rho c in J/(mm^3 K), h in W/(mm^2 K)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker.coil.thermal_network import ThermalNetwork
from whisker.coil.thermal_parts import fin_conductance_W_per_K

# "bobbin": the rod tab (resin); "resin": the core and the outer flange; "rod": the rod in the membrane
# (the network's rod node), "rod below": the rest of it
PARTS = ("winding", "resin", "glue", "rod below", "membrane", "bobbin", "rod")


def _skfem():
    import skfem  # a ModuleNotFoundError names the [fem] extra (whisker.extras)
    return skfem


def _axis(breaks, hmax):
    """Grid coordinates through every break point, no cell wider than hmax (mm)."""
    b = np.unique(np.round(np.asarray(breaks, dtype=float), 9))
    out = [b[0]]
    for a, c in zip(b[:-1], b[1:]):
        k = max(1, math.ceil((c - a) / hmax - 1e-9))
        out.extend(np.linspace(a, c, k + 1)[1:])
    return np.array(out)


@dataclass
class FEResult:
    times_s: np.ndarray
    mean_C: dict            # part -> (len(times),) volume-mean temperature, C
    steady_C: dict          # part -> steady volume-mean temperature, C
    cells: int
    dofs: int


class ConductionFE:
    """The model of the module docstring for `design` at grid size `h_mm` (near the coil) and
    `h_far_mm` (the membrane's outer part)."""

    def __init__(self, design, h_mm: float = 0.15, h_far_mm: float = 0.6):
        if not (0.02 <= h_mm <= 1.0) or not (h_mm <= h_far_mm <= 5.0):
            raise ValueError(f"ConductionFE: grid sizes must satisfy 0.02 <= h_mm <= h_far_mm <= 5 "
                             f"(got {h_mm}, {h_far_mm})")
        self.design = design
        self.net = ThermalNetwork(design, exchange=False)
        self.h_mm = h_mm
        self._mesh(h_far_mm)
        self._assemble()

    # ---- geometry ----------------------------------------------------------------------------------
    def _mesh(self, h_far):
        sk = _skfem()
        from whisker.design.former import layout

        d, g = self.design, self.net.geo
        f = layout(d)
        R = d.whiskers.ring_radius
        t = g.membrane_t
        zc = f.axis_z
        r2 = g.membrane_r2
        near_x = [f.tab[0], f.tab[1], f.core[1], f.flange[1], R - g.socket_r, R - g.rod_r, R + g.rod_r, R + g.socket_r]
        xs = np.concatenate([_axis([R - r2, f.tab[0]], h_far), _axis(near_x, self.h_mm),
                             _axis([f.flange[1], max(R + r2, f.flange[1] + 0.1)], h_far)])
        ys = np.concatenate([_axis([0.0, g.socket_r, g.rod_r, g.winding_ri, g.winding_ro, g.coil_ro], self.h_mm),
                             _axis([g.coil_ro, max(r2, g.coil_ro + 0.1)], h_far)])
        zb = [f.tab_bottom, zc - g.coil_ro, zc - g.winding_ro, zc - g.winding_ri, zc, zc + g.winding_ri,
              zc + g.winding_ro, zc + g.coil_ro, f.socket_bottom, f.tab_top, 0.0, t]
        zs = _axis(zb, self.h_mm)
        xs, ys = np.unique(np.round(xs, 9)), np.unique(np.round(ys, 9))
        mesh = sk.MeshHex.init_tensor(xs, ys, zs)
        c = mesh.p[:, mesh.t].mean(axis=1)
        x, y, z = c
        rc = np.hypot(y, z - zc)                    # about the coil axis
        rr = np.hypot(x - R, y)                     # about the rod axis
        part = np.full(mesh.t.shape[1], -1)
        in_core_x = (x > f.core[0]) & (x < f.core[1])
        part[in_core_x & (rc > g.winding_ri) & (rc < g.winding_ro)] = 0                        # winding
        part[in_core_x & (rc < g.winding_ri) & (rc > g.bore_r)] = 1                            # core
        part[(x > f.flange[0]) & (x < f.flange[1]) & (rc < g.coil_ro)] = 1                     # flange
        tab = (x > f.tab[0]) & (x < f.tab[1]) & (y < g.tab_y / 2) & (z > f.tab_bottom) & (z < f.tab_top)
        part[tab] = 5                                                                         # tab
        sock = (z > f.socket_bottom) & (z < f.tab_top)
        part[tab & sock & (rr < g.socket_r)] = 2                                              # glue
        part[(rr < g.rod_r) & (z > f.socket_bottom) & (z < 0)] = 3                            # rod below
        part[(rr < g.rod_r) & (z > 0) & (z < t)] = 6                                          # rod in membrane
        part[(z > 0) & (z < t) & (rr >= g.rod_r) & (rr < r2)] = 4                             # membrane
        keep = part >= 0
        self.mesh = mesh.remove_elements(np.flatnonzero(~keep))
        self.part = part[keep]
        self.axis_z = zc
        self.rod_x = R

    def _assemble(self):
        sk = _skfem()
        from skfem import BilinearForm, LinearForm
        from skfem.helpers import dot, grad
        import scipy.sparse as sp

        net, M = self.net, self.net.mat
        g = net.geo
        mesh, e = self.mesh, sk.ElementHex1()
        h, hr = net.film_coefficients_W_m2K()
        k = {0: net.winding_conductivity_W_mK(), 1: M["bobbin"].conductivity_W_mK, 5: M["bobbin"].conductivity_W_mK, 2: M["rod_glue"].conductivity_W_mK,
             3: M["rod"].conductivity_W_mK, 6: M["rod"].conductivity_W_mK, 4: M["membrane"].conductivity_W_mK}
        v_w = math.pi * (g.winding_ro ** 2 - g.winding_ri ** 2) * g.winding_length
        rc_w = (g.copper_mass_g * M["winding"].specific_heat_J_gK + g.enamel_mass_g * M["enamel"].specific_heat_J_gK) / v_w
        rc = {0: rc_w, 1: M["bobbin"].volumetric_heat_J_per_mm3K, 5: M["bobbin"].volumetric_heat_J_per_mm3K, 2: M["rod_glue"].volumetric_heat_J_per_mm3K,
              3: M["rod"].volumetric_heat_J_per_mm3K, 6: M["rod"].volumetric_heat_J_per_mm3K, 4: M["membrane"].volumetric_heat_J_per_mm3K}

        @BilinearForm
        def lap(u, v, w):
            return dot(grad(u), grad(v))

        @BilinearForm
        def mass(u, v, w):
            return u * v

        @LinearForm
        def unit(v, w):
            return v

        N = mesh.p.shape[1]
        K = sp.csr_matrix((N, N))
        Mm = sp.csr_matrix((N, N))
        self.basis = {}
        self.volume = {}
        self.mean_w = {}
        for p in range(7):
            idx = np.flatnonzero(self.part == p)
            if idx.size == 0:
                continue
            b = sk.Basis(mesh, e, elements=idx)
            K = K + k[p] * 1e-3 * lap.assemble(b)
            Mm = Mm + rc[p] * mass.assemble(b)
            wv = unit.assemble(b)
            self.volume[PARTS[p]] = float(wv.sum())
            self.mean_w[PARTS[p]] = wv / wv.sum()
        # heat source: uniform in the winding, 1 W
        self.f_unit = self.mean_w["winding"].copy()
        # convection on the free faces
        bf = mesh.boundary_facets()
        fc = mesh.p[:, mesh.facets[:, bf]].mean(axis=1)
        fx, fy, fz = fc
        elem = mesh.f2t[0, bf]
        fpart = self.part[elem]
        eps = 1e-7
        sym = np.abs(fy) < eps
        rr = np.hypot(fx - self.rod_x, fy)
        mem_rim = (fpart == 4) & (np.abs(fz - 0.0) > eps) & (np.abs(fz - g.membrane_t) > eps)
        bore = np.isin(fpart, (1, 5)) & (np.hypot(fy, fz - self.axis_z) < g.bore_r + 1e-6) & ~sym
        rod_top = (fpart == 6) & (np.abs(fz - g.membrane_t) < eps) & (rr < g.rod_r)
        rod_side = np.isin(fpart, (2, 3, 6)) & ~rod_top
        conv = ~(sym | mem_rim | bore | rod_top)
        self.facet_groups = {"symmetry": int(sym.sum()), "convective": int(conv.sum()), "rod_top": int(rod_top.sum())}
        # A staircase of grid faces has more area than the round surface it follows (up to 4/pi): each
        # face convects with its area projected on the true surface's normal, |n . n_true| (for an
        # axis-aligned face of a cylinder about the coil or the rod axis; 1 on the flat faces), so the
        # faces' total is the true area whatever the grid.
        pts = mesh.p[:, mesh.facets[:, bf]]
        normal_axis = np.argmin(np.ptp(pts, axis=1), axis=0)          # 0: x, 1: y, 2: z
        proj = np.ones(bf.size)
        coil_side = np.isin(fpart, (0, 1)) & (normal_axis != 0)         # winding, core, flange: cylinders about x
        ry, rz = fy, fz - self.axis_z
        rn = np.hypot(ry, rz) + 1e-12
        proj[coil_side] = np.where(normal_axis == 1, np.abs(ry), np.abs(rz))[coil_side] / rn[coil_side]
        rod_like = np.isin(fpart, (2, 3, 6)) & (normal_axis != 2)       # rod and glue: cylinders about z
        rx = fx - self.rod_x
        rn2 = np.hypot(rx, fy) + 1e-12
        proj[rod_like] = np.where(normal_axis == 0, np.abs(rx), np.abs(fy))[rod_like] / rn2[rod_like]

        @BilinearForm
        def film(u, v, w):
            return w.c * u * v

        Kb = sp.csr_matrix((N, N))
        for sel, coef in ((conv & ~rod_side, h + hr), (conv & rod_side, h)):
            if sel.any():
                fb = sk.FacetBasis(mesh, e, facets=bf[sel])
                nqp = fb.X.shape[1]
                c = np.repeat((coef * 1e-6 * proj[sel])[:, None], nqp, axis=1)
                Kb = Kb + film.assemble(fb, c=c)
        if rod_top.any():
            fb = sk.FacetBasis(mesh, e, facets=bf[rod_top])
            top_area = float(unit.assemble(fb).sum())
            # the protrusion as a fin on the end face: the network's fin conductance spread over it
            g_fin = fin_conductance_W_per_K(h + hr, M["rod"].conductivity_W_mK, 2 * g.rod_r, g.protrusion)
            Kb = Kb + g_fin / top_area * mass.assemble(fb)
        self.K = (K + Kb).tocsc()
        self.M = Mm.tocsc()

    # ---- answers -----------------------------------------------------------------------------------
    @property
    def dofs(self) -> int:
        return self.mesh.p.shape[1]

    def _means(self, T):
        return {p: float(self.mean_w[p] @ T) for p in self.mean_w}

    def run(self, power_W: float, t_end_s: float, dt_s: float = 0.02, report_every: int = 1) -> FEResult:
        """Temperature rise of each part's volume mean from ambient with `power_W` in the winding:
        the transient to t_end_s and the steady state (temperatures in C)."""
        from scipy.sparse.linalg import splu

        if not (power_W > 0 and math.isfinite(power_W)) or not (t_end_s > 0) or not (dt_s > 0):
            raise ValueError("ConductionFE.run: need power_W > 0, t_end_s > 0, dt_s > 0")
        amb = self.net.ambient_C
        f = 0.5 * power_W * self.f_unit           # the half model carries half the power
        steps = max(1, math.ceil(t_end_s / dt_s))
        dt = t_end_s / steps
        A = splu((self.M / dt + self.K).tocsc())
        Md = self.M / dt
        T = np.zeros(self.dofs)
        times, means = [0.0], {p: [amb] for p in self.mean_w}
        for s in range(1, steps + 1):
            T = A.solve(Md @ T + f)
            if s % report_every == 0 or s == steps:
                times.append(s * dt)
                for p, v in self._means(T).items():
                    means[p].append(amb + v)
        Tss = splu(self.K).solve(f)
        return FEResult(np.array(times), {p: np.array(v) for p, v in means.items()},
                        {p: amb + v for p, v in self._means(Tss).items()}, self.mesh.t.shape[1], self.dofs)


def network_means(design, power_W: float, times_s, **network) -> tuple[dict, dict]:
    """The network's (exchange=False) answer to the same question as :meth:`ConductionFE.run`:
    the winding, bobbin (the tab's volume mean), rod and membrane node temperatures at `times_s` and at
    steady state, C. `network`: more ThermalNetwork arguments (tab_nodes)."""
    net = ThermalNetwork(design, exchange=False, max_substep_s=0.01, **network)
    p = np.zeros(net.n)
    p[0] = power_W
    x = net.initial_state()
    t_prev = 0.0
    rows = {k: [] for k in ("winding", "bobbin", "rod", "membrane")}
    for t in times_s:
        x = net.step_state(x, None, float(t) - t_prev, power_W=p)
        t_prev = float(t)
        for k in rows:
            rows[k].append(float(net.node_temperatures(x)[k][0]))
    ss = net.node_temperatures(net.steady_state(power_W=p))
    return ({k: np.array(v) for k, v in rows.items()}, {k: float(ss[k][0]) for k in rows})
