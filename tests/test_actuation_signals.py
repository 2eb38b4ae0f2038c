"""Every coil is de-energised however the program ends: SIGTERM, an exception, Ctrl-C, normal exit.

Each case runs a child process that drives the coils on gpiozero mock pins whose every state and
function change is appended (and flushed) to a log file; the parent reads the log after the child
has ended. The coils must be low *before* gpiozero starts releasing pins (the first "function input"
line), i.e. switched off by the actuator, not merely by the library's own cleanup.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CHILD = textwrap.dedent('''
    import os, signal, sys, time
    # Ctrl-C's default: a shell starts background jobs with SIGINT ignored, and Python then installs no
    # KeyboardInterrupt handler, so a CI launched with `&` would test an ignored Ctrl-C
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.path.insert(0, {tests!r})
    from gpiozero.pins.mock import MockFactory, MockPWMPin
    LOG = open(sys.argv[2], "a", buffering=1)

    class LoggingPin(MockPWMPin):
        def _change_state(self, value):
            changed = super()._change_state(value)
            if changed:
                LOG.write(f"{{self.info.name}} state {{float(value)}}\\n"); LOG.flush()
            return changed

        def _set_function(self, value):
            super()._set_function(value)
            LOG.write(f"{{self.info.name}} function {{value}}\\n"); LOG.flush()

    from test_actuation_doubles import coil_model
    from whisker.drive.actuation import Actuator, deenergise_on_signals
    from whisker.drive.hbridge import GpioBackend
    from whisker.design import default_design
    from whisker.drive.guard import ThermalGuard

    mode = sys.argv[1]
    d = default_design()
    thermal, current = coil_model(d)
    backend = GpioBackend(d, pin_factory=MockFactory(pin_class=LoggingPin))
    guard = ThermalGuard(d, thermal=thermal, current_fn=current)
    with deenergise_on_signals():
        if mode == "normal":  # no `with`, no close(): only the atexit hook can switch off
            act = Actuator(d, backend, guard=guard, current_fn=current)
            act.retract(which="all")
            print("READY", flush=True)
            sys.exit(0)
        with Actuator(d, backend, guard=guard, current_fn=current) as act:
            act.retract(which="every-second")
            act.extend(level=0.5, which="opposite", start=1)
            print("READY", flush=True)
            if mode == "exception":
                raise RuntimeError("boom in the middle of a hold")
            time.sleep(60)
''')


def run_child(tmp_path, mode, sig=None):
    script = tmp_path / "child.py"
    script.write_text(CHILD.format(tests=str(ROOT / "tests")))
    log = tmp_path / "pins.log"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    p = subprocess.Popen([sys.executable, str(script), mode, str(log)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        line = p.stdout.readline()
        assert line.strip() == "READY", p.stderr.read()
        if sig is not None:
            p.send_signal(sig)
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    return p.returncode, err, log.read_text().splitlines()


def check_log(lines):
    from whisker.design import default_design
    from whisker.drive.pins import pin_map

    coil_pins = {f"GPIO{g}" for c in pin_map(default_design()) for g in (c.forward, c.backward)}
    first_release = next((i for i, l in enumerate(lines) if l.split()[1:] == ["function", "input"]),
                         len(lines))
    state = {}
    energised = False
    for line in lines[:first_release]:
        name, kind, value = line.split()
        if kind == "state" and name in coil_pins:
            state[name] = float(value)
            energised |= float(value) > 0
    assert energised, "the child never energised a coil"
    on = {k: v for k, v in state.items() if v != 0}
    assert not on, f"coil pins still driven when the program ended: {on}"


def test_sigterm_deenergises(tmp_path):
    code, err, lines = run_child(tmp_path, "hold", signal.SIGTERM)
    assert code == 128 + signal.SIGTERM, err
    check_log(lines)


def test_exception_deenergises(tmp_path):
    code, err, lines = run_child(tmp_path, "exception")
    assert code == 1 and "boom in the middle of a hold" in err
    check_log(lines)


def test_ctrl_c_deenergises(tmp_path):
    code, err, lines = run_child(tmp_path, "hold", signal.SIGINT)
    assert code != 0 and "KeyboardInterrupt" in err
    check_log(lines)


def test_normal_exit_deenergises(tmp_path):
    code, err, lines = run_child(tmp_path, "normal")
    assert code == 0, err
    check_log(lines)


def test_sigkill_control_shows_coils_left_on(tmp_path):
    """Control: the log does show a coil left on when nothing switches it off (SIGKILL)."""
    code, err, lines = run_child(tmp_path, "hold", signal.SIGKILL)
    assert code == -signal.SIGKILL
    with pytest.raises(AssertionError, match="still driven"):
        check_log(lines)
