"""The HAT's per-coil current loop: read each coil's current from its INA3221 channel, trim the PWM duty.

The DRV8833 sets a voltage (duty x supply); the coil's current then moves with its temperature
(+0.39 %/K copper) and the bridge's drop. Here the level asks for a current, level x I_fs
(whisker.coil.board.full_scale_current_A), and an integral controller moves the duty until the
measured mean current matches it, so the force (linear in the current) no longer depends on the coil's
temperature; what is left is the INA3221's error (gain 0.25 %, offset 80 uV, both maximum) and the
sense resistor's 1 % (whisker.coil.board.current_error).

INA3221 (TI SBOS576): shunt-voltage registers 0x01/0x03/0x05 for channels 1..3, a 16-bit two's
complement word whose upper 13 bits count 40 uV (the low 3 bits are zero).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

INA3221_SHUNT_REG = (0x01, 0x03, 0x05)
INA3221_LSB_V = 40e-6


def ina3221_shunt_V(word: int) -> float:
    """Shunt voltage from one INA3221 shunt register word (16 bits, big-endian as read), V."""
    if not 0 <= int(word) <= 0xFFFF:
        raise ValueError(f"an INA3221 register is 16 bits (got {word!r})")
    w = int(word)
    if w & 0x8000:
        w -= 0x10000
    return (w >> 3) * INA3221_LSB_V


@dataclass
class CurrentLoop:
    """Integral control of one coil's duty: duty += gain x (target - measured) / I_fs per update.

    gain 0.5 per update settles a proportional plant (measured = duty x I_on) in a few updates
    without overshoot for any I_on between I_fs and 2 I_fs (the coil's current at full duty).
    """

    full_scale_A: float
    gain: float = 0.5
    duty: float = 0.0
    history: list = field(default_factory=list)

    def update(self, target_A: float, measured_A: float) -> float:
        if not (math.isfinite(target_A) and math.isfinite(measured_A)):
            raise ValueError(f"current loop needs finite currents (target {target_A!r}, measured {measured_A!r})")
        if abs(target_A) > self.full_scale_A * (1 + 1e-9):
            raise ValueError(f"target {target_A:.3g} A is above the full scale {self.full_scale_A:.3g} A")
        self.duty += self.gain * (target_A - measured_A) / self.full_scale_A
        self.duty = min(1.0, max(-1.0, self.duty))
        self.history.append((target_A, measured_A, self.duty))
        return self.duty
