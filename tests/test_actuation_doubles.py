"""Helpers shared by the actuation, guard and recording tests (no tests in here).

`coil_model(design)` is the real coil model (whisker.coil.thermal_network / whisker.coil), used by most tests.
`DoubleThermal` / `double_current_A` are test doubles with the same call signatures (a lumped coil:
heat capacity C, thermal resistance to ambient Rth, copper resistance rising 0.393 %/K), used only
where a test needs what the real coil cannot give: a coil that heats `speedup` times faster (so a
real-time watchdog test trips in under a second), a model that returns NaN, or round numbers.
"""

from __future__ import annotations

import numpy as np

ALPHA_CU = 0.00393  # 1/K, copper


def double_current_A(design, volts_at_coil, temperature_C=20.0):
    """V / R(T), R(20 C) = coil.resistance (test double of whisker.coil.current_A)."""
    r = design.coil.resistance * (1.0 + ALPHA_CU * (temperature_C - 20.0))
    return volts_at_coil / r


class DoubleThermal:
    """Test double of whisker.coil.thermal.CoilThermal: C dT/dt = I^2 R(T) - (T - Ta) / Rth (exact step
    for a frozen R over dt)."""

    def __init__(self, design, heat_capacity_J_per_K=0.1, rth_K_per_W=60.0, speedup=1.0):
        self.design = design
        self.ambient_C = design.thermal.ambient
        from whisker.coil.thermal_materials import limit_C
        self.limit_C = min(limit_C(design, "mount"), limit_C(design, "magnet"), limit_C(design, "enamel"))
        self.c = heat_capacity_J_per_K / speedup
        self.rth = rth_K_per_W

    def step(self, temperature_C, current_A, dt_s):
        r = self.design.coil.resistance * (1.0 + ALPHA_CU * (temperature_C - 20.0))
        p = current_A ** 2 * r
        t_inf = self.ambient_C + p * self.rth
        tau = self.rth * self.c
        return t_inf + (temperature_C - t_inf) * np.exp(-dt_s / tau)


def coil_model(design):
    """(thermal, current_fn): the real coil model (whisker.coil.thermal_network.ThermalNetwork, the
    guard's default, and whisker.coil.current_A)."""
    from whisker.coil import current_A
    from whisker.coil.thermal_network import ThermalNetwork

    return ThermalNetwork(design), current_A


class FakeClock:
    """A clock the test moves by hand (seconds)."""

    def __init__(self, t=0.0):
        self.t = float(t)

    def __call__(self):
        return self.t

    def advance(self, dt):
        self.t += dt
        return self.t
