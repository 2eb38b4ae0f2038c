"""Winding jig (printable, FDM 0.4 mm): an arbor for a hand drill or a small motor that turns the
bobbin about its coil axis and counts the turns.

Along +z from the chuck: a ``winding_jig.shank_diameter`` shank, then a disc whose top face has a
pocket that takes the bobbin's tab (keyed: the tab is not square, so the bobbin sits one way, its
coil axis on the arbor's axis); the winding starts at the disc face. Per turn, one flag on the
disc's rim passes a slotted opto switch or a microswitch, and one magnet (pocket in the disc's
underside, opposite the flag) passes a reed switch or a bicycle computer's sensor: either counts
turns; a hand count of the flag works too at drill speeds below ~2 turns/s. Units: mm.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

from whisker.cad.solids import bobbin as bobbin_model
from whisker.cad import extras
from whisker.cad.solids.shapes import cut_all, cylinder


def layout(d: Design) -> dict:
    j = extras.section(d, "winding_jig")
    B = bobbin_model.layout(d)
    w = d.coil.outer_diameter  # the tab's width, across the arbor's x
    # the tab's extent relative to the coil axis, across the arbor's y
    y0, y1 = B["tab_bottom"] - d.coil_axis_z, B["tab_top"] - d.coil_axis_z
    disc_top = j.shank_length + j.disc_thickness
    depth = min(B["tab"][1] - B["tab"][0], j.disc_thickness - d.print.min_wall)
    return dict(settings=j, tab=(w, y0, y1), disc=(j.shank_length, disc_top), pocket_depth=depth)


def jig_tools(d: Design) -> dict[str, cq.Shape]:
    L = layout(d)
    j, c = L["settings"], d.print.clearance
    w, y0, y1 = L["tab"]
    z0, z1 = L["disc"]
    pocket = cq.Solid.makeBox(w + 2 * c, (y1 - y0) + 2 * c, L["pocket_depth"] + 1,
                              cq.Vector(-w / 2 - c, y0 - c, z1 - L["pocket_depth"]))
    md, mh = j.counter_magnet
    r = j.disc_diameter / 2 - d.hole(md) / 2 - d.print.min_wall
    magnet = cylinder(d.hole(md) / 2, z0 - 1, z0 + mh + 0.2, -r, 0.0)
    return {"bobbin pocket": pocket, "counter magnet pocket": magnet}


def edges(d: Design) -> dict[str, cq.Shape]:
    from whisker.cad.verify.walls import outside_ring

    L = layout(d)
    return {"disc rim": outside_ring(L["settings"].disc_diameter / 2, L["disc"][0], L["disc"][1])}


def winding_jig(d: Design) -> cq.Shape:
    L = layout(d)
    j = L["settings"]
    z0, z1 = L["disc"]
    shank = cylinder(j.shank_diameter / 2, 0.0, z0 + 0.01)
    disc = cylinder(j.disc_diameter / 2, z0, z1)
    flag = cq.Solid.makeBox(j.flag_length + 1.0, j.flag_width, j.disc_thickness,
                            cq.Vector(j.disc_diameter / 2 - 1.0, -j.flag_width / 2, z0))
    return cut_all(shank.fuse(disc, flag).clean(), jig_tools(d).values())
