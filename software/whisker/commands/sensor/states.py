"""`whisker states`: label every frame of a tracks CSV rest / contact / dynamic, per whisker."""

from __future__ import annotations

import json
import sys

import click

from whisker.cliutil import design_options, fail


def json_line(frame: int, t_s: float, labels, disp=None) -> str:
    """One frame as a JSON line: {"frame", "t", "states": [...], "dx", "dy"} (px, 3 decimals)."""
    from whisker.sensing.states import STATE_NAMES

    rec = {"frame": int(frame), "t": round(float(t_s), 4), "states": [STATE_NAMES[int(s)] for s in labels]}
    if disp is not None:
        rec["dx"] = [None if v != v else round(float(v), 3) for v in disp[0]]
        rec["dy"] = [None if v != v else round(float(v), 3) for v in disp[1]]
    return json.dumps(rec, separators=(",", ":"))


def _num(v: float) -> str:
    return "" if v != v else f"{v:.4f}"     # a lost marker (NaN) is an empty cell


@click.command()
@design_options
@click.argument("tracks", type=click.Path())
@click.option("--estimator", "method", type=click.Choice(["authors", "adaptive"]), default="adaptive",
              show_default=True,
              help="State estimator: authors = their FFT/peak-valley window method, exactly; adaptive = noise-learned, "
                   "hysteresis, every frame judged (docs/states.md).")
@click.option("--window", type=click.IntRange(4, 10000), default=30, show_default=True,
              help="authors' method: frames per window (their offline default 30; 15 on their Pi).")
@click.option("--out", "out_csv", type=click.Path(dir_okay=False), default=None,
              help="CSV: frame, time_s, whisker, dx_px, dy_px (px), state.")
@click.option("--json/--no-json", "as_json", default=True, show_default=True,
              help="One JSON line per frame on stdout.")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
def cli(design, tracks, method, window, out_csv, as_json, quiet):
    """Run a state estimator on TRACKS: a `whisker track` / `whisker record` CSV (or session
    folder), or the authors' airflow file (Time,dx,dy), for the design's whiskers. Prints one JSON
    line per frame and a summary (frames per state and whisker) on stderr. Refuses (exit 2) a file
    it cannot decide on: too few frames, or a whisker with no rest reference."""
    import numpy as np

    from whisker.cliutil import check_out_path
    from whisker.files import atomic_write_text
    from whisker.sensing.states import STATE_NAMES, StateInputError
    from whisker.sensing.states_offline import StatesUndecided, label_recording
    from whisker.vision.trackfile import TracksError, read_tracks

    if out_csv:
        check_out_path(out_csv, "states")
    n = design.whiskers.count
    try:
        tr = read_tracks(tracks, n_whiskers=n)
        labels, notes = label_recording(method, tr.time_s, tr.dx_px, tr.dy_px, window=window)
    except StatesUndecided as err:
        fail(f"states: {tracks}: cannot decide: {err}")
    except (TracksError, StateInputError) as err:
        fail(f"states: {err}")
    if not quiet:
        for note in notes:
            click.echo(f"states: {note}", err=True)
    rows = ["frame,time_s,whisker,dx_px,dy_px,state"]
    counts = np.zeros((n, 3), int)
    out = sys.stdout
    try:
        for k in range(tr.time_s.size):
            lab = labels[k]
            counts[np.arange(n), lab] += 1
            if as_json:
                out.write(json_line(k, tr.time_s[k], lab, (tr.dx_px[k], tr.dy_px[k])) + "\n")
            if out_csv:
                rows.extend(f"{k},{tr.time_s[k]:.4f},{w},{_num(tr.dx_px[k, w])},{_num(tr.dy_px[k, w])},"
                            f"{STATE_NAMES[lab[w]]}" for w in range(n))
    except BrokenPipeError:          # a reader (head, a controller) stopped listening
        sys.stderr.close()
        return
    if out_csv:
        try:
            atomic_write_text(out_csv, "\n".join(rows) + "\n")
        except OSError as err:
            fail(f"states: cannot write the labels CSV {out_csv}: {err.strerror or err}", code=1)
    if not quiet:
        click.echo(f"{tr.time_s.size} frames x {n} whiskers ({tr.layout} layout), estimator {method}: "
                   + "; ".join(f"w{w} " + "/".join(f"{STATE_NAMES[s]} {counts[w, s]}" for s in range(3))
                               for w in range(n)), err=True)
        if out_csv:
            click.echo(f"wrote {out_csv}", err=True)
