"""What a run returns: :class:`Result` (arrays; SI angles, mm positions) and the error a run raises
when it becomes non-physical. Plain data below every stepping loop."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from whisker.sim.graph import Plan


class SimulationError(RuntimeError):
    """The run became non-physical (NaN, energy blow-up); one line saying what and when."""


@dataclass
class Result:
    plan: Plan
    t_s: np.ndarray                     # (T,)
    theta_rad: np.ndarray               # (T, N, 2): radial (+ retract), tangential
    tips_mm: np.ndarray                 # (T, N, 3) sensor frame
    markers_mm: np.ndarray              # (T, N, 3) sensor frame
    energy_J: np.ndarray                # (T,) whiskers' mechanical energy
    levels: np.ndarray                  # (T, N)
    temperature_C: np.ndarray | None = None   # (T, N) when heating is built
    objects_mm: np.ndarray | None = None      # (T, M, 3) world positions of the objects
    object_names: list[str] = field(default_factory=list)
    sensor_pose: np.ndarray | None = None     # (T, 4) x, y, tip height, yaw
    contacts: np.ndarray | None = None        # (T,) number of active contacts
    steps: int = 0
    info: dict = field(default_factory=dict)

    @property
    def theta_deg(self) -> np.ndarray:
        return np.degrees(self.theta_rad)


def check_finite(name: str, arr, t: float) -> None:
    if not np.all(np.isfinite(arr)):
        raise SimulationError(f"{name} became non-finite at t = {t:.4g} s (time step too large or a "
                              f"broken parameter); try a smaller scene.timestep")
