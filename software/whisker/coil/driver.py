"""Coil drivers: H-bridge voltage drops, the supply a coil voltage needs, dividers and PWM.

Bridge models (datasheet numbers, typical unless a ``corner="max"`` is asked for):

``L298N`` (ST L298 datasheet, "Dual full-bridge driver", electrical characteristics): bipolar, so the
drop does not vanish at low current. Source saturation V_CEsat(H) = 1.35 V typ / 1.7 V max at 1 A,
2.0 / 2.7 V at 2 A; sink V_CEsat(L) = 1.2 / 1.6 V at 1 A, 1.7 / 2.3 V at 2 A. Each is modelled as a
line through its 1 A and 2 A points (V0 + r I): total typ 1.40 V + 1.15 ohm * I (1.9 V at 0.43 A),
max 1.60 V + 1.70 ohm * I. 2 A DC per bridge, supply 4.5 (logic 5 V) to 46 V.
``TB6612FNG`` (Toshiba datasheet): MOSFET, output on-resistance upper + lower 0.5 ohm typ
(0.7 max assumed), 1.2 A average per channel, VM 2.5-13.5 V.
``DRV8833`` (TI datasheet SLVSAR1): MOSFET, HS + LS on-resistance 360 mOhm typ at VM = 5 V (0.45
max assumed), 1.5 A RMS per H-bridge (with good copper), VM 2.7-10.8 V.

Drive methods for a coil voltage below what the bridge gives:
- series resistor (the "divider" with no shunt): current I = (Vs - V0)/(Rc + r + Rs);
- divider (series R1 from the bridge, shunt R2 across the coil, as in the paper): the coil is part of
  the divider, so its voltage follows its resistance (it warms by 14 % from 20 to 55 C) and the
  shunt wastes power; it regulates only when R2 << Rc;
- PWM on the bridge: mean current D * V/R, so force follows the duty; but the coil heats with the
  RMS current: at the same mean current PWM heats the coil 1/D times more than a steady current.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from whisker import coil as _coil

E24 = (1.0, 1.1, 1.2, 1.3, 1.5, 1.6, 1.8, 2.0, 2.2, 2.4, 2.7, 3.0, 3.3, 3.6, 3.9, 4.3, 4.7, 5.1, 5.6,
       6.2, 6.8, 7.5, 8.2, 9.1)
E96 = tuple(round(10 ** (i / 96.0), 2) for i in range(96))  # IEC 60063: 1.00, 1.02, 1.05, ... 9.76


class DriverError(ValueError):
    """An impossible drive request; the one-line message says what and why."""


BRIDGE_TABLE = "bridges.csv"        # hw/bridges.csv: one row per H-bridge IC, each naming its datasheet
MONITOR_TABLE = "current_monitors.csv"  # hw/current_monitors.csv: I2C current monitors


def _rows(name: str) -> list[dict]:
    import csv

    from whisker.resources import hw_dir

    with open(hw_dir() / name, newline="") as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def _opt(v: str) -> float | None:
    return float(v) if v.strip() else None


@dataclass(frozen=True)
class Bridge:
    """One row of hw/bridges.csv: an H-bridge IC. Drops are for both conducting switches,
    ``v0 + r I`` at the min / typ / max corner (V, ohm); currents per bridge (A)."""

    name: str
    kind: str              # "bipolar" or "mosfet"
    v0_typ: float          # V, total drop at zero current (both switches)
    r_typ: float           # ohm, total slope
    v0_max: float
    r_max: float
    max_current_A: float
    supply_min_V: float
    supply_max_V: float
    source: str
    channels: int = 2
    peak_current_A: float = 0.0
    v0_min: float = 0.0
    r_min: float = 0.0
    regulation: str = "none"         # none | sense_resistor | ipropi
    vtrip_min: float | None = None   # V (sense_resistor) or fraction (ipropi)
    vtrip_typ: float | None = None
    vtrip_max: float | None = None
    tsd_C: float = 150.0             # C, thermal shutdown (minimum)
    package: str = ""

    def drop_V(self, current_A: float, corner: str = "typ") -> float:
        i = abs(float(current_A))
        try:
            v0, r = {"typ": (self.v0_typ, self.r_typ), "max": (self.v0_max, self.r_max),
                     "min": (self.v0_min, self.r_min)}[corner]
        except KeyError:
            raise DriverError(f"corner must be 'min', 'typ' or 'max' (got {corner!r})") from None
        return (v0 + r * i) if i > 0 else 0.0


def _bridge(row: dict) -> Bridge:
    return Bridge(name=row["name"], kind=row["kind"], v0_typ=float(row["v0_typ_V"]), r_typ=float(row["r_typ_ohm"]),
                  v0_max=float(row["v0_max_V"]), r_max=float(row["r_max_ohm"]),
                  max_current_A=float(row["max_current_A"]), supply_min_V=float(row["supply_min_V"]),
                  supply_max_V=float(row["supply_max_V"]), source=row["source"], channels=int(row["channels"]),
                  peak_current_A=float(row["peak_current_A"]), v0_min=float(row["v0_min_V"]),
                  r_min=float(row["r_min_ohm"]), regulation=row["regulation"], vtrip_min=_opt(row["vtrip_min"]),
                  vtrip_typ=_opt(row["vtrip_typ"]), vtrip_max=_opt(row["vtrip_max"]), tsd_C=float(row["tsd_C"]),
                  package=row["package"])


@dataclass(frozen=True)
class Monitor:
    """One row of hw/current_monitors.csv: an I2C current monitor (shunt-voltage ADC)."""

    name: str
    channels: int
    addresses: int
    offset_V: float      # V, shunt offset (max)
    gain_error: float    # fraction (max)
    full_scale_V: float  # V, +- shunt range
    lsb_V: float
    supply_min_V: float
    supply_max_V: float
    package: str
    source: str


def _monitor(row: dict) -> Monitor:
    return Monitor(name=row["name"], channels=int(row["channels"]), addresses=int(row["addresses"]),
                   offset_V=float(row["offset_V"]), gain_error=float(row["gain_error"]),
                   full_scale_V=float(row["full_scale_V"]), lsb_V=float(row["lsb_V"]),
                   supply_min_V=float(row["supply_min_V"]), supply_max_V=float(row["supply_max_V"]),
                   package=row["package"], source=row["source"])


BRIDGES = {r["name"]: _bridge(r) for r in _rows(BRIDGE_TABLE)}
MONITORS = {r["name"]: _monitor(r) for r in _rows(MONITOR_TABLE)}

#: driver.type of the generated Raspberry Pi HAT (hw/pcb): its bridge is driver.bridge (whisker.coil.board).
HAT = "HAT"


def bridge(name: str) -> Bridge:
    """The bridge called `name` (a row of hw/bridges.csv)."""
    try:
        return BRIDGES[name]
    except KeyError:
        raise DriverError(f"unknown driver {name!r}: no such bridge in hw/bridges.csv; known: {', '.join(BRIDGES)}") from None


def design_bridge(design) -> Bridge:
    """The bridge a design drives its coils with: driver.bridge on the HAT, else driver.type (a module)."""
    if design.driver.type == HAT:
        return bridge(design.driver.bridge)
    return bridge(design.driver.type)


def monitor(name: str) -> Monitor:
    try:
        return MONITORS[name]
    except KeyError:
        raise DriverError(f"unknown current monitor {name!r}; known: {', '.join(MONITORS)} "
                          "(hw/current_monitors.csv)") from None


def coil_current_A(bridge_: Bridge, supply_V: float, coil_ohm: float, series_ohm: float = 0.0,
                   corner: str = "typ") -> float:
    """Steady current through coil + series resistor from a bridge at supply_V, A (>= 0)."""
    v0 = bridge_.v0_typ if corner == "typ" else bridge_.v0_max
    r = bridge_.r_typ if corner == "typ" else bridge_.r_max
    return max(0.0, (supply_V - v0) / (coil_ohm + series_ohm + r))


def series_resistance_ohm(design) -> float:
    """The series resistor per coil of the design, ohm (``driver.series_resistance``; 0 = none).

    ``"auto"``: the smallest E24 value such that a cold (20 C) coil gets at most
    ``drive.max_coil_voltage`` at 100 % duty with the bridge's typical drop (the driver model of
    :func:`whisker.drive.guard.full_scale_voltage`): I = (Vs - V0)/(Rc + Rs + r) <= Vmax/Rc gives
    Rs >= Rc (Vs - V0)/Vmax - Rc - r, rounded up to E24; 0 when the bare bridge already stays within
    the rating (default design: 5.872 x 6.1/3.3 - 7.022 = 3.83 -> 3.9 ohm).
    """
    value = design.driver.series_resistance
    if design.driver.type == HAT:
        return 0.0  # the HAT regulates each coil's current: no series resistor
    if value != "auto":
        return float(value)
    return auto_series_resistance_ohm(bridge(design.driver.type), float(design.driver.supply_voltage),
                                      float(design.coil.resistance), float(design.drive.max_coil_voltage))


def auto_series_resistance_ohm(bridge_: Bridge, supply_V: float, coil_ohm: float, max_coil_V: float,
                               series: str = "E24") -> float:
    """Smallest preferred series resistor keeping coil_ohm at <= max_coil_V fully on, ohm (0 if none needed).

    Typical bridge corner: the lower drop of the two corners, so the larger coil voltage.
    """
    if not (coil_ohm > 0 and max_coil_V > 0 and math.isfinite(supply_V)):
        raise DriverError(f"series resistor needs a positive coil resistance and rating (got {coil_ohm!r} ohm, "
                          f"{max_coil_V!r} V)")
    exact = coil_ohm * (supply_V - bridge_.v0_typ) / max_coil_V - coil_ohm - bridge_.r_typ
    # a difference of nearly equal terms: within rounding of them, the bare bridge is exactly at the rating
    if exact <= 1e-12 * (coil_ohm + bridge_.r_typ):
        return 0.0
    rs = nearest_preferred(exact, series, "up")
    # guard against rounding: the chosen value must keep the coil within the rating
    while coil_current_A(bridge_, supply_V, coil_ohm, rs) * coil_ohm > max_coil_V * (1 + 1e-12):
        rs = nearest_preferred(rs * 1.0001, series, "up")
    return rs


POWER_RATINGS_W = (0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 25.0, 50.0)  # common resistor ratings (25/50 W:
                                                                      # aluminium-housed wirewound)
RESISTOR_LOAD = 0.6  # largest fraction of the rating used: metal-oxide/film resistors derate linearly
                     # from 100 % at 70 C ambient to 0 near 200 C, so 60 % holds up to ~120 C ambient


def resistor_rating_W(power_W: float) -> float:
    """Smallest common power rating that carries power_W at <= RESISTOR_LOAD of its rating, W."""
    if not (math.isfinite(power_W) and power_W >= 0):
        raise DriverError(f"resistor power must be a finite number >= 0 (got {power_W!r} W)")
    for r in POWER_RATINGS_W:
        if power_W <= RESISTOR_LOAD * r:
            return r
    raise DriverError(f"{power_W:.3g} W in the series resistor needs more than a {POWER_RATINGS_W[-1]:g} W part; "
                      f"lower the supply or use PWM without a resistor")


def resistor_power_W(design, temperature_C: float = 20.0) -> float:
    """Heat in one coil's series resistor at 100 % duty (steady), W; cold coil = the largest current."""
    rs = series_resistance_ohm(design)
    if rs == 0:
        return 0.0
    rc = _coil.resistance_ohm(design, temperature_C)
    i = coil_current_A(design_bridge(design), float(design.driver.supply_voltage), rc, rs)
    return i * i * rs


def supply_for_coil_voltage(bridge_: Bridge, coil_V: float, coil_ohm: float, corner: str = "typ") -> float:
    """Supply voltage that puts coil_V across the coil directly on the bridge, V."""
    return coil_V + bridge_.drop_V(coil_V / coil_ohm, corner)


def nearest_preferred(value: float, series: str = "E24", mode: str = "nearest") -> float:
    """Nearest preferred value (E24 or E96), 'nearest', 'up' (>= value) or 'down' (<= value)."""
    if not (math.isfinite(value) and value > 0):
        raise DriverError(f"no preferred value for {value!r} ohm (needs a positive resistance)")
    base = {"E24": E24, "E96": E96}.get(series)
    if base is None:
        raise DriverError(f"series must be E24 or E96 (got {series!r})")
    dec = math.floor(math.log10(value))
    cands = sorted(b * 10 ** e for e in (dec - 1, dec, dec + 1) for b in base)
    if mode == "up":
        return min(c for c in cands if c >= value * (1 - 1e-12))
    if mode == "down":
        return max(c for c in cands if c <= value * (1 + 1e-12))
    return min(cands, key=lambda c: abs(math.log(c / value)))


@dataclass(frozen=True)
class DrivePlan:
    method: str
    detail: str
    coil_V_cold: float
    current_cold_A: float
    current_hot_A: float          # at the lowest thermal limit temperature
    force_change_hot_pct: float   # current (= force) change from 20 C to the limit
    coil_heat_W: float            # mean heat in the coil, cold
    wasted_W: float               # heat in resistors/bridge, cold
    warning: str = ""

    def to_dict(self) -> dict:
        return asdict(self)


def plan(design, target_coil_V: float | None = None, driver: str | None = None,
         supply_V: float | None = None, series: str = "E24") -> dict:
    """Ways to get `target_coil_V` (default [actuation] voltage) across the coil from the bridge.

    Returns the bridge drop, the supply needed for direct drive, and DrivePlans for direct drive,
    series resistor, the paper's divider and PWM, each with its cold/hot current.
    """
    br = bridge(driver) if driver else design_bridge(design)
    vs = float(supply_V if supply_V is not None else design.driver.supply_voltage)
    vt = float(target_coil_V if target_coil_V is not None else design.actuation.voltage)
    if not (vt > 0 and math.isfinite(vt)):
        raise DriverError(f"target coil voltage must be positive (got {vt!r})")
    rc = _coil.resistance_ohm(design, 20.0)
    from whisker.coil.thermal_network import ThermalNetwork

    t_hot = ThermalNetwork(design).winding_limit_C
    rh = _coil.resistance_ohm(design, t_hot)
    i_t = vt / rc
    out = {"driver": br.name, "driver_source": br.source, "supply_V": vs, "target_coil_V": vt,
           "coil_ohm_20C": rc, "coil_ohm_hot": rh, "hot_C": t_hot, "target_current_A": i_t,
           "bridge_drop_V": br.drop_V(i_t), "bridge_drop_max_V": br.drop_V(i_t, "max"),
           "supply_for_direct_V": supply_for_coil_voltage(br, vt, rc),
           "supply_for_direct_max_V": supply_for_coil_voltage(br, vt, rc, "max"), "plans": [], "warnings": []}
    if i_t > br.max_current_A:
        out["warnings"].append(f"{i_t:.2f} A exceeds the {br.name}'s {br.max_current_A:g} A rating")
    if not (br.supply_min_V <= vs <= br.supply_max_V):
        out["warnings"].append(f"supply {vs:g} V is outside the {br.name}'s {br.supply_min_V:g}-{br.supply_max_V:g} V range")
    # full-on voltage available at the coil
    i_full = coil_current_A(br, vs, rc)
    v_full = i_full * rc
    out["coil_V_full_on"] = v_full
    plans = []
    i_full_hot = coil_current_A(br, vs, rh)
    plans.append(DrivePlan("direct", f"bridge fully on at {vs:g} V", v_full, i_full, i_full_hot,
                           100 * (i_full_hot / i_full - 1), i_full ** 2 * rc, i_full * br.drop_V(i_full)))
    if v_full < vt:
        out["warnings"].append(
            f"the {br.name} at {vs:g} V gives only {v_full:.2f} V at the coil (drop {br.drop_V(i_full):.2f} V); "
            f"{out['supply_for_direct_V']:.2f} V supply needed for {vt:g} V")
    else:
        # series resistor
        rs_exact = (vs - br.v0_typ) / i_t - rc - br.r_typ
        rs = nearest_preferred(rs_exact, series, "up") if rs_exact > 0 else 0.0
        i_c, i_h = coil_current_A(br, vs, rc, rs), coil_current_A(br, vs, rh, rs)
        plans.append(DrivePlan("series", f"series resistor alone (no PWM): {rs:g} ohm ({series}; exact {rs_exact:.3g}) "
                                         f"would give {vt:g} V fully on; not the design's drive (pwm+series below)",
                               i_c * rc, i_c, i_h, 100 * (i_h / i_c - 1), i_c ** 2 * rc,
                               i_c ** 2 * rs + i_c * br.drop_V(i_c)))
        # the paper's divider: R1 in series, R2 across the coil; pick R2 = coil/2 ... show regulation
        for shunt_ratio in (1.0, 0.1):
            r2 = nearest_preferred(rc * shunt_ratio, series)
            plans.append(_divider_plan(br, vs, vt, rc, rh, r2, series))
        # PWM
        duty = vt / v_full
        i_mean = duty * i_full
        i_mean_hot = duty * i_full_hot
        plans.append(DrivePlan("pwm", f"PWM duty {duty:.3f} (mean current {i_mean:.3f} A)", vt, i_mean,
                               i_mean_hot, 100 * (i_mean_hot / i_mean - 1), duty * i_full ** 2 * rc,
                               duty * i_full * br.drop_V(i_full),
                               warning=f"the coil heats {1 / duty:.2f}x more than a steady current of the same "
                                       f"mean (RMS^2 = mean^2 / duty)"))
        # the design's drive: its series resistor (driver.series_resistance) plus PWM for the rest
        rs_d = series_resistance_ohm(design) if driver in (None, design.driver.type) else 0.0
        if rs_d > 0:
            i_c, i_h = coil_current_A(br, vs, rc, rs_d), coil_current_A(br, vs, rh, rs_d)
            v_fs = i_c * rc
            out["design_series_ohm"], out["coil_V_full_on_design"] = rs_d, v_fs
            if v_fs >= vt:
                d_s = vt / v_fs
                plans.append(DrivePlan(
                    "pwm+series", f"the design's drive: {rs_d:g} ohm series resistor (driver.series_resistance, "
                    f"{v_fs:.2f} V at the coil fully on) + PWM duty {d_s:.3f}, heating {1 / d_s:.2f}x a steady "
                    f"current (PWM alone {1 / duty:.2f}x)", vt, d_s * i_c, d_s * i_h,
                    100 * (i_h / i_c - 1), d_s * i_c ** 2 * rc, d_s * (i_c ** 2 * rs_d + i_c * br.drop_V(i_c))))
    out["plans"] = [p.to_dict() for p in plans]
    return out


def _divider_plan(br: Bridge, vs: float, vt: float, rc: float, rh: float, r2: float, series: str) -> DrivePlan:
    """R1 from the bridge output to the coil, R2 across the coil; R1 chosen for vt cold."""
    def coil_v(r1, rcoil):
        rp = r2 * rcoil / (r2 + rcoil)
        # bridge: Vs - V0 - r I = I (r1 + rp)
        i = max(0.0, (vs - br.v0_typ) / (r1 + rp + br.r_typ))
        return i * rp, i

    rp = r2 * rc / (r2 + rc)
    i_tot = vt / rp
    r1_exact = (vs - br.v0_typ) / i_tot - rp - br.r_typ
    warning = ""
    if r1_exact <= 0:
        return DrivePlan("divider", f"R2 = {r2:g} ohm across the coil: no R1 can reach {vt:g} V from {vs:g} V",
                         0.0, 0.0, 0.0, 0.0, 0.0, 0.0, warning="infeasible")
    r1 = nearest_preferred(r1_exact, series, "up")
    vc, itot = coil_v(r1, rc)
    vh, itot_h = coil_v(r1, rh)
    ic, ih = vc / rc, vh / rh
    wasted = itot ** 2 * r1 + (vc ** 2) / r2 + itot * br.drop_V(itot)
    dv = 100 * (vh / vc - 1)
    if r2 > 0.1 * rc:
        warning = (f"a divider into a {rc:.3g} ohm coil does not regulate: the coil is part of it, its voltage "
                   f"changes {dv:+.1f} % as it warms to the limit; a stiff divider needs R2 << {rc:.3g} ohm and "
                   f"wastes {wasted:.2f} W")
    else:
        warning = (f"this stiff divider holds the voltage ({dv:+.1f} %) but wastes {wasted:.2f} W, and force "
                   f"follows current, which still changes {100 * (ih / ic - 1):+.1f} % as the coil warms")
    return DrivePlan("divider", f"R1 = {r1:g} ohm, R2 = {r2:g} ohm across the coil ({series})", vc, ic, ih,
                     100 * (ih / ic - 1), ic ** 2 * rc, wasted, warning=warning)


def compare_drivers(design, supply_V: float | None = None) -> list[dict]:
    """Every bridge fully on into the cold coil at the supply: drop, coil voltage, current, efficiency."""
    vs = float(supply_V if supply_V is not None else design.driver.supply_voltage)
    rc = _coil.resistance_ohm(design, 20.0)
    vt = design.actuation.voltage
    rows = []
    for br in BRIDGES.values():
        i = coil_current_A(br, vs, rc)
        rows.append({"driver": br.name, "kind": br.kind, "supply_V": vs, "current_A": i,
                     "coil_V": i * rc, "drop_V": br.drop_V(i), "drop_max_V": br.drop_V(i, "max"),
                     "efficiency": (i * rc) / vs if i > 0 else 0.0,
                     "supply_for_target_V": supply_for_coil_voltage(br, vt, rc),
                     "in_supply_range": br.supply_min_V <= vs <= br.supply_max_V,
                     "within_current_rating": i <= br.max_current_A})
    return rows
