"""Finite-element model of a plate with rigid inclusions: the rigid-body stiffness of each inclusion.

The plate is a 3D linear-elastic solid (the small-strain limit of the silicone's neo-Hookean fit),
meshed as a prism stack over a 2D triangulation and split into tetrahedra: quadratic displacements
(P2) and a linear pressure (P1), the Taylor-Hood mixed (Herrmann) formulation

    a(u, v) = int 2 mu dev eps(u) : dev eps(v),   b(v, p) = -int p div v,   c(p, q) = -int p q / K,

which stays free of volumetric locking as the silicone's K / mu (~2.5e4) goes to incompressible.

Each inclusion (a rod cast through the plate) is rigid and bonded over the plate's full thickness:
the displacement of every node on its surface is u = t + w x (x - pivot), six rigid-body unknowns
per inclusion with the pivot on the mid-plane at its centre. The plate is held (u = 0) on a clamp:
its lower face outside a radius (the membrane glued on the mount's seat ledge) or its outer side
face (the closed-form check). Static condensation of every other unknown - the plate's, and every
inclusion motion but one chosen rotation each - gives the m x m stiffness of those rotations (N mm/rad).
The mixed system is symmetric quasi-definite ([[A, B^T], [B, -C]], A and C positive definite), so
SuperLU factorises it with a symmetric fill-reducing ordering and no pivoting (Vanderbei 1995:
quasi-definite matrices are strongly factorisable), ~3.5x faster than its default partial pivoting.

Libraries: scikit-fem (assembly: pure Python on numpy/scipy, a small wheel on every platform,
including the Raspberry Pi) and Triangle (Shewchuk's quality 2D mesher through the ``triangle``
binding: a graded triangulation around the rods from the rods' segment length alone). The
prism-stack mesh, rather than a 3D mesher such as gmsh, puts the plate's faces and the clamp's edge
exactly on mesh faces, with the layer count as an explicit refinement parameter, and keeps gmsh's
~100 MB binary (with its X11/OpenGL libraries) off the install. SfePy would do the same job with a
larger install. Lengths in mm, moduli in MPa, forces in N, moments in N mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Triangle's minimum angle (deg) for quality triangles: a graded mesh without slivers.
MIN_ANGLE_DEG = 30.0


class MeshError(ValueError):
    """A geometry that cannot be meshed; one line naming the dimension."""


@dataclass(frozen=True)
class Inclusion:
    """A rigid cylinder through the plate: centre (x, y) mm, radius mm."""

    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Plate:
    """The plate's outline (k x 2, mm, counter-clockwise), thickness (mm), inclusions and clamp.

    clamp_radius: the lower face is held outside this radius (mm); None holds the outer side face.
    """

    outline: tuple[tuple[float, float], ...]
    thickness: float
    inclusions: tuple[Inclusion, ...]
    clamp_radius: float | None


def _circle(x: float, y: float, r: float, n: int) -> np.ndarray:
    a = 2 * np.pi * np.arange(n) / n
    return np.column_stack([x + r * np.cos(a), y + r * np.sin(a)])


def triangulate(plate: Plate, size: float, rod_size: float) -> tuple[np.ndarray, np.ndarray]:
    """2D quality triangulation of the plate's outline minus the inclusions, mm.

    size: largest triangle edge (mm, through Triangle's area bound); rod_size: segment length on the
    inclusions' circles (mm), which grades the mesh towards the rods. The clamp circle (if any) is
    a mesh line, so the clamp's edge lies on triangle edges.
    """
    import triangle

    verts: list[np.ndarray] = []
    segs: list[np.ndarray] = []

    def loop(pts: np.ndarray) -> None:
        start = sum(len(v) for v in verts)
        n = len(pts)
        verts.append(pts)
        segs.append(np.column_stack([start + np.arange(n), start + (np.arange(n) + 1) % n]))

    outline = np.asarray(plate.outline, float)
    # split the outline's edges to about `size` so Triangle does not grade away from long edges
    pts = []
    for p, q in zip(outline, np.roll(outline, -1, axis=0)):
        k = max(1, math.ceil(np.hypot(*(q - p)) / size))
        pts.extend(p + (q - p) * i / k for i in range(k))
    loop(np.array(pts))
    if plate.clamp_radius is not None:
        loop(_circle(0.0, 0.0, plate.clamp_radius, max(24, math.ceil(2 * np.pi * plate.clamp_radius / size))))
    for inc in plate.inclusions:
        loop(_circle(inc.x, inc.y, inc.radius, max(8, math.ceil(2 * np.pi * inc.radius / rod_size))))
    geo = {"vertices": np.vstack(verts), "segments": np.vstack(segs)}
    if plate.inclusions:
        geo["holes"] = np.array([[i.x, i.y] for i in plate.inclusions])
    area = size ** 2 * math.sqrt(3) / 4
    out = triangle.triangulate(geo, f"pq{MIN_ANGLE_DEG:g}a{area:.6g}Q")
    return out["vertices"], out["triangles"]


def extrude(points: np.ndarray, tris: np.ndarray, thickness: float, layers: int) -> tuple[np.ndarray, np.ndarray]:
    """A prism stack over a triangulation, each prism split into three tetrahedra, mm.

    The split follows the vertices' global order (each quad face's diagonal joins its lowest-numbered
    lower vertex to its highest-numbered upper vertex), so neighbouring prisms share their faces'
    diagonals and the tetrahedral mesh is conforming.
    """
    n = len(points)
    zs = np.linspace(0.0, thickness, layers + 1)
    p3 = np.vstack([np.column_stack([points, np.full(n, z)]) for z in zs])
    t = np.sort(tris, axis=1)
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    tets = []
    for k in range(layers):
        lo, hi = k * n, (k + 1) * n
        tets += [np.column_stack([a + lo, b + lo, c + lo, c + hi]),
                 np.column_stack([a + lo, b + lo, b + hi, c + hi]),
                 np.column_stack([a + lo, a + hi, b + hi, c + hi])]
    t4 = np.vstack(tets)
    # positive orientation
    v = p3[t4]
    det = np.einsum("ij,ij->i", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), v[:, 3] - v[:, 0])
    t4[det < 0] = t4[det < 0][:, [0, 2, 1, 3]]
    return p3, t4


@dataclass(frozen=True)
class Solution:
    """The inclusions' tilt stiffness (m x m) and the model's size."""

    stiffness: np.ndarray      # moment about inclusion i's axis per radian about inclusion j's axis, N mm/rad
    pivots: np.ndarray         # m x 3, mm
    dofs: int                  # unknowns of the mixed system
    elements: int


def _rod_basis(axis) -> np.ndarray:
    """6 x 6 orthonormal basis of a rod's rigid motions (t, w): column 0 the rotation about `axis`,
    columns 1-3 the translations, 4-5 the two other rotations."""
    ax = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(ax[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, ax)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(ax, e1)
    q = np.zeros((6, 6))
    q[3:, 0] = ax
    q[:3, 1:4] = np.eye(3)
    q[3:, 4] = e1
    q[3:, 5] = e2
    return q


def solve(plate: Plate, shear_modulus: float, bulk_modulus: float, size: float, rod_size: float,
          layers: int, axes) -> Solution:
    """Assemble the mixed P2-P1 system and condense it onto one rotation per inclusion, N mm/rad.

    axes: per inclusion, the rotation axis (3-vector) whose stiffness is wanted, about the pivot on
    the mid-plane at the inclusion's centre. Every other motion of every inclusion (translations,
    the two other rotations) is free: condensed out with the plate's own unknowns. Linear in the
    moduli: scaling mu and K together scales the result by the same factor.
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu
    from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, MeshTet, asm
    from skfem.helpers import ddot, div, sym_grad

    t = plate.thickness
    pts2, tris = triangulate(plate, size, rod_size)
    p3, t4 = extrude(pts2, tris, t, layers)
    mesh = MeshTet(p3.T.copy(), t4.T.copy())
    ub = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    pb = Basis(mesh, ElementTetP1(), intorder=2)

    @BilinearForm
    def a(u, v, w):
        # deviatoric part only: the volumetric part is carried by the pressure (p = K div u)
        return 2.0 * shear_modulus * (ddot(sym_grad(u), sym_grad(v)) - div(u) * div(v) / 3.0)

    @BilinearForm
    def b(u, q, w):
        return -div(u) * q

    @BilinearForm
    def c(p, q, w):
        return -p * q / bulk_modulus

    A, B, C = asm(a, ub), asm(b, ub, pb), asm(c, pb)
    K = sp.bmat([[A, B.T], [B, C]], format="csr")
    nu = ub.N
    n = K.shape[0]

    # component of each displacement dof and its location
    comp = np.empty(nu, dtype=int)
    for i, name in enumerate(("u^1", "u^2", "u^3")):
        comp[ub.get_dofs().all(name)] = i
    loc = ub.doflocs.T  # nu x 3
    eps = 1e-6 * max(1.0, t)

    # clamp
    if plate.clamp_radius is not None:
        rc = plate.clamp_radius
        cf = mesh.facets_satisfying(lambda x: (np.abs(x[2]) < eps) & (np.hypot(x[0], x[1]) > rc - eps))
    else:
        outline = np.asarray(plate.outline, float)
        r_in = float(np.min(np.hypot(outline[:, 0], outline[:, 1]))) * math.cos(math.pi / len(outline))
        cf = mesh.facets_satisfying(lambda x: np.hypot(x[0], x[1]) > r_in - 1e-3 * max(1.0, r_in))
    if len(cf) == 0:
        raise MeshError("the clamp holds no face of the mesh: check the clamp radius against the outline")
    clamped = np.unique(ub.get_dofs(cf).all())

    # rigid inclusions: u = t + w x (x - pivot), in each rod's basis (_rod_basis): 1 kept + 5 condensed
    m = len(plate.inclusions)
    owner = np.full(nu, -1)
    pivots = np.array([[i.x, i.y, t / 2] for i in plate.inclusions]).reshape(-1, 3)
    for k, inc in enumerate(plate.inclusions):
        f = mesh.facets_satisfying(lambda x, inc=inc: np.hypot(x[0] - inc.x, x[1] - inc.y) < inc.radius + 1e-6)
        if len(f) == 0:
            raise MeshError(f"inclusion {k} at ({inc.x:.3g}, {inc.y:.3g}) mm has no surface in the mesh")
        owner[np.unique(ub.get_dofs(f).all())] = k
    if np.any(owner[clamped] >= 0):
        raise MeshError("a rod touches the clamped seat: the rods must lie inside the seat's opening")
    keep = np.ones(n, dtype=bool)
    keep[clamped] = False
    keep[:nu][owner >= 0] = False
    free = np.flatnonzero(keep)
    nf = len(free)
    rigid = np.flatnonzero(owner >= 0)
    # columns: [free plate dofs | 5 condensed motions per rod | 1 kept rotation per rod]
    col = np.empty((m, 6), dtype=int)
    for k in range(m):
        col[k, 1:] = nf + 5 * k + np.arange(5)
        col[k, 0] = nf + 5 * m + k
    # d(u_c)/d(t, w): translations -> unit; rotations -> (w x r)_c
    r = loc[rigid] - pivots[owner[rigid]]
    cc = comp[rigid]
    J = np.zeros((len(rigid), 6))
    J[np.arange(len(rigid)), cc] = 1.0
    rows_w = np.zeros((len(rigid), 3))
    # (w x r)_0 = wy rz - wz ry ; _1 = wz rx - wx rz ; _2 = wx ry - wy rx
    sel0, sel1, sel2 = cc == 0, cc == 1, cc == 2
    rows_w[sel0] = np.column_stack([np.zeros(sel0.sum()), r[sel0, 2], -r[sel0, 1]])
    rows_w[sel1] = np.column_stack([-r[sel1, 2], np.zeros(sel1.sum()), r[sel1, 0]])
    rows_w[sel2] = np.column_stack([r[sel2, 1], -r[sel2, 0], np.zeros(sel2.sum())])
    J[:, 3:] = rows_w
    Q = np.stack([_rod_basis(ax) for ax in axes])          # m x 6 x 6
    Jq = np.einsum("ij,ijk->ik", J, Q[owner[rigid]])        # rigid dofs x 6 (in each rod's basis)
    rows = [free, np.repeat(rigid, 6)]
    cols = [np.arange(nf), col[owner[rigid]].ravel()]
    vals = [np.ones(nf), Jq.ravel()]
    T = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, nf + 6 * m))
    Kr = (T.T @ K @ T).tocsc()
    nc = nf + 5 * m
    lu = splu(Kr[:nc, :nc], permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    Kcr = Kr[:nc, nc:].toarray()
    S = Kr[nc:, nc:].toarray() - Kcr.T @ lu.solve(Kcr)
    S = 0.5 * (S + S.T)
    if not np.all(np.isfinite(S)):
        raise MeshError("the membrane model gave a non-finite stiffness: the mesh is degenerate")
    return Solution(stiffness=S, pivots=pivots, dofs=nc, elements=mesh.t.shape[1])
