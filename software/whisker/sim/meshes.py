"""Mesh objects of a scene: the file they name and their bounds (trimesh)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whisker.sim.scene import SceneError


def mesh_path(scene, o) -> str:
    """The object's mesh file, resolved against the scene's folder (refused when missing)."""
    p = Path(o.mesh)
    p = p if p.is_absolute() else Path(scene.base_dir) / p
    if not p.is_file():
        raise SceneError(f"object {o.name!r}: mesh file not found: {p}")
    return str(p.resolve())


def mesh_bounds(scene, o) -> np.ndarray:
    """(2, 3) bounds of the mesh in its file's units (read with trimesh)."""
    import trimesh

    try:
        m = trimesh.load_mesh(mesh_path(scene, o))
    except Exception as err:  # trimesh raises many types for unreadable files
        raise SceneError(f"object {o.name!r}: cannot read mesh {o.mesh!r} ({err})") from None
    b = np.asarray(m.bounds, dtype=float)
    if b.shape != (2, 3) or not np.all(np.isfinite(b)):
        raise SceneError(f"object {o.name!r}: mesh {o.mesh!r} has no finite bounds")
    return b
