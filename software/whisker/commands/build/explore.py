"""`whisker explore`: a grid of designs, each design's predicted grasp, force, heat and resolution."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from whisker.cliutil import fail


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="Base design TOML file (default: hw/sensor.toml, the paper's sensor).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Fixed override for every design, e.g. --set mechanics.tip_friction=0.6 (repeatable).")
@click.option("--vary", "varies", multiple=True, metavar="SECTION.KEY=VALUES",
              help="A design value to vary: a,b,c or start:stop:step (inclusive), e.g. --vary whiskers.count=4,6,8 "
                   "--vary whiskers.ring_radius=8:16:2 (repeatable; the grid is every combination).")
@click.option("--attempts", type=click.IntRange(1, 10_000), default=20, show_default=True,
              help="Simulated grasp attempts per object and configuration (make sim-grasp: 100).")
@click.option("--chunk", type=click.IntRange(1, 10_000), default=5, show_default=True,
              help="Attempts per task (the unit a worker runs and the cache keeps); the table does not depend on it.")
@click.option("--cad", type=click.Choice(["evaluate", "skip"]), default="evaluate", show_default=True,
              help="evaluate: the CAD checks of `make sweep` on every design (about 2-5 s each); skip: the design "
                   "model and the calculators only (the table says so).")
@click.option("--jobs", type=click.IntRange(-1, 4096), default=-1, show_default=True,
              help="Local processes through joblib (-1: every core; 1: this process, serially).")
@click.option("--workers", type=click.IntRange(1, 4096), default=None,
              help="Start a Dask LocalCluster with this many worker processes instead of joblib.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the tasks on an existing Dask cluster, e.g. tcp://10.0.0.5:8786 (workers need whisker-array[all,explore]).")
@click.option("--out", type=click.Path(file_okay=False), default="runs/explore", show_default=True,
              help="Output folder: results.csv, pareto_*.png, pareto/*.toml, summary.md, cache/ (finished tasks).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def cli(design_file, overrides, varies, attempts, chunk, cad, jobs, workers, scheduler, out, quiet):
    """Explore a grid of designs: for every design that builds, the steady tilt, tip travel and force at
    the grasp voltage, the time to the first thermal limit and the safe duty, the sensing resolution
    and the simulated grasp success on the paper's five objects (every whisker, and the paper's
    every-second and opposite-pair subsets), with Wilson 95 % intervals. A design that does not build
    is listed with its refusal. Finished tasks are cached in OUT/cache: run the same command again to
    resume an interrupted study. docs/explore.md.
    """
    from whisker.explore.grid import ExploreError, grid

    if not varies:
        raise click.UsageError("give at least one --vary SECTION.KEY=VALUES (e.g. --vary whiskers.count=6,8)")
    if workers is not None and scheduler is not None:
        raise click.UsageError("--workers starts a local cluster, --scheduler uses an existing one: give one")
    if jobs == 0:
        raise click.BadParameter("0 processes; give -1 (every core) or a count", param_hint="--jobs")
    if design_file is not None and not str(design_file).strip():
        fail("--design: empty file name; give a design TOML file or leave --design out")
    try:
        points = grid(design_file, tuple(overrides), list(varies))
    except ExploreError as err:
        fail(str(err))
    import importlib.util

    for mod in ("mujoco", *(("cadquery",) if cad == "evaluate" else ())):   # [sim], [cad]: before any task
        if importlib.util.find_spec(mod) is None:
            raise ModuleNotFoundError(f"No module named {mod!r}", name=mod)
    from whisker.explore.study import Study, run, table
    from whisker.explore.report import write
    from whisker.explore.tasks import TaskCache
    from whisker.resources import scenes_dir
    from whisker.sim.scene import load_scene

    scene = load_scene(scenes_dir() / "grasp.toml")
    scene = scene.with_(experiment={**scene.experiment.model_dump(), "attempts": attempts})
    study = Study(points, scene, attempts, min(chunk, attempts), cad == "evaluate")
    engine = _engine(jobs, workers, scheduler)
    out = Path(out)
    from tqdm import tqdm

    bar = tqdm(total=1, disable=quiet, unit="task", file=sys.stderr, desc="explore",
               bar_format="{desc}: {n}/{total} tasks |{bar}| [{elapsed}<{remaining}]{postfix}")
    shown = [0]

    def progress(p):
        bar.total = max(p.total, 1)
        bar.n = p.done
        bar.set_postfix_str(f"running {p.running}, failed {p.failed}, from cache {p.cached}", refresh=False)
        for line in p.failures[shown[0]:]:
            bar.write(f"task failed: {line}", file=sys.stderr)
        shown[0] = len(p.failures)
        bar.refresh()

    import warnings

    # an interrupt cancels the running tasks on purpose (they are not cached, a rerun does them)
    warnings.filterwarnings("ignore", message=r".*tasks which were still being processed", category=UserWarning)
    t0 = time.perf_counter()
    try:
        prog = run(study, engine, TaskCache(out / "cache"), progress)
    except KeyboardInterrupt:
        bar.close()
        fail(f"interrupted: the finished tasks are cached in {out / 'cache'}; run the same command to resume", 1)
    finally:
        engine.close()
    bar.close()
    rows = table(study)
    varied = [v.split("=", 1)[0].strip() for v in varies]
    base = Path(design_file) if design_file else None
    from whisker.design import DEFAULT_DESIGN

    base_text = (base or DEFAULT_DESIGN).read_text(encoding="utf-8")
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "refused", "failed")}
    summary = (f"# whisker explore: {len(rows)} designs, {counts['ok']} simulated, {counts['refused']} refused, "
               f"{counts['failed']} failed\n\n{attempts} attempts per object and configuration; CAD checks: {cad}; "
               f"{engine.name}; {prog.done - prog.cached} tasks run, {prog.cached} from the cache, "
               f"{time.perf_counter() - t0:.1f} s.")
    from whisker.design import DesignError, load_design

    try:
        base_digest = load_design(design_file, overrides).digest()
    except DesignError:
        base_digest = ""               # the base itself may be refused; only its grid points matter
    paths = write(out, rows, points, varied, base_text, summary, base_digest)
    click.echo(summary.splitlines()[0].removeprefix("# ") + f"; wrote {out}/results.csv, pareto_*.png, "
               f"{sum(p.suffix == '.toml' for p in paths)} Pareto design files in {out}/pareto/")
    if prog.failed:
        fail(f"explore: {prog.failed} tasks failed (first: {prog.failures[0]}); their designs are marked "
             "failed in results.csv, run again to retry them", 1)


def _engine(jobs: int, workers: int | None, scheduler: str | None):
    from whisker.explore.study import DaskEngine, JoblibEngine

    if workers is None and scheduler is None:
        return JoblibEngine(jobs)
    if scheduler is not None:
        from distributed.comm.addressing import parse_address

        try:
            parse_address(scheduler.strip(), strict=True)
        except ValueError as err:
            raise click.BadParameter(f"{scheduler!r} is not a Dask scheduler address like tcp://HOST:8786 ({err})",
                                     param_hint="--scheduler") from None
    try:
        return DaskEngine(workers=workers, address=scheduler.strip() if scheduler else None)
    except (OSError, TimeoutError) as err:
        fail(f"--scheduler {scheduler}: no Dask scheduler answers there ({type(err).__name__}: "
             f"{' '.join(str(err).split())[:200]})", 1)
