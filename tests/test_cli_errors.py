"""Issue 22's examples, one test each: bad input is refused in one line, never answered with exit 0.

Every example failed (traceback, or exit 0 with a meaningless result) before the CLI's one error
path (whisker.errors) and the checks where numbers enter. Also: the error path itself (exit
statuses, --debug, WHISKER_DEBUG) and a recording on a full disk.
"""

from __future__ import annotations

import errno
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from test_dataset import synthetic
from test_recording_plot import make_trial
from whisker.cli import main
from whisker.design import default_design

ROOT = Path(__file__).resolve().parents[1]


def run(*args, env=None):
    """(exit status, stdout, stderr) of `whisker ARGS` run in-process."""
    r = CliRunner().invoke(main, [str(a) for a in args], env={"WHISKER_DEBUG": "", **(env or {})})
    return r.exit_code, r.stdout, r.stderr


def one_line(err: str) -> str:
    """The error message: one line, no traceback."""
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    msg = lines[-1]
    assert "internal error" not in msg
    return msg


# -- the error path ------------------------------------------------------------------------------------
def test_oserror_is_one_line_with_the_path(tmp_path):
    (tmp_path / "file").write_text("x")
    code, _, err = run("coil", "report", "--out", tmp_path / "file" / "sub")
    assert code == 2 and "Not a directory" in one_line(err) and str(tmp_path / "file") in err


def test_debug_shows_the_traceback(tmp_path):
    (tmp_path / "f").write_text("x")
    args = ["coil", "report", "--out", str(tmp_path / "f" / "x")]
    r = CliRunner().invoke(main, args, env={"WHISKER_DEBUG": ""})
    assert r.exit_code == 2 and r.exception is None or isinstance(r.exception, SystemExit)
    r = CliRunner().invoke(main, ["--debug", *args])
    assert isinstance(r.exception, NotADirectoryError)  # re-raised: click's runner holds the traceback
    r = CliRunner().invoke(main, args, env={"WHISKER_DEBUG": "1"})
    assert isinstance(r.exception, NotADirectoryError)


def test_explain_maps_exceptions():
    from whisker.errors import explain, is_internal

    assert explain(OSError(errno.ENOSPC, "No space left on device", "/x"))[0] == 1
    assert explain(OSError(errno.EROFS, "Read-only file system", "/x"))[0] == 1
    assert explain(FileNotFoundError(errno.ENOENT, "No such file or directory", "/x"))[0] == 2
    code, line = explain(ValueError("bad\nvalue"))
    assert code == 2 and line == "bad value"
    assert explain(UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"))[0] == 2
    code, line = explain(ZeroDivisionError("division by zero"))
    assert code == 1 and is_internal(line) and "--debug" in line


# -- whisker sim -------------------------------------------------------------------------------------------
def _scene(tmp_path, text: str) -> Path:
    p = tmp_path / "scene.toml"
    p.write_text(text)
    return p


BALL_INSIDE = '[scene]\nduration = 0.05\n[[objects]]\nname = "ball"\nsize = [50.0]\nmass = 10.0\n'
TIPS_LOW = '[scene]\nduration = 0.05\n[sensor]\npath = [[0.0, 0.0, 0.0, -20.0, 0.0]]\n'


@pytest.mark.parametrize("text, words", [
    (BALL_INSIDE, "overlaps membrane"),
    (TIPS_LOW, "below the table top"),
    ('[scene]\nduration = 1\ntimestep = 1e-12\n[sensor]\npath = [[0, 0, 0, 20, 0], [1, 5, 0, 20, 0]]\n',
     "WHISKER_SIM_MAX_STEPS"),
    ('[[objects]]\nname = "ball"\nsize = [1e308]\nmass = 1.0\n', "sizes must be in (0, 1000]"),
    ('[[objects]]\nname = "ball"\nsize = [5.0]\nmass = 1.0\npos = [40.0, 0.0]\n'
     '[sensor]\npath = [[0.0, 0.0, 0.0, 3.0, 0.0], [1.0, 30.0, 0.0, 3.0, 0.0]]\n', "duration must be > 0"),
])
def test_sim_refuses_impossible_scenes_in_explain_and_run(tmp_path, text, words):
    scene = _scene(tmp_path, text)
    for extra in (["--explain"], ["--out", tmp_path / "run", "-q"]):
        code, out, err = run("sim", scene, *extra)
        assert code == 2 and words in one_line(err), err
    assert not (tmp_path / "run").exists()


def test_sim_unphysical_run_is_flagged():
    from types import SimpleNamespace

    from whisker.sim import scene_from_dict
    from whisker.sim.validate import run_flags

    scene = scene_from_dict({"objects": [{"name": "ball", "size": [5.0], "mass": 1.0, "pos": [40.0, 0.0]}]})
    res = SimpleNamespace(energy_J=np.array([0.0, 0.0]), info={"mujoco_energy_J": 74.6, "mujoco_energy_max_J": 74.6,
                                                                  "mujoco_energy_start_J": 0.001},
                          objects_mm=np.array([[[40.0, 0.0, 5.0]], [[1500.0, 0.0, 5.0]]]), object_names=["ball"])
    flags = run_flags(scene, res)
    assert any("energy rose" in f for f in flags) and any("'ball' left the scene" in f for f in flags)
    calm = SimpleNamespace(energy_J=np.array([0.0, 0.0]), info={"mujoco_energy_J": 0.001, "mujoco_energy_max_J": 0.001,
                                                                   "mujoco_energy_start_J": 0.001},
                           objects_mm=np.array([[[40.0, 0.0, 5.0]]] * 2), object_names=["ball"])
    assert run_flags(scene, calm) == []


# -- whisker recplot ---------------------------------------------------------------------------------------
@pytest.fixture()
def session(tmp_path):
    make_trial(tmp_path / "s", default_design(), offset_s=0.2, amplitude=2.0)
    return tmp_path / "s"


@pytest.mark.parametrize("value", ["nan", "inf"])
def test_recplot_refuses_sessions_with_no_valid_point(session, tmp_path, value):
    lines = (session / "tracks.csv").read_text().splitlines()
    head = lines[0].split(",")
    rows = []
    for line in lines[1:]:
        c = line.split(",")
        for k in ("dx_px", "dy_px"):
            c[head.index(k)] = value
        rows.append(",".join(c))
    (session / "tracks.csv").write_text("\n".join([lines[0], *rows]) + "\n")
    code, _, err = run("recplot", session, "--out", tmp_path / "f.png")
    assert code == 2 and "no valid point" in one_line(err)
    assert not (tmp_path / "f.png").exists() and not (tmp_path / "f.csv").exists()


@pytest.mark.parametrize("content", [b"", b"\xff\xfe\x00garbage\x81"])
def test_recplot_names_trials_without_actuation(session, tmp_path, content):
    (session / "actuation.csv").write_bytes(content)
    code, _, err = run("recplot", session, "--out", tmp_path / "f.png")
    assert code == 2 and "no 'retract' command to align on in 1 trial(s)" in one_line(err) and str(session) in err
    code, _, err = run("recplot", session, "--out", tmp_path / "f.png", "--align", "frame")
    assert code == 0, err


def test_recplot_refuses_unknown_align(session, tmp_path):
    code, _, err = run("recplot", session, "--out", tmp_path / "f.png", "--align", "bogus")
    assert code == 2 and "unknown --align 'bogus'" in one_line(err)


# -- whisker classify --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def data(tmp_path_factory):
    from whisker.data.dataset_files import write_csv_folder

    base = tmp_path_factory.mktemp("cls")
    write_csv_folder(synthetic(n_obj=3, trials=3, poses=6, R=2, W=8), base / "data")
    return base / "data"


def test_classify_refuses_a_single_class(data, tmp_path):
    for args in (["train", "--out", tmp_path / "m.joblib"], ["evaluate", "--seeds", "1", "--protocol", "random"]):
        code, _, err = run("classify", *args, "--data", data, "--objects", "obj0", "--epochs", "1")
        assert code == 2 and "a classifier needs at least 2" in one_line(err)
    assert not (tmp_path / "m.joblib").exists()


def test_classify_refuses_too_few_rows_per_class(tmp_path):
    from whisker.data.dataset_files import write_csv_folder

    ds = synthetic(n_obj=2, trials=1, poses=1, R=2, W=8)      # one sample per object
    write_csv_folder(ds, tmp_path / "d")
    code, _, err = run("classify", "train", "--data", tmp_path / "d", "--protocol", "random",
                       "--out", tmp_path / "m.joblib")
    assert code == 2 and "leaves no" in one_line(err)


@pytest.mark.parametrize("value", ["1e308", "-1e308", "5000"])
def test_classify_refuses_absurd_features(data, tmp_path, value):
    bad = tmp_path / "bad"
    bad.mkdir()
    for f in data.iterdir():
        (bad / f.name).write_bytes(f.read_bytes())
    rows = (bad / "obj1.csv").read_text().splitlines()
    rows[0] = ",".join([value] + rows[0].split(",")[1:])
    (bad / "obj1.csv").write_text("\n".join(rows) + "\n")
    code, out, err = run("classify", "train", "--data", bad, "--protocol", "random", "--out", tmp_path / "m.joblib")
    assert code == 2 and "beyond the" in one_line(err) and "RuntimeWarning" not in out + err
    assert not (tmp_path / "m.joblib").exists()


@pytest.fixture(scope="module")
def model(data, tmp_path_factory):
    out = tmp_path_factory.mktemp("model") / "m.joblib"
    code, _, err = run("classify", "train", "--data", data, "--protocol", "random", "--epochs", "3", "--out", out)
    assert code == 0, err
    return out


def test_predict_refuses_an_absurd_row(model, data, tmp_path):
    row = (data / "obj0.csv").read_text().splitlines()[0].split(",")
    (tmp_path / "in.csv").write_text(",".join(["1e308"] + row[1:]) + "\n")
    code, out, err = run("classify", "predict", "--model", model, "--input", tmp_path / "in.csv")
    assert code == 2 and "beyond the" in one_line(err) and out == ""


@pytest.mark.parametrize("content", [b"", b"garbage, not a model", "truncate"])
def test_model_files_that_are_not_ours(model, data, tmp_path, content):
    bad = tmp_path / "bad.joblib"
    bad.write_bytes(model.read_bytes()[:200] if content == "truncate" else content)
    before = bad.read_bytes()
    for args in (["predict", "--model", bad, "--input", data / "obj0.csv"],
                 ["evaluate", "--model", bad, "--data", data]):
        code, _, err = run("classify", *args)
        msg = one_line(err)
        assert code == 2 and ("not a whisker classify model" in msg or "damaged whisker classify model" in msg)
        assert "Aborted" not in err
    assert bad.read_bytes() == before


def test_model_carries_version_and_layout(model):
    from whisker.data.classify import FEATURE_LAYOUT, MODEL_FORMAT, load_model

    b = load_model(model)
    assert b["format"] == MODEL_FORMAT and b["feature_layout"] == FEATURE_LAYOUT and b["feature_limit_px"] > 0
    assert "scikit-learn" in b["versions"]


# -- whisker record ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("option, value", [("--duration", "nan"), ("--fps", "nan"), ("--duration", "inf"),
                                           ("--duration", "0")])
def test_record_refuses_nan_durations_and_rates(tmp_path, option, value):
    code, _, err = run("record", "--source", "synthetic:3", "--rest-frames", "1", "--out", tmp_path / "s", option, value)
    assert code == 2 and option in one_line(err)
    assert not (tmp_path / "s").exists()


# -- non-UTF-8 files and absurd numbers ----------------------------------------------------------------------
GARBAGE = b"\xff\xfe\x00\x81\xc3\x28 not text \x80"


def test_non_utf8_files_are_refused_in_one_line(model, tmp_path):
    f = tmp_path / "bin.toml"
    f.write_bytes(GARBAGE)
    code, _, err = run("sim", f, "--explain")
    assert code == 2 and str(f) in one_line(err)
    d = tmp_path / "data"
    d.mkdir()
    (d / "a.csv").write_bytes(GARBAGE)
    (d / "b.csv").write_bytes(GARBAGE)
    code, _, err = run("classify", "train", "--data", d, "--out", tmp_path / "m.joblib")
    assert code == 2 and "not UTF-8" in one_line(err)
    code, _, err = run("classify", "predict", "--model", model, "--input", d / "a.csv")
    assert code == 2 and "not UTF-8" in one_line(err)
    code, _, err = run("design", "show", "--design", f)
    assert code == 2 and str(f) in one_line(err)


@pytest.mark.parametrize("args", [["--wire", "1e308"], ["--volts", "1e308"], ["--gap", "nan"],
                                  ["--set", "coil.wire_diameter=1e308"]])
def test_coil_report_refuses_absurd_numbers(args):
    code, _, err = run("coil", "report", *args)
    assert code == 2
    one_line(err)


def test_design_show_and_coil_report_load_the_same_way():
    """Both read the design through whisker.cliutil.design_options: a value one refuses as a design
    error, the other refuses with the same words."""
    for over in ("whiskers.count=0", "coil.turns=-3", "coil.wire_diameter=nan"):
        c1, _, e1 = run("design", "show", "--set", over)
        c2, _, e2 = run("coil", "report", "--set", over)
        assert c1 == c2 == 2 and one_line(e1) == one_line(e2)
    for value in ("1e308", "nan", "-0.1", "abc"):       # a coil shortcut is the same --set
        c1, _, e1 = run("design", "show", "--set", f"coil.wire_diameter={value}")
        c2, _, e2 = run("coil", "report", "--wire", value)
        assert c1 == c2 == 2 and one_line(e1) == one_line(e2)


# -- a full disk ------------------------------------------------------------------------------------------------
def _small_tmpfs(path: Path) -> bool:
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(path)], capture_output=True)
    return r.returncode == 0


def test_recording_on_a_full_disk_keeps_every_complete_frame(tmp_path, monkeypatch):
    """A small tmpfs where the machine allows mounting one (root), otherwise ENOSPC simulated after 4
    frame images. Either way: one line, exit 1, every complete frame readable, recplot works."""
    import cv2

    from whisker.data.session import load_session

    disk = tmp_path / "disk"
    real = _small_tmpfs(disk)
    try:
        if not real:
            import whisker.data.recording as R

            calls = {"n": 0}
            orig = R.atomic_write_bytes

            def filling(path, data):
                calls["n"] += 1
                if calls["n"] > 4:
                    raise OSError(errno.ENOSPC, "No space left on device")
                return orig(path, data)

            monkeypatch.setattr(R, "atomic_write_bytes", filling)
        out = disk / "session"
        code, _, err = run("record", "--source", "synthetic:200", "--out", out, "--rest-frames", "2", "-q")
        assert code == 1 and "No space left on device" in one_line(err) and str(out) in err
        s = load_session(out)
        assert len(s.frame_index) >= 2 and f"keeps its {len(s.frame_index)} complete frame(s)" in err
        for f in s.frame_files:
            assert cv2.imread(str(out / "frames" / f)) is not None
        assert s.tracks["dx_px"].shape == (len(s.frame_index), 8)
        code, _, err = run("recplot", out, "--out", tmp_path / "fig.png", "--align", "frame")
        assert code == 0, err
        assert (tmp_path / "fig.png").stat().st_size > 0
    finally:
        if real:
            subprocess.run(["umount", str(disk)], capture_output=True)
