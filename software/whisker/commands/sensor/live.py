"""`whisker live`: camera (or simulator, or video) -> tracker -> per-whisker states, frame by frame."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import click

from whisker.cliutil import design_options, fail


def open_live_source(source: str, design, fps: float, max_frames, contacts=()):
    """A frame source: `sim` renders the simulator's whiskers (at rest unless `contacts`, a list of
    whisker.drive.simulated.Contact, push them); anything else goes to
    whisker.vision.camera.open_source. Returns (source, sim backend or None)."""
    from whisker.vision.camera import open_source

    if source == "sim":
        from whisker.data.recording import SimCamera
        from whisker.sim import actuation_backend

        backend = actuation_backend(design)
        for c in contacts:
            backend.add_contact(c)
        return SimCamera(design, backend, fps=fps, count=max_frames), backend
    return open_source(source, design), None


@click.command()
@design_options
@click.option("--source", required=True, metavar="SOURCE",
              help="picamera, a camera index, a video file, an image folder, synthetic[:N], or sim (the simulator).")
@click.option("--fps", type=click.FloatRange(1, 240), default=15.0, show_default=True,
              help="Frame rate of --source sim, frames/s.")
@click.option("--contact", "contacts", multiple=True, metavar="W:START-END:DEG",
              help="--source sim: an object pushes whisker W's tip to DEG deg of radial tilt (+ retraction side) "
                   "from START to END s after the start, e.g. 0:2-4:5 (repeatable). Without it the simulated "
                   "whiskers are never touched: every frame is rest.")
@click.option("--estimator", "method", type=click.Choice(["authors", "adaptive"]), default="adaptive",
              show_default=True, help="State estimator (docs/states.md).")
@click.option("--tracker", "track_method", type=click.Choice(["paper", "contour", "blob", "roi", "fit"]), default="roi",
              show_default=True, help="Marker tracking method (docs/tracking.md).")
@click.option("--rest-frames", type=click.IntRange(1, 1000), default=5, show_default=True,
              help="First frames (whiskers untouched) that set the tracker's rest baseline.")
@click.option("--record", type=click.Path(dir_okay=False), default=None,
              help="Write the annotated video (.mp4/.avi): states and displacement arrows.")
@click.option("--show", is_flag=True, help="Show the annotated frames in a window (needs a display).")
@click.option("--max-frames", type=click.IntRange(1, None), default=None, help="Stop after this many frames.")
@click.option("--calibration", type=click.Path(dir_okay=False), default=None, help="Lens calibration .npz.")
@click.option("--mask", type=click.Path(dir_okay=False), default=None, help="Region-of-interest image.")
@click.option("--locate", "locate", is_flag=True,
              help="Active whisking (docs/locate.md): when a whisker settles in contact, sweep its coil and print "
                   "the contact distance along the rod (mm) and the force (mN) as a {\"locate\": ...} line; "
                   "\"no contact\" if none touches. Drives the coils: --source sim only (hardware: record a sweep "
                   "and run `whisker locate SESSION`).")
@click.option("--locate-whisker", type=click.IntRange(0), default=None,
              help="--locate: sweep only this whisker (default: the first one in contact).")
@click.option("--sweep-level", type=click.FloatRange(-1, 1), default=None,
              help="--locate: sweep level (signed PWM duty) [default: whisker.sensing.locate.DEFAULT_AMPLITUDE].")
@click.option("--sweep-duration", type=click.FloatRange(0.05, 60), default=None,
              help="--locate: sweep duration, s [default: whisker.sensing.locate.DEFAULT_DURATION_S].")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
def cli(design, source, fps, contacts, method, track_method, rest_frames, record, show, max_frames, calibration, mask,
        locate, locate_whisker, sweep_level, sweep_duration, quiet):
    """Track the markers and label every whisker rest / contact / dynamic, live.

    Writes one JSON line per frame on stdout ({"frame", "t", "states", "dx", "dy", "valid", "force_mN",
    "direction_deg", "ms"}: px; the tip force from the deflection and the membrane stiffness, mN, and
    its direction, deg CCW from the sensor's +x; docs/states.md), for other programs to read;
    --record writes the annotated video (state labels, displacement and force arrows), --show opens a window.
    --contact W:START-END:DEG@MM puts the simulated object MM mm along the rod (for --locate).
    Stop with Ctrl-C (or q in the window)."""
    import itertools

    import numpy as np


    from whisker.vision.camera import SourceError
    from whisker.sensing.contact_force import ForceModel
    from whisker.sensing.live import LivePipeline, annotate
    from whisker.sensing.states import make_estimator
    from whisker.vision.tracking import CalibrationError, Tracker

    from whisker.drive.simulated import Contact

    if contacts and source != "sim":
        fail("live: --contact schedules objects in the simulator: use it with --source sim")
    try:
        schedule = [Contact.parse(c) for c in contacts]
        for c in schedule:
            if c.whisker >= design.whiskers.count:
                raise ValueError(f"contact {c.whisker}: the design has whiskers 0-{design.whiskers.count - 1}")
    except ValueError as err:
        fail(f"live: --contact: {err}")
    locator = None
    if locate:
        from whisker.sensing.locate import LocateError
        from whisker.sensing.locate_live import LiveLocator

        if source != "sim":
            fail("live: --locate drives the coils, which `whisker live` can only do in the simulator (--source sim); "
                 "on hardware record a sweep (`whisker record`) and run `whisker locate SESSION`")
        try:
            locator = LiveLocator(design, whisker=locate_whisker, amplitude=sweep_level, duration_s=sweep_duration,
                                  fps=fps)
        except LocateError as err:
            fail(f"live: --locate refused: {err}")
    elif locate_whisker is not None or sweep_level is not None or sweep_duration is not None:
        fail("live: --locate-whisker, --sweep-level and --sweep-duration go with --locate")
    if source == "sim" and not schedule and not quiet:
        click.echo("live: --source sim without --contact: nothing touches the simulated whiskers", err=True)
    if show and not os.environ.get("DISPLAY") and sys.platform.startswith("linux"):
        fail("live: --show needs a display (DISPLAY is unset); use --record FILE.mp4", code=1)
    try:
        tracker = Tracker(design, track_method, calibration=calibration, mask=mask)
        src, backend = open_live_source(source, design, fps, None if max_frames is None else max_frames + rest_frames,
                                        schedule)
    except (ValueError, SourceError) as err:
        fail(f"live: {err}")
    except OSError as err:
        fail(f"live: {err}", code=1)
    frames = iter(src)
    writer = rec_tmp = pipe = None
    n_frames, t_proc = 0, 0.0
    try:
        rest = list(itertools.islice(frames, rest_frames))
        if len(rest) < rest_frames:
            fail(f"live: the source {source} gave {len(rest)} frame(s), fewer than the {rest_frames} --rest-frames "
                 f"for the rest baseline: no states", code=1)
        tracker.calibrate(rest)
        pipe = LivePipeline(tracker, make_estimator(method, tracker.n), force_model=ForceModel.from_design(design))
        stream = frames if max_frames is None else itertools.islice(frames, max_frames)
        levels = None
        for frame in stream:
            live = pipe.step(frame, levels=levels)
            n_frames += 1
            t_proc += live.process_s
            sys.stdout.write(json.dumps(live.record(), separators=(",", ":")) + "\n")
            if locator is not None:
                found = locator.update(live, tracker)
                if found is not None:
                    _say_locate(found, quiet)
                levels = locator.next_levels()
                backend.set_levels(np.zeros(design.whiskers.count) if levels is None else levels)
            sys.stdout.flush()
            if record or show:
                import cv2

                img = annotate(frame.image, live, tracker.baseline.track_xy)
                if img is None:
                    continue
                if record:
                    if writer is None:
                        rec_path = Path(record)
                        rec_path.parent.mkdir(parents=True, exist_ok=True)
                        rec_tmp = rec_path.with_name(f".{rec_path.stem}.tmp{rec_path.suffix}")
                        fourcc = cv2.VideoWriter_fourcc(*("mp4v" if rec_path.suffix.lower() == ".mp4" else "MJPG"))
                        writer = cv2.VideoWriter(str(rec_tmp), fourcc, float(getattr(src, "fps", fps)),
                                                 (img.shape[1], img.shape[0]))
                        if not writer.isOpened():
                            fail(f"live: cannot write video {record} (no codec for {rec_path.suffix})", code=1)
                    writer.write(img)
                if show:
                    cv2.imshow("whisker live", img)
                    if cv2.waitKey(1) & 0xFF in (27, ord("q")):
                        break
    except (SourceError, CalibrationError) as err:
        fail(f"live: {err}")
    except (KeyboardInterrupt, BrokenPipeError):
        pass
    finally:
        src.close()
        if backend is not None:
            backend.off()
        if locator is not None and (end := locator.finish()) is not None:
            _say_locate(end, quiet)
        if writer is not None:
            writer.release()
            os.replace(rec_tmp, record)
    ready = pipe is not None and pipe.estimator.ready
    if n_frames == 0 or not ready:
        fail(f"live: the source ended after {n_frames} frame(s) past the rest baseline, before the {method} "
             f"estimator could decide ({pipe.estimator.needs if pipe else 'frames'}): every label was its "
             f"initial rest", code=1)
    if not quiet:
        click.echo(f"live: {n_frames} frames, {1e3 * t_proc / max(n_frames, 1):.2f} ms/frame tracking + states"
                   + (f"; wrote {record}" if record and writer is not None else ""), err=True)


def _say_locate(rec: dict, quiet: bool) -> None:
    """One {"locate": ...} JSON line on stdout, and the sentence on stderr."""
    sys.stdout.write(json.dumps({"locate": rec}, separators=(",", ":")) + "\n")
    sys.stdout.flush()
    if not quiet:
        click.echo(f"locate: whisker {rec.get('whisker')}: {rec['status']}: {rec.get('message', '')}", err=True)
