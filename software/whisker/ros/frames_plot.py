"""A picture of the URDF's frames (docs/ros2.md): side view and top view, read back from the URDF text.

The URDF is parsed with the standard library's XML parser and its fixed joints composed (every
frame at zero tilt), so the picture shows what a robot description gets, not a second drawing of
the design. Lengths in mm.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np


def _matrix(xyz, rpy) -> np.ndarray:
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = Rz @ Ry @ Rx
    T[:3, 3] = xyz
    return T


def frame_poses(urdf_text: str) -> dict[str, np.ndarray]:
    """{link: 4 x 4 pose in the root link, mm} at zero joint angles."""
    root = ET.fromstring(urdf_text)
    children: dict[str, list] = {}
    links = [ln.get("name") for ln in root.findall("link")]
    child_links = set()
    for j in root.findall("joint"):
        o = j.find("origin")
        xyz = [float(v) for v in (o.get("xyz") if o is not None else "0 0 0").split()]
        rpy = [float(v) for v in (o.get("rpy") if o is not None else "0 0 0").split()]
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        children.setdefault(parent, []).append((child, _matrix(xyz, rpy)))
        child_links.add(child)
    base = next(ln for ln in links if ln not in child_links)
    poses = {base: np.eye(4)}
    todo = [base]
    while todo:
        p = todo.pop()
        for c, A in children.get(p, []):
            poses[c] = poses[p] @ A
            todo.append(c)
    for k in poses:
        poses[k] = poses[k].copy()
        poses[k][:3, 3] *= 1e3
    return poses


def cylinders(urdf_text: str) -> dict[str, tuple[float, float, float]]:
    """{link: (radius, z0, z1) mm} of the links drawn as a cylinder on their own z axis."""
    out = {}
    for ln in ET.fromstring(urdf_text).findall("link"):
        cyl = ln.find("visual/geometry/cylinder")
        if cyl is None:
            continue
        z = float(ln.find("visual/origin").get("xyz").split()[2]) * 1e3
        h = float(cyl.get("length")) * 1e3
        out[ln.get("name")] = (float(cyl.get("radius")) * 1e3, z - h / 2, z + h / 2)
    return out


def draw_frames(urdf_text: str, path, title: str = "") -> None:
    """Side (x-z) and top (x-y) views of every frame with its x (red), y (green), z (blue) axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from matplotlib.patches import Circle, Rectangle

    poses = frame_poses(urdf_text)
    cyl = {k: v for k, v in cylinders(urdf_text).items() if not k.endswith("_rod")}
    fig, axes = plt.subplots(1, 2, figsize=(11, 6.5), gridspec_kw={"width_ratios": [1, 1.2]})
    show = [k for k in poses if not k.endswith(("_rod", "flange_plate", "_adapter", "_mount"))]
    for ax, (i, j), name in ((axes[0], (0, 2), "side view (x right, z up), mm"),
                             (axes[1], (0, 1), "top view (x right, y up), mm")):
        for k in show:
            T = poses[k]
            o = T[:3, 3]
            top_view = j == 1
            if top_view and (k.endswith("_tip") or k.endswith(("flange", "sensor", "camera_optical"))):
                continue
            L = 4.0 if k.endswith("_base") else 8.0
            for col, c in zip(range(3), "rgb"):
                a = T[:3, col] * L
                ax.annotate("", xy=(o[i] + a[i], o[j] + a[j]), xytext=(o[i], o[j]),
                            arrowprops=dict(arrowstyle="->", color=c, lw=1.2))
            ax.plot(o[i], o[j], "k.", ms=4)
            label = k.split("_", 1)[1] if "_" in k else k
            if not (k.endswith("_tip") and not k.endswith("0_tip")) and not (
                    not top_view and k.endswith("_base") and not k.endswith(("0_base", "4_base"))):
                ax.text(o[i] + 1.0, o[j] + 1.0, label, fontsize=7)
        for k in poses:          # the rods at rest
            if k.endswith("_tip"):
                b = poses[k.replace("_tip", "_base")][:3, 3]
                t = poses[k][:3, 3]
                ax.plot([b[i], t[i]], [b[j], t[j]], color="0.3", lw=0.8)
        for k, (r, z0, z1) in cyl.items():       # the printed stack, in the sensor frame
            zs = poses[k][2, 3]
            if top_view:
                if k.endswith("_mount"):
                    ax.add_patch(Circle((0, 0), r, fill=False, ec="0.6", lw=0.8, ls="--"))
            else:
                ax.add_patch(Rectangle((-r, zs + z0), 2 * r, z1 - z0, fc="0.92", ec="0.6", lw=0.6, zorder=0))
                ax.text(-r - 1, zs + (z0 + z1) / 2, k.split("_", 1)[1], fontsize=7, ha="right", va="center")
        if top_view:
            lim = max([v[0] for k, v in cyl.items() if k.endswith("_mount")] or [20.0])
            ax.set_xlim(-lim - 3, lim + 3)
            ax.set_ylim(-lim - 3, lim + 3)
        else:
            lim = max(v[0] for v in cyl.values()) if cyl else 20.0
            ax.set_xlim(-lim - 22, lim + 12)
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=9)
        ax.grid(True, lw=0.3)
    fig.suptitle(title or "URDF frames (x red, y green, z blue); root: the robot's tool flange face", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
