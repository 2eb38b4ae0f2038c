"""Crash-safe recording sessions: frames, tracks and actuation commands on one clock.

A session is a folder::

    <session>/
      metadata.json     format, start time, clock, the resolved design (+ derived values, digest),
                        the streams and their columns, the command line; rewritten (atomically) at
                        the end with "complete": true and the counts
      frames/000000.png one image per frame, each written to a temporary name, fsynced, renamed:
                        a file under its final name is always a whole image
      frames.csv        frame, time_s, source_time_s, file        (one row per completed frame)
      tracks.csv        the `whisker track` CSV columns (one row per frame and whisker)
      actuation.csv     time_s, phase, requested_0..N-1, applied_0..N-1 (one row per change)
      guard.csv         time_s, temperature_0..N-1 (estimated coil temperatures, once per frame)

Clock: every ``time_s`` is seconds of ``time.monotonic()`` since the session's ``t0``; metadata
holds the wall-clock time of ``t0``. The actuator uses the same monotonic clock, so actuation
rows and frames are directly comparable.

Crash safety (SIGKILL, power loss): the tables are append-only CSV; each row (or the rows of one
frame) is one ``write`` followed by ``flush`` and ``os.fsync``. Per frame the order is: image file,
its tracks rows, then its ``frames.csv`` row, which marks the frame complete. After a crash,
`whisker.data.session.load_session` reads every complete row (a torn last line, written only in part, is
dropped) and keeps the frames whose row and image exist. A recording replays through
``whisker track --source <session>/frames`` (the images sort in frame order).
"""

from __future__ import annotations

import csv
import io
import os
import sys
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Optional, Sequence

from whisker.errors import BadInput
import numpy as np

from whisker.files import atomic_write_bytes, atomic_write_json

FORMAT = "whisker-session/1"
FRAME_DIGITS = 6
IMAGE_FORMATS = ("png", "jpg")


class RecordingError(BadInput):  # a RuntimeError (whisker.errors)
    """A session folder that cannot be written or read (one-line message)."""


def actuation_columns(n: int) -> list[str]:
    return (["time_s", "phase"] + [f"requested_{i}" for i in range(n)]
            + [f"applied_{i}" for i in range(n)])


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class _Table:
    """An append-only CSV file; every append is one write + flush + fsync."""

    def __init__(self, path: Path, columns: Sequence[str], fsync: bool = True):
        self.path = path
        self.columns = list(columns)
        self.fsync = fsync
        self.rows = 0
        self._lock = threading.Lock()  # actuation rows come from the sequence and watchdog threads
        self._fh = open(path, "a", encoding="utf-8", newline="")
        if self._fh.tell() == 0:
            self._write([self.columns])

    def _write(self, rows) -> None:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        for r in rows:
            w.writerow(r)
        self._fh.write(buf.getvalue())
        self._fh.flush()
        if self.fsync:
            os.fsync(self._fh.fileno())

    def append(self, rows) -> None:
        rows = list(rows)
        for r in rows:
            if len(r) != len(self.columns):
                raise RecordingError(f"{self.path.name}: row has {len(r)} values for {len(self.columns)} columns")
        with self._lock:
            self._write(rows)
            self.rows += len(rows)

    def close(self) -> None:
        with self._lock:
            if not self._fh.closed:
                self._fh.close()


def _num(v, fmt: str = ".6f") -> str:
    """A number for a CSV cell; NaN/inf become an empty cell."""
    v = float(v)
    return format(v, fmt) if np.isfinite(v) else ""


class Recorder:
    """Write one session folder. Use as a context manager (closing marks the session complete).

    folder: must not exist or be empty. image_format: "png" (lossless, default) or "jpg" (smaller,
    faster, lossy). fsync: False only for benchmarks (then only a process crash, not a power cut,
    is survived). meta: extra JSON-able metadata (e.g. the command line, the source, the sequence).
    """

    def __init__(self, folder, design, *, image_format: str = "png", jpeg_quality: int = 95,
                 fsync: bool = True, meta: Optional[dict] = None, clock=time.monotonic):
        if image_format not in IMAGE_FORMATS:
            raise RecordingError(f"image format must be one of {IMAGE_FORMATS}, got {image_format!r}")
        self.folder = Path(folder)
        if self.folder.exists() and (not self.folder.is_dir() or any(self.folder.iterdir())):
            raise RecordingError(f"session folder {self.folder} already exists and is not empty")
        self.design = design
        self.n = design.whiskers.count
        self.image_format = image_format
        self.jpeg_quality = int(jpeg_quality)
        self.fsync = fsync
        self.clock = clock
        self.frames_dir = self.folder / "frames"
        self.frames_dir.mkdir(parents=True, exist_ok=True)
        self.t0 = clock()
        self.t0_wall = time.time()
        from whisker.vision.trackfile import CSV_HEADER

        self.track_columns = CSV_HEADER.split(",")
        self.tables = {
            "frames": _Table(self.folder / "frames.csv", ["frame", "time_s", "source_time_s", "file"], fsync),
            "tracks": _Table(self.folder / "tracks.csv", self.track_columns, fsync),
            "actuation": _Table(self.folder / "actuation.csv", actuation_columns(self.n), fsync),
            "guard": _Table(self.folder / "guard.csv",
                            ["time_s"] + [f"temperature_{i}" for i in range(self.n)], fsync),
            "events": _Table(self.folder / "events.csv", ["time_s", "event", "coils", "temperatures_C"], fsync),
        }
        self.meta = {
            "format": FORMAT,
            "complete": False,
            "created": datetime.fromtimestamp(self.t0_wall, timezone.utc).isoformat(),
            "clock": "seconds of time.monotonic() since t0",
            "t0_wall_s": self.t0_wall,
            "whiskers": self.n,
            "frames": {"folder": "frames", "pattern": f"%0{FRAME_DIGITS}d.{image_format}",
                       "format": image_format},
            "streams": {name: {"file": t.path.name, "columns": t.columns} for name, t in self.tables.items()},
            "design": design.to_dict(),
            "derived": design.derived(),
            "digest": design.digest(),
            "command": sys.argv,
            "fsync": fsync,
            **(meta or {}),
        }
        atomic_write_json(self.folder / "metadata.json", self.meta)
        _fsync_dir(self.folder)
        self.frames = 0
        self._closed = False

    # -- clock -----------------------------------------------------------------------------
    def now(self) -> float:
        """Session time, s (monotonic since t0)."""
        return self.clock() - self.t0

    def session_time(self, monotonic_s: float) -> float:
        return float(monotonic_s) - self.t0

    # -- streams ---------------------------------------------------------------------------
    def write_frame(self, index: int, image, *, time_s: Optional[float] = None,
                    source_time_s: float = float("nan"), track_rows: Sequence[str] = ()) -> str:
        """Store one frame: the image, then its tracks rows (CSV lines), then its frames.csv row.

        Returns the image's file name. A frame without an image (unreadable) gets an empty file
        name and its row anyway.
        """
        t = self.now() if time_s is None else float(time_s)
        name = ""
        if image is not None:
            import cv2

            name = f"{int(index):0{FRAME_DIGITS}d}.{self.image_format}"
            params = [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality] if self.image_format == "jpg" else []
            ok, buf = cv2.imencode(f".{self.image_format}", image, params)
            if not ok:
                raise RecordingError(f"frame {index}: OpenCV could not encode the image as {self.image_format}")
            self._write_image(self.frames_dir / name, buf.tobytes())
        if track_rows:
            self.tables["tracks"].append(list(csv.reader(track_rows)))
        self.tables["frames"].append([[int(index), _num(t), _num(source_time_s), name]])
        self.frames += 1
        return name

    def _write_image(self, path: Path, data: bytes) -> None:
        if self.fsync:
            atomic_write_bytes(path, data)
        else:
            tmp = path.with_name(f".{path.name}.tmp")
            tmp.write_bytes(data)
            os.replace(tmp, path)

    def log_actuation(self, monotonic_s: float, phase: str, requested, applied) -> None:
        """Actuator log callback: one actuation.csv row (time converted to session time)."""
        req = np.asarray(requested, dtype=float)
        app = np.asarray(applied, dtype=float)
        self.tables["actuation"].append(
            [[_num(self.session_time(monotonic_s)), phase] + [_num(v, ".6g") for v in req] + [_num(v, ".6g") for v in app]])

    def log_event(self, clock_s: float, event: str, coils, temperatures_C) -> None:
        """Actuator on_event callback: one events.csv row (a guard derate/cut starting or ending)."""
        self.tables["events"].append([[_num(self.session_time(clock_s)), event, " ".join(map(str, coils)),
                                       " ".join(f"{float(v):.2f}" for v in temperatures_C)]])

    def log_guard(self, temperatures, time_s: Optional[float] = None) -> None:
        t = self.now() if time_s is None else float(time_s)
        self.tables["guard"].append([[_num(t)] + [_num(v, ".3f") for v in temperatures]])

    # -- end -------------------------------------------------------------------------------
    def close(self, **summary) -> None:
        """Mark the session complete (metadata rewritten atomically with counts and `summary`)."""
        if self._closed:
            return
        self._closed = True
        for t in self.tables.values():
            t.close()
        self.meta.update({"complete": True, "duration_s": self.now(), "frame_count": self.frames,
                          "rows": {k: t.rows for k, t in self.tables.items()}, **summary})
        atomic_write_json(self.folder / "metadata.json", self.meta)
        _fsync_dir(self.folder)

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        stopped = None if exc_type is None else exc_type.__name__
        self.close(stopped_by=stopped)


# ---------------------------------------------------------------------------------------------
# the recording loop
# ---------------------------------------------------------------------------------------------

def record_frames(recorder: Recorder, frames, *, tracker=None, model: str = "paper", runner=None,
                  actuator=None, max_frames: Optional[int] = None, duration_s: Optional[float] = None,
                  after_sequence_s: Optional[float] = None, on_frame=None, frame_times: bool = False) -> int:
    """Record `frames` (an iterable of whisker.vision.camera.Frame) into `recorder`.

    Per frame: session time, the sequence runner's tick (actuation rows are logged by the actuator's
    log callback, which the caller points at ``recorder.log_actuation``), tracking (if a calibrated
    `tracker` is given), the guard's temperatures, then the frame itself. Stops at the end of the
    frames, after `max_frames`, after `duration_s`, or `after_sequence_s` after the sequence ended.
    Returns the number of frames written. frame_times: the frames' own time_s is session time (a
    simulated camera on the recorder's clock, `SimCamera.epoch`), so frames buffered before
    writing (the rest frames) keep the time they were taken.
    """
    from whisker.vision.camera import Frame

    count = 0
    seq_end = None
    for frame in frames:
        t = float(frame.time_s) if frame_times else recorder.now()
        if duration_s is not None and t >= duration_s - 1e-9:
            break                       # [0, duration): fps x duration frames from a regular clock
        if runner is not None:
            if runner.t0 is None:
                runner.start(recorder.clock())
            else:
                runner.tick(recorder.clock())
            if runner.done and seq_end is None:
                seq_end = t
        rows = ()
        if tracker is not None:
            from whisker.vision.trackfile import csv_rows

            res = tracker.track(frame.image)
            defl = tracker.deflection(res, model=model)
            rows = csv_rows(Frame(frame.index, t, None), res, defl)
        if actuator is not None and actuator.guard is not None:
            recorder.log_guard(actuator.guard.temperatures, t)
        recorder.write_frame(frame.index, frame.image, time_s=t, source_time_s=frame.time_s, track_rows=rows)
        count += 1
        if on_frame is not None:
            on_frame(count, t)
        if max_frames is not None and count >= max_frames:
            break
        if seq_end is not None and after_sequence_s is not None and t - seq_end >= after_sequence_s:
            break
    return count


class SimCamera:
    """Frames of the simulated sensor, in real time: at `fps`, the simulator backend's whisker tilts
    (``backend.angles_deg()``, + = retraction) are rendered by ``whisker.vision.render`` into a camera
    frame (coil blocks, red markers, wires, noise). With ``whisker record --source sim --backend
    sim`` the actuation moves the simulated whiskers and the tracker sees them move, end to end,
    without hardware. Iterates ``whisker.vision.camera.Frame``; `count` None = until closed.
    """

    name = "sim"
    truncated = False

    def __init__(self, design, backend, *, fps: float = 15.0, count: Optional[int] = None, seed: int = 0,
                 noise_sigma: float = 4.0, blur_px: float = 0.7, clock=time.monotonic, sleep=time.sleep):
        if not hasattr(backend, "angles_deg"):
            raise RecordingError("the sim camera needs the simulator backend (--backend sim)")
        if not (fps > 0):
            raise RecordingError(f"sim camera fps must be > 0, got {fps}")
        self.design, self.backend, self.fps, self.count, self.seed = design, backend, float(fps), count, seed
        self.render_kw = {"noise_sigma": noise_sigma, "blur_px": blur_px}
        self.clock, self.sleep = clock, sleep
        self.epoch: Optional[float] = None      # clock time of t = 0 (default: the first frame's)
        self._closed = False

    def __iter__(self):
        from whisker.vision import render
        from whisker.vision.camera import Frame

        t0 = self.clock() if self.epoch is None else self.epoch
        i = 0
        while not self._closed and (self.count is None or i < self.count):
            wait = t0 + i / self.fps - self.clock()
            if wait > 0:
                self.sleep(wait)
            tilt = np.asarray(self.backend.angles_deg(), dtype=float)
            img = render.render_frame(self.design, render.scene_markers(self.design, tilt), seed=self.seed + i,
                                      **self.render_kw)
            yield Frame(i, self.clock() - t0, img)
            i += 1

    def close(self) -> None:
        self._closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
