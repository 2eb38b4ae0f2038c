"""The HAT's coil drive: a DRV8833 bridge per two coils, each coil's current read by an INA3221 and held
by a software loop; against the paper's L298N modules, which set a voltage.

Why this drive (numbers from hw/bridges.csv and hw/current_monitors.csv, default design):

- The grasp sets ``actuation.voltage`` = 3 V across a 5.87 ohm coil at 20 C: 0.51 A; the full scale
  (level 1) is the coil rating, ``drive.max_coil_voltage`` / R_c(20 C) = 3.3 / 5.87 = 0.56 A.
- An L298N sets a voltage: its drop spreads 1.9-2.5 V (``drop_V`` min..max at 0.5 A), and the coil's
  copper gains 0.39 %/K, so the current (and the force, which is linear in it) spreads over 25-60 C and
  the datasheet corners by ~18 % (``spread``; benchmarks/results/driver.md).
- A MOSFET bridge (DRV8833: 0.36 ohm typ HS+LS) drops only 0.2 V, but at a fixed voltage the coil's
  temperature still moves the current by 12 %. Its built-in chopper (xISEN trip 160-240 mV over a sense
  resistor) would regulate, but only to +-20 %; the DRV8874/DRV8876 current mirrors to about +-10 %
  below 0.5 A.
- So each coil's current is measured over the DRV8833's sense resistor by an INA3221 (offset 80 uV,
  gain error 0.25 %, both maximum) and the duty is trimmed in software (whisker.drive.current_loop):
  the current then follows the level to the monitor's error plus the 1 % resistor, ~+-1.4 %, whatever
  the coil's temperature. The DRV8833's own chopper stays as a hardware cap: with the sense resistor
  chosen here it trips at 160-240 mV / R_s, above the full scale and below the bridge's 1.5 A rating,
  so a stuck PWM output cannot over-drive a coil.

Level semantics are kept: a level is a fraction of the full-scale "cold-coil volts" (whisker.drive.guard);
on the HAT, level x full scale / R_c(20 C) is the regulated current at any coil temperature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from whisker import coil as _coil
from whisker.coil import driver as _driver

#: Tolerance of the sense resistors (1 %, thick-film current-sense parts).
SENSE_TOLERANCE = 0.01
#: The hardware chopper must not bite below this multiple of the full-scale current.
CHOPPER_MARGIN = 1.1
#: Coil temperatures over which the force error is quoted, C (issue: 25-60 C).
T_RANGE_C = (25.0, 60.0)


class BoardError(ValueError):
    """A design the HAT cannot drive (one-line message naming the limit)."""


def is_hat(design) -> bool:
    return design.driver.type == _driver.HAT


def full_scale_current_A(design) -> float:
    """Level-1 coil current on the HAT, A: the coil rating ``drive.max_coil_voltage`` / R_c(20 C)."""
    return float(design.drive.max_coil_voltage) / float(design.coil.resistance)


def sense_resistance_ohm(design) -> float:
    """Per-coil sense resistor, ohm. ``auto``: the largest E24 value that keeps the full-scale current
    within 95 % of the monitor's shunt range and the bridge's chopper (trip >= vtrip_min / R_s) at least
    ``CHOPPER_MARGIN`` above the full scale: R_s <= min(0.95 V_fs / I_fs, vtrip_min / (1.1 I_fs))."""
    value = design.driver.sense_resistance
    if value != "auto":
        return float(value)
    br = _driver.bridge(design.driver.bridge)
    mon = _driver.monitor(design.driver.current_monitor)
    i_fs = full_scale_current_A(design)
    limit = 0.95 * mon.full_scale_V / i_fs
    if br.regulation == "sense_resistor" and br.vtrip_min:
        limit = min(limit, br.vtrip_min / (CHOPPER_MARGIN * i_fs))
    return _driver.nearest_preferred(limit, "E24", "down")


def chopper_trip_A(design) -> tuple[float, float]:
    """(min, max) current where the bridge's own chopper limits a coil, A (inf when it has none)."""
    br = _driver.bridge(design.driver.bridge)
    if br.regulation != "sense_resistor":
        return (math.inf, math.inf)
    rs = sense_resistance_ohm(design)
    return (br.vtrip_min / (rs * (1 + SENSE_TOLERANCE)), br.vtrip_max / (rs * (1 - SENSE_TOLERANCE)))


def current_error(design, current_A: float) -> float:
    """Largest relative error of the regulated current at ``current_A``: monitor gain error + its offset
    over the shunt voltage + the sense resistor's tolerance (fraction)."""
    mon = _driver.monitor(design.driver.current_monitor)
    rs = sense_resistance_ohm(design)
    i = abs(float(current_A))
    if i == 0:
        return 0.0
    return mon.gain_error + mon.offset_V / (i * rs) + SENSE_TOLERANCE


def check(design) -> None:
    """Refuse a HAT design it cannot drive: one line naming the limit (BoardError)."""
    br = _driver.bridge(design.driver.bridge)
    mon = _driver.monitor(design.driver.current_monitor)
    from whisker.coil.thermal import CoilThermal

    i_fs = full_scale_current_A(design)
    if i_fs > br.max_current_A:
        raise BoardError(f"the coil's full-scale current {i_fs:.3g} A (drive.max_coil_voltage / coil.resistance) "
                         f"is above the {br.name}'s {br.max_current_A:g} A per bridge (hw/bridges.csv)")
    vs = float(design.driver.supply_voltage)
    if not (br.supply_min_V <= vs <= br.supply_max_V):
        raise BoardError(f"driver.supply_voltage = {vs:g} V is outside the {br.name}'s "
                         f"{br.supply_min_V:g}-{br.supply_max_V:g} V (hw/bridges.csv)")
    rs = sense_resistance_ohm(design)
    if i_fs * rs > mon.full_scale_V:
        raise BoardError(f"{i_fs:.3g} A over the {rs:g} ohm sense resistor is {1e3 * i_fs * rs:.0f} mV, beyond the "
                         f"{mon.name}'s {1e3 * mon.full_scale_V:.2f} mV range; lower driver.sense_resistance")
    lo, _hi = chopper_trip_A(design)
    if lo < i_fs:
        raise BoardError(f"the {br.name}'s chopper trips at {lo:.3g} A with {rs:g} ohm, below the full-scale "
                         f"{i_fs:.3g} A; lower driver.sense_resistance")
    t_hot = CoilThermal(design).limit_C
    need = i_fs * (_coil.resistance_ohm(design, t_hot) + rs + br.r_max)
    if vs < need:
        raise BoardError(f"driver.supply_voltage = {vs:g} V cannot push {i_fs:.3g} A through a coil at its "
                         f"{t_hot:.0f} C limit ({need:.2f} V needed with the {br.name}'s drop and the sense resistor)")


def max_coils() -> int:
    """Coils one HAT carries: the current monitors' I2C addresses x channels (INA3221: 4 x 3 = 12)."""
    return max_coils_for(_driver.monitor("INA3221"))


def max_coils_for(mon) -> int:
    return mon.addresses * mon.channels


@dataclass(frozen=True)
class Spread:
    """Coil current at one level over coil temperature and the datasheet corners, A."""

    driver: str
    level: float
    nominal_A: float
    low_A: float
    high_A: float

    @property
    def span(self) -> float:
        """(high - low) / nominal: the force spread, force being linear in the current."""
        return (self.high_A - self.low_A) / self.nominal_A


def spread_hat(design, level: float) -> Spread:
    """The HAT at `level`: the loop holds I = level I_fs at any temperature, to the sensing error."""
    i = level * full_scale_current_A(design)
    e = current_error(design, i)
    return Spread("HAT " + design.driver.bridge + " + " + design.driver.current_monitor, level, i,
                  i * (1 - e), i * (1 + e))


def spread_voltage_drive(design, bridge_name: str, level: float, temps_C=T_RANGE_C) -> Spread:
    """A voltage-setting bridge (PWM duty `level` on the bridge, the design's series resistor when the
    bridge is the design's module): mean current D (Vs - V0 - r I)/(R_c(T) + R_s) over the bridge's
    min..max drop and coil temperatures ``temps_C``; nominal at the typical drop and 20 C."""
    br = _driver.bridge(bridge_name)
    vs = float(design.driver.supply_voltage)
    rs = _driver.series_resistance_ohm(design) if bridge_name == design.driver.type else 0.0
    vals = []
    for corner in ("min", "max"):
        v0, r = {"min": (br.v0_min, br.r_min), "max": (br.v0_max, br.r_max)}[corner]
        for t in temps_C:
            rc = _coil.resistance_ohm(design, t)
            vals.append(level * max(0.0, (vs - v0) / (rc + rs + r)))
    nominal = level * _driver.coil_current_A(br, vs, _coil.resistance_ohm(design, 20.0), rs)
    return Spread(br.name, level, nominal, min(vals), max(vals))



def with_driver(design, driver_type: str):
    """The design with ``driver.type`` replaced (the board and the modules side by side)."""
    if design.driver.type == driver_type:
        return design
    from whisker.design import apply_overrides, design_from_dict

    return design_from_dict(apply_overrides(design.to_dict(), [f'driver.type="{driver_type}"']))


def compare(design, volts: float | None = None, temps_C=T_RANGE_C) -> list[dict]:
    """The grasp (``actuation.voltage`` as cold-coil volts, or `volts`) on the HAT and on the L298N
    modules: coil current and force at the rest gap, nominal and bounds over coil temperature
    (`temps_C`) and the datasheet spread. Force = (force per ampere at the rest gap,
    whisker.coil.magnetics) x current."""
    from whisker.coil import magnetics

    v = float(volts if volts is not None else design.actuation.voltage)
    k = float(magnetics.force_per_ampere_N(design, design.actuation.gap))
    r20 = float(design.coil.resistance)
    rows = []
    hat = with_driver(design, _driver.HAT)
    s_hat = spread_hat(hat, v / (full_scale_current_A(hat) * r20))
    mod = with_driver(design, "L298N")
    br = _driver.bridge("L298N")
    rs = _driver.series_resistance_ohm(mod)
    v_fs = _driver.coil_current_A(br, float(mod.driver.supply_voltage), r20, rs) * r20
    s_mod = spread_voltage_drive(mod, "L298N", v / v_fs, temps_C)
    for s, how in ((s_hat, f"current loop, sense {sense_resistance_ohm(hat):g} ohm"),
                   (s_mod, f"PWM duty {s_mod.level:.3f} + {rs:g} ohm series")):
        rows.append({"driver": s.driver, "how": how, "level": s.level, "current_A": s.nominal_A,
                     "current_low_A": s.low_A, "current_high_A": s.high_A, "force_mN": k * s.nominal_A * 1e3,
                     "force_low_mN": k * s.low_A * 1e3, "force_high_mN": k * s.high_A * 1e3,
                     "spread_pct": 100 * s.span})
    return rows
