"""Coil former (bobbin), printed on a resin (MSLA) printer: 0.05 mm pixels and layers, walls down to
``bobbin.min_wall`` (0.3 mm). An FDM printer with a 0.4 mm nozzle cannot print its 1 mm core.

The layout (whisker 0, sensor coordinates, mm) is whisker.design.former's: the *tab* centred on the rod,
the rod in a blind socket in it, outside the winding, and two lead holes beside the socket through
which the leads run down to the tab's lower face, glued there (the strain relief; whisker.design.leads);
the tab's lower face is the marker face the camera sees (the red dot goes there); the *core* with a
bore on the coil axis (for a 0.3 mm pin, or just to save resin); the *outer flange*, and on it, with
``actuation.end_stop``, the end-stop post that meets the magnet's face at the stop tilt
(whisker.design.stop). The winding
fills the window between tab and flange up to ``bobbin.rim_margin`` under the rim; the turns that
fit, their resistance and wire length come from whisker.coil.winding on that window.
"""

from __future__ import annotations

import cadquery as cq

from whisker import coil as coil_calc
from whisker.design import former
from whisker.design import Design
from whisker.design.stop import end_stop

from whisker.cad.solids.shapes import cut_all, cylinder, radial_cylinder


def layout(d: Design) -> dict:
    """The former's layout (whisker.design.former.layout) as a dict, with the [bobbin] settings."""
    f = former.layout(d)
    return dict(settings=d.bobbin, tab=f.tab, core=f.core, flange=f.flange, tab_top=f.tab_top,
                tab_bottom=f.tab_bottom, socket_diameter=f.socket_diameter, socket_bottom=f.socket_bottom,
                bore=f.bore, lead_y=f.lead_y, outer_x=f.outer_x, winding_od=f.winding_outer_diameter)


def bobbin_tools(d: Design) -> dict[str, cq.Shape]:
    L = layout(d)
    b, R = L["settings"], d.whiskers.ring_radius
    tools = {"rod socket": cylinder(L["socket_diameter"] / 2, L["socket_bottom"], L["tab_top"] + 1, R, 0.0),
             "core bore": radial_cylinder(L["tab"][1], L["outer_x"] + 1, L["bore"], d.coil_axis_z, 0.0)}
    for s in (-1, 1):
        tools[f"lead hole {'+' if s > 0 else '-'}y"] = cylinder(b.lead_hole / 2, L["tab_bottom"] - 1,
                                                                L["tab_top"] + 1, R, s * L["lead_y"])
    return tools


def edges(d: Design) -> dict[str, cq.Shape]:
    """The space around the tab's sides, for the wall check."""
    from whisker.cad.verify.walls import outside_box

    L = layout(d)
    r = d.coil.outer_diameter / 2
    return {"tab sides": outside_box((L["tab"][0], -r, L["tab_bottom"]), (L["tab"][1], r, L["tab_top"]), 1.0)}


def bobbin(d: Design) -> cq.Shape:
    L = layout(d)
    c = d.coil
    tab = cq.Solid.makeBox(L["tab"][1] - L["tab"][0], c.outer_diameter, L["tab_top"] - L["tab_bottom"],
                           cq.Vector(L["tab"][0], -c.outer_diameter / 2, L["tab_bottom"]))
    core = radial_cylinder(L["core"][0] - 0.01, L["core"][1] + 0.01, c.inner_diameter, d.coil_axis_z, 0.0)
    flange = radial_cylinder(L["flange"][0], L["flange"][1], c.outer_diameter, d.coil_axis_z, 0.0)
    parts = [core, flange]
    stop = end_stop(d)
    if stop is not None:   # the end-stop post: meets the magnet's face at the stop tilt (whisker.design.stop)
        parts.append(radial_cylinder(L["outer_x"] - 0.01, L["outer_x"] + stop.post_length_mm, stop.post_diameter_mm,
                                     d.coil_axis_z, 0.0))
    return cut_all(tab.fuse(*parts).clean(), bobbin_tools(d).values())


def winding_envelope(d: Design) -> cq.Shape:
    """The wound copper as a full annulus between tab and flange (for the assembly), mm: from the
    core out to the coil.turns' build at winding.fill_factor (whisker.coil.winding), at most the
    window's outer diameter."""
    L = layout(d)
    od = min(L["winding_od"], coil_calc.winding(d).wound_outer_diameter_mm)
    outer = radial_cylinder(L["core"][0], L["core"][1], od, d.coil_axis_z, 0.0)
    return outer.cut(radial_cylinder(L["core"][0] - 1, L["core"][1] + 1, d.coil.inner_diameter, d.coil_axis_z, 0.0))


def outer_face_radius(d: Design) -> float:
    """Radius (mm) of the bobbin's outer flange face at rest."""
    return layout(d)["outer_x"]
