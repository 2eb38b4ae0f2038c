"""Assembly sequence check: every step of hw/assembly_sequence.toml swept along its path against
what is already in place.

A step moves rigid pieces (a magnet, the membrane, a rod, a coil, the camera board, the adapter)
from a start clear of everything to their final places along a path of straight segments. The
swept volume of a piece over a segment is the convex hull of the piece at both ends (manifold3d):
exact for convex pieces (discs, rods, boards) and a safe over-estimate for the others. A step
passes when no swept volume overlaps any part placed by an earlier step by more than
``verdict.VOLUME_EPS``; otherwise it is refused with one line naming the step, the piece and what it
runs into. Flexible parts (the LED strip) are checked only where they end up. Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import cadquery as cq
import manifold3d
import numpy as np

from whisker.design import sizing
from whisker.design import Design, DesignError
from whisker.files import read_toml
from whisker.resources import hw_dir

from whisker.cad.solids import reference
from whisker.cad.verify.verdict import VOLUME_EPS, Check, make_check, to_mesh

SEQUENCE = hw_dir() / "assembly_sequence.toml"
VARIANTS = ("robot", "bench")


@dataclass(frozen=True)
class Step:
    name: str
    parts: tuple[str, ...]
    path: tuple[tuple[str, str | float], ...]
    after: tuple[str, ...]
    variant: str = "all"
    flexible: bool = False


def load_steps(path: str | Path = SEQUENCE) -> list[Step]:
    data = read_toml(path, "assembly sequence", DesignError)
    steps = []
    for i, raw in enumerate(data.get("step", [])):
        try:
            steps.append(Step(raw["name"], tuple(raw["parts"]), tuple((s, v) for s, v in raw.get("path", [])),
                              tuple(raw.get("after", [])), raw.get("variant", "all"), bool(raw.get("flexible", False))))
        except (KeyError, TypeError, ValueError) as err:
            raise DesignError(f"assembly sequence {path}: step {i + 1} is malformed ({err})") from None
    return steps


# ---- the pieces, in their final places ---------------------------------------------------------

def _camera(d: Design) -> list[tuple[str, cq.Shape]]:
    from whisker.design.camera_boards import profile

    from whisker.cad.solids.camera_seat import board
    return list(board(d, profile(d.camera.board), sizing.mount_levels(d)["board_face"]).items())


def _adapter(d):
    from whisker.cad.solids import adapter
    return [("adapter", adapter.adapter(d)), ("flange plate", adapter.flange_plate(d))]


def _cover(d):
    from whisker.cad.solids import cover
    return [("cover", cover.cover(d))]


PIECES: dict[str, Callable[[Design], list[tuple[str, cq.Shape]]]] = {
    "magnets": lambda d: [(f"magnet {i}", reference.magnet(d, a)) for i, a in enumerate(d.whisker_angles_deg)],
    "membrane": lambda d: [("membrane", reference.membrane(d))],
    "rods": lambda d: [(f"rod {i}", reference.rod(d, a)) for i, a in enumerate(d.whisker_angles_deg)],
    # the coil as it is made: bobbin (tab, flanges) and winding, one rigid piece on its rod
    "coils": lambda d: [(f"coil {i}", reference.coil(d, a)) for i, a in enumerate(d.whisker_angles_deg)],
    "camera": _camera,
    "led_strip": lambda d: [("LED strip", reference.led_strip(d))],
    "adapter": _adapter,
    "cover": _cover,
}


#: Design parameters that decide whether each part reaches its place (named in a refusal).
PARAMETERS = {
    "magnets": ("magnet.diameter", "magnet.height", "membrane.inscribed_radius", "mount.seat_ledge"),
    "membrane": ("membrane.inscribed_radius", "print.clearance"),
    "rods": ("whiskers.ring_radius", "whiskers.rod_diameter"),
    "coils": ("coil.length", "coil.outer_diameter", "bobbin.tab", "bobbin.flange", "whiskers.ring_radius",
              "membrane.inscribed_radius", "mount.seat_ledge"),
    "camera": ("camera.board", "mount.camera_recess"),
    "led_strip": ("mount.led_strip_width", "mount.led_strip_thickness"),
    "adapter": ("adapter.preset",),
    "cover": ("cover.thickness",),
}


def distances(d: Design) -> dict[str, float]:
    """Named path lengths (mm) derived from the design."""
    w = d.magnet.diameter / 2
    reach = d.neck_radius - d.print.clearance
    # a magnet (axis radial) passes the seat's opening if its outer corners stay inside it
    inner = math.sqrt(reach ** 2 - w ** 2) - d.magnet.height if reach > w else -math.inf
    return {"travel": 150.0, "neck_to_pocket": d.cavity_radius - inner}


def _manifold(shape: cq.Shape) -> manifold3d.Manifold:
    m = to_mesh(shape, 0.02, 0.3)
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.ascontiguousarray(m.vertices, dtype=np.float32),
                                               tri_verts=np.ascontiguousarray(m.faces, dtype=np.uint32)))


def _direction(kind: str, piece: manifold3d.Manifold) -> np.ndarray:
    axes = {"+z": (0, 0, 1), "-z": (0, 0, -1), "+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0)}
    if kind in axes:
        return np.array(axes[kind], float)
    if kind in ("radial_out", "radial_in"):
        bb = np.asarray(piece.bounding_box(), float)
        c = (bb[:3] + bb[3:]) / 2
        r = math.hypot(c[0], c[1])
        if r < 1e-9:
            raise DesignError(f"a piece on the sensor axis has no radial direction ({kind})")
        v = np.array([c[0] / r, c[1] / r, 0.0])
        return v if kind == "radial_out" else -v
    raise DesignError(f"unknown path direction {kind!r}; known: {', '.join([*axes, 'radial_out', 'radial_in'])}")


def sweep(piece: manifold3d.Manifold, path, dist: dict[str, float]) -> manifold3d.Manifold:
    """The volume the piece passes through walking `path` (start -> final place)."""
    moves = []
    for kind, length in path:
        L = dist[length] if isinstance(length, str) else float(length)
        if not math.isfinite(L):
            raise DesignError(f"path segment {kind} {length}: no such path for this design")
        moves.append(_direction(kind, piece) * L)
    out = piece
    offset = np.zeros(3)
    for mv in reversed(moves):  # walk back from the final place
        a = piece.translate(tuple(-offset))
        b = piece.translate(tuple(-(offset + mv)))
        out = out + manifold3d.Manifold.batch_hull([a, b])
        offset = offset + mv
    return out


def check_sequence(d: Design, mount: cq.Shape, variant: str = "robot", steps: list[Step] | None = None) -> list[Check]:
    """One check per step of the chosen variant: nothing already in place is in the step's way."""
    if variant not in VARIANTS:
        raise DesignError(f"unknown assembly variant {variant!r}; known: {', '.join(VARIANTS)}")
    steps = load_steps() if steps is None else steps
    dist = distances(d)
    placed: list[tuple[str, manifold3d.Manifold]] = [("mount", _manifold(mount))]
    done: set[str] = set()
    out = []
    for k, step in enumerate(s for s in steps if s.variant in ("all", variant)):
        missing = [a for a in step.after if a not in done]
        if missing:
            raise DesignError(f"assembly step {step.name!r} needs {', '.join(missing)} first")
        unknown = [p for p in step.parts if p not in PIECES]
        if unknown:
            raise DesignError(f"assembly step {step.name!r}: unknown part {unknown[0]!r}; known: {', '.join(PIECES)}")
        pieces = [(label, _manifold(shape)) for part in step.parts for label, shape in PIECES[part](d)]
        worst, what = 0.0, ""
        try:
            for label, m in pieces:
                swept = m if step.flexible else sweep(m, step.path, dist)
                for name, body in placed:
                    v = (swept ^ body).volume()
                    if v > max(worst, VOLUME_EPS):
                        worst, what = v, f"{label} runs into the {name} ({v:.3g} mm^3)"
        except DesignError as err:
            worst, what = math.inf, str(err)
        params = tuple(dict.fromkeys(p for part in step.parts for p in PARAMETERS.get(part, ())))
        out.append(make_check(f"assembly step {k + 1}: {step.name}", "assembly", worst, worst <= VOLUME_EPS, "0",
                          "mm^3", params, what))
        placed += pieces
        done.add(step.name)
    return out
