"""`whisker actuate`: drive the coils (neutral, retract, extend, per-whisker levels or volts)."""

from __future__ import annotations

import sys
import time

import click

from whisker.cliutil import design_options, fail

ACTIONS = ("neutral", "retract", "extend", "levels", "volts", "sequence")


def backend_option(f):
    return click.option(
        "--backend", type=click.Choice(["mock", "gpio", "sim"]), required=True,
        help="gpio: the Raspberry Pi's pins (gpiozero's default pin factory); mock: gpiozero mock pins "
             "(a dry run that prints pin states); sim: the simulator's actuation input.")(f)


def config_options(f):
    f = click.option("--start", type=int, default=0, show_default=True,
                     help="First active whisker of the configuration.")(f)
    f = click.option("--config", "which", default="all", show_default=True, metavar="NAME|K",
                     help="Active whiskers: all, every-second, opposite, or K evenly spaced whiskers "
                          "(the paper's 8 / 4 / 2).")(f)
    return f


def level_options(f):
    f = click.option("--volts", type=float, default=None,
                     help="Mean volts at each active coil (duty = volts / the coil voltage at 100 % duty).")(f)
    f = click.option("--level", type=float, default=None,
                     help="PWM duty 0..1 on each active coil (default: actuation.voltage, the paper's 3 V).")(f)
    f = click.option("--policy", type=click.Choice(["derate", "cut"]), default="derate", show_default=True,
                     help="Thermal guard: derate (reduce the level near the limit) or cut (full level, then off).")(f)
    return f


def resolve_level(design, level, volts):
    from whisker.drive.guard import volts_to_levels

    if level is not None and volts is not None:
        fail("give --level or --volts, not both")
    if volts is not None:
        return float(volts_to_levels(design, abs(volts)))
    return level


def print_pins(act) -> None:
    states = getattr(act.backend, "pin_states", None)
    if states is None:
        return
    rows = states()
    expander = any(s.get("address") is not None for s in rows)
    click.echo("whisker  forward=duty  backward=duty" + ("  (PCA9685 address/channel)" if expander else "  (BCM GPIO)"))
    for s in rows:
        pre = f"0x{s['address']:02X}/ch" if s.get("address") is not None else "GPIO"
        click.echo(f"{s['whisker']:>7}  {pre}{s['forward']:<3}={s['forward_value']:.3f}     "
                   f"{pre}{s['backward']:<3}={s['backward_value']:.3f}")


@click.command()
@design_options
@click.argument("action", type=click.Choice(ACTIONS))
@click.argument("values", required=False, default=None, metavar="[V0,V1,...|FILE]")
@backend_option
@config_options
@level_options
@click.option("--duration", type=click.FloatRange(0, 3600), default=1.0, show_default=True,
              help="Seconds to hold, then every coil goes neutral.")
@click.option("--pins", "show_pins", is_flag=True, help="Print every coil's pin states while holding.")
@click.option("-q", "--quiet", is_flag=True, help="No per-second status lines.")
def cli(design, action, values, backend, which, start, level, volts, policy, duration, show_pins, quiet):
    """Drive the coils for --duration seconds, then return every whisker to neutral.

    \b
    ACTION:
      neutral   no current in any coil
      retract   tips toward the centre on the --config whiskers
      extend    tips away from the centre on the --config whiskers
      levels    one signed PWM duty per whisker: VALUES = 0.5,0,0,-0.3,...  (+ = retract)
      volts     one signed mean coil voltage per whisker: VALUES = 3,0,-1.5,...
      sequence  the timed steps of a TOML FILE or a shipped example by name, e.g. voltage_sweep
                (docs/actuation.md; checked whole before it runs);
                --duration is ignored

    Levels above the coil rating (drive.max_coil_voltage) are refused. The thermal guard follows each
    coil's temperature with the coil model and derates or cuts a coil before its limit. Every coil
    is switched off at the end, on Ctrl-C, on SIGTERM and on an error. Examples:

    \b
      whisker actuate retract --config every-second --backend gpio --duration 2
      whisker actuate levels 0.5,0,0,0,-0.5,0,0,0 --backend mock --pins
    """
    import numpy as np

    from whisker.drive.actuation import deenergise_on_signals, open_actuator
    from whisker.drive.guard import RatingError

    n = design.whiskers.count
    vec = None
    if action == "sequence":
        return run_sequence_file(design, values, backend, policy, quiet)
    if action in ("levels", "volts"):
        if not values:
            fail(f"actuate {action}: give {n} comma-separated values, e.g. " + ",".join(["0"] * n))
        try:
            vec = np.array([float(v) for v in values.split(",")])
        except ValueError:
            fail(f"actuate {action}: values must be numbers separated by commas, got {values!r}")
        if vec.shape != (n,):
            fail(f"actuate {action}: the design has {n} whiskers, got {vec.size} values")
    elif values:
        fail(f"actuate {action} takes no values (got {values!r})")
    try:
        with deenergise_on_signals():
            with open_actuator(design, backend, policy=policy) as act:
                lvl = resolve_level(design, level, volts)
                if action == "neutral":
                    act.neutral()
                elif action == "retract":
                    act.retract(level=lvl, which=which, start=start)
                elif action == "extend":
                    act.extend(level=lvl, which=which, start=start)
                elif action == "levels":
                    act.apply(vec, "levels")
                else:
                    act.set_volts(vec)
                if show_pins:
                    print_pins(act)
                t0 = time.monotonic()
                next_report = 0.0
                peak = np.zeros(n)
                while (t := time.monotonic() - t0) < duration:
                    tilt = sim_tilt_deg(act)
                    if tilt is not None:
                        peak = np.where(np.abs(tilt) > np.abs(peak), tilt, peak)
                    if not quiet and t >= next_report:
                        g = act.guard
                        click.echo(f"t={t:5.1f} s  applied={np.round(act.applied, 3).tolist()}  "
                                   f"max coil {g.temperatures.max():.1f} C (cut {g.cut_C:.0f} C)"
                                   + (f"  tilt={np.round(tilt, 2).tolist()} deg" if tilt is not None else ""),
                                   err=True)
                        next_report += 1.0
                    time.sleep(min(0.05, max(0.0, duration - t)))
                tilt = sim_tilt_deg(act)
                if tilt is not None:
                    peak = np.where(np.abs(tilt) > np.abs(peak), tilt, peak)
                act.neutral()
                if show_pins:
                    print_pins(act)
                g = act.guard
                click.echo(f"done: peak coil temperature {g.peak_C.max():.1f} C (estimated), "
                           f"guard trips {g.trips.tolist()}", err=True)
                if tilt is not None:
                    click.echo(f"simulated tilt at the end of the drive (deg, + = retracted): "
                               f"{np.round(tilt, 2).tolist()}; largest reached: {np.round(peak, 2).tolist()}", err=True)
    except (RatingError, ValueError, RuntimeError) as err:
        fail(f"actuate: {err}")


def sim_tilt_deg(act):
    """The simulated whiskers' radial tilt, deg (+ = retracted), when the backend is the simulator; else None."""
    angles = getattr(act.backend, "angles_deg", None)
    return None if angles is None else angles()


def run_sequence_file(design, path, backend, policy, quiet):
    """`whisker actuate sequence FILE`: validate every step, then run them with phase reports."""
    from whisker.drive.actuation import deenergise_on_signals, open_actuator
    from whisker.drive.sequences import load_sequence, run_sequence
    from whisker.drive.guard import RatingError

    if not path:
        fail("actuate sequence: give the sequence FILE (TOML with [[step]] entries)")
    try:
        steps = load_sequence(design, path)
    except ValueError as err:  # includes RatingError
        fail(f"actuate: {err}")
    try:
        with deenergise_on_signals():
            with open_actuator(design, backend, policy=policy) as act:
                last = [None]

                def report(t, phase):
                    if phase != last[0] and not quiet:
                        last[0] = phase
                        tilt = sim_tilt_deg(act)
                        click.echo(f"t={t:7.2f} s  {phase:12s} applied={[round(float(x), 3) for x in act.applied]}"
                                   + (f"  tilt={[round(float(x), 2) for x in tilt]} deg" if tilt is not None else ""),
                                   err=True)

                run_sequence(act, steps, on_tick=report)
                g = act.guard
                click.echo(f"done: {len(steps)} steps, peak coil temperature {g.peak_C.max():.1f} C (estimated), "
                           f"guard trips {g.trips.tolist()}", err=True)
    except (RatingError, ValueError, RuntimeError) as err:
        fail(f"actuate: {err}")
