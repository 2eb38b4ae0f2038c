"""Shared command-line pieces: the design options every command takes, and clean failures."""

from __future__ import annotations

import functools
import sys

import click

from whisker.design import DesignError, load_design


def design_options(f):
    """Add --design FILE and --set section.key=value; pass the validated Design as `design`.

    A bad design exits with status 2 and one line naming the parameter.
    """
    @click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
                  help="Design TOML file (default: hw/sensor.toml, the paper's sensor).")
    @click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
                  help="Override one design value, e.g. --set whiskers.count=6 (repeatable).")
    @functools.wraps(f)
    def wrapper(*args, design_file=None, overrides=(), **kwargs):
        try:
            design = load_design(design_file, overrides)
        except DesignError as err:
            fail(f"design refused: {err}")
        return f(*args, design=design, **kwargs)
    return wrapper


def fail(message: str, code: int = 2) -> None:
    """Print one line to stderr and exit non-zero."""
    click.echo(message, err=True)
    sys.exit(code)
