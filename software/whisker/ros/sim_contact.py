"""A simulated object touching the whiskers, for the node on the simulator (`~/sim_contact`).

The simulator's actuation backend (whisker.drive.simulated.SimBackend) moves the whiskers under gravity
and their coils only. `ContactBackend` adds what whisker.sim.experiments.state_sequences calls a contact: a
one-sided stiff wall (50 x the membrane's stiffness, critically damped at half its rate) that
comes in along a direction and pushes the touched whiskers' tips to a set tilt, so that the
camera sees a contact that no coil caused. Nothing else changes: the same integrator
(whisker.coil.kinematics.step_free), gravity and magnetic torques, and the same clock.
"""

from __future__ import annotations

import math

import numpy as np

from whisker.coil.kinematics import gravity_torque, magnetic_torque, step_free
from whisker.drive.simulated import SimBackend


class ContactBackend(SimBackend):
    """SimBackend plus an optional wall contact (see the module docstring)."""

    WALL_STIFFNESS = 50.0     # x the membrane's rotational stiffness (whisker.sim.experiments.state_sequences)

    def __init__(self, design, **kw):
        super().__init__(design, **kw)
        self.touch = np.zeros(self.n, dtype=bool)
        self.direction = np.zeros((self.n, 2))        # unit tilt direction the wall pushes (radial, tangential)
        self.reach_rad = 0.0

    def set_contact(self, whiskers, reach_deg: float, direction: str = "in") -> None:
        """Touch `whiskers` (indices; empty = release): the wall pushes their tips `reach_deg` of tilt
        radially in (+, retraction) or out; any previous contact is replaced."""
        if not (math.isfinite(reach_deg) and 0.0 <= reach_deg <= 45.0):
            raise ValueError(f"contact reach must be 0..45 deg of tilt, got {reach_deg}")
        self.sync()
        touch = np.zeros(self.n, dtype=bool)
        touch[list(whiskers)] = True
        d = np.zeros((self.n, 2))
        d[:, 0] = 1.0 if direction == "in" else -1.0
        self.touch, self.direction, self.reach_rad = touch, d, math.radians(reach_deg)

    def advance(self, seconds: float) -> None:
        if not self.touch.any():
            return super().advance(seconds)
        from whisker.drive.guard import coil_current_A

        steps = int(seconds / self.dt)
        if steps <= 0:
            return
        k = self.WALL_STIFFNESS * self.body.stiffness
        c = 2 * 0.5 * math.sqrt(k * self.body.inertia_kgm2)
        current = np.asarray(coil_current_A(self.design, self.levels * self.volts_full_scale, 20.0), dtype=float)
        for _ in range(steps):
            tau = gravity_torque(self.body, self.theta, self.facing)
            if np.any(current != 0):
                tau[:, 0] += magnetic_torque(self.design, self.body, self.theta[:, 0], current, self.model)
            pen = self.reach_rad - np.sum(self.theta * self.direction, axis=1)
            f = np.where(self.touch & (pen > 0), k * pen - c * np.sum(self.omega * self.direction, axis=1), 0.0)
            tau += np.maximum(f, 0.0)[:, None] * self.direction
            self.theta, self.omega = step_free(self.body, self.theta, self.omega, tau, self.dt)
        self.t_sim += steps * self.dt
