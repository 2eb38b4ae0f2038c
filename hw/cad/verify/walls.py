"""Wall thickness between named features of a printed part, measured on its mesh.

A *feature* is a solid the part's maker cut away or that bounds it: a hole, a pocket, a cavity,
or an *edge* (a shell just outside the part's outer surface, see :func:`outside_ring` and
:func:`outside_slab`). The wall between two features is the shortest segment from one feature's
cut surface to the other's that runs through the part's material. It is measured on the part's
mesh (the exported STL tessellation), not read from the design's numbers:

1. each feature's surface is sampled (about ``1/spacing^2`` points per mm^2, seeded, so a run is
   repeatable);
2. for every pair of features that do not touch (touching features form one opening: the lens
   cone and the board pocket, a hole and the pocket it opens into), a k-d tree (scipy) gives the
   sample pairs closer than ``min_wall``;
3. a pair counts only if both ends lie on the part's surface (trimesh proximity, within ``tol``)
   and the segment's interior is inside the part's material (trimesh containment at 1/4, 1/2, 3/4);
4. the closest counted pair is made exact by alternating projection between the part's own faces
   that lie on the two features (they end at the part's edges, so the pair cannot slide off it):
   the reported thickness does not depend on the sampling.

The result is a :class:`whisker.cad.verify.verdict.Check` naming the thinnest wall's two features and
where it is (x, y, z in the mesh's coordinates, mm). Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping

import cadquery as cq
import manifold3d
import numpy as np
import trimesh
from scipy.spatial import cKDTree

from whisker.cad.verify.verdict import Check, make_check, to_mesh

# Features closer than this are one opening, not two with a wall between them (mm).
TOUCH = 1e-3
# A wall may measure this much under its modelled thickness and still pass: the tessellation's
# chords and the surface sampling (mm; the same allowance as checks.MESH_TOL).
SLACK = 0.05


@dataclass(frozen=True)
class Wall:
    a: str
    b: str
    thickness: float                      # mm
    point_a: tuple[float, float, float]   # on feature a's surface
    point_b: tuple[float, float, float]
    limit: float = 0.0                    # mm, the thinnest this wall may be (its features' largest limit)

    @property
    def where(self) -> tuple[float, float, float]:
        return tuple(float(round((p + q) / 2, 2)) for p, q in zip(self.point_a, self.point_b))

    def describe(self) -> str:
        x, y, z = self.where
        return f"between {self.a} and {self.b} at ({x:g}, {y:g}, {z:g}) mm"


def outside_ring(radius: float, z0: float, z1: float, width: float = 3.0) -> cq.Shape:
    """The space just outside a round part's rim: an annulus from `radius` to radius + width (mm)."""
    outer = cq.Solid.makeCylinder(radius + width, z1 - z0, cq.Vector(0, 0, z0))
    return outer.cut(cq.Solid.makeCylinder(radius, z1 - z0, cq.Vector(0, 0, z0)))


def outside_slab(z: float, xy: float, below: bool, width: float = 3.0) -> cq.Shape:
    """The space just above (below=False) or below a part's flat face at height z, over +-xy (mm)."""
    z0 = z - width if below else z
    return cq.Solid.makeBox(2 * xy, 2 * xy, width, cq.Vector(-xy, -xy, z0))


def outside_box(lo: tuple[float, float, float], hi: tuple[float, float, float], width: float = 3.0) -> cq.Shape:
    """The space just outside the four sides of a box-shaped part from `lo` to `hi` (mm)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    outer = cq.Solid.makeBox(x1 - x0 + 2 * width, y1 - y0 + 2 * width, z1 - z0, cq.Vector(x0 - width, y0 - width, z0))
    return outer.cut(cq.Solid.makeBox(x1 - x0, y1 - y0, z1 - z0, cq.Vector(x0, y0, z0)))


def _as_mesh(name: str, f) -> trimesh.Trimesh:
    m = f if isinstance(f, trimesh.Trimesh) else to_mesh(f, 0.01, 0.2)
    if len(m.faces) == 0 or not m.is_watertight:
        raise ValueError(f"wall check feature {name!r} is not a closed solid")
    return m


def _manifold(m: trimesh.Trimesh) -> manifold3d.Manifold:
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.ascontiguousarray(m.vertices, dtype=np.float32),
                                               tri_verts=np.ascontiguousarray(m.faces, dtype=np.uint32)))


def _touch(a: manifold3d.Manifold, b: manifold3d.Manifold, box: manifold3d.Manifold) -> np.ndarray | None:
    """Where the features meet within the part's bounding box (where they cut it), or None. Tools
    that only overlap in the air around the part (overshoots) are two features with a wall between."""
    a, b = a ^ box, b ^ box
    if a.is_empty() or b.is_empty():
        return None
    common = a ^ b
    if common.volume() > 1e-9:
        bb = np.asarray(common.bounding_box(), float)
        return (bb[:3] + bb[3:]) / 2
    if a.min_gap(b, 10 * TOUCH) < TOUCH:
        bb = np.asarray(a.bounding_box(), float)
        return (bb[:3] + bb[3:]) / 2
    return None


def _inside(part: trimesh.Trimesh, pts: np.ndarray) -> np.ndarray:
    """Points strictly inside the part's material. The closest surface point's face normal decides
    (inside if the point lies behind the face); where the closest point is on an edge or a vertex
    (the normal is ambiguous there) trimesh's ray containment decides."""
    pts = np.asarray(pts, float).reshape(-1, 3)
    if not len(pts):
        return np.zeros(0, bool)
    closest, dist, tri = trimesh.proximity.closest_point(part, pts)
    side = np.einsum("ij,ij->i", pts - closest, part.face_normals[tri])
    inside = (side < 0) & (dist > 1e-9)
    bary = trimesh.triangles.points_to_barycentric(part.triangles[tri], closest)
    edge = np.any(bary < 1e-6, axis=1)
    if edge.any():
        inside[edge] = part.contains(pts[edge])
    return inside


def _part_faces_on(part: trimesh.Trimesh, feature: trimesh.Trimesh, c: np.ndarray, r: float,
                   tol: float) -> trimesh.Trimesh | None:
    """The part's faces within `r` of `c` that lie on the feature's surface (a sub-mesh), or None."""
    tri = part.triangles
    sel = np.flatnonzero(np.all((tri.min(axis=1) <= c + r) & (tri.max(axis=1) >= c - r), axis=1))
    if not len(sel):
        return None
    # a face lies on the feature if its centre and corners do
    pts = np.vstack([part.triangles_center[sel], tri[sel].reshape(-1, 3)])
    _, dist, _ = trimesh.proximity.closest_point(feature, pts)
    on = (dist[:len(sel)] < tol) & np.all(dist[len(sel):].reshape(-1, 3) < tol, axis=1)
    return trimesh.Trimesh(part.vertices, part.faces[sel[on]], process=False) if on.any() else None


def _project(part: trimesh.Trimesh, fa: trimesh.Trimesh, fb: trimesh.Trimesh, p: np.ndarray, q: np.ndarray,
             tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of the part's own faces on the two features near (p, q): alternating
    projection between the two face sets (they end at the part's edges, so the pair cannot slide
    off the part), mm."""
    r = max(1.0, 2.0 * float(np.linalg.norm(q - p)))
    sa, sb = _part_faces_on(part, fa, p, r, tol), _part_faces_on(part, fb, q, r, tol)
    if sa is None or sb is None:
        return p, q
    a, b = p, q
    for _ in range(30):
        b2 = trimesh.proximity.closest_point(sb, a[None])[0][0]
        a2 = trimesh.proximity.closest_point(sa, b2[None])[0][0]
        done = np.linalg.norm(a2 - a) < 1e-5 and np.linalg.norm(b2 - b) < 1e-5
        a, b = a2, b2
        if done:
            break
    # The closest pair often lies on the part's face where both features break out (two rims):
    # its midpoint is then on that face, the limit of pairs through the material.
    mid = (a + b) / 2
    on_face = trimesh.proximity.closest_point(part, mid[None])[1][0] < 1e-6
    ok = np.linalg.norm(b - a) < np.linalg.norm(q - p) and (on_face or _inside(part, [mid])[0])
    return (a, b) if ok else (p, q)


def _first_in_material(part: trimesh.Trimesh, p: np.ndarray, q: np.ndarray, tol: float) -> int | None:
    """Index of the first pair (p[i], q[i]) with both ends on the part's surface and the segment's
    interior in its material, or None. Tested in growing chunks: containment is the costly test."""
    start = 0
    for size in (16, 128, 1024, len(p)):
        stop = min(len(p), start + size)
        if stop <= start:
            break
        a, b = p[start:stop], q[start:stop]
        _, on_a, _ = trimesh.proximity.closest_point(part, a)
        _, on_b, _ = trimesh.proximity.closest_point(part, b)
        cand = np.flatnonzero((on_a < tol) & (on_b < tol))
        if len(cand):
            ts = (0.25, 0.5, 0.75)
            pts = np.vstack([a[cand] + t * (b[cand] - a[cand]) for t in ts])
            inside = _inside(part, pts).reshape(len(ts), -1).all(axis=0)
            if inside.any():
                return start + int(cand[np.flatnonzero(inside)[0]])
        start = stop
    return None


def thin_walls(part: trimesh.Trimesh, features: Mapping[str, object], min_wall: float,
               spacing: float | None = None, tol: float = 0.05, seed: int = 0,
               max_candidates: int = 4000, slack: float = SLACK, separate: Iterable[str] = (),
               limits: Mapping[str, float] | None = None) -> list[Wall]:
    """Every pair of features with a wall thinner than its limit - `slack` (mm) between them,
    the largest shortfall first.

    A pair's limit is `min_wall`, or the larger of the two features' own `limits` (mm) where one
    has one: a heat-set insert's hole asks for the fastener table's insert_min_wall of plastic
    around it (hw/fasteners.csv), more than the printer's general minimum.

    `features` maps a name to a solid (CadQuery shape or watertight trimesh) in the part mesh's
    coordinates. `tol` is how far a sample may be from the part's surface and still be on it: at
    least the mesh's linear tolerance. Features named in `separate` must not meet any other
    feature (two screws' holes): one that does is a wall of 0 mm where they meet.
    """
    separate = set(separate)
    limits = dict(limits or {})
    if not (math.isfinite(min_wall) and min_wall > 0):
        raise ValueError(f"min_wall must be a positive number of mm (got {min_wall!r})")
    for n, v in limits.items():
        if n not in features or not (math.isfinite(v) and v > 0):
            raise ValueError(f"wall limit for {n!r} must be a positive number of mm for a named feature (got {v!r})")
    h = spacing or min(min_wall / 4.0, 0.3)
    widest = max([min_wall, *limits.values()])
    names = list(features)
    meshes = {n: _as_mesh(n, features[n]) for n in names}
    manis = {n: _manifold(m) for n, m in meshes.items()}
    rng = np.random.default_rng(seed)
    samples = {}
    for n, m in meshes.items():
        count = int(min(max(m.area / h ** 2, 200), 60_000))
        pts, _ = trimesh.sample.sample_surface(m, count, seed=int(rng.integers(2 ** 31)))
        samples[n] = np.asarray(pts)
    lo, hi = part.bounds
    # only samples near the part can bound its material
    samples = {n: p[np.all((p >= lo - tol) & (p <= hi + tol), axis=1)] for n, p in samples.items()}
    # a hair beyond the part, so an edge feature (which starts at its surface) meets what opens onto it
    box = manifold3d.Manifold.cube(hi - lo + 0.02).translate(lo - 0.01)
    trees = {n: cKDTree(p) for n, p in samples.items() if len(p)}
    boxes = {n: (p.min(axis=0) - widest, p.max(axis=0) + widest) for n, p in samples.items() if len(p)}
    found: list[Wall] = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            pa, pb = samples[a], samples[b]
            limit = max(min_wall, limits.get(a, 0.0), limits.get(b, 0.0))
            if a in separate or b in separate:
                meet = _touch(manis[a], manis[b], box)
                if meet is not None:
                    found.append(Wall(a, b, 0.0, tuple(map(float, meet)), tuple(map(float, meet)), limit))
                    continue
            if not len(pa) or not len(pb):
                continue
            if np.any(boxes[a][1] < boxes[b][0]) or np.any(boxes[b][1] < boxes[a][0]):
                continue  # farther apart than a wall
            swap = len(pa) > len(pb)  # query the smaller set against the larger one's tree
            x, y, px, py = (b, a, pb, pa) if swap else (a, b, pa, pb)
            dist, idx = trees[y].query(px, distance_upper_bound=limit + h)
            hit = np.isfinite(dist)
            if not hit.any():
                continue
            if _touch(manis[a], manis[b], box) is not None:
                continue
            order = np.argsort(dist[hit])[:max_candidates]
            p, q, dd = px[hit][order], py[idx[hit][order]], dist[hit][order]
            k = _first_in_material(part, p, q, tol)
            if k is None:
                continue
            rx, ry = _project(part, meshes[x], meshes[y], p[k], q[k], tol)
            thick = float(np.linalg.norm(ry - rx))
            ra, rb = (ry, rx) if swap else (rx, ry)
            if thick < limit - slack:
                found.append(Wall(a, b, thick, tuple(map(float, ra)), tuple(map(float, rb)), limit))
    return sorted(found, key=lambda w: w.thickness - w.limit)


def wall_check(part_name: str, part: trimesh.Trimesh, features: Mapping[str, object], min_wall: float,
               parameters: tuple[str, ...] = ("print.min_wall",), **kw) -> Check:
    """One check: the thinnest wall between any two features, >= `min_wall` (mm), or >= a feature's
    own limit (`limits`, mm: an insert's wall) for the walls around that feature."""
    walls = thin_walls(part, features, min_wall, **kw)
    limits = kw.get("limits") or {}
    own = f", {len(limits)} with their own wall up to {max(limits.values()):g} mm" if limits else ""
    if not walls:
        return make_check("thinnest wall between features", part_name, float(min_wall), True, f">= {min_wall:g}",
                          "mm", parameters, f"none under its limit (less {SLACK:g} mm) among {len(features)} features{own}")
    w = walls[0]
    more = f" (+{len(walls) - 1} more thin walls)" if len(walls) > 1 else ""
    return make_check("thinnest wall between features", part_name, w.thickness, False, f">= {w.limit:g}", "mm",
                      parameters, w.describe() + more)
