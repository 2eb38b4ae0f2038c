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


def test_actuate_refusals():
    r = run_cli("actuate", "levels", "1,0,0,0,0,0,0,0", "--backend", "mock", "--set", "drive.full_scale_voltage=5")
    assert r.returncode == 2 and "above the coil rating" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("actuate", "levels", "0.1,0.2", "--backend", "mock")
    assert r.returncode == 2 and "8 whiskers, got 2 values" in r.stderr
    r = run_cli("actuate", "volts", "3,x,0,0,0,0,0,0", "--backend", "mock")
    assert r.returncode == 2 and "numbers" in r.stderr
    r = run_cli("actuate", "retract", "--backend", "mock", "--volts", "9")
    assert r.returncode == 2 and "max_coil_voltage" in r.stderr
    r = run_cli("actuate", "retract", "--backend", "mock", "--config", "3")
    assert r.returncode == 2 and "divides" in r.stderr
    r = run_cli("actuate", "retract")
    assert r.returncode == 2 and "--backend" in r.stderr


def test_grasp_mock_phases():
    r = run_cli("grasp", "--backend", "mock", "--config", "opposite", "--retract-s", "0.1", "--hold-s", "0.1",
                "--release-s", "0.1", "--trials", "2", "--pause-s", "0")
    assert r.returncode == 0, r.stderr
    for phase in ("retract", "hold", "release", "neutral"):
        assert r.stderr.count(f" {phase} ") == 2
    assert "peak coil temperature" in r.stderr
    assert "applied=[0.97, 0.0, 0.0, 0.0, 0.97, 0.0, 0.0, 0.0]" in r.stderr
