"""`whisker closedloop`: the closed-loop grasp controller against the paper's open loop, in simulation."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from whisker.cliutil import fail

DEFAULT_SCENE = Path(__file__).resolve().parents[1] / "sim" / "scenes" / "grasp.toml"


@click.command()
@click.option("--scene", "scene_path", type=click.Path(dir_okay=False), default=str(DEFAULT_SCENE), show_default=False,
              help="Grasp scene (objects, tip height, lift; default the paper's grasp.toml).")
@click.option("--attempts", type=click.IntRange(1, 10000), default=20, show_default=True,
              help="Common placements per object and configuration.")
@click.option("--fps", type=click.FloatRange(1, 500), default=15.0, show_default=True, help="Camera frame rate.")
@click.option("--objects", multiple=True, help="Only these objects (repeatable; default all of the scene's).")
@click.option("--whiskers", "counts", multiple=True, type=int,
              help="Only the configurations with these many whiskers (repeatable: 8, 4, 2).")
@click.option("--out", type=click.Path(file_okay=False), default="runs/grasp-closed", show_default=True,
              help="Folder for closed_loop.md, closed_loop.json and closed_loop_runs.csv.")
@click.option("--early-contact", type=click.Choice(["abort", "continue"]), default="abort", show_default=True,
              help="A whisker touched before any coil is driven: abort (fail safe) or log it and grasp anyway.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def cli(scene_path, attempts, fps, objects, counts, out, early_contact, quiet):
    """Grasp the scene's objects open loop (the paper: 3 V, lift, hope) and closed loop (camera ->
    tracker -> states -> controller: grip on contact, lowest holding level, slip re-grip, fail
    safe), on the same placements, and write the paired table (docs/states.md)."""
    from tqdm import tqdm

    from whisker.files import atomic_write_text
    from whisker.sim import SceneError, load_scene, scene_design
    from whisker.sim.grasp_closed import closed_loop_csv, closed_loop_json, closed_loop_markdown, closed_loop_table
    from whisker.sim.paper import configurations

    try:
        scene = load_scene(scene_path)
        design = scene_design(scene)
        cfgs = configurations(scene, design)
        if counts:
            cfgs = [c for c in cfgs if len(c) in counts]
            if not cfgs:
                fail(f"closedloop: no configuration with {', '.join(map(str, counts))} whiskers")
        bar = tqdm(total=1.0, disable=quiet, file=sys.stderr, bar_format="{l_bar}{bar}| {elapsed}<{remaining}")

        def progress(f):
            bar.n = round(f, 4)
            bar.refresh()
        tab = closed_loop_table(scene, design, attempts=attempts, fps=fps, configs=cfgs, objects=list(objects) or None,
                                progress=progress, params={"early_contact": early_contact})
        bar.close()
    except (SceneError, ValueError) as err:
        fail(f"closedloop: {err}")
    except ImportError as err:
        fail(f"closedloop: the simulator needs {err.name or err} (pip install -e '.[sim]')", code=1)
    out = Path(out)
    md = closed_loop_markdown(tab)
    atomic_write_text(out / "closed_loop_runs.csv", closed_loop_csv(tab))
    atomic_write_text(out / "closed_loop.json", closed_loop_json(tab))
    atomic_write_text(out / "closed_loop.md", md)
    click.echo(md)
