"""The mould's casting checks, measured on the meshes of the mould base and the whisker ring:
the draft that lets the cured membrane out, and each rod's stop and axial slack. Units: mm, deg.

- Draft: every side-wall face of the base's cavity (the faces facing the axis strictly between its
  floor, z = 0, and its top, z = membrane.thickness) must lean out upwards by at least ``mold.draft_deg``: its
  outward normal (into the cavity) rises by asin(n_z) above the horizontal. A wall leaning the other
  way (an undercut) measures negative and is refused.
- Fit of the cast membrane: the cavity's top is the widest the cast membrane gets; it must not be
  wider than the mount's seat pocket, which is ``print.clearance`` wider than the nominal polygon.
- Stop and slack: a ray down each rod socket of the base finds its floor (the rod's stop), a ray up
  each socket of the ring finds its end; the slack is that end minus the tip of a nominal rod
  standing on its stop, and must be ``mold.rod_slack`` (>= 0: a nominal rod is never clamped).
- Vents in sight: a ray straight up from each vent of the lid (measured on the lid's mesh: the
  holes of its top face outside the rod ring) must miss the whisker ring standing on it, so the
  pourer sees silicone rise in every vent.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from shapely.geometry import Point

from whisker.design import Design

from whisker.cad.solids import ring
from whisker.cad.verify.checks import holes, section
from whisker.cad.verify.verdict import Check, make_check, measured_check
from whisker.cad.solids.shapes import polar_xy

# Faces closer than this to the cavity's floor or top belong to them, not to a side wall (mm).
EDGE = 1e-3
# Mesh tolerance of a measured angle (deg) and of a measured height (mm).
ANGLE_TOL = 0.05
HEIGHT_TOL = 0.01


def side_wall_drafts(base: trimesh.Trimesh, d: Design) -> np.ndarray:
    """Draft (deg) of every side-wall face of the cavity: asin of its normal's z component."""
    t = d.membrane.thickness
    z = base.triangles_center[:, 2]
    n = base.face_normals
    c = base.triangles_center
    # the cavity's walls face the axis (the base's outer wall faces away from it)
    inward = np.einsum("ij,ij->i", n[:, :2], c[:, :2]) < 0
    wall = (z > EDGE) & (z < t - EDGE) & (np.abs(n[:, 2]) < 0.999) & inward
    return np.degrees(np.arcsin(np.clip(n[wall, 2], -1.0, 1.0)))


def _inscribed(base: trimesh.Trimesh, z: float) -> float:
    cav = holes(section(base, z))
    return Point(0, 0).distance(cav[0].exterior) if len(cav) == 1 else math.nan


def _first_hit(mesh: trimesh.Trimesh, origin, direction) -> float:
    locs, _, _ = mesh.ray.intersects_location([origin], [direction], multiple_hits=False)
    return float(np.asarray(locs).reshape(-1, 3)[0, 2]) if len(locs) else math.nan


def stops_and_slack(base: trimesh.Trimesh, ring_mesh: trimesh.Trimesh, d: Design) -> list[tuple[float, float]]:
    """(stop z, slack) per rod, measured: the socket floor under each rod in the base and the end
    of its socket in the ring above it, mm."""
    out = []
    tip = ring.levels(d)["tip"]
    for a in d.whisker_angles_deg:
        x, y = polar_xy(d.whiskers.ring_radius, a)
        stop = _first_hit(base, (x, y, -0.01), (0, 0, -1))
        end = _first_hit(ring_mesh, (x, y, tip - 1.0), (0, 0, 1))
        out.append((stop, end - (stop + d.whiskers.rod_length)))
    return out


def release_checks(base: trimesh.Trimesh, ring_mesh: trimesh.Trimesh, d: Design) -> list[Check]:
    m, t = d.mold, d.membrane.thickness
    drafts = side_wall_drafts(base, d)
    worst = float(drafts.min()) if len(drafts) else math.nan
    out = [make_check("cavity side-wall draft (release upwards)", "mold_base", worst, worst >= m.draft_deg - ANGLE_TOL,
                  f">= mold.draft_deg {m.draft_deg:g}", "deg", ("mold.draft_deg",),
                  f"least of {len(drafts)} side-wall faces; the membrane lifts out along the rods")]
    grow = _inscribed(base, t - EDGE) - d.membrane.inscribed_radius
    out.append(make_check("cast membrane's top beyond the nominal polygon", "mold_base", grow,
                      grow <= d.print.clearance + HEIGHT_TOL, f"<= print.clearance {d.print.clearance:g}", "mm",
                      ("mold.draft_deg", "membrane.thickness", "print.clearance"),
                      "the mount's seat pocket is print.clearance wider than the nominal polygon"))
    found = stops_and_slack(base, ring_mesh, d)
    stop_err = max(abs(s + d.rod_below_membrane) for s, _ in found)
    out.append(measured_check("rod stop height error", "mold_base", stop_err, stop_err <= HEIGHT_TOL, f"<= {HEIGHT_TOL:g}",
                         "mm", ("whiskers.rod_length", "whiskers.protrusion", "membrane.thickness"),
                         f"socket floors at z = {-d.rod_below_membrane:g} mm: a rod's lower end"))
    slack = min(s for _, s in found)
    off = max(abs(s - m.rod_slack) for _, s in found)
    out.append(make_check("rod axial slack (stop in the base to the ring's socket end)", "whisker_ring", slack,
                      slack >= -HEIGHT_TOL and off <= HEIGHT_TOL, f"== mold.rod_slack {m.rod_slack:g}", "mm",
                      ("mold.rod_slack", "ring.hole_depth"), f"{len(found)} rods; a rod up to {m.rod_slack:g} mm "
                      "long still stands on its stop"))
    return out


def vent_checks(lid: trimesh.Trimesh, ring_mesh: trimesh.Trimesh, d: Design) -> list[Check]:
    """Every vent of the lid is at a cavity corner and visible from above past the whisker ring."""
    from whisker.cad.verify.checks import _ray_hits, describe_circles

    top = d.membrane.thickness + d.mold.lid_thickness
    corner = d.membrane.inscribed_radius / math.cos(math.pi / d.membrane.sides)
    circles = describe_circles(holes(section(lid, top - 0.5)))
    found = [polar_xy(r, a) for r, a, dia in circles
             if abs(dia - d.mold.vent_diameter) < 0.05 and r > d.whiskers.ring_radius + 1]
    hidden = [(x, y) for x, y in found if len(_ray_hits(ring_mesh, (x, y, top + 0.1), (0, 0, 1)))]
    reach = max((corner - math.hypot(x, y) - d.mold.vent_diameter / 2 for x, y in found), default=math.inf)
    return [make_check("vents at the cavity's corners", "mold_lid", len(found), len(found) == d.membrane.sides and reach <= 0.1,
                       f"== {d.membrane.sides}, each rim at its corner", "", ("membrane.sides", "mold.vent_diameter"),
                       f"each vent's rim within {max(reach, 0.0):.2f} mm of its corner (nominal cavity)"),
            make_check("vents in sight from above with the whisker ring on", "whisker_ring", len(hidden),
                       not hidden, "== 0", "", ("ring.margin", "mold.vent_diameter"),
                       f"hidden under the ring: {hidden}" if hidden else "a ray up from every vent misses the ring")]

