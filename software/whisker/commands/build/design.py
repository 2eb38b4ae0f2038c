"""`whisker design`: show the resolved design and the quantities derived from it."""

from __future__ import annotations

import json

import click

from whisker.cliutil import design_options


@click.group()
def cli():
    """Inspect the design model (hw/sensor.toml plus overrides)."""


@cli.command()
@design_options
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of TOML.")
def show(design, as_json):
    """Print the fully resolved design, where each value came from, and its derived quantities.

    Every value is marked "file" (hw/sensor.toml, --design or --set) or "rule" (set to "auto" in the
    file and sized from the ring by whisker.design.sizing, with the rule's reason). The camera board
    profiles camera.board can choose are listed at the end.
    """
    from whisker.design.camera_boards import describe

    derived = {**design.derived(), "digest": design.digest()}
    # the stiffness "auto" is the membrane model's (whisker.mechanics.membrane), resolved here to show it;
    # without the [fem] extra and off the shipped/cached geometries, the line says why instead
    from whisker.mechanics.membrane import MembraneError, design_stiffness_Nmm_per_rad, stiffness_source
    try:
        derived["rotational_stiffness_Nmm_per_rad"] = design_stiffness_Nmm_per_rad(design)
        derived["rotational_stiffness_source"] = stiffness_source(design)
    except MembraneError as err:
        derived["rotational_stiffness_Nmm_per_rad"] = None
        derived["rotational_stiffness_source"] = str(err)
    data = design.to_dict()
    sources = {f"{sec}.{key}": design.source(f"{sec}.{key}") for sec, vals in data.items() for key in vals}
    boards = describe()
    if as_json:
        click.echo(json.dumps({"design": data, "sources": sources, "derived": derived, "camera_boards": boards},
                              indent=2))
        return
    import tomli_w

    for sec, vals in data.items():
        click.echo(f"[{sec}]")
        for key, value in vals.items():
            line = tomli_w.dumps({key: value}).strip()
            src = sources[f"{sec}.{key}"]
            click.echo(f"{line:<40} # {src}")
        click.echo("")
    click.echo("# derived")
    for k, v in derived.items():
        click.echo(f"# {k} = {v}")
    click.echo("# camera boards (camera.board; hw/camera_boards.toml)")
    for line in boards:
        click.echo(f"#   {line}")
