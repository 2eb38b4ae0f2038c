"""`whisker coil`: what to wind, what it will do, how long it can stay on, and how to drive it."""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import click

from whisker.cliutil import design_options, fail
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad, stiffness_source

#: most rows `coil thermal` prints (one per --step)
MAX_THERMAL_ROWS = 100_000
#: mm, the largest gap `coil force` tabulates: beyond it the force is nil and the models' series overflow
MAX_GAP_MM = 1000.0

# shortcut option -> design parameter
_SHORTCUTS = {
    "wire": "coil.wire_diameter", "enamel_grade": "winding.enamel_grade", "inner": "coil.inner_diameter",
    "outer": "coil.outer_diameter", "length": "coil.length", "fill": "winding.fill_factor",
    "resistance": "coil.resistance", "supply": "driver.supply_voltage", "driver_name": "driver.type",
    "gap": "actuation.gap", "stiffness": "mechanics.rotational_stiffness",
}


#: a shortcut's value is passed on as typed, so the design model (pydantic) parses and bounds it
#: exactly as it does `--set section.key=VALUE` (and `design show`)
DESIGN_VALUE = click.STRING


def coil_options(f):
    """Design options plus coil shortcuts (--wire, --turns, --fill ...) applied as overrides.

    The shortcuts become ``--set`` overrides on the same loading path as every other command
    (whisker.cliutil.design_options -> load_design), so `coil report --wire X` and
    `design show --set coil.wire_diameter=X` accept and refuse exactly the same values.
    """
    inner = design_options(_turns_max(f))

    @click.option("--wire", type=DESIGN_VALUE, help="Bare wire diameter, mm (coil.wire_diameter).")
    @click.option("--enamel-grade", type=click.IntRange(1, 3), help="IEC 60317 enamel grade 1-3 (winding.enamel_grade).")
    @click.option("--inner", type=DESIGN_VALUE, help="Coil bore diameter, mm (coil.inner_diameter).")
    @click.option("--outer", type=DESIGN_VALUE, help="Coil outer diameter, mm (coil.outer_diameter).")
    @click.option("--length", type=DESIGN_VALUE, help="Coil length along its axis, mm (coil.length).")
    @click.option("--turns", help="Turns (coil.turns), or 'max' for as many as fit at the fill factor.")
    @click.option("--fill", type=DESIGN_VALUE, help="Copper fill factor (winding.fill_factor).")
    @click.option("--resistance", type=DESIGN_VALUE, help="Measured coil resistance at 20 C, ohm (coil.resistance).")
    @click.option("--supply", type=DESIGN_VALUE, help="Supply into the H-bridge, V (driver.supply_voltage).")
    @click.option("--driver", "driver_name", type=click.Choice(["L298N", "TB6612FNG", "DRV8833"]),
                  help="H-bridge (driver.type).")
    @click.option("--gap", type=DESIGN_VALUE, help="Coil-magnet gap at rest, mm (actuation.gap).")
    @click.option("--stiffness", type=DESIGN_VALUE, help="Membrane rotational stiffness, N*mm/rad.")
    @functools.wraps(inner)
    def wrapper(*args, overrides=(), turns=None, **kwargs):
        over = list(overrides)
        for key, param in _SHORTCUTS.items():
            v = kwargs.pop(key, None)
            if v is not None:   # the text as typed: the design model parses and bounds it, as for --set
                over.append(f"{param}={v!r}" if key == "driver_name" else f"{param}={v}")
        if turns is not None and turns != "max":
            over.append(f"coil.turns={turns}")
        return inner(*args, overrides=tuple(over), turns_max=turns == "max", **kwargs)
    return wrapper


def _turns_max(f):
    """--turns max: as many turns as fit at the (validated) design's fill factor."""
    @functools.wraps(f)
    def wrapper(*args, design, turns_max=False, **kwargs):
        if turns_max:
            from whisker.coil import winding
            from whisker.design import DesignError, apply_overrides, design_from_dict

            try:
                design = design_from_dict(apply_overrides(design.to_dict(), [
                    f"coil.turns={winding(design).max_turns_at_fill}"]))
            except DesignError as err:
                fail(f"design refused: {err}")
        return f(*args, design=design, **kwargs)
    return wrapper


def _guard(fn):
    """Turn the calculators' one-line errors into a clean exit (status 2)."""
    @functools.wraps(fn)
    def wrapper(*a, **k):
        from whisker.coil import CoilError
        from whisker.coil.driver import DriverError
        from whisker.coil.magnetics import MagneticsError
        try:
            return fn(*a, **k)
        except (CoilError, DriverError, MagneticsError) as err:
            fail(str(err))
    return wrapper


@click.group()
def cli():
    """Coil calculator: winding, force, deflection, heating and driver for the whisker coils.

    Every number comes from the design (hw/sensor.toml plus --set overrides); the shortcut options
    (--wire, --turns, --fill, --supply, --driver ...) are overrides too. See docs/coil.md.
    """


@cli.command()
@coil_options
@click.option("--volts", type=float, default=None, help="Volts across the coil (default: actuation.voltage).")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Also write report.txt, report.json, force.png and temperature.png into this folder.")
@_guard
def report(design, volts, as_json, out):
    """Full report: winding (fits?), resistance, current, force vs gap, deflection, heating, driver."""
    from whisker.coil.report import build_report, format_report, plot_force, plot_temperature
    from whisker.files import atomic_write_json, atomic_write_text

    rep = build_report(design, volts)
    text = format_report(rep)
    click.echo(json.dumps(rep, indent=2, allow_nan=False) if as_json else text)
    if out:
        o = Path(out)
        atomic_write_text(o / "report.txt", text + "\n")
        atomic_write_json(o / "report.json", rep)
        plot_force(design, o / "force.png")
        plot_temperature(design, o / "temperature.png", rep["electrical"]["volts_at_coil"])
        click.echo(f"wrote {o}/report.txt, report.json, force.png, temperature.png", err=True)


@cli.command()
@coil_options
@click.option("--model", "models", multiple=True,
              type=click.Choice(["dipole", "dipole_field", "filament", "magpylib", "table"]),
              help="Model(s) to tabulate (repeatable; default: table).")
@click.option("--gaps", default="0.2,0.5,1,2,2.5,5,10", show_default=True, help="Comma-separated gaps, mm.")
@click.option("--volts", type=float, default=None, help="Also give the force at this coil voltage (20 C).")
@_guard
def force(design, models, gaps, volts):
    """Force on the coil towards the magnet per ampere (mN/A) against gap, for each model."""
    import numpy as np

    from whisker.coil import current_A
    from whisker.coil.magnetics import force_per_ampere_N

    try:
        g = np.array([float(x) for x in gaps.split(",") if x.strip()])
    except ValueError:
        fail(f"--gaps: not a comma-separated list of numbers: {gaps!r}")
    if g.size == 0 or not np.all((g > 0) & (g <= MAX_GAP_MM)):
        fail(f"--gaps: every gap must be in (0, {MAX_GAP_MM:g}] mm (got {gaps!r})")
    models = models or ("table",)
    cur = current_A(design, volts) if volts is not None else None
    head = "gap_mm " + " ".join(f"{m + '_mN/A':>16s}" for m in models)
    if cur is not None:
        head += f"   mN at {volts:g} V ({cur:.3f} A, {models[-1]})"
    click.echo(head)
    cols = [np.atleast_1d(force_per_ampere_N(design, g, model=m)) * 1e3 for m in models]
    for i, gi in enumerate(g):
        line = f"{gi:6.2f} " + " ".join(f"{c[i]:16.4f}" for c in cols)
        if cur is not None:
            line += f"   {cols[-1][i] * cur:10.3f}"
        click.echo(line)


@cli.command()
@coil_options
@click.option("--volts", type=float, multiple=True, help="Coil voltages (repeatable; default 0.5..actuation.voltage).")
@_guard
def deflection(design, volts):
    """Steady whisker tilt against coil voltage, with the pull-in (snap-through) voltage."""
    import numpy as np

    from whisker.coil import current_A, equilibrium, pull_in, resistance_ohm

    vs = volts or tuple(np.round(np.linspace(0.5, design.actuation.voltage, 6), 3))
    i_pull, th_pull = pull_in(design)
    pull = (f"pull-in above {i_pull:.3f} A = {i_pull * resistance_ohm(design):.2f} V (at {math.degrees(th_pull):.1f} deg)"
            if math.isfinite(i_pull) else "no pull-in (the coil cannot reach the magnet)")
    click.echo(f"stiffness {design_stiffness_Nmm_per_rad(design):.4g} N*mm/rad ({stiffness_source(design)}), gap {design.actuation.gap:g} mm; {pull}")
    click.echo("volts  current_A  tilt_deg  gap_mm  state")
    for v in vs:
        eq = equilibrium(design, current_A(design, float(v)))
        tilt = f"{eq.theta_deg:8.2f}" if eq.stable else "    snap"
        click.echo(f"{float(v):5.2f}  {eq.current_A:9.3f}  {tilt}  {eq.gap_mm:6.2f}  {eq.message}")


@cli.command("fit-stiffness")
@coil_options
@click.argument("points", nargs=-1, required=True)
@click.option("--amps", is_flag=True, help="Points are CURRENT:DEG instead of VOLTS:DEG.")
@_guard
def fit_stiffness_cmd(design, points, amps):
    """Fit mechanics.rotational_stiffness to measured points VOLTS:DEG (e.g. 1:3.5 2:8 3:15)."""
    from whisker.coil import fit_stiffness

    pts = []
    for p in points:
        try:
            a, b = p.split(":")
            pts.append((float(a), float(b)))
        except ValueError:
            fail(f"point {p!r}: expected DRIVE:DEGREES, e.g. 3:15")
    res = fit_stiffness(design, pts, by="amps" if amps else "volts")
    click.echo(f"rotational stiffness {res['rotational_stiffness_Nmm_per_rad']:.4g} N*mm/rad from "
               f"{res['points']} point(s), rms residual {res['rms_residual_deg']:.3g} deg")
    click.echo(f"use it: --set {res['set']}  (or edit [mechanics] in your design file)")


@cli.command()
@coil_options
@click.option("--volts", type=float, default=None, help="Volts across the coil (default: actuation.voltage).")
@click.option("--duty", type=click.FloatRange(0, 1), default=1.0, show_default=True, help="PWM duty.")
@click.option("--seconds", type=float, default=60.0, show_default=True, help="Duration, s.")
@click.option("--step", type=float, default=1.0, show_default=True, help="Print interval, s.")
@_guard
def thermal(design, volts, duty, seconds, step):
    """Every coil at a voltage (V) and PWM duty from ambient: each part's temperature (C) against time
    (s) from the thermal network (whisker.coil.thermal_network), the time to each material's limit and
    the safe duty."""
    import math

    import numpy as np

    from whisker.coil import thermal_network as tn
    from whisker.coil import thermal_parts as tp

    v = design.actuation.voltage if volts is None else volts
    if not (math.isfinite(v) and v >= 0):
        fail(f"--volts must be a finite voltage >= 0 (got {v!r})")
    t_end = seconds
    if not step > 0 or not (t_end >= 0):
        fail(f"--step must be > 0 s and --seconds >= 0 (got step {step:g}, seconds {t_end:g})")
    if t_end / step > MAX_THERMAL_ROWS:
        fail(f"--seconds {t_end:g} / --step {step:g} is {t_end / step:.3g} rows, over {MAX_THERMAL_ROWS}; "
             "give a larger --step")
    net = tn.ThermalNetwork(design)
    times = tn.time_to_limits_s(net, v, duty)
    first = min(times, key=times.get)
    ss = tn.steady_state_at_volts(net, v, duty)
    t_first = "never" if math.isinf(times[first]) else f"{times[first]:.3g} s"
    click.echo(f"{v:g} V, duty {duty:g} on every coil: steady winding {float(net.winding_C(ss)[0]):.0f} C; "
               f"first limit {first if t_first != 'never' else net.limit_label} after {t_first}; "
               f"safe duty {tn.safe_duty(net, v) * 100:.1f} %")
    names = list(tp.PER_WHISKER) + list(tp.SHARED)
    click.echo("t_s    " + "  ".join(f"{n[:8]:>8s}" for n in names) + "   (C)")
    ts, xs = tn.run_at_volts(net, v, max(t_end, step), duty=duty, dt_s=min(step, 0.05))
    for k in range(int(round(t_end / step)) + 1):
        i = int(np.argmin(np.abs(ts - k * step)))
        nt = net.node_temperatures(xs[i])
        click.echo(f"{ts[i]:6.1f} " + "  ".join(f"{float(nt[n][0]):8.2f}" for n in names))


@cli.command()
@coil_options
@click.option("--volts", type=float, default=None, help="Target volts across the coil (default: actuation.voltage).")
@click.option("--amps", type=float, default=None, help="Target coil current instead (A, cold coil).")
@click.option("--series", type=click.Choice(["E24", "E96"]), default="E24", show_default=True,
              help="Preferred-number series the series resistor is picked from (E24: 5 %, E96: 1 %).")
@_guard
def driver(design, volts, amps, series):
    """Bridge drop, supply needed, series resistor / divider / PWM, and the alternative drivers."""
    from whisker.coil.report import build_report, format_report

    from whisker.coil import driver as drv
    from whisker.coil import resistance_ohm

    if amps is not None:
        if volts is not None:
            fail("give --volts or --amps, not both")
        if not (amps > 0 and math.isfinite(amps)):
            fail(f"--amps {amps:g}: the target coil current must be a positive finite number of amperes")
        volts = amps * resistance_ohm(design, 20.0)
    elif volts is not None and not (volts > 0 and math.isfinite(volts)):
        fail(f"--volts {volts:g}: the target coil voltage must be a positive finite number of volts")
    rep = build_report(design, volts)
    rep["driver"] = drv.plan(design, volts, series=series)
    text = format_report(rep)
    click.echo(text[text.index("DRIVER"):])


@cli.command()
@coil_options
@click.option("--sensors", type=click.IntRange(1, 1_000_000), default=2000, show_default=True,
              help="Built sensors to draw (each of whiskers.count whiskers with its own draws).")
@click.option("--drive", "drive_mode", type=click.Choice(["voltage", "current", "bringup"]), default="voltage",
              show_default=True, help="voltage: one PWM level (actuation.voltage, V at the coil); current: a "
              "regulated current (--amps, A); bringup: levels raised per whisker from `whisker calibrate stiffness`.")
@click.option("--amps", type=click.FloatRange(0, 10, min_open=True), default=None,
              help="Coil current for --drive current, A (default: actuation.voltage / coil.resistance).")
@click.option("--sobol", "sobol_base", type=click.IntRange(0, 65536), default=0,
              help="Also Sobol' indices with this base sample (runs = base x (factors + 2)); 0 = none.")
@click.option("--tolerances", type=click.Path(dir_okay=False), default=None,
              help="Tolerance table (default hw/tolerances.csv): name, level, kind, min, max, unit, applies_to, source.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed of the sampled builds.")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Write tolerance.json there (atomically: a refused run leaves the old one).")
@_guard
def tolerance(design, sensors, drive_mode, amps, sobol_base, tolerances, seed, out):
    """Build scatter: tilt at the grasp level, P(pull-in), build yield (%), Sobol' indices. docs/coil.md."""
    from whisker.coil import tolerance as tol
    from whisker.coil.tolerance_table import load_tolerances
    from whisker.files import atomic_write_json

    drive = tol.Drive(drive_mode, amps)
    load_tolerances(tolerances)          # refuse a bad table before any work
    r = tol.study(design, sensors, drive, seed=seed, tolerances=tolerances)
    rep = r.to_dict()
    p = r.tilt_percentiles_deg
    click.echo(f"{sensors} sensors x {r.whiskers_per_sensor} whiskers, drive {drive_mode}, "
               f"{'end stop' if r.end_stop else 'no stop'}, stiffness {r.stiffness_Nmm_per_rad:.3g} N*mm/rad")
    click.echo(f"nominal: grasp {r.grasp_current_nominal_A:.3f} A, " + (
        "no pull-in" if r.pull_in_margin_nominal is None else
        f"pull-in {r.pull_in_current_nominal_A:.3f} A (margin {r.pull_in_margin_nominal * 100:+.1f} %)"))
    if r.holding:
        h = r.holding
        click.echo(f"end stop {h['tilt_deg']:g} deg: holding {h['holding_torque_Nmm']:.3f} N*mm, post "
                   f"{h['post_force_mN']:.1f} mN, tip {h['tip_force_mN']:.2f} mN")
    click.echo(f"yield {r.yield_ * 100:.2f} % (95 % {r.yield_ci95[0] * 100:.2f}-{r.yield_ci95[1] * 100:.2f}); per whisker "
               f"P(pull-in) {r.p_pull_in * 100:.2f} %, coil on magnet {r.p_coil_on_magnet * 100:.2f} %, short of "
               f"{r.target_tilt_deg:.1f} deg {r.p_short * 100:.2f} %")
    if p:
        click.echo("tilt deg: " + ", ".join(f"{k} {v:.2f}" for k, v in p.items()))
    if sobol_base:
        s = tol.sobol(design, sobol_base, drive, seed=seed, tolerances=tolerances)
        rep["sobol"] = s
        click.echo(f"Sobol' indices of {s['output']} ({s['runs']} runs): factor S1 ST")
        for row in s["indices"]:
            click.echo(f"  {row['factor']:20s} {row['S1']:6.3f} {row['ST']:6.3f} (+-{row['ST_conf']:.3f})")
    if out:
        atomic_write_json(Path(out) / "tolerance.json", rep)
        click.echo(f"wrote {out}/tolerance.json", err=True)
