"""The sensor's URDF (whisker.ros.urdf) loads in the ROS project's URDF parser (urdf_parser_py) and
its frames are the CAD's: the flange-to-whisker-ring offset against the built parts' manifest."""

from __future__ import annotations

import math

import numpy as np
import pytest
from urdf_parser_py.urdf import URDF

from conftest import load_manifest
from whisker.design import load_design
from whisker.design.flanges import flange
from whisker.ros.urdf import frames, joint_names, rpy_from_matrix, urdf


def _chain_z_mm(robot, root: str, tip: str) -> np.ndarray:
    """Position (mm) of `tip` in `root` at zero joint angles, composing the joints' origins."""
    T = np.eye(4)
    for name in robot.get_chain(root, tip, links=False):
        j = robot.joint_map[name]
        r, p, y = j.origin.rpy
        Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
        Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
        Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
        A = np.eye(4)
        A[:3, :3] = Rz @ Ry @ Rx
        A[:3, 3] = j.origin.xyz
        T = T @ A
    return T[:3, 3] * 1e3


def test_default_urdf_parses_with_one_joint_per_whisker():
    d = load_design(None)
    robot = URDF.from_xml_string(urdf(d))
    assert robot.get_root() == "whisker_flange"
    moving = [j for j in robot.joints if j.type != "fixed"]
    assert [j.name for j in moving] == joint_names(d) == [f"whisker_{i}" for i in range(8)]
    for j, a in zip(moving, d.whisker_angles_deg):
        assert j.limit.upper == pytest.approx(math.radians(d.whiskers.max_deflection_deg))
        # each pivot on the ring at the whisker's angle, at the membrane's mid-plane
        pos = _chain_z_mm(robot, "whisker_sensor", f"whisker_{moving.index(j)}_base")
        np.testing.assert_allclose(pos, [d.whiskers.ring_radius * math.cos(math.radians(a)),
                                         d.whiskers.ring_radius * math.sin(math.radians(a)), d.pivot_z], atol=1e-6)
        tip = _chain_z_mm(robot, f"whisker_{moving.index(j)}_base", f"whisker_{moving.index(j)}_tip")
        np.testing.assert_allclose(tip, [0, 0, d.l_u], atol=1e-6)


def test_flange_to_ring_offset_matches_the_cad_manifest(default_build):
    """The manifest's flange plate (its solid's bounding box, sensor coordinates) ends at the
    centring spigot; the robot's flange face is the spigot's depth (hw/flanges.csv) above that."""
    d = load_design(None)
    m = load_manifest(default_build)
    fl = flange(d.adapter.preset)
    face_z = m["parts"]["flange_plate"]["bbox_mm"]["min"][2] + fl.centring_depth
    ring_z = m["derived"]["pivot_z_mm"]
    robot = URDF.from_xml_string(urdf(d))
    offset = _chain_z_mm(robot, "whisker_flange", "whisker_ring")
    assert offset[2] == pytest.approx(ring_z - face_z, abs=0.01)
    assert offset[2] == pytest.approx(frames(d).flange_to_ring_mm, abs=1e-6)
    # the camera's optical centre, from the mount's manifest numbers
    cam = _chain_z_mm(robot, "whisker_flange", "whisker_camera_optical")
    assert cam[2] == pytest.approx(m["derived"]["camera_z_mm"] - face_z, abs=0.01)


def test_urdf_follows_the_design_file():
    """Another ring and whisker count: the joints and pivots move with the design (no second copy)."""
    d = load_design(None, ["whiskers.count=6", "whiskers.ring_radius=10"])
    robot = URDF.from_xml_string(urdf(d, prefix="left_"))
    assert [j.name for j in robot.joints if j.type == "revolute"] == [f"left_{i}" for i in range(6)]
    pos = _chain_z_mm(robot, "left_sensor", "left_3_base")
    np.testing.assert_allclose(np.hypot(pos[0], pos[1]), 10.0, atol=1e-6)


@pytest.mark.parametrize("rpy", [(0.3, -0.2, 1.1), (0.0, 0.0, -2.5), (-1.0, 0.7, 0.2)])
def test_rpy_round_trip(rpy):
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    np.testing.assert_allclose(rpy_from_matrix(Rz @ Ry @ Rx), rpy, atol=1e-12)


def test_without_the_extra_one_line_names_the_install():
    """rclpy missing (None in sys.modules: the import fails as if the wheels were not installed)."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['rclpy'] = None\n"
            "from whisker.cli import main; main(['ros', '--source', 'sim', '--backend', 'sim', '--duration', '1'])")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 1
    lines = res.stderr.strip().splitlines()
    assert lines == ["whisker ros needs rclpy from the [ros] extra: pip install 'whisker-array[ros]'"], res.stderr


def test_cli_writes_the_urdf_and_the_frames_picture_without_ros(tmp_path):
    from conftest import run_cli

    res = run_cli("ros", "--urdf", str(tmp_path / "s.urdf"), "--frames-png", str(tmp_path / "f.png"),
                  "--prefix", "left_", "--set", "whiskers.count=4")
    assert res.returncode == 0, res.stderr
    robot = URDF.from_xml_string((tmp_path / "s.urdf").read_text())
    assert [j.name for j in robot.joints if j.type == "revolute"] == [f"left_{i}" for i in range(4)]
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = run_cli("ros", "--urdf", "-", "--prefix", "9x")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "--prefix" in bad.stderr
