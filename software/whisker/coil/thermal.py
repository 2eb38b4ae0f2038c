"""Lumped thermal model of one coil: temperature against time, time to the first limit, safe duty.

One node (copper + enamel + the core in the bore, the carbon-fibre rod) at temperature T:

    C dT/dt = I^2 R(T) - h A (T - Ta) - eps sigma A (T^4 - Ta^4) - G_rod (T - Ta)

R(T) = R20 (1 + 0.00393 (T - 20)) (copper, IEC 60028). Driven at constant VOLTAGE the power falls as
the coil warms (V^2/R(T)); at constant CURRENT it rises (thermal runaway is possible). A = the
coil's outer surface (side + both annular faces), h = [thermal] convection_coefficient,
eps = [thermal] emissivity, G_rod = [thermal] rod_conductance. Skipped (Principle 3): the gradient
inside the winding (Biot number h*r/k_winding ~ 1e-3, negligible), heating of the surroundings.

This is the cheap one-node variant, kept for the accuracy-vs-cost benchmark (benchmarks/bench_thermal.py);
the guard, the report, the simulator and the explorer use the thermal network
(whisker.coil.thermal_network), which has a node per part and every material's own limit.

Limits ("whichever is lowest"): the magnet's maximum working temperature, PLA softening, the
enamel's thermal class (hw/materials/thermal.csv via whisker.coil.thermal_materials.limit_C). They are applied to the COIL temperature: conservative for the magnet and the PLA,
which sit across the gap and warm more slowly than the coil.

Heat capacity and resistance follow the design's measured resistance by default: the wire length is
R / (ohm per m), so a coil that measures 7 ohm has the copper of 7 ohm of wire.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker import coil as _coil

SIGMA = 5.670374419e-8  # W/(m^2 K^4), Stefan-Boltzmann
KELVIN = 273.15
CONVECTION_MODELS = ("constant", "churchill_chu")


def churchill_chu_h(diameter_mm: float, surface_C, ambient_C: float):
    """Natural-convection coefficient of a horizontal cylinder in air, W/(m^2 K), vectorised.

    Churchill & Chu (1975): Nu = (0.60 + 0.387 Ra^(1/6) / (1 + (0.559/Pr)^(9/16))^(8/27))^2, with
    air properties at the film temperature from power-law fits to Incropera's Table A.4 (k = 0.0241
    (Tf/273.15)^0.81 W/(m K), nu = 1.33e-5 (Tf/273.15)^1.75 m^2/s, Pr = 0.71, beta = 1/Tf).
    At zero temperature difference it returns the conduction limit (Ra = 0).
    """
    D = diameter_mm * 1e-3
    Ts = np.asarray(surface_C, dtype=float)
    tf = (Ts + ambient_C) / 2.0 + KELVIN
    k = 0.0241 * (tf / KELVIN) ** 0.81
    nu = 1.33e-5 * (tf / KELVIN) ** 1.75
    pr = 0.71
    ra = 9.81 * np.abs(Ts - ambient_C) / tf * D ** 3 / (nu * nu / pr)
    nu_d = (0.60 + 0.387 * ra ** (1.0 / 6.0) / (1.0 + (0.559 / pr) ** (9.0 / 16.0)) ** (8.0 / 27.0)) ** 2
    return nu_d * k / D


@dataclass(frozen=True)
class Limits:
    magnet_C: float
    pla_C: float
    enamel_C: float

    @property
    def lowest(self) -> tuple[str, float]:
        items = {"magnet max temperature": self.magnet_C, "PLA softening": self.pla_C,
                 "enamel class": self.enamel_C}
        name = min(items, key=items.get)
        return name, items[name]


class CoilThermal:
    """Lumped coil thermal model built from a design. Units: C, A, s, W, J/K."""

    def __init__(self, design, source: str = "measured", convection: str = "constant"):
        c, th = design.coil, design.thermal
        self.design = design
        self.source = source
        self.ambient_C = float(th.ambient)
        from whisker.coil.thermal_materials import limit_C
        self.limits = Limits(limit_C(design, "magnet"), limit_C(design, "mount"), limit_C(design, "enamel"))
        self.limit_name, self.limit_C = self.limits.lowest
        self.r20_ohm = float(_coil.resistance_ohm(design, 20.0, source=source))
        d = c.wire_diameter
        a_cu = math.pi * d * d / 4.0
        length_mm = self.r20_ohm / _coil.ohm_per_m(d) * 1000.0
        do = _coil.enamel_overall_diameter_mm(d, design.winding.enamel_grade)
        self.copper_mass_g = length_mm * a_cu * _coil.COPPER_DENSITY_G_CM3 / 1000.0
        enamel_mass = length_mm * math.pi * (do * do - d * d) / 4.0 * _coil.ENAMEL_DENSITY_G_CM3 / 1000.0
        core_mass = math.pi * (c.inner_diameter / 2.0) ** 2 * c.length * design.mechanics.rod_density / 1000.0
        self.heat_capacity_J_per_K = (self.copper_mass_g * _coil.COPPER_SPECIFIC_HEAT
                                      + enamel_mass * _coil.ENAMEL_SPECIFIC_HEAT
                                      + core_mass * th.former_specific_heat)
        ro, ri = c.outer_diameter / 2.0, c.inner_diameter / 2.0
        self.area_m2 = (2.0 * math.pi * ro * c.length + 2.0 * math.pi * (ro * ro - ri * ri)) * 1e-6
        self.h = float(th.convection_coefficient)
        if convection not in CONVECTION_MODELS:
            raise ValueError(f"convection must be one of {', '.join(CONVECTION_MODELS)} (got {convection!r})")
        self.convection = convection
        self.diameter_mm = float(c.outer_diameter)
        self.emissivity = float(th.emissivity)
        self.g_rod = float(th.rod_conductance)

    # ---- physics ----------------------------------------------------------------------------
    def resistance(self, T):
        return self.r20_ohm * _coil.temperature_factor(T)

    def loss_W(self, T):
        """Heat leaving the coil at temperature T, W (convection + radiation + rod)."""
        T = np.asarray(T, dtype=float)
        ta = self.ambient_C
        rad = self.emissivity * SIGMA * self.area_m2 * ((T + KELVIN) ** 4 - (ta + KELVIN) ** 4)
        return (self.h_at(T) * self.area_m2 + self.g_rod) * (T - ta) + rad

    def h_at(self, T):
        """Convection coefficient at coil temperature T, W/(m^2 K) (constant or Churchill-Chu)."""
        if self.convection == "constant":
            return self.h
        return churchill_chu_h(self.diameter_mm, T, self.ambient_C)

    def conductance_W_per_K(self, T):
        """dLoss/dT at T, W/K."""
        T = np.asarray(T, dtype=float)
        return self.h_at(T) * self.area_m2 + self.g_rod + 4.0 * self.emissivity * SIGMA * self.area_m2 * (T + KELVIN) ** 3

    @property
    def time_constant_s(self) -> float:
        """Cooling time constant near ambient, s (C / G)."""
        if not hasattr(self, "_tau"):
            self._tau = self.heat_capacity_J_per_K / float(self.conductance_W_per_K(self.ambient_C))
        return self._tau

    def _rate(self, T, power):
        return (power - self.loss_W(T)) / self.heat_capacity_J_per_K

    def step(self, temperature_C: float, current_A: float, dt_s: float) -> float:
        """Temperature after dt_s at a constant current, C. Exponential-Euler sub-steps (exact for
        the linearised ODE), stable for any dt; refuses non-finite or negative inputs."""
        T, I, dt = float(temperature_C), float(current_A), float(dt_s)
        if not (math.isfinite(T) and math.isfinite(I) and math.isfinite(dt)) or dt < 0:
            raise ValueError(f"CoilThermal.step: need finite temperature/current and dt >= 0 "
                             f"(got {temperature_C!r}, {current_A!r}, {dt_s!r})")
        if dt == 0.0:
            return T
        n = max(1, int(math.ceil(dt / (0.1 * self.time_constant_s))))
        h = dt / n
        C = self.heat_capacity_J_per_K
        # scalar arithmetic (no numpy): the simulator and the guard call this in their loops
        r20, alpha, ta = self.r20_ohm, _coil.ALPHA20_PER_K, self.ambient_C
        cc = self.convection != "constant"
        g_lin = self.h * self.area_m2 + self.g_rod
        g_rad = self.emissivity * SIGMA * self.area_m2
        ta4 = (ta + KELVIN) ** 4
        i2 = I * I
        for _ in range(n):
            if cc:  # h(T) frozen over the sub-step
                g_lin = float(churchill_chu_h(self.diameter_mm, T, ta)) * self.area_m2 + self.g_rod
            tk = T + KELVIN
            p = i2 * r20 * (1.0 + alpha * (T - 20.0))
            a = (p - g_lin * (T - ta) - g_rad * (tk ** 4 - ta4)) / C          # dT/dt at T
            b = (i2 * r20 * alpha - g_lin - 4.0 * g_rad * tk ** 3) / C       # d(dT/dt)/dT
            x = b * h
            if abs(x) < 1e-8:
                T = T + a * h
            else:
                T = T + a * math.expm1(min(x, 50.0)) / b
            T = min(max(T, -KELVIN + 1.0), 5000.0)  # physically meaningless beyond; keeps runaway finite
        return T

    def step_voltage(self, temperature_C: float, volts: float, dt_s: float, duty: float = 1.0) -> float:
        """Temperature after dt_s at a constant voltage across the coil and a PWM duty (mean power
        duty * V^2/R(T); valid for PWM periods << the thermal time constant)."""
        T, dt = float(temperature_C), float(dt_s)
        n = max(1, int(math.ceil(dt / (0.05 * self.time_constant_s))))
        h = dt / n
        for _ in range(n):
            i_rms = math.sqrt(duty) * volts / float(self.resistance(T))
            T = self.step(T, i_rms, h)
        return T

    # ---- answers ----------------------------------------------------------------------------
    def steady_state_C(self, volts: float, duty: float = 1.0) -> float:
        """Steady temperature at a constant voltage and duty, C."""
        from scipy.optimize import brentq

        def f(T):
            return duty * volts * volts / float(self.resistance(T)) - float(self.loss_W(T))

        if volts == 0 or duty == 0:
            return self.ambient_C
        return float(brentq(f, self.ambient_C, 5000.0))

    def temperature_curve(self, volts: float, t_end_s: float, duty: float = 1.0, points: int = 400):
        """(t_s, T_C) arrays at constant voltage from ambient."""
        t = np.linspace(0.0, float(t_end_s), int(points))
        T = np.empty_like(t)
        T[0] = self.ambient_C
        for i in range(1, len(t)):
            T[i] = self.step_voltage(T[i - 1], volts, t[i] - t[i - 1], duty)
        return t, T

    def time_to_C(self, target_C: float, volts: float, duty: float = 1.0) -> float:
        """Seconds at constant voltage from ambient until the coil reaches target_C (math.inf if never).

        t = C * integral of dT / (P(T) - loss(T)) from ambient to target_C (adaptive quadrature,
        scipy ``quad``; the integrand grows without bound only as the target nears the steady state).
        """
        from scipy.integrate import quad

        if target_C <= self.ambient_C:
            return 0.0
        if self.steady_state_C(volts, duty) <= target_C:
            return math.inf

        def inv_rate(T):
            return 1.0 / (duty * volts * volts / float(self.resistance(T)) - float(self.loss_W(T)))

        val, _ = quad(inv_rate, self.ambient_C, target_C, epsrel=1e-10, limit=200)
        return float(self.heat_capacity_J_per_K * val)

    def safe_duty(self, volts: float, margin_C: float = 0.0) -> float:
        """Highest PWM duty (0..1) whose steady temperature stays at the lowest limit minus margin_C."""
        t_lim = self.limit_C - margin_C
        if t_lim <= self.ambient_C:
            return 0.0
        if volts == 0:
            return 1.0
        d = float(self.loss_W(t_lim)) * float(self.resistance(t_lim)) / (volts * volts)
        return min(1.0, d)


def time_to_limit_s(design, volts: float, duty: float = 1.0) -> float:
    """Seconds at `volts` across the coil from ambient until the lowest thermal limit (inf if never)."""
    th = CoilThermal(design)
    return th.time_to_C(th.limit_C, volts, duty)


def safe_duty(design, volts: float) -> float:
    """Highest continuous PWM duty at `volts` that keeps the coil at or below the lowest limit."""
    return CoilThermal(design).safe_duty(volts)


def summary(design, volts: float) -> dict:
    """Everything the report prints about heating at `volts` (finite numbers or None for 'never')."""
    th = CoilThermal(design)
    times = {}
    for name, lim in (("magnet", th.limits.magnet_C), ("pla", th.limits.pla_C), ("enamel", th.limits.enamel_C)):
        t = th.time_to_C(lim, volts)
        times[name] = None if math.isinf(t) else t
    t_first = th.time_to_C(th.limit_C, volts)
    return {
        "volts": volts, "ambient_C": th.ambient_C, "limit_C": th.limit_C, "limit": th.limit_name,
        "heat_capacity_J_per_K": th.heat_capacity_J_per_K, "copper_mass_g": th.copper_mass_g,
        "surface_mm2": th.area_m2 * 1e6, "conductance_W_per_K": float(th.conductance_W_per_K(th.ambient_C)),
        "time_constant_s": th.time_constant_s,
        "power_cold_W": volts * volts / float(th.resistance(th.ambient_C)),
        "heating_rate_cold_K_per_s": volts * volts / float(th.resistance(th.ambient_C)) / th.heat_capacity_J_per_K,
        "steady_state_C": th.steady_state_C(volts),
        "time_to_first_limit_s": None if math.isinf(t_first) else t_first,
        "time_to_limit_s": times,
        "safe_duty": th.safe_duty(volts),
    }
