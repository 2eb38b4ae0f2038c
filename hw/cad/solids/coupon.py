"""Print-tolerance coupon (printable): find the clearance your printer needs, once.

A flat plate carries, for each clearance ``c`` in ``print.coupon_clearances`` (mm, radial):
- a vertical rod hole of diameter ``whiskers.rod_diameter + 2c`` (vertical like the rod sockets and
  guides of the mould and the whisker ring),
- a blind magnet pocket of diameter ``magnet.diameter + 2c`` and depth ``magnet.height +
  mount.glue_gap`` with a HORIZONTAL axis, in a wall standing on the plate (horizontal like the
  magnet pockets in the mount's wall, which print as arches),
- the clearance engraved on the plate in front of them (e.g. ``0.2``).

Print it, push a rod and a magnet into each column, take the smallest clearance that fits without
force, and set ``print.clearance`` to it. The coupon prints as modelled: plate on the bed (z = 0).
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import Design

# Label glyph height and engraving depth (mm): 3 layers of 0.2 mm, readable at a 0.4 mm nozzle.
LABEL_SIZE = 3.5
LABEL_DEPTH = 0.6
LABEL_FONT = "DejaVu Sans"


def label(c: float) -> str:
    """The engraved text for a clearance in mm: 0, 0.1, 0.15 ..."""
    return f"{c:g}"


def layout(d: Design) -> dict[str, float]:
    """Pitch, plate and wall dimensions and feature positions of the coupon (mm)."""
    cs = d.print.coupon_clearances
    wall = max(d.print.min_wall, 2.0)
    pocket_max = d.magnet.diameter + 2 * max(cs)
    longest = max(len(label(c)) for c in cs)
    # a glyph is at most ~0.7 em wide; print.min_wall between glyphs (label_glyphs), a wall each side
    pitch = max(pocket_max + 2 * wall, (0.7 * LABEL_SIZE + d.print.min_wall) * longest + 2 * wall)
    plate_t = max(3.0, 2 * d.print.min_wall)
    pocket_depth = d.magnet.height + d.mount.glue_gap
    rod_y = wall + d.whiskers.rod_diameter / 2 + max(cs)
    label_y = rod_y + d.whiskers.rod_diameter / 2 + max(cs) + 1.0 + LABEL_SIZE / 2
    wall_y0 = label_y + LABEL_SIZE / 2 + 1.5
    wall_t = pocket_depth + d.print.min_wall
    wall_h = pocket_max + 2 * wall
    return dict(pitch=pitch, width=pitch * len(cs), plate_t=plate_t, rod_y=rod_y, label_y=label_y,
                wall_y0=wall_y0, wall_t=wall_t, wall_h=wall_h, depth=wall_y0 + wall_t,
                pocket_depth=pocket_depth, pocket_z=plate_t + wall_h / 2)


def column_x(d: Design) -> list[float]:
    lay = layout(d)
    return [lay["pitch"] * (k + 0.5) for k in range(len(d.print.coupon_clearances))]


def coupon_tools(d: Design) -> dict[str, cq.Shape]:
    """Every solid cut from the coupon, by name (the wall check names them): per clearance its rod
    hole, magnet pocket and each engraved glyph of its label."""
    lay = layout(d)
    tools: dict[str, cq.Shape] = {}
    for c, x in zip(d.print.coupon_clearances, column_x(d)):
        tools[f"rod hole {c:g}"] = cq.Solid.makeCylinder(d.whiskers.rod_diameter / 2 + c, lay["plate_t"] + 2,
                                                         cq.Vector(x, lay["rod_y"], -1), cq.Vector(0, 0, 1))
        tools[f"magnet pocket {c:g}"] = cq.Solid.makeCylinder(d.magnet.diameter / 2 + c, lay["pocket_depth"] + 0.5,
                                                              cq.Vector(x, lay["wall_y0"] - 0.5, lay["pocket_z"]),
                                                              cq.Vector(0, 1, 0))
        for k, g in enumerate(label_glyphs(d, c, x, lay["label_y"], lay["plate_t"])):
            tools[f"label {c:g} glyph {k}"] = g
    return tools


def edges(d: Design) -> dict[str, cq.Shape]:
    """The space around the plate's four sides, for the wall check."""
    from whisker.cad.verify.walls import outside_box

    lay = layout(d)
    return {"plate edge": outside_box((0.0, 0.0, 0.0), (lay["width"], lay["wall_y0"], lay["plate_t"]))}


def tolerance_coupon(d: Design) -> cq.Shape:
    lay = layout(d)
    body = cq.Solid.makeBox(lay["width"], lay["depth"], lay["plate_t"])
    wall = cq.Solid.makeBox(lay["width"], lay["wall_t"], lay["wall_h"] + 0.01,
                            cq.Vector(0, lay["wall_y0"], lay["plate_t"] - 0.01))
    body = body.fuse(wall).clean()
    return body.cut(*coupon_tools(d).values()).clean()


def _glyph(ch: str, z: float) -> cq.Shape:
    return (cq.Workplane("XY", origin=(0, 0, z))
            .text(ch, LABEL_SIZE, -LABEL_DEPTH, combine=False, halign="center", valign="bottom", font=LABEL_FONT)
            .val())


def label_glyphs(d: Design, c: float, x: float, y: float, z: float) -> list[cq.Shape]:
    """The engraving of one clearance label, one solid per character, centred on (x, y) at the plate's
    top z. Set with the font's own spacing, "0.1" left 0.01 mm of plate between the "0" and the "."
    (too thin to print: the label blurs); each glyph here is placed print.min_wall after the last."""
    glyphs = [_glyph(ch, z) for ch in label(c)]
    boxes = [g.BoundingBox() for g in glyphs]
    width = sum(b.xlen for b in boxes) + d.print.min_wall * (len(glyphs) - 1)
    out, left = [], x - width / 2
    lo, hi = min(b.ymin for b in boxes), max(b.ymax for b in boxes)  # on one baseline, centred on y
    for g, b in zip(glyphs, boxes):
        out.append(g.translate(cq.Vector(left - b.xmin, y - (lo + hi) / 2, 0)))
        left += b.xlen + d.print.min_wall
    return out
