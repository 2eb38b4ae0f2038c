"""Preview images (PNG) of the exported parts and of the assembled sensor, rendered headless.

Rendering: matplotlib's Poly3DCollection (Agg backend) with flat Lambert shading from one light,
all faces of an image in ONE collection so matplotlib depth-sorts them face by face (painter's
algorithm: good for these convex-ish parts, approximate where faces interpenetrate). The meshes are
the exported STL files, so an image shows exactly what is printed. Printable parts are drawn in
their printing pose on a bed outline; the assembly is drawn in sensor coordinates with the mount
cut open along the x-z plane so the coils, magnets and membrane inside are visible.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path
from typing import Callable

import numpy as np
import trimesh

from whisker.design import Design
from whisker.files import atomic_write_bytes

LIGHT = np.array([0.4, -0.5, 0.77])
COLORS = {"mount": "#d8d3c4", "mold_base": "#8fb3d9", "mold_lid": "#a9c9a4", "whisker_ring": "#e0b36a",
          "tolerance_coupon": "#d99a9a", "membrane": "#e8e0c8", "rod": "#303030", "coil": "#b5651d",
          "magnet": "#8a8f99"}


# Faces are split until no edge is longer than the view's size / FINENESS (depth-sorting quality).
FINENESS = 45.0


def fine(mesh: trimesh.Trimesh, max_edge: float) -> trimesh.Trimesh:
    """The mesh with every edge at most max_edge long (mm), face normals kept."""
    v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=max_edge, max_iter=12)
    return trimesh.Trimesh(v, f, process=False)


def shade(mesh: trimesh.Trimesh, color: str, ambient: float = 0.35) -> np.ndarray:
    """RGBA per face: ambient + diffuse Lambert term from LIGHT (unit-less, 0..1)."""
    from matplotlib.colors import to_rgb

    light = LIGHT / np.linalg.norm(LIGHT)
    lambert = np.clip(mesh.face_normals @ light, 0.0, 1.0)
    k = ambient + (1 - ambient) * lambert
    rgb = np.clip(np.asarray(to_rgb(color))[None, :] * k[:, None], 0, 1)
    return np.column_stack([rgb, np.ones(len(rgb))])


def render(meshes: list[tuple[trimesh.Trimesh, str]], title: str, size_px: tuple[int, int] = (900, 700),
           elev: float = 28.0, azim: float = -58.0, bed: tuple[float, float] | None = None,
           paths: list[np.ndarray] | None = None, path_color: str = "#1f4e79",
           labels: list[tuple[np.ndarray, str]] | None = None) -> bytes:
    """PNG bytes of the meshes (each with a colour) seen from (elev, azim) in degrees.

    `paths`: polylines (N x 3, mm) drawn dashed over the meshes with an arrow head at their end
    (assembly pictures: where a part goes). `labels`: (point, text) callouts drawn over everything,
    the text in a white box at the point (part names, whisker numbers, +x, magnet poles)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    paths = [np.asarray(p, float) for p in paths or [] if len(p) > 1]
    labels = [(np.asarray(p, float), t) for p, t in labels or []]
    lo = np.min([m.bounds[0] for m, _ in meshes] + [p.min(0) for p in paths] + [p for p, _ in labels], axis=0)
    hi = np.max([m.bounds[1] for m, _ in meshes] + [p.max(0) for p in paths] + [p for p, _ in labels], axis=0)
    # Painter's algorithm sorts whole faces: long faces sort wrongly, so split them to a fine size.
    meshes = [(fine(m, max(hi - lo) / FINENESS), c) for m, c in meshes]
    tris = np.concatenate([m.triangles for m, _ in meshes])
    cols = np.concatenate([shade(m, c) for m, c in meshes])
    dpi = 100
    fig = plt.figure(figsize=(size_px[0] / dpi, size_px[1] / dpi), dpi=dpi)
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(tris, facecolors=cols, edgecolors=cols, linewidths=0.1))
    if paths:  # on top of the meshes (mplot3d would sort a line as one object among the faces)
        ax.computed_zorder = False
        for p in paths:
            ax.plot(*p.T, color=path_color, lw=1.4, ls="--", zorder=10)
            u = p[-1] - p[-2]
            u = u / max(np.linalg.norm(u), 1e-9) * 0.05 * max(hi - lo)  # a head 5 % of the view long
            ax.quiver(*(p[-1] - u), *u, color=path_color, lw=1.6, arrow_length_ratio=0.9, zorder=11)
    if labels:  # on top of the meshes and the paths
        ax.computed_zorder = False
        for p, text in labels:
            ax.text(*p, text, fontsize=8, zorder=20, ha="center", va="center",
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="#555555", lw=0.5, alpha=0.85))
    if bed is not None:  # a square of bed around the part, not the whole bed
        pad = 0.15 * max(hi[:2] - lo[:2]) + 2
        bx = [lo[0] - pad, hi[0] + pad, hi[0] + pad, lo[0] - pad, lo[0] - pad]
        by = [lo[1] - pad, lo[1] - pad, hi[1] + pad, hi[1] + pad, lo[1] - pad]
        ax.plot(bx, by, [lo[2]] * 5, color="#777777", lw=0.8)
        lo[:2], hi[:2] = lo[:2] - pad, hi[:2] + pad
    centre, half = (lo + hi) / 2, max(hi - lo) / 2
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.35)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    ax.set_title(title, fontsize=11)
    fig.subplots_adjust(0, 0, 1, 0.94)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()


CUT_OFFSET_MM = 1e-4  # mm, where the mount is cut open for the assembly picture


def _load(out: Path, manifest: dict, name: str, to_design: bool) -> trimesh.Trimesh:
    part = manifest["parts"][name]
    mesh = trimesh.load_mesh(out / part["files"]["stl"])
    if to_design:
        mesh.apply_transform(np.array(part["stl_to_design_transform"]))
    return mesh


def assembly_meshes(d: Design, out: Path, manifest: dict) -> list[tuple[trimesh.Trimesh, str]]:
    """Mount (cut open on the x-z plane, y > 0 kept), membrane, and every whisker's rod, coil and
    magnet, copied from whisker 0's reference parts by rotating about z (sensor coordinates)."""
    mount = _load(out, manifest, "mount", True)
    # 0.1 um off the x-z plane: features centred on it (cable exits, lead holes) put mesh vertices exactly
    # on the plane, and trimesh's cap then leaves the cut mesh open.
    cut = mount.slice_plane([0, CUT_OFFSET_MM, 0], [0, 1, 0], cap=True)
    items = [(cut, COLORS["mount"]), (_load(out, manifest, "membrane", True), COLORS["membrane"])]
    a0 = d.whisker_angles_deg[0]
    for name in ("rod", "coil", "magnet"):
        ref = _load(out, manifest, name, True)
        for a in d.whisker_angles_deg:
            r = trimesh.transformations.rotation_matrix(math.radians(a - a0), [0, 0, 1])
            items.append((ref.copy().apply_transform(r), COLORS[name]))
    return items


#: Parts printed in resin, not FDM (no print pose in the manifest), shown as modelled: the build guide
#: names their picture.
RESIN_PREVIEW = ("bobbin",)


def write_previews(d: Design, out: Path, images: Path, size_px: tuple[int, int] = (900, 700),
                   progress: Callable[[str], None] | None = None) -> list[Path]:
    """One PNG per printable part (``<part>.png``) and ``assembly.png`` into ``images``."""
    out, images = Path(out), Path(images)
    manifest = json.loads((out / "manifest.json").read_text())
    say = progress or (lambda name: None)
    paths = []
    for name, part in manifest["parts"].items():
        if not part.get("printable") and name not in RESIN_PREVIEW:
            continue
        mesh = _load(out, manifest, name, False)
        x, y, z = mesh.extents
        title = (f"{name} ({x:.1f} x {y:.1f} x {z:.1f} mm, resin print, docs/build.md)" if name in RESIN_PREVIEW
                 else f"{name} ({x:.0f} x {y:.0f} x {z:.0f} mm, as printed)")
        png = render([(mesh, COLORS.get(name, "#cccccc"))], title, size_px, bed=(d.print.bed_x, d.print.bed_y))
        paths.append(atomic_write_bytes(images / f"{name}.png", png))
        say(name)
    title = (f"assembly: {d.whiskers.count} whiskers on a {d.whiskers.ring_radius:g} mm ring "
             f"(mount cut open; rods shortened to 20 mm in view)")
    items = assembly_meshes(d, out, manifest)
    items = [(_clip_top(m, 20.0), c) for m, c in items]
    paths.append(atomic_write_bytes(images / "assembly.png", render(items, title, size_px, elev=18, azim=-70)))
    say("assembly")
    return paths


def _clip_top(mesh: trimesh.Trimesh, z_max: float) -> trimesh.Trimesh:
    """The mesh below z_max (the 63 mm rods would make the sensor tiny in the picture)."""
    if mesh.bounds[1, 2] <= z_max:
        return mesh
    return mesh.slice_plane([0, 0, z_max], [0, 0, -1], cap=True)
