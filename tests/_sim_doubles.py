"""Test doubles for the contract modules the simulator calls (notes/contracts.md), used ONLY when
the real module (issue 4: whisker.coil, whisker.coil.magnetics, whisker.coil.thermal) is not installed yet.
Numbers follow DESIGN.md section 2 (k(gap) ~0.23/0.084/0.016 N/A at 0.5/2/5 mm, ~7 ohm, 0.23 g Cu).
"""

from __future__ import annotations

import importlib
import sys
import types

import numpy as np


def _magnetics():
    m = types.ModuleType("whisker.coil.magnetics")

    def force_per_ampere_N(design, gap_mm, model="table"):
        g = np.asarray(gap_mm, dtype=float)
        return 11.7 / (g + 3.19) ** 3
    m.force_per_ampere_N = force_per_ampere_N
    return m


def _coil():
    m = types.ModuleType("whisker.coil")

    def resistance_ohm(design, temperature_C=20.0):
        return design.coil.resistance * (1 + 0.00393 * (np.asarray(temperature_C, dtype=float) - 20.0))

    def current_A(design, volts_at_coil, temperature_C=20.0):
        return np.asarray(volts_at_coil, dtype=float) / resistance_ohm(design, temperature_C)

    class W:
        copper_mass_g = 0.23
    m.resistance_ohm = resistance_ohm
    m.current_A = current_A
    m.winding = lambda design: W()
    return m


def _thermal():
    m = types.ModuleType("whisker.coil.thermal")

    class CoilThermal:
        def __init__(self, design):
            self.design = design
            self.ambient_C = design.thermal.ambient
            self.limit_C = design.thermal.pla_softening

        def step(self, temperature_C, current_A, dt_s):
            R = self.design.coil.resistance * (1 + 0.00393 * (temperature_C - 20.0))
            C, h = 0.23 * 0.385, 0.01
            return temperature_C + dt_s * (current_A ** 2 * R - h * (temperature_C - self.ambient_C)) / C
    m.CoilThermal = CoilThermal
    return m


def install() -> list[str]:
    """Install a double for each contract module that is missing; return the names installed."""
    done = []
    for name, make in (("whisker.coil.magnetics", _magnetics), ("whisker.coil", _coil), ("whisker.coil.thermal", _thermal)):
        try:
            importlib.import_module(name)
        except ImportError:
            sys.modules[name] = make()
            done.append(name)
    return done
