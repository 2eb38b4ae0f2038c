"""Pictures of the build guide that are not assembly steps (docs/build.md, `make guide`): the winding
jig in use, with a bobbin in its pocket, the winding, the wire's path and the turn counters named.

The jig (whisker.cad.solids.winding_jig) turns the bobbin about its coil axis on the arbor's axis (+z): the
bobbin's tab sits in the disc's pocket, keyed, with the tab's rod side down. In sensor coordinates
the bobbin's coil axis is +x at z = coil axis height and its tab spans the tab's x range; the
picture maps (x, y, z) -> (y, z - coil axis, x - tab start + pocket floor), a proper rotation.
Units: mm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from whisker.design import Design
from whisker.files import atomic_write_bytes

from whisker.cad.solids import bobbin as bobbin_model
from whisker.cad.solids import winding_jig
from whisker.cad.verify.checks import to_mesh
from whisker.cad.pictures.preview import render

#: Mesh tolerances for the pictures (mm, rad).
TOLERANCE = (0.02, 0.2)
COLOURS = {"jig": "#c4cfbf", "bobbin": "#e8590c", "winding": "#b87333"}
WINDING_JIG_PICTURE = "winding_jig_in_use.png"


def _on_jig(d: Design, mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """A piece of the bobbin (sensor coordinates) moved into the jig's pocket."""
    B, J = bobbin_model.layout(d), winding_jig.layout(d)
    floor = J["disc"][1] - J["pocket_depth"]
    m = mesh.copy().apply_translation((-B["tab"][0], 0.0, -d.coil_axis_z))
    rot = np.eye(4)
    rot[:3, :3] = [[0, 1, 0], [0, 0, 1], [1, 0, 0]]  # (x, y, z) -> (y, z, x)
    return m.apply_transform(rot).apply_translation((0.0, 0.0, floor))


def winding_scene(d: Design) -> tuple[list[tuple[trimesh.Trimesh, str]], list[np.ndarray], list[tuple[np.ndarray, str]]]:
    """Meshes, the wire's path (spool -> winding) and the callouts of the winding picture."""
    from whisker.coil import winding

    J = winding_jig.layout(d)
    j = J["settings"]
    jig = to_mesh(winding_jig.winding_jig(d), *TOLERANCE)
    bob = _on_jig(d, to_mesh(bobbin_model.bobbin(d), *TOLERANCE))
    wound = _on_jig(d, to_mesh(bobbin_model.winding_envelope(d), *TOLERANCE))
    lo, hi = wound.bounds
    z_mid = (lo[2] + hi[2]) / 2
    r_w = (hi[0] - lo[0]) / 2
    spool = np.array([r_w, 25.0, z_mid])
    wire = np.array([spool, [r_w, 0.0, z_mid]])
    z0, z1 = J["disc"]
    turns = winding(d).turns
    labels = [
        (np.array([0.0, 0.0, hi[2] + 2.0]), f"bobbin: {turns} turns side by side"),
        (spool + [0, 0, 2.0], "wire from the spool, ~20 g tension"),
        (np.array([j.disc_diameter / 2 + j.flag_length, 0.0, z1 + 1.5]), "flag: 1 per turn (opto / microswitch)"),
        (np.array([-j.disc_diameter / 2, 0.0, z0 - 1.5]), "counter magnet below (reed switch)"),
        (np.array([0.0, -j.shank_diameter, z0 / 2]), "shank: into the drill chuck"),
        (np.array([0.0, -j.disc_diameter / 2 - 2, (z0 + z1) / 2]), "bobbin tab in the keyed pocket"),
    ]
    meshes = [(jig, COLOURS["jig"]), (bob, COLOURS["bobbin"]), (wound, COLOURS["winding"])]
    return meshes, [wire], labels


def winding_picture(d: Design, size_px: tuple[int, int] = (900, 700)) -> bytes:
    meshes, paths, labels = winding_scene(d)
    return render(meshes, "winding jig in use: a bobbin in its pocket, wound from the spool", size_px,
                  elev=20, azim=-60, paths=paths, path_color="#b87333", labels=labels)


#: The camera's view (whisker.vision.render, a synthetic frame) at rest and with every whisker retracted.
CAMERA_PICTURES = {"camera_view_rest.png": 0.0, "camera_view_retracted.png": None}


def camera_picture(d: Design, tilt_deg: float | None) -> bytes:
    """What the camera sees (synthetic frame, whisker.vision.render), each marker numbered: the camera
    looks up, so the numbers run clockwise on screen. `tilt_deg` None = the largest tilt inwards
    (whiskers.max_deflection_deg, a grasp)."""
    import io

    from PIL import Image, ImageDraw

    from whisker.vision import render as vr

    tilt = d.whiskers.max_deflection_deg if tilt_deg is None else tilt_deg
    px = vr.scene_markers(d, tilt)
    bgr = vr.render_frame(d, px)
    img = Image.fromarray(np.ascontiguousarray(bgr[..., ::-1]))
    draw = ImageDraw.Draw(img)
    centre = np.array([d.camera.width_px, d.camera.height_px]) / 2
    for i, (x, y) in enumerate(px):
        u = np.array([x, y]) - centre
        u = u / max(np.linalg.norm(u), 1e-9)
        tx, ty = np.array([x, y]) + 22 * u
        draw.text((tx - 8, ty - 6), f"w{i}", fill=(255, 255, 255))
    what = "at rest" if tilt == 0 else f"all whiskers retracted {tilt:g} deg (grasp): markers move out"
    draw.rectangle((0, 0, img.width, 24), fill=(0, 0, 0))
    draw.text((8, 6), f"camera view, {what}; numbers run clockwise (the camera looks up)", fill=(255, 255, 255))
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def write_guide_images(d: Design, out: str | Path, size_px: tuple[int, int] = (900, 700)) -> list[Path]:
    """Every guide picture that is not an assembly step or a part preview, into `out` (atomic)."""
    out = Path(out)
    paths = [atomic_write_bytes(out / WINDING_JIG_PICTURE, winding_picture(d, size_px))]
    paths += [atomic_write_bytes(out / name, camera_picture(d, tilt)) for name, tilt in CAMERA_PICTURES.items()]
    return paths


def generated(d: Design) -> set[str]:
    """Every picture (relative to docs/) that `make guide` writes: the part previews, the assembly
    steps and this module's."""
    from whisker.cad.pictures import assembly_images
    from whisker.cad.parts import PARTS
    from whisker.cad.pictures.preview import RESIN_PREVIEW

    parts = {f"images/parts/{p.name}.png" for p in PARTS if p.printable or p.name in RESIN_PREVIEW}
    steps = {f"images/assembly/{v.file_name()}" for v in assembly_images.views()}
    own = {f"images/build/{n}" for n in (WINDING_JIG_PICTURE, *CAMERA_PICTURES)}
    return parts | steps | own | {"images/parts/assembly.png"}
