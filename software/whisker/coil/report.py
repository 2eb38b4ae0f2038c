"""The coil calculator's report: one dict (JSON-ready, finite numbers only) and its text form.

Pulls together whisker.coil (winding, electrical, deflection), whisker.coil.magnetics (force against
gap), whisker.coil.thermal (heating) and whisker.coil.driver (bridge, supply, divider, PWM).
"""

from __future__ import annotations

import math

import numpy as np

from whisker import coil
from whisker.coil import driver
from whisker.coil import magnetics
from whisker.coil import thermal
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad, stiffness_source

REPORT_GAPS_MM = (0.2, 0.5, 1.0, 2.0, 2.5, 5.0, 10.0)
#: built sensors in the report's build-scatter study (Latin hypercube, seed 0): ~0.5 s; the yield's
#: 95 % interval at this size is about +-1 % near 99 % (benchmarks/results/tolerance.md has larger runs)
REPORT_SENSORS = 400


def margin_and_yield(design, volts: float, sensors: int = REPORT_SENSORS) -> dict:
    """Margin to pull-in at nominal values and the build yield (whisker.coil.tolerance) at `volts`."""

    from whisker.coil import tolerance

    d = design if volts == design.actuation.voltage else design.model_copy(
        update={"actuation": replace_actuation(design, volts)})
    res = {}
    for name, drive in (("voltage", tolerance.Drive("voltage")), ("bringup", tolerance.Drive("bringup"))):
        r = tolerance.study(d, sensors, drive)
        res[name] = {"yield": r.yield_, "yield_ci95": list(r.yield_ci95), "p_pull_in": r.p_pull_in,
                     "p_coil_on_magnet": r.p_coil_on_magnet, "p_short": r.p_short,
                     "tilt_percentiles_deg": r.tilt_percentiles_deg}
    return {"sensors": sensors, "whiskers_per_sensor": r.whiskers_per_sensor,
            "stiffness_Nmm_per_rad": r.stiffness_Nmm_per_rad, "stiffness_source": r.stiffness_source,
            "grasp_current_A": r.grasp_current_nominal_A, "pull_in_current_A": r.pull_in_current_nominal_A,
            "pull_in_margin": r.pull_in_margin_nominal, "end_stop": r.end_stop,
            "stop_reach_current_A": r.stop_reach_current_nominal_A, "holding": r.holding,
            "target_tilt_deg": r.target_tilt_deg, "drives": res}


def _build_or_missing(design, volts: float) -> dict:
    try:
        return margin_and_yield(design, volts)
    except ModuleNotFoundError as err:   # SALib is the [tolerance] extra; the rest of the report stands
        from whisker.extras import missing_extra_message
        return {"missing": missing_extra_message(err, "the build yield") or str(err)}


def replace_actuation(design, volts: float):
    return design.actuation.model_copy(update={"voltage": float(volts)})


def build_report(design, volts: float | None = None) -> dict:
    """Everything `whisker coil report` prints, for the coil voltage `volts` (default [actuation])."""
    v = float(volts if volts is not None else design.actuation.voltage)
    if not (math.isfinite(v) and v > 0):
        raise coil.CoilError(f"volts must be a positive finite number (got {volts!r}); at 0 V nothing moves or heats")
    w = coil.winding(design)
    i20 = coil.current_A(design, v, 20.0)
    th = thermal.CoilThermal(design)
    i_hot = coil.current_A(design, v, th.limit_C)
    gaps = np.array(REPORT_GAPS_MM)
    k = magnetics.force_per_ampere_N(design, gaps)
    k_rest = float(magnetics.force_per_ampere_N(design, design.actuation.gap))
    eq = coil.equilibrium(design, i20)
    i_pull, th_pull = coil.pull_in(design)
    r20 = coil.resistance_ohm(design, 20.0)
    elec = {
        "volts_at_coil": v,
        "resistance_20C_ohm": r20,
        "resistance_at_limit_ohm": coil.resistance_ohm(design, th.limit_C),
        "current_20C_A": i20,
        "current_at_limit_A": i_hot,
        "power_20C_W": v * i20,
        "current_density_A_mm2": coil.current_density_A_mm2(design, i20),
        "magnetic_moment_mA_m2": coil.magnetic_moment_Am2(design, i20) * 1e3,
        "inductance_wheeler_uH": w.inductance_wheeler_H * 1e6,
        "inductance_numeric_uH": w.inductance_numeric_H * 1e6,
        "time_constant_us": w.time_constant_s * 1e6,
    }
    force = {
        "model": "table (converged filament model; see benchmarks/results/magnetics.md)",
        "gaps_mm": gaps.tolist(),
        "force_per_ampere_N_per_A": np.asarray(k).tolist(),
        "force_at_volts_mN": (np.asarray(k) * i20 * 1e3).tolist(),
        "rest_gap_mm": design.actuation.gap,
        "force_at_rest_mN": k_rest * i20 * 1e3,
        "lever_mm": coil.lever_mm(design),
        "torque_at_rest_Nmm": k_rest * i20 * coil.lever_mm(design),
    }
    defl = {
        "rotational_stiffness_Nmm_per_rad": design_stiffness_Nmm_per_rad(design),
        "stiffness_source": stiffness_source(design),
        "equilibrium": eq.to_dict(),
        "pull_in_current_A": i_pull if math.isfinite(i_pull) else None,
        "pull_in_volts": i_pull * r20 if math.isfinite(i_pull) else None,
        "pull_in_theta_deg": math.degrees(th_pull) if math.isfinite(i_pull) else None,
    }
    rep = {
        "design_digest": design.digest(),
        "winding": w.to_dict(),
        "resistance_vs_fill": coil.resistance_range_vs_fill(design),
        "electrical": elec,
        "force": force,
        "deflection": defl,
        "thermal": thermal.summary(design, v),
        "driver": driver.plan(design, v),
        "drivers": driver.compare_drivers(design),
        "build": _build_or_missing(design, v),
    }
    return rep


def _f(x, fmt=".3g"):
    return "n/a" if x is None else format(x, fmt)


def _build_lines(L: list, b: dict, e: dict) -> None:
    """The report's margin-and-yield lines."""
    L.append(f"MARGIN AND BUILD YIELD at {e['volts_at_coil']:g} V ({b['sensors']} built sensors of "
             f"{b['whiskers_per_sensor']} whiskers, hw/tolerances.csv, whisker.coil.tolerance; stiffness "
             f"{b['stiffness_Nmm_per_rad']:.3g} N*mm/rad from {b['stiffness_source']})")
    if b["pull_in_margin"] is None:
        L.append("  no pull-in: the coil cannot reach the magnet")
    else:
        L.append(f"  margin to pull-in in coil current at nominal values: {b['pull_in_margin'] * 100:+.1f} % "
                 f"({b['pull_in_current_A']:.3f} A against {b['grasp_current_A']:.3f} A; the no-stop target is >= +20 %)")
    if b["end_stop"]:
        h = b["holding"]
        L.append(f"  end stop at {h['tilt_deg']:g} deg (coil {h['stop_gap_mm']:.2f} mm from the magnet), reached from "
                 f"{b['stop_reach_current_A']:.3f} A; holding at {b['grasp_current_A']:.3f} A: {h['holding_torque_Nmm']:.3f} "
                 f"N*mm, {h['post_force_mN']:.1f} mN on the post, lifted off by {h['tip_force_mN']:.2f} mN at the tip")
    for name, r in b["drives"].items():
        what = ("one level for every whisker" if name == "voltage" else
                "levels raised per whisker at bring-up (whisker calibrate stiffness)")
        L.append(f"  yield {r['yield'] * 100:.1f} % (95 % {r['yield_ci95'][0] * 100:.1f}-{r['yield_ci95'][1] * 100:.1f}) "
                 f"with {what}; per whisker P(pull-in) {r['p_pull_in'] * 100:.1f} %, coil on magnet "
                 f"{r['p_coil_on_magnet'] * 100:.2f} %, short of {b['target_tilt_deg']:.1f} deg {r['p_short'] * 100:.2f} %")


def format_report(rep: dict) -> str:
    """Human-readable text of :func:`build_report`."""
    w, e, f, d, t, dr = rep["winding"], rep["electrical"], rep["force"], rep["deflection"], rep["thermal"], rep["driver"]
    L = []
    L.append("WINDING")
    L.append(f"  {w['turns']} turns, wire overall {w['wire_overall_diameter_mm']:.3f} mm, window {w['window_mm2']:.2f} mm^2 "
             "(the bobbin's: coil.length x (coil.outer_diameter/2 - bobbin.rim_margin - coil.inner_diameter/2))")
    L.append(f"  copper fill needed {w['fill_required']:.3f} (assumed {w['fill_factor']:.2f}, orthocyclic limit "
             f"{w['fill_limit_orthocyclic']:.3f}) -> {'FITS' if w['fits'] else 'DOES NOT FIT'}")
    L.append(f"  turns that fit: {w['max_turns_at_fill']} at fill {w['fill_factor']:.2f}, "
             f"{w['max_turns_orthocyclic']} orthocyclic")
    L.append(f"  {w['turns_per_layer']} turns/layer, {w['layers']} layers, build {w['build_mm']:.2f} mm "
             f"(wound OD {w['wound_outer_diameter_mm']:.2f} mm)")
    L.append(f"  wire {w['wire_length_mm'] / 1000:.2f} m, {w['resistance_ohm']:.2f} ohm at 20 C predicted "
             f"(design {w['measured_resistance_ohm']:g}; that is {w['turns_for_measured_resistance']} turns), "
             f"copper {w['copper_mass_g']:.3f} g")
    L.append("  resistance if the whole window is wound at fill: " + ", ".join(
        f"{r['fill']:.2f}: {r['turns']} t / {r['resistance_ohm']:.1f} ohm" for r in rep["resistance_vs_fill"]))
    for msg in w["warnings"]:
        L.append(f"  WARNING: {msg}")
    L.append(f"ELECTRICAL at {e['volts_at_coil']:g} V across the coil")
    L.append(f"  R {e['resistance_20C_ohm']:.2f} ohm (20 C) / {e['resistance_at_limit_ohm']:.2f} ohm (limit); "
             f"I {e['current_20C_A']:.3f} A / {e['current_at_limit_A']:.3f} A; P {e['power_20C_W']:.2f} W")
    L.append(f"  current density {e['current_density_A_mm2']:.1f} A/mm^2, moment {e['magnetic_moment_mA_m2']:.3f} mA*m^2")
    L.append(f"  L {e['inductance_numeric_uH']:.0f} uH numeric / {e['inductance_wheeler_uH']:.0f} uH Wheeler, "
             f"L/R {e['time_constant_us']:.0f} us")
    L.append(f"FORCE on the coil towards the magnet ({f['model']})")
    for g, k, fm in zip(f["gaps_mm"], f["force_per_ampere_N_per_A"], f["force_at_volts_mN"]):
        L.append(f"  gap {g:5.2f} mm: {k * 1e3:8.2f} mN/A  {fm:8.2f} mN")
    L.append(f"  at rest (gap {f['rest_gap_mm']:g} mm): {f['force_at_rest_mN']:.2f} mN, torque "
             f"{f['torque_at_rest_Nmm']:.4f} N*mm on a {f['lever_mm']:.2f} mm lever")
    n_m = w["turns_for_measured_resistance"]
    if abs(n_m - w["turns"]) > 0.1 * w["turns"]:
        L.append(f"  NOTE: force uses coil.turns = {w['turns']}; if the coil has the {n_m} turns its measured "
                 f"resistance implies, every force and torque here is {n_m / w['turns']:.2f}x")
    eq = d["equilibrium"]
    L.append(f"DEFLECTION (rotational stiffness {d['rotational_stiffness_Nmm_per_rad']:.4g} N*mm/rad from the {d['stiffness_source']})")
    if eq["stable"]:
        L.append(f"  steady tilt {eq['theta_deg']:.2f} deg, gap {eq['gap_mm']:.2f} mm ({eq['message']})")
    else:
        L.append(f"  NO STABLE EQUILIBRIUM: {eq['message']}")
    if d["pull_in_current_A"] is None:
        L.append("  no pull-in: the gap is at least the lever, the coil cannot reach the magnet")
    else:
        L.append(f"  pull-in (snap-through) above {d['pull_in_current_A']:.3f} A = {d['pull_in_volts']:.2f} V, "
                 f"at {d['pull_in_theta_deg']:.1f} deg")
    b = rep["build"]
    if "missing" in b:
        L.append(f"MARGIN AND BUILD YIELD: {b['missing']}")
    else:
        _build_lines(L, b, e)
    L.append(f"THERMAL at {t['volts']:g} V continuous (ambient {t['ambient_C']:g} C)")
    L.append(f"  heat capacity {t['heat_capacity_J_per_K'] * 1e3:.0f} mJ/K, cooling {t['conductance_W_per_K'] * 1e3:.2f} mW/K, "
             f"time constant {t['time_constant_s']:.1f} s, {t['heating_rate_cold_K_per_s']:.1f} K/s at first")
    L.append(f"  first limit {t['limit']} ({t['limit_C']:g} C) after {_f(t['time_to_first_limit_s'])} s; "
             f"magnet {_f(t['time_to_limit_s']['magnet'])} s, PLA {_f(t['time_to_limit_s']['pla'])} s, "
             f"enamel {_f(t['time_to_limit_s']['enamel'])} s; steady state {t['steady_state_C']:.0f} C")
    L.append(f"  safe continuous duty cycle: {t['safe_duty'] * 100:.1f} %")
    L.append(f"DRIVER {dr['driver']} at {dr['supply_V']:g} V ({dr['driver_source']})")
    L.append(f"  drop {dr['bridge_drop_V']:.2f} V typ / {dr['bridge_drop_max_V']:.2f} V max at "
             f"{dr['target_current_A']:.3f} A; coil gets {dr['coil_V_full_on']:.2f} V fully on; supply for "
             f"{dr['target_coil_V']:g} V: {dr['supply_for_direct_V']:.2f} V typ / {dr['supply_for_direct_max_V']:.2f} V max")
    if dr.get("design_series_ohm"):
        L.append(f"  with the design's {dr['design_series_ohm']:g} ohm series resistor (driver.series_resistance): "
                 f"{dr['coil_V_full_on_design']:.2f} V at the coil fully on (PWM level 1)")
    for p in dr["plans"]:
        line = f"  {p['method']:8s} {p['detail']}"
        if p["current_cold_A"] > 0:
            line += (f": {p['current_cold_A']:.3f} A cold, {p['current_hot_A']:.3f} A hot "
                     f"({p['force_change_hot_pct']:+.1f} % force), coil {p['coil_heat_W']:.2f} W, wasted {p['wasted_W']:.2f} W")
        L.append(line)
        if p["warning"] and p["warning"] != "infeasible":
            L.append(f"           WARNING: {p['warning']}")
    for msg in dr["warnings"]:
        L.append(f"  WARNING: {msg}")
    L.append("  alternatives fully on at the same supply:")
    for r in rep["drivers"]:
        L.append(f"    {r['driver']:10s} {r['kind']:7s} drop {r['drop_V']:.2f} V, coil {r['coil_V']:.2f} V, "
                 f"{r['current_A']:.3f} A, supply for {rep['electrical']['volts_at_coil']:g} V: {r['supply_for_target_V']:.2f} V"
                 + ("" if r["within_current_rating"] else " (OVER ITS CURRENT RATING fully on)")
                 + ("" if r["in_supply_range"] else " (SUPPLY OUT OF RANGE)"))
    return "\n".join(L)


def plot_force(design, path, current_A: float | None = None) -> None:
    """Force per ampere against gap for every cheap model (log axes), written atomically as PNG."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from whisker.files import atomic_write_bytes

    gaps = np.geomspace(0.1, 20.0, 200)
    fig, ax = plt.subplots(figsize=(6, 4))
    for m in ("dipole", "dipole_field", "table"):
        ax.loglog(gaps, np.asarray(magnetics.force_per_ampere_N(design, gaps, model=m)) * 1e3, label=m)
    ax.axvline(design.actuation.gap, color="grey", ls=":", label="rest gap")
    ax.set_xlabel("gap, mm")
    ax.set_ylabel("force per ampere, mN/A")
    ax.set_title("coil-magnet force")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def plot_temperature(design, path, volts: float) -> None:
    """Coil temperature against time at `volts` continuous and at the safe duty, with the limits."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from whisker.files import atomic_write_bytes

    th = thermal.CoilThermal(design)
    t_end = max(10.0, 4.0 * th.time_constant_s)
    fig, ax = plt.subplots(figsize=(6, 4))
    duty = th.safe_duty(volts)
    for dty, lab in ((1.0, "continuous"), (duty, f"safe duty {duty * 100:.0f} %")):
        t, T = th.temperature_curve(volts, t_end, duty=dty)
        ax.plot(t, T, label=lab)
    for name, lim in (("magnet", th.limits.magnet_C), ("PLA", th.limits.pla_C), ("enamel", th.limits.enamel_C)):
        ax.axhline(lim, ls=":", color="grey")
        ax.text(t_end, lim, name, ha="right", va="bottom", fontsize=8)
    ax.set_xlabel("time, s")
    ax.set_ylabel("coil temperature, C")
    ax.set_title(f"coil at {volts:g} V")
    ax.set_ylim(th.ambient_C - 5, min(max(th.limits.enamel_C + 20, 100), th.steady_state_C(volts) + 20))
    ax.legend()
    ax.grid(True, alpha=0.3)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
