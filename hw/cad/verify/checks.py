"""Geometry checks, measured on the solids (OpenCascade) and on the exported meshes (trimesh,
manifold3d) - never read back from the design's parameters.

Each check returns a :class:`Check` with the measured value, the limit, and the design parameters
that drive it, so a refused design gets one line that says which knob to turn.
"""

from __future__ import annotations

import math
from typing import Iterable

import cadquery as cq
import manifold3d
import numpy as np
import shapely
import trimesh
from shapely.geometry import Point, Polygon

from whisker.design import sizing
from whisker.design import Design

from whisker.cad.solids import reference, ring
from whisker.cad.verify.verdict import VOLUME_EPS, Check, make_check, measured_check, to_mesh  # noqa: F401  (re-exported for the checks' users)


def resolution(d: Design, radius: float) -> float:
    """How far the exported mesh of a curved surface of `radius` (mm) may lie from the true surface:
    the measurement resolution of every check that measures a round feature on a mesh, mm.

    OpenCascade keeps chords within export.linear_tolerance on plain faces, but on a face cut by other
    features (a cavity wall between magnet pockets) it may honour only export.angular_tolerance,
    whose chord sagitta is radius (1 - cos(alpha / 2)) (measured: 0.076 mm at a 24.5 mm cavity).
    """
    e = d.export
    return max(e.linear_tolerance, radius * (1.0 - math.cos(e.angular_tolerance / 2))) + 1e-6

# The membrane's rim needs at least this much flange to be glued on (mm).
MIN_GLUE_LEDGE = 0.5


# ---- mesh helpers ---------------------------------------------------------------------------

def section(mesh: trimesh.Trimesh, z: float) -> list[Polygon]:
    """Polygons (with holes) of the mesh cut by the plane at height z, in sensor xy (mm)."""
    path = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
    if path is None:
        return []
    to_2d = np.eye(4)
    to_2d[2, 3] = -z
    planar, _ = path.to_2D(to_2D=to_2d)
    return list(planar.polygons_full)


def holes(polys: Iterable[Polygon]) -> list[Polygon]:
    return [Polygon(r) for p in polys for r in p.interiors]


def describe_circles(polys: Iterable[Polygon]) -> list[tuple[float, float, float]]:
    """(radius from axis, angle deg, equivalent diameter) of each polygon (mm, deg, mm)."""
    out = []
    for p in polys:
        c = p.centroid
        out.append((math.hypot(c.x, c.y), math.degrees(math.atan2(c.y, c.x)) % 360, 2 * math.sqrt(p.area / math.pi)))
    return out


def _angle_error(found: list[float], wanted: list[float]) -> float:
    """Largest angular distance (deg) from each wanted angle to its nearest found angle."""
    if not found:
        return math.inf
    return max(min(abs((f - w + 180) % 360 - 180) for f in found) for w in wanted)


def ring_of_holes(part: str, what: str, circles, d: Design, diameter: float, diam_params: tuple[str, ...]) -> list[Check]:
    """Checks that exactly N holes of `diameter` sit at the ring radius on the whisker angles."""
    n, r = d.whiskers.count, d.whiskers.ring_radius
    tol = 2 * resolution(d, diameter / 2)  # both sides of a hole may be off by one resolution
    match = [c for c in circles if abs(c[2] - diameter) < max(3 * tol, 0.1 * diameter)]
    params = ("whiskers.count", "whiskers.ring_radius", *diam_params)
    out = [make_check(f"{what} found", part, len(match), len(match) == n, f"== {n}", "", params,
                  "holes merged or missing" if len(match) != n else "")]
    if match:
        rad_err = max(abs(c[0] - r) for c in match)
        out.append(measured_check(f"{what} radius error", part, rad_err, rad_err <= tol, f"<= {tol:.3g}", "mm", params))
        ang_err = _angle_error([c[1] for c in match], d.whisker_angles_deg)
        ang_tol = math.degrees(tol / r) + 1e-3
        out.append(measured_check(f"{what} angle error", part, ang_err, ang_err <= ang_tol, f"<= {ang_tol:.3g}", "deg", params))
        dia_err = max(abs(c[2] - diameter) for c in match)
        out.append(measured_check(f"{what} diameter error", part, dia_err, dia_err <= tol, f"<= {tol:.3g}", "mm", diam_params))
    return out


# ---- checks on every exported mesh ------------------------------------------------------------

def mesh_checks(name: str, mesh: trimesh.Trimesh, cad_volume: float, printable: bool, d: Design,
                print_extent: tuple[float, float, float] | None) -> list[Check]:
    out = [measured_check("watertight", name, bool(mesh.is_watertight), mesh.is_watertight, "true")]
    mf = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                                             tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))
    status = mf.status()
    out.append(measured_check("manifold", name, status.name, status == manifold3d.Error.NoError, "NoError"))
    rel = abs(mesh.volume - cad_volume) / cad_volume if cad_volume > 0 else math.inf
    out.append(measured_check("mesh vs CAD volume", name, rel * 100, rel <= 0.005, "<= 0.5", "%",
                      ("export.linear_tolerance", "export.angular_tolerance")))
    if printable and print_extent is not None:
        x, y, h = print_extent
        p = d.print
        fits = h <= p.max_height and ((x <= p.bed_x and y <= p.bed_y) or (y <= p.bed_x and x <= p.bed_y))
        out.append(make_check("fits printer", name, max(x, y, h), fits,
                          f"<= bed {p.bed_x:g} x {p.bed_y:g} x {p.max_height:g}", "mm",
                          ("print.profile",),
                          f"part is {x:.1f} x {y:.1f} x {h:.1f} mm"))
    return out


# ---- part-specific checks on meshes ---------------------------------------------------------------

def membrane_checks(mesh: trimesh.Trimesh, d: Design) -> list[Check]:
    m = d.membrane
    polys = section(mesh, m.thickness / 2)
    out = ring_of_holes("membrane", "rod holes", describe_circles(holes(polys)), d, d.whiskers.rod_diameter,
                        ("whiskers.rod_diameter",))
    if len(polys) != 1:
        return out + [make_check("one piece", "membrane", len(polys), False, "== 1", "", ("membrane.inscribed_radius",))]
    outline = polys[0].exterior
    inscribed = Point(0, 0).distance(outline)
    tol = resolution(d, m.inscribed_radius)
    out.append(measured_check("inscribed radius error", "membrane", abs(inscribed - m.inscribed_radius),
                         abs(inscribed - m.inscribed_radius) <= tol, f"<= {tol:.3g}", "mm",
                         ("membrane.inscribed_radius",), f"measured {inscribed:.3f} mm"))
    sides = len(Polygon(outline).simplify(0.01).exterior.coords) - 1
    out.append(measured_check("polygon sides", "membrane", sides, sides == m.sides, f"== {m.sides}", "", ("membrane.sides",)))
    thick = float(mesh.bounds[1, 2] - mesh.bounds[0, 2])
    out.append(measured_check("thickness error", "membrane", abs(thick - m.thickness), abs(thick - m.thickness) <= 1e-3,
                      "<= 0.001", "mm", ("membrane.thickness",)))
    return out


def mold_checks(base: trimesh.Trimesh, lid: trimesh.Trimesh, d: Design) -> list[Check]:
    rod_hole = d.hole(d.whiskers.rod_diameter)
    params = ("whiskers.rod_diameter", "print.clearance")
    out = ring_of_holes("mold_base", "rod sockets", describe_circles(holes(section(base, -d.rod_below_membrane / 2))),
                        d, rod_hole, params)
    cav = holes(section(base, d.membrane.thickness / 2))
    inscribed = Point(0, 0).distance(cav[0].exterior) if len(cav) == 1 else math.nan
    tol = resolution(d, d.membrane.inscribed_radius)
    out.append(measured_check("cavity inscribed radius error", "mold_base", abs(inscribed - d.membrane.inscribed_radius),
                         abs(inscribed - d.membrane.inscribed_radius) <= tol, f"<= {tol:.3g}", "mm",
                         ("membrane.inscribed_radius",)))
    # Floor under the rod sockets: ray down each socket to its bottom, then to the base's underside.
    walls = []
    for x, y in [(d.whiskers.ring_radius * math.cos(math.radians(a)), d.whiskers.ring_radius * math.sin(math.radians(a)))
                 for a in d.whisker_angles_deg]:
        hits = np.sort(_ray_hits(base, (x, y, 100.0), (0, 0, -1))[:, 2])[::-1]
        walls.append(hits[0] - hits[-1] if len(hits) >= 2 else math.nan)
    w = float(np.min(walls))
    out.append(make_check("floor under rod sockets", "mold_base", w, w >= d.print.min_wall, f">= {d.print.min_wall:g}",
                      "mm", ("mold.floor", "whiskers.rod_length", "whiskers.protrusion", "print.min_wall")))
    out += ring_of_holes("mold_lid", "rod guides", describe_circles(holes(section(lid, d.membrane.thickness + d.mold.lid_thickness / 2))),
                         d, rod_hole, params)
    return out


def ring_checks(mesh: trimesh.Trimesh, d: Design) -> list[Check]:
    z = ring.levels(d)
    polys = section(mesh, (z["plate_bottom"] + z["socket_bottom"]) / 2)
    circles = describe_circles(holes(polys))
    out = ring_of_holes("whisker_ring", "rod sockets", circles, d, d.hole(d.whiskers.rod_diameter),
                        ("whiskers.rod_diameter", "print.clearance"))
    # The central opening shows as the inner ring of the plate's section (an interior of it).
    centre = [c for c in circles if c[0] < 0.5]
    opening = centre[0][2] if centre else 0.0
    # The opening's equivalent diameter reads small by up to two resolutions of its radius.
    need = d.mold.pour_diameter - 2 * resolution(d, d.mold.pour_diameter / 2)
    out.append(make_check("pour opening through ring", "whisker_ring", opening, opening >= need,
                      f">= mold.pour_diameter {d.mold.pour_diameter:g}", "mm",
                      ("whiskers.ring_radius", "ring.margin", "mold.pour_diameter")))
    return out


def _ray_hits(mesh: trimesh.Trimesh, origin, direction) -> np.ndarray:
    locs, _, _ = mesh.ray.intersects_location([origin], [direction], multiple_hits=True)
    return np.asarray(locs).reshape(-1, 3)


def mount_checks(mesh: trimesh.Trimesh, membrane_mesh: trimesh.Trimesh, d: Design) -> list[Check]:
    out: list[Check] = []
    n, minw = d.whiskers.count, d.print.min_wall
    pocket_params = ("whiskers.count", "whiskers.ring_radius", "magnet.diameter", "print.clearance")
    # Magnet pockets: notches of the cavity outline at the coil-axis height.
    polys = section(mesh, d.coil_axis_z)
    cav = holes(polys)
    cav_main = max(cav, key=lambda p: p.area) if cav else Polygon()
    # Tessellated circles have their vertices on the circle: the smallest vertex radius is the wall.
    r_cav = min(math.hypot(x, y) for x, y in cav_main.exterior.coords) if cav else math.nan
    notches = (shapely.difference(cav_main, Point(0, 0).buffer(r_cav + 2 * resolution(d, d.cavity_radius), 256))
               if cav else Polygon())
    pockets = [g for g in getattr(notches, "geoms", [notches]) if not g.is_empty and g.area > 0.05]
    found = describe_circles(pockets)
    out.append(make_check("magnet pockets found", "mount", len(pockets), len(pockets) == n, f"== {n}", "", pocket_params,
                      "pockets merged or missing" if len(pockets) != n else ""))
    if pockets:
        ang = _angle_error([f[1] for f in found], d.whisker_angles_deg)
        out.append(measured_check("magnet pocket angle error", "mount", ang, ang <= 0.5, "<= 0.5", "deg", pocket_params))
        # Measured magnet face radius = where the pockets start = cavity wall (its nearest mesh point).
        face_err, tol = abs(r_cav - d.cavity_radius), resolution(d, d.cavity_radius)
        out.append(measured_check("magnet face radius error", "mount", face_err, face_err <= tol, f"<= {tol:.3g}", "mm",
                             ("whiskers.ring_radius", "coil.length", "actuation.gap")))
        gaps = [a.distance(b) for i, a in enumerate(pockets) for b in pockets[i + 1:]]
        between = min(gaps) if gaps else math.inf
        if len(pockets) > 1:
            out.append(make_check("wall between magnet pockets", "mount", between, between >= minw, f">= {minw:g}", "mm",
                              pocket_params + ("print.min_wall",)))
        outer = polys[0].exterior if polys else None
        to_rim = min(p.distance(outer) for p in pockets) if outer is not None else math.nan
        out.append(make_check("wall from magnet pockets to rim", "mount", to_rim, to_rim >= minw, f">= {minw:g}", "mm",
                          ("mount.outer_radius", "magnet.height", "mount.glue_gap", "print.min_wall")))
        # Wall above each pocket up to the membrane seat: a ray up through the pocket's centroid.
        above = []
        for p in pockets:
            hits = _ray_hits(mesh, (p.centroid.x, p.centroid.y, d.coil_axis_z), (0, 0, 1))
            zs = np.sort(hits[:, 2])
            above.append(zs[1] - zs[0] if len(zs) >= 2 else math.nan)
        wa = float(np.min(above))
        out.append(make_check("wall above magnet pockets", "mount", wa, wa >= minw, f">= {minw:g}", "mm",
                          ("coil.drop", "coil.outer_diameter", "magnet.diameter", "print.min_wall")))
    # Membrane ledge: how far the membrane overlaps the mount just under its seat.
    under = holes(section(mesh, -0.05))
    cav_top = max((max(math.hypot(x, y) for x, y in h.exterior.coords) for h in under), default=math.nan)
    mem = section(membrane_mesh, d.membrane.thickness / 2)
    mem_in = Point(0, 0).distance(mem[0].exterior) if mem else math.nan
    ledge = mem_in - cav_top
    out.append(make_check("membrane ledge", "mount", ledge, ledge >= MIN_GLUE_LEDGE, f">= {MIN_GLUE_LEDGE:g}",
                      "mm", ("membrane.inscribed_radius", "mount.seat_ledge")))
    # Robot mounting holes in the bottom face.
    bottom = sizing.mount_levels(d)["bottom"]
    mh = describe_circles(holes(section(mesh, bottom + 0.5)))
    want = d.mount.mounting_hole_count
    mh_ok = [c for c in mh if abs(c[2] - d.mounting_hole_diameter) < 0.2]
    out.append(make_check("mounting holes found", "mount", len(mh_ok), len(mh_ok) == want, f"== {want}", "",
                      ("mount.mounting_hole_count", "mount.mounting_bolt_radius", "mount.ribbon_width"),
                      "a hole runs into the camera pocket or cable slot" if len(mh_ok) != want else ""))
    # Camera sight lines: from the optical centre to every marker, at rest and at full deflection.
    out.append(sight_check(mesh, d))
    out.append(camera_view_check(d))
    return out


def marker_points(d: Design, tilt_deg: float) -> np.ndarray:
    """Marker centres (x, y, z) in mm for all whiskers tilted by tilt_deg (retraction positive)."""
    t = math.radians(tilt_deg)
    dz = d.marker_z - d.pivot_z  # negative: marker below pivot
    # Retraction moves the tip in, so the marker (below the pivot) moves out by |dz| sin t.
    r = d.whiskers.ring_radius - dz * math.sin(t)
    z = d.pivot_z + dz * math.cos(t)
    return np.array([(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)), z) for a in d.whisker_angles_deg])


def sight_check(mesh: trimesh.Trimesh, d: Design) -> Check:
    cam = np.array([0.0, 0.0, d.camera_z])
    blocked = 0
    pts = np.vstack([marker_points(d, s * d.whiskers.max_deflection_deg) for s in (-1, 0, 1)])
    for p in pts:
        v = p - cam
        dist = np.linalg.norm(v)
        hits = _ray_hits(mesh, cam, v / dist)
        if len(hits) and np.min(np.linalg.norm(hits - cam, axis=1)) < dist - 1e-6:
            blocked += 1
    return make_check("markers hidden from camera", "mount", blocked, blocked == 0, "== 0", "",
                  ("camera.distance", "camera.lens_block", "whiskers.ring_radius"))


def camera_view_check(d: Design) -> Check:
    """Every marker's whole disc, at rest and at full deflection either way, inside the image with
    camera.edge_margin_px to spare. Pinhole model of the undistorted image; the image's shorter
    half-side is the limit in every direction, so the check holds for any image orientation."""
    cam = d.camera
    pts = np.vstack([marker_points(d, s * d.whiskers.max_deflection_deg) for s in (-1, 0, 1)])
    depth = pts[:, 2] - d.camera_z
    reach = cam.focal_length_px * (np.hypot(pts[:, 0], pts[:, 1]) + d.coil.marker_diameter / 2) / depth
    worst = float(np.max(reach)) if np.all(depth > 0) else math.inf
    limit = min(cam.width_px, cam.height_px) / 2 - cam.edge_margin_px
    return make_check("marker reach from image centre", "camera", worst, worst <= limit, f"<= {limit:g}", "px",
                  ("camera.distance", "camera.focal_length_px", "whiskers.ring_radius", "whiskers.max_deflection_deg"),
                  "a marker leaves the camera's view" if worst > limit else "")


# ---- checks on solids ------------------------------------------------------------------------

def _common_volume(a: cq.Shape, b: cq.Shape) -> float:
    return a.intersect(b).Volume()


def clearance(a: cq.Shape, b: cq.Shape) -> tuple[float, float]:
    """(smallest gap in mm, shared volume in mm^3) of two solids; the gap is 0 when they overlap."""
    v = _common_volume(a, b)
    return (0.0, v) if v > VOLUME_EPS else (a.distance(b), 0.0)


def solid_checks(d: Design, mount: cq.Shape, membrane: cq.Shape) -> list[Check]:
    """Collisions and fits, measured with OpenCascade booleans and distances."""
    out: list[Check] = []
    angles = d.whisker_angles_deg
    theta = d.whiskers.max_deflection_deg
    magnets = [reference.magnet(d, a) for a in angles]
    mag_in_mount = max(_common_volume(m, mount) for m in magnets)
    out.append(make_check("magnet overlaps mount", "mount", mag_in_mount, mag_in_mount < VOLUME_EPS, "0", "mm^3",
                      ("magnet.diameter", "magnet.height", "print.clearance")))
    # Every coil against its neighbour, the mount and the magnets, all tilted in, at rest and out.
    worst, worst_overlap, where = math.inf, 0.0, ""
    n = len(angles)
    for tilt in (-theta, 0.0, theta):
        coils = [reference.coil_envelope(d, a, tilt) for a in angles]
        pairs = [(f"coils {i} and {(i + 1) % n}", coils[i], coils[(i + 1) % n]) for i in range(n if n > 2 else n - 1)]
        pairs += [(f"coil {i} and mount", c, mount) for i, c in enumerate(coils)]
        pairs += [(f"coil {i} and magnet {j % n}", c, magnets[j % n]) for i, c in enumerate(coils)
                  for j in ({i - 1, i, i + 1} if n > 1 else {i})]
        for what, a, b in pairs:
            gap, overlap = clearance(a, b)
            if gap < worst or (gap == 0 and overlap > worst_overlap):
                worst, worst_overlap = gap, overlap
                where = (f"{what} overlap by {overlap:.3g} mm^3" if overlap else f"{what}") + f" at tilt {tilt:+g} deg"
    # A coil swinging past a printed surface needs at least the print clearance.
    need = max(d.print.clearance, 0.05)
    out.append(make_check("coil clearance over full deflection", "assembly", worst, worst >= need,
                      f">= {need:g}", "mm", ("whiskers.count", "whiskers.ring_radius", "whiskers.max_deflection_deg",
                                       "coil.outer_diameter", "coil.length", "actuation.gap", "mount.flange_thickness"),
                      where))
    from whisker.cad.assembly.swing import swing_check  # every solid, rods, windings and leads included, over the swing
    out += swing_check(d, mount, membrane)
    mem_overlap = _common_volume(membrane, mount)
    out.append(make_check("membrane overlaps its seat", "assembly", mem_overlap, mem_overlap < VOLUME_EPS, "0", "mm^3",
                      ("membrane.inscribed_radius", "print.clearance", "mount.outer_radius")))
    return out
