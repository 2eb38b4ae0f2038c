"""`whisker hw`: bill of materials and coil-driver wiring (pin map, netlist, ERC) from the design."""

from __future__ import annotations

from pathlib import Path

import click

from whisker.cliutil import design_options, fail


@click.group()
def cli():
    """Hardware outputs generated from the design: BOM (hw/bom.csv) and driver wiring (hw/pcb/)."""


@cli.command()
@design_options
@click.option("--out", type=click.Path(dir_okay=False), default="hw/bom.csv", show_default=True,
              help="CSV file to write ('-' prints to stdout).")
@click.option("--print-report", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Slicer report (exports/print_report.json): adds sliced filament grams to the notes.")
def bom(design, out, print_report):
    """Write the bill of materials for the design (quantities from the design and its CAD volumes).

    Exit status 2 with one line when the design cannot be wired (too many coils for the Pi) or
    the BOM cannot be made.
    """
    from whisker.bom import BomError, bom_csv, make_bom, write_bom_csv
    from whisker.drive.pins import PinMapError

    try:
        rows = make_bom(design, print_report)
    except (PinMapError, BomError) as err:
        fail(f"bom refused: {err}")
    if out == "-":
        click.echo(bom_csv(rows), nl=False)
        return
    write_bom_csv(rows, out)
    click.echo(f"wrote {out}: {len(rows)} lines for {design.whiskers.count} whiskers "
               f"(design {design.digest()})")


@cli.command()
@design_options
@click.option("--out", type=click.Path(file_okay=False), default="hw/pcb/generated", show_default=True,
              help="Output folder for pinout.csv/.md, wiring.png, driver.net, erc.txt, summary.json.")
@click.option("--no-diagram", is_flag=True, help="Skip the wiring diagram (faster).")
def pcb(design, out, no_diagram):
    """Pin map, pinout table, wiring diagram and SKiDL KiCad netlist; fails on any ERC error.

    SKiDL's ERC never fails by itself: its errors are counted here and any error exits 1
    (the output folder is then left as it was). Too many coils for the Pi exits 2.
    """
    from whisker.coil.driver import DriverError
    from whisker.pcb.build import ErcFailed, build
    from whisker.drive.pins import PinMapError

    try:
        summary = build(design, Path(out), draw=not no_diagram)
    except (PinMapError, DriverError) as err:  # DriverError: no series resistor part carries the power
        fail(f"pcb refused: {err}")
    except ErcFailed as err:
        fail(str(err), code=1)
    for w in summary["supply_warnings"]:
        click.echo(f"caution: {w}", err=True)
    click.echo(f"wrote {out}/: {summary['whiskers']} coils, {summary['modules']} driver module(s), "
               f"{summary['parts']} parts, {summary['nets']} nets; ERC {summary['erc_errors']} errors, "
               f"{summary['erc_warnings']} warnings")


@cli.command()
@design_options
@click.option("--out", type=click.Path(file_okay=False), default="hw/pcb/generated/hat", show_default=True,
              help="Output folder for the HAT: netlist, ERC, placement, routed board, Gerbers, drill, BOM, CPL, renders.")
@click.option("--no-route", is_flag=True, help="Circuit, ERC and placement only (no KiCad needed).")
def hat(design, out, no_route):
    """The driver HAT for the design (driver.type is set to "HAT" for it): SKiDL circuit + ERC,
    parts placed by code on the 65 x 56.5 mm HAT outline, routed (freeroute), checked by
    `kicad-cli pcb drc` (0 errors, 0 unconnected), Gerbers/Excellon (dates stripped), JLCPCB BOM and
    CPL, top/bottom renders. Needs KiCad 9 (kicad-cli, pcbnew) unless --no-route.

    Exit status 2 with one line for a design the HAT cannot carry (coil current above the bridge's
    rating, more coils than its monitors address, unknown bridge) or without KiCad; 1 when ERC or DRC
    fails. The output folder is replaced only by a complete, clean build.
    """
    from whisker.coil.driver import DriverError
    from whisker.drive.pins import PinMapError
    from whisker.pcb.board import HatErcFailed, build_hat
    from whisker.pcb.hat import HatError
    from whisker.pcb.kicad import BoardFailed, KicadMissing

    try:
        summary = build_hat(design, Path(out), route=not no_route, log=lambda m: click.echo(m, err=True))
    except (HatError, PinMapError, DriverError) as err:
        fail(f"hat refused: {err}")
    except KicadMissing as err:
        fail(f"hat: {err}")
    except (HatErcFailed, BoardFailed) as err:
        fail(str(err), code=1)
    drc = summary.get("drc")
    click.echo(f"wrote {out}/: {summary['whiskers']} coils, {summary['parts']} parts, {summary['nets']} nets; ERC "
               f"{summary['erc_errors']} errors" + (f"; DRC {drc['errors']} errors, {drc['unconnected']} unconnected"
                                                     if drc else "; not routed (--no-route)"))


@cli.command()
@design_options
def pins(design):
    """Print the pin map (one line per coil) as the actuation software uses it."""
    from whisker.drive.pins import PinMapError, pin_map

    try:
        chans = pin_map(design)
    except PinMapError as err:
        fail(f"pins refused: {err}")
    for c in chans:
        where = "GPIO" if c.bus == "gpio" else f"PCA9685@0x{c.address:02X} ch"
        en = "jumper" if c.enable is None else f"GPIO{c.enable}"
        click.echo(f"coil {c.whisker}: forward {where}{c.forward}, backward {where}{c.backward}, "
                   f"enable {en}, module U{c.module + 1} channel {c.channel}")
