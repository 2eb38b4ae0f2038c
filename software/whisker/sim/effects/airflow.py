"""Airflow effect: a fluctuating drag along each rod, from a flow speed and a turbulence level.

Built only when a scene asks for it (``[airflow] speed > 0``); `effect()` gives the line that
``whisker sim --explain`` prints. The model (per whisker i, time t):

    U_i(t) = U (1 + I (sqrt(c) n_0(t) + sqrt(1 - c) n_i(t)))          m/s
    q_i(t) = 1/2 rho C_d d U_i |U_i|                                    N/m, drag per length
    tau_i  = q_i (L^2 - a^2) / 2                                        N*m about the pivot

U = `speed_m_s`, I = `turbulence` (fluctuation std / mean speed), c = `coherence` (the share of the
fluctuation common to all whiskers), n_k unit-variance Ornstein-Uhlenbeck processes with integral
time `integral_time_s` (exact discretisation, so any time step gives the same statistics), d the
rod diameter, the drag uniform on the rod from the membrane's upper face (a = half the membrane
thickness above the pivot) to the tip (L = l_u). C_d of a circular cylinder in cross flow is about
1.0-1.2 for 1e2 < Re < 1e5 (White, *Fluid Mechanics*, Fig. 7.16; a 0.5 mm rod at 1-20 m/s has
Re 30-700); rho = 1.2 kg/m^3 (air at 20 C, 1 atm). The flow is horizontal in the sensor frame at
heading `direction_deg` from +x; the torque is split onto each whisker's radial and tangential
tilt axes with the sign convention of `whisker.coil.kinematics` (+radial tilt moves the tip to -r).
The rod's own motion is neglected against U (tip speeds are mm/s, U is m/s).
"""

from __future__ import annotations

import math
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from whisker.sim.graph import Effect
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad


class AirflowSpec(BaseModel):
    """The scene's ``[airflow]`` section (no flow by default)."""
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    speed_m_s: float = Field(0.0, ge=0, le=100, description="m/s, mean flow speed (0: no airflow effect)")
    turbulence: float = Field(0.3, ge=0, le=3, description="std of the speed fluctuation / mean speed")
    direction_deg: float = Field(0.0, description="deg, flow heading in the sensor's x-y plane from +x")
    integral_time_s: float = Field(0.05, gt=0, le=60, description="s, correlation time of the fluctuation")
    coherence: float = Field(0.5, ge=0, le=1, description="share of the fluctuation common to all whiskers")
    drag_coefficient: float = Field(1.1, gt=0, le=5, description="C_d of the rod in cross flow")
    air_density_kg_m3: float = Field(1.2, gt=0, le=2000, description="kg/m^3 (air 1.2; water 1000)")
    start_s: float = Field(0.0, ge=0, description="s, the flow starts (a gust)")
    stop_s: float | None = Field(None, gt=0, description="s, the flow stops (default: never)")

    def blowing(self, t_s: float) -> bool:
        return self.on and t_s >= self.start_s and (self.stop_s is None or t_s < self.stop_s)

    @property
    def on(self) -> bool:
        return self.speed_m_s > 0


def lever_m2(design) -> float:
    """(L^2 - a^2) / 2 in m^2: the drag torque per unit drag-per-length about the pivot."""
    L = design.l_u * 1e-3
    a = design.membrane.thickness / 2 * 1e-3
    return max(L * L - a * a, 0.0) / 2


def mean_torque_Nm(design, spec: AirflowSpec) -> float:
    """Drag torque on one rod at the mean speed (no turbulence), N*m."""
    d = design.whiskers.rod_diameter * 1e-3
    return 0.5 * spec.air_density_kg_m3 * spec.drag_coefficient * d * spec.speed_m_s ** 2 * lever_m2(design)


def effect(spec: AirflowSpec | None, design, stiffness_Nm_rad: float | None = None):
    """The plan entry (whisker.sim.effects.plan.Effect): built when the scene has a flow, with the
    mean tilt it causes."""
    if spec is None or not spec.on:
        return Effect("airflow", False, "no airflow in the scene")
    tau = mean_torque_Nm(design, spec)
    k = stiffness_Nm_rad if stiffness_Nm_rad else design_stiffness_Nmm_per_rad(design) * 1e-3
    when = "" if spec.start_s == 0 and spec.stop_s is None else \
        f" from {spec.start_s:g} s" + ("" if spec.stop_s is None else f" to {spec.stop_s:g} s")
    return Effect("airflow", True,
                  f"flow {spec.speed_m_s:g} m/s{when} at {spec.direction_deg:g} deg, turbulence {spec.turbulence:g}: "
                  f"drag {tau * 1e6:.3g} uN*m per rod at the mean speed = {math.degrees(tau / k):.2g} deg "
                  f"static tilt (C_d {spec.drag_coefficient:g})", needs=("kinematics",))


class AirflowDrag:
    """Drag torques (n, 2) = (radial, tangential) N*m on `n` whiskers, advanced step by step."""

    def __init__(self, design, spec: AirflowSpec, seed: int = 0):
        self.spec = spec
        self.n = design.whiskers.count
        self.rng = np.random.default_rng(seed)
        self._noise = self.rng.standard_normal(self.n + 1)    # stationary start
        d = design.whiskers.rod_diameter * 1e-3
        self._q_per_u2 = 0.5 * spec.air_density_kg_m3 * spec.drag_coefficient * d * lever_m2(design)
        ang = np.radians(np.asarray(design.whisker_angles_deg, dtype=float))
        phi = math.radians(spec.direction_deg)
        u = np.array([math.cos(phi), math.sin(phi)])
        self._f_r = u[0] * np.cos(ang) + u[1] * np.sin(ang)       # flow along each radial axis
        self._f_t = -u[0] * np.sin(ang) + u[1] * np.cos(ang)      # ... and tangential axis

    def speeds(self) -> np.ndarray:
        s = self.spec
        c = s.coherence
        n = math.sqrt(c) * self._noise[0] + math.sqrt(1 - c) * self._noise[1:]
        return s.speed_m_s * (1 + s.turbulence * n)

    def step(self, dt: float) -> None:
        """Advance the fluctuations by dt s (exact Ornstein-Uhlenbeck update)."""
        r = math.exp(-dt / self.spec.integral_time_s)
        self._noise = r * self._noise + math.sqrt(1 - r * r) * self.rng.standard_normal(self._noise.size)

    def torque(self, t_s: float | None = None) -> np.ndarray:
        """Drag torques now; zero outside the spec's start_s..stop_s when `t_s` is given."""
        if t_s is not None and not self.spec.blowing(t_s):
            return np.zeros((self.n, 2))
        U = self.speeds()
        mag = self._q_per_u2 * U * np.abs(U)
        return np.stack([-mag * self._f_r, mag * self._f_t], axis=-1)
