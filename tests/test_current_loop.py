"""The HAT's current loop (whisker.drive.current_loop): INA3221 register decoding and the duty trim
holding the coil current while the coil warms from 25 to 60 C."""

from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from whisker import coil
from whisker.coil import board
from whisker.design import default_design
from whisker.drive.current_loop import CurrentLoop, ina3221_shunt_V


def test_ina3221_decoding():
    assert ina3221_shunt_V(0x0000) == 0.0
    assert ina3221_shunt_V(0x0008) == pytest.approx(40e-6)
    assert ina3221_shunt_V(0x7FF8) == pytest.approx(4095 * 40e-6)   # +163.8 mV full scale
    assert ina3221_shunt_V(0xFFF8) == pytest.approx(-40e-6)
    with pytest.raises(ValueError):
        ina3221_shunt_V(0x10000)


@given(st.integers(0, 0xFFFF))
def test_ina3221_range(word):
    assert abs(ina3221_shunt_V(word)) <= 4096 * 40e-6


def test_loop_holds_the_current_as_the_coil_warms():
    d = default_design('driver.type="HAT"')
    i_fs = board.full_scale_current_A(d)
    loop = CurrentLoop(i_fs)
    target = 3.0 / d.coil.resistance
    vs = d.driver.supply_voltage
    drop = 0.36 * 0.5 + 0.24 * 0.5
    out = []
    for step in range(200):
        t = 25.0 + 35.0 * min(1.0, step / 120)            # the coil warms 25 -> 60 C
        i_on = (vs - drop) / coil.resistance_ohm(d, t)
        measured = loop.duty * i_on
        loop.update(target, measured)
        out.append((t, loop.duty * i_on))
    settled = [i for t, i in out[20:]]
    assert max(abs(i / target - 1) for i in settled) < 0.01  # within 1 % while the copper gains 14 %
    assert out[-1][0] == 60.0


def test_loop_refuses_bad_input():
    loop = CurrentLoop(0.5)
    with pytest.raises(ValueError, match="finite"):
        loop.update(float("nan"), 0.0)
    with pytest.raises(ValueError, match="above the full scale"):
        loop.update(0.6, 0.0)
