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
    """Print the fully resolved design and its derived quantities (l_u, l_l, mm per pixel ...)."""
    derived = {**design.derived(), "digest": design.digest()}
    if as_json:
        click.echo(json.dumps({"design": design.to_dict(), "derived": derived}, indent=2))
        return
    import tomli_w

    click.echo(tomli_w.dumps(design.to_dict()))
    click.echo("# derived")
    for k, v in derived.items():
        click.echo(f"# {k} = {v}")
