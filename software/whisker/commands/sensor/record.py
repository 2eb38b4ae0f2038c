"""`whisker record`: frames, tracks and actuation commands on one clock into a crash-safe session."""

from __future__ import annotations

import sys
import time

import click

from whisker.cliutil import design_options, fail
from whisker.commands.sensor.actuate import level_options
from whisker.commands.sensor.grasp import build_sequence, sequence_options


#: how a guard event is printed
GUARD_WORDS = {"derate": "derates", "derate-end": "stops derating", "cut": "cuts", "resume": "restores"}

#: a --duration at least this long is announced before recording starts, s
LONG_RECORDING_S = 60.0


@click.command()
@design_options
@click.option("--source", required=True, metavar="SOURCE",
              help="picamera, a camera index (0, 1 ...), a video file, an image folder, synthetic[:N], or sim "
                   "(frames rendered from the simulator's whiskers, with --backend sim).")
@click.option("--fps", type=click.FloatRange(0.1, 120), default=15.0, show_default=True,
              help="Frame rate of --source sim.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Session folder to create (must not exist or be empty).")
@click.option("--frames", "max_frames", type=click.IntRange(1, None), default=None,
              help="Stop after this many frames.")
@click.option("--duration", type=click.FloatRange(0, 24 * 3600, min_open=True), default=None,
              help="Stop after this many seconds (at most a day).")
@click.option("--tracker", "method", type=click.Choice(["paper", "contour", "blob", "roi"]), default="roi",
              show_default=True, help="Marker tracking method (see whisker track --help).")
@click.option("--model", type=click.Choice(["paper", "exact"]), default="paper", show_default=True,
              help="Deflection geometry for the tracks table.")
@click.option("--rest-frames", type=click.IntRange(1, 1000), default=5, show_default=True,
              help="The first frames, recorded before any actuation, give the tracker's rest baseline.")
@click.option("--no-track", is_flag=True, help="Record frames (and actuation) only; track later with whisker track.")
@click.option("--backend", type=click.Choice(["none", "mock", "gpio", "sim"]), default="none", show_default=True,
              help="Actuation backend for --grasp (none = record only).")
@click.option("--grasp", "which", default=None, metavar="NAME|K",
              help="Run the grasp sequence on these whiskers (all, every-second, opposite, or 8/4/2) "
                   "after the rest frames, recording every actuation command.")
@click.option("--sequence", "sequence_file", type=click.Path(dir_okay=False), default=None,
              help="Run the timed steps of this TOML file instead of --grasp (see whisker actuate sequence).")
@click.option("--start", type=int, default=0, show_default=True, help="First active whisker of --grasp.")
@level_options
@sequence_options
@click.option("--tail-s", type=click.FloatRange(0, 600), default=1.0, show_default=True,
              help="Seconds to keep recording after the grasp sequence ended.")
@click.option("--image-format", type=click.Choice(["png", "jpg"]), default="png", show_default=True,
              help="png: lossless (exact replay); jpg: smaller and faster to write.")
@click.option("--no-fsync", is_flag=True,
              help="Flush without fsync: still loses nothing on a crash or SIGKILL of this program, but a "
                   "power cut may lose the last seconds; ~3-10x cheaper per frame (benchmarks/results/actuation.md).")
@click.option("--trial", default=None, help="Free text stored in metadata.json (object, trial number ...).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar or summary.")
def cli(design, source, fps, out_dir, max_frames, duration, method, model, rest_frames, no_track, backend, which,
        sequence_file, start,
        level, volts, policy, release_level, hold_level, release_s, hold_s, retract_s, tail_s, image_format,
        no_fsync, trial, quiet):
    """Record a session: every frame as an image, the tracks, the actuation commands and the coils'
    estimated temperatures, all on one clock, into --out.

    Crash-safe: each row is flushed and fsynced and each image is renamed into place whole, so after
    a crash (even SIGKILL) every completed frame's data is readable. Replay the frames with
    `whisker track --source OUT/frames`; plot trials with `whisker recplot` (python -m
    whisker.data.recplot). Every coil is switched off at the end, on Ctrl-C, SIGTERM and errors.
    Example (the paper's grasp recording, 4 whiskers):

    \b
      whisker record --source picamera --out runs/pinecone-1 --backend gpio --grasp every-second \\
          --retract-s 1 --hold-s 3 --release-s 1 --tail-s 1 --trial "pinecone 1"
    """
    import itertools

    from tqdm import tqdm


    from whisker.drive.actuation import deenergise_on_signals, open_actuator
    from whisker.drive.sequences import SequenceRunner, ThreadedSequenceRunner
    from whisker.vision.camera import SourceError, open_source
    from whisker.commands.sensor.actuate import resolve_level
    from whisker.drive.guard import RatingError
    from whisker.data.recording import Recorder, RecordingError, SimCamera, record_frames

    if which is not None and sequence_file is not None:
        fail("record: give --grasp or --sequence, not both")
    if (which is not None or sequence_file is not None) and backend == "none":
        fail("record: --grasp and --sequence need an actuation --backend (mock, gpio or sim)")
    file_steps = None
    if sequence_file is not None:
        from whisker.drive.sequences import load_sequence

        try:
            file_steps = load_sequence(design, sequence_file)
        except ValueError as err:
            fail(f"record: {err}")
    if (max_frames is None and duration is None and which is None and sequence_file is None
            and source in ("picamera", "sim") + tuple("0123456789")):
        fail("record: a live camera needs --frames, --duration or --grasp to know when to stop")
    if not quiet and duration is not None and duration >= LONG_RECORDING_S:
        click.echo(f"record: up to {duration:g} s ({duration / 60:.1f} min) of frames; Ctrl-C stops early and "
                   "keeps every complete frame", err=True)
    tracker = None
    if not no_track:
        from whisker.vision.tracking import Tracker

        try:
            tracker = Tracker(design, method)
        except ValueError as err:
            fail(f"record: {err}")
    sim_backend = None
    clock = time.monotonic
    if source == "sim":
        if backend not in ("sim", "none"):
            fail("record: --source sim films the simulator: use --backend sim (or none)")
        from whisker.drive.simulated import SimClock, actuation_backend

        # simulated time: frames at exactly 1/fps of simulated seconds, whatever the machine's load
        clock = SimClock(period_s=min(0.01, float(design.drive.guard_period)))
        sim_backend = actuation_backend(design, clock=clock)
        src = SimCamera(design, sim_backend, fps=fps, clock=clock, sleep=clock.sleep)
    else:
        try:
            src = open_source(source, design)
        except SourceError as err:
            fail(f"record: {err}")
    meta = {"source": source, "tracking": None if no_track else {"method": method, "model": model},
            "trial": trial}
    if source == "sim":
        meta["clock"] = "simulated seconds since t0 (the camera, simulator, sequence and guard share it)"
    act = runner = None
    n_frames = 0
    written = [0]                            # complete frames so far (for the message if the disk fills)
    try:
        with deenergise_on_signals():
            try:
                rec = Recorder(out_dir, design, image_format=image_format, meta=meta, fsync=not no_fsync,
                               clock=clock)
            except RecordingError as err:
                fail(f"record: {err}")
            if source == "sim":
                src.epoch = rec.t0            # frame times are session times
            with rec:
                try:
                    if which is not None or file_steps is not None:
                        def on_event(t_clock, event, coils, temps, rec=rec):
                            rec.log_event(t_clock, event, coils, temps)
                            tqdm.write(f"record: t = {rec.session_time(t_clock):.2f} s: guard {GUARD_WORDS[event]} "
                                       f"coil(s) {' '.join(map(str, coils))} at up to {max(temps):.1f} C "
                                       f"(derating from {act.guard.derate_from_C:g} C, cut at {act.guard.cut_C:g} C)",
                                       file=sys.stderr)

                        act = open_actuator(design, backend, policy=policy, log=rec.log_actuation,
                                            backend_object=sim_backend, clock=clock,
                                            watchdog=source != "sim", on_event=on_event)
                        if file_steps is not None:
                            steps = file_steps
                        else:
                            lvl = resolve_level(design, level, volts)
                            lvl = act.default_level() if lvl is None else lvl
                            steps = build_sequence(design, which, start, lvl, hold_level, retract_s, hold_s,
                                                   release_s, release_level)
                        rec.meta["sequence"] = [{"phase": s.phase, "duration_s": s.duration_s,
                                                 "levels": list(s.levels)} for s in steps]
                        act.neutral()
                    frames = iter(src)
                    rest = list(itertools.islice(frames, rest_frames))
                    if tracker is not None:
                        from whisker.vision.tracking import CalibrationError

                        try:
                            tracker.calibrate(rest)
                        except CalibrationError as err:
                            fail(f"record: {err}")
                    bar = tqdm(desc="record", unit="frame", disable=quiet, file=sys.stderr, total=max_frames)

                    def tick(c, t):
                        written[0] += 1
                        bar.update()
                    n_frames = record_frames(rec, rest, tracker=tracker, model=model, actuator=act,
                                             on_frame=tick, frame_times=source == "sim")
                    left = None if max_frames is None else max_frames - n_frames
                    if left is None or left > 0:
                        if act is None:
                            runner = None
                        elif source == "sim":          # ticked by the simulated clock, no thread
                            runner = SequenceRunner(act, steps)
                            clock.hooks.append(lambda now: runner.tick(now) if runner.t0 is not None else None)
                        else:
                            runner = ThreadedSequenceRunner(act, steps)
                        n_frames += record_frames(
                            rec, frames, tracker=tracker, model=model, runner=runner, actuator=act,
                            max_frames=left, duration_s=duration,
                            after_sequence_s=tail_s if runner is not None else None,
                            on_frame=tick, frame_times=source == "sim")
                    bar.close()
                finally:
                    # switch off while the actuation table is still open, so the "off" row is recorded
                    if runner is not None and hasattr(runner, "stop"):
                        runner.stop()
                    if act is not None:
                        act.close()
                        rec.meta["guard"] = act.guard.state()
                        rec.meta["guard_events"] = [{"time_s": round(rec.session_time(t), 4), "event": e,
                                                     "coils": c, "temperatures_C": tc} for t, e, c, tc in act.events]
    except (RatingError, ValueError, RuntimeError) as err:
        fail(f"record: {err}")
    except OSError as err:
        from whisker.errors import explain

        code, line = explain(err)
        fail(f"record: writing {out_dir}: {line}; the session keeps its {written[0]} complete frame(s) "
             "(readable by whisker recplot and whisker track)", code)
    finally:
        if runner is not None and hasattr(runner, "stop"):
            runner.stop()
        if act is not None:
            act.close()
        src.close()
    if not quiet:
        click.echo(f"recorded {n_frames} frames into {out_dir}; replay: whisker track --source {out_dir}/frames",
                   err=True)
