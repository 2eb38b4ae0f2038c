"""Closed-loop grasp controller: the same code for the simulator and the hardware.

Each camera frame the rig hands the controller the tracked displacement of every whisker; the
controller answers with coil levels and an arm velocity (`Command`). Phases:

1. ``descend``  arm down at `descend_mm_s` to the grasp height, coils off. The first frames teach
   the state estimator each whisker's rest position and noise. A whisker in contact here (before
   any actuation) aborts: coils off, arm up (fail safe, reason logged).
2. ``close``    the configuration's coils at the paper's level. After `settle_s` (from the design's
   whisker dynamics, :func:`settle_time_s`: ~98 ms, so the second frame at 15/s) a whisker holds the
   object when its displacement differs from the displacement its own coil alone would cause
   (`expected_px(level)`, the free closing in air) by more than the estimator's contact threshold
   (whisker.sensing.states.AdaptiveEstimator with the command's expected displacement). Grip when at
   least `quorum` of the active whiskers hold; none within `close_timeout_s`: release ("missed").
3. ``tighten``  step down to the lowest level of the ladder full x step_factor^k (not below
   min_fraction x full) that still presses every holding whisker on the object with `keep_force`
   of the full level's force (the coil heat falls with the level): from the net closing torque at
   the whisker's measured position when the map knows it (`expected_px.pressing_Nm`, the coil's
   pull at that gap minus the membrane's spring), else from a linear-spring proxy (the free closing
   `margin_px` and `keep_force` of the full level's distance beyond the held position); after
   `settle_s` a whisker that lost contact brings the level back to the one that held before the
   step-down. `step_down = "top"` (default) does this at the top of the lift, `"grip"` before the
   lift (less heat, more drops: docs/states.md).
4. ``lift``     arm up `lift_mm` in `lift_s`. Slip (in the lift and the hold): a holding whisker
   springs back toward its free closing (its distance from it shrinks below `slip_fraction` of the
   value at the start of the lift) or loses contact: re-grip at a higher level (as the thermal
   guard allows), pausing the arm for `settle_s`, at most `regrips` times.
5. ``hold``     `hold_s` at the top (counted from the end of the lift), then coils off, ``done``.

Fail safe at any phase: a marker lost for `lost_frames` frames, a gap between frames longer than
`max_gap_frames` periods (dropped frames), or a thermal-guard cut on a holding coil -> coils off,
arm stopped, phase ``abort`` with the reason. Levels always pass through the thermal guard
(whisker.drive.guard.ThermalGuard) when one is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from whisker.sensing.states import AdaptiveEstimator, AdaptiveParams


@dataclass(frozen=True)
class ControlParams:
    full_level: float                       # the paper's grasp level (3 V as a duty, whisker.drive.guard)
    grasp_height_mm: float                  # tips above the table when closing
    start_height_mm: float                  # tips above the table at the start
    fps: float = 15.0
    descend_s: float = 0.3                  # same descent as the open-loop protocol
    lift_mm: float = 30.0
    lift_s: float = 0.5
    hold_s: float = 0.4
    settle_s: float = 0.076                 # the rigs set it from the design: settle_time_s(design, model_tolerance)
    close_timeout_s: float = 0.6
    quorum: float = 0.5
    step_factor: float = 0.95
    keep_force: float = 0.8
    min_fraction: float = 0.35
    margin_px: float = 5.0
    slip_fraction: float = 0.5
    regrips: int = 2
    model_tolerance: float = 0.15           # share of the expected free closing treated as model error
    step_down: str = "top"                  # "grip": before the lift; "top": after the lift (hold only)
    early_contact: str = "abort"            # a whisker in contact before actuation: "abort" (fail safe,
                                            # the rule) or "continue" (log it and grasp anyway)
    lost_frames: int = 2
    max_gap_frames: float = 2.5


def settle_time_s(design, tolerance: float) -> float:
    """Time (s) after a coil step for a free whisker's displacement to come within `tolerance`
    (a share) of its free closing, so that a whisker still swinging is not taken for a blocked one.

    The whisker is a torsional spring-damper about its pivot (whisker.coil.kinematics.whisker_body:
    stiffness k, inertia J, damping ratio zeta, omega_n = sqrt(k/J)); its step response approaches
    the final value inside the envelope exp(-zeta omega_n t) / sqrt(1 - zeta^2) when under-damped
    (Ogata, Modern Control Engineering, 5th ed., sec. 5-3), so t = ln(1 / (tolerance sqrt(1 - zeta^2)))
    / (zeta omega_n); over-damped, the slow pole omega_n (zeta - sqrt(zeta^2 - 1)) sets the rate
    (t = ln(1/tolerance) / that rate). Gravity and the magnet's pull,
    which softens the spring near full closing, are neglected (the estimator's tolerance covers the
    map's error)."""
    from whisker.coil.kinematics import whisker_body

    if not (0.0 < tolerance < 1.0):
        raise ValueError(f"settle tolerance must be a share in (0, 1), got {tolerance}")
    zeta = float(design.mechanics.damping_ratio)
    wn = whisker_body(design).omega_n
    if zeta < 1.0:
        sigma, amp = zeta * wn, 1.0 / math.sqrt(1.0 - zeta * zeta)
    else:
        sigma, amp = wn * (zeta - math.sqrt(zeta * zeta - 1.0)), 1.0
    if not (sigma > 0 and math.isfinite(sigma)):
        raise ValueError(f"mechanics.damping_ratio={zeta:g}: the whisker never settles (no damping)")
    return max(0.0, math.log(amp / tolerance)) / sigma


@dataclass
class Command:
    levels: np.ndarray                      # (n,) coil levels from now on
    arm_mm_s: float                         # vertical arm velocity, + up
    phase: str
    reason: str = ""


@dataclass
class ControlLog:
    events: list = field(default_factory=list)     # (t_s, phase, reason)
    grip_t_s: float | None = None
    hold_level: float | None = None
    regrips: int = 0


class GraspController:
    """See the module docstring. `expected_px(level) -> (n, 2)`: each whisker's free displacement
    (px) when its coil is driven at `level` (e.g. `whisker.sim.experiments.closed_loop.free_closing_px`);
    `guard`: a whisker.drive.guard.ThermalGuard whose clock is the frame time, or None."""

    def __init__(self, n: int, active, params: ControlParams, expected_px: Callable[[float], np.ndarray],
                 guard=None):
        self.n = int(n)
        self.active = np.zeros(self.n, dtype=bool)
        self.active[list(active)] = True
        self.p = params
        self.expected_px = expected_px
        self.guard = guard
        period = 1.0 / params.fps
        self.est = AdaptiveEstimator(self.n, AdaptiveParams(learn_s=max(0.1, 2.5 * period), learn_frames=3,
                                                            contact_min_px=1.5,
                                                            expected_tolerance=params.model_tolerance))
        self.phase = "descend"
        self.log = ControlLog()
        self.level = 0.0
        self._t_phase: float | None = None
        self._t_last: float | None = None
        self._lost = np.zeros(self.n, dtype=int)
        self._h = params.start_height_mm
        self._holding = np.zeros(self.n, dtype=bool)
        self._gap0 = np.zeros(self.n)
        self._pause_until = -math.inf
        self._t_top = math.inf
        self._next = "lift"
        self._d = np.zeros((self.n, 2))
        self._early_logged = False
        self._lifted = 0.0
        self._applied = np.zeros(self.n)     # the levels the coils actually got (after the guard)
        self._derate_logged = False
        self._level_before = params.full_level     # the level that held before a step-down

    # -- helpers ------------------------------------------------------------------------------
    def _enter(self, t: float, phase: str, reason: str = "") -> None:
        self.phase = phase
        self._t_phase = t
        self.log.events.append((round(t, 4), phase, reason))

    def _levels(self, level: float, t: float) -> np.ndarray:
        req = np.where(self.active, level, 0.0)
        out = req if self.guard is None else self.guard.allow(req, t)
        self._applied = np.asarray(out, dtype=float).copy()
        if (self.guard is not None and not self._derate_logged and self._holding.any()
                and np.any(np.abs(out[self._holding]) < np.abs(req[self._holding]) * 0.99)):
            # the guard lowers a holding coil: the grip now has less force than the controller chose
            self._derate_logged = True
            w = int(np.flatnonzero(self._holding & (np.abs(out) < np.abs(req) * 0.99))[0])
            self.log.events.append((round(t, 4), "derate", f"thermal guard: whisker {w} at level {abs(out[w]):.3f} "
                                                           f"of {abs(req[w]):.3f} "
                                                           f"({float(self.guard.temperatures[w]):.1f} C)"))
        return out

    def _abort(self, t: float, reason: str, arm: float = 0.0) -> Command:
        self.level = 0.0
        self._enter(t, "abort", reason)
        return Command(self._levels(0.0, t), arm, "abort", reason)

    def expected(self, level: float) -> np.ndarray:
        e = np.asarray(self.expected_px(level), dtype=float).reshape(self.n, 2)
        return np.where(self.active[:, None], e, 0.0)

    def expected_applied(self) -> np.ndarray:
        """Each whisker's free closing at the level its coil actually got (the guard may have
        lowered it below the request): the reference for contact and slip."""
        lv = np.abs(self._applied)
        out = np.zeros((self.n, 2))
        for v in np.unique(lv[self.active]):
            m = self.active & (lv == v)
            out[m] = self.expected(float(v))[m]
        return out

    # -- the loop -----------------------------------------------------------------------------
    def step(self, t_s: float, dx_px, dy_px, valid=None) -> Command:
        """One camera frame in, one command out."""
        p = self.p
        t = float(t_s)
        if self._t_phase is None:
            self._enter(t, "descend")
        if self.phase in ("abort", "done"):
            return Command(self._levels(0.0, t), 0.0, self.phase)
        dx = np.asarray(dx_px, dtype=float)
        dy = np.asarray(dy_px, dtype=float)
        ok = np.isfinite(dx) & np.isfinite(dy) & (np.ones(self.n, bool) if valid is None else np.asarray(valid, bool))
        # fail safe: dropped frames, lost markers
        if self._t_last is not None and t - self._t_last > p.max_gap_frames / p.fps:
            return self._abort(t, f"dropped frames: {t - self._t_last:.3f} s since the last frame "
                                  f"(> {p.max_gap_frames:g} periods)")
        self._t_last = t
        self._lost = np.where(ok, 0, self._lost + 1)
        if np.any(self._lost >= p.lost_frames):
            w = int(np.argmax(self._lost))
            return self._abort(t, f"marker of whisker {w} lost for {int(self._lost[w])} frames")
        exp = self.expected_applied() if np.any(self._applied[self.active]) else None
        self.est.update(t, np.where(ok, dx, np.nan), np.where(ok, dy, np.nan), exp)
        contact = self.est.contact.copy()
        since = t - self._t_phase
        d = np.stack([dx, dy], axis=-1)
        self._d = d

        if self.phase == "descend":
            if self.est.ready and np.any(contact):
                w = int(np.flatnonzero(contact)[0])
                why = (f"contact before actuation: whisker {w} displaced "
                       f"{float(np.hypot(*self.est.displacement[w])):.1f} px")
                if p.early_contact == "abort":
                    return self._abort(t, why, arm=+50.0)
                if not self._early_logged:
                    self._early_logged = True
                    self.log.events.append((round(t, 4), "descend", why + " (continuing)"))
            if self._h <= p.grasp_height_mm + 1e-9:
                if not self.est.ready:
                    return self._abort(t, "descent ended before the rest frames were learned")
                self.level = p.full_level
                self._enter(t, "close", f"level {self.level:.3f}")
                return Command(self._levels(self.level, t), 0.0, "close")
            # at the nominal speed, but never below the grasp height within the next period
            v = max(-(p.start_height_mm - p.grasp_height_mm) / p.descend_s, (p.grasp_height_mm - self._h) * p.fps)
            self._h += v / p.fps
            return Command(self._levels(0.0, t), v, "descend")

        if self.phase == "close":
            if since < p.settle_s:
                return Command(self._levels(self.level, t), 0.0, "close")
            hold = contact & self.active
            need = max(1, math.ceil(p.quorum * self.active.sum()))
            if hold.sum() >= need:
                self._holding = hold
                self.log.grip_t_s = t
                msg = f"{int(hold.sum())} whiskers hold"
                if p.step_down == "grip":
                    return self._tighten(t, d, "lift", msg)
                return self._start_lift(t, msg)
            if since >= p.close_timeout_s:
                self.level = 0.0
                self._enter(t, "done", f"missed: {int(hold.sum())} of {int(self.active.sum())} whiskers hold")
                return Command(self._levels(0.0, t), 0.0, "done")
            return Command(self._levels(self.level, t), 0.0, "close")

        if self.phase == "tighten":
            if since < p.settle_s:
                return Command(self._levels(self.level, t), 0.0, "tighten")
            lost = self._holding & ~contact
            if lost.any() and self.level < self._level_before - 1e-9:
                # the step-down was too deep: back at once to the level that held (a rung at a time
                # lets the object slide out during the settle times, one per rung)
                self.level = self._level_before
                self._enter(t, "tighten", f"whisker {int(np.flatnonzero(lost)[0])} let go: level back to {self.level:.3f}")
                return Command(self._levels(self.level, t), 0.0, "tighten")
            self.log.hold_level = self.level
            if self._next == "lift":
                return self._start_lift(t, f"holding at level {self.level:.3f}")
            self._enter(t, "hold", f"holding at level {self.level:.3f}")
            return Command(self._levels(self.level, t), 0.0, "hold")

        if self.phase in ("lift", "hold"):
            if self._guard_cut():
                return self._abort(t, "thermal guard cut a holding coil")
            gap = np.linalg.norm(d - self.expected_applied(), axis=1)
            slip = self._holding & ((gap < p.slip_fraction * self._gap0) | ~contact)
            if t >= self._pause_until and slip.any() and self.log.regrips < p.regrips and self.level < p.full_level - 1e-9:
                self.log.regrips += 1
                self.level = min(p.full_level, self.level / p.step_factor ** 2)
                self._pause_until = t + p.settle_s
                self.log.events.append((round(t, 4), "regrip", f"slip on whisker {int(np.flatnonzero(slip)[0])}: "
                                                                 f"level {self.level:.3f}"))
                return Command(self._levels(self.level, t), 0.0, self.phase, "regrip")
            if self.phase == "hold":
                if t - self._t_top >= p.hold_s:
                    self.level = 0.0
                    self._enter(t, "done", "released")
                    return Command(self._levels(0.0, t), 0.0, "done")
                return Command(self._levels(self.level, t), 0.0, "hold")
            if t < self._pause_until:
                return Command(self._levels(self.level, t), 0.0, "lift")
            if self._lifted >= p.lift_mm - 1e-9:
                self._t_top = t
                if p.step_down == "top":
                    return self._tighten(t, d, "hold", "at the top")
                self._enter(t, "hold")
                return Command(self._levels(self.level, t), 0.0, "hold")
            v = min(p.lift_mm / p.lift_s, (p.lift_mm - self._lifted) * p.fps)
            self._lifted += v / p.fps
            return Command(self._levels(self.level, t), v, "lift")
        raise AssertionError(f"unknown phase {self.phase}")      # pragma: no cover

    def _tighten(self, t: float, d: np.ndarray, then: str, why: str) -> Command:
        self._level_before = self.level
        self.level = self._hold_level(d)
        self._next = then
        self._enter(t, "tighten", f"{why}; level {self.level:.3f}")
        return Command(self._levels(self.level, t), 0.0, "tighten")

    def _start_lift(self, t: float, why: str) -> Command:
        p = self.p
        self.log.hold_level = self.log.hold_level or self.level
        d = self._d
        self._gap0 = np.linalg.norm(d - self.expected_applied(), axis=1)
        self._lifted = 0.0
        self._enter(t, "lift", why)
        v = min(p.lift_mm / p.lift_s, p.lift_mm * p.fps)
        self._lifted += v / p.fps
        return Command(self._levels(self.level, t), v, "lift")

    def _guard_cut(self) -> bool:
        return bool(self.guard is not None and np.any(self.guard.tripped & self._holding))

    def _hold_level(self, d: np.ndarray) -> float:
        """The lowest ladder level that still presses every holding whisker on the object with
        `keep_force` of the full level's force.

        With a map that knows the pressing torque (`expected_px.pressing_Nm(level, d_px)`, e.g.
        whisker.sim.experiments.closed_loop.FreeClosing): the net closing torque at each holding
        whisker's measured position, tau(level) >= keep_force x tau(full). Otherwise the linear-spring
        proxy: pressing ~ stiffness x (free closing - held position), i.e. a free closing `margin_px`
        and `keep_force` of the full level's distance beyond every holding whisker. The proxy fails
        where the magnet's pull grows steeply as the gap closes (pull-in onto an end stop): there the
        free closing reaches the stop at a fraction of the full level while a whisker held at a wide
        gap presses with far less (docs/states.md)."""
        p = self.p
        h = self._holding
        pressing = getattr(self.expected_px, "pressing_Nm", None)
        if pressing is not None:
            tau_full = np.asarray(pressing(p.full_level, d), dtype=float)[h]
            if not np.all(tau_full > 0):
                return p.full_level          # a whisker not pressed on at full level: no margin to give away

            def holds(lv):
                return bool(np.all(np.asarray(pressing(lv, d), dtype=float)[h] >= p.keep_force * tau_full))
        else:
            held = np.linalg.norm(d, axis=1)
            full = np.linalg.norm(self.expected(p.full_level), axis=1)
            need = held + np.maximum(p.margin_px, p.keep_force * (full - held))

            def holds(lv):
                free = np.linalg.norm(self.expected(lv), axis=1)
                return bool(np.all(free[h] >= need[h]))
        best = p.full_level
        lv = p.full_level
        while lv * p.step_factor >= p.min_fraction * p.full_level - 1e-12:
            lv *= p.step_factor
            if holds(lv):
                best = lv
            else:
                break
        return best
