"""The single pin map (whisker.drive.pins): reserved pins stay free, no pin is used twice, and a coil
count the Pi cannot serve is refused with a message that names the alternative."""

import pytest
from hypothesis import given, settings, strategies as st

from whisker.design import DesignError, default_design
from whisker.drive.pins import (HEADER_PIN, RESERVED, PinMapError, free_gpio, max_direct_coils,
                          modules_needed, pin_map, used_gpio)


def _design(n, *extra):
    return default_design(f"whiskers.count={n}", *extra)


def test_free_gpio_excludes_reserved_and_is_in_range():
    pins = free_gpio()
    assert len(pins) == len(set(pins)) == 22
    assert not set(pins) & {0, 1, 2, 3, 14, 15}
    assert all(2 <= g <= 27 and g in HEADER_PIN for g in pins)
    assert max_direct_coils() == 11


def test_default_design_map():
    chans = pin_map(default_design())
    assert [c.whisker for c in chans] == list(range(8))
    assert [c.module for c in chans] == [0, 0, 1, 1, 2, 2, 3, 3]
    assert [c.channel for c in chans] == list("ABABABAB")
    assert all(c.enable is None and c.bus == "gpio" for c in chans)
    # 8 coils leave SPI0 (GPIO 7..11) free as well as I2C and UART.
    assert not set(used_gpio(default_design())) & {7, 8, 9, 10, 11, *RESERVED}


@settings(max_examples=25, deadline=None)
@given(st.integers(min_value=1, max_value=11))
def test_direct_map_is_injective_and_avoids_reserved(n):
    chans = pin_map(_design(n))
    pins = [p for c in chans for p in (c.forward, c.backward)]
    assert len(pins) == len(set(pins)) == 2 * n
    assert not set(pins) & set(RESERVED)
    assert max(c.module for c in chans) + 1 == modules_needed(n)


def test_six_and_twelve_are_consistent_prefixes():
    six = pin_map(_design(6))
    twelve = pin_map(_design(12, 'wiring.expander="pca9685"'))
    # The first channels of the 6-coil map are the 8-coil map's first six: adding coils never moves one.
    assert six == pin_map(_design(8))[:6]
    assert len(twelve) == 12 and {c.address for c in twelve} == {0x40, 0x41}
    per_board = {}
    for c in twelve:
        per_board.setdefault(c.address, []).extend([c.forward, c.backward])
    assert all(sorted(v) == list(range(len(v))) for v in per_board.values())
    assert sorted(per_board[0x40]) == list(range(16))
    assert set(used_gpio(_design(12, 'wiring.expander="pca9685"'))) == {2, 3}


@pytest.mark.parametrize("n", [12, 16, 64])
def test_too_many_coils_is_refused_naming_the_expander(n):
    with pytest.raises(PinMapError) as err:
        pin_map(_design(n))
    msg = str(err.value)
    assert "\n" not in msg and f"{n} coils" in msg and "PCA9685" in msg and "at most 11" in msg


def test_expander_address_space_is_checked():
    with pytest.raises(PinMapError, match="0x40..0x6F"):
        pin_map(_design(64, 'wiring.expander="pca9685"', "wiring.pca9685_address=0x6E"))
    with pytest.raises(DesignError):
        _design(8, 'wiring.expander="mcp23017"')


def test_modules_needed():
    assert [modules_needed(n) for n in (0, 1, 2, 3, 8, 12)] == [0, 1, 1, 2, 4, 6]
    with pytest.raises(ValueError):
        modules_needed(-1)


def test_supply_warnings_follow_the_l298_datasheet():
    from whisker.drive.pins import module_makes_own_logic_supply, supply_warnings

    assert default_design().driver.supply_voltage == 7.5
    assert supply_warnings(default_design()) == []  # the default 7.5 V is within the datasheet
    assert module_makes_own_logic_supply(default_design())  # > 7 V: the module's 78M05 makes VSS
    w5 = supply_warnings(default_design("driver.supply_voltage=5"))  # 5 V < 3.3 V + 2.5 V
    assert len(w5) == 1 and "5.8 V" in w5[0] and "\n" not in w5[0] and "default 7.5 V" in w5[0]
    assert supply_warnings(default_design("driver.supply_voltage=6.5")) == []
    low = supply_warnings(default_design("driver.supply_voltage=4.0"))
    assert len(low) == 2 and "separate 5 V" in low[1]
    assert supply_warnings(default_design('driver.type="TB6612FNG"')) == []
    assert not module_makes_own_logic_supply(default_design("driver.supply_voltage=7.0"))
    assert module_makes_own_logic_supply(default_design("driver.supply_voltage=7.5"))


def test_header_table_is_complete_and_consistent():
    from whisker.drive.pins import HEADER_POWER

    assert sorted(HEADER_PIN) == list(range(28))  # BCM 0..27
    phys = sorted([*HEADER_PIN.values(), *HEADER_POWER])
    assert phys == list(range(1, 41))  # every header pin exactly once
    assert [p for p, k in HEADER_POWER.items() if k == "GND"] == [6, 9, 14, 20, 25, 30, 34, 39]
    assert (HEADER_PIN[2], HEADER_PIN[3], HEADER_PIN[14], HEADER_PIN[15]) == (3, 5, 8, 10)


@settings(max_examples=40, deadline=None)
@given(vs=st.floats(0.5, 46.0))
def test_supply_warnings_at_any_supply(vs):
    """L298N: a caution below VS_min = 3.3 V + 2.5 V = 5.8 V, a second one below VSS_min = 4.5 V, none
    from 5.8 V up; the module makes its own logic supply above VSS_max = 7 V."""
    from whisker.drive.pins import module_makes_own_logic_supply, supply_warnings

    d = default_design(f"driver.supply_voltage={vs!r}")
    w = supply_warnings(d)
    assert len(w) == (vs < 5.8) + (vs < 4.5)
    assert all("\n" not in x and "ST L298 datasheet" in w[0] for x in w)
    assert module_makes_own_logic_supply(d) == (vs > 7.0)
