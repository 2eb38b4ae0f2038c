"""`whisker doctor`, the extras table and the shipped-data lookup (whisker.resources)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT, WHISKER
from whisker import extras, resources


def doctor(tmp_path, *args, factory="mock"):
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache"), "GPIOZERO_PIN_FACTORY": factory}
    res = subprocess.run([*WHISKER, "doctor", *args], capture_output=True, text=True, cwd=tmp_path, env=env,
                         timeout=120)
    items = {line[5:17].strip(): (line[:3].strip(), line[17:]) for line in res.stdout.splitlines()[:-1]}
    return res, items


def test_data_lookup_in_a_clone_is_the_checkout():
    assert resources.default_design_path() == ROOT / "hw" / "sensor.toml"
    assert resources.sequences_dir() == ROOT / "docs" / "sequences"
    assert resources.example("voltage_sweep", resources.sequences_dir()) == ROOT / "docs/sequences/voltage_sweep.toml"
    assert resources.example("grasp.toml", resources.scenes_dir()).is_file()
    # a path that exists, or one with a folder, is taken as given (a typo is reported by the caller)
    assert resources.example("no_such_sequence", resources.sequences_dir()).name == "no_such_sequence"
    assert str(resources.example("x/voltage_sweep", resources.sequences_dir())) == "x/voltage_sweep"


def test_extras_all_installed_in_the_test_environment():
    status = extras.extras_status()
    assert {"cad", "sim", "hw", "magnetics", "all"} <= set(status)
    assert all(missing == [] for missing in status.values()), status


def test_missing_extra_message_names_the_pip_install():
    err = ModuleNotFoundError("No module named 'OCP.TopoDS'", name="OCP.TopoDS")
    assert extras.missing_extra_message(err, "whisker cad") == (
        "whisker cad needs OCP from the [cad] extra: pip install 'whisker-array[cad]'")
    assert extras.missing_extra_message(ModuleNotFoundError("x", name="numpy")) is None


def test_doctor_reports_each_item_and_exit_status(tmp_path):
    res, items = doctor(tmp_path)
    assert set(items) == {"design", "extras", "camera", "gpio", "coil state", "kicad"}, res.stdout
    assert items["kicad"][0] == "ok"  # informational: the sensor never needs KiCad
    assert "kicad-cli 9." in items["kicad"][1] or "bookworm-backports" in items["kicad"][1]
    assert items["design"][0] == "ok" and str(ROOT / "hw" / "sensor.toml") in items["design"][1]
    assert items["gpio"] == ("ok", "MockFactory opens all 16 coil pins (GPIO 4, 5, 6, 12, 13, 16, 17, 18, 19, "
                                   "20, 22, 23, 24, 25, 26, 27)")
    assert items["coil state"][0] == "ok" and "none yet" in items["coil state"][1]
    bad = [k for k, (st, _) in items.items() if st == "FIX"]
    assert res.returncode == (1 if bad else 0) and res.stdout.splitlines()[-1].startswith(f"{6 - len(bad)}/6 ok")


def test_doctor_says_what_to_fix(tmp_path):
    state = tmp_path / "cache" / "whisker" / "coil_state.json"
    state.parent.mkdir(parents=True)
    state.write_text("{not json")
    res, items = doctor(tmp_path, "--set", "whiskers.count=0")
    assert res.returncode == 1
    assert items["design"][0] == "FIX" and "whiskers.count" in items["design"][1]
    assert items["gpio"][0] == "FIX" and "fix the design first" in items["gpio"][1]
    assert items["coil state"][0] == "FIX" and f"rm {state}" in items["coil state"][1]
    state.write_text(json.dumps({"wall_time_s": 0, "digest": "x", "temperatures_C": [30.0] * 8}))
    res, items = doctor(tmp_path, "--set", 'wiring.expander="pca9685"')
    assert items["coil state"][0] == "ok" and "another design" in items["coil state"][1]
    assert items["gpio"][0] == "ok" and "PCA9685" in items["gpio"][1]


def test_doctor_without_a_pin_factory_says_what_to_install(tmp_path):
    if sys.platform != "linux" or os.path.exists("/dev/gpiochip0"):
        pytest.skip("this machine has GPIO: the default pin factory may load")
    res, items = doctor(tmp_path, factory="")
    assert items["gpio"][0] == "FIX" and "whisker-array[pi]" in items["gpio"][1]
