"""`whisker cad`: build, check and export the printable parts; sweep the feasible designs."""

from __future__ import annotations

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
    from whisker.cad.buildkey import FORMATS, up_to_date

    out = Path(out)
    if not force and up_to_date(out, design):
        click.echo(f"{out}/ is up to date (design {design.digest()})")
        return
    from whisker.cad.build import DesignRefused, build as run_build

    t0 = time.perf_counter()
    say = None if quiet else (lambda msg: click.echo(f"  {msg}", err=True))
    try:
        manifest = run_build(design, out, FORMATS, progress=say)
    except DesignRefused as err:
        fail(str(err), code=1)
    n = sum(len(p["checks"]) for p in manifest["parts"].values())
    click.echo(f"built {len(manifest['parts'])} parts for {design.whiskers.count} whiskers at "
               f"{design.whiskers.ring_radius:g} mm into {out}/: {n} checks passed "
               f"({time.perf_counter() - t0:.1f} s)")


def _int_range(text: str) -> list[int]:
    a, _, b = text.partition("..")
    return list(range(int(a), int(b or a) + 1))


def _float_list(text: str) -> list[float]:
    if ".." in text:  # start..stop:step
        rng, _, step = text.partition(":")
        a, _, b = rng.partition("..")
        a, b, s = float(a), float(b), float(step or 1)
        return [round(a + i * s, 6) for i in range(int(round((b - a) / s)) + 1)]
    return [float(x) for x in text.split(",")]


@cli.command()
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Design TOML file (default: hw/sensor.toml).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE", help="Override a design value.")
@click.option("--counts", default="2..16", show_default=True, help="Whisker counts, a..b.")
@click.option("--radii", default="4..25:1", show_default=True, help="Ring radii in mm: a..b:step or a,b,c.")
@click.option("--out", type=click.Path(file_okay=False), default="exports/sweep", show_default=True)
@click.option("--workers", default=-1, show_default=True, help="Parallel processes (joblib; -1 = every core).")
def sweep(design_file, overrides, counts, radii, out, workers):
    """Build and check every (count, radius) pair: a table and a plot of the feasible region.

    Every size set to "auto" in the design follows the ring. Each refused cell names the physical
    conflict behind it; the plot draws the small-ring bound (neighbouring coils at full inward swing).
    """
    from tqdm import tqdm

    from whisker.cad.sweep import sweep as run_sweep, write_reports

    counts_l, radii_l = _int_range(counts), _float_list(radii)
    bar = tqdm(total=len(counts_l) * len(radii_l), desc="designs", unit="design", file=sys.stderr)

    def progress(i, n):
        bar.update(i - bar.n)

    t0 = time.perf_counter()
    rows = run_sweep(counts_l, radii_l, design_file, tuple(overrides), workers, progress)
    bar.close()
    per = (time.perf_counter() - t0) / max(1, len(rows))
    paths = write_reports(rows, Path(out))
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
    from whisker.cad.assembly_images import update_page, write_assembly_images
    from whisker.design import DesignError

    try:
        w, h = (int(v) for v in size.lower().split("x"))
        if w < 100 or h < 100:
            raise ValueError
    except ValueError:
        fail(f"--size {size!r}: expected WIDTHxHEIGHT of at least 100x100 pixels, e.g. 900x700")
    try:
        paths = write_assembly_images(design, Path(out), (w, h), progress=lambda p: click.echo(f"  wrote {p}", err=True))
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
