"""The whisker's end stop: a post on the bobbin's outer flange that meets the magnet's face.

With ``actuation.end_stop = true`` the retraction of every whisker ends at ``whiskers.max_deflection_deg``:
a cylindrical post (``bobbin.stop_post_diameter``), centred on the coil axis on the outer flange's face,
touches the magnet's face there. A current above the pull-in current then lands the coil on the stop
(a defined pose, the coil clear of the magnet) instead of snapping it onto the magnet. One source for
the CAD (whisker.cad.solids.bobbin), the swing check (whisker.cad.assembly.swing), the coil physics (whisker.coil.tilt:
the tilt is clamped at the stop) and the simulator (whisker.coil.kinematics).

Geometry (whisker 0, mm, tilt retraction positive, pivot at the membrane's mid-plane; the rotation of
whisker.design.former.tilt): a point at radial offset ``a`` from the rod and ``h`` below the pivot moves
out to a cos(theta) + h sin(theta). The post's tip reaches furthest at its lower edge,
a = (outer flange face - rod) + post length, h = lever + post radius. It touches the magnet's face
(X = cavity radius - ring radius) at theta_s when a cos(theta_s) + h sin(theta_s) = X, so
post length = (X - h sin theta_s)/cos theta_s - (outer flange face - rod). The flange's own lower rim
(a = outer flange face - rod, h = lever + coil.outer_diameter/2) must stay clear of the magnet's face
up to theta_s, or the flange would be the stop: refused in one line.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from whisker.design.validation import DesignError


@dataclass(frozen=True)
class EndStop:
    tilt_deg: float                # retraction tilt where the post meets the magnet's face
    post_length_mm: float          # beyond the outer flange's face, along the coil axis
    post_diameter_mm: float
    gap_mm: float                  # winding face to magnet face on the coil axis at the stop (the force's gap,
                                   # whisker.coil.tilt.gap_at_mm convention: gap - lever sin theta_s)
    contact_arm_mm: float          # pivot to the contact, measured across the contact's (radial) normal
    rim_clearance_mm: float        # the flange's lower rim to the magnet's face at the stop

    def to_dict(self) -> dict:
        return asdict(self)


def _lever(d) -> float:
    return d.pivot_z - d.coil_axis_z


def post_length_for(d, tilt_deg: float, gap_mm: float | None = None, lever_mm: float | None = None) -> float:
    """Post length (mm) that meets the magnet's face at tilt_deg for a rest gap and lever (default: the design's)."""
    from whisker.design.former import outer_offset, winding_face_offset

    gap = d.actuation.gap if gap_mm is None else gap_mm
    lev = _lever(d) if lever_mm is None else lever_mm
    th = math.radians(tilt_deg)
    x_face = winding_face_offset(d) + gap
    h = lev + d.bobbin.stop_post_diameter / 2
    return (x_face - h * math.sin(th)) / math.cos(th) - outer_offset(d)


def contact_tilt_rad(a_mm, h_mm, x_face_mm):
    """Tilt (rad, vectorised) at which a point at radial offset a and depth h below the pivot reaches
    the radial position x_face: a cos t + h sin t = X -> t = asin(X / hypot(a, h)) - atan2(a, h)."""
    import numpy as np

    a, h, x = np.asarray(a_mm, float), np.asarray(h_mm, float), np.asarray(x_face_mm, float)
    r = np.hypot(a, h)
    return np.arcsin(np.clip(x / r, -1.0, 1.0)) - np.arctan2(a, h)


def end_stop(d) -> EndStop | None:
    """The design's end stop, or None when ``actuation.end_stop`` is false."""
    from whisker.design.former import outer_offset, winding_face_offset

    if not d.actuation.end_stop:
        return None
    th_deg = d.whiskers.max_deflection_deg
    th = math.radians(th_deg)
    lev = _lever(d)
    p = post_length_for(d, th_deg)
    x_face = winding_face_offset(d) + d.actuation.gap
    rim = outer_offset(d) * math.cos(th) + (lev + d.coil.outer_diameter / 2) * math.sin(th)
    if p <= 0 or rim >= x_face:
        rim_deg = math.degrees(float(contact_tilt_rad(outer_offset(d), lev + d.coil.outer_diameter / 2, x_face)))
        raise DesignError(
            f"actuation.end_stop: the bobbin's outer flange meets the magnet at {rim_deg:.1f} deg, before the stop at "
            f"whiskers.max_deflection_deg = {th_deg:g} deg; lower the stop tilt or widen actuation.gap")
    h = lev + d.bobbin.stop_post_diameter / 2
    return EndStop(tilt_deg=th_deg, post_length_mm=p, post_diameter_mm=d.bobbin.stop_post_diameter,
                   gap_mm=d.actuation.gap - lev * math.sin(th),
                   contact_arm_mm=h * math.cos(th) - (outer_offset(d) + p) * math.sin(th),
                   rim_clearance_mm=x_face - rim)


def stop_tilt_rad(d) -> float | None:
    """The stop's tilt in rad, or None without a stop."""
    s = end_stop(d)
    return None if s is None else math.radians(s.tilt_deg)
