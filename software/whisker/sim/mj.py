"""The contact effect: MuJoCo model of the sensor, its whiskers, the table and the objects.

Built only when the plan has ``contact`` (objects within reach, tips on the table, or forced).
Units inside MuJoCo are SI (m, kg, s); the scene's mm and g are converted here.

- The sensor rides on an "arm" of three slides and a yaw hinge whose pose and velocity are set to the
  scene's path (the UR16e's prescribed motion; a mocap body would move with zero velocity, so
  friction would not see the lift).
- Each whisker is a rigid body on two hinges at its pivot (radial tilt about -t, then tangential
  about -r: the same universal joint as whisker.coil.kinematics), with the membrane as joint
  stiffness/damping, the inertia of :class:`~whisker.coil.kinematics.WhiskerBody` given explicitly
  (so both models carry the same mass data), a hard stop as the joint range, and geoms: a capsule
  rod (``contact.rod_friction``) and a sand-coated tip capsule over ``contact.tip_coating`` mm.
  Whiskers do not collide with each other (in the paper they cross in the centre when all retract
  without an object).
- Objects are free bodies with their mass (g) and friction; the table is a plane at z = 0.
- Which friction a contact uses: a coefficient belongs to a pair of surfaces, but MuJoCo combines two
  geoms by taking the larger value unless their ``priority`` differs, when the higher one's parameters
  are used. Priorities make each pair use its own value: the table, the membrane and the bare rods
  (2) use theirs against anything (the smooth carbon rod slides on every object, the paper's
  "slippage between the whisker rods and the objects"); an object (1) uses its ``friction``, its
  coefficient against the sand-coated tips (default ``[mechanics] tip_friction``), when a tip (0)
  touches it. Without this, an object's tip-pair value would also apply along the bare rods.
- The coil torque (the Drive's torque at the current tilt) is a MuJoCo affine actuator on each
  whisker's radial hinge, re-linearised about the tilt every ``contact.chunk`` steps; gravity is
  MuJoCo's.

Reference: MuJoCo XML reference (hinge stiffness/damping/range, geom friction, priority and
contype/conaffinity, general actuators) https://mujoco.readthedocs.io/en/stable/XMLreference.html
"""

from __future__ import annotations

import math

import numpy as np

from whisker.sim.drive import Drive
from whisker.sim.effects.plan import CONTACT_MODELS
from whisker.sim.meshes import mesh_bounds, mesh_path
from whisker.sim.result import SimulationError
from whisker.sim.scene import SceneError
from whisker.sim.drive import pose_at, poses_table

MM = 1e-3


def sensor_frame(scene, design, pose) -> tuple[np.ndarray, np.ndarray]:
    """(arm joint values [x m, y m, z m, yaw rad], facing quaternion wxyz) for a path pose.

    The arm carries the sensor: three slides and a yaw hinge, set every step to the path's pose and
    velocity (a mocap body would teleport with zero velocity, and friction would not see the lift).
    """
    x, y, h, yaw = pose
    z_tip = design.pivot_z + design.l_u
    if scene.sensor.facing == "down":
        q = np.array([0.0, 1.0, 0.0, 0.0])       # 180 deg about x: whiskers point down
        z = h + z_tip
    else:
        q = np.array([1.0, 0.0, 0.0, 0.0])
        z = h - z_tip
    return np.array([x * MM, y * MM, z * MM, math.radians(yaw)]), q


def _qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _f(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.atleast_1d(v))


def _fr(scene, mu: float) -> str:
    """MuJoCo's friction triplet (sliding, torsional m, rolling m) for Coulomb coefficient `mu`.

    Torsional: (2/3) mu a for a disc of radius a = ``contact.patch_radius`` under uniform pressure
    (the friction torque of a flat circular contact, e.g. Johnson, Contact Mechanics, sec. 7.3 /
    any text on pivot friction). Rolling: 0.0001 m, MuJoCo's default (used only with condim 6).
    Which geom's triplet a contact uses is set by the geoms' ``priority`` (module docstring).
    """
    return f"{mu:g} {2.0 / 3.0 * mu * scene.contact.patch_radius * MM:.9g} 0.0001"


def build_mjcf(scene, design, body) -> str:
    """The MJCF XML of the scene (SI units)."""
    c = scene.contact
    n = design.whiskers.count
    pos0, q0 = sensor_frame(scene, design, pose_at(scene, 0.0))
    J_com = body.inertia_kgm2 - body.mass_kg * body.com_m ** 2
    J_ax = max(0.5 * body.rod_mass_kg * body.rod_radius_m ** 2
               + 0.5 * body.coil_mass_kg * (design.coil.outer_diameter / 2 * MM) ** 2, 1e-12)
    stop = math.degrees(body.stop_rad)
    mu_tip = design.mechanics.tip_friction
    coat = min(c.tip_coating, design.l_u) * MM
    r = body.rod_radius_m
    meshes = [o for o in scene.objects if o.shape == "mesh"]
    out = [f'<mujoco model="whisker-scene">',
           '<compiler angle="degree" inertiafromgeom="auto"/>',
           f'<option timestep="{scene.scene.timestep:.9g}" integrator="{c.integrator}" cone="{c.cone}" '
           f'impratio="{c.impratio:g}" gravity="0 0 -9.81"><flag energy="enable"/></option>',
           f'<default><geom condim="{c.condim}" solref="{c.solref_timeconst:.9g} 1"/></default>']
    if meshes:
        out.append("<asset>")
        for o in meshes:
            k = o.size[0] * MM
            out.append(f'<mesh name="mesh:{o.name}" file="{mesh_path(scene, o)}" scale="{k:.9g} {k:.9g} {k:.9g}"/>')
        out.append("</asset>")
    out.append('<worldbody>')
    if scene.table.enabled:
        out.append(f'<geom name="table" type="plane" size="1 1 0.01" friction="{_fr(scene, scene.table.friction)}" '
                   'contype="1" conaffinity="3" priority="2"/>')
    out.append('<body name="arm" gravcomp="1"><inertial pos="0 0 0" mass="100" diaginertia="1 1 1"/>'
               '<joint name="ax" type="slide" axis="1 0 0"/><joint name="ay" type="slide" axis="0 1 0"/>'
               '<joint name="az" type="slide" axis="0 0 1"/><joint name="ayaw" type="hinge" axis="0 0 1"/>')
    out.append(f'<body name="sensor" quat="{_f(q0)}">')
    # the membrane face: objects cannot pass through the sensor
    out.append(f'<geom name="membrane" type="cylinder" size="{design.membrane.inscribed_radius * MM:.9g} '
               f'{design.membrane.thickness / 2 * MM:.9g}" pos="0 0 {design.pivot_z * MM:.9g}" '
               f'contype="2" conaffinity="0" friction="{_fr(scene, 0.5)}" mass="0" priority="2"/>')
    for i, a in enumerate(design.whisker_angles_deg):
        ar = math.radians(a)
        cx, cy = math.cos(ar), math.sin(ar)
        p = np.array([design.whiskers.ring_radius * cx, design.whiskers.ring_radius * cy, design.pivot_z]) * MM
        out.append(f'<body name="w{i}" pos="{_f(p)}">')
        out.append(f'<inertial pos="0 0 {body.com_m:.9g}" mass="{body.mass_kg:.9g}" '
                   f'diaginertia="{J_com:.9g} {J_com:.9g} {J_ax:.9g}"/>')
        out.append(f'<joint name="r{i}" type="hinge" axis="{_f([cy, -cx, 0])}" stiffness="{body.stiffness:.9g}" solreflimit="{2 * scene.scene.timestep:.9g} 1" '
                   f'damping="{body.damping:.9g}" range="{-stop:.9g} {stop:.9g}" limited="true"/>')
        out.append(f'<joint name="t{i}" type="hinge" axis="{_f([-cx, -cy, 0])}" stiffness="{body.stiffness:.9g}" solreflimit="{2 * scene.scene.timestep:.9g} 1" '
                   f'damping="{body.damping:.9g}" range="{-stop:.9g} {stop:.9g}" limited="true"/>')
        out.append(f'<geom name="rod{i}" type="capsule" fromto="0 0 {-body.rod_bottom_m:.9g} 0 0 {body.rod_top_m - coat:.9g}" '
                   f'size="{r:.9g}" friction="{_fr(scene, c.rod_friction)}" contype="2" conaffinity="0" mass="0" priority="2"/>')
        out.append(f'<geom name="tip{i}" type="capsule" fromto="0 0 {body.rod_top_m - coat:.9g} 0 0 {body.rod_top_m:.9g}" '
                   f'size="{r * c.tip_radius_factor:.9g}" friction="{_fr(scene, mu_tip)}" contype="2" conaffinity="0" mass="0"/>')
        out.append('</body>')
    out.append('</body></body>')
    for o in scene.objects:
        out.append(_object_xml(scene, o, design))
    out.append('</worldbody><actuator>')
    for i in range(n):
        out.append(f'<general name="m{i}" joint="r{i}" gaintype="affine" gainprm="0 0 0" biastype="none" '
                   'ctrllimited="false" forcelimited="false"/>')
    out.append('</actuator></mujoco>')
    return "\n".join(out)


def object_friction(o, design, scene=None) -> float:
    """An object's Coulomb coefficient against the sand-coated tips: its own (the pair's), else the tip
    cap material's (``contact.tip_material``, when it gives one), else the design's tip_friction."""
    if o.friction is not None:
        return o.friction
    cap = scene.materials.get(scene.contact.tip_material) if scene is not None and scene.contact.tip_material else None
    return cap.friction if cap is not None and cap.friction is not None else design.mechanics.tip_friction


def _object_xml(scene, o, design) -> str:
    yaw = math.radians(o.yaw)
    q = [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]
    fr = f'friction="{_fr(scene, object_friction(o, design, scene))}" contype="1" conaffinity="3" priority="1"'
    if o.shape == "mesh":
        g = f'<geom type="mesh" name="obj:{o.name}:0" mesh="mesh:{o.name}" mass="{o.mass * 1e-3:.9g}" {fr}/>'
        z = -mesh_bounds(scene, o)[0][2] * o.size[0] * MM      # its lowest point rests on the table
    else:
        g = "".join(f'<geom type="{sh}" name="obj:{o.name}:{k}" size="{_f(np.asarray(sz) * MM)}" '
                    f'pos="{_f(np.asarray(ps) * MM)}" mass="{m * 1e-3:.9g}" {fr}/>'
                    for k, (sh, sz, ps, m) in enumerate(o.geoms()))
        z = o.half_height * MM
    joint = "" if o.fixed else "<freejoint/>"
    return (f'<body name="obj:{o.name}" pos="{o.pos[0] * MM:.9g} {o.pos[1] * MM:.9g} {z + 1e-5:.9g}" quat="{_f(q)}">'
            f'{joint}{g}</body>')


class MjScene:
    """A built MuJoCo scene with the whisker drive; step() advances one time step."""

    def __init__(self, scene, design, plan, body):
        import mujoco

        self.mujoco = mujoco
        self.scene, self.design, self.body = scene, design, body
        self.xml = build_mjcf(scene, design, body)
        try:
            self.model = mujoco.MjModel.from_xml_string(self.xml)
        except ValueError as err:
            raise SceneError(f"MuJoCo refused the scene: {str(err).splitlines()[0]}") from None
        for model in CONTACT_MODELS:           # contact models beyond the rigid one (whisker.sim.effects.plan)
            if plan.built(model.NAME):
                model.apply(plan.effect(model.NAME), self)
        self.data = mujoco.MjData(self.model)
        n = design.whiskers.count
        self.n = n
        jid = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, f"{k}{i}") for i in range(n) for k in "rt"]
        self.qadr = np.array([self.model.jnt_qposadr[j] for j in jid]).reshape(n, 2)
        self.vadr = np.array([self.model.jnt_dofadr[j] for j in jid]).reshape(n, 2)
        aj = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, k) for k in ("ax", "ay", "az", "ayaw")]
        self.arm_q = np.array([self.model.jnt_qposadr[j] for j in aj])
        self.arm_v = np.array([self.model.jnt_dofadr[j] for j in aj])
        self.obj_ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, f"obj:{o.name}") for o in scene.objects]
        self.drive = Drive(scene, design, plan, body)
        pos0, _ = sensor_frame(scene, design, pose_at(scene, 0.0))
        self.data.qpos[self.arm_q] = pos0
        self.data.qpos[self.qadr[:, 0]] = math.radians(scene.scene.initial_tilt_deg)
        mujoco.mj_forward(self.model, self.data)
        self.t = 0.0

    def theta(self) -> np.ndarray:
        return self.data.qpos[self.qadr].copy()

    def omega(self) -> np.ndarray:
        return self.data.qvel[self.vadr].copy()

    def objects_mm(self) -> np.ndarray:
        return self.data.xpos[self.obj_ids].copy() / MM if self.obj_ids else np.zeros((0, 3))

    def arm_table(self, times: np.ndarray) -> np.ndarray:
        """Arm joint values (T, 4) along the path at `times`."""
        poses = poses_table(self.scene, times)
        z_tip = self.design.pivot_z + self.design.l_u
        z = poses[:, 2] + (z_tip if self.scene.sensor.facing == "down" else -z_tip)
        return np.stack([poses[:, 0] * MM, poses[:, 1] * MM, z * MM, np.radians(poses[:, 3])], axis=1)

    def _magnetic_gains(self, I: np.ndarray) -> None:
        """Coil torque as MuJoCo affine actuators, linearised about each whisker's current tilt.

        tau(theta) = I k(gap(theta)) L cos(theta) ~ I (f(th0) + f'(th0) (theta - th0)); the gains are
        refreshed every chunk, so between refreshes the torque follows the tilt to first order.
        """
        th0 = self.data.qpos[self.qadr[:, 0]].copy()
        if not self.drive.on or not np.any(I):
            self.model.actuator_gainprm[:, :2] = 0.0
            self.data.ctrl[:] = 0.0
            return
        h = 1e-4
        f0 = self.drive.torque(self.body, th0, np.ones_like(th0))
        f1 = self.drive.torque(self.body, th0 + h, np.ones_like(th0))
        slope = (f1 - f0) / h
        self.model.actuator_gainprm[:, 0] = f0 - slope * th0
        self.model.actuator_gainprm[:, 1] = slope
        self.data.ctrl[:] = I

    def advance(self, levels: np.ndarray, arm0: np.ndarray, arm1: np.ndarray, nstep: int) -> None:
        """`nstep` time steps with `levels`, the arm moving linearly from arm0 to arm1 meanwhile."""
        d, dt = self.data, self.model.opt.timestep
        d.qpos[self.arm_q] = arm0                 # the arm follows the path exactly (prescribed motion)
        d.qvel[self.arm_v] = (arm1 - arm0) / (dt * nstep)
        I = self.drive.currents(levels)
        self._magnetic_gains(I)
        self.mujoco.mj_step(self.model, d, nstep)
        bad = d.warning[self.mujoco.mjtWarning.mjWARN_BADQACC]
        if bad.number:                            # MuJoCo reset the state: the run is no longer physical
            raise SimulationError(f"MuJoCo found an unstable acceleration (DOF {bad.lastinfo}) near t = "
                                  f"{self.t + dt * nstep:.4g} s and reset the state; use a smaller "
                                  "scene.timestep or a softer contact (contact.solref_timeconst)")
        self.drive.heat(dt * nstep)
        self.t += dt * nstep

    def step(self, levels: np.ndarray) -> None:
        dt = self.model.opt.timestep
        arm0, arm1 = self.arm_table(np.array([self.t, self.t + dt]))
        self.advance(levels, arm0, arm1, 1)
