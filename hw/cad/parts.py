"""The part catalogue: every part is a function of the design (cq_warehouse style)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cadquery as cq
import numpy as np
import trimesh

from whisker.design import Design

from whisker.cad.solids import adapter, bobbin, board_holder, coupon, cover, mold, mount, reference, ring, winding_jig


@dataclass(frozen=True)
class PartSpec:
    name: str
    build: Callable[[Design], cq.Shape]
    printable: bool
    description: str
    flip_to_print: bool = False  # printed upside down: its top face is the large flat face


PARTS: tuple[PartSpec, ...] = (
    PartSpec("mount", mount.mount, True,
             "PLA body: membrane seat, magnet pockets, LED channel, camera seat, robot mounting holes",
             flip_to_print=True),
    PartSpec("mold_base", mold.mold_base, True, "membrane mould, base: cavity, rod sockets, registration pins"),
    PartSpec("mold_lid", mold.mold_lid, True, "membrane mould, lid: rod guides, pour opening, vents"),
    PartSpec("whisker_ring", ring.whisker_ring, True, "gluing/casting jig holding the rods at the ring radius",
             flip_to_print=True),
    PartSpec("adapter", adapter.adapter, True,
             "robot adapter under the mount: the mount's screws from below, coupling screws into the flange plate"),
    PartSpec("flange_plate", adapter.flange_plate, True,
             "robot flange plate: ISO 9409-1 pattern (adapter.preset), spigot and pin below, inserts for the adapter",
             flip_to_print=True),
    PartSpec("cover", cover.cover, True, "camera cover closing the camera pocket from below (without the adapter)"),
    PartSpec("winding_jig", winding_jig.winding_jig, True,
             "coil winding arbor for a hand drill: bobbin pocket, a flag and a magnet per turn", flip_to_print=True),
    PartSpec("tolerance_coupon", coupon.tolerance_coupon, True,
             "print-tolerance coupon: rod holes and magnet pockets at print.coupon_clearances, labelled"),
    PartSpec("board_holder", board_holder.board_holder, True, "lens calibration: holds a ChArUco patch at the marker plane", flip_to_print=True),
    PartSpec("bobbin", bobbin.bobbin, False,
             "coil former, whisker 0: resin (MSLA) print, not sliced here; rod tab, core, flange"),
    PartSpec("membrane", reference.membrane, False, "cast Ecoflex membrane (reference, not printed)"),
    PartSpec("rod", reference.rod, False, "carbon-fibre whisker rod, whisker 0 (reference)"),
    PartSpec("coil", reference.coil, False, "disc coil, whisker 0 (reference)"),
    PartSpec("magnet", reference.magnet, False, "NdFeB disc magnet, whisker 0 (reference)"),
)

BY_NAME = {p.name: p for p in PARTS}


def print_transform(spec: PartSpec, shape: cq.Shape) -> np.ndarray:
    """4x4 transform from design coordinates to the printing pose: flipped if the part prints
    upside down, centred on the bed, lowest point at z = 0 (mm)."""
    flip = trimesh.transformations.rotation_matrix(np.pi, [1, 0, 0]) if spec.flip_to_print else np.eye(4)
    bb = shape.BoundingBox()
    corners = np.array([[x, y, z] for x in (bb.xmin, bb.xmax) for y in (bb.ymin, bb.ymax) for z in (bb.zmin, bb.zmax)])
    pts = trimesh.transform_points(corners, flip)
    lo, hi = pts.min(0), pts.max(0)
    move = np.eye(4)
    move[:3, 3] = [-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]]
    return np.round(move @ flip, 12)  # exact 0/1 entries keep OCC's orthogonality test happy


def print_pose(spec: PartSpec, shape: cq.Shape) -> cq.Shape:
    """The part as it lies on the printer bed (the same pose as print_transform)."""
    m = print_transform(spec, shape)
    if spec.flip_to_print:
        shape = shape.rotate(cq.Vector(0, 0, 0), cq.Vector(1, 0, 0), 180)
    return shape.translate(cq.Vector(*m[:3, 3]))
