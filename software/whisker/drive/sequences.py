"""Timed coil sequences: steps of levels held for a time (the paper's grasp: retract, hold, release),
read from sequence files (docs/sequences/*.toml), and run on an :class:`whisker.drive.actuation.Actuator`
in the foreground (:func:`run_sequence`) or a thread (:class:`ThreadedSequenceRunner`)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from whisker.drive.actuation import Actuator, configuration
from whisker.drive.guard import RatingError, check_levels, volts_to_levels

__all__ = ["Step", "grasp_sequence", "sequence_from_dict", "load_sequence", "SequenceRunner",
           "ThreadedSequenceRunner", "run_sequence"]


@dataclass(frozen=True)
class Step:
    """Hold `levels` (N,) for `duration_s` seconds, labelled `phase`."""

    phase: str
    duration_s: float
    levels: tuple = field(default=())

    def __post_init__(self):
        if not (self.duration_s >= 0) or self.duration_s == float("inf"):
            raise ValueError(f"step {self.phase!r}: duration must be finite and >= 0, got {self.duration_s}")


def grasp_sequence(n: int, mask, level: float, *, retract_s: float = 1.0, hold_s: float = 3.0,
                   release_s: float = 1.0, hold_level: Optional[float] = None,
                   release_level: float = 0.0) -> list[Step]:
    """The paper's grasp: retract the active whiskers, hold, release.

    Phases: "retract" (level on the active whiskers for retract_s: they close on the object),
    "hold" (hold_level, default = level, for hold_s: the arm lifts), "release" (release_level on the
    active whiskers for release_s; 0 = neutral, a small negative value pushes the object off), then
    "neutral" (all zero). The paper uses 3 V with 8, 4 or 2 whiskers; its Fig. 8 marks the
    retract command, the arm moving up and the return to neutral.
    """
    m = np.asarray(mask, dtype=bool)
    if m.shape != (n,):
        raise ValueError(f"mask must have shape ({n},), got {m.shape}")
    hold_level = level if hold_level is None else hold_level

    def lv(x):
        return tuple(float(v) for v in np.where(m, float(x), 0.0))

    return [Step("retract", retract_s, lv(level)), Step("hold", hold_s, lv(hold_level)),
            Step("release", release_s, lv(release_level)), Step("neutral", 0.0, lv(0.0))]


def sequence_from_dict(design, data: dict) -> list[Step]:
    """Steps from a parsed sequence file (TOML), every level checked against the ratings first.

    Format::

        repeat = 2                    # optional, run the steps this many times
        [[step]]
        phase = "retract"             # label, logged with every command
        duration_s = 1.0
        config = "every-second"       # optional (default "all"), with `start`
        level = 0.8                   # signed duty on the configured whiskers, or
        # volts = 2.5                 # signed mean volts on the configured whiskers, or
        # levels = [0.5, 0, ...]      # one signed duty per whisker, or
        # volts_each = [3, 0, ...]    # one signed voltage per whisker

    A step with none of them is neutral. Raises ValueError / RatingError naming the step; nothing
    runs unless the whole sequence is valid.
    """
    n = design.whiskers.count
    if not isinstance(data, dict):
        raise ValueError("a sequence file must be a TOML table with [[step]] entries")
    unknown = set(data) - {"repeat", "step"}
    if unknown:
        raise ValueError(f"sequence: unknown key(s) {sorted(unknown)} (expected repeat and [[step]])")
    raw = data.get("step")
    if not isinstance(raw, list) or not raw:
        raise ValueError("sequence: no [[step]] entries")
    repeat = data.get("repeat", 1)
    if not isinstance(repeat, int) or not 1 <= repeat <= 10000:
        raise ValueError(f"sequence: repeat must be an integer 1..10000, got {repeat!r}")
    allowed = {"phase", "duration_s", "config", "start", "level", "volts", "levels", "volts_each"}
    steps = []
    for k, st in enumerate(raw):
        where = f"sequence step {k + 1}"
        if not isinstance(st, dict):
            raise ValueError(f"{where}: must be a table")
        bad = set(st) - allowed
        if bad:
            raise ValueError(f"{where}: unknown key(s) {sorted(bad)}; allowed: {sorted(allowed)}")
        phase = st.get("phase", f"step{k + 1}")
        if not isinstance(phase, str) or not phase or "," in phase or "\n" in phase:
            raise ValueError(f"{where}: phase must be a non-empty label without commas")
        dur = st.get("duration_s")
        if not isinstance(dur, (int, float)) or isinstance(dur, bool) or not (0 <= dur < float("inf")):
            raise ValueError(f"{where}: duration_s must be a finite number >= 0, got {dur!r}")
        given = [key for key in ("level", "volts", "levels", "volts_each") if key in st]
        if len(given) > 1:
            raise ValueError(f"{where}: give one of level, volts, levels, volts_each (got {given})")
        try:
            if not given:
                lv = np.zeros(n)
            elif given[0] in ("levels", "volts_each"):
                vec = np.asarray(st[given[0]], dtype=float)
                if vec.shape != (n,):
                    raise ValueError(f"{given[0]} needs {n} values (one per whisker), got {vec.size}")
                lv = vec if given[0] == "levels" else volts_to_levels(design, vec)
            else:
                value = float(st[given[0]])
                if given[0] == "volts":
                    value = float(volts_to_levels(design, value))
                mask = configuration(n, st.get("config", "all"), int(st.get("start", 0)))
                lv = np.where(mask, value, 0.0)
            lv = check_levels(design, lv)
        except RatingError as err:
            raise RatingError(f"{where} ({phase}): {err}") from None
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where} ({phase}): {err}") from None
        steps.append(Step(phase, float(dur), tuple(float(x) for x in lv)))
    return steps * repeat


def load_sequence(design, path) -> list[Step]:
    """Read a sequence TOML file (see :func:`sequence_from_dict`), or a shipped example by name
    (``voltage_sweep``: docs/sequences/ in a clone, whisker.sequences in a wheel)."""
    from whisker.files import read_toml
    from whisker.resources import example, sequences_dir

    return sequence_from_dict(design, read_toml(example(path, sequences_dir()), "sequence"))


class SequenceRunner:
    """Steps through a list of :class:`Step` on an actuator without blocking.

    Call :meth:`tick` (with the same clock's time) as often as convenient, e.g. once per camera
    frame while recording: it applies a step's levels when the step begins and runs the guard
    otherwise. `done` is True once the last step has begun and its duration has passed.
    """

    def __init__(self, actuator: Actuator, steps: Sequence[Step]):
        if not steps:
            raise ValueError("a sequence needs at least one step")
        self.actuator = actuator
        self.steps = list(steps)
        ends = np.cumsum([s.duration_s for s in self.steps])
        self.starts = np.concatenate([[0.0], ends[:-1]])
        self.total_s = float(ends[-1])
        self.t0: Optional[float] = None
        self.index = -1
        self.done = False
        self._lock = threading.RLock()

    def start(self, now: float) -> None:
        self.t0 = float(now)
        self.tick(now)

    def tick(self, now: float) -> str:
        """Apply whatever step is due at `now`; returns the current phase."""
        with self._lock:
            return self._tick(now)

    def _tick(self, now: float) -> str:
        if self.t0 is None:
            self.t0 = float(now)
        t = float(now) - self.t0
        due = int(np.searchsorted(self.starts, t, side="right")) - 1
        due = min(max(due, 0), len(self.steps) - 1)
        while self.index < due:  # apply each step that began, even if a tick skipped over it
            self.index += 1
            step = self.steps[self.index]
            self.actuator.apply(np.asarray(step.levels, dtype=float), step.phase)
        if self.index == due:
            self.actuator.tick()
        self.done = t >= self.total_s
        return self.steps[self.index].phase


class ThreadedSequenceRunner(SequenceRunner):
    """A :class:`SequenceRunner` that also ticks itself every `period_s` in a background thread
    once started, so phase changes keep their timing when the caller ticks rarely (e.g. once per
    camera frame). :meth:`stop` ends the thread; the caller still owns switching off."""

    def __init__(self, actuator: Actuator, steps: Sequence[Step], *, period_s: float = 0.01,
                 clock: Callable[[], float] = time.monotonic):
        super().__init__(actuator, steps)
        self.period_s = float(period_s)
        self.clock = clock
        self.error: Optional[BaseException] = None
        self._stop_event = threading.Event()
        self._thread: Optional[threading.Thread] = None

    def start(self, now: float) -> None:
        super().start(now)
        self._thread = threading.Thread(target=self._run, name="whisker-sequence", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop_event.wait(self.period_s) and not self.done:
            try:
                self.tick(self.clock())
            except BaseException as err:  # noqa: BLE001 - reported to the caller's thread
                self.error = err
                self.actuator.off()
                return

    def tick(self, now: float) -> str:
        if self.error is not None:
            raise RuntimeError(f"sequence thread failed: {self.error}") from self.error
        return super().tick(now)

    def stop(self) -> None:
        self._stop_event.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)


def run_sequence(actuator: Actuator, steps: Sequence[Step], *, period_s: float = 0.02,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 on_tick: Optional[Callable[[float, str], None]] = None) -> None:
    """Run `steps` to the end (blocking), ticking every `period_s`; switches off at the end."""
    runner = SequenceRunner(actuator, steps)
    runner.start(clock())
    try:
        while True:
            now = clock()
            phase = runner.tick(now)
            if on_tick is not None:
                on_tick(now - runner.t0, phase)
            if runner.done:
                break
            sleep(min(period_s, max(0.0, runner.t0 + runner.total_s - now)) or period_s)
    finally:
        actuator.off()
