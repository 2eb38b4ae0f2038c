"""Shared command-line pieces: the design options every command takes, and clean failures."""

from __future__ import annotations

import functools
import math
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
        if design_file is not None and not str(design_file).strip():
            fail("--design: empty file name; give a design TOML file or leave --design out for hw/sensor.toml")
        try:
            design = load_design(design_file, overrides)
        except DesignError as err:
            fail(f"design refused: {err}")
        return f(*args, design=design, **kwargs)
    return wrapper


def check_out_path(path, command: str, *, folder: bool = False):
    """Validate an output path before any work: not an existing folder when a file is written (or a
    file when a folder is), and its nearest existing parent a writable folder. Exits 2 with one
    line otherwise; returns the Path."""
    import os
    from pathlib import Path

    p = Path(path)
    if not str(path).strip():
        fail(f"{command}: --out is empty; give a file or folder name")
    if p.exists():
        if not folder and p.is_dir():
            fail(f"{command}: --out {p} is a folder; give a file name")
        if folder and not p.is_dir():
            fail(f"{command}: --out {p} is a file; give a folder name")
    parent = p.parent if not p.exists() else (p if folder else p.parent)
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        fail(f"{command}: --out {p}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK) or str(parent.resolve()).startswith(("/proc", "/sys")):
        fail(f"{command}: --out {p}: cannot write in {parent} (permission denied or a system folder)")
    return p


def exclusive_out(path, command: str):
    """Context manager: the output lock of `path` (whisker.files.output_lock); a second writer
    exits 1 with one line naming the output."""
    import contextlib

    from whisker.files import OutputBusy, output_lock

    @contextlib.contextmanager
    def _cm():
        try:
            cm = output_lock(path)
            cm.__enter__()
        except OutputBusy as err:
            fail(f"{command}: {err}", code=1)
        except OSError as err:
            fail(f"{command}: cannot lock the output {path}: {err.strerror or err}", code=1)
        try:
            yield
        except BaseException as err:
            if not cm.__exit__(type(err), err, err.__traceback__):
                raise
        else:
            cm.__exit__(None, None, None)
    return _cm()


def fail(message: str, code: int = 2) -> None:
    """Print one line to stderr and exit non-zero."""
    click.echo(message, err=True)
    sys.exit(code)


#: largest magnitude a number option without its own bounds accepts: no quantity of this sensor in
#: the CLI's units (mm, g, s, V, A, ohm, deg, C, Hz) comes near a million; beyond it a value is a
#: typo and would overflow the models (1e308 V squared is inf).
MAX_MAGNITUDE = 1e6


class _Checked(click.ParamType):
    """A parameter type that converts with `inner` (its own type) and then checks the value."""

    def __init__(self, inner: click.ParamType):
        self.inner = inner
        self.name = inner.name

    def get_metavar(self, param, ctx=None):
        try:
            return self.inner.get_metavar(param, ctx)
        except TypeError:  # click < 8.2
            return self.inner.get_metavar(param)

    def shell_complete(self, ctx, param, incomplete):
        return self.inner.shell_complete(ctx, param, incomplete)

    def __repr__(self):
        return f"{type(self).__name__}({self.inner!r})"


class FiniteFloat(_Checked):
    """A float option that refuses NaN and +-inf, and magnitudes beyond its range (default +-MAX_MAGNITUDE)."""

    def convert(self, value, param, ctx):
        v = self.inner.convert(value, param, ctx)
        if v is None or isinstance(value, bool):
            return v
        if not math.isfinite(v):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        has_max = isinstance(self.inner, click.FloatRange) and self.inner.max is not None
        has_min = isinstance(self.inner, click.FloatRange) and self.inner.min is not None
        if (not has_max and v > MAX_MAGNITUDE) or (not has_min and v < -MAX_MAGNITUDE):
            self.fail(f"{value!r} is beyond +-{MAX_MAGNITUDE:g} (no quantity of the sensor is that large)",
                      param, ctx)
        return v


class NonEmptyPath(_Checked):
    """A click.Path that refuses an empty name (which would mean the current folder) and one that is
    not UTF-8."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail("empty path: give a file or folder name", param, ctx)
        if isinstance(value, str):
            try:
                value.encode("utf-8")
            except UnicodeEncodeError:
                self.fail(f"{value!r} is not a UTF-8 name; rename it (the CAD, image and plot libraries "
                          "need UTF-8 paths)", param, ctx)
        return self.inner.convert(value, param, ctx)


def harden_numbers(cmd: click.Command) -> click.Command:
    """Give every float parameter of `cmd` (and its subcommands) the FiniteFloat check, every path
    parameter the NonEmptyPath check and every text parameter the Utf8Text check, once.

    Called by the top-level group on every command it loads, so a command added later gets it too.
    """
    if getattr(cmd, "_finite_numbers", False):
        return cmd
    cmd._finite_numbers = True
    for p in cmd.params:
        if isinstance(p.type, click.types.FloatParamType):
            p.type = FiniteFloat(p.type)
        elif isinstance(p.type, click.Path):
            p.type = NonEmptyPath(p.type)
        elif type(p.type) is click.types.StringParamType:
            p.type = Utf8Text(p.type)
    if isinstance(cmd, click.Group):
        for sub in cmd.commands.values():
            harden_numbers(sub)
    return cmd


class Utf8Text(_Checked):
    """Text that is valid UTF-8 (a shell passes undecodable bytes as lone surrogates, which no plot,
    CSV or JSON writer accepts)."""

    def convert(self, value, param, ctx):
        v = self.inner.convert(value, param, ctx)
        if isinstance(v, str):
            try:
                v.encode("utf-8")
            except UnicodeEncodeError:
                self.fail(f"{v!r} is not valid UTF-8 text", param, ctx)
        return v
