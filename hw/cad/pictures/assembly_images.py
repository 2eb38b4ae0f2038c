"""Assembly pictures: one PNG per step of the build (issues 15 and 21), rendered from the real solids.

The steps are the two casting steps of docs/bringup.md (mould base + lid + rods through the lid;
the whisker ring on the lid, as a section) followed by every step of hw/assembly_sequence.toml, in
file order. For each step the parts already in place are drawn in neutral colours, the step's new
parts in :data:`HIGHLIGHT`, pulled back along their insertion path (the path of the sequence, with
"travel" shortened to :func:`explode_distance` so they stay in the picture), and the path from
there to the final place is drawn as a dashed line with an arrow head. Printed parts the new parts
go into (mount, mould, ring, adapter, cover) are cut open on the x-z plane (y >= 0 kept).

The solids are those of whisker.cad (parts.PARTS, sequence.PIECES), tessellated with
checks.to_mesh; the renderer is whisker.cad.pictures.preview.render. Units: mm.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import trimesh

from whisker.design import Design
from whisker.files import atomic_write_bytes

from whisker.cad.solids import reference

from whisker.cad.assembly import sequence
from whisker.cad.verify.checks import to_mesh
from whisker.cad.pictures.preview import _clip_top, render

#: Colour of the parts a step adds (orange; no neutral colour below is this saturated).
HIGHLIGHT = "#e8590c"
#: Colour of the insertion paths.
PATH_COLOR = "#1f4e79"
#: Neutral colours of the parts already in place.
NEUTRAL = {"mount": "#d8d3c4", "mold_base": "#b8c4cf", "mold_lid": "#c4cfbf", "whisker_ring": "#cfc6b0",
           "membrane": "#e8e0c8", "rod": "#404040", "coil": "#8c8278", "magnet": "#8a8f99",
           "led_strip": "#9aa7b0", "camera": "#5d7060", "adapter": "#c9c9c9", "cover": "#c9c9c9",
           "flange_plate": "#b0b0b0", "insert": "#c8a040", "screw": "#505050"}
#: Pieces drawn in their own colour even when new (hardware reads as hardware).
OWN_COLOUR = ("insert", "screw")
#: Printed parts cut open (half section) so what goes inside them is visible.
CUT = ("mount", "mold_base", "mold_lid", "whisker_ring", "adapter", "cover")
#: Mesh tolerances for the pictures (mm, rad): coarser than the export, finer than a pixel.
TOLERANCE = (0.05, 0.3)
#: Rods are cut at this height above the highest other part in a sensor step (the 63 mm rods
#: would make the sensor tiny in the picture); the casting steps show them whole.
ROD_VIEW_ABOVE = 12.0


@dataclass(frozen=True)
class View:
    """One picture: `placed` parts in neutral colours, `new` parts moved along `path` to their place."""
    name: str                     # short name for the file: <slug>.png
    title: str                    # the step's name as the sequence or the guide says it
    placed: tuple[str, ...]       # part names (sequence.PIECES keys or casting part names)
    new: tuple[str, ...]
    path: tuple[tuple[str, str | float], ...]
    flexible: bool = False
    casting: bool = False
    variant: str = "all"
    staggered: bool = False       # the new parts go in one after the other: drawn 1x, 2x, ... as far out
    after: tuple[str, ...] = ()   # steps that must be done first (the sequence's `after`)

    def file_name(self, index: int = 0) -> str:
        """The picture's file, named for the step and not numbered: docs/build.md is the one numbering
        of the build (`index` is kept for callers that pass it)."""
        return f"{slug(self.name)}.png"


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


CASTING = (
    View("mould", "casting 1: mould lid on the base, a rod through every lid guide into its socket",
         ("mold_base",), ("mold_lid", "cast_rods"), (("-z", "travel"),), casting=True, staggered=True),
    View("casting with the ring jig", "casting 2: whisker ring on the lid over the rod tips (section)",
         ("mold_base", "mold_lid", "cast_rods"), ("whisker_ring",), (("-z", "travel"),), casting=True,
         after=("mould",)),
)


def views(steps: list[sequence.Step] | None = None) -> list[View]:
    """The casting views, then one view per step of the sequence (every variant, in file order).

    A step's placed parts are the mount and the parts of every earlier step of its variant chain
    ("all" steps, plus the earlier steps of its own variant)."""
    steps = sequence.load_steps() if steps is None else steps
    out = list(CASTING)
    for k, step in enumerate(steps):
        earlier = [p for s in steps[:k] if s.variant in ("all", step.variant) for p in s.parts]
        out.append(View(step.name, step.name, ("mount", *earlier), step.parts, step.path, step.flexible,
                        variant=step.variant, after=step.after))
    return out


#: How the sequence's path directions read in the guide.
DIRECTION_WORDS = {"-z": "down", "+z": "up", "+x": "along +x", "-x": "along -x", "+y": "along +y",
                   "-y": "along -y", "radial_out": "radially out", "radial_in": "radially in"}
PART_WORDS = {"mold_base": "mould base", "mold_lid": "mould lid", "cast_rods": "rods", "whisker_ring": "whisker ring",
              "led_strip": "LED strip", "camera": "camera board", "insert": "heat-set inserts",
              "screw": "screws (ISO 4762)", "adapter": "adapter + flange plate (on the robot first)"}
TABLE_BEGIN, TABLE_END = "<!-- BEGIN SEQUENCE TABLE (make assembly-images) -->", "<!-- END SEQUENCE TABLE -->"


def path_text(view: View, d: Design) -> str:
    """The insertion path in words, with the lengths the design gives (mm)."""
    if view.flexible:
        return "bent into place"
    dist = sequence.distances(d)
    words = []
    for kind, length in view.path:
        how = DIRECTION_WORDS.get(kind, kind)
        if length == "travel":
            words.append(f"{how}, from clear of everything")
        else:
            L = dist[length] if isinstance(length, str) else float(length)
            words.append(f"{how} {L:.1f} mm" + (f" ({length})" if isinstance(length, str) else ""))
    return ", then ".join(words)


def sequence_table(d: Design, image_dir: str = "images/assembly") -> str:
    """The Markdown table of docs/assembly.md: one row per view, from the sequence data."""
    rows = ["| step | new parts | path | first | variant | picture |", "| --- | --- | --- | --- | --- | --- |"]
    for i, v in enumerate(views(), start=1):
        parts = ", ".join(PART_WORDS.get(p, p) for p in v.new)
        first = "; ".join(v.after) or "-"
        src = f"{image_dir}/{v.file_name(i)}"
        img = f'<a href="{src}"><img src="{src}" alt="{v.name}" width="260"></a>'
        rows.append(f"| {v.title} | {parts} | {path_text(v, d)} | {first} | {v.variant} | {img} |")
    return "\n".join(rows)


def update_page(page: Path, d: Design) -> bool:
    """Replace the table between TABLE_BEGIN and TABLE_END in `page` (atomically); True if it changed."""
    from whisker.files import atomic_write_text

    text = Path(page).read_text()
    head, sep, rest = text.partition(TABLE_BEGIN)
    _, sep2, tail = rest.partition(TABLE_END)
    if not (sep and sep2):
        raise ValueError(f"{page}: no {TABLE_BEGIN} ... {TABLE_END} block to fill")
    new = f"{head}{TABLE_BEGIN}\n{sequence_table(d)}\n{TABLE_END}{tail}"
    if new != text:
        atomic_write_text(page, new)
    return new != text


def explode_distance(d: Design) -> float:
    """How far a part that comes from "travel" away is drawn from its place: the mount's outer
    radius (mm), enough to clear it in the picture without making the sensor small."""
    return float(d.mount.outer_radius)


def _screw(size: str, length: float, head_z: float, x: float, y: float, down: bool) -> trimesh.Trimesh:
    """An ISO 4762 screw (head and shank cylinders, hw/fasteners.csv) whose head's inner face is at
    head_z, the shank going up (down=False) or down from there (mm)."""
    from whisker.design import fasteners

    f = fasteners.fastener(size)
    s = -1.0 if down else 1.0
    head = trimesh.creation.cylinder(f.head_diameter / 2, f.head_height, sections=24)
    head.apply_translation((x, y, head_z - s * f.head_height / 2))
    shank = trimesh.creation.cylinder(f.nominal / 2, length, sections=16)
    shank.apply_translation((x, y, head_z + s * length / 2))
    return trimesh.util.concatenate([head, shank])


def _hardware(d: Design, part: str) -> list[tuple[str, trimesh.Trimesh]]:
    """The screws and heat-set inserts of a part, drawn in place (their sizes from hw/fasteners.csv)."""
    from whisker.design import fasteners, sizing

    from whisker.cad.solids import adapter, cover
    from whisker.cad.solids.shapes import polar_xy

    out: list[tuple[str, trimesh.Trimesh]] = []
    f = d.fasteners
    if part == "mount" and f.mount_joint == "insert":
        ins = fasteners.fastener(f.mount_screw)
        z0 = sizing.mount_levels(d)["bottom"]
        for a in sizing.mounting_hole_angles(d):
            x, y = polar_xy(d.mount.mounting_bolt_radius, a)
            m = trimesh.creation.cylinder(ins.insert_od / 2, ins.insert_length, sections=24)
            out.append(("insert", m.apply_translation((x, y, z0 + ins.insert_length / 2))))
    if part == "adapter":
        L = adapter.layout(d)
        head = L["sensor"].head_height
        for j in adapter.joints(d)[:2]:
            length, _ = fasteners.screw_length(j.size, j.kind, j.clamp)
            if j.name == "mount to adapter":  # from below, heads in the adapter's counterbores
                for a in sizing.mounting_hole_angles(d):
                    out.append(("screw", _screw(j.size, length, L["bottom"] + 0.5 + head,
                                                *polar_xy(d.mount.mounting_bolt_radius, a), down=False)))
            else:  # coupling screws from above into the flange plate's inserts
                for a in L["coupling_angles"]:
                    out.append(("screw", _screw(j.size, length, L["top"] - 0.5 - head,
                                                *polar_xy(L["coupling_radius"], a), down=True)))
    if part == "cover":
        L = cover.layout(d)
        j = cover.joints(d)[0]
        length, _ = fasteners.screw_length(j.size, j.kind, j.clamp)
        for x, y in L["screws"]:
            out.append(("screw", _screw(j.size, length, L["bottom"] + 0.5 + L["screw"].head_height, x, y, down=False)))
    return out


def _pieces(d: Design, part: str) -> list[tuple[str, trimesh.Trimesh]]:
    """(colour key, mesh in sensor coordinates) of every piece of one part, with its screws and inserts."""
    if part in ("mount", "mold_base", "mold_lid", "whisker_ring"):
        from whisker.cad.parts import BY_NAME
        return [(part, to_mesh(BY_NAME[part].build(d), *TOLERANCE)), *_hardware(d, part)]
    if part == "cast_rods":
        return [("rod", to_mesh(reference.rod(d, a), *TOLERANCE)) for a in d.whisker_angles_deg]
    key = {"magnets": "magnet", "rods": "rod", "coils": "coil"}.get(part, part)
    return ([(key if label != "flange plate" else "flange_plate", to_mesh(shape, *TOLERANCE))
             for label, shape in sequence.PIECES[part](d)] + _hardware(d, part))


def _moves(piece: trimesh.Trimesh, path, dist: dict[str, float]) -> list[np.ndarray]:
    """The path's segments as vectors (mm), start -> final place, for this piece."""
    import manifold3d

    m = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.ascontiguousarray(piece.vertices, dtype=np.float32),
                                            tri_verts=np.ascontiguousarray(piece.faces, dtype=np.uint32)))
    return [sequence._direction(kind, m) * (dist[L] if isinstance(L, str) else float(L)) for kind, L in path]


def scene(d: Design, view: View, cache: dict | None = None
          ) -> tuple[list[tuple[trimesh.Trimesh, str]], list[np.ndarray]]:
    """Meshes with colours and the insertion paths (polylines, N x 3, start -> final place) of one view."""
    items, paths, _ = labelled_scene(d, view, cache)
    return items, paths


def labelled_scene(d: Design, view: View, cache: dict | None = None
                   ) -> tuple[list[tuple[trimesh.Trimesh, str]], list[np.ndarray], list[tuple[np.ndarray, str]]]:
    """:func:`scene` and its callouts (point, text): every part named where it is drawn, and in the
    sensor steps the whisker numbers, +x and, in the magnets' step, the pole facing the centre."""
    cache = {} if cache is None else cache

    def pieces(part):
        if part not in cache:
            cache[part] = _pieces(d, part)
        return cache[part]

    dist = dict(sequence.distances(d), travel=explode_distance(d))
    items: list[tuple[trimesh.Trimesh, str, str]] = []  # mesh, colour, part
    for part in view.placed:
        for key, mesh in pieces(part):
            items.append((_half(mesh) if part in CUT else mesh, NEUTRAL[key], key if key in OWN_COLOUR else part))
    paths: list[np.ndarray] = []
    shifted: dict[str, np.ndarray] = {}  # how far each new part is drawn from its place (mm)
    seen: set[tuple[float, float, bool]] = set()
    for depth, part in enumerate(view.new):
        for key, mesh in pieces(part):
            moves = _moves(mesh, view.path, dist) if view.path and not view.flexible else []
            if view.staggered:  # the casting rods go in after the lid: drawn farther out
                moves = [mv * (1 + depth) for mv in moves]
            total = np.sum(moves, axis=0) if moves else np.zeros(3)
            shown = mesh.copy().apply_translation(-total)
            own = key in OWN_COLOUR
            items.append((_half(shown) if part in CUT else shown, NEUTRAL[key] if own else HIGHLIGHT, key if own else part))
            shifted.setdefault(part, total)
            if moves:
                # the arrow ends on the piece's leading face, where it meets its place
                u = moves[-1] / max(np.linalg.norm(moves[-1]), 1e-9)
                c = mesh.bounds.mean(axis=0) + mesh.extents / 2 * u
                key_xy = (round(c[0], 0), round(c[1], 0), part == view.new[0])
                if key_xy in seen:  # the rods and coils of one whisker share one arrow
                    continue
                seen.add(key_xy)
                pts = [c - total]
                for mv in moves:
                    pts.append(pts[-1] + mv)
                paths.append(np.array(pts))
    items = [it for it in items if len(it[0].faces)]  # a half section of a piece on the -y side is empty
    top = max(m.bounds[1, 2] for m, _, part in items if part not in ("rods", "cast_rods"))
    if not view.casting:
        top += ROD_VIEW_ABOVE
        items = [(_clip_top(m, top), c, part) for m, c, part in items]
        paths = [np.clip(p, None, [np.inf, np.inf, top]) for p in paths]
    labels = _callouts(d, view, items, shifted, top)
    return [(m, c) for m, c, _ in items if len(m.faces)], paths, labels


def _callouts(d: Design, view: View, items, shifted: dict[str, np.ndarray], top: float
              ) -> list[tuple[np.ndarray, str]]:
    """(point, text) callouts of one view (mm, sensor coordinates)."""
    out: list[tuple[np.ndarray, str]] = []
    named: set[str] = set()
    # seen from below (camera, adapter, cover): name only what the step is about, no whisker marks
    below = any(kind == "+z" for kind, _ in view.path)
    keep = set(view.new) | {"mount", "camera", "insert", "screw"} if below else None
    for mesh, _, part in items:  # one name per part, at the top of its first drawn piece
        if part in named or not len(mesh.faces) or (keep is not None and part not in keep):
            continue
        named.add(part)
        lo, hi = mesh.bounds
        where = np.array([(lo[0] + hi[0]) / 2, max(hi[1], 0.0), hi[2]])
        if part in ("mount", "mold_base"):  # big parts: name them at their outer rim
            where = np.array([hi[0], 0.0, (lo[2] + hi[2]) / 2])
        out.append((where, PART_WORDS.get(part, part) + (" (new)" if part in view.new else "")))
    if below:
        return out
    z_mark = top if view.casting else d.membrane.thickness + 2.0
    for i, a in enumerate(d.whisker_angles_deg):  # whisker numbers, counter-clockwise from above
        r = d.whiskers.ring_radius + 3.0
        out.append((np.array([r * np.cos(np.radians(a)), r * np.sin(np.radians(a)), z_mark]), f"w{i}"))
    out.append((np.array([d.mount.outer_radius + 8.0, 0.0, z_mark]), "+x ->"))
    if "magnets" in view.new:
        from whisker.design import sizing
        z = sizing.mount_levels(d)["pocket"] - np.asarray(shifted.get("magnets", np.zeros(3)))[2]
        for a in d.whisker_angles_deg[:1]:
            r = d.cavity_radius - 1.5
            out.append((np.array([r * np.cos(np.radians(a)), r * np.sin(np.radians(a)), z]),
                        "N faces the centre\n(every magnet)"))
    return out


def _half(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh on the y >= 0 side of the x-z plane, capped (a half section)."""
    return mesh.slice_plane([0, 0, 0], [0, 1, 0], cap=True)


def render_view(d: Design, view: View, size_px: tuple[int, int] = (900, 700), cache: dict | None = None) -> bytes:
    """PNG bytes of one view."""
    items, paths, labels = labelled_scene(d, view, cache)
    how = "bent into place, shown in place" if view.flexible else "orange: new parts, moved back along their path"
    # From below for the parts that come up from below (camera, adapter, cover).
    up = any(kind == "+z" for kind, _ in view.path)
    png = render(items, f"{view.title}\n({how})", size_px, elev=-22 if up else 22, azim=-70,
                 paths=paths, path_color=PATH_COLOR, labels=labels)
    return _palette(png)


def _palette(png: bytes, colours: int = 128) -> bytes:
    """The PNG with an adaptive palette (Pillow): a third of the size, no visible change."""
    import io

    from PIL import Image

    img = Image.open(io.BytesIO(png)).convert("RGB").quantize(colours, method=Image.Quantize.MEDIANCUT)
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def write_assembly_images(d: Design, out: Path, size_px: tuple[int, int] = (900, 700),
                          only: Callable[[int, View], bool] | None = None,
                          progress: Callable[[str], None] | None = None) -> list[Path]:
    """One PNG per view into `out` (<name>.png), each written atomically."""
    out = Path(out)
    say = progress or (lambda msg: None)
    cache: dict = {}
    written = []
    for i, view in enumerate(views(), start=1):
        if only is not None and not only(i, view):
            continue
        path = atomic_write_bytes(out / view.file_name(i), render_view(d, view, size_px, cache))
        written.append(path)
        say(str(path))
    return written
