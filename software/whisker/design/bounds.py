"""Closed-form refusals: design conflicts that a formula decides in microseconds, before any solid.

`whisker cad build` and `whisker cad sweep` (and the explorer) call `refusal(design)` first: a
design that one of these necessary conditions already rules out is refused in one line, without
the minutes of CAD work that would reach the same verdict. Each condition is necessary, never
stricter than the CAD check it anticipates, so it never refuses a design that builds:

- crowding: the ring radius is below the small-ring bound
  (`whisker.design.sizing.crowding_bound_radius`, docs/sweep.md; the CAD check of neighbouring
  coils refuses every cell inside it, tests/test_cad_scaled.py).
- pour opening: the mould's pour opening (radius mold.pour_diameter / 2) reaches the rod sockets'
  holes (radius whiskers.ring_radius - hole / 2): the whisker ring's opening cannot be as wide.
- printer bed: the mount is at least a disc of radius mount.outer_radius, which fits a rectangular
  bed only if its diameter is at most the bed's shorter side (hw/printer profile, print.profile).
- camera view: the markers at rest, ring_radius x focal_length_px / camera.distance from the
  image centre, are outside the image (half its height).
"""

from __future__ import annotations

import math


def refusals(d) -> list[str]:
    """One line per closed-form condition `d` (a resolved Design) violates; [] when none decides."""
    from whisker.design.sizing import crowding_bound_radius

    out = []
    R, n = d.whiskers.ring_radius, d.whiskers.count
    bound = crowding_bound_radius(d)
    if R < bound - 1e-9:
        out.append(f"crowding: whiskers.count={n} at whiskers.ring_radius={R:g} mm: neighbouring coils collide at "
                   f"full inward swing; the small-ring bound needs ring_radius >= {bound:.2f} mm "
                   "(whisker.design.sizing.crowding_bound_radius, docs/sweep.md)")
    hole = d.hole(d.whiskers.rod_diameter)
    if d.mold.pour_diameter / 2 > R - hole / 2:
        out.append(f"pour opening: mold.pour_diameter {d.mold.pour_diameter:g} mm reaches the rod sockets "
                   f"(ring radius {R:g} mm less half a {hole:g} mm hole); give a smaller mold.pour_diameter or a "
                   "larger whiskers.ring_radius")
    try:
        from whisker.design.printer import load_profile

        p = load_profile(d.print.profile)
        side = min(p.bed_x, p.bed_y)
        if 2 * d.mount.outer_radius > side:
            out.append(f"printer bed: the mount is {2 * d.mount.outer_radius:g} mm across (mount.outer_radius "
                       f"{d.mount.outer_radius:g} mm), wider than the bed's {side:g} mm side ({d.print.profile})")
    except (OSError, ValueError):
        pass                       # an unreadable profile is the design model's (and the CAD's) to report
    r_px = R * d.camera.focal_length_px / d.camera.distance if d.camera.distance > 0 else math.inf
    if r_px > d.camera.height_px / 2:
        out.append(f"camera view: the markers at rest are {r_px:.0f} px from the image centre, outside the "
                   f"{d.camera.width_px} x {d.camera.height_px} px image (camera.distance {d.camera.distance:g} mm); "
                   "give a larger camera.distance")
    return out


def refusal(d) -> str | None:
    """The first closed-form refusal of `d` as one line, or None."""
    r = refusals(d)
    return r[0] if r else None
