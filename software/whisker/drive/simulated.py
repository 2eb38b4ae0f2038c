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

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from whisker.drive.guard import full_scale_voltage as _guard_full_scale_voltage
from whisker.coil.kinematics import gravity_torque, magnetic_torque, step_free, tip_positions_mm, whisker_body


@dataclass(frozen=True)
class Contact:
    """An object pushing whisker `whisker`'s tip from start_s to end_s (simulated s) until its radial
    tilt reaches tilt_deg (+ = the retraction side, - = extension; the simulated camera renders the
    radial tilt): a one-sided wall 50x the membrane's stiffness, as
    whisker.sim.experiments.state_sequences. With ``r_mm`` the object holds the rod r_mm from the pivot
    instead of at the tip, and the wall's stiffness is the rod's bending between pivot and contact,
    3 EI / r (Euler-Bernoulli, a moment at the pivot, the rod pinned at r: what `whisker locate` reads)."""
    whisker: int
    start_s: float
    end_s: float
    tilt_deg: float
    r_mm: float | None = None

    @staticmethod
    def parse(text: str) -> "Contact":
        """W:START-END:DEG[@MM], e.g. 0:2-4:5 (whisker 0 pushed to 5 deg from 2 s to 4 s) or 0:2-4:5@30
        (the same, the object touching the rod 30 mm from the pivot)."""
        text, sep, at = text.partition("@")
        try:
            r_mm = float(at) if sep else None
            if r_mm is not None and not (math.isfinite(r_mm) and r_mm > 0):
                raise ValueError
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            w, deg = int(parts[0]), float(parts[2])
            a, b = (float(x) for x in parts[1].split("-"))
        except (ValueError, IndexError):
            raise ValueError(f"contact {text!r}: expected WHISKER:START-END:DEG[@MM], e.g. 0:2-4:5 or 0:2-4:5@30 "
                             "(MM > 0)") from None
        if not all(math.isfinite(v) for v in (a, b, deg)) or not 0 <= a < b or not 0 < abs(deg) <= 45:
            raise ValueError(f"contact {text!r}: need 0 <= START < END (s) and 0 < |DEG| <= 45, all finite")
        return Contact(w, a, b, deg, r_mm)


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
        self.contacts: list[Contact] = []
        k_wall = 50.0 * self.body.stiffness                     # a stiff one-sided wall (as state_sequences)
        self._wall = (k_wall, 2 * 0.5 * math.sqrt(k_wall * self.body.inertia_kgm2))

    def add_contact(self, contact: "Contact") -> None:
        """Schedule an object pushing whisker tips (see `Contact`); times in simulated seconds."""
        if not 0 <= contact.whisker < self.n:
            raise ValueError(f"contact whisker {contact.whisker} is not one of the design's 0-{self.n - 1}")
        if contact.r_mm is not None and contact.r_mm > self.design.whiskers.protrusion:
            raise ValueError(f"contact at {contact.r_mm:g} mm is beyond the rod's {self.design.whiskers.protrusion:g} mm")
        self.contacts.append(contact)

    def _contact_torque(self) -> np.ndarray:
        tau = np.zeros((self.n, 2))
        for ct in self.contacts:
            if not ct.start_s <= self.t_sim < ct.end_s:
                continue
            k, c = self._wall_of(ct)
            w, sign = ct.whisker, math.copysign(1.0, ct.tilt_deg)
            pen = math.radians(abs(ct.tilt_deg)) - sign * float(self.theta[w, 0])
            if pen > 0:
                tau[w, 0] += sign * max(k * pen - c * sign * float(self.omega[w, 0]), 0.0)
        return tau

    def _wall_of(self, ct: "Contact") -> tuple[float, float]:
        """(stiffness N*m/rad, damping N*m*s/rad) of a contact: the stiff wall, or the rod held at r_mm."""
        if ct.r_mm is None:
            return self._wall
        from whisker.mechanics.membrane import rod_bending_stiffness_Nmm2

        k = 3.0 * rod_bending_stiffness_Nmm2(self.design) / ct.r_mm * 1e-3      # N*mm/rad -> N*m/rad
        return k, 2 * 0.5 * math.sqrt(k * self.body.inertia_kgm2)

    def _substeps(self) -> int:
        """Sub-steps per dt that keep the explicit contact force stable (omega_n dt <= 0.5)."""
        k = max((self._wall_of(ct)[0] for ct in self.contacts), default=0.0)
        return max(1, math.ceil(self.dt * math.sqrt(k / self.body.inertia_kgm2) / 0.5))

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
        t_end = self.t_sim + steps * self.dt
        sub = self._substeps() if self.contacts else 1
        h = self.dt / sub
        for k in range(steps * sub):
            tau = gravity_torque(self.body, self.theta, self.facing)
            if self.contacts:
                self.t_sim = t_end - (steps * sub - k) * h
                tau = tau + self._contact_torque()
            if np.any(I != 0):
                tau[:, 0] += magnetic_torque(self.design, self.body, self.theta[:, 0], I, self.model)
            self.theta, self.omega = step_free(self.body, self.theta, self.omega, tau, h)
        self.t_sim = t_end

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
