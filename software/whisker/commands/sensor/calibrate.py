"""`whisker calibrate`: from an assembled sensor to trustworthy numbers (docs/bringup.md).

camera     lens calibration from ChArUco views (fisheye and rational models, the better one kept)
board      the ChArUco board for the design, PNG + PDF at true scale
wiring     pulse every coil, diagnose swapped / reversed / dead coils, write a pin-map override
stiffness  the paper's Fig. 4 protocol: fit the membrane's rotational stiffness
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from whisker.cliutil import design_options, fail
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad


@click.group()
def cli():
    """Calibrate a built sensor: lens, board, coil wiring, membrane stiffness (docs/bringup.md)."""


# ---- camera -----------------------------------------------------------------------------------------

def _collect_views(spec, source, max_frames: int, every: int, progress: bool):
    """Detected board views and refused frames (name, reason) from a frame source."""
    from tqdm import tqdm

    from whisker.bringup.charuco import View, detect

    board = spec.board()
    views, rejected, size, frames = [], [], None, 0
    first = None
    it = tqdm(source, total=max_frames, desc="board views", unit="frame", disable=not progress, leave=False)
    for fr in it:
        if frames >= max_frames:
            break
        frames += 1
        if fr.index % every:
            continue
        name = f"frame {fr.index}"
        img = fr.image
        got = detect(spec, img, name, board=board)
        if isinstance(got, View):
            shape = img.shape[1], img.shape[0]
            if size is not None and shape != size:
                rejected.append((name, f"frame is {shape[0]}x{shape[1]} px, the others {size[0]}x{size[1]}"))
                continue
            size = shape
            views.append(got)
            if first is None:
                first = img
        else:
            rejected.append((name, got))
    return views, rejected, size, frames, first


def _synthetic_board_source(design, spec: str):
    """synthetic-board[:N]: N rendered board views through calibration.DEMO_LENS (a trial without a camera)."""
    from whisker.bringup.charuco import synthetic_board_views
    from whisker.vision.camera import Frame, FrameSource, SourceError

    try:
        count = int(spec.split(":", 1)[1]) if ":" in spec else 18
    except ValueError:
        raise SourceError(f"synthetic-board count must be an integer, got {spec!r}") from None

    class _Views(FrameSource):
        name = spec

        def __iter__(self):
            for i, img in enumerate(synthetic_board_views(design, count)):
                yield Frame(i, i / self.fps, img)
    return _Views()


@cli.command()
@design_options
@click.option("--source", required=True, metavar="SOURCE",
              help="Frames showing the board: picamera, a camera index, a video file or an image folder; "
                   "synthetic-board[:N] renders N views through a known fisheye lens (a trial).")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False),
              help="Lens .npz to write (mtx, dist, model, image_size, rms_px): what `whisker track --calibration` reads. "
                   "The report goes beside it: OUT.report.json and OUT.undistorted.png.")
@click.option("--max-frames", type=click.IntRange(1, 100000), default=600, show_default=True,
              help="Read at most this many frames (a live camera runs until then).")
@click.option("--every", type=click.IntRange(1, 1000), default=1, show_default=True,
              help="Use every Nth frame (videos, live cameras: fewer, more different views).")
@click.option("--plane-view", type=click.Path(exists=True, dir_okay=False), default=None,
              help="A frame of the board in its holder at the marker plane: mm per px measured there.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def camera(design, source, out, max_frames, every, plane_view, quiet):
    """Calibrate the lens from ChArUco board views (print the board with `whisker calibrate board`).

    Show the board at many tilts and places, covering the image corners too. Both OpenCV lens models
    are fitted (fisheye and rational); every 4th view is held out and the model with the lower
    held-out reprojection error is written. Example:

    \b
      whisker calibrate camera --source board_frames/ --out hw/lens.npz
    """
    import cv2

    from whisker.bringup.charuco import (CalibrationInputError, View, board_for, before_after, calibrate_views,
                                     camera_report, detect)
    from whisker.vision.camera import SourceError, open_source
    from whisker.files import atomic_write_bytes, atomic_write_json
    from whisker.vision.lens import lens_bytes

    out = Path(out)
    if out.suffix != ".npz":
        fail(f"--out must end in .npz, got {out}")
    try:
        spec = board_for(design)
        if source.split(":")[0] == "synthetic-board":
            src = _synthetic_board_source(design, source)
        else:
            src = open_source(source, design)
        with src:
            views, rejected, size, frames, first = _collect_views(spec, src, max_frames, every, not quiet)
        if frames == 0:
            fail(f"camera: source {source} returned no frames", 1)
        cal = calibrate_views(views, size, rejected)
        pv = None
        if plane_view:
            got = detect(spec, cv2.imread(plane_view), plane_view)
            if not isinstance(got, View):
                fail(f"--plane-view {plane_view}: {got}")
            pv = got
        report = camera_report(cal, design, pv)
    except (SourceError, CalibrationInputError) as err:
        fail(f"camera: {err}")
    except OSError as err:
        fail(f"camera: {err}", 1)
    report["board"] = spec.as_dict()
    report["source"] = str(source)
    stem = out.with_suffix("")
    ok, png = cv2.imencode(".png", before_after(cal.lens, first))
    try:
        atomic_write_json(f"{stem}.report.json", report)
        atomic_write_bytes(f"{stem}.undistorted.png", png.tobytes())
        atomic_write_bytes(out, lens_bytes(cal.lens, rms_px=cal.heldout_px[cal.lens.model],
                                           rms_fit_px=cal.rms_fit_px, views=len(cal.views)))
    except OSError as err:
        fail(f"camera: cannot write {out}: {err}", 1)
    mm = report["mm_per_px"]
    fov = report["field_of_view_deg"]
    held = ", ".join(f"{m} {e:.3f}" if e is not None else f"{m} failed" for m, e in report["heldout_rms_px"].items())
    click.echo(f"{out}: {cal.lens.model} model from {len(cal.views)} views ({len(rejected)} refused); "
               f"held-out RMS px: {held}")
    click.echo(f"f = {report['fx_px']:.2f} x {report['fy_px']:.2f} px, centre ({report['cx_px']:.1f}, "
               f"{report['cy_px']:.1f}) px; field of view {fov['horizontal']:.1f} x {fov['vertical']:.1f} deg "
               f"({fov['diagonal']:.1f} diagonal)")
    line = (f"mm/px at the marker plane: {mm['at_design_distance']:.5f} at the design distance "
            f"(design {mm['design']:.5f}, {mm['difference_pct']:+.2f} %)")
    if "plane_view" in mm:
        line += f"; holder view {mm['plane_view']:.5f} at {mm['plane_view_distance_mm']:.2f} mm"
    click.echo(line)
    click.echo(f"report: {stem}.report.json, {stem}.undistorted.png")


# ---- board ------------------------------------------------------------------------------------------

@cli.command()
@design_options
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="exports/calibration", show_default=True,
              help="Folder for charuco_board.png, charuco_board.pdf and charuco_board.json.")
@click.option("--dpi", type=click.IntRange(150, 2400), default=600, show_default=True, help="PNG resolution.")
def board(design, out_dir, dpi):
    """Write the ChArUco board sized for the design's camera distance and field of view.

    Print the PDF at 100 % ("actual size", no fit-to-page) and measure the 10 mm scale bar.
    """
    from whisker.bringup.charuco import CalibrationInputError, board_for, board_files
    from whisker.files import publish, staging_dir

    try:
        spec = board_for(design)
        out = Path(out_dir)
        with staging_dir(out) as tmp:
            names = board_files(spec, tmp, dpi)
            publish(tmp, out, names)
    except CalibrationInputError as err:
        fail(f"board: {err}")
    except OSError as err:
        fail(f"board: {err}", 1)
    w, h = spec.size_mm
    click.echo(f"{out}/charuco_board.pdf: {spec.squares_x} x {spec.squares_y} squares of {spec.square_mm:g} mm "
               f"({w:g} x {h:g} mm, {spec.dictionary} markers of {spec.marker_mm:g} mm); print at 100 %")
    click.echo(json.dumps(spec.as_dict()))


# ---- wiring -----------------------------------------------------------------------------------------

def _int_list(text: str, what: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        fail(f"--sim-miswire: {what} must be comma-separated integers, got {text!r}")


def _sim_harness(spec: str | None, n: int):
    """--sim-miswire ORDER[/SIGNS[/DEAD]] -> Harness (e.g. 0,3,2,1,4,5,6,7/1,1,1,1,1,-1,1,1/)."""
    from whisker.bringup.wiring import Harness

    if not spec:
        return Harness.correct(n)
    parts = spec.split("/")
    order = _int_list(parts[0], "ORDER") or list(range(n))
    sign = _int_list(parts[1], "SIGNS") if len(parts) > 1 and parts[1] else [1] * n
    dead = set(_int_list(parts[2], "DEAD")) if len(parts) > 2 and parts[2] else set()
    if sorted(order) != list(range(n)) or len(sign) != n or any(s not in (1, -1) for s in sign) \
            or not dead <= set(range(n)):
        fail(f"--sim-miswire: ORDER must be a permutation of 0..{n - 1}, SIGNS {n} values of 1/-1, DEAD channels "
             f"0..{n - 1}; got {spec!r}")
    return Harness(order, sign, dead)


class _Device:
    """Actuator, frame grabber, sleep and clock of the backend (the simulator or the real sensor)."""

    def __init__(self, design, backend: str, source, harness, policy: str = "cut"):
        from whisker.drive.actuation import Actuator, open_actuator
        from whisker.drive.guard import ThermalGuard

        if backend == "sim":
            from whisker.bringup.wiring import MiswiredSim, SimCamera, VirtualClock

            clock = VirtualClock()
            self.backend = MiswiredSim(design, harness, clock=clock)
            self.actuator = Actuator(design, self.backend, guard=ThermalGuard(design, clock=clock, policy=policy),
                                     watchdog=False, clock=clock)
            self.camera = SimCamera(design, self.backend)
            self.grab = self.camera.grab
            self.sleep = clock.sleep
            self._src = None
            return
        import time

        from whisker.vision.camera import open_source

        if not source:
            fail("--backend gpio needs --source (the sensor's camera: picamera or a camera index)")
        self._src = open_source(source, design)
        self._it = iter(self._src)
        try:
            self.actuator = open_actuator(design, backend, policy=policy)
        except BaseException:
            self._src.close()
            raise
        self.sleep = time.sleep

        def grab():
            fr = next(self._it, None)
            if fr is None or fr.image is None:
                raise OSError(f"camera {source} returned no frame")
            return fr.image
        self.grab = grab

    def camera_noise(self, sigma: float) -> None:
        self.camera.noise = float(sigma)

    def close(self):
        self.actuator.close()
        if self._src is not None:
            self._src.close()


def device_options(f):
    """The options of the commands that drive the coils and watch the markers (wiring, stiffness)."""
    opts = [
        click.option("--backend", type=click.Choice(["gpio", "sim"]), required=True,
                     help="gpio: the sensor's coils and camera; sim: the simulator (see --sim-miswire, --sim-set)."),
        click.option("--source", default=None, metavar="SOURCE", help="Camera for --backend gpio: picamera or an index."),
        click.option("--calibration", type=click.Path(exists=True, dir_okay=False), default=None,
                     help="Lens .npz from `whisker calibrate camera`."),
        click.option("--sim-miswire", default=None, metavar="ORDER[/SIGNS[/DEAD]]",
                     help="Simulated harness fault: channel j reaches coil ORDER[j] with sign SIGNS[j]; DEAD channels "
                          "drive nothing. E.g. 0,3,2,1,4,5,6,7/1,1,1,1,1,-1,1,1 swaps coils 1 and 3, reverses coil 5."),
        click.option("-q", "--quiet", is_flag=True, help="No progress bar."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


@cli.command()
@design_options
@device_options
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Design file to write with the pin-map override ([wiring] coil_order, coil_polarity): a copy "
                   "of --design (or hw/sensor.toml) with those two lines. Without --out nothing is written.")
@click.option("--volts", type=click.FloatRange(0.1, 10), default=1.5, show_default=True,
              help="Mean coil volts of each pulse (a safe level: about half the grasping voltage).")
@click.option("--settle", type=click.FloatRange(0.05, 10), default=0.5, show_default=True,
              help="Seconds after switching a coil on or off before the frames are taken.")
@click.option("--min-px", type=click.FloatRange(0.1, 100), default=1.0, show_default=True,
              help="A channel whose marker moves less than this (px) is a dead coil.")
def wiring(design, backend, source, out, volts, settle, min_px, calibration, sim_miswire, quiet):
    """Pulse each coil alone, track the markers, diagnose the wiring and write the pin-map fix.

    For every channel: which marker moved, how far (px) and which way (outward = retracts, as a
    positive level should), and the largest motion of any other marker (cross-talk, px). Swapped
    coils, reversed leads and dead coils are named. With --out, the override goes into a copy of the
    design file; use it with `--design FILE` from then on. Example:

    \b
      whisker calibrate wiring --backend gpio --source picamera --out my_sensor.toml
      whisker actuate retract --backend gpio --design my_sensor.toml
    """
    from whisker.design import DEFAULT_DESIGN
    from whisker.files import atomic_write_text
    from whisker.drive.guard import RatingError, volts_to_levels
    from whisker.vision.tracking import CalibrationError, Tracker
    from whisker.bringup.wiring import WiringError, diagnose, override_for, pulse_coils, with_override

    n = design.whiskers.count
    harness = _sim_harness(sim_miswire, n)
    if sim_miswire and backend != "sim":
        fail("--sim-miswire works only with --backend sim")
    base_file = click.get_current_context().params.get("design_file") or DEFAULT_DESIGN
    try:
        level = float(volts_to_levels(design, volts))
        tracker = Tracker(design, "roi", calibration=calibration)
        dev = _Device(design, backend, source, harness)
        from tqdm import tqdm

        bar = tqdm(total=n, desc="coil pulses", unit="coil", disable=quiet, leave=False)
        try:
            resp, rest = pulse_coils(dev.actuator, dev.grab, tracker, level, settle_s=settle, sleep=dev.sleep,
                                     progress=lambda i: bar.update())
        finally:
            bar.close()
            dev.close()
        diag = diagnose(resp, rest, min_px=min_px)
        for line in diag.lines():
            click.echo(line)
        if diag.dead:
            override_for(design, diag)   # raises with the reason
        if diag.ok:
            click.echo("wiring: every coil retracts its own whisker; no override needed")
        else:
            click.echo(f"wiring: swapped {diag.swapped or 'none'}, reversed {diag.reversed or 'none'}")
        order, pol = override_for(design, diag)
        if out:
            from pathlib import Path

            atomic_write_text(out, with_override(Path(base_file).read_text(), order, pol))
            click.echo(f"{out}: [wiring] coil_order = {order}, coil_polarity = {pol}")
        elif not diag.ok:
            click.echo(f"give --out FILE to write the fix: coil_order = {order}, coil_polarity = {pol}")
    except (WiringError, CalibrationError) as err:
        fail(f"wiring: {err}", 1)
    except (RatingError, ValueError) as err:
        fail(f"wiring: {err}")
    except (OSError, RuntimeError) as err:   # camera or coil driver unavailable (SourceError is one)
        fail(f"wiring: {err}", 1)


# ---- stiffness --------------------------------------------------------------------------------------

def _with_fit(design, res):
    """The design with the fitted rest gap (when the data fix it), for the per-whisker levels."""
    if not res.get("gap_identified"):
        return design
    from whisker.design import apply_overrides, design_from_dict
    return design_from_dict(apply_overrides(design.to_dict(), [f"actuation.gap={res['gap_mm']:.4f}"]))


@cli.command()
@design_options
@device_options
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Design file to write: a copy of --design with mechanics.rotational_stiffness (and actuation.gap "
                   "when the data fix it) set. The plot and report go beside it (OUT.stiffness.png/.json).")
@click.option("--steps", type=click.IntRange(2, 20), default=5, show_default=True,
              help="Voltage magnitudes up to actuation.voltage, each in both polarities.")
@click.option("--max-volts", type=click.FloatRange(0.1, 10), default=None,
              help="Largest step (default actuation.voltage, the paper's 3 V).")
@click.option("--settle", type=click.FloatRange(0.05, 10), default=0.6, show_default=True,
              help="Seconds each step is held before its frames are taken.")
@click.option("--fixed-gap", is_flag=True, help="Fit the stiffness only; keep actuation.gap from the design.")
@click.option("--sim-set", multiple=True, metavar="SECTION.KEY=VALUE",
              help="The simulated device differs from the design by this (e.g. mechanics.rotational_stiffness=1.6).")
@click.option("--sim-noise", type=click.FloatRange(0, 50), default=3.0, show_default=True,
              help="Camera noise of the simulated frames, grey levels.")
def stiffness(design, backend, source, out, steps, max_volts, settle, fixed_gap, calibration, sim_set, sim_noise,
              sim_miswire, quiet):
    """Fit the membrane's rotational stiffness from tracked tilts at voltage steps (paper Fig. 4).

    Every coil is driven at +v and -v for each step (coils off and cooled between steps, through the
    thermal guard); the tracked tilt of each whisker is fitted with the coil model (whisker.coil).
    Run `whisker calibrate wiring` first: reversed coils make the fit meaningless. Example:

    \b
      whisker calibrate stiffness --backend gpio --source picamera --design my_sensor.toml --out my_sensor.toml
    """
    from pathlib import Path

    import numpy as np
    from tqdm import tqdm

    from whisker.design import DEFAULT_DESIGN, DesignError, apply_overrides, design_from_dict
    from whisker.design.edit import set_keys
    from whisker.files import atomic_write_bytes, atomic_write_json, atomic_write_text
    from whisker.drive.guard import RatingError
    from whisker.bringup.stiffness import StiffnessError, fit, measure_tilts, plot_png, steps_volts
    from whisker.vision.tracking import CalibrationError, Tracker
    base_file = click.get_current_context().params.get("design_file") or DEFAULT_DESIGN
    device = design
    if sim_set:
        if backend != "sim":
            fail("--sim-set works only with --backend sim")
        try:
            device = design_from_dict(apply_overrides(design.to_dict(), sim_set))
        except DesignError as err:
            fail(f"--sim-set: {err}")
    volts = steps_volts(design, steps, max_volts)
    try:
        tracker = Tracker(design, "roi", calibration=calibration)
        if sim_miswire and backend != "sim":
            fail("--sim-miswire works only with --backend sim")
        dev = _Device(device, backend, source, _sim_harness(sim_miswire, design.whiskers.count))
        if backend == "sim":
            dev.camera_noise(sim_noise)
        bar = tqdm(total=len(volts), desc="voltage steps", unit="step", disable=quiet, leave=False)
        temps = []
        try:
            tilts = measure_tilts(dev.actuator, dev.grab, tracker, volts, settle_s=settle, sleep=dev.sleep,
                                  progress=lambda s: bar.update(), temperatures=temps)
        finally:
            bar.close()
            dev.close()
        # the hardware's coils are as warm as the guard estimates; the simulator drives them at 20 C
        res = fit(design, volts, tilts, fit_gap=not fixed_gap,
                  temperatures_C=np.array(temps) if backend == "gpio" and len(temps) == len(volts) else None)
    except (StiffnessError, CalibrationError) as err:
        fail(f"stiffness: {err}", 1)
    except (RatingError, ValueError) as err:
        fail(f"stiffness: {err}")
    except (OSError, RuntimeError) as err:   # camera or coil driver unavailable (SourceError is one)
        fail(f"stiffness: {err}", 1)
    res["volts"] = volts.tolist()
    res["tilts_deg"] = [[None if not np.isfinite(x) else float(x) for x in row] for row in tilts]
    k = res["rotational_stiffness_Nmm_per_rad"]
    click.echo(f"rotational stiffness {k:.4g} N*mm/rad (design {design_stiffness_Nmm_per_rad(design):.4g}), "
               f"rest gap {res['gap_mm']:.3f} mm " + ("(fitted)" if res["gap_identified"] else
                                                     f"(design's: the data do not fix it, best {res['gap_best_mm']:.2f})")
               + f"; RMS residual {res['rms_residual_deg']:.3f} deg over {res['points']} points")
    from whisker.bringup.stiffness import bringup_levels
    try:
        lv = bringup_levels(_with_fit(design, res), res["per_whisker_Nmm_per_rad"])
    except ValueError as err:
        fail(f"stiffness: {err}")
    res.update(lv)
    click.echo("per whisker: safe level " + " ".join(f"{x:.3f}" for x in lv["safe_levels"])
               + "; grasp level " + " ".join(f"{x:.3f}" for x in lv["grasp_levels"]))
    if lv["short_of_stop"]:
        click.echo(f"WARNING: whisker(s) {', '.join(map(str, lv['short_of_stop']))} need more than the rating "
                   "(drive.max_coil_voltage) to reach the end stop: check the magnet and the gap", err=True)
    stem = Path(out).with_suffix("") if out else Path("stiffness")
    try:
        atomic_write_bytes(f"{stem}.stiffness.png", plot_png(design, volts, tilts, res))
        atomic_write_json(f"{stem}.stiffness.json", res)
        if out:
            text = set_keys(Path(base_file).read_text(), "mechanics", {"rotational_stiffness": f"{k:.4g}"},
                            "N*mm/rad, fitted by `whisker calibrate stiffness`")
            if res["gap_identified"]:
                text = set_keys(text, "actuation", {"gap": f"{res['gap_mm']:.3f}"},
                                "mm, fitted by `whisker calibrate stiffness`")
            text = set_keys(text, "drive", {"safe_levels": "[" + ", ".join(f"{x:.4g}" for x in lv["safe_levels"]) + "]",
                                            "grasp_levels": "[" + ", ".join(f"{x:.4g}" for x in lv["grasp_levels"]) + "]"},
                            "per whisker, set by `whisker calibrate stiffness`")
            atomic_write_text(out, text)
    except OSError as err:
        fail(f"stiffness: cannot write {stem}: {err}", 1)
    click.echo(f"plot: {stem}.stiffness.png, report: {stem}.stiffness.json" + (f"; design: {out}" if out else ""))
