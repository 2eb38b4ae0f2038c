"""Shared fixtures. Building the default design takes a few seconds, so it is built once per run."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
WHISKER = [sys.executable, "-m", "whisker.cli"]


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*WHISKER, *args], capture_output=True, text=True, cwd=cwd or ROOT, timeout=600)


@pytest.fixture(scope="session")
def default_build(tmp_path_factory) -> Path:
    """exports of the default design, built by the CLI into a temporary folder."""
    out = tmp_path_factory.mktemp("exports")
    res = run_cli("cad", "build", "--out", str(out), "-q")
    assert res.returncode == 0, res.stderr
    return out


@pytest.fixture(scope="session")
def six_build(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("exports6")
    res = run_cli("cad", "build", "--set", "whiskers.count=6", "--set", "whiskers.ring_radius=10", "--out", str(out), "-q")
    assert res.returncode == 0, res.stderr
    return out


def load_manifest(out: Path) -> dict:
    def no_nan(x):
        raise AssertionError(f"non-finite constant {x} in manifest")
    return json.loads((out / "manifest.json").read_text(), parse_constant=no_nan)


def load_part_mesh(out: Path, name: str):
    """An exported STL brought back into sensor coordinates with the manifest's transform."""
    import trimesh

    manifest = load_manifest(out)
    mesh = trimesh.load_mesh(out / manifest["parts"][name]["files"]["stl"])
    return mesh.apply_transform(np.array(manifest["parts"][name]["stl_to_design_transform"]))


def section_polygons(mesh, z: float):
    path = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
    m = np.eye(4)
    m[2, 3] = -z
    return list(path.to_2D(to_2D=m)[0].polygons_full)


def circles(polys):
    """(radius from the axis, angle deg, equivalent diameter) of each interior ring."""
    from shapely.geometry import Polygon

    out = []
    for p in polys:
        for ring in p.interiors:
            q = Polygon(ring)
            c = q.centroid
            out.append((math.hypot(c.x, c.y), math.degrees(math.atan2(c.y, c.x)) % 360, 2 * math.sqrt(q.area / math.pi)))
    return out


def peer_data() -> Path | None:
    p = os.environ.get("WHISKER_PEER_DATA")
    return Path(p) if p and Path(p).is_dir() else None
