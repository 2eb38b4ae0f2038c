"""Frame sources behind one interface: iterate `Frame(index, time_s, image)` (image: HxWx3 uint8 BGR).

`open_source(spec, design=None)` picks the source from a string:

* ``"picamera"``          Raspberry Pi camera through Picamera2 (imported only here; install it on the
                           Pi with ``sudo apt install python3-picamera2``). Format "RGB888", which
                           Picamera2 delivers in B, G, R byte order, i.e. what OpenCV expects.
* ``"0"``, ``"1"``, ...   a camera index for OpenCV ``VideoCapture`` (USB cameras).
* a video file            OpenCV ``VideoCapture`` (replay). A truncated file ends early; the source's
                           ``truncated`` attribute then says so.
* an image folder / file  the images in name order (png, jpg, jpeg, bmp, tif, tiff). An unreadable
                           file yields a Frame with ``image=None``: the tracker flags that frame.
                           Frame times are index / fps, or, when the folder holds ``times.csv``
                           (columns ``file,time_s``), each image's recorded time, so a replay
                           keeps the gaps of dropped frames.
* ``"synthetic[:N]"``     N rendered frames (default 100) from `whisker.vision.render` with a known marker
                           path (``.truth[i]`` = marker pixels of frame i), for tests and demos.

An unknown or unreadable source raises `SourceError` with one line saying what is wrong.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from whisker.errors import EnvironmentFault

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


class SourceError(EnvironmentFault):  # a RuntimeError (whisker.errors)
    """A frame source that cannot be opened or read; the message is one line."""


@dataclass(frozen=True)
class Frame:
    index: int
    time_s: float
    image: np.ndarray | None


class FrameSource:
    """Iterable of Frames; use as a context manager or call close()."""
    name = "source"
    fps: float = 30.0
    truncated = False

    def __iter__(self) -> Iterator[Frame]:  # pragma: no cover - abstract
        raise NotImplementedError

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class VideoSource(FrameSource):
    """OpenCV VideoCapture on a file or a camera index."""

    def __init__(self, target, *, width: int | None = None, height: int | None = None):
        import cv2

        self.name = str(target)
        self.live = isinstance(target, int)
        self.cap = cv2.VideoCapture(target)
        if not self.cap.isOpened():
            self.cap.release()
            what = f"camera index {target}" if self.live else f"video file {target}"
            raise SourceError(f"cannot open {what} with OpenCV VideoCapture")
        if self.live and width and height:
            self.cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            self.cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        fps = self.cap.get(cv2.CAP_PROP_FPS)
        self.fps = fps if math.isfinite(fps) and fps > 0 else 30.0
        count = self.cap.get(cv2.CAP_PROP_FRAME_COUNT)
        self.expected = int(count) if (not self.live and math.isfinite(count) and count > 0) else None

    def __iter__(self):
        import cv2

        i = 0
        t0 = time.monotonic()
        while True:
            try:
                ok, img = self.cap.read()
            except cv2.error:  # a corrupt stream can raise inside the decoder
                ok, img = False, None
            if not ok or img is None:
                break
            t = (time.monotonic() - t0) if self.live else i / self.fps
            yield Frame(i, t, img)
            i += 1
        if self.expected is not None and i < self.expected:
            self.truncated = True
        self.frames_read = i

    def close(self):
        self.cap.release()


class FolderSource(FrameSource):
    """Images of a folder (or one image file) in name order."""

    def __init__(self, path, *, fps: float = 30.0):
        path = Path(path)
        self.name = str(path)
        self.fps = fps
        if path.is_dir():
            self.files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if not self.files:
                raise SourceError(f"image folder {path} holds no {'/'.join(IMAGE_SUFFIXES)} files")
        else:
            self.files = [path]
        self.times = self._times(path / "times.csv") if path.is_dir() else None

    def _times(self, csv_path: Path):
        """Recorded frame times (s) per image from times.csv, or None when there is no such file."""
        import csv

        if not csv_path.is_file():
            return None
        try:
            with open(csv_path, newline="") as fh:
                rows = {r["file"]: float(r["time_s"]) for r in csv.DictReader(fh)}
        except (KeyError, ValueError, TypeError, UnicodeDecodeError, csv.Error) as err:
            raise SourceError(f"{csv_path}: needs the columns file,time_s with one number per image ({err})") from None
        missing = [f.name for f in self.files if f.name not in rows]
        if missing:
            raise SourceError(f"{csv_path}: no time for {missing[0]} ({len(missing)} image(s) without one)")
        times = [rows[f.name] for f in self.files]
        if not all(math.isfinite(t) for t in times) or any(b <= a for a, b in zip(times, times[1:])):
            raise SourceError(f"{csv_path}: the times must be finite and increase in the images' name order")
        return times

    def __iter__(self):
        import cv2

        for i, f in enumerate(self.files):
            img = cv2.imread(str(f), cv2.IMREAD_COLOR)
            yield Frame(i, self.times[i] if self.times else i / self.fps, img)


class PicameraSource(FrameSource):
    """Raspberry Pi camera via Picamera2 (optional dependency)."""

    def __init__(self, width: int = 640, height: int = 480, fps: float | None = None):
        """fps: ask the sensor for this frame rate (Picamera2's FrameRate control), or its default."""
        try:
            from picamera2 import Picamera2
        except ImportError:
            raise SourceError("source 'picamera' needs the picamera2 package (on Raspberry Pi OS: "
                              "sudo apt install python3-picamera2); use a camera index for USB cameras") from None
        self.name = "picamera"
        try:
            self.cam = Picamera2()
            controls = {"FrameRate": float(fps)} if fps else {}
            self.cam.configure(self.cam.create_video_configuration(main={"size": (width, height), "format": "RGB888"},
                                                                   controls=controls))
            if fps:
                self.fps = float(fps)
            self.cam.start()
        except Exception as err:
            raise SourceError(f"cannot start the Raspberry Pi camera: {err}") from None

    def __iter__(self):
        i = 0
        t0 = time.monotonic()
        while True:
            img = self.cam.capture_array("main")
            yield Frame(i, time.monotonic() - t0, np.ascontiguousarray(img[..., :3]))
            i += 1

    def close(self):
        try:
            self.cam.stop()
            self.cam.close()
        except Exception:
            pass


class SyntheticSource(FrameSource):
    """Rendered frames: every whisker swings radially, tilt(t) = amplitude * sin(2 pi t / period)^2.

    truth[i] holds the marker pixel centres of frame i. Keyword arguments go to `render_frame`.
    """

    def __init__(self, design, count: int = 100, *, amplitude_deg: float = 10.0, period_frames: int = 40,
                 fps: float = 30.0, seed: int = 0, **render_kw):
        from whisker.vision import render

        if count < 1:
            raise SourceError(f"synthetic source needs at least 1 frame, got {count}")
        self.name = f"synthetic:{count}"
        self.design = design
        self.fps = fps
        self.seed = seed
        self.render_kw = {"noise_sigma": 4.0, "blur_px": 0.7, **render_kw}
        n = design.whiskers.count
        phase = np.linspace(0.0, math.pi, n, endpoint=False)
        self.tilts = np.array([amplitude_deg * np.sin(math.pi * i / period_frames + phase) ** 2 for i in range(count)])
        self.truth = np.array([render.scene_markers(design, t) for t in self.tilts])
        self._render = render.render_frame

    def __iter__(self):
        for i, pts in enumerate(self.truth):
            yield Frame(i, i / self.fps, self._render(self.design, pts, seed=self.seed + i, **self.render_kw))


def open_source(spec, design=None, **kw) -> FrameSource:
    """A FrameSource from a spec string (see module doc). `design` is needed for 'synthetic'."""
    s = str(spec).strip()
    if not s:
        raise SourceError("empty source: give picamera, a camera index, a video file, an image folder or synthetic")
    if s == "picamera":
        return PicameraSource(**kw)
    if s.split(":")[0] == "synthetic":
        if design is None:
            from whisker.design import default_design

            design = default_design()
        try:
            count = int(s.split(":", 1)[1]) if ":" in s else 100
        except ValueError:
            raise SourceError(f"synthetic source count must be an integer, got {s!r}") from None
        return SyntheticSource(design, count, **kw)
    if s.isdigit():
        return VideoSource(int(s), **kw)
    p = Path(s)
    if not p.exists():
        raise SourceError(f"source {s}: no such file or folder (nor picamera, a camera index or synthetic)")
    if p.is_dir() or p.suffix.lower() in IMAGE_SUFFIXES:
        return FolderSource(p, **kw)
    return VideoSource(s)
