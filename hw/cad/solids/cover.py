"""Camera cover (printable, FDM 0.4 mm): closes the camera pocket from below when the sensor is used
without the robot adapter (the adapter's top face closes it otherwise).

A plate under the mount's bottom face (sensor coordinates, mm), as wide as the camera pocket plus
``cover.margin`` each side, with a relief in its top face for the board's back components and the
flat cable, continued as a channel to the -y edge under the mount's flat-cable slot, and two screws
left and right of the pocket (``cover.screw``, ``cover.joint`` in the mount), counterbored from below.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import fasteners
from whisker.design import sizing
from whisker.design import Design

from whisker.cad import extras
from whisker.cad.solids.shapes import cut_all, cylinder
from whisker.cad.verify.walls import outside_box


def layout(d: Design) -> dict:
    c = extras.section(d, "cover")
    f = fasteners.fastener(d.fasteners.cover_screw)
    w, h = d.hole(d.camera.board_width), d.hole(d.camera.board_height)
    top = sizing.mount_levels(d)["bottom"]
    t = c.thickness + c.relief_depth
    t = max(t, f.head_height + 0.5 + d.print.min_wall)
    # room for a counterbored screw between the pocket and the edge, a wall each side
    margin = max(c.margin, d.hole(f.head_diameter) + 2 * d.print.min_wall + 0.1)
    half = (w / 2 + margin, h / 2 + margin)
    return dict(settings=c, screw=f, pocket=(w, h), top=top, bottom=top - t, thickness=t, half=half,
                screws=[(-(w / 2 + margin / 2), 0.0), (w / 2 + margin / 2, 0.0)])


def cover_tools(d: Design) -> dict[str, cq.Shape]:
    L = layout(d)
    c, f, top, bot = L["settings"], L["screw"], L["top"], L["bottom"]
    w, h = L["pocket"]
    rw = d.hole(d.mount.ribbon_width)
    relief = cq.Solid.makeBox(w, h, c.relief_depth + 1, cq.Vector(-w / 2, -h / 2, top - c.relief_depth))
    channel = cq.Solid.makeBox(rw, L["half"][1] + 1, c.relief_depth + 1,
                               cq.Vector(-rw / 2, -L["half"][1] - 1, top - c.relief_depth))
    tools = {"board and cable relief": relief.fuse(channel).clean()}
    clear, cb = f.clear_medium, d.hole(f.head_diameter)
    for k, (x, y) in enumerate(L["screws"]):
        tools[f"screw {k}"] = cylinder(clear / 2, bot - 1, top + 1, x, y).fuse(
            cylinder(cb / 2, bot - 1, bot + f.head_height + 0.5, x, y)).clean()
    return tools


def edges(d: Design) -> dict[str, cq.Shape]:
    L = layout(d)
    hx, hy = L["half"]
    return {"cover edge": outside_box((-hx, -hy, L["bottom"]), (hx, hy, L["top"]))}


def cover(d: Design) -> cq.Shape:
    L = layout(d)
    hx, hy = L["half"]
    body = cq.Solid.makeBox(2 * hx, 2 * hy, L["thickness"], cq.Vector(-hx, -hy, L["bottom"]))
    return cut_all(body, cover_tools(d).values())


def joints(d: Design) -> list[fasteners.Joint]:
    L = layout(d)
    return [fasteners.Joint("camera cover", d.fasteners.cover_screw, d.fasteners.cover_joint, len(L["screws"]),
                            L["thickness"] - L["screw"].head_height - 0.5)]
