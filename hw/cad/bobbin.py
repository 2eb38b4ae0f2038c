"""Coil former (bobbin), printed on a resin (MSLA) printer: 0.05 mm pixels and layers, walls down to
``bobbin.min_wall`` (0.3 mm). An FDM printer with a 0.4 mm nozzle cannot print its 1 mm core.

Whisker 0 in sensor coordinates (mm); the coil's axis is radial (x), at ``design.coil_axis_z``:
- the *tab*: a block centred on the rod (x = ring radius), ``bobbin.tab`` thick along x, as wide as
  the coil, from the coil's lower face up to ``tab_top``; the rod sits in a blind socket in it and
  ends above the winding's axis, outside the winding; two lead holes beside the socket take the
  coil's leads up along the rod (the strain relief); its lower face is the marker face the camera
  sees (the red dot goes there);
- the *core*: ``coil.inner_diameter``, ``coil.length`` long, outboard of the tab, with a bore on the
  coil axis (for a 0.3 mm pin, or just to save resin);
- the *outer flange*: ``bobbin.flange`` thick, ``coil.outer_diameter`` across.
The winding fills the window between tab and flange up to ``bobbin.rim_margin`` under the rim; the
turns that fit, their resistance and wire length come from whisker.coil.winding on that window.
"""

from __future__ import annotations

import cadquery as cq

from whisker import coil as coil_calc
from whisker.design import Design, design_from_dict

from . import extras
from .shapes import cut_all, cylinder, radial_cylinder


def layout(d: Design) -> dict:
    b = extras.section(d, "bobbin")
    c, R = d.coil, d.whiskers.ring_radius
    tab0, tab1 = R - b.tab / 2, R + b.tab / 2
    core1 = tab1 + c.length
    tab_top = min(-d.coil.drop / 2, d.coil_axis_z + c.outer_diameter / 2 + b.socket_depth)
    socket = d.hole(d.whiskers.rod_diameter) if d.print.clearance <= 0.1 else d.whiskers.rod_diameter + 0.2
    return dict(settings=b, tab=(tab0, tab1), core=(tab1, core1), flange=(core1, core1 + b.flange),
                tab_top=tab_top, tab_bottom=d.marker_z, socket_diameter=socket,
                socket_bottom=-d.rod_below_membrane, bore=max(b.min_wall, c.inner_diameter - 2 * b.min_wall),
                lead_y=socket / 2 + b.min_wall + b.lead_hole / 2, outer_x=core1 + b.flange)


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
    from .walls import outside_box

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
    return cut_all(tab.fuse(core, flange).clean(), bobbin_tools(d).values())


def winding_envelope(d: Design) -> cq.Shape:
    """The wound copper as a full annulus between tab and flange (for the assembly), mm."""
    L = layout(d)
    od = d.coil.outer_diameter - 2 * L["settings"].rim_margin
    outer = radial_cylinder(L["core"][0], L["core"][1], od, d.coil_axis_z, 0.0)
    return outer.cut(radial_cylinder(L["core"][0] - 1, L["core"][1] + 1, d.coil.inner_diameter, d.coil_axis_z, 0.0))


def winding_design(d: Design) -> Design:
    """The design with [coil] describing the bobbin's window (outer diameter less the rim margin)."""
    data = d.to_dict()
    data["coil"]["outer_diameter"] = d.coil.outer_diameter - 2 * layout(d)["settings"].rim_margin
    return design_from_dict(data)


def winding(d: Design) -> dict:
    """Turns that fit the bobbin at [winding] fill_factor and what they give (whisker.coil.winding):
    turns, 20 C resistance (ohm), wire length (mm), and whether the design's coil.turns fit."""
    wd = winding_design(d)
    requested = coil_calc.winding(wd)
    data = wd.to_dict()
    data["coil"]["turns"] = max(1, requested.max_turns_at_fill)
    fit = coil_calc.winding(design_from_dict(data))
    return {"turns": fit.turns, "resistance_ohm": fit.resistance_ohm, "wire_length_mm": fit.wire_length_mm,
            "layers": fit.layers, "design_turns": d.coil.turns, "design_turns_fit": requested.fits,
            "window_mm2": fit.window_mm2}


def outer_face_radius(d: Design) -> float:
    """Radius (mm) of the bobbin's outer flange face at rest: the magnet face must be
    ``actuation.gap`` beyond it (today's cavity radius assumes a coil centred on the rod)."""
    return layout(d)["outer_x"]
