"""The sensor's URDF, generated from the design: tool flange, mount, camera, whisker ring, whiskers.

Every number comes from the design model (whisker.design) and the adapter's layout
(whisker.cad.solids.adapter_layout, the numbers the CAD plates are built from), so a robot description that
includes this URDF follows any change of the design file. No ROS package is needed to generate it.

Frames (URDF: metres, radians; the sensor coordinates of hw/sensor.toml are mm, z = 0 on the
membrane's lower face, z up towards the tips):

- ``<prefix>flange``: the mating face of the flange plate, i.e. the robot's tool flange face
  (ISO 9409-1), axes parallel to the sensor's (z out of the flange, towards the tips). Attach it to
  the robot's ``tool0``/``flange`` with a fixed joint whose yaw puts the flange's positioning pin at
  ``pin_angle_deg`` (returned by :func:`frames`; the pin hole of the flange plate) of this frame's x.
- ``<prefix>sensor``: the sensor frame of every other topic (contact points, wrenches):
  the sensor axis, z = 0 on the membrane's lower face.
- ``<prefix>ring``: the whisker ring, the plane of the pivots (z = design.pivot_z, mid-membrane).
- ``<prefix>camera_optical``: the camera's optical frame (ROS REP 103 optical convention: z along the
  view, up the sensor axis; x = image right, y = image down, from whisker.vision.geometry.camera_rotation).
- ``<prefix><i>_base``: whisker i's pivot, x radially outward, z up.
- joint ``<prefix><i>`` (revolute about the base's -y): the whisker's radial tilt, rad, + = retraction
  (tip towards the centre, the direction a + coil level drives it), limited to whiskers.max_deflection_deg;
  the rod link ``<prefix><i>_rod`` and its ``<prefix><i>_tip`` (l_u above the pivot) follow it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

MM = 1e-3          # m per mm


@dataclass(frozen=True)
class Frames:
    """The levels the URDF is built from, mm in sensor coordinates (see the module docstring)."""
    flange_z: float             # the robot flange's face (the flange plate's bottom face)
    plate_top_z: float          # flange plate top = adapter bottom
    mount_bottom_z: float       # adapter top = mount bottom
    mount_top_z: float
    mount_radius: float
    adapter_radius: float
    plate_radius: float
    pivot_z: float              # the whisker ring (pivot plane)
    ring_radius: float
    camera_z: float             # the camera's optical centre
    angles_deg: tuple           # whisker angles, CCW from +x
    tip_mm: float               # l_u, pivot to tip
    rod_below_mm: float         # rod below the pivot
    rod_diameter: float
    max_tilt_deg: float
    pin_angle_deg: float | None  # the flange plate's positioning pin, deg CCW from +x (None: no pin)

    @property
    def flange_to_ring_mm(self) -> float:
        """Tool flange face to the whisker ring (pivot plane) along the sensor axis, mm."""
        return self.pivot_z - self.flange_z


def frames(design, preset: str | None = None) -> Frames:
    """The URDF's levels from the design and the adapter's layout (`preset`: adapter.preset override)."""
    from whisker.cad.solids.adapter_layout import layout
    from whisker.design import sizing

    L = layout(design, preset)
    levels = sizing.mount_levels(design)
    return Frames(flange_z=float(L["plate_bottom"]), plate_top_z=float(L["plate_top"]),
                  mount_bottom_z=float(levels["bottom"]), mount_top_z=float(levels["top"]),
                  mount_radius=float(design.mount.outer_radius), adapter_radius=float(L["radius"]),
                  plate_radius=float(L["plate_radius"]), pivot_z=float(design.pivot_z),
                  ring_radius=float(design.whiskers.ring_radius), camera_z=float(design.camera_z),
                  angles_deg=tuple(float(a) for a in design.whisker_angles_deg), tip_mm=float(design.l_u),
                  rod_below_mm=float(design.whiskers.rod_length - design.l_u),
                  rod_diameter=float(design.whiskers.rod_diameter),
                  max_tilt_deg=float(design.whiskers.max_deflection_deg),
                  pin_angle_deg=None if L["pin_angle"] is None else float(L["pin_angle"]))


def rpy_from_matrix(R) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad; R = Rz(yaw) Ry(pitch) Rx(roll)) of a 3 x 3 rotation matrix."""
    R = np.asarray(R, dtype=float)
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
    else:                                   # gimbal lock: put everything in yaw
        roll, yaw = 0.0, math.atan2(-R[0, 1], R[1, 1])
    return roll, pitch, yaw


def _f(x: float) -> str:
    return f"{x:.10g}"


def _origin(xyz_mm=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> str:
    return (f'<origin xyz="{" ".join(_f(v * MM) for v in xyz_mm)}" '
            f'rpy="{" ".join(_f(v) for v in rpy)}"/>')


def _cylinder_link(name: str, radius_mm: float, z0: float, z1: float, colour: str) -> str:
    """A link whose visual is a cylinder on its z axis from z0 to z1 (mm, in the link's frame)."""
    return (f'  <link name={quoteattr(name)}>\n'
            f'    <visual>{_origin((0, 0, (z0 + z1) / 2))}'
            f'<geometry><cylinder radius="{_f(radius_mm * MM)}" length="{_f((z1 - z0) * MM)}"/></geometry>'
            f'<material name={quoteattr(colour)}/></visual>\n'
            f'  </link>\n')


def _fixed(name: str, parent: str, child: str, xyz_mm=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> str:
    return (f'  <joint name={quoteattr(name)} type="fixed"><parent link={quoteattr(parent)}/>'
            f'<child link={quoteattr(child)}/>{_origin(xyz_mm, rpy)}</joint>\n')


def joint_names(design, prefix: str = "whisker_") -> list[str]:
    """The whisker joints, in whisker order: `<prefix><i>` (the names of the JointState topic)."""
    return [f"{prefix}{i}" for i in range(design.whiskers.count)]


def urdf(design, *, prefix: str = "whisker_", preset: str | None = None, name: str = "whisker_array") -> str:
    """The URDF (XML text) of the sensor of `design` (see the module docstring for the frames)."""
    from whisker.vision.geometry import camera_rotation

    F = frames(design, preset)
    p = prefix
    out = [f'<?xml version="1.0"?>\n<robot name={quoteattr(name)}>\n',
           '  <material name="pla"><color rgba="0.85 0.85 0.85 1"/></material>\n',
           '  <material name="carbon"><color rgba="0.1 0.1 0.1 1"/></material>\n',
           f'  <link name="{p}flange"/>\n',
           f'  <link name="{p}sensor"/>\n',
           _fixed(f"{p}flange_to_sensor", f"{p}flange", f"{p}sensor", (0, 0, -F.flange_z)),
           # the printed stack, for display (sensor coordinates; the CAD has the real solids)
           _cylinder_link(f"{p}flange_plate", F.plate_radius, F.flange_z, F.plate_top_z, "pla"),
           _fixed(f"{p}sensor_to_flange_plate", f"{p}sensor", f"{p}flange_plate"),
           _cylinder_link(f"{p}adapter", F.adapter_radius, F.plate_top_z, F.mount_bottom_z, "pla"),
           _fixed(f"{p}sensor_to_adapter", f"{p}sensor", f"{p}adapter"),
           _cylinder_link(f"{p}mount", F.mount_radius, F.mount_bottom_z, F.mount_top_z, "pla"),
           _fixed(f"{p}sensor_to_mount", f"{p}sensor", f"{p}mount"),
           f'  <link name="{p}ring"/>\n',
           _fixed(f"{p}sensor_to_ring", f"{p}sensor", f"{p}ring", (0, 0, F.pivot_z)),
           f'  <link name="{p}camera_optical"/>\n',
           _fixed(f"{p}sensor_to_camera", f"{p}sensor", f"{p}camera_optical", (0, 0, F.camera_z),
                  rpy_from_matrix(np.asarray(camera_rotation(design), dtype=float).T))]
    lim = math.radians(F.max_tilt_deg)
    for i, a in enumerate(F.angles_deg):
        ar = math.radians(a)
        base, rod, tip = f"{p}{i}_base", f"{p}{i}_rod", f"{p}{i}_tip"
        out.append(f'  <link name="{base}"/>\n')
        out.append(_fixed(f"{p}ring_to_{i}", f"{p}ring", base,
                          (F.ring_radius * math.cos(ar), F.ring_radius * math.sin(ar), 0.0), (0.0, 0.0, ar)))
        out.append(_cylinder_link(rod, F.rod_diameter / 2, -F.rod_below_mm, F.tip_mm, "carbon"))
        out.append(f'  <joint name="{p}{i}" type="revolute"><parent link="{base}"/><child link="{rod}"/>'
                   f'{_origin()}<axis xyz="0 -1 0"/>'
                   f'<limit lower="{_f(-lim)}" upper="{_f(lim)}" effort="1" velocity="100"/></joint>\n')
        out.append(f'  <link name="{tip}"/>\n')
        out.append(_fixed(f"{p}{i}_rod_to_tip", rod, tip, (0.0, 0.0, F.tip_mm)))
    out.append("</robot>\n")
    return "".join(out)
