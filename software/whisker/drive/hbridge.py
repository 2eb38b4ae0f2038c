"""H-bridge backends: what turns a vector of coil levels into pins (gpiozero on the Pi or its mock
pins, a PCA9685 expander over I2C, or the simulator), no safety of their own: the
:class:`whisker.drive.actuation.Actuator` in front of them checks ratings and heat.

Backend protocol (the contract with the simulator, issue 8): any object with

    set_levels(levels: np.ndarray shape (N,), values in [-1, 1]) -> None
    off() -> None            # every coil without current; must not raise

and optionally ``close()``. Backends here: :class:`GpioBackend` on gpiozero (real pins through
gpiozero's default pin factory on a Raspberry Pi, or ``gpiozero.pins.mock.MockFactory`` for tests,
see :func:`mock_backend`), and the simulator's backend through :func:`open_backend` ("sim").

Wiring (from :func:`whisker.drive.pins.pin_map`, the one pin map): coil i is one L298N channel, its two
inputs IN1/IN2 on GPIO ``forward``/``backward``. Each coil is a gpiozero ``Motor(forward, backward,
enable=..., pwm=True)``: a positive level is PWM duty on ``forward`` with ``backward`` low, a negative
level duty on ``backward`` with ``forward`` low (gpiozero switches the other input off *before*
raising the new one, so both inputs are never high together), 0 = both low. If the pin map gives
an ``enable`` GPIO it is held high while the actuator is open and driven low by :meth:`off`.
"""

from __future__ import annotations

import time
from typing import Optional, Protocol, Sequence

import numpy as np

__all__ = ["Backend", "GpioBackend", "Pca9685Backend", "MockI2CBus", "mock_backend", "open_backend", "BACKENDS"]


class Backend(Protocol):
    """What an actuation backend provides (see the module docstring)."""

    def set_levels(self, levels: np.ndarray) -> None: ...

    def off(self) -> None: ...


# ---------------------------------------------------------------------------------------------
# backends
# ---------------------------------------------------------------------------------------------

class GpioBackend:
    """One gpiozero ``Motor`` per coil on the pins of :func:`whisker.drive.pins.pin_map`.

    pin_factory: None = gpiozero's default (the real pins on a Raspberry Pi), or a factory such as
    ``MockFactory(pin_class=MockPWMPin)``. channels: override the pin map (objects with whisker,
    forward, backward, enable, bus), e.g. for a test bench.
    """

    def __init__(self, design, *, pin_factory=None, channels: Optional[Sequence] = None):
        from gpiozero import Motor

        self.n = design.whiskers.count
        if channels is None:
            from whisker.drive.pins import pin_map

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
            from whisker.drive.pins import pin_map

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
            from whisker.drive.simulated import actuation_backend
        except ImportError as err:
            raise RuntimeError("the simulator backend needs whisker.sim.actuation_backend, "
                               f"which is not available ({err})") from err
        return actuation_backend(design)
    raise ValueError(f"backend must be one of {BACKENDS}, got {name!r}")
