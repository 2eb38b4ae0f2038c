"""The one pin map: which Raspberry Pi GPIO (or PWM-expander channel) drives which coil.

Every consumer (the actuation backends, the BOM, the netlist in ``hw/pcb``, the pinout table and the
wiring diagram) calls :func:`pin_map`; no pin number is typed anywhere else.

Drive scheme (documented in docs/wiring.md)
-------------------------------------------
Each coil sits on one channel of an L298N dual H-bridge module (channel A = IN1/IN2/ENA/OUT1-2,
channel B = IN3/IN4/ENB/OUT3-4), so ``modules = ceil(N / 2)``. Three GPIO per coil (IN1, IN2, EN) would
need 24 pins for 8 coils, more than a Pi 4B has free. Instead the module's EN jumper stays fitted
(EN tied to its +5 V logic rail) and the two direction inputs are driven with PWM: forward = duty on
IN1 with IN2 low, backward = duty on IN2 with IN1 low, both low = coast. This is exactly gpiozero's
``Motor(forward, backward, enable=None, pwm=True)``; signed duty in [-1, 1] per coil, independently.
So each coil needs 2 GPIO and ``enable`` is ``None`` (jumpered).

The L298's logic inputs switch at V_IH >= 2.3 V (ST L298 datasheet, "Input High Voltage"), so the
Pi's 3.3 V outputs drive them directly; the module's 5 V logic is never fed back to the Pi.

Pins kept free (BCM numbering, pinout.xyz):
  GPIO 0/1  ID EEPROM (HAT identification) - outside 2..27 anyway;
  GPIO 2/3  I2C1 (SDA/SCL): sensors, and the PCA9685 expander below;
  GPIO 14/15 UART (serial console).
The camera uses the CSI connector, not GPIO. That leaves 22 usable GPIO = 11 coils. The SPI0 pins
(GPIO 7-11) are handed out last, so designs up to 8 coils leave SPI free too.

Beyond 11 coils the Pi cannot serve the coils directly: :func:`pin_map` raises :class:`PinMapError`
naming the alternative, a PCA9685 16-channel I2C PWM expander (``--set wiring.expander="pca9685"``):
two expander channels per coil (IN1, IN2), 8 coils per PCA9685 board, boards on I2C1 at addresses
``wiring.pca9685_address + k``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional

#: BCM GPIO number -> physical pin on the 40-pin header (Raspberry Pi 4B; pinout.xyz).
HEADER_PIN: dict[int, int] = {
    2: 3, 3: 5, 4: 7, 14: 8, 15: 10, 17: 11, 18: 12, 27: 13, 22: 15, 23: 16, 24: 18, 10: 19,
    9: 21, 25: 22, 11: 23, 8: 24, 7: 26, 0: 27, 1: 28, 5: 29, 6: 31, 12: 32, 13: 33, 19: 35,
    16: 36, 26: 37, 20: 38, 21: 40,
}
#: Physical header pins that are power rails (not GPIO).
HEADER_POWER: dict[int, str] = {1: "3V3", 17: "3V3", 2: "5V", 4: "5V",
                                6: "GND", 9: "GND", 14: "GND", 20: "GND", 25: "GND", 30: "GND",
                                34: "GND", 39: "GND"}

#: GPIO a user may drive on a Pi 4B header (BCM 2..27).
GPIO_RANGE = range(2, 28)
#: GPIO the coils must not take, with the reason (shown in the pinout table and the docs).
RESERVED: dict[int, str] = {0: "ID EEPROM (ID_SD)", 1: "ID EEPROM (ID_SC)",
                            2: "I2C1 SDA", 3: "I2C1 SCL", 14: "UART TXD", 15: "UART RXD"}
#: SPI0 pins: usable, but handed out last so that small designs keep SPI free.
SPI0 = (10, 9, 11, 8, 7)

#: PCA9685: 16 PWM channels per board, 7-bit I2C addresses 0x40..0x7F (NXP PCA9685 datasheet, 7.1),
#: 0x70 is its All-Call address by default, so we use at most 0x40..0x6F.
PCA9685_CHANNELS = 16
PCA9685_MAX_BOARDS = 0x70 - 0x40

#: L298N module terminal names for channel A / B: (forward input, backward input, enable, outputs).
L298N_TERMINALS = {"A": ("IN1", "IN2", "ENA", ("OUT1", "OUT2")),
                   "B": ("IN3", "IN4", "ENB", ("OUT3", "OUT4"))}


#: The Pi's GPIO (and a PCA9685 on the Pi's 3V3) drive a logic high of about 3.3 V.
LOGIC_HIGH_V = 3.3
#: ST L298 datasheet, electrical characteristics: VS (power supply) operative minimum = V_IH + 2.5 V;
#: VSS (logic supply) 4.5..7 V. L298N modules make VSS with a 78M05 from VS when their 5V-EN jumper
#: is fitted, which needs roughly VS >= 7 V.
L298_VS_ABOVE_VIH = 2.5
L298_VSS_RANGE = (4.5, 7.0)

#: The LED strip (a 5 V 3528 strip) runs from the Pi's 5 V header rail, whatever the coil supply: a
#: 7.5 V coil supply would overdrive it. (+, -) physical header pins; pin 6 (GND) carries the common
#: ground to the coil supply. The strip draws ~0.1 A (100 mm of a 4.8 W/m strip), well within what
#: a 3 A Pi supply leaves on the 5 V rail.
LED_HEADER_PINS = (4, 9)


def supply_warnings(design) -> list[str]:
    """Electrical cautions about the driver supply for this wiring (one line each, [] when none)."""
    if design.driver.type.upper() != "L298N":
        return []
    vs = design.driver.supply_voltage
    out = []
    vs_min = LOGIC_HIGH_V + L298_VS_ABOVE_VIH
    if vs < vs_min:
        out.append(f"driver.supply_voltage = {vs:g} V is below the L298's operating minimum VS >= V_IH + "
                   f"{L298_VS_ABOVE_VIH:g} V = {vs_min:g} V with {LOGIC_HIGH_V:g} V inputs (ST L298 "
                   "datasheet); modules often still switch, but the default 7.5 V (5V-EN jumper fitted) is within it")
    if vs < L298_VSS_RANGE[0]:
        out.append(f"driver.supply_voltage = {vs:g} V is below the L298's logic supply minimum "
                   f"{L298_VSS_RANGE[0]:g} V: feed the modules' +5V terminals from a separate 5 V supply")
    return out


def module_makes_own_logic_supply(design) -> bool:
    """True when the supply exceeds the L298's logic range: keep the module's 5V-EN jumper fitted (its
    regulator makes +5 V) instead of feeding the supply into the +5V terminal."""
    return design.driver.supply_voltage > L298_VSS_RANGE[1]


class PinMapError(ValueError):
    """The controller cannot serve this many coils with the chosen scheme (one-line message)."""


@dataclass(frozen=True)
class CoilChannel:
    """Where coil `whisker` is wired.

    forward / backward: BCM GPIO numbers (``bus == "gpio"``) or PCA9685 channel numbers 0..15
    (``bus == "pca9685"``, board at I2C ``address``). Duty on `forward` drives a positive level
    (retraction, tip toward the centre) once the coil's leads are polarised as docs/wiring.md says.
    enable: GPIO of the channel's EN input, or None when EN is jumpered high on the module (the
    scheme used here). module: L298N module index (0-based); channel: "A" or "B" on that module.
    """

    whisker: int
    forward: int
    backward: int
    enable: Optional[int]
    module: int
    channel: str
    bus: str = "gpio"
    address: Optional[int] = None

    @property
    def terminals(self) -> tuple[str, str, str, tuple[str, str]]:
        """L298N terminal names (IN fwd, IN bwd, EN, (OUT a, OUT b)) of this channel."""
        return L298N_TERMINALS[self.channel]

    def as_dict(self) -> dict:
        return asdict(self)


def free_gpio() -> list[int]:
    """GPIO available for coils, in the order they are handed out (BCM numbers).

    Header order (so neighbouring coils use neighbouring header pins), non-SPI pins first.
    """
    usable = [g for g in GPIO_RANGE if g not in RESERVED]
    by_header = sorted(usable, key=lambda g: HEADER_PIN[g])
    return [g for g in by_header if g not in SPI0] + [g for g in by_header if g in SPI0]


def max_direct_coils() -> int:
    """Largest coil count the Pi serves directly at 2 GPIO per coil (11 on a Pi 4B)."""
    return len(free_gpio()) // 2


def modules_needed(n_coils: int) -> int:
    """L298N modules for `n_coils` (two channels each): ceil(N / 2)."""
    if n_coils < 0:
        raise ValueError(f"coil count must be >= 0, got {n_coils}")
    return math.ceil(n_coils / 2)


def expander_boards_needed(n_coils: int) -> int:
    """PCA9685 boards for `n_coils` at two channels per coil: ceil(2 N / 16)."""
    return math.ceil(2 * n_coils / PCA9685_CHANNELS)


def _scheme(design) -> tuple[str, int]:
    wiring = getattr(design, "wiring", None)
    if wiring is None:  # a design model without a [wiring] section: direct GPIO
        return "none", 0x40
    return wiring.expander, wiring.pca9685_address


def pin_map(design) -> list[CoilChannel]:
    """One :class:`CoilChannel` per whisker, index i = whisker i (design.whisker_angles_deg order).

    Coil i uses L298N module i // 2, channel "A" for even i and "B" for odd i, unless the design's
    [wiring] coil_order / coil_polarity override (from `whisker calibrate wiring`) re-routes a whisker
    to another channel or exchanges its pins (see :func:`apply_override`). Raises
    :class:`PinMapError` when the Pi (or the expander address space) cannot serve N coils.
    """
    n = design.whiskers.count
    expander, address0 = _scheme(design)
    if expander == "none":
        pins = free_gpio()
        if 2 * n > len(pins):
            raise PinMapError(
                f"{n} coils need {2 * n} GPIO (IN1+IN2 per coil, EN jumpered) but a Raspberry Pi 4B "
                f"has only {len(pins)} free (GPIO 2..27 minus I2C 2/3 and UART 14/15): at most "
                f"{len(pins) // 2} coils; use a PCA9685 16-channel I2C PWM expander on GPIO 2/3 "
                f"(--set wiring.expander=\"pca9685\", {expander_boards_needed(n)} board(s))")
        return apply_override(design, [CoilChannel(whisker=i, forward=pins[2 * i], backward=pins[2 * i + 1],
                                                    enable=None, module=i // 2, channel="AB"[i % 2])
                                       for i in range(n)])
    if expander == "pca9685":
        boards = expander_boards_needed(n)
        last = address0 + boards - 1
        if last >= 0x40 + PCA9685_MAX_BOARDS or address0 < 0x40:
            raise PinMapError(
                f"{n} coils need {boards} PCA9685 boards at I2C 0x{address0:02X}..0x{last:02X}, "
                f"beyond 0x40..0x6F; lower wiring.pca9685_address or add a TCA9548A I2C multiplexer")
        per_board = PCA9685_CHANNELS // 2
        return apply_override(design, [CoilChannel(whisker=i, forward=2 * (i % per_board),
                                                    backward=2 * (i % per_board) + 1, enable=None,
                                                    module=i // 2, channel="AB"[i % 2], bus="pca9685",
                                                    address=address0 + i // per_board) for i in range(n)])
    raise PinMapError(f"wiring.expander must be \"none\" or \"pca9685\", got {expander!r}")


def _override(design) -> tuple[list[int], list[int]] | None:
    """(order, polarity) of the design's pin-map override ([wiring] coil_order / coil_polarity, written
    by `whisker calibrate wiring`), or None when there is none. One-line PinMapError when malformed."""
    wiring = getattr(design, "wiring", None)
    order = list(getattr(wiring, "coil_order", ()) or ())
    pol = list(getattr(wiring, "coil_polarity", ()) or ())
    if not order and not pol:
        return None
    n = design.whiskers.count
    order = order or list(range(n))
    pol = pol or [1] * n
    if sorted(order) != list(range(n)):
        raise PinMapError(f"wiring.coil_order must be a permutation of 0..{n - 1} (one channel per whisker), got {order}")
    if len(pol) != n or any(p not in (1, -1) for p in pol):
        raise PinMapError(f"wiring.coil_polarity must be {n} values of +1 or -1, got {pol}")
    return order, pol


def apply_override(design, channels: list[CoilChannel]) -> list[CoilChannel]:
    """The pin map with the design's override: whisker i takes channel coil_order[i]'s pins, forward and
    backward exchanged where coil_polarity[i] = -1 (so a positive level still retracts whisker i)."""
    ov = _override(design)
    if ov is None:
        return channels
    order, pol = ov
    out = []
    for i, (j, p) in enumerate(zip(order, pol)):
        c = channels[j]
        fwd, bwd = (c.forward, c.backward) if p > 0 else (c.backward, c.forward)
        out.append(CoilChannel(whisker=i, forward=fwd, backward=bwd, enable=c.enable, module=c.module,
                               channel=c.channel, bus=c.bus, address=c.address))
    return out


def used_gpio(design) -> dict[int, str]:
    """Every GPIO the design's wiring uses, with its role (coil pins, and I2C when an expander is used)."""
    used: dict[int, str] = {}
    for ch in pin_map(design):
        if ch.bus == "gpio":
            used[ch.forward] = f"coil {ch.whisker} forward"
            used[ch.backward] = f"coil {ch.whisker} backward"
            if ch.enable is not None:
                used[ch.enable] = f"coil {ch.whisker} enable"
        else:
            used[2] = "I2C1 SDA (PCA9685)"
            used[3] = "I2C1 SCL (PCA9685)"
    return used
