"""`whisker print`: slicer check and print report, part preview images, the printer profile."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from whisker.cliutil import design_options, fail

@click.group()
def cli():
    """Printing: slice every printable part with PrusaSlicer (time, grams, supports), preview images.

    The printer's numbers (bed, height, nozzle, layers, filament density) come from the PrusaSlicer
    profile named by the design's print.profile (default hw/printer/prusa_mk3s_pla_0.2mm.ini).
    """


def _ensure_build(design, out: Path, quiet: bool) -> None:
    """Build the design into `out` unless a build of exactly this design and code is there."""
    from whisker.cad.buildkey import FORMATS, up_to_date

    if up_to_date(out, design):
        return
    from whisker.cad.build import DesignRefused, build

    if not quiet:
        click.echo(f"  building the parts into {out}/", err=True)
    try:
        build(design, out, FORMATS)
    except DesignRefused as err:
        fail(str(err), code=1)


@cli.command()
@design_options
@click.option("--build", "out", type=click.Path(file_okay=False), default="exports", show_default=True,
              help="Build folder (from `whisker cad build`, STL in mm); built first if it holds another design.")
@click.option("--coarse", is_flag=True,
              help="Slice with 0.3 mm layers, 1 perimeter, no infill: proves the parts slice, fast, but the "
                   "time and grams are NOT real estimates (used by the tests).")
@click.option("--no-gcode", is_flag=True, help="Do not keep the G-code files (out/gcode/<part>.gcode).")
@click.option("--quiet", "-q", is_flag=True, help="Only print the result lines.")
def check(design, out, coarse, no_gcode, quiet):
    """Check and slice every printable part headless; write the print report (into the --build folder).

    Per part: fits the printer, `prusa-slicer --info` reports a manifold mesh with no open edges,
    admesh agrees, an overhang check decides supports, and the part slices into G-code with layers;
    the estimated print time and filament grams are read from the G-code. Writes
    BUILD/print_report.md and .json, BUILD/gcode/*.gcode, and adds the results to BUILD/manifest.json.

    Exit status 1 if a part is not printable (one line per failed part, with the reason), 3 if
    prusa-slicer or admesh is not installed (the message says how to install it).
    """
    from tqdm import tqdm

    from whisker.cad.verify.printcheck import ToolMissing, check_exports, find_tool, fmt_duration

    out = Path(out)
    try:  # before the (slow) build: a missing slicer is the first thing to hear about
        find_tool("prusa-slicer"), find_tool("admesh")
    except ToolMissing as err:
        fail(str(err), code=3)
    _ensure_build(design, out, quiet)
    parts = json.loads((out / "manifest.json").read_text())["parts"].values()
    bar = tqdm(total=sum(bool(p.get("printable")) for p in parts), desc="slicing", unit="part", file=sys.stderr,
               disable=quiet)
    started = []

    def progress(msg: str) -> None:  # called as each part starts
        if started:
            bar.update(1)
        started.append(msg)
        bar.set_postfix_str(msg.removeprefix("checking and slicing "))

    try:
        report = check_exports(design, out, coarse=coarse, keep_gcode=not no_gcode, progress=progress)
        bar.update(1 if started else 0)
    except ToolMissing as err:
        fail(str(err), code=3)
    finally:
        bar.close()
    from whisker.cad.verify.printcheck import PartPrint

    for part in report["parts"].values():
        click.echo(("  " if part["ok"] else "  FAILED ") + PartPrint(**part).line())
    s = report["summary"]
    note = " (coarse slicing: not real estimates)" if coarse else ""
    click.echo(f"{s['printable']} of {s['parts']} parts printable; one sensor {fmt_duration(s['total_time_s'])}, "
               f"{s['total_filament_g']:.1f} g{note}; report: {out / 'print_report.md'}")
    if not s["all_ok"]:
        sys.exit(1)


@cli.command()
@design_options
@click.option("--build", "out", type=click.Path(file_okay=False), default="exports", show_default=True,
              help="Build folder (from `whisker cad build`, STL in mm); built first if it holds another design.")
@click.option("--images", type=click.Path(file_okay=False), default=None,
              help="Folder for the PNG files [default: BUILD/preview]. `docs/images` for the README.")
@click.option("--size", default="900x700", show_default=True, help="Image size in pixels, WxH.")
def preview(design, out, images, size):
    """PNG images of every printable part (as it lies on the bed) and of the assembly (cut open)."""
    from tqdm import tqdm

    from whisker.cad.pictures.preview import write_previews

    out = Path(out)
    _ensure_build(design, out, quiet=False)
    try:
        w, h = (int(v) for v in size.lower().split("x"))
    except ValueError:
        fail(f"--size {size!r}: expected WIDTHxHEIGHT, e.g. 900x700")
    bar = tqdm(desc="rendering", unit="image", file=sys.stderr)
    paths = write_previews(design, out, Path(images) if images else out / "preview", (w, h),
                           progress=lambda name: bar.update(1))
    bar.close()
    click.echo(f"wrote {len(paths)} images: " + ", ".join(str(p) for p in paths))


@cli.command()
@design_options
def profile(design):
    """Show the printer profile the design uses and the numbers read from it."""
    from whisker.design.printer import load_profile

    p = load_profile(design.print.profile)
    click.echo(f"{p.path}\n  bed {p.bed_x:g} x {p.bed_y:g} mm, max height {p.max_height:g} mm, nozzle "
               f"{p.nozzle_diameter:g} mm, layers {p.layer_height:g} mm (first {p.first_layer_height:g}), filament "
               f"{p.filament_diameter:g} mm at {p.filament_density:g} g/cm^3, supports below "
               f"{p.support_threshold_deg:g} deg from horizontal")
