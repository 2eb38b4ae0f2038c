"""Closed-loop grasps in the simulator: MuJoCo whiskers and object, the rendered camera, the tracker,
the state estimator and `whisker.sensing.grasp_control.GraspController`, frame by frame.

`SimGraspRig` is the simulator backend of a grasp: each camera period it renders the frame from
the MuJoCo tilts (whisker.vision.render, as the camera effect does), and after the controller's answer it
advances MuJoCo one period with the commanded coil levels and arm velocity. The controller is the
one hardware would run (the hardware rig gives it picamera frames and a whisker.drive.actuation.Actuator).
`OpenLoopController` is the paper's protocol on the same rig, so the two are compared on identical
placements and physics. Coil energy = sum over coils of I_rms^2 R(T) dt (Joule heat of the PWM
current at the coil's simulated temperature; whisker.sim.contract, whisker.coil).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from whisker.sensing.grasp_control import Command, ControlParams, GraspController
from whisker.coil.kinematics import marker_positions_mm, static_equilibrium, whisker_body
from whisker.sim.experiments.paper import (START_HEIGHT, T_CLOSE, T_DOWN, T_HOLD, T_LIFT, Placement, grasp_level,
                               grasp_scene)


class FreeClosing:
    """`expected_px(level) -> (n, 2)`: the marker displacement (px, the tracker's frame) of a free
    whisker driven at `level`, from the static equilibrium (whisker.coil.kinematics), tabulated on
    `points` levels in 0..1 and interpolated; and `pressing_Nm(level, d_px) -> (n,)`: the net closing
    torque (N m) a whisker blocked at displacement `d_px` presses on the object with at `level`.

    The pressing torque is tau_magnetic(I(level), theta) + tau_gravity(theta) - k theta at the held
    tilt theta (the marker displacement inverted through the same camera model), i.e. the torque the
    object's contact force must balance. The free closing alone is no measure of it: with the
    design's magnet the pull grows steeply as the gap closes, so from ~40 % of full scale the free
    whisker snaps onto the end stop, while a whisker held far from the magnet (the object in the way)
    presses with only the pull at its own, wider gap (whisker.sensing.grasp_control._hold_level)."""

    def __init__(self, design, *, facing: str = "down", points: int = 24, theta_points: int = 64):
        from whisker.sim.contract import current_A, full_scale_voltage, marker_pixels

        self.design, self.facing = design, facing
        n = design.whiskers.count
        self.n = n
        self.body = body = whisker_body(design)
        self.lv = lv = np.linspace(0.0, 1.0, points)
        self.volts = full_scale_voltage(design)
        I = np.asarray(current_A(design, lv * self.volts), dtype=float)
        th = static_equilibrium(design, body, I, facing=facing).theta_rad            # (points,)

        def px(theta):
            return marker_pixels(design, marker_positions_mm(design, np.stack([np.full(n, theta), np.zeros(n)], -1)))
        rest = px(0.0)
        self.tab = np.array([px(t) - rest for t in th])                               # (points, n, 2)
        # held displacement (px, its length) -> radial tilt (rad), per whisker, on 0..stop
        self.th_grid = np.linspace(0.0, body.stop_rad, theta_points)
        self.r_grid = np.array([np.linalg.norm(px(t) - rest, axis=1) for t in self.th_grid])   # (T, n)

    def __call__(self, level: float) -> np.ndarray:
        x = float(np.clip(abs(level), 0.0, 1.0))
        lv, tab = self.lv, self.tab
        k = min(int(np.searchsorted(lv, x)), len(lv) - 1)
        if k == 0:
            return tab[0].copy()
        w = (x - lv[k - 1]) / (lv[k] - lv[k - 1])
        return (1 - w) * tab[k - 1] + w * tab[k]

    def held_theta_rad(self, d_px) -> np.ndarray:
        """Radial tilt (rad) of each whisker at marker displacement `d_px` (n, 2), clipped to 0..stop."""
        r = np.linalg.norm(np.asarray(d_px, dtype=float).reshape(self.n, 2), axis=1)
        return np.array([np.interp(r[i], self.r_grid[:, i], self.th_grid) for i in range(self.n)])

    def pressing_Nm(self, level: float, d_px) -> np.ndarray:
        """Net closing torque (N m) of each whisker held at `d_px` with its coil at `level` (20 C)."""
        from whisker.coil.kinematics import gravity_torque, magnetic_torque
        from whisker.sim.contract import current_A

        th = self.held_theta_rad(d_px)
        I = float(current_A(self.design, abs(float(level)) * self.volts))
        return (magnetic_torque(self.design, self.body, th, I) + gravity_torque(self.body, th, self.facing)
                - self.body.stiffness * th)


def free_closing_px(design, *, facing: str = "down", points: int = 24) -> FreeClosing:
    """The free-closing map of `design` (see FreeClosing): callable as `expected_px(level)`."""
    return FreeClosing(design, facing=facing, points=points)


class OpenLoopController:
    """The paper's protocol (whisker.sim.experiments.paper timeline) frame by frame: descend, close at the level,
    wait, lift, hold, release. It never looks at the frames. `guard`: a whisker.drive.guard.ThermalGuard
    on the frame clock the levels pass through, as the hardware's actuator always does (None: the
    bare protocol, as `make sim-grasp`)."""

    def __init__(self, n: int, active, params: ControlParams, guard=None):
        self.p = params
        self.guard = guard
        self.mask = np.zeros(n, dtype=bool)
        self.mask[list(active)] = True
        self.phase = "descend"
        self._t0 = None
        self._h = params.start_height_mm
        self._lifted = 0.0

    def step(self, t_s, dx_px=None, dy_px=None, valid=None) -> Command:
        cmd = self._step(t_s)
        if self.guard is not None:
            cmd.levels = self.guard.allow(cmd.levels, t_s)
        return cmd

    def _step(self, t_s) -> Command:
        p = self.p
        if self._t0 is None:
            self._t0 = t_s
        t = t_s - self._t0
        lv = np.where(self.mask, p.full_level, 0.0)
        t1, t2 = T_DOWN, T_DOWN + T_CLOSE
        t3, t4 = t2 + T_LIFT, t2 + T_LIFT + T_HOLD
        # speeds of the paper's path, each move ending exactly at its end point
        if t < t1 - 1e-9:
            self.phase = "descend"
            v = max(-(p.start_height_mm - p.grasp_height_mm) / T_DOWN, (p.grasp_height_mm - self._h) * p.fps)
            self._h += v / p.fps
            return Command(np.zeros_like(lv), v, "descend")
        if t < t2 - 1e-9:
            self.phase = "close"
            return Command(lv, 0.0, "close")
        if t < t3 - 1e-9:
            self.phase = "lift"
            v = min(p.lift_mm / T_LIFT, (p.lift_mm - self._lifted) * p.fps)
            self._lifted += v / p.fps
            return Command(lv, v, "lift")
        if t < t4:
            self.phase = "hold"
            return Command(lv, 0.0, "hold")
        self.phase = "done"
        return Command(np.zeros_like(lv), 0.0, "done")


@dataclass
class GraspRun:
    controller: str
    success: bool
    lift_mm: float
    energy_J: float
    peak_C: float
    time_to_grip_s: float | None
    outcome: str
    frames: int
    process_ms: list = field(default_factory=list)     # tracker + states + controller, per frame
    contact_latency_frames: list = field(default_factory=list)
    events: list = field(default_factory=list)
    abort_reaction_frames: int | None = None            # first true touch -> the abort command


class SimGraspRig:
    """One grasp attempt in MuJoCo at `placement`, stepped one camera period at a time."""

    def __init__(self, scene, design, obj, active, placement: Placement, *, fps: float = 15.0, seed: int = 0,
                 noise_sigma: float = 2.0, blur_px: float = 0.8, body=None):
        from whisker.sim.contract import marker_pixels, render_frame, tracker
        from whisker.sim.effects.plan import plan
        from whisker.sim.mj import MM, MjScene

        self.design, self.fps = design, float(fps)
        self.n = design.whiskers.count
        self.level = grasp_level(design)
        s = grasp_scene(scene, obj, active, dx=placement.dx, dy=placement.dy, obj_yaw=placement.obj_yaw,
                        sensor_yaw=placement.sensor_yaw, level=self.level)
        self.scene = s
        pl = plan(s, design)
        self.body = body if body is not None else whisker_body(design)
        self.sim = MjScene(s, design, pl, self.body)
        self.MM = MM
        self.dt = s.scene.timestep
        self.nstep = max(1, int(round(1.0 / (self.fps * self.dt))))
        self.period = self.nstep * self.dt
        self.start_h = float(s.sensor.path[0][3])
        self.grasp_h = float(s.experiment.tip_height) if s.experiment.tip_height else float(s.sensor.path[1][3])
        self.grasp_h = float(s.sensor.path[1][3])
        self.yaw = math.radians(float(s.sensor.path[0][4]))
        self.h = self.start_h
        self.z_tip = design.pivot_z + design.l_u
        self.obj_z0 = float(self.sim.objects_mm()[0, 2])
        self.energy_J = 0.0
        self.peak_C = float(np.max(self.sim.drive.T))
        self.t = 0.0
        self.seed = seed
        self._render = lambda px, k: render_frame(design, px, seed=seed * 1_000_003 + k, noise_sigma=noise_sigma,
                                                  blur_px=blur_px)
        self._marker_pixels = marker_pixels
        self.tracker = tracker(design, "roi")
        rest_px = marker_pixels(design, marker_positions_mm(design, np.zeros((self.n, 2))))
        self.tracker.calibrate([self._render(rest_px, 10_000_000 + j) for j in range(5)])
        self.k = 0
        self.hidden: set[int] = set()
        self.touched = np.zeros(self.n, dtype=bool)      # touches since the last frame (truth)
        self.last_levels = np.zeros(self.n)
        import mujoco
        ids = {mujoco.mj_name2id(self.sim.model, mujoco.mjtObj.mjOBJ_GEOM, f"{p}{i}"): i
               for i in range(self.n) for p in ("rod", "tip")}
        self._whisker_geom = ids
        self._table = mujoco.mj_name2id(self.sim.model, mujoco.mjtObj.mjOBJ_GEOM, "table")

    def params(self, **kw) -> ControlParams:
        from whisker.sensing.grasp_control import settle_time_s

        e = self.scene.experiment
        if "settle_s" not in kw:
            kw["settle_s"] = settle_time_s(self.design, kw.get("model_tolerance", ControlParams.model_tolerance))
        return ControlParams(full_level=self.level, grasp_height_mm=self.grasp_h, start_height_mm=self.start_h,
                             fps=self.fps, lift_mm=e.lift, **kw)

    def _arm(self, h: float) -> np.ndarray:
        return np.array([0.0, 0.0, (h + self.z_tip) * self.MM, self.yaw])

    def touching(self) -> np.ndarray:
        """Whiskers touching the object now (MuJoCo contacts of a rod/tip with a non-table geom)."""
        d = self.sim.data
        out = np.zeros(self.n, dtype=bool)
        for c in d.contact[:d.ncon]:
            for a, b in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
                if a in self._whisker_geom and b != self._table and b not in self._whisker_geom:
                    out[self._whisker_geom[a]] = True
        return out

    def frame(self):
        """The camera frame now: (time s, image). Markers in `hidden` are not drawn (a covered or
        fallen-off marker, for the fail-safe tests)."""
        px = self._marker_pixels(self.design, marker_positions_mm(self.design, self.sim.theta()))
        if self.hidden:
            px = px.copy()
            px[sorted(self.hidden)] = np.nan
        img = self._render(px, self.k)
        self.k += 1
        return self.t, img

    def advance(self, levels, arm_mm_s: float) -> None:
        """One camera period with `levels` and the arm moving at `arm_mm_s` (+ up)."""
        from whisker.coil import resistance_ohm
        from whisker.sim.contract import current_A, pwm_rms_current_A

        levels = np.asarray(levels, dtype=float)
        self.last_levels = levels.copy()
        h1 = self.h + arm_mm_s * self.period
        T = self.sim.drive.T.copy()
        # in chunks, to catch touches that begin and end between two frames (a tip bouncing off)
        chunk = max(1, self.scene.contact.chunk)
        done = 0
        while done < self.nstep:
            m = min(chunk, self.nstep - done)
            a0 = self._arm(self.h + arm_mm_s * self.period * done / self.nstep)
            a1 = self._arm(self.h + arm_mm_s * self.period * (done + m) / self.nstep)
            self.sim.advance(levels, a0, a1, m)
            self.touched |= self.touching()
            done += m
        self.h = h1
        self.t += self.period
        T2 = self.sim.drive.T
        Tm = 0.5 * (T + T2)
        I = np.asarray(current_A(self.design, levels * self.sim.drive.volts, Tm), dtype=float)
        irms = pwm_rms_current_A(I, levels)
        self.energy_J += float(np.sum(irms ** 2 * np.asarray(resistance_ohm(self.design, Tm)))) * self.period
        self.peak_C = max(self.peak_C, float(np.max(T2)))

    def lift_mm(self) -> float:
        return float(self.sim.objects_mm()[0, 2]) - self.obj_z0


def run_grasp(rig: SimGraspRig, controller, *, hold_height_mm: float, max_s: float = 6.0,
              on_frame=None, drop_frame=None) -> GraspRun:
    """Drive `rig` with `controller` until it is done or aborts; success = the object's centre more
    than `hold_height_mm` above its start when the hold ends (the paper's criterion). The final
    command (coils off) is applied for one more period, so the rig ends in the state it asked for.
    `drop_frame(rig) -> bool`: frames for which it is true never reach the controller (the rig runs
    on with the previous command), as a camera dropping frames."""
    tracked = hasattr(controller, "est")
    times, lift_at_release = [], None
    t_grip = None
    process = []
    latency = []
    touched_at = np.full(rig.n, -1)
    detected = np.zeros(rig.n, dtype=bool)
    frames = 0
    cmd = None
    reaction = None
    while rig.t < max_s:
        t, img = rig.frame()
        if cmd is not None and drop_frame is not None and drop_frame(rig):
            rig.advance(cmd.levels, cmd.arm_mm_s)
            continue
        touching = rig.touching() | rig.touched
        rig.touched = np.zeros(rig.n, dtype=bool)
        if tracked and controller.phase in ("descend", "close", "tighten"):
            touched_at[touching & (touched_at < 0)] = frames + 1       # this frame's number
        t0 = time.perf_counter()
        if tracked:
            res = rig.tracker.track(img)
            cmd = controller.step(t, res.dx_px, res.dy_px, res.valid)
        else:
            cmd = controller.step(t)
        process.append((time.perf_counter() - t0) * 1e3)
        frames += 1
        if on_frame is not None:
            on_frame(rig, controller, cmd)
        # latency of the contact flag: frames from the first true touch to the first contact flag
        if tracked and controller.phase in ("descend", "close", "tighten"):
            hit = controller.est.contact & (touched_at >= 0) & ~detected
            for w in np.flatnonzero(hit):
                latency.append(int(frames - touched_at[w]))
            detected |= controller.est.contact & (touched_at >= 0)
        if cmd.phase == "lift" and t_grip is None:
            t_grip = t
        if cmd.phase == "abort" and tracked and np.any(touched_at >= 0):
            reaction = int(frames - touched_at[touched_at >= 0].min())
        if cmd.phase in ("done", "abort"):
            if lift_at_release is None:
                lift_at_release = rig.lift_mm()
            rig.advance(cmd.levels, cmd.arm_mm_s)
            break
        rig.advance(cmd.levels, cmd.arm_mm_s)
    if lift_at_release is None:
        lift_at_release = rig.lift_mm()
    events = getattr(getattr(controller, "log", None), "events", [])
    outcome = events[-1][2] if events else (cmd.phase if cmd else "")
    held_phase = getattr(controller, "phase", "done") == "done" and not outcome.startswith("missed")
    success = bool(held_phase and lift_at_release > hold_height_mm)
    return GraspRun(type(controller).__name__, success, float(lift_at_release), rig.energy_J, rig.peak_C,
                    t_grip, outcome or "done", frames, process, latency, list(events), reaction)
