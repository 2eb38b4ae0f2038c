"""An actuation backend driving the simulated whiskers (``set_levels``/``off``, as every backend in whisker.drive.hbridge).

``whisker actuate --backend sim`` (whisker.drive.hbridge.open_backend("sim")) gets one of these. The
whiskers follow the levels through the same effects a free scene builds (kinematics, gravity,
magnetics): each call advances the simulation to the caller's clock (``time.monotonic`` by
default, or an injected clock for tests), holding the previous levels over the elapsed time, so
a timed sequence on the simulator moves the whiskers as it would move the hardware. A level is a
signed PWM duty: the mean coil current is level x V_fs / R, V_fs the full-scale coil voltage of
the hardware path (whisker.drive.guard.full_scale_voltage).
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from whisker.drive.guard import full_scale_voltage as _guard_full_scale_voltage
from whisker.coil.kinematics import gravity_torque, magnetic_torque, step_free, tip_positions_mm, whisker_body


class SimBackend:
    """Simulated coils + whiskers. ``levels`` (N,) in [-1, 1], + retracts; ``off()`` never raises."""

    def __init__(self, design, *, clock: Callable[[], float] = time.monotonic, dt: float = 5e-4,
                 facing: str = "down", magnetics_model: str = "table", max_catch_up_s: float = 5.0):
        self.design = design
        self.n = design.whiskers.count
        self.body = whisker_body(design)
        self.clock = clock
        self.dt = float(dt)
        self.facing = facing
        self.model = magnetics_model
        self.max_catch_up_s = max_catch_up_s
        self.volts_full_scale = float(_guard_full_scale_voltage(design))   # V at level 1 (whisker.drive.guard)
        self.levels = np.zeros(self.n)
        self.theta = np.zeros((self.n, 2))
        self.omega = np.zeros((self.n, 2))
        self.t_sim = 0.0
        self._t_wall = clock()
        self.history: list[tuple[float, np.ndarray]] = []

    # --- contract -----------------------------------------------------------------------------
    def set_levels(self, levels) -> None:
        lv = np.asarray(levels, dtype=float).reshape(-1)
        if lv.shape != (self.n,):
            raise ValueError(f"levels must have shape ({self.n},), got {lv.shape}")
        if not np.all(np.isfinite(lv)) or np.any(np.abs(lv) > 1):
            raise ValueError(f"levels must be finite and in [-1, 1], got {lv.tolist()}")
        self.sync()
        self.levels = lv.copy()
        self.history.append((self.t_sim, self.levels.copy()))

    def off(self) -> None:
        try:
            self.sync()
        finally:
            self.levels = np.zeros(self.n)
            self.history.append((self.t_sim, self.levels.copy()))

    def close(self) -> None:
        self.off()

    # --- simulation ----------------------------------------------------------------------------
    def sync(self) -> None:
        """Advance the simulation to the clock (at most ``max_catch_up_s`` at once)."""
        now = self.clock()
        elapsed = max(now - self._t_wall, 0.0)
        if elapsed > self.max_catch_up_s:        # a long pause: skip what cannot be caught up
            self._t_wall = now - self.max_catch_up_s
            elapsed = self.max_catch_up_s
        steps = int(elapsed / self.dt + 1e-9)
        self.advance(steps * self.dt)
        self._t_wall += steps * self.dt          # the remainder is simulated at the next call

    def advance(self, seconds: float) -> None:
        from whisker.drive.guard import coil_current_A

        steps = int(seconds / self.dt + 1e-9)
        if steps <= 0:
            return
        I = np.asarray(coil_current_A(self.design, self.levels * self.volts_full_scale, 20.0), dtype=float)   # mean current of the PWM
        for _ in range(steps):
            tau = gravity_torque(self.body, self.theta, self.facing)
            if np.any(I != 0):
                tau[:, 0] += magnetic_torque(self.design, self.body, self.theta[:, 0], I, self.model)
            self.theta, self.omega = step_free(self.body, self.theta, self.omega, tau, self.dt)
        self.t_sim += steps * self.dt

    def angles_deg(self) -> np.ndarray:
        """Radial tilt of each whisker, deg (+ = retracted)."""
        self.sync()
        return np.degrees(self.theta[:, 0])

    def tips_mm(self) -> np.ndarray:
        self.sync()
        return tip_positions_mm(self.design, self.theta)


class SimClock:
    """Simulated time, s: a clock (``clock()``) that moves only when told (``sleep(dt)``).

    A simulated recording (`whisker record --source sim --backend sim`) runs the camera, the
    simulator, the sequence and the thermal guard on it, so its frames come at exactly 1/fps of
    simulated time whatever the machine's load. `sleep` advances in steps of at most `period_s`
    and calls every `hooks` function with the new time after each step (the sequence runner and the
    guard's watchdog, which a real recording runs in threads on the wall clock)."""

    def __init__(self, period_s: float = 0.01):
        if not (period_s > 0):
            raise ValueError(f"sim clock period must be > 0 s, got {period_s}")
        self.t = 0.0
        self.period_s = float(period_s)
        self.hooks: list[Callable[[float], None]] = []

    def __call__(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        end = self.t + max(float(seconds), 0.0)
        while self.t < end - 1e-12:
            self.t = min(end, self.t + self.period_s)
            for hook in list(self.hooks):
                hook(self.t)
        self.t = end


def actuation_backend(design, **kw) -> SimBackend:
    """The simulator's actuation backend for `design` (see :class:`SimBackend`)."""
    return SimBackend(design, **kw)
