"""`whisker design`: show the resolved design and the quantities derived from it."""

from __future__ import annotations

import json

import click

from whisker.cliutil import design_options


@click.group()
def cli():
    """Inspect the design model (hw/sensor.toml plus overrides)."""


#: units a field's description may start with (the design model's Field descriptions and the
#: comments of hw/sensor.toml both open with the unit: "mm, circle of rod centres")
UNITS = ("mm", "deg", "px", "ohm", "g/cm^3", "g", "s", "V", "A", "W", "T", "C", "K", "Hz", "turns", "N/m", "mN",
         "mm/px", "rad", "%")


def field_unit(design, section: str, key: str) -> str:
    """The unit of design value section.key from its Field description, which opens with it
    ("mm, circle of rod centres" -> "mm", "W/(m^2 K), coil surface to air" -> "W/(m^2 K)"), or ""."""
    import re

    model = getattr(design, section, None)
    field = type(model).model_fields.get(key) if model is not None else None
    desc = (field.description or "") if field is not None else ""
    m = re.match(r"\s*([^\s,;:(]+(?:\([^)]*\))?)", desc)
    if m:
        tok = m.group(1)
        if tok in UNITS or re.search(r"[/*^]", tok):
            return tok
    for suffix, unit in (("_deg", "deg"), ("_px", "px"), ("_mm", "mm"), ("_s", "s"), ("_ohm", "ohm")):
        if key.endswith(suffix):
            return unit
    return ""


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
            # None: not set in the file, the model's own source applies (e.g. a material table's limit)
            line = f"# {key} unset" if value is None else tomli_w.dumps({key: value}).strip()
            src = sources[f"{sec}.{key}"]
            unit = field_unit(design, sec, key)
            click.echo(f"{line:<40} # {unit + '; ' if unit else ''}{src}")
        click.echo("")
    click.echo("# derived")
    for k, v in derived.items():
        click.echo(f"# {k} = {v}")
    click.echo("# camera boards (camera.board; hw/camera_boards.toml)")
    for line in boards:
        click.echo(f"#   {line}")
