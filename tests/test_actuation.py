"""Actuation on gpiozero mock pins: the exact pin states of every command and configuration."""

from __future__ import annotations

import numpy as np
import pytest
from gpiozero.pins.mock import MockFactory, MockPWMPin
from hypothesis import given, settings
from hypothesis import strategies as st

from test_actuation_doubles import FakeClock, coil_model
from whisker.drive.actuation import Actuator, configuration
from whisker.drive.hbridge import GpioBackend, mock_backend
from whisker.drive.sequences import SequenceRunner, Step, grasp_sequence, run_sequence
from whisker.design import default_design
from whisker.drive.guard import RatingError, ThermalGuard, full_scale_voltage
from whisker.drive.pins import CoilChannel, pin_map


@pytest.fixture(scope="module")
def design():
    return default_design()


def make(design, backend=None, clock=None, **guard_kw):
    clock = clock or FakeClock()
    thermal, current = coil_model(design)
    guard = ThermalGuard(design, thermal=thermal, current_fn=current, clock=clock, **guard_kw)
    backend = backend or mock_backend(design)
    return Actuator(design, backend, guard=guard, watchdog=False, clock=clock, current_fn=current), backend, clock


def pin_values(backend, channels):
    """(forward, backward, enable or None) state of every coil's mock pins, read from the factory."""
    f = backend.factory
    out = []
    for c in channels:
        en = None if c.enable is None else f.pin(c.enable).state
        out.append((float(f.pin(c.forward).state), float(f.pin(c.backward).state), en))
    return out


def expected(levels, enable_wired=False):
    return [(max(v, 0.0), max(-v, 0.0), (True if enable_wired else None)) for v in levels]


def test_pin_map_is_the_single_source(design):
    act, be, _ = make(design)
    with act:
        assert [(c.forward, c.backward, c.enable) for c in be.channels] == \
               [(c.forward, c.backward, c.enable) for c in pin_map(design)]
        # every coil pin is an output, PWM at the design's frequency, starting low
        for c in be.channels:
            for g in (c.forward, c.backward):
                p = be.factory.pin(g)
                assert p.function == "output"
                assert p.frequency == design.drive.pwm_frequency
                assert p.state == 0


@pytest.mark.parametrize("which", ["all", "every-second", "opposite", 8, 4, 2, 1])
@pytest.mark.parametrize("start", [0, 1, 3])
def test_every_configuration_exact_pins(design, which, start):
    act, be, _ = make(design)
    lvl = act.default_level()
    mask = configuration(8, which, start)
    with act:
        act.retract(which=which, start=start)
        assert pin_values(be, be.channels) == expected(np.where(mask, lvl, 0.0))
        act.extend(level=0.5, which=which, start=start)
        assert pin_values(be, be.channels) == expected(np.where(mask, -0.5, 0.0))
        act.neutral()
        assert pin_values(be, be.channels) == expected(np.zeros(8))
    assert all(p.state == 0 for p in be.factory.pins.values())


def test_configuration_masks():
    assert configuration(8, "all").tolist() == [True] * 8
    assert np.flatnonzero(configuration(8, "every-second")).tolist() == [0, 2, 4, 6]
    assert np.flatnonzero(configuration(8, "every-second", 1)).tolist() == [1, 3, 5, 7]
    assert np.flatnonzero(configuration(8, "opposite")).tolist() == [0, 4]
    assert np.flatnonzero(configuration(8, "opposite", 2)).tolist() == [2, 6]
    assert np.flatnonzero(configuration(8, 2, 7)).tolist() == [3, 7]
    assert np.flatnonzero(configuration(6, "every-second")).tolist() == [0, 2, 4]
    assert np.flatnonzero(configuration(6, 3, 1)).tolist() == [1, 3, 5]
    for bad in (3, 0, 9, "some", "every-second-ish"):
        with pytest.raises(ValueError, match="configuration"):
            configuration(8, bad)
    with pytest.raises(ValueError, match="divides"):
        configuration(7, "every-second")


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 24), data=st.data())
def test_configuration_evenly_spaced(n, data):
    k = data.draw(st.sampled_from([d for d in range(1, n + 1) if n % d == 0]))
    start = data.draw(st.integers(-30, 30))
    idx = np.flatnonzero(configuration(n, k, start))
    assert len(idx) == k
    assert start % n in idx
    gaps = np.diff(np.concatenate([idx, [idx[0] + n]]))
    assert np.all(gaps == n // k)


def test_per_whisker_levels_and_volts(design):
    act, be, _ = make(design)
    levels = np.array([0.6, -0.6, 0.25, -0.25, 0.0, 1e-3, -1e-3, 0.5])  # within max_level (0.63 at 7.5 V)
    with act:
        act.apply(levels, "levels")
        assert pin_values(be, be.channels) == expected(levels)
        act.set_whisker(4, -0.55)
        assert pin_values(be, be.channels)[4] == (0.0, 0.55, None)
        assert pin_values(be, be.channels)[0] == (0.6, 0.0, None)  # others kept
        volts = np.array([3.0, -3.0, 1.6, 0, 0, 0, 0, -0.8])
        act.set_volts(volts)
        fs = full_scale_voltage(design)
        assert np.allclose([f - b for f, b, _ in pin_values(be, be.channels)], volts / fs)


def test_refusals_change_nothing(design):
    act, be, _ = make(design)
    with act:
        act.retract(level=0.5)
        before = pin_values(be, be.channels)
        top = design.drive.max_coil_voltage / full_scale_voltage(design)
        over = np.zeros(8)
        over[3] = min(1.0, top + 0.01)
        if top < 1.0:
            with pytest.raises(RatingError, match="whisker 3.*max_coil_voltage"):
                act.apply(over)
        with pytest.raises(RatingError, match="max_coil_voltage"):
            act.set_volts(np.full(8, design.drive.max_coil_voltage + 0.5))
        with pytest.raises(ValueError, match="whisker 2 is nan"):
            act.apply([0, 0, np.nan, 0, 0, 0, 0, 0])
        with pytest.raises(ValueError, match="whisker 1 is inf"):
            act.apply([0, np.inf, 0, 0, 0, 0, 0, 0])
        with pytest.raises(ValueError, match="outside"):
            act.apply([0, 0, 0, 0, 0, -1.5, 0, 0])
        with pytest.raises(ValueError, match="shape"):
            act.apply(np.zeros(7))
        with pytest.raises(ValueError, match="whisker must be"):
            act.set_whisker(8, 0.1)
        assert pin_values(be, be.channels) == before


def test_rating_refused_above_coil_rating():
    # a 5 V full scale with a 3.3 V coil rating: only levels up to 0.66 are allowed
    d = default_design("drive.full_scale_voltage=5.0")
    act, be, _ = make(d)
    with act:
        act.apply(np.full(8, 0.66))
        with pytest.raises(RatingError, match="above the coil rating"):
            act.apply(np.full(8, 0.67))
        with pytest.raises(RatingError):
            act.retract(level=1.0)


def test_driver_rating_refused():
    # 1 ohm coils on a 12 V supply would draw ~4.9 A from a 2 A L298N channel
    d = default_design("coil.resistance=1.0", "driver.supply_voltage=12")
    thermal, current = coil_model(d)
    guard = ThermalGuard(d, thermal=thermal, current_fn=current)
    with pytest.raises(RatingError, match="L298N.s 2 A per channel"):
        Actuator(d, mock_backend(d), guard=guard, watchdog=False)


def test_no_shoot_through_on_reversal(design):
    """Reversing a coil never has both H-bridge inputs high at once (gpiozero lowers the other first)."""
    events = []

    class LoggingPin(MockPWMPin):
        def _change_state(self, value):
            changed = super()._change_state(value)
            if changed:
                events.append((self.info.name, float(value)))
            return changed

    factory = MockFactory(pin_class=LoggingPin)
    be = GpioBackend(design, pin_factory=factory)
    be.factory = factory
    act, _, _ = make(design, backend=be)
    names = {f"GPIO{c.forward}": (c.whisker, 0) for c in be.channels}
    names.update({f"GPIO{c.backward}": (c.whisker, 1) for c in be.channels})
    with act:
        for lv in (0.6, -0.6, 0.3, -0.5, 0.0, -0.2, 0.6):
            act.apply(np.full(8, lv))
    state = np.zeros((8, 2))
    assert len(events) > 40
    for name, value in events:
        w, k = names[name]
        state[w, k] = value
        assert not (state[w, 0] > 0 and state[w, 1] > 0), f"coil {w} had both inputs on"
    assert np.all(state == 0)


def test_enable_pin_wiring(design):
    """A pin map with EN wired: EN high while open, low after off()."""
    chans = [CoilChannel(whisker=i, forward=4 + i, backward=12 + i, enable=20 + i, module=i // 2,
                         channel="AB"[i % 2]) for i in range(8)]
    be = mock_backend(design, channels=chans)
    act, _, _ = make(design, backend=be)
    act.retract(level=0.5, which="opposite")
    assert pin_values(be, chans) == expected(np.where(configuration(8, "opposite"), 0.5, 0.0), True)
    act.off()
    assert pin_values(be, chans) == [(0.0, 0.0, False)] * 8
    act.close()


def test_gpio_backend_refuses_expander_channels():
    d = default_design('wiring.expander="pca9685"')
    with pytest.raises(ValueError, match="GpioBackend drives Pi GPIO only"):
        GpioBackend(d, pin_factory=MockFactory(pin_class=MockPWMPin))


def test_grasp_sequence_phases_and_pins(design):
    clock = FakeClock()
    act, be, _ = make(design, clock=clock)
    log = []
    act.log = lambda t, phase, req, applied: log.append((t, phase, applied.copy()))
    mask = configuration(8, "every-second")
    lvl = act.default_level()
    # short phases at moderate levels: the coils stay below the guard's derate band (40 C), which a
    # 3 V mean reaches in ~1 s from a 7.5 V supply (PWM heats with the 5.24 V full-scale current)
    steps = grasp_sequence(8, mask, lvl, retract_s=0.3, hold_s=0.5, release_s=0.3, hold_level=0.2,
                           release_level=-0.2)
    assert [s.phase for s in steps] == ["retract", "hold", "release", "neutral"]
    seen = {}
    with act:
        runner = SequenceRunner(act, steps)
        runner.start(clock())
        while not runner.done:
            phase = runner.tick(clock.advance(0.01))
            seen.setdefault(phase, pin_values(be, be.channels))
        assert pin_values(be, be.channels) == expected(np.zeros(8))
    assert seen["retract"] == expected(np.where(mask, lvl, 0.0))
    assert seen["hold"] == expected(np.where(mask, 0.2, 0.0))
    assert seen["release"] == expected(np.where(mask, -0.2, 0.0))
    phases = [p for _, p, _ in log]
    assert phases[:4] == ["retract", "hold", "release", "neutral"]
    t_changes = [t for t, p, _ in log if p in ("hold", "release")]
    assert t_changes == pytest.approx([0.3, 0.8], abs=0.011)


def test_sequence_skipping_ticks_applies_every_step(design):
    """A slow caller that ticks once per second still applies every step in order."""
    clock = FakeClock()
    act, be, _ = make(design, clock=clock)
    log = []
    act.log = lambda t, phase, req, applied: log.append(phase)
    steps = [Step("a", 0.1, (0.1,) * 8), Step("b", 0.1, (0.2,) * 8), Step("c", 0.0, (0.0,) * 8)]
    with act:
        r = SequenceRunner(act, steps)
        r.start(0.0)
        r.tick(clock.advance(5.0))
        assert r.done
    assert log[:3] == ["a", "b", "c"]


def test_run_sequence_blocking_switches_off(design):
    clock = FakeClock()
    act, be, _ = make(design, clock=clock)
    steps = grasp_sequence(8, configuration(8, "all"), 0.5, retract_s=0.1, hold_s=0.1, release_s=0.1)
    phases = []
    run_sequence(act, steps, period_s=0.02, clock=clock, sleep=clock.advance,
                 on_tick=lambda t, p: phases.append(p))
    assert {"retract", "hold", "release", "neutral"} <= set(phases)
    assert pin_values(be, be.channels) == expected(np.zeros(8))
    act.close()


def test_exception_in_sequence_switches_off(design):
    clock = FakeClock()
    act, be, _ = make(design, clock=clock)

    def boom(t, phase):
        if phase == "hold":
            raise RuntimeError("boom")

    steps = grasp_sequence(8, configuration(8, "all"), 0.5, retract_s=0.1, hold_s=1.0, release_s=0.1)
    with pytest.raises(RuntimeError):
        run_sequence(act, steps, clock=clock, sleep=clock.advance, on_tick=boom)
    assert pin_values(be, be.channels) == expected(np.zeros(8))
    act.close()


def test_backend_failure_switches_off(design):
    class Flaky:
        def __init__(self):
            self.calls, self.offs = 0, 0

        def set_levels(self, levels):
            self.calls += 1
            if self.calls == 2:
                raise OSError("pin write failed")

        def off(self):
            self.offs += 1

    be = Flaky()
    act, _, _ = make(design, backend=be)
    act.retract(level=0.2)
    with pytest.raises(OSError):
        act.retract(level=0.3)
    assert be.offs >= 1 and np.all(act.applied == 0)
    act.close()


def test_six_whisker_design():
    d = default_design("whiskers.count=6")
    act, be, _ = make(d)
    with act:
        act.retract(level=0.4, which=3, start=1)
        assert pin_values(be, be.channels) == expected(np.where(configuration(6, 3, 1), 0.4, 0.0))
        with pytest.raises(ValueError, match="divides"):
            act.retract(which=4)


def test_threaded_runner_keeps_phase_timing(design):
    """Ticked only by its own thread (the caller never ticks), the phases change on time."""
    import time

    from whisker.drive.sequences import ThreadedSequenceRunner

    thermal, current = coil_model(design)
    guard = ThermalGuard(design, thermal=thermal, current_fn=current)
    be = mock_backend(design)
    log = []
    act = Actuator(design, be, guard=guard, current_fn=current, watchdog=False,
                   log=lambda t, phase, req, applied: log.append((t, phase)))
    steps = grasp_sequence(8, configuration(8, "opposite"), 0.5, retract_s=0.2, hold_s=0.2, release_s=0.2)
    with act:
        r = ThreadedSequenceRunner(act, steps, period_s=0.005)
        r.start(time.monotonic())
        deadline = time.monotonic() + 10
        while not r.done and time.monotonic() < deadline:
            time.sleep(0.02)
        r.stop()
        assert r.done
    t0 = r.t0
    when = {p: t - t0 for t, p in log if p in ("retract", "hold", "release")}
    assert when["retract"] == pytest.approx(0.0, abs=0.05)
    assert when["hold"] == pytest.approx(0.2, abs=0.1) and when["release"] == pytest.approx(0.4, abs=0.1)
    assert when["hold"] < when["release"]
    assert all(p.state == 0 for p in be.factory.pins.values())


def test_gpio_backend_without_pins_fails_clearly(design):
    from pathlib import Path

    from whisker.drive.hbridge import open_backend

    model = Path("/proc/device-tree/model")
    if model.exists() and "Raspberry" in model.read_text(errors="ignore"):
        pytest.skip("running on a Raspberry Pi: the real pins exist")
    with pytest.raises(RuntimeError, match="no GPIO pins on this machine.*--backend mock"):
        open_backend("gpio", design)
    with pytest.raises(ValueError, match="backend must be one of"):
        open_backend("serial", design)


# ---- PCA9685 expander (beyond 11 coils) --------------------------------------------------------

def test_pca9685_exact_channel_duties():
    from whisker.drive.hbridge import MockI2CBus, Pca9685Backend

    d = default_design("whiskers.count=12", 'wiring.expander="pca9685"')
    chans = pin_map(d)
    bus = MockI2CBus()
    be = Pca9685Backend(d, bus=bus, sleep=lambda s: None)
    assert be.addresses == [0x40, 0x41] and be.prescale == 5  # round(25e6 / (4096 * 1000)) - 1
    for a in be.addresses:
        assert bus.regs[a][0xFE] == 5 and bus.regs[a][0x00] == 0x20  # awake, auto-increment
    act, _, _ = make(d, backend=be)
    levels = np.array([1.0, -1.0, 0.5, -0.25, 0.0, 0.3, 0, 0, 0.9, -0.9, 0, 1e-3])
    top = __import__("whisker.drive.guard", fromlist=["max_level"]).max_level(d)
    levels = np.clip(levels, -top, top)
    with act:
        act.apply(levels)
        for c, v in zip(chans, levels):
            fwd, bwd = be.read_duty(c.address, c.forward), be.read_duty(c.address, c.backward)
            assert fwd == pytest.approx(max(v, 0), abs=1 / 4096) and bwd == pytest.approx(max(-v, 0), abs=1 / 4096)
            assert not (fwd > 0 and bwd > 0)
        act.retract(level=0.5, which="opposite")
        mask = configuration(12, "opposite")
        for c, m in zip(chans, mask):
            assert be.read_duty(c.address, c.forward) == pytest.approx(0.5 if m else 0.0, abs=1 / 4096)
    # off(): one ALL_LED_OFF_H full-off write per board, every channel reads 0
    assert all(be.read_duty(c.address, ch) == 0 for c in chans for ch in (c.forward, c.backward))
    assert (0x40, 0xFD, 0x10) in bus.writes[-4:] and (0x41, 0xFD, 0x10) in bus.writes[-4:]


def test_pca9685_frequency_range_and_mock_backend():
    from whisker.drive.hbridge import MockI2CBus, Pca9685Backend

    d = default_design("whiskers.count=12", 'wiring.expander="pca9685"', "drive.pwm_frequency=5000")
    with pytest.raises(ValueError, match="24..1526 Hz"):
        Pca9685Backend(d, bus=MockI2CBus())
    d = default_design("whiskers.count=12", 'wiring.expander="pca9685"')
    be = mock_backend(d)
    assert isinstance(be, Pca9685Backend)
    be.set_levels(np.full(12, 0.25))
    assert [round(s["forward_value"], 3) for s in be.pin_states()] == [0.25] * 12


# ---- sequence files ---------------------------------------------------------------------------

def test_sequence_file_parses_and_validates(design, tmp_path):
    from whisker.drive.sequences import load_sequence, sequence_from_dict
    from whisker.drive.guard import full_scale_voltage

    root = __import__("pathlib").Path(__file__).resolve().parents[1]
    steps = load_sequence(design, root / "docs" / "sequences" / "voltage_sweep.toml")
    assert [s.phase for s in steps][:4] == ["neutral", "+1.0V", "rest", "+2.0V"]
    assert steps[1].levels[0] == pytest.approx(1.0 / full_scale_voltage(design)) and not any(steps[1].levels[1:])
    assert steps[-2].levels[0] == pytest.approx(-3.0 / full_scale_voltage(design))
    data = {"repeat": 2, "step": [
        {"phase": "a", "duration_s": 0.5, "config": "opposite", "start": 1, "level": -0.4},
        {"phase": "b", "duration_s": 0.0, "levels": [0.1] * 8},
        {"phase": "c", "duration_s": 1, "volts_each": [0, 0, 3, 0, 0, 0, 0, 0]},
        {"phase": "d", "duration_s": 1}]}
    st = sequence_from_dict(design, data)
    assert len(st) == 8 and st[0].levels == (0, -0.4, 0, 0, 0, -0.4, 0, 0) and st[3].levels == (0.0,) * 8
    bad = [
        ({"step": []}, "no \\[\\[step\\]\\]"),
        ({"steps": []}, "unknown key"),
        ({"repeat": 0, "step": [{"duration_s": 1}]}, "repeat"),
        ({"step": [{"duration_s": -1}]}, "duration_s"),
        ({"step": [{"duration_s": 1, "level": 0.5, "volts": 1}]}, "give one of"),
        ({"step": [{"duration_s": 1, "levels": [0.1] * 7}]}, "needs 8 values"),
        ({"step": [{"duration_s": 1, "config": 3, "level": 0.1}]}, "divides"),
        ({"step": [{"duration_s": 1, "volts": 9}]}, "max_coil_voltage"),
        ({"step": [{"duration_s": 1, "speed": 2}]}, "unknown key"),
        ({"step": [{"phase": "a,b", "duration_s": 1}]}, "without commas"),
    ]
    for d, msg in bad:
        with pytest.raises(ValueError, match=msg):
            sequence_from_dict(design, d)
    (tmp_path / "x.toml").write_text("[[step]\n")
    with pytest.raises(ValueError, match="x.toml"):
        load_sequence(design, tmp_path / "x.toml")
    with pytest.raises(RatingError, match="step 2 \\(hot\\)"):
        sequence_from_dict(default_design("drive.full_scale_voltage=5"),
                           {"step": [{"duration_s": 1}, {"phase": "hot", "duration_s": 1, "level": 0.9}]})


def test_sequence_file_cli(tmp_path):
    from click.testing import CliRunner

    from whisker.cli import main

    f = tmp_path / "s.toml"
    f.write_text('[[step]]\nphase = "go"\nduration_s = 0.2\nconfig = "opposite"\nlevel = 0.5\n'
                 '[[step]]\nphase = "stop"\nduration_s = 0.0\n')
    r = CliRunner().invoke(main, ["actuate", "sequence", str(f), "--backend", "mock"])
    assert r.exit_code == 0, r.stderr
    assert " go " in r.stderr and " stop " in r.stderr and "2 steps" in r.stderr
    r = CliRunner().invoke(main, ["actuate", "sequence", str(tmp_path / "none.toml"), "--backend", "mock"])
    assert r.exit_code == 2 and "does not exist" in r.stderr
