"""The tracks CSV: its columns and rows as `whisker track` / `whisker record` write them (one row per frame
and whisker), and reading it, or the authors' airflow layout (``Time,dx,dy``, or
``Time,dx_0..dx_{W-1},dy_0..``), into arrays."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


CSV_HEADER = ("frame,time_s,whisker,x_px,y_px,dx_px,dy_px,valid,status,theta_deg,"
              "tip_x_mm,tip_y_mm,tip_z_mm")


def _fmt(v, nd=4) -> str:
    return "" if not math.isfinite(v) else f"{v:.{nd}f}"


def csv_rows(frame, result, defl) -> list[str]:
    """CSV lines of one frame (one per whisker); invalid markers leave the numbers empty."""
    rows = []
    for i in range(len(result.valid)):
        rows.append(",".join([
            str(frame.index), f"{frame.time_s:.4f}", str(i),
            _fmt(result.positions_px[i, 0]), _fmt(result.positions_px[i, 1]),
            _fmt(result.dx_px[i]), _fmt(result.dy_px[i]), "1" if result.valid[i] else "0", result.status[i],
            _fmt(defl.theta_deg[i]), _fmt(defl.tip_x_mm[i]), _fmt(defl.tip_y_mm[i]), _fmt(defl.tip_z_mm[i])]))
    return rows


class TracksError(ValueError):
    """A tracks file that cannot be read; the message names the file and the problem."""


@dataclass
class Tracks:
    time_s: np.ndarray      # (T,)
    dx_px: np.ndarray       # (T, n), NaN where the marker was lost
    dy_px: np.ndarray
    layout: str             # "whisker-track" or "authors"


class _Bad(ValueError):
    pass


def _float(v: str) -> float:
    """An empty cell is a lost marker (NaN); anything else must be a finite number."""
    v = v.strip()
    if v == "":
        return float("nan")
    try:
        x = float(v)
    except ValueError:
        raise _Bad(f"{v[:20]!r} is not a number") from None
    if not np.isfinite(x):
        raise _Bad(f"{v[:20]!r} is not finite (a lost marker is an empty cell)")
    return x


def read_tracks(path, n_whiskers: int | None = None) -> Tracks:
    """Read `path` (a tracks CSV or a session folder holding tracks.csv). `n_whiskers`: the design's
    whisker count; a whisker index (or dx_i column) at or beyond it is refused. Every numeric cell
    must be empty (lost marker) or a finite number; a whisker with no finite sample is refused."""
    try:
        return _read_tracks(Path(path), n_whiskers)
    except _Bad as err:
        raise TracksError(f"tracks file {path}: {err}") from None


def _read_tracks(path: Path, n_whiskers) -> Tracks:
    path = Path(path)
    if path.is_dir():
        path = path / "tracks.csv"           # a `whisker record` session folder
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise TracksError(f"tracks file {path} does not exist") from None
    except (OSError, UnicodeDecodeError) as err:
        raise TracksError(f"tracks file {path}: cannot read it ({err})") from None
    if len(rows) < 2:
        raise TracksError(f"tracks file {path} has no data rows")
    head = [h.strip() for h in rows[0]]
    body = [r for r in rows[1:] if len(r) == len(head)]
    col = {h: i for i, h in enumerate(head)}
    if {"frame", "time_s", "whisker", "dx_px", "dy_px"} <= col.keys():
        try:
            frame = np.array([int(r[col["frame"]]) for r in body])
            whisker = np.array([int(r[col["whisker"]]) for r in body])
        except ValueError:
            raise TracksError(f"tracks file {path}: frame and whisker must be integers") from None
        if frame.size == 0 or whisker.min() < 0:
            raise TracksError(f"tracks file {path}: no rows or a negative whisker index")
        if n_whiskers is not None and whisker.max() >= n_whiskers:
            raise TracksError(f"tracks file {path}: whisker index {int(whisker.max())} is outside the design's "
                              f"{n_whiskers} whiskers (0-{n_whiskers - 1}); give the matching --design/--set")
        frames, fidx = np.unique(frame, return_inverse=True)
        n = int(whisker.max()) + 1 if n_whiskers is None else int(n_whiskers)
        t = np.full(frames.size, np.nan)
        dx = np.full((frames.size, n), np.nan)
        dy = np.full((frames.size, n), np.nan)
        valid = np.array([r[col["valid"]] != "0" for r in body]) if "valid" in col else np.ones(len(body), bool)
        t[fidx] = [_float(r[col["time_s"]]) for r in body]
        vx = np.array([_float(r[col["dx_px"]]) for r in body])
        vy = np.array([_float(r[col["dy_px"]]) for r in body])
        dx[fidx, whisker] = np.where(valid, vx, np.nan)
        dy[fidx, whisker] = np.where(valid, vy, np.nan)
        layout = "whisker-track"
    elif "Time" in col:
        xs = sorted((h for h in head if h.startswith("dx_")), key=lambda h: int(h.split("_")[-1]) if h.split("_")[-1].isdigit() else -1)
        ys = sorted((h for h in head if h.startswith("dy_")), key=lambda h: int(h.split("_")[-1]) if h.split("_")[-1].isdigit() else -1)
        if not xs and {"dx", "dy"} <= col.keys():
            xs, ys = ["dx"], ["dy"]
        if not xs or len(xs) != len(ys):
            raise TracksError(f"tracks file {path}: needs dx, dy or matching dx_i, dy_i columns beside Time")
        if n_whiskers is not None and len(xs) > n_whiskers:
            raise TracksError(f"tracks file {path}: {len(xs)} whiskers (dx columns) but the design has "
                              f"{n_whiskers}; give the matching --design/--set")
        t = np.array([_float(r[col["Time"]]) for r in body])
        dx = np.array([[_float(r[col[h]]) for h in xs] for r in body])
        dy = np.array([[_float(r[col[h]]) for h in ys] for r in body])
        layout = "authors"
    else:
        raise TracksError(f"tracks file {path}: unknown columns {','.join(head[:6])}...; expected the "
                          "`whisker track` CSV or the authors' Time,dx,dy")
    if t.size == 0:
        raise TracksError(f"tracks file {path} has no complete data rows")
    dead = [w for w in range(dx.shape[1]) if not np.any(np.isfinite(dx[:, w]) & np.isfinite(dy[:, w]))]
    if dead:
        raise TracksError(f"tracks file {path}: whisker(s) {', '.join(map(str, dead[:8]))} have no valid "
                          f"(finite) displacement in any of the {t.size} frames")
    if not np.all(np.isfinite(t)):
        raise TracksError(f"tracks file {path}: a frame has no valid time")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise TracksError(f"tracks file {path}: time does not increase at data row {k + 1} ({t[k]:g} s)")
    return Tracks(time_s=t, dx_px=dx, dy_px=dy, layout=layout)
