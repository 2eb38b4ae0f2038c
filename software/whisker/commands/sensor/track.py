"""`whisker track`: follow the whisker markers in a camera stream, a video or an image folder."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click

from whisker.cliutil import design_options, fail
from whisker.vision.annotate import annotate  # noqa: F401  (used below; importable from here as before)
from whisker.vision.trackfile import CSV_HEADER, csv_rows  # noqa: F401



def _measured_tracker(design, tracker, rest, kw, quiet):
    """A tracker whose marker radii are measured on the first usable rest frame (or `tracker` if none)."""
    from whisker.vision.rest_geometry import RestGeometryError, measure
    from whisker.vision.tracking import Tracker

    img = next((getattr(f, "image", f) for f in rest if getattr(f, "image", f) is not None), None)
    try:
        g = measure(design, img, calibration=kw["calibration"], mask=kw["mask"])
    except RestGeometryError as err:
        click.echo(f"track: {err}; the design's marker size is used", err=True)
        return tracker
    if not quiet:
        for line in g.lines():
            click.echo(f"rest frame: {line}", err=True)
    return Tracker(design, marker_radius_px=g.marker_radius_px, edge_radius_px=g.edge_radius_px, **kw)


@click.command()
@design_options
@click.option("--source", required=True, metavar="SOURCE",
              help="picamera, a camera index (0, 1 ...), a video file, an image folder or file, or synthetic[:N].")
@click.option("--tracker", "method", type=click.Choice(["paper", "contour", "blob", "roi", "fit"]), default="roi",
              show_default=True, help="Marker tracker: paper = the paper's pipeline (HSV, 10x10 erosion, contours); "
                                      "roi = fastest, subpixel; fit = roi + disc fit, most exact (docs/tracking.md).")
@click.option("--out", "out_csv", type=click.Path(dir_okay=False), default=None,
              help="CSV: one row per frame and whisker (frame, time_s, whisker, x_px, y_px, dx_px, dy_px, valid, "
                   "status, theta_deg, tip_x_mm, tip_y_mm, tip_z_mm).")
@click.option("--record", type=click.Path(dir_okay=False), default=None, help="Write an annotated video (.mp4/.avi).")
@click.option("--show", is_flag=True, help="Show the annotated frames live (needs a display and an OpenCV with GUI; "
                                         "otherwise the annotated video is written instead).")
@click.option("--rest", "rest_source", default=None, metavar="SOURCE",
              help="Rest (untouched) frames for the baseline; default: the first --rest-frames of --source.")
@click.option("--rest-frames", type=click.IntRange(1, 1000), default=5, show_default=True,
              help="Number of rest frames whose per-marker median is the baseline.")
@click.option("--calibration", type=click.Path(dir_okay=False), default=None,
              help="Lens calibration .npz with mtx and dist (undistorts the marker positions).")
@click.option("--undistort", type=click.Choice(["points", "image"]), default="points", show_default=True,
              help="points: undistort the centroids (exact, cheap); image: remap every frame first.")
@click.option("--mask", type=click.Path(dir_okay=False), default=None, help="Region-of-interest image; nonzero = track.")
@click.option("--model", type=click.Choice(["paper", "exact"]), default="paper", show_default=True,
              help="Deflection geometry: the paper's equations or the exact ray/pivot-sphere model.")
@click.option("--k-source", type=click.Choice(["design", "ring"]), default="design", show_default=True,
              help="mm per pixel from the camera model, or measured from the rest ring's radius.")
@click.option("--max-frames", type=click.IntRange(1, None), default=None, help="Stop after this many frames.")
@click.option("--marker-size", type=click.Choice(["measured", "design"]), default="measured", show_default=True,
              help="fit: the markers' radius measured on the first rest frame (whisker.vision.rest_geometry) or the "
                   "design's coil.marker_diameter.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar or summary.")
def cli(design, source, method, out_csv, record, show, rest_source, rest_frames, calibration, undistort, mask,
        model, k_source, max_frames, marker_size, quiet):
    """Track the whisker markers and compute each whisker's deflection (theta, tip position).

    The first --rest-frames frames (or the --rest source) must show the whiskers untouched: their
    median marker positions are the baseline from which dx, dy, theta and the tip follow. Whisker
    indices follow the design (whisker i at whiskers.first_angle_deg + i*360/N, counter-clockwise
    seen from ABOVE; the camera looks up, so on screen they run clockwise). Frames that cannot be
    tracked are kept in the CSV with valid=0 and a status (lost, merged, border, bad-frame).
    """
    import itertools

    import numpy as np
    from tqdm import tqdm

    from whisker.vision.camera import SourceError, open_source
    from whisker.files import atomic_write_text
    from whisker.vision.tracking import CalibrationError, Tracker

    try:
        tracker = Tracker(design, method, calibration=calibration, undistort=undistort, mask=mask, k_source=k_source)
    except ValueError as err:
        fail(f"track: {err}")
    try:
        src = open_source(source, design)
    except SourceError as err:
        fail(f"track: {err}")
    frames = iter(src)
    buffered = []
    try:
        if rest_source is not None:
            with open_source(rest_source, design) as rs:
                rest = [f for f in itertools.islice(iter(rs), rest_frames)]
        else:
            rest = buffered = list(itertools.islice(frames, rest_frames))
        if not rest:
            fail("track: no frames to take the rest baseline from (empty or unreadable source)")
        if method == "fit" and marker_size == "measured":
            tracker = _measured_tracker(design, tracker, rest, dict(
                method=method, calibration=calibration, undistort=undistort, mask=mask, k_source=k_source), quiet)
        tracker.calibrate(rest)
    except SourceError as err:
        src.close()
        fail(f"track: {err}")
    except CalibrationError as err:
        src.close()
        fail(f"track: {err}")

    writer = None
    rec_tmp = None
    if show:
        import cv2

        why = ""
        if not os.environ.get("DISPLAY") and sys.platform.startswith("linux"):
            why = "no display (DISPLAY is unset)"
        else:
            try:
                cv2.namedWindow("whisker track")
            except cv2.error:
                why = "this OpenCV has no GUI (opencv-python-headless)"
        if why:
            # no live window: the annotated video instead
            show = False
            if record is None:
                record = str(Path(out_csv).with_suffix(".mp4")) if out_csv else "annotated.mp4"
            click.echo(f"track: --show: {why}; writing the annotated video {record} instead", err=True)
    rows = [CSV_HEADER]
    stream = itertools.chain(buffered, frames)
    if max_frames is not None:
        stream = itertools.islice(stream, max_frames)
    n_frames = 0
    valid_count = np.zeros(tracker.n, int)
    refused, refused_frames = 0, 0
    import time

    t_track = 0.0
    try:
        for frame in tqdm(stream, desc="track", unit="frame", disable=quiet, file=sys.stderr):
            t0 = time.perf_counter()
            res = tracker.track(frame.image)
            t_track += time.perf_counter() - t0
            defl = tracker.deflection(res, model=model)
            rows.extend(csv_rows(frame, res, defl))
            n_frames += 1
            valid_count += res.valid
            refused += res.fit_refused
            refused_frames += res.fit_refused > 0
            if record or show:
                import cv2

                img = annotate(frame.image, res, tracker.baseline.track_xy)
                if img is not None and record:
                    if writer is None:
                        rec_path = Path(record)
                        rec_path.parent.mkdir(parents=True, exist_ok=True)
                        rec_tmp = rec_path.with_name(f".{rec_path.stem}.tmp{rec_path.suffix}")
                        fourcc = cv2.VideoWriter_fourcc(*("mp4v" if rec_path.suffix.lower() == ".mp4" else "MJPG"))
                        writer = cv2.VideoWriter(str(rec_tmp), fourcc, float(src.fps), (img.shape[1], img.shape[0]))
                        if not writer.isOpened():
                            fail(f"track: cannot write video {record} (codec for {rec_path.suffix} unavailable)")
                        rec_size = img.shape[:2]
                    if img.shape[:2] == rec_size:
                        writer.write(img)
                if img is not None and show:
                    cv2.imshow("whisker track", img)
                    if cv2.waitKey(1) & 0xFF in (27, ord("q")):
                        break
    except KeyboardInterrupt:
        pass
    finally:
        src.close()
        if writer is not None:
            writer.release()
            os.replace(rec_tmp, record)
    if out_csv:
        atomic_write_text(out_csv, "\n".join(rows) + "\n")
    if not quiet:
        ms = 1000.0 * t_track / max(n_frames, 1)
        click.echo(f"{n_frames} frames, method {method}, {ms:.2f} ms/frame tracking; valid per whisker: "
                   f"{(valid_count / max(n_frames, 1)).round(3).tolist()}", err=True)
        if method == "fit":
            click.echo(f"fit: the disc fit was refused (centroid kept) for {refused} of {int(valid_count.sum())} "
                       f"tracked markers, in {refused_frames} of {n_frames} frames", err=True)
        if getattr(src, "truncated", False):
            click.echo(f"warning: {source} ended early (truncated video)", err=True)
        if out_csv:
            click.echo(f"wrote {out_csv}", err=True)
