"""Whisker ring: the gluing and casting jig (printable).

A ring plate with a blind socket per rod at the ring radius stands on a tube on the mould lid and
keeps all rods parallel while the Ecoflex cures. It stands inside the lid's vents, which stay in
sight from above. The rods stand on their stops in the mould base
(mold.py), so a nominal rod's tip is ``whiskers.protrusion`` above the membrane; each socket ends
``mold.rod_slack`` above that tip (the axial slack: a rod cut a little long still reaches its stop). The plate's central
opening lets the Ecoflex be poured into the lid's pour opening with the jig in place.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

from whisker.cad.solids.shapes import cut_all, cylinder, polar_xy


def radii(d: Design) -> dict[str, float]:
    """Inner opening, outer plate radius and tube radii (mm). The plate and the tube end ring.margin
    outside the sockets, inside the mould lid's vents (at the cavity's corners), so the pourer sees
    every vent from above with the jig in place (whisker.cad.verify.mold_checks.vent_checks)."""
    w, r = d.whiskers, d.ring
    socket_r = d.hole(w.rod_diameter) / 2
    outer = w.ring_radius + socket_r + r.margin
    # The Ecoflex is poured through the plate's opening: never narrower than the pour opening.
    opening = max(w.ring_radius - socket_r - r.margin, d.mold.pour_diameter / 2)
    return dict(opening=opening, outer=outer, tube_inner=outer - r.tube_wall)


def levels(d: Design) -> dict[str, float]:
    lid_top = d.membrane.thickness + d.mold.lid_thickness
    tip = d.membrane.thickness + d.whiskers.protrusion
    return dict(lid_top=lid_top, tip=tip, socket_bottom=tip + d.mold.rod_slack, plate_bottom=tip - d.ring.hole_depth,
                top=tip - d.ring.hole_depth + d.ring.plate_thickness)


def whisker_ring(d: Design) -> cq.Shape:
    rr, z = radii(d), levels(d)
    plate = cylinder(rr["outer"], z["plate_bottom"], z["top"])
    if rr["opening"] > 0:
        plate = plate.cut(cylinder(rr["opening"], z["plate_bottom"] - 1, z["top"] + 1))
    tube = cylinder(rr["outer"], z["lid_top"], z["plate_bottom"] + 0.01).cut(
        cylinder(rr["tube_inner"], z["lid_top"] - 1, z["plate_bottom"] + 0.02))
    body = plate.fuse(tube).clean()
    sockets = [cylinder(d.hole(d.whiskers.rod_diameter) / 2, z["plate_bottom"] - 1, z["socket_bottom"],
                        *polar_xy(d.whiskers.ring_radius, a)) for a in d.whisker_angles_deg]
    return cut_all(body, sockets)
