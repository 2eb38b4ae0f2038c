"""`whisker sim SCENE.toml`: simulate a scene with only the effects it needs."""

from __future__ import annotations

import json
import time
from pathlib import Path

import click

from whisker.cliutil import fail

#: a plain run of at least this many time steps says so before it starts
LONG_RUN_STEPS = 200_000


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("scene_file", type=click.Path(dir_okay=False))
@click.option("--explain", is_flag=True, help="List the effects built and skipped, each with its reason, and exit.")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Run folder (default: runs/<scene name>). Written atomically; old files are replaced.")
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Design TOML file instead of the one the scene names (the scene's [design] set still applies).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override a design value for this run, e.g. --set mechanics.tip_friction=0.5 (repeatable).")
@click.option("--scene-set", "scene_sets", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override a scene value (TOML syntax), e.g. --scene-set contact.patch_radius=2.5, "
                   "--scene-set experiment.placement_noise=3 or one object by name: "
                   "--scene-set 'objects.foam ball.friction=0.3' (repeatable).")
@click.option("--attempts", type=int, default=None, help="Override experiment.attempts (grasp).")
@click.option("--trials", type=int, default=None, help="Override experiment.trials (displacement, classification).")
@click.option("--jobs", type=click.IntRange(min=1), default=1, show_default=True,
              help="Worker processes (joblib) for the grasp table's attempts; the table is the same for any count.")
@click.option("--json", "as_json", is_flag=True, help="With --explain: print the plan as JSON.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def cli(scene_file, explain, out, design_file, overrides, scene_sets, attempts, trials, jobs, as_json, quiet):
    """Simulate SCENE.toml: the sensor, its whiskers, coils, objects and camera.

    Builds only the effects the scene calls for (kinematics, gravity, motion, magnetics, heating,
    contact via MuJoCo, camera, tracking) and says why; a scene where nothing moves is solved as a
    static equilibrium. The scene's [experiment] repeats it the way the paper does (angle vs voltage,
    grasp table, displacement vs time, classification dataset). Outputs go to a run folder:
    plan.json, tracks.csv, plots, tables, summary.json. The example scenes ship with the package:
    give their name (grasp, angle_vs_voltage, ...) instead of a file (software/whisker/sim/scenes/).
    """
    from whisker.sim import SceneError, SimulationError, load_scene, plan, scene_design
    from whisker.sim.contract import MissingModule
    from whisker.sim.validate import check, steps_of

    try:
        from whisker.resources import example, scenes_dir

        scene = load_scene(example(scene_file, scenes_dir()))
        if scene_sets:
            from whisker.sim.scene import scene_with_overrides
            scene = scene_with_overrides(scene, scene_sets)
        changes = {}
        if attempts is not None or trials is not None:
            ex = scene.experiment.model_dump()
            if attempts is not None:
                ex["attempts"] = attempts
            if trials is not None:
                ex["trials"] = trials
            changes["experiment"] = ex
        if changes:
            scene = scene.with_(**changes)
        design = scene_design(scene, tuple(overrides), design_file)
        p = plan(scene, design)
        check(scene, design, p)          # the same checks for --explain and for the run
    except (SceneError, MissingModule) as err:
        fail(f"scene refused: {err}")
    if explain:
        if as_json:
            click.echo(json.dumps(p.to_dict(), indent=2))
        else:
            click.echo(f"scene {scene.scene.name!r}: experiment {scene.experiment.kind}")
            click.echo(p.explain())
        return
    from tqdm import tqdm

    from whisker.sim.runner import run_scene

    out = Path(out) if out else Path("runs") / _slug(scene.scene.name)
    from whisker.cliutil import check_out_path

    check_out_path(out, "sim", folder=True)
    steps = steps_of(scene) if p.solver != "static" else 0
    if steps >= LONG_RUN_STEPS and scene.experiment.kind == "none":
        click.echo(f"long run: {steps:,} time steps of {scene.scene.timestep:g} s ({p.solver} solver); "
                   "the progress bar shows how far it is", err=True)
    bar = tqdm(total=1000, disable=quiet, unit="", bar_format="{l_bar}{bar}| {elapsed}<{remaining}",
               desc=scene.scene.name, file=None)

    last = [0.0]

    def progress(frac):                      # throttled: at most a few redraws per second
        now = time.monotonic()
        if now - last[0] < 0.25 and frac < 1.0:
            return
        last[0] = now
        bar.n = int(1000 * min(max(frac, 0.0), 1.0))
        bar.refresh()
    t0 = time.perf_counter()
    from whisker.cliutil import exclusive_out

    try:
        with exclusive_out(out, "sim"):
            summary = run_scene(scene, design, p, out, progress=progress, jobs=jobs)
    except (SceneError, SimulationError, MissingModule, ValueError) as err:
        bar.close()
        fail(f"simulation failed: {err}", 1)
    except OSError as err:
        bar.close()
        fail(f"sim: cannot write the run folder {out}/: {err.strerror or err}", 1)
    bar.n = 1000
    bar.close()
    click.echo(summary.get("headline", f"done in {time.perf_counter() - t0:.2f} s"))
    click.echo(f"run folder: {out}")
    flags = summary.get("flags") or []
    if flags:
        fail(f"sim: the run is unphysical: {'; '.join(flags)} (see {out}/summary.json)", 1)


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in name.lower()).strip("-") or "scene"
