"""`whisker cad`: build, check and export the printable parts; sweep the feasible designs."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import click

from whisker.cliutil import design_options, fail

@click.group()
def cli():
    """Parametric CAD: every part of the sensor from the design, as STL and STEP, checked."""


@cli.command()
@design_options
@click.option("--out", type=click.Path(file_okay=False), default="exports", show_default=True,
              help="Output folder for STL, STEP and manifest.json.")
@click.option("--force", is_flag=True, help="Rebuild even if the output is up to date.")
@click.option("--quiet", "-q", is_flag=True, help="Only print the result line.")
def build(design, out, force, quiet):
    """Build every part, run every geometry check, write STL + STEP + manifest.json.

    A design that fails a check is refused: exit status 1, one line naming the parameters and
    the violated constraint, and the output folder left exactly as it was.
    """
    from whisker.cliutil import check_out_path
    from whisker.design.bounds import refusal

    check_out_path(out, "cad build", folder=True)
    why = refusal(design)                    # closed-form bounds first: no solid for a design they rule out
    if why:
        fail(f"design refused before building: {why}", code=1)
    from whisker.cad.buildkey import FORMATS, up_to_date

    out = Path(out)
    if not force and up_to_date(out, design):
        click.echo(f"{out}/ is up to date (design {design.digest()})")
        return
    from whisker.cad.build import DesignRefused, build as run_build

    t0 = time.perf_counter()
    say = None if quiet else (lambda msg: click.echo(f"  {msg}", err=True))
    from whisker.cliutil import exclusive_out

    with exclusive_out(out, "cad build"):
        try:
            manifest = run_build(design, out, FORMATS, progress=say)
        except DesignRefused as err:
            fail(str(err), code=1)
        except OSError as err:
            fail(f"cad build: cannot write the parts into {out}/: {err.strerror or err}", code=1)
    n = sum(len(p["checks"]) for p in manifest["parts"].values())
    click.echo(f"built {len(manifest['parts'])} parts for {design.whiskers.count} whiskers at "
               f"{design.whiskers.ring_radius:g} mm into {out}/: {n} checks passed "
               f"({time.perf_counter() - t0:.1f} s)")


def _num(text: str, what: str, kind=float):
    try:
        v = kind(text.strip())
    except ValueError:
        raise click.BadParameter(f"{text.strip()!r} is not {'an integer' if kind is int else 'a number'} ({what})")
    if not math.isfinite(v):
        raise click.BadParameter(f"{text.strip()!r} is not a finite number ({what})")
    return v


def _int_range(text: str) -> list[int]:
    """a..b (a <= b), or a single count; refuses text, an inverted range, counts below 2."""
    a, sep, b = text.partition("..")
    lo = _num(a, "counts are a..b", int)
    hi = _num(b, "counts are a..b", int) if sep else lo
    if hi < lo:
        raise click.BadParameter(f"{text!r} is an inverted range: give a..b with a <= b, e.g. 2..16")
    if lo < 2 or hi > 64:
        raise click.BadParameter(f"{text!r}: whisker counts must be within 2..64")
    return list(range(lo, hi + 1))


def _float_list(text: str) -> list[float]:
    """a..b:step (a <= b, step > 0) or a,b,c, in mm; refuses text, NaN, an inverted range, a zero step."""
    if ".." in text:  # start..stop:step
        rng, _, step = text.partition(":")
        a, _, b = rng.partition("..")
        a, b = _num(a, "radii are a..b:step or a,b,c"), _num(b, "radii are a..b:step or a,b,c")
        s = _num(step, "the step of a..b:step") if step.strip() else 1.0
        if b < a:
            raise click.BadParameter(f"{text!r} is an inverted range: give a..b:step with a <= b, e.g. 4..25:1")
        if s <= 0:
            raise click.BadParameter(f"{text!r}: the step must be > 0 mm, e.g. 4..25:1")
        n = int(round((b - a) / s)) + 1
        if n > 10000:
            raise click.BadParameter(f"{text!r} gives {n} radii; at most 10000")
        vals = [round(a + i * s, 6) for i in range(n)]
    else:
        vals = [_num(x, "radii are a..b:step or a,b,c") for x in text.split(",")]
    if min(vals) <= 0 or max(vals) > 1000:
        raise click.BadParameter(f"{text!r}: ring radii must be within (0, 1000] mm")
    return vals


@cli.command()
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Design TOML file (default: hw/sensor.toml).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE", help="Override a design value.")
@click.option("--counts", default="2..16", show_default=True, help="Whisker counts, a..b (a <= b) or one count.")
@click.option("--radii", default="4..25:1", show_default=True,
              help="Ring radii in mm: a..b:step (a <= b, step > 0 mm) or a,b,c.")
@click.option("--out", type=click.Path(file_okay=False), default="exports/sweep", show_default=True,
              help="Folder for sweep.csv, sweep.md and sweep.png.")
@click.option("--workers", type=int, default=-1, show_default=True,
              help="Parallel processes (joblib): a positive count, or -1 = every core.")
def sweep(design_file, overrides, counts, radii, out, workers):
    """Build and check every (count, radius) pair: a table and a plot of the feasible region.

    Every size set to "auto" in the design follows the ring. Each refused cell names the physical
    conflict behind it; the plot draws the small-ring bound (neighbouring coils at full inward swing).
    """
    from whisker.cliutil import check_out_path, exclusive_out
    from whisker.design import DesignError, load_design

    try:
        counts_l = _int_range(counts)
    except click.BadParameter as err:
        fail(f"cad sweep: --counts: {err.message}")
    try:
        radii_l = _float_list(radii)
    except click.BadParameter as err:
        fail(f"cad sweep: --radii: {err.message}")
    if workers == 0 or workers < -1:
        fail(f"cad sweep: --workers {workers}: give a positive number of processes, or -1 for every core")
    check_out_path(out, "cad sweep", folder=True)
    try:
        load_design(design_file, tuple(overrides))
    except DesignError as err:
        fail(f"design refused: {err}")
    from tqdm import tqdm

    from whisker.cad.verify.sweep import sweep as run_sweep, write_reports

    bar = tqdm(total=len(counts_l) * len(radii_l), desc="designs", unit="design", file=sys.stderr)

    def progress(i, n):
        bar.update(i - bar.n)

    t0 = time.perf_counter()
    with exclusive_out(out, "cad sweep"):
        rows = run_sweep(counts_l, radii_l, design_file, tuple(overrides), workers, progress)
        bar.close()
        per = (time.perf_counter() - t0) / max(1, len(rows))
        try:
            paths = write_reports(rows, Path(out))
        except OSError as err:
            fail(f"cad sweep: cannot write the tables into {out}/: {err.strerror or err}", code=1)
    ok = sum(r["feasible"] for r in rows)
    click.echo(f"{ok} of {len(rows)} designs feasible ({per:.2f} s per design); wrote "
               + ", ".join(str(p) for p in paths))


@cli.command("assembly-images")
@design_options
@click.option("--out", type=click.Path(file_okay=False), default="exports/assembly", show_default=True,
              help="Folder for step_NN_<name>.png (`make assembly-images`: docs/images/assembly).")
@click.option("--size", default="900x700", show_default=True, help="Image size in pixels, WxH.")
@click.option("--page", type=click.Path(dir_okay=False, exists=True), default=None,
              help="Markdown page whose sequence table (between its BEGIN/END SEQUENCE TABLE comments) is "
                   "rewritten from hw/assembly_sequence.toml, e.g. docs/assembly.md.")
def assembly_images(design, out, size, page):
    """One PNG per assembly step: the casting steps, then every step of hw/assembly_sequence.toml.

    Parts already in place are grey, the step's new parts orange, moved back along their
    insertion path (drawn as a dashed arrow); the mount and mould are cut open on the x-z plane.
    """
    from whisker.cliutil import check_out_path, exclusive_out

    try:                                         # every option checked before the CAD kernel loads
        w, h = (int(v) for v in size.lower().split("x"))
        if w < 100 or h < 100 or w > 10000 or h > 10000:
            raise ValueError
    except ValueError:
        fail(f"--size {size!r}: expected WIDTHxHEIGHT of 100x100 to 10000x10000 pixels, e.g. 900x700")
    if page:
        begin = "<!-- BEGIN SEQUENCE TABLE"
        try:
            text = Path(page).read_text(encoding="utf-8")
        except UnicodeDecodeError:
            fail(f"--page {page}: not UTF-8 text; give a Markdown page such as docs/assembly.md")
        except OSError as err:
            fail(f"--page {page}: cannot read it ({err.strerror or err})", code=1)
        if begin not in text:
            fail(f"--page {page}: no sequence table block ({begin} ... END SEQUENCE TABLE comments) to rewrite")
    check_out_path(out, "cad assembly-images", folder=True)
    from whisker.cad.pictures.assembly_images import update_page, write_assembly_images
    from whisker.design import DesignError

    from tqdm import tqdm

    bar = tqdm(desc="assembly images", unit="image", file=sys.stderr)
    try:
        with exclusive_out(out, "cad assembly-images"):
            paths = write_assembly_images(design, Path(out), (w, h),
                                          progress=lambda p: (bar.update(), bar.set_postfix_str(Path(p).name)))
        bar.close()
        if page:
            changed = update_page(Path(page), design)
            click.echo(f"  {'updated' if changed else 'unchanged'}: the sequence table in {page}", err=True)
    except DesignError as err:
        fail(f"design refused: {err}")
    except OSError as err:
        fail(f"cannot write the images into {out}/: {err}", code=1)
    except ValueError as err:  # the page has no table block
        fail(str(err))
    click.echo(f"wrote {len(paths)} assembly images into {out}/")
