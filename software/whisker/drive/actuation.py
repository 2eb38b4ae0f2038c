"""Coil actuation: whisker configurations, and the safety that de-energises every coil however the
program ends.

Units and signs. A *level* is a signed PWM duty in [-1, 1] per whisker: + = retraction (the tip
moves toward the array's centre), - = extension, 0 = neutral (no current). Level x
the coil's full-scale voltage (:func:`whisker.drive.guard.full_scale_voltage`) is the mean voltage at the
coil (:func:`whisker.drive.guard.volts_to_levels`).

Safety (:class:`Actuator`): every request is checked against the ratings (refused, not clamped:
:class:`whisker.drive.guard.RatingError`), then passed through the thermal guard; a watchdog thread keeps
the guard's temperature estimate current every ``drive.guard_period`` seconds while a coil is on,
so a coil left on is derated and cut even if the caller sleeps. Coils are switched off on normal
exit (context manager and ``atexit``), on an exception, on Ctrl-C (KeyboardInterrupt unwinds through
the context manager) and on SIGTERM/SIGHUP (:func:`deenergise_on_signals` turns them into
``SystemExit``). SIGKILL and power loss cannot be caught by any program: docs/actuation.md lists the
hardware measures (pull-down resistors on the inputs) that cover them.

The backends (gpiozero pins, PCA9685, simulator) are in :mod:`whisker.drive.hbridge`; timed sequences in
:mod:`whisker.drive.sequences`.
"""

from __future__ import annotations

import atexit
import signal
import threading
import time
import weakref
from contextlib import contextmanager
from typing import Callable, Iterable, Iterator, Optional

import numpy as np

from whisker.drive.guard import RatingError, ThermalGuard, check_driver, check_levels, volts_to_levels
from whisker.drive.hbridge import open_backend

__all__ = ["Actuator", "RatingError", "configuration", "CONFIG_NAMES", "deenergise_on_signals", "Terminated",
           "default_state_file", "open_actuator"]


# ---------------------------------------------------------------------------------------------
# configurations
# ---------------------------------------------------------------------------------------------

#: Named configurations -> number of active whiskers as a function of N (the paper's 8/4/2 for N=8).
CONFIG_NAMES = {"all": lambda n: n, "every-second": lambda n: n // 2, "opposite": lambda n: 2}


def configuration(n: int, which, start: int = 0) -> np.ndarray:
    """Boolean mask (n,) of the active whiskers.

    which: "all", "every-second", "opposite", or an integer k = number of evenly spaced active
    whiskers (whiskers start, start + n/k, start + 2n/k, ...): with N = 8 the paper's 8, 4 and 2
    are "all", "every-second" and "opposite". k must divide n, so that the active whiskers are
    evenly spaced and their forces balance.
    """
    if n < 1:
        raise ValueError(f"whisker count must be >= 1, got {n}")
    if isinstance(which, str) and which in CONFIG_NAMES:
        k = CONFIG_NAMES[which](n)
        label = which
    else:
        try:
            k = int(which)
        except (TypeError, ValueError):
            raise ValueError(f"configuration must be one of {sorted(CONFIG_NAMES)} or a whisker "
                             f"count, got {which!r}") from None
        label = f"{k} whiskers"
    if k < 1 or k > n or n % k:
        raise ValueError(f"configuration {label!r} needs a number of active whiskers (here {k}) "
                         f"that divides the whisker count {n}")
    mask = np.zeros(n, dtype=bool)
    mask[(int(start) + np.arange(k) * (n // k)) % n] = True
    return mask


# ---------------------------------------------------------------------------------------------
# the actuator
# ---------------------------------------------------------------------------------------------

_LIVE: "weakref.WeakSet[Actuator]" = weakref.WeakSet()
_ATEXIT = []


def _off_at_exit() -> None:  # normal interpreter exit: nothing stays energised
    for act in list(_LIVE):
        act.close()


def _register_atexit() -> None:
    # Registered when the first Actuator is made, i.e. after gpiozero's own atexit hook (which
    # releases the pins): atexit runs last-registered first, so the coils are switched off by us,
    # through the open devices, before gpiozero lets go of the pins.
    if not _ATEXIT:
        atexit.register(_off_at_exit)
        _ATEXIT.append(True)


class Actuator:
    """Rated, thermally guarded commands on a backend. Use as a context manager.

    guard: a :class:`whisker.drive.guard.ThermalGuard` (default: one on the design's coil model), or
    False for no thermal guard (refused unless ``unguarded_ok=True``: for bench tests of the pins).
    watchdog: run the guard every ``drive.guard_period`` s in a thread (default True; tests with an
    injected clock call :meth:`tick` themselves). log: callback(time_s, phase, requested, applied)
    for every change of the applied levels (the recorder's actuation table).
    """

    def __init__(self, design, backend, *, guard=None, watchdog: bool = True,
                 clock: Callable[[], float] = time.monotonic, log: Optional[Callable] = None,
                 unguarded_ok: bool = False, current_fn: Optional[Callable] = None):
        self.design = design
        self.n = design.whiskers.count
        self.backend = backend
        self.clock = clock
        self.log = log
        if guard is False:
            if not unguarded_ok:
                raise ValueError("an Actuator without a thermal guard needs unguarded_ok=True")
            self.guard = None
        else:
            check_driver(design, current_fn)
            self.guard = guard if guard is not None else ThermalGuard(design, clock=clock,
                                                                      current_fn=current_fn)
        self.requested = np.zeros(self.n)
        self.applied = np.zeros(self.n)
        self.phase = "neutral"
        self._lock = threading.RLock()
        self._closed = False
        self._stop = threading.Event()
        self._thread = None
        self._logged = np.zeros(self.n)
        self.failed: Optional[BaseException] = None
        _LIVE.add(self)
        _register_atexit()
        if watchdog and self.guard is not None:
            self._thread = threading.Thread(target=self._watch, name="whisker-guard", daemon=True)
            self._thread.start()

    # -- core ------------------------------------------------------------------------------
    def apply(self, levels, phase: str = "") -> np.ndarray:
        """Request `levels` (N,); returns the levels actually applied after the guard.

        Raises RatingError / ValueError without changing anything when a level is refused.
        """
        req = check_levels(self.design, levels)
        with self._lock:
            if self._closed:
                raise RuntimeError("actuator is closed")
            if self.failed is not None:
                raise RuntimeError(f"the thermal guard failed ({self.failed}); coils are off")
            self.requested = req.copy()
            if phase:
                self.phase = phase
            return self._push(force_log=True)

    def tick(self) -> np.ndarray:
        """Update the guard and re-apply the requested levels (call periodically while on)."""
        with self._lock:
            if self._closed:
                return self.applied
            try:
                return self._push(force_log=False)
            except Exception as err:  # a failing guard or backend: off, and refuse further commands
                self.failed = err
                self.off()
                raise

    #: a guard-driven change smaller than this (in level) is applied but not logged, so a derating
    #: coil does not write a log row every guard period
    LOG_RESOLUTION = 0.01

    def _push(self, force_log: bool) -> np.ndarray:
        now = self.clock()
        allowed = self.requested if self.guard is None else self.guard.allow(self.requested, now)
        changed = not np.array_equal(allowed, self.applied)
        if changed or force_log:
            try:
                self.backend.set_levels(allowed)
            except BaseException:
                self.off()
                raise
            self.applied = np.array(allowed, dtype=float)
            if self.log is not None and (force_log or self._worth_logging()):
                self._logged = self.applied.copy()
                self.log(now, self.phase, self.requested.copy(), self.applied.copy())
        return self.applied

    def _worth_logging(self) -> bool:
        last = self._logged
        return bool(np.any(np.abs(self.applied - last) >= self.LOG_RESOLUTION)
                    or np.any((self.applied == 0) != (last == 0)))

    def _watch(self) -> None:
        period = float(self.design.drive.guard_period)
        while not self._stop.wait(period):
            try:
                self.tick()
            except Exception:  # noqa: BLE001 - tick() has switched off and recorded the failure
                return

    # -- commands --------------------------------------------------------------------------
    def neutral(self) -> np.ndarray:
        """Every coil without current (whiskers return to rest under the membrane's stiffness)."""
        return self.apply(np.zeros(self.n), "neutral")

    def _masked(self, which, level, start: int = 0) -> np.ndarray:
        mask = configuration(self.n, which, start)
        return np.where(mask, np.asarray(level, dtype=float), 0.0)

    def retract(self, level: Optional[float] = None, which="all", start: int = 0) -> np.ndarray:
        """Tips toward the centre on the whiskers of configuration `which` (others neutral).

        level: duty in (0, 1]; default = each whisker's drive.grasp_levels from bring-up when set, else
        actuation.voltage (3 V) / full-scale voltage.
        """
        if level is None:
            g = self.design.drive.grasp_levels
            level = np.asarray(g, dtype=float) if len(g) == self.n else self.default_level()
        elif float(level) < 0:
            raise ValueError(f"retract level must be >= 0 (use extend), got {level}")
        return self.apply(self._masked(which, level, start), "retract")

    def extend(self, level: Optional[float] = None, which="all", start: int = 0) -> np.ndarray:
        """Tips away from the centre (negative levels) on the whiskers of `which`."""
        level = self.default_level() if level is None else float(level)
        if level < 0:
            raise ValueError(f"extend level is a magnitude, must be >= 0, got {level}")
        return self.apply(self._masked(which, -level, start), "extend")

    def set_whisker(self, whisker: int, level: float, phase: str = "level") -> np.ndarray:
        """Change one whisker's level, keeping the others' requested levels."""
        if not 0 <= whisker < self.n:
            raise ValueError(f"whisker must be 0..{self.n - 1}, got {whisker}")
        req = self.requested.copy()
        req[whisker] = float(level)
        return self.apply(req, phase)

    def set_volts(self, volts, phase: str = "volts") -> np.ndarray:
        """Signed mean volts at each coil (N,) -> levels, refused above drive.max_coil_voltage."""
        return self.apply(volts_to_levels(self.design, volts), phase)

    def default_level(self) -> float:
        """The design's actuation voltage (the paper's 3 V) as a duty."""
        return float(volts_to_levels(self.design, self.design.actuation.voltage))

    # -- shutdown --------------------------------------------------------------------------
    def off(self) -> None:
        """De-energise every coil now. Never raises; safe to call any number of times.

        Called from signal handlers and atexit too, so it does not wait for the watchdog's lock:
        the request is zeroed first (a concurrent tick can then only apply zeros), then the pins.
        """
        self.requested = np.zeros(self.n)
        locked = self._lock.acquire(timeout=0.5)
        try:
            self.backend.off()
        except Exception:  # noqa: BLE001 - last line of defence
            pass
        finally:
            if locked:
                self._lock.release()
        if self.guard is not None:
            try:
                self.guard.allow(self.requested, self.clock())
            except Exception:  # noqa: BLE001
                pass
        if np.any(self.applied != 0) and self.log is not None:
            try:
                self.log(self.clock(), "off", self.requested.copy(), np.zeros(self.n))
            except Exception:  # noqa: BLE001
                pass
        self.applied = np.zeros(self.n)
        self.phase = "off"

    def close(self) -> None:
        """Stop the watchdog, switch everything off, save the guard state, release the pins."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)
        with self._lock:
            self.off()
            self._closed = True
        if self.guard is not None:
            try:
                self.guard.save_state()
            except Exception:  # noqa: BLE001
                pass
        close = getattr(self.backend, "close", None)
        if close is not None:
            try:
                close()
            except Exception:  # noqa: BLE001
                pass
        _LIVE.discard(self)

    def __enter__(self) -> "Actuator":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# ---------------------------------------------------------------------------------------------
# signals
# ---------------------------------------------------------------------------------------------

class Terminated(SystemExit):
    """Raised in the main thread on SIGTERM/SIGHUP so that every `with`/`finally` runs."""


@contextmanager
def deenergise_on_signals(signals: Iterable[int] = (signal.SIGTERM, signal.SIGHUP)) -> Iterator[None]:
    """Turn SIGTERM (and SIGHUP) into :class:`Terminated` (exit status 128 + signal) while inside.

    Ctrl-C already raises KeyboardInterrupt. Both unwind through the Actuator's context manager,
    which switches the coils off. Only the main thread can install handlers; elsewhere this is a
    no-op.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise Terminated(128 + signum)

    old = {}
    for s in signals:
        old[s] = signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


# ---------------------------------------------------------------------------------------------
# construction from the command line
# ---------------------------------------------------------------------------------------------

def default_state_file(backend_name: str):
    """Where the real coils' temperatures persist between runs (gpio only; None otherwise):
    $XDG_CACHE_HOME/whisker/coil_state.json (default ~/.cache/whisker/coil_state.json)."""
    import os
    from pathlib import Path

    if backend_name != "gpio":
        return None
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "whisker" / "coil_state.json"


def open_actuator(design, backend_name: str, *, policy: str = "derate", state_file=None,
                  log: Optional[Callable] = None, watchdog: bool = True, backend_object=None) -> Actuator:
    """An Actuator on the named backend (or on `backend_object`, already open) with the design's
    coil model as thermal guard."""
    backend = backend_object if backend_object is not None else open_backend(backend_name, design)
    try:
        guard = ThermalGuard(design, policy=policy,
                             state_file=state_file if state_file is not None else default_state_file(backend_name))
        return Actuator(design, backend, guard=guard, watchdog=watchdog, log=log)
    except BaseException:
        close = getattr(backend, "close", None)
        if close is not None:
            close()
        raise
