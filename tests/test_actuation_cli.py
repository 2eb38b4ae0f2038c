"""whisker actuate / grasp / record / recplot on the command line (mock pins)."""

from __future__ import annotations

import pytest

from conftest import run_cli


@pytest.mark.parametrize("cmd", ["actuate", "grasp", "record", "recplot"])
def test_help(cmd):
    res = run_cli(cmd, "--help")
    assert res.returncode == 0 and "Usage:" in res.stdout
    if cmd != "recplot":
        assert "--backend" in res.stdout


def test_actuate_mock_prints_exact_pins():
    res = run_cli("actuate", "levels", "0.5,0,0,0,-0.25,0,0,0", "--backend", "mock", "--duration", "0.1",
                  "--pins", "-q")
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    first = lines[1:9]  # the table while holding
    assert "GPIO4  =0.500" in first[0] and "=0.000" in first[0].split("GPIO4")[1].split("GPIO")[1]
    assert first[4].split()[-1].endswith("=0.250")  # whisker 4 backward
    assert all(l.count("=0.000") == 2 for l in lines[-8:])  # neutral at the end


@pytest.mark.parametrize("args, message", [
    (["levels", "1,0,0,0,0,0,0,0", "--set", "drive.full_scale_voltage=5"], "above the coil rating"),
    (["levels", "0.1,0.2"], "8 whiskers, got 2 values"),
    (["volts", "3,x,0,0,0,0,0,0"], "numbers"),
    (["retract", "--volts", "9"], "max_coil_voltage"),
    (["retract", "--config", "3"], "divides"),
    (["retract", "--level", "0.5", "--volts", "1"], "not both"),
])
def test_actuate_refusals(args, message):
    """In-process (click's CliRunner): one line on stderr, exit status 2, no traceback."""
    from click.testing import CliRunner

    from whisker.cli import main

    r = CliRunner().invoke(main, ["actuate", *args, "--backend", "mock", "--duration", "0"])
    assert r.exit_code == 2 and message in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_backend_is_required():
    from click.testing import CliRunner

    from whisker.cli import main

    r = CliRunner().invoke(main, ["actuate", "retract"])
    assert r.exit_code == 2 and "--backend" in r.stderr


def test_grasp_mock_phases():
    r = run_cli("grasp", "--backend", "mock", "--config", "opposite", "--retract-s", "0.1", "--hold-s", "0.1",
                "--release-s", "0.1", "--trials", "2", "--pause-s", "0")
    assert r.returncode == 0, r.stderr
    for phase in ("retract", "hold", "release", "neutral"):
        assert r.stderr.count(f" {phase} ") == 2
    assert "peak winding temperature" in r.stderr
    # the paper's 3 V as a level of the coil's full scale (the 7.5 V supply behind the auto series
    # resistor: 3.28 V for the wound coil, so 0.915; the 600-turn coil's 3.22 V gave 0.931)
    from whisker.design import default_design
    from whisker.drive.guard import full_scale_voltage

    d = default_design()
    lv = round(d.actuation.voltage / full_scale_voltage(d), 3)
    assert 0.5 < lv < 1.0
    assert f"applied=[{lv}, 0.0, 0.0, 0.0, {lv}, 0.0, 0.0, 0.0]" in r.stderr
