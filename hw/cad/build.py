"""`whisker cad build`: every part as STL and STEP, checked, with a manifest.

Pipeline: design -> solids -> solid checks -> STL/STEP into a staging folder -> mesh checks on the
written STL files -> manifest. Only a design that passes every check is published into the output
folder (one atomic rename per file, manifest last); a refused design raises :class:`DesignRefused`
and leaves the output folder exactly as it was.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import cadquery as cq
import numpy as np
import trimesh

from whisker.design import Design
from whisker.files import atomic_write_json, drop_stale_staging, publish, staging_dir

from whisker.cad.verify import checks, mold_checks

from whisker.cad.assembly import sequence
from whisker.cad.assembly.model import export_step, sensor_assembly
from whisker.cad.buildkey import FORMATS, build_key, content_sha256, file_sha256, fix_step_timestamp
from whisker.cad.parts import PARTS, print_pose, print_transform


class DesignRefused(ValueError):
    """The design fails a geometry check; str() is one line naming the parameters."""

    def __init__(self, failed: list[checks.Check]):
        self.failed = failed
        more = f" (+{len(failed) - 1} more failed checks)" if len(failed) > 1 else ""
        super().__init__(f"design refused: {failed[0].line()}{more}")


def _bbox(shape: cq.Shape) -> dict:
    bb = shape.BoundingBox()
    lo, hi = [bb.xmin, bb.ymin, bb.zmin], [bb.xmax, bb.ymax, bb.zmax]
    return {"min": [round(v, 4) for v in lo], "max": [round(v, 4) for v in hi],
            "size": [round(b - a, 4) for a, b in zip(lo, hi)]}


def build_solids(d: Design) -> dict[str, cq.Shape]:
    return {spec.name: spec.build(d) for spec in PARTS}


def evaluate(d: Design) -> list[checks.Check]:
    """All design checks without writing files (used by the sweep): in-memory tessellation."""
    solids = build_solids(d)
    solid = checks.solid_checks(d, solids["mount"], solids["membrane"])
    if not all(c.ok for c in solid):
        return solid
    tol = (d.export.linear_tolerance, d.export.angular_tolerance)
    return solid + mesh_design_checks(d, {n: checks.to_mesh(s, *tol) for n, s in solids.items()})


def build(d: Design, out: str | Path, formats: tuple[str, ...] = FORMATS,
          progress: Callable[[str], None] | None = None) -> dict:
    """Build, check and publish every part; returns the manifest. Raises DesignRefused."""
    out = Path(out)
    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    timings: dict[str, float] = {}

    say("building solids")
    solids = build_solids(d)
    timings["solids_s"] = time.perf_counter() - t0

    say("checking collisions and fits on the solids")
    t = time.perf_counter()
    solid = checks.solid_checks(d, solids["mount"], solids["membrane"])
    timings["solid_checks_s"] = time.perf_counter() - t
    if not all(c.ok for c in solid):
        raise DesignRefused([c for c in solid if not c.ok])

    lin, ang = d.export.linear_tolerance, d.export.angular_tolerance
    drop_stale_staging(out)
    parts: dict[str, dict] = {}
    part_checks: dict[str, list[checks.Check]] = {}  # in part order, as the manifest lists them
    files: list[str] = []
    with staging_dir(out) as tmp:
        meshes: dict[str, trimesh.Trimesh] = {}
        t = time.perf_counter()
        for spec in PARTS:
            say(f"exporting {spec.name}")
            shape = solids[spec.name]
            pose = print_transform(spec, shape) if spec.printable else np.eye(4)
            placed = print_pose(spec, shape) if spec.printable else shape
            entry = {"description": spec.description, "printable": spec.printable,
                     "volume_mm3": round(shape.Volume(), 4), "bbox_mm": _bbox(shape),
                     "print_bbox_mm": _bbox(placed) if spec.printable else None,
                     "stl_to_design_transform": np.linalg.inv(pose).round(9).tolist(), "files": {}}
            if "stl" in formats:
                cq.exporters.export(cq.Workplane().add(placed), str(tmp / f"{spec.name}.stl"),
                                    tolerance=lin, angularTolerance=ang)
                entry["files"]["stl"] = f"{spec.name}.stl"
            if "step" in formats:
                cq.exporters.export(cq.Workplane().add(shape), str(tmp / f"{spec.name}.step"))
                fix_step_timestamp(tmp / f"{spec.name}.step")
                entry["files"]["step"] = f"{spec.name}.step"
            files += list(entry["files"].values())
            parts[spec.name] = entry
            if "stl" in formats:
                # Measure the mesh that was written, brought back into design coordinates.
                mesh = trimesh.load_mesh(tmp / f"{spec.name}.stl")
                meshes[spec.name] = mesh.copy().apply_transform(np.linalg.inv(pose))
                extent = tuple(mesh.extents) if spec.printable else None
                part_checks[spec.name] = checks.mesh_checks(spec.name, mesh, shape.Volume(), spec.printable, d, extent)
            else:
                meshes[spec.name] = checks.to_mesh(shape, lin, ang)
                part_checks[spec.name] = []
        timings["export_s"] = time.perf_counter() - t

        if "step" in formats:
            say("exporting assembly")
            export_step(sensor_assembly(d, solids["mount"], solids["membrane"]), str(tmp / "assembly.step"))
            fix_step_timestamp(tmp / "assembly.step")
            files.append("assembly.step")

        say("measuring the meshes")
        t = time.perf_counter()
        measured = mesh_design_checks(d, meshes)
        timings["mesh_checks_s"] = time.perf_counter() - t
        say("measuring the walls of the printed parts")
        t = time.perf_counter()
        measured += wall_checks(d, meshes)
        timings["wall_checks_s"] = time.perf_counter() - t
        say("checking the assembly sequence")
        t = time.perf_counter()
        measured += sequence.check_sequence(d, solids["mount"], "robot")
        timings["sequence_s"] = time.perf_counter() - t
        for c in solid + measured:
            part_checks.setdefault(c.part, []).append(c)
        for name, found in part_checks.items():
            parts.setdefault(name, {})["checks"] = [c.to_dict() for c in found]

        failed = [c for found in part_checks.values() for c in found if not c.ok]
        if failed:
            raise DesignRefused(failed)

        timings["total_s"] = time.perf_counter() - t0
        manifest = {
            "file_sha256": {name: file_sha256(tmp / name) for name in files},
            # what each file holds, without a STEP file's write time (tests/test_exports.py)
            "content_sha256": {name: content_sha256(tmp / name) for name in files},
            "generator": "whisker cad build",
            "build_key": build_key(d, formats),
            "design_digest": d.digest(),
            "design": d.to_dict(),
            "derived": d.derived(),
            "export": {"formats": list(formats), "linear_tolerance_mm": lin, "angular_tolerance_rad": ang},
            "parts": parts,
            "assembly": {"files": {"step": "assembly.step"}} if "step" in formats else None,
            "all_checks_passed": True,
            "timings_s": {k: round(v, 3) for k, v in timings.items()},
        }
        atomic_write_json(tmp / "manifest.json", manifest)
        old = _previous_files(out)
        say("publishing")
        publish(tmp, out, files + ["manifest.json"], stale=old, after_each=_publish_pause())
    say(f"wrote {len(files)} files to {out}")
    return manifest


def _publish_pause() -> Callable[[str], None] | None:
    """WHISKER_PUBLISH_PAUSE_S: seconds to wait after each published file, so a test can kill a
    build part-way through publishing (tests/test_cad_manifest.py). Unset in normal use."""
    import os

    pause = float(os.environ.get("WHISKER_PUBLISH_PAUSE_S", "0") or 0)
    return (lambda name: time.sleep(pause)) if pause > 0 else None


def mesh_design_checks(d: Design, meshes: dict[str, trimesh.Trimesh]) -> list[checks.Check]:
    """Part-specific checks on meshes in design coordinates."""
    return (checks.membrane_checks(meshes["membrane"], d)
            + checks.mold_checks(meshes["mold_base"], meshes["mold_lid"], d)
            + mold_checks.release_checks(meshes["mold_base"], meshes["whisker_ring"], d)
            + mold_checks.vent_checks(meshes["mold_lid"], meshes["whisker_ring"], d)
            + checks.ring_checks(meshes["whisker_ring"], d)
            + checks.mount_checks(meshes["mount"], meshes["membrane"], d))


def wall_checks(d: Design, meshes: dict[str, trimesh.Trimesh]) -> list[checks.Check]:
    """No wall thinner than the process allows between two named features of any printed part,
    measured on its mesh (whisker.cad.verify.walls); parts in parallel on two workers (joblib)."""
    from joblib import Parallel, delayed

    from whisker.cad.verify import part_features, walls

    jobs = [(name, meshes[name], feats, minw, sep, own) for name, (feats, minw, sep, own)
            in part_features.all_printed(d).items() if name in meshes]

    def params(name, own):
        base = ("bobbin.min_wall",) if name == "bobbin" else ("print.min_wall",)
        return base + (("fasteners.mount_joint", "mount.outer_radius") if own else ())

    return Parallel(n_jobs=2, prefer="threads")(
        delayed(walls.wall_check)(name, mesh, feats, minw, params(name, own), separate=sep, limits=own)
        for name, mesh, feats, minw, sep, own in jobs)


def _previous_files(out: Path) -> list[str]:
    import json

    try:
        old = json.loads((out / "manifest.json").read_text())
    except (FileNotFoundError, ValueError):
        return []
    names = [f for p in old.get("parts", {}).values() for f in p.get("files", {}).values()]
    return names + (["assembly.step"] if old.get("assembly") else [])

