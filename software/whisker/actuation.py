"""Coil actuation: H-bridge channels through gpiozero, whisker configurations, timed sequences,
and the safety that de-energises every coil however the program ends.

Units and signs. A *level* is a signed PWM duty in [-1, 1] per whisker: + = retraction (the tip
moves toward the array's centre), - = extension, 0 = neutral (no current). Level x
the coil's full-scale voltage (:func:`whisker.guard.full_scale_voltage`) is the mean voltage at the
coil (:func:`whisker.guard.volts_to_levels`).

Backend protocol (the contract with the simulator, issue 8): any object with

    set_levels(levels: np.ndarray shape (N,), values in [-1, 1]) -> None
    off() -> None            # every coil without current; must not raise

and optionally ``close()``. Backends here: :class:`GpioBackend` on gpiozero (real pins through
gpiozero's default pin factory on a Raspberry Pi, or ``gpiozero.pins.mock.MockFactory`` for tests,
see :func:`mock_backend`), and the simulator's backend through :func:`open_backend` ("sim").

Wiring (from :func:`whisker.pins.pin_map`, the one pin map): coil i is one L298N channel, its two
inputs IN1/IN2 on GPIO ``forward``/``backward``. Each coil is a gpiozero ``Motor(forward, backward,
enable=..., pwm=True)``: a positive level is PWM duty on ``forward`` with ``backward`` low, a negative
level duty on ``backward`` with ``forward`` low (gpiozero switches the other input off *before*
raising the new one, so both inputs are never high together), 0 = both low. If the pin map gives
an ``enable`` GPIO it is held high while the actuator is open and driven low by :meth:`off`.

Safety (:class:`Actuator`): every request is checked against the ratings (refused, not clamped:
:class:`whisker.guard.RatingError`), then passed through the thermal guard; a watchdog thread keeps
the guard's temperature estimate current every ``drive.guard_period`` seconds while a coil is on,
so a coil left on is derated and cut even if the caller sleeps. Coils are switched off on normal
exit (context manager and ``atexit``), on an exception, on Ctrl-C (KeyboardInterrupt unwinds through
the context manager) and on SIGTERM/SIGHUP (:func:`deenergise_on_signals` turns them into
``SystemExit``). SIGKILL and power loss cannot be caught by any program: docs/actuation.md lists the
hardware measures (pull-down resistors on the inputs) that cover them.
"""

from __future__ import annotations

import atexit
import signal
import sys
import threading
import time
import weakref
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator, Optional, Protocol, Sequence

import numpy as np

from whisker.guard import RatingError, ThermalGuard, check_driver, check_levels, volts_to_levels

__all__ = [
    "Backend", "GpioBackend", "Pca9685Backend", "MockI2CBus", "mock_backend", "open_backend", "Actuator", "Step", "RatingError",
    "configuration", "CONFIG_NAMES", "grasp_sequence", "run_sequence", "SequenceRunner",
    "ThreadedSequenceRunner", "sequence_from_dict", "load_sequence",
    "deenergise_on_signals",
]


class Backend(Protocol):
    """What an actuation backend provides (see the module docstring)."""

    def set_levels(self, levels: np.ndarray) -> None: ...

    def off(self) -> None: ...


# ---------------------------------------------------------------------------------------------
# backends
# ---------------------------------------------------------------------------------------------

class GpioBackend:
    """One gpiozero ``Motor`` per coil on the pins of :func:`whisker.pins.pin_map`.

    pin_factory: None = gpiozero's default (the real pins on a Raspberry Pi), or a factory such as
    ``MockFactory(pin_class=MockPWMPin)``. channels: override the pin map (objects with whisker,
    forward, backward, enable, bus), e.g. for a test bench.
    """

    def __init__(self, design, *, pin_factory=None, channels: Optional[Sequence] = None):
        from gpiozero import Motor

        self.n = design.whiskers.count
        if channels is None:
            from whisker.pins import pin_map

            channels = pin_map(design)
        channels = sorted(channels, key=lambda c: c.whisker)
        if [c.whisker for c in channels] != list(range(self.n)):
            raise ValueError(f"pin map must give exactly one channel per whisker 0..{self.n - 1}")
        for c in channels:
            if getattr(c, "bus", "gpio") != "gpio":
                raise ValueError(
                    f"coil {c.whisker} is on bus {c.bus!r}: GpioBackend drives Pi GPIO only; use "
                    "Pca9685Backend (open_backend picks it for wiring.expander=\"pca9685\")")
        self.channels = channels
        self.frequency_hz = float(design.drive.pwm_frequency)
        self.motors = []
        try:
            for c in channels:
                m = Motor(c.forward, c.backward, enable=c.enable, pwm=True, pin_factory=pin_factory)
                for dev in (m.forward_device, m.backward_device):
                    dev.frequency = self.frequency_hz
                self.motors.append(m)
        except BaseException:
            self.close()
            raise
        self.levels = np.zeros(self.n)

    def set_levels(self, levels) -> None:
        lv = np.asarray(levels, dtype=float)
        if lv.shape != (self.n,) or not np.all(np.isfinite(lv)) or np.any(np.abs(lv) > 1.0):
            raise ValueError(f"GpioBackend.set_levels needs {self.n} finite levels in [-1, 1], got {lv!r}")
        for m, v in zip(self.motors, lv):
            m.value = float(v)
            if getattr(m, "enable_device", None) is not None and not m.enable_device.value:
                m.enable_device.on()
        self.levels = lv.copy()

    def off(self) -> None:
        """Both inputs of every channel low (and EN low where wired); never raises."""
        for m in self.motors:
            for dev_name in ("forward_device", "backward_device", "enable_device"):
                dev = getattr(m, dev_name, None)
                if dev is None:
                    continue
                try:
                    dev.off()
                except Exception:  # noqa: BLE001 - keep switching the others off
                    pass
        self.levels = np.zeros(self.n)

    def close(self) -> None:
        self.off()
        for m in self.motors:
            try:
                m.close()
            except Exception:  # noqa: BLE001
                pass
        self.motors = []

    def pin_states(self) -> list[dict]:
        """Per coil: GPIO numbers and the present value of forward, backward (duty) and enable."""
        out = []
        for c, m in zip(self.channels, self.motors):
            en = getattr(m, "enable_device", None)
            out.append({"whisker": c.whisker, "forward": c.forward, "backward": c.backward,
                        "forward_value": float(m.forward_device.value),
                        "backward_value": float(m.backward_device.value),
                        "enable": c.enable, "enable_value": None if en is None else int(en.value)})
        return out


class Pca9685Backend:
    """Coils on PCA9685 16-channel I2C PWM expanders (``wiring.expander = "pca9685"``, the pin map's
    answer beyond 11 coils): per coil two channels (the L298N's IN1/IN2), duty on ``forward`` for a
    positive level, on ``backward`` for a negative one, the other channel fully off.

    Registers (NXP PCA9685 datasheet, section 7.3): MODE1 0x00 (bit 4 SLEEP, bit 5 AI auto-increment,
    bit 7 RESTART), MODE2 0x01 (bit 2 OUTDRV totem pole), LEDn_ON_L = 0x06 + 4 n (ON_L, ON_H, OFF_L,
    OFF_H; bit 4 of ON_H = full on, bit 4 of OFF_H = full off, which wins), ALL_LED_OFF_H 0xFD,
    PRE_SCALE 0xFE = round(25 MHz / (4096 f)) - 1, writable only in SLEEP (f = 24..1526 Hz).

    bus: an SMBus-like object (``write_byte_data``, ``read_byte_data``, ``write_i2c_block_data``);
    default ``smbus2.SMBus(1)`` (I2C1 on GPIO 2/3; ``pip install smbus2``), or :class:`MockI2CBus`.
    """

    MODE1, MODE2, LED0_ON_L, ALL_LED_OFF_H, PRE_SCALE = 0x00, 0x01, 0x06, 0xFD, 0xFE
    OSC_HZ = 25_000_000
    FULL = 0x10  # bit 4 of LEDn_ON_H / LEDn_OFF_H

    def __init__(self, design, *, bus=None, channels: Optional[Sequence] = None, sleep=time.sleep):
        self.n = design.whiskers.count
        if channels is None:
            from whisker.pins import pin_map

            channels = pin_map(design)
        channels = sorted(channels, key=lambda c: c.whisker)
        if [c.whisker for c in channels] != list(range(self.n)) or any(c.bus != "pca9685" for c in channels):
            raise ValueError(f"Pca9685Backend needs one pca9685 channel pair per whisker 0..{self.n - 1}")
        self.channels = channels
        f = float(design.drive.pwm_frequency)
        self.prescale = round(self.OSC_HZ / (4096.0 * f)) - 1
        if not 3 <= self.prescale <= 255:
            raise ValueError(f"drive.pwm_frequency={f:g} Hz is outside the PCA9685's 24..1526 Hz")
        if bus is None:
            try:
                from smbus2 import SMBus
            except ImportError as err:
                raise RuntimeError("the PCA9685 backend needs smbus2 (pip install smbus2)") from err
            bus = SMBus(1)
        self.bus = bus
        self.addresses = sorted({c.address for c in channels})
        for a in self.addresses:
            self.bus.write_byte_data(a, self.ALL_LED_OFF_H, self.FULL)     # every output off first
            self.bus.write_byte_data(a, self.MODE1, 0x10)                   # sleep, to set the prescaler
            self.bus.write_byte_data(a, self.PRE_SCALE, self.prescale)
            self.bus.write_byte_data(a, self.MODE2, 0x04)                   # totem-pole outputs
            self.bus.write_byte_data(a, self.MODE1, 0x20)                   # wake, auto-increment
        sleep(0.0005)  # oscillator start-up, 500 us (datasheet)
        self.levels = np.zeros(self.n)

    def _duty(self, address: int, channel: int, duty: float) -> None:
        if duty <= 0.0:
            regs = [0, 0, 0, self.FULL]
        elif duty >= 1.0:
            regs = [0, self.FULL, 0, 0]
        else:
            off = min(4095, max(1, int(round(duty * 4096))))
            regs = [0, 0, off & 0xFF, off >> 8]
        self.bus.write_i2c_block_data(address, self.LED0_ON_L + 4 * channel, regs)

    def set_levels(self, levels) -> None:
        lv = np.asarray(levels, dtype=float)
        if lv.shape != (self.n,) or not np.all(np.isfinite(lv)) or np.any(np.abs(lv) > 1.0):
            raise ValueError(f"Pca9685Backend.set_levels needs {self.n} finite levels in [-1, 1], got {lv!r}")
        for c, v in zip(self.channels, lv):
            on, off = (c.forward, c.backward) if v >= 0 else (c.backward, c.forward)
            self._duty(c.address, off, 0.0)  # the other input off first: never both driven
            self._duty(c.address, on, abs(float(v)))
        self.levels = lv.copy()

    def off(self) -> None:
        """Every output of every board fully off (one ALL_LED_OFF_H write per board); never raises."""
        for a in self.addresses:
            try:
                self.bus.write_byte_data(a, self.ALL_LED_OFF_H, self.FULL)
            except Exception:  # noqa: BLE001 - keep switching the other boards off
                pass
        self.levels = np.zeros(self.n)

    def close(self) -> None:
        self.off()
        close = getattr(self.bus, "close", None)
        if close is not None:
            try:
                close()
            except Exception:  # noqa: BLE001
                pass

    def pin_states(self) -> list[dict]:
        """Per coil: the expander channels and their duty read back from the registers."""
        out = []
        for c in self.channels:
            out.append({"whisker": c.whisker, "forward": c.forward, "backward": c.backward,
                        "forward_value": self.read_duty(c.address, c.forward),
                        "backward_value": self.read_duty(c.address, c.backward),
                        "enable": None, "enable_value": None, "address": c.address})
        return out

    def read_duty(self, address: int, channel: int) -> float:
        """Duty of one channel read back from its LEDn registers (full off wins over full on)."""
        base = self.LED0_ON_L + 4 * channel
        on_l, on_h, off_l, off_h = (self.bus.read_byte_data(address, base + k) for k in range(4))
        if off_h & self.FULL:
            return 0.0
        if on_h & self.FULL:
            return 1.0
        return (((off_h & 0x0F) << 8 | off_l) - ((on_h & 0x0F) << 8 | on_l)) % 4096 / 4096.0


class MockI2CBus:
    """A register file per I2C address standing in for PCA9685 boards (dry runs and tests).

    A write to ALL_LED_ON_L..ALL_LED_OFF_H loads that register of all 16 channels, as the chip does;
    a block write needs MODE1's AI bit; PRE_SCALE only takes in SLEEP. ``writes`` logs
    (address, register, value).
    """

    def __init__(self):
        self.regs: dict[int, bytearray] = {}
        self.writes: list[tuple[int, int, int]] = []

    def _file(self, address: int) -> bytearray:
        if address not in self.regs:
            f = bytearray(256)
            f[0x00] = 0x11  # MODE1 power-on: SLEEP + ALLCALL
            f[0x01] = 0x04
            for ch in range(16):
                f[0x06 + 4 * ch + 3] = 0x10  # LEDn full off at power-on
            self.regs[address] = f
        return self.regs[address]

    def write_byte_data(self, address: int, register: int, value: int) -> None:
        f = self._file(address)
        if register == Pca9685Backend.PRE_SCALE and not f[0x00] & 0x10:
            raise OSError("PCA9685: PRE_SCALE written outside SLEEP is ignored by the chip")
        self.writes.append((address, register, value & 0xFF))
        if 0xFA <= register <= 0xFD:  # ALL_LED_*: loads that register of every channel, reads back 0
            for ch in range(16):
                f[0x06 + 4 * ch + register - 0xFA] = value & 0xFF
            return
        f[register] = value & 0xFF

    def write_i2c_block_data(self, address: int, register: int, data) -> None:
        f = self._file(address)
        if len(data) > 1 and not f[0x00] & 0x20:
            raise OSError("PCA9685: block write without MODE1 auto-increment")
        for k, v in enumerate(data):
            self.write_byte_data(address, register + k, v)

    def read_byte_data(self, address: int, register: int) -> int:
        return self._file(address)[register]


def mock_backend(design, *, pin_class=None, channels=None) -> GpioBackend:
    """A :class:`GpioBackend` on gpiozero's ``MockFactory`` (PWM-capable mock pins): for tests and
    for dry runs without a Raspberry Pi. The factory is at ``backend.factory``."""
    from gpiozero.pins.mock import MockFactory, MockPWMPin

    if channels is None and design.wiring.expander == "pca9685":
        return Pca9685Backend(design, bus=MockI2CBus(), sleep=lambda s: None)
    factory = MockFactory(pin_class=pin_class or MockPWMPin)
    backend = GpioBackend(design, pin_factory=factory, channels=channels)
    backend.factory = factory
    return backend


BACKENDS = ("mock", "gpio", "sim")


def open_backend(name: str, design):
    """Backend by name: "mock" (gpiozero mock pins), "gpio" (real pins), "sim" (the simulator)."""
    if name == "mock":
        return mock_backend(design)
    if name == "gpio" and design.wiring.expander == "pca9685":
        return Pca9685Backend(design)
    if name == "gpio":
        from gpiozero.exc import BadPinFactory, GPIOZeroError

        import warnings

        try:
            with warnings.catch_warnings():  # gpiozero warns once per pin library it cannot load
                warnings.simplefilter("ignore")
                return GpioBackend(design)
        except BadPinFactory as err:
            raise RuntimeError(
                f"no GPIO pins on this machine (gpiozero: {err}); on a Raspberry Pi install lgpio "
                "(sudo apt install python3-lgpio), elsewhere use --backend mock or sim") from None
        except GPIOZeroError as err:
            raise RuntimeError(f"gpiozero could not open the coil pins: {err}") from None
    if name == "sim":
        try:
            from whisker.sim import actuation_backend
        except ImportError as err:
            raise RuntimeError("the simulator backend needs whisker.sim.actuation_backend, "
                               f"which is not available ({err})") from err
        return actuation_backend(design)
    raise ValueError(f"backend must be one of {BACKENDS}, got {name!r}")


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

    guard: a :class:`whisker.guard.ThermalGuard` (default: one on the design's coil model), or
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

    def _masked(self, which, level: float, start: int = 0) -> np.ndarray:
        mask = configuration(self.n, which, start)
        return np.where(mask, float(level), 0.0)

    def retract(self, level: Optional[float] = None, which="all", start: int = 0) -> np.ndarray:
        """Tips toward the centre on the whiskers of configuration `which` (others neutral).

        level: duty in (0, 1]; default = actuation.voltage (3 V) / full-scale voltage.
        """
        level = self.default_level() if level is None else float(level)
        if level < 0:
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
# timed sequences
# ---------------------------------------------------------------------------------------------

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
