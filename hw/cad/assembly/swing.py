"""Every solid of the assembly against every other, over the whole swing; the coils' leads.

The moving pieces of each whisker - rod, bobbin, winding (rigid together) and its two leads (their
free part re-drawn taut at each tilt, whisker.design.leads) - are placed at ``leads.SWING_SAMPLES`` tilts
from full extension to full retraction, every whisker at the same tilt, and intersected (manifold3d
mesh booleans) with the mount, the magnets, the LED strip, the membrane, and the other whiskers'
pieces. A pair counts when it shares more than ``verdict.VOLUME_EPS``.

Left out, and why: the rods above the membrane's upper face (there they can only meet each other,
at the tips, when every whisker retracts past ``leads.tips_meet_deg``: the grasp); a rod and the membrane (the rod is glued through it; the membrane is soft and
follows the rod); a winding and its own bobbin (wound on its core: coincident faces, measured
exactly with OpenCascade at rest instead, since the two never move apart); lead against lead (wires
may touch); the leads' few millimetres from the winding over the tab's top (they lie on the
bobbin); the camera board and lens holder (far below the coils; on the smallest rings, e.g. 2 @ 4 mm,
the cable exits' height reaches the lens holder's pocket, a limit of the mount's layout that no check
covers yet). Units: mm.
"""

from __future__ import annotations

import math

import cadquery as cq
import manifold3d
import numpy as np

from whisker.design import leads
from whisker.design import Design

from whisker.cad.solids import bobbin as former
from whisker.cad.solids import reference
from whisker.cad.verify.verdict import VOLUME_EPS, Check, make_check, to_mesh

# The lead as modelled: enamelled 0.1 mm wire (whisker.coil.enamel_overall_diameter_mm).
SPHERE_SEGMENTS = 8


def lead_diameter(d: Design) -> float:
    from whisker.coil import enamel_overall_diameter_mm
    return enamel_overall_diameter_mm(d.coil.wire_diameter, d.winding.enamel_grade)


def lead_solid(d: Design, i: int, side: int, tilt_deg: float = 0.0) -> cq.Shape:
    """One lead as a solid: a circle swept along its polyline (whisker.design.leads.path)."""
    pts = [cq.Vector(*p) for p in leads.path(d, i, side, tilt_deg)]
    r = lead_diameter(d) / 2
    segs = []
    for a, b in zip(pts[:-1], pts[1:]):
        segs.append(cq.Solid.makeCylinder(r, (b - a).Length, a, (b - a).normalized()))
        segs.append(cq.Solid.makeSphere(r, b, angleDegrees1=-90, angleDegrees2=90))
    return segs[0].fuse(*segs[1:]).clean()


def _manifold(shape: cq.Shape) -> manifold3d.Manifold:
    m = to_mesh(shape, 0.01, 0.2)
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.ascontiguousarray(m.vertices, dtype=np.float32),
                                               tri_verts=np.ascontiguousarray(m.faces, dtype=np.uint32)))


def _capsules(points: np.ndarray, r: float) -> manifold3d.Manifold:
    balls = [manifold3d.Manifold.sphere(r, SPHERE_SEGMENTS).translate(tuple(map(float, p))) for p in points]
    return manifold3d.Manifold.compose([manifold3d.Manifold.batch_hull([a, b]) for a, b in zip(balls[:-1], balls[1:])])


def _pose(d: Design, angle_deg: float, tilt_deg: float) -> np.ndarray:
    """3 x 4 matrix: tilt whisker 0's pieces about its pivot (whisker.design.former.tilt), then turn to angle."""
    b = math.radians(-tilt_deg)
    p = np.array([d.whiskers.ring_radius, 0.0, d.pivot_z])
    m = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    rot = rz @ m
    return np.column_stack([rot, rz @ (p - m @ p)])


def _overlaps(a: manifold3d.Manifold, b: manifold3d.Manifold) -> float:
    ba, bb = np.asarray(a.bounding_box()), np.asarray(b.bounding_box())
    if np.any(ba[:3] > bb[3:]) or np.any(bb[:3] > ba[3:]):
        return 0.0
    return (a ^ b).volume()


def static_pieces(d: Design, mount: cq.Shape, membrane: cq.Shape) -> dict[str, manifold3d.Manifold]:
    out = {"mount": _manifold(mount), "membrane": _manifold(membrane)}
    out.update({f"magnet {i}": _manifold(reference.magnet(d, a)) for i, a in enumerate(d.whisker_angles_deg)})
    out["LED strip"] = _manifold(reference.led_strip(d))
    return out


def swing_check(d: Design, mount: cq.Shape, membrane: cq.Shape) -> list[Check]:
    """No two solids of the assembly share volume at any sampled tilt of the swing; and the coil's
    own rigid parts (rod, bobbin, winding) do not overlap, measured exactly at rest."""
    rigid = {"rod": reference.rod(d), "bobbin": former.bobbin(d), "winding": former.winding_envelope(d)}
    own = max(rigid[a].intersect(rigid[b]).Volume() for a, b in (("rod", "bobbin"), ("rod", "winding"),
                                                                   ("bobbin", "winding")))
    out = [make_check("rod, bobbin and winding overlap", "assembly", own, own <= VOLUME_EPS, "0", "mm^3",
                  ("bobbin.tab", "bobbin.socket_depth", "coil.drop", "whiskers.rod_length"))]
    # The rods up to the membrane's upper face: above it they meet only each other, at the tips, when
    # every whisker retracts past asin(R / l_u) (whisker.design.leads.tips_meet_deg), which is the grasp.
    below = cq.Solid.makeBox(200, 200, 200, cq.Vector(-100, -100, d.membrane.thickness - 200))
    rest = {k: _manifold(v.intersect(below) if k == "rod" else v) for k, v in rigid.items()}
    static = static_pieces(d, mount, membrane)
    r = lead_diameter(d) / 2
    n = d.whiskers.count
    worst, where = 0.0, ""
    for tilt in leads.swing_tilts(d):
        moving: list[tuple[int, str, manifold3d.Manifold]] = []
        for i, a in enumerate(d.whisker_angles_deg):
            pose = _pose(d, a, float(tilt))
            moving += [(i, f"{k} {i}", m.transform(pose)) for k, m in rest.items()]
            moving += [(i, f"lead {i}{'+' if s > 0 else '-'}", _capsules(leads.path(d, i, s, float(tilt)), r))
                       for s in (-1, 1)]
        pairs = [(na, ma, nb, mb) for _, na, ma in moving for nb, mb in static.items()
                 if not (na.startswith("rod") and nb == "membrane")]
        for k, (i, na, ma) in enumerate(moving):
            for j, nb, mb in moving[k + 1:]:
                if na.startswith("lead") and nb.startswith("lead"):
                    continue
                if i == j and {na.split()[0], nb.split()[0]} == {"bobbin", "winding"}:
                    continue
                if i != j and n > 2 and (j - i) % n not in (1, n - 1) and not (na.startswith("lead") or nb.startswith("lead")):
                    continue  # rigid pieces only meet their neighbours; leads cross the ring
                pairs.append((na, ma, nb, mb))
        for na, ma, nb, mb in pairs:
            v = _overlaps(ma, mb)
            if v > max(worst, VOLUME_EPS):
                worst, where = v, f"{na} and {nb} overlap by {v:.3g} mm^3 at tilt {float(tilt):+.3g} deg"
    out.append(make_check("solids overlapping over the swing", "assembly", worst, worst <= VOLUME_EPS, "0", "mm^3",
                      ("whiskers.max_deflection_deg", "bobbin.tab", "coil.length", "actuation.gap",
                       "mount.cable_exit_count", "membrane.inscribed_radius"), where))
    out += end_stop_check(d)
    rep = leads.length_report(d)
    need = rep["needed_to_outside_mm"]
    out.append(make_check("coil lead length for the full swing", "assembly", d.bom.coil_lead_length,
                      d.bom.coil_lead_length >= need, f">= {need:.3g}", "mm", ("bom.coil_lead_length",),
                      f"longest taut path {rep['longest_free_mm']:.3g} mm, swing slack {rep['swing_slack_mm']:.3g} mm"))
    return out


#: deg past the stop at which the end-stop check looks: the post must be the first thing to meet the magnet
STOP_PROBE_DEG = 0.5


def end_stop_check(d: Design) -> list[Check]:
    """With ``actuation.end_stop``: the swing above ends at the stop tilt, where the bobbin's post just
    touches its magnet; STOP_PROBE_DEG further, the post overlaps the magnet (it is what stops the
    whisker) while the winding and the rest of the bobbin (without its post) stay clear."""
    from whisker.design.stop import end_stop

    s = end_stop(d)
    if s is None:
        return []
    tilt = s.tilt_deg + STOP_PROBE_DEG
    pose = _pose(d, d.whisker_angles_deg[0], tilt)
    mag = _manifold(reference.magnet(d, d.whisker_angles_deg[0]))
    post = _manifold(former.bobbin(d)).transform(pose)
    bare = _manifold(former.bobbin(d.model_copy(update={"actuation": d.actuation.model_copy(
        update={"end_stop": False})}))).transform(pose)
    wind = _manifold(former.winding_envelope(d)).transform(pose)
    v_post, v_rest = _overlaps(post, mag), max(_overlaps(bare, mag), _overlaps(wind, mag))
    ok = v_post > VOLUME_EPS and v_rest <= VOLUME_EPS
    return [make_check("end stop: the post meets the magnet first", "assembly", v_rest, ok, "0", "mm^3",
                       ("actuation.end_stop", "whiskers.max_deflection_deg", "bobbin.stop_post_diameter",
                        "actuation.gap"),
                       f"{STOP_PROBE_DEG:g} deg past the stop ({s.tilt_deg:g} deg): post in the magnet "
                       f"{v_post:.3g} mm^3, flange and winding {v_rest:.3g} mm^3")]
