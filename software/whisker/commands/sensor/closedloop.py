"""`whisker closedloop`: the closed-loop grasp controller, in simulation (against the paper's open loop)
or on the hardware (camera -> tracker -> controller -> coils, whisker.sensing.rig)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from whisker.cliutil import fail
from whisker.commands.sensor.actuate import config_options
from whisker.resources import scenes_dir

DEFAULT_SCENE = scenes_dir() / "grasp.toml"

#: options that only the simulated comparison reads, and those only a hardware run reads
SIM_ONLY = ("scene_path", "attempts", "objects", "counts", "out", "open_guard", "jobs", "locate")
HW_ONLY = ("source", "which", "start", "policy", "out_log", "rest_frames", "max_frames", "track_method",
           "calibration", "mask", "descend_mm", "descend_s", "lift_mm", "lift_s", "hold_s", "arm", "design_file",
           "overrides", "watchdog_s")


@click.command()
@click.option("--backend", type=click.Choice(["sim", "mock", "gpio"]), default="sim", show_default=True,
              help="sim: open vs closed loop on the simulator's grasp scene (the table of docs/states.md); "
                   "gpio: one closed-loop grasp on the Raspberry Pi's coils; mock: the same on gpiozero mock pins "
                   "(a dry run, e.g. replaying a recording).")
@click.option("--scene", "scene_path", type=click.Path(dir_okay=False), default=str(DEFAULT_SCENE), show_default=False,
              help="[sim] Grasp scene (objects, tip height, lift; default the paper's grasp.toml).")
@click.option("--attempts", type=click.IntRange(1, 10000), default=20, show_default=True,
              help="[sim] Common placements per object and configuration.")
@click.option("--fps", type=click.FloatRange(1, 500), default=15.0, show_default=True,
              help="Camera frame rate (hardware: the controller's frame period; a video's own rate wins).")
@click.option("--objects", multiple=True, help="[sim] Only these objects (repeatable; default all of the scene's).")
@click.option("--whiskers", "counts", multiple=True, type=int,
              help="[sim] Only the configurations with these many whiskers (repeatable: 8, 4, 2).")
@click.option("--out", type=click.Path(file_okay=False), default="runs/grasp-closed", show_default=True,
              help="[sim] Folder for closed_loop.md, closed_loop.json and closed_loop_runs.csv.")
@click.option("--open-guard/--bare-open", "open_guard", default=True, show_default=True,
              help="[sim] The open loop's levels pass through the same thermal guard as the closed loop's "
                   "(as on the hardware, whose actuator always applies it); --bare-open: the paper's protocol "
                   "without a guard (a simulator-only reference).")
@click.option("--locate", is_flag=True,
              help="[sim] At each closed-loop grip, where the object sits along the holding whiskers: a locate sweep "
                   "(docs/locate.md) per holding whisker, mm from the pivot, estimate+-1 sigma (true); column "
                   "`locate` of closed_loop_runs.csv.")
@click.option("--early-contact", type=click.Choice(["abort", "continue"]), default="abort", show_default=True,
              help="A whisker touched before any coil is driven: abort (fail safe) or log it and grasp anyway.")
@click.option("--design", "design_file", type=click.Path(dir_okay=False), default=None,
              help="[hardware] Design TOML file (default: hw/sensor.toml).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="[hardware] Override one design value (repeatable).")
@click.option("--source", default=None, metavar="SOURCE",
              help="[hardware] Frames: picamera, a camera index, a video file or an image folder (a folder's "
                   "times.csv, columns file,time_s, gives the recorded frame times).")
@config_options
@click.option("--policy", type=click.Choice(["derate", "cut"]), default="derate", show_default=True,
              help="[hardware] Thermal guard: derate near the limit, or full level then off.")
@click.option("--log", "out_log", type=click.Path(dir_okay=False), default=None,
              help="[hardware] JSON lines, one per frame (default runs/closedloop/grasp.jsonl), written whole at the end.")
@click.option("--rest-frames", type=click.IntRange(3, 1000), default=5, show_default=True,
              help="[hardware] First frames (coils off, whiskers untouched) that set the tracker's rest baseline.")
@click.option("--max-frames", type=click.IntRange(1, None), default=None,
              help="[hardware] Stop (coils off, exit 1) after this many controller frames.")
@click.option("--tracker", "track_method", type=click.Choice(["paper", "contour", "blob", "roi", "fit"]),
              default="roi", show_default=True, help="[hardware] Marker tracking method (docs/tracking.md).")
@click.option("--calibration", type=click.Path(dir_okay=False, exists=True), default=None,
              help="[hardware] Lens calibration .npz.")
@click.option("--mask", type=click.Path(dir_okay=False, exists=True), default=None,
              help="[hardware] Region-of-interest image.")
@click.option("--descend-mm", type=click.FloatRange(0.5, 500), default=15.0, show_default=True,
              help="[hardware] Descent to the grasp height, mm (the arm's path; hand-held: notional).")
@click.option("--descend-s", type=click.FloatRange(0.1, 120), default=2.0, show_default=True,
              help="[hardware] Seconds of the descent (the rest statistics are learned meanwhile).")
@click.option("--lift-mm", type=click.FloatRange(0, 500), default=30.0, show_default=True, help="[hardware] Lift, mm.")
@click.option("--lift-s", type=click.FloatRange(0.05, 120), default=1.0, show_default=True,
              help="[hardware] Seconds of the lift.")
@click.option("--hold-s", type=click.FloatRange(0, 600), default=2.0, show_default=True,
              help="[hardware] Seconds of the hold at the top, then release.")
@click.option("--arm", type=click.Choice(["handheld"]), default="handheld", show_default=True,
              help="[hardware] Who moves the sensor: handheld prints prompts (a robot driver implements "
                   "whisker.sensing.rig.Arm from Python).")
@click.option("--watchdog-s", type=click.FloatRange(0.05, 60), default=None,
              help="[hardware] Coils off after this many seconds without a frame (default: 2.5 frame periods "
                   "for a live camera, 5 s for a file).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="[sim] Worker processes (joblib) for the attempts; the table is the same for any count.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar / prompts.")
@click.pass_context
def cli(ctx, backend, scene_path, attempts, fps, objects, counts, out, open_guard, early_contact, jobs, quiet, locate,
        **hw):
    """Closed-loop grasps: grip on contact, lowest holding level, slip re-grip, fail safe.

    \b
    --backend sim (default): grasp the scene's objects open loop (the paper: 3 V, lift, hope) and
      closed loop (camera -> tracker -> states -> controller) on the same placements in the
      simulator, both through the thermal guard (--bare-open: the open loop without it), and write
      the paired table (docs/states.md).
    --backend gpio|mock: one closed-loop grasp on the hardware: --source frames -> tracker -> the same
      controller -> the coils (thermal guard, off on every exit) and the arm (hand-held prompts).
      A lost marker, dropped frames, contact before actuation, a thermal cut, no frame for
      --watchdog-s or the camera ending early stop it: coils off, the reason on stderr and in the
      log, exit status 1. Exit 0 when the grasp ended (held and released, or missed and released).

    \b
      whisker closedloop --backend gpio --source picamera --config every-second
      whisker closedloop --backend mock --source recording/ --log runs/replay.jsonl
    """
    from click.core import ParameterSource

    given = {k for k in list(SIM_ONLY) + list(HW_ONLY)
             if ctx.get_parameter_source(k) not in (ParameterSource.DEFAULT, None)}
    if backend == "sim":
        extra = sorted(given & set(HW_ONLY))
        if extra:
            fail(f"closedloop: --{extra[0].replace('out_log', 'log').replace('_', '-').replace('which', 'config')} "
                 "is for --backend mock or gpio (the simulator takes the design and frames from --scene)")
        return run_sim(scene_path, attempts, fps, objects, counts, out, early_contact, quiet, open_guard, jobs, locate)
    extra = sorted(given & set(SIM_ONLY))
    if extra:
        name = (extra[0].replace('scene_path', 'scene').replace('counts', 'whiskers')
                .replace('open_guard', 'open-guard/--bare-open').replace('_', '-'))
        fail(f"closedloop: --{name} "
             "is for --backend sim only")
    fps_given = ctx.get_parameter_source("fps") != ParameterSource.DEFAULT
    sys.exit(run_hardware(backend, fps, fps_given, early_contact, quiet, **hw))


def run_sim(scene_path, attempts, fps, objects, counts, out, early_contact, quiet, open_guard=True, jobs=1, locate=False):
    import numpy as np
    from tqdm import tqdm

    from whisker.files import atomic_write_text
    from whisker.sim import SceneError, load_scene, scene_design
    from whisker.sim.experiments.grasp_closed import closed_loop_csv, closed_loop_json, closed_loop_markdown, closed_loop_table
    from whisker.sim.experiments.paper import configurations

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
        noise = None
        if locate:
            from whisker.sim.experiments.locate_sweep import tracker_noise_bank

            noise = tracker_noise_bank(design, 60)                 # rendered rest frames, the fit tracker
            noise = noise[np.isfinite(noise).all(axis=1)]
            noise = noise - noise.mean(axis=0)
        tab = closed_loop_table(scene, design, attempts=attempts, fps=fps, configs=cfgs, objects=list(objects) or None,
                                progress=progress, params={"early_contact": early_contact}, open_guard=open_guard,
                                n_jobs=jobs, locate_noise=noise)
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


def free_closing_model(design):
    """expected_px(level): the free closing of each whisker in air from the design's coil and membrane
    model (the static equilibrium the simulator uses, whisker.sim.experiments.closed_loop.free_closing_px)."""
    from whisker.sim.experiments.closed_loop import free_closing_px

    return free_closing_px(design)


def run_hardware(backend, fps, fps_given, early_contact, quiet, *, design_file, overrides, source, which, start,
                 policy, out_log, rest_frames, max_frames, track_method, calibration, mask, descend_mm, descend_s,
                 lift_mm, lift_s, hold_s, arm, watchdog_s) -> int:
    from whisker.drive.actuation import configuration, deenergise_on_signals, open_actuator
    from whisker.vision.camera import FolderSource, SourceError, VideoSource, open_source
    from whisker.design import DesignError, load_design
    from whisker.sensing.grasp_control import GraspController
    from whisker.drive.guard import RatingError, ThermalGuard
    from whisker.sensing.rig import HandHeldArm, HardwareRig, handheld_params
    from whisker.vision.tracking import CalibrationError, Tracker

    if not source or not source.strip():
        fail("closedloop: --backend mock/gpio needs --source (picamera, a camera index, a video file or an image folder)")
    try:
        design = load_design(design_file, overrides)
    except DesignError as err:
        fail(f"design refused: {err}")
    n = design.whiskers.count
    try:
        active = list(map(int, configuration(n, which, start).nonzero()[0]))
        tracker = Tracker(design, track_method, calibration=calibration, mask=mask)
        p = Path(source)
        if source.strip() == "picamera":
            src = open_source("picamera", design, fps=fps)       # the controller's frame period is the camera's
        else:
            src = FolderSource(p, fps=fps) if p.is_dir() else open_source(source, design)
        live = not isinstance(src, (FolderSource, VideoSource)) or getattr(src, "live", False)
        if isinstance(src, VideoSource) and not src.live and not fps_given:
            fps = src.fps
        params = handheld_params(design, fps=fps, descend_mm=descend_mm, descend_s=descend_s, lift_mm=lift_mm,
                                 lift_s=lift_s, hold_s=hold_s, early_contact=early_contact)
    except (ValueError, SourceError) as err:
        fail(f"closedloop: {err}")
    except OSError as err:
        fail(f"closedloop: {err}", code=1)
    try:
        expected = free_closing_model(design)
    except ImportError as err:
        src.close()
        fail(f"closedloop: the free-closing model needs {err.name or err} (pip install -e '.[sim]')", code=1)
    ctl = GraspController(n, active, params, expected, guard=ThermalGuard(design, clock=lambda: 0.0))
    log = Path(out_log) if out_log else Path("runs/closedloop/grasp.jsonl")
    dog = watchdog_s if watchdog_s is not None else (max(0.2, params.max_gap_frames / params.fps) if live else 5.0)
    try:
        with deenergise_on_signals():
            with open_actuator(design, backend, policy=policy) as act:
                rig = HardwareRig(design, src, tracker, act, ctl, arm=HandHeldArm(echo=(lambda s: None) if quiet else None),
                                  log=log, rest_frames=rest_frames, max_frames=max_frames, watchdog_s=dog)
                res = rig.run()
    except (RatingError, ValueError, RuntimeError, CalibrationError) as err:
        fail(f"closedloop: {err}", code=1 if isinstance(err, RuntimeError) else 2)
    finally:
        src.close()
    if res.phase == "abort":
        click.echo(f"closedloop: ABORT after {res.frames} frames: {res.reason}; coils off; log {log}", err=True)
        return res.exit_code
    ms = sum(res.process_ms) / max(len(res.process_ms), 1)
    click.echo(f"closedloop: {res.reason or res.phase} after {res.frames} frames ({ms:.2f} ms/frame tracking + "
               f"controller); log {log}", err=True)
    return res.exit_code
