"""A recording session read back (the folder `whisker.data.recording.Recorder` writes; layout, clock
and crash safety in that module's docstring).

:func:`load_session` reads a session, complete or cut short by a crash: every complete row of the
append-only tables (a torn last line, written only in part, is dropped) and the frames whose
``frames.csv`` row and image both exist, as a :class:`Session` of numpy arrays on the session's clock.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from whisker.data.recording import FORMAT, RecordingError

def read_table(path) -> dict[str, list[str]]:
    """Columns of an append-only CSV as lists of strings; a torn last line is dropped."""
    path = Path(path)
    if not path.exists():
        return {}
    text = path.read_text(encoding="utf-8", errors="replace")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # the last row was written only in part
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return {}
    header, body = rows[0], rows[1:]
    body = [r for r in body if len(r) == len(header)]
    return {h: [r[i] for r in body] for i, h in enumerate(header)}


def _floats(values) -> np.ndarray:
    """Numbers of a CSV column; empty and non-finite cells become NaN (a ValueError names a bad cell)."""
    out = np.array([float(v) if v not in ("", None) else np.nan for v in values], dtype=float)
    out[~np.isfinite(out)] = np.nan
    return out


@dataclass
class Session:
    """A recording read back. frames: index, time_s, file per complete frame (image present);
    tracks: (F, N) arrays keyed by column for those frames; actuation: times, phases, levels."""

    folder: Path
    meta: dict
    frame_index: np.ndarray
    frame_time_s: np.ndarray
    frame_files: list
    tracks: dict = field(default_factory=dict)
    act_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    act_phase: list = field(default_factory=list)
    act_requested: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    act_applied: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    guard_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    guard_temperatures: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    events: list = field(default_factory=list)      # (time_s, event, coils) of events.csv

    def guard_intervals(self) -> list[tuple[float, float, str, list]]:
        """(start_s, end_s, "derate"/"cut", coils) of every guard derate or cut in the session; one
        still running at the end ends at the last frame."""
        end_t = float(self.frame_time_s[-1]) if len(self.frame_time_s) else 0.0
        out, open_ = [], {}
        for t, ev, coils in self.events:
            for c in coils:
                if ev in ("derate", "cut"):
                    open_.setdefault((ev, c), t)
                elif ev in ("derate-end", "resume"):
                    kind = "derate" if ev == "derate-end" else "cut"
                    if (kind, c) in open_:
                        out.append((open_.pop((kind, c)), t, kind, [c]))
        out += [(t0, end_t, kind, [c]) for (kind, c), t0 in open_.items()]
        return sorted(out)

    @property
    def complete(self) -> bool:
        return bool(self.meta.get("complete"))

    def phase_times(self) -> list[tuple[float, str]]:
        """(time_s, phase) at each phase change of the actuation table."""
        out, last = [], None
        for t, p in zip(self.act_time_s, self.act_phase):
            if p != last:
                out.append((float(t), p))
                last = p
        return out

    def displacement(self, quantity: str = "px") -> np.ndarray:
        """(F, N) displacement of each whisker per frame: "px" = marker |(dx, dy)| in pixels,
        "mm" = tip displacement |(tip_x, tip_y)| in mm, "deg" = theta. NaN where invalid."""
        if quantity == "px":
            d = np.hypot(self.tracks["dx_px"], self.tracks["dy_px"])
        elif quantity == "mm":
            d = np.hypot(self.tracks["tip_x_mm"], self.tracks["tip_y_mm"])
        elif quantity == "deg":
            d = self.tracks["theta_deg"].copy()
        else:
            raise ValueError(f"displacement quantity must be px, mm or deg, got {quantity!r}")
        return np.where(self.tracks["valid"] > 0, d, np.nan)


def load_session(folder) -> Session:
    """Read a session folder, complete or cut short by a crash (see the module doc).

    A table that is not a session's (wrong columns, cells that are not numbers) raises
    RecordingError naming the file; rows torn by a crash are dropped silently.
    """
    folder = Path(folder)
    meta_path = folder / "metadata.json"
    if not meta_path.is_file():
        raise RecordingError(f"{folder} is not a recording session (no metadata.json)")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except ValueError as err:
        raise RecordingError(f"{meta_path}: unreadable metadata ({' '.join(str(err).split())})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        got = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise RecordingError(f"{folder}: unknown session format {got!r} (expected {FORMAT})")
    n = meta.get("whiskers")
    if not isinstance(n, int) or not 1 <= n <= 64:
        raise RecordingError(f"{meta_path}: 'whiskers' must be a count 1..64 (got {n!r})")
    try:
        return _read_session(folder, meta, n)
    except (ValueError, TypeError, IndexError, KeyError, OverflowError) as err:
        raise RecordingError(f"{folder}: a table is not a session's ({' '.join(str(err).split())}); "
                             "check frames.csv, tracks.csv and actuation.csv") from None


#: columns a session's frame and track tables must have (when the table has a header at all); an
#: unreadable actuation table counts as no actuation
REQUIRED_COLUMNS = {
    "frames.csv": ("frame", "time_s", "file"),
    "tracks.csv": ("frame", "whisker", "dx_px", "dy_px", "valid", "theta_deg", "tip_x_mm", "tip_y_mm"),
}


def _table(folder: Path, name: str) -> dict[str, list[str]]:
    """read_table, refusing a table whose header lacks a column the session needs."""
    tab = read_table(folder / name)
    missing = [c for c in REQUIRED_COLUMNS.get(name, ()) if tab and c not in tab]
    if missing:
        raise RecordingError(f"{folder / name}: missing column(s) {', '.join(missing)}; not a session table "
                             "written by whisker record")
    return tab


def _read_session(folder: Path, meta: dict, n: int) -> Session:
    fr = _table(folder, "frames.csv")
    idx = np.array([int(v) for v in fr.get("frame", [])], dtype=int)
    t = _floats(fr.get("time_s", []))
    files = list(fr.get("file", []))
    keep = np.array([(not f) or (folder / "frames" / f).exists() for f in files], dtype=bool)
    idx, t, files = idx[keep], t[keep], [f for f, k in zip(files, keep) if k]

    tr = _table(folder, "tracks.csv")
    tracks = {}
    if tr and tr.get("frame"):
        tf = np.array([int(v) for v in tr["frame"]], dtype=int)
        tw = np.array([int(v) for v in tr["whisker"]], dtype=int)
        pos = {f: i for i, f in enumerate(idx)}
        for col in tr:
            if col in ("frame", "whisker", "status", "time_s"):
                continue
            arr = np.full((len(idx), n), np.nan)
            vals = _floats(tr[col])
            for f, w, v in zip(tf, tw, vals):
                if f in pos and 0 <= w < n:
                    arr[pos[f], w] = v
            tracks[col] = arr
    ac = read_table(folder / "actuation.csv")
    if "time_s" not in ac or "phase" not in ac:
        ac = {}           # unreadable: no actuation to align on (recplot names the trial)
    at = _floats(ac.get("time_s", []))
    req = np.array([_floats(ac.get(f"requested_{i}", [])) for i in range(n)]).T.reshape(len(at), n)
    app = np.array([_floats(ac.get(f"applied_{i}", [])) for i in range(n)]).T.reshape(len(at), n)
    gd = read_table(folder / "guard.csv")
    gt = _floats(gd.get("time_s", []))
    gtemp = np.array([_floats(gd.get(f"temperature_{i}", [])) for i in range(n)]).T.reshape(len(gt), n)
    ev = read_table(folder / "events.csv")
    events = []
    for ts, name, coils in zip(_floats(ev.get("time_s", [])), ev.get("event", []), ev.get("coils", [])):
        try:
            events.append((float(ts), name, [int(c) for c in coils.split()]))
        except ValueError:
            continue          # a torn or edited row: the events are a record, not the data
    return Session(folder, meta, idx, t, files, tracks, at, list(ac.get("phase", [])), req, app, gt, gtemp, events)
