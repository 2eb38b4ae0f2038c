"""Named features (the solids cut from a part, and the space around its edges) of the printed parts,
for the wall check (whisker.cad.verify.walls). Units: mm, sensor coordinates.

The mount's and the moulds' are their own named tools (mount.mount_tools, mold.base_tools,
mold.lid_tools). The ring's repeat the cutting tools of ring.py with names; tests/test_walls.py
checks that each is cut from its part and touches it, so a tool changed in one place and not the
other fails there.
"""

from __future__ import annotations

import cadquery as cq

from whisker.design import sizing
from whisker.design import Design

from whisker.cad.solids import mold, mount, ring
from whisker.cad.solids.shapes import cylinder, polar_xy
from whisker.cad.verify.walls import outside_ring, outside_slab

Features = dict[str, cq.Shape]


def mount_features(d: Design) -> Features:
    z = sizing.mount_levels(d)
    return {**mount.mount_tools(d), "outer rim": outside_ring(d.mount.outer_radius, z["bottom"], z["top"])}


def mold_base_features(d: Design) -> Features:
    return {**mold.base_tools(d), "outer rim": outside_ring(mold.outer_radius(d), -d.mold.floor, d.membrane.thickness)}


def mold_lid_features(d: Design) -> Features:
    t = d.membrane.thickness
    return {**mold.lid_tools(d), "lid edge": outside_ring(mold.outer_radius(d), t, t + d.mold.lid_thickness)}


def ring_features(d: Design) -> Features:
    rr, z = ring.radii(d), ring.levels(d)
    f: Features = {"outer rim": outside_ring(rr["outer"], z["lid_top"], z["top"]),
                   "plate top": outside_slab(z["top"], rr["outer"], below=False),
                   "tube bore": cylinder(rr["tube_inner"], z["lid_top"] - 1, z["plate_bottom"])}
    if rr["opening"] > 0:
        f["pour opening"] = cylinder(rr["opening"], z["plate_bottom"] - 1, z["top"] + 1)
    for i, a in enumerate(d.whisker_angles_deg):
        f[f"rod socket {i}"] = cylinder(d.hole(d.whiskers.rod_diameter) / 2, z["plate_bottom"] - 1,
                                        z["socket_bottom"], *polar_xy(d.whiskers.ring_radius, a))
    return f


#: Part name (whisker.cad.parts) -> its named features.
FEATURES = {"mount": mount_features, "mold_base": mold_base_features, "mold_lid": mold_lid_features,
            "whisker_ring": ring_features}


def insert_walls(d: Design) -> dict[str, dict[str, float]]:
    """Part -> {feature: thinnest wall around it, mm} for every feature that holds a heat-set insert:
    the fastener table's insert_min_wall (hw/fasteners.csv), read through fasteners.Hole.wall."""
    from whisker.design import fasteners

    from whisker.cad.solids import adapter

    out: dict[str, dict[str, float]] = {}
    f = d.fasteners
    if f.mount_joint == "insert":
        wall = d.mounting_hole_wall
        out["mount"] = {n: wall for n in mount.mount_tools(d) if n.startswith("mounting hole")}
    if f.cover_joint == "insert":
        wall = fasteners.hole(f.cover_screw, "insert").wall(d.print.min_wall)
        out.setdefault("mount", {}).update({n: wall for n in mount.mount_tools(d) if n.startswith("cover screw")})
    wall = fasteners.hole(f.mount_screw, "insert").wall(d.print.min_wall)  # the flange plate's coupling inserts
    out["flange_plate"] = {n: wall for n in adapter.plate_tools(d) if n.startswith("coupling insert")}
    return out


def all_printed(d: Design) -> dict[str, tuple[Features, float, list[str], dict[str, float]]]:
    """Every printed part's (features, thinnest wall in mm, features that must not meet any other,
    {feature: its own thinnest wall in mm}): the FDM parts at print.min_wall, the resin bobbin at
    bobbin.min_wall, the holes of heat-set inserts at the fastener table's insert wall."""
    from whisker.cad.solids import adapter, bobbin, coupon, cover, winding_jig

    own = insert_walls(d)
    out = {name: (fn(d), d.print.min_wall, [], own.get(name, {})) for name, fn in FEATURES.items()}
    out["adapter"] = ({**adapter.adapter_tools(d), **adapter.edges(d)}, d.print.min_wall, adapter.separate(d), {})
    out["flange_plate"] = ({**adapter.plate_tools(d), **adapter.plate_edges(d)}, d.print.min_wall,
                           adapter.plate_separate(d), own.get("flange_plate", {}))
    out["cover"] = ({**cover.cover_tools(d), **cover.edges(d)}, d.print.min_wall, [], {})
    out["winding_jig"] = ({**winding_jig.jig_tools(d), **winding_jig.edges(d)}, d.print.min_wall, [], {})
    out["bobbin"] = ({**bobbin.bobbin_tools(d), **bobbin.edges(d)}, d.bobbin.min_wall, [], {})
    # printed once; its engraved glyphs are features, so the plate between them keeps print.min_wall.
    # (The board holder has one 6 mm push-out hole in a pedestal of the neck's size: no wall to check.)
    out["tolerance_coupon"] = ({**coupon.coupon_tools(d), **coupon.edges(d)}, d.print.min_wall, [], {})
    return out
