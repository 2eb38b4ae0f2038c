"""`whisker grasp`: the paper's grasp sequence (retract, hold, release) on 8, 4 or 2 whiskers."""

from __future__ import annotations

import sys
import time

import click

from whisker.cliutil import design_options, fail
from whisker.commands.sensor.actuate import backend_option, config_options, level_options, resolve_level


def sequence_options(f):
    f = click.option("--release-level", type=click.FloatRange(-1, 0), default=0.0, show_default=True,
                     help="Level during release (0 = neutral; negative pushes the object off).")(f)
    f = click.option("--hold-level", type=click.FloatRange(0, 1), default=None,
                     help="Level while holding (default: the highest level at which this retract + hold "
                          "keeps every coil out of the guard's derate band, from the thermal network: "
                          "whisker.drive.thermal_protocol.fit_hold_level; lower = cooler coils).")(f)
    f = click.option("--release-s", type=click.FloatRange(0, 600), default=1.0, show_default=True,
                     help="Seconds of the release phase.")(f)
    f = click.option("--hold-s", type=click.FloatRange(0, 600), default=3.0, show_default=True,
                     help="Seconds of the hold phase (the arm lifts the object).")(f)
    f = click.option("--retract-s", type=click.FloatRange(0, 600), default=1.0, show_default=True,
                     help="Seconds of the retract phase (the whiskers close on the object).")(f)
    return f


def build_sequence(design, which, start, level, hold_level, retract_s, hold_s, release_s, release_level):
    """The grasp's steps; without a --hold-level the holding level is the highest with which the
    retract at `level` and the hold stay out of the thermal guard's derate band on every coil of the
    configuration (whisker.drive.thermal_protocol.fit_hold_level: the thermal network, every material's
    own limit), so the guard never drops a held object."""
    from whisker.drive.actuation import configuration
    from whisker.drive.sequences import grasp_sequence

    mask = configuration(design.whiskers.count, which, start)
    if hold_level is None:
        from whisker.drive.thermal_protocol import Protocol, fit_hold_level

        proto = Protocol(close_s=retract_s, lift_mm=0.0, hold_s=hold_s, release_s=0.0)
        hold_level = fit_hold_level(design, abs(level), proto, active=mask, resolution=0.005)
        click.echo(f"holding level {hold_level:.3f} (grasp level {abs(level):.3f}): the highest that keeps "
                   f"every material out of the guard's derate band for {retract_s:g} s + {hold_s:g} s", err=True)
    return grasp_sequence(design.whiskers.count, mask, level, retract_s=retract_s, hold_s=hold_s,
                          release_s=release_s, hold_level=hold_level, release_level=release_level)


@click.command()
@design_options
@backend_option
@config_options
@level_options
@sequence_options
@click.option("--trials", type=click.IntRange(1, 1000), default=1, show_default=True,
              help="Repeat the grasp this many times.")
@click.option("--pause-s", type=click.FloatRange(0, 3600), default=5.0, show_default=True,
              help="Seconds of neutral between trials (the coils cool).")
def cli(design, backend, which, start, level, volts, policy, release_level, hold_level, release_s, hold_s,
        retract_s, trials, pause_s):
    """Grasp: retract the --config whiskers, hold (the arm lifts), release, return to neutral.

    The paper grasps at 3 V (the default level, actuation.voltage) with all 8, every second (4)
    or two opposite whiskers: --config all | every-second | opposite (or 8 / 4 / 2). Each phase
    change is printed with its time. The thermal guard derates or cuts a coil before its limit,
    so a long --hold-s at full level may be limited: a lower --hold-level keeps the coils cooler.
    Every coil is switched off at the end, on Ctrl-C, SIGTERM and errors. Example:

    \b
      whisker grasp --config every-second --backend gpio --hold-s 3 --hold-level 0.35
    """
    from whisker.drive.actuation import deenergise_on_signals, open_actuator
    from whisker.drive.sequences import run_sequence
    from whisker.drive.guard import RatingError

    try:
        with deenergise_on_signals():
            with open_actuator(design, backend, policy=policy) as act:
                lvl = resolve_level(design, level, volts)
                lvl = act.default_level() if lvl is None else lvl
                steps = build_sequence(design, which, start, lvl, hold_level, retract_s, hold_s, release_s,
                                       release_level)
                for trial in range(trials):
                    last = [None]

                    def report(t, phase):
                        if phase != last[0]:
                            last[0] = phase
                            click.echo(f"trial {trial + 1}/{trials}  t={t:6.2f} s  {phase:8s} "
                                       f"applied={[round(float(x), 3) for x in act.applied]}", err=True)

                    run_sequence(act, steps, on_tick=report)
                    if trial + 1 < trials:
                        time.sleep(pause_s)
                g = act.guard
                why = next((r for r in g.trip_reason if r), "")
                click.echo(f"done: peak winding temperature {g.peak_C.max():.1f} C (estimated; every material "
                           f"held {design.drive.guard_margin:g} C below its own limit, the weakest: "
                           f"{g.limit_label}), guard trips {g.trips.tolist()}"
                           + (f", on {why}" if why else ""), err=True)
    except (RatingError, ValueError, RuntimeError) as err:
        fail(f"grasp: {err}")
