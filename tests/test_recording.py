"""Recording sessions: one clock, a table per stream, crash safety (SIGKILL), replay via whisker track."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli
from whisker.design import default_design
from whisker.data.recording import Recorder, RecordingError
from whisker.data.session import load_session, read_table

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def design():
    return default_design()


def frame_image(i, h=48, w=64):
    """A deterministic test image for frame i (so a reader can check every pixel)."""
    rng = np.random.default_rng(i)
    return rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)


def test_round_trip(design, tmp_path):
    out = tmp_path / "s"
    with Recorder(out, design, meta={"trial": "t1"}) as rec:
        for i in range(5):
            rows = [f"{i},0.1,{w},1,2,{w * 0.5},0,1,ok,0.1,0.2,0.3,64" for w in range(8)]
            rec.write_frame(i, frame_image(i), source_time_s=i / 30, track_rows=rows)
            rec.log_actuation(rec.t0 + 0.01 * i, "retract" if i < 3 else "hold", np.full(8, 0.5), np.full(8, 0.4))
            rec.log_guard(np.full(8, 25.0 + i))
    s = load_session(out)
    assert s.complete and s.meta["trial"] == "t1" and s.meta["frame_count"] == 5
    assert s.meta["design"] == design.to_dict() and s.meta["digest"] == design.digest()
    assert s.frame_index.tolist() == list(range(5))
    assert np.all(np.diff(s.frame_time_s) >= 0)
    assert s.tracks["dx_px"].shape == (5, 8) and s.tracks["dx_px"][3, 4] == 2.0
    assert np.allclose(s.displacement("px")[:, 2], 1.0)
    assert s.act_applied.shape == (5, 8) and np.allclose(s.act_applied, 0.4)
    assert [p for _, p in s.phase_times()] == ["retract", "hold"]
    assert s.act_time_s[1] == pytest.approx(0.01, abs=1e-6)
    assert np.allclose(s.guard_temperatures[:, 0], 25 + np.arange(5))
    import cv2

    for i, f in enumerate(s.frame_files):
        assert np.array_equal(cv2.imread(str(out / "frames" / f)), frame_image(i))


def test_refuses_existing_session_and_bad_rows(design, tmp_path):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "x").write_text("keep me")
    with pytest.raises(RecordingError, match="not empty"):
        Recorder(tmp_path / "s", design)
    with pytest.raises(RecordingError, match="image format"):
        Recorder(tmp_path / "t", design, image_format="gif")
    rec = Recorder(tmp_path / "u", design)
    with pytest.raises(RecordingError, match="13 columns"):
        rec.write_frame(0, frame_image(0), track_rows=["0,1,2"])
    rec.close()
    with pytest.raises(RecordingError, match="not a recording session"):
        load_session(tmp_path / "s")
    (tmp_path / "s" / "metadata.json").write_text("{")
    with pytest.raises(RecordingError, match="unreadable metadata"):
        load_session(tmp_path / "s")


def test_torn_last_line_is_dropped(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("a,b\n1,2\n3,4\n5,")
    assert read_table(p) == {"a": ["1", "3"], "b": ["2", "4"]}
    p.write_text("a,b\n1,2\n3\n")  # a short row (never written by the recorder) is skipped too
    assert read_table(p) == {"a": ["1"], "b": ["2"]}
    assert read_table(tmp_path / "missing.csv") == {}


def test_jpg_and_missing_image(design, tmp_path):
    with Recorder(tmp_path / "s", design, image_format="jpg") as rec:
        rec.write_frame(0, frame_image(0))
        rec.write_frame(1, None)  # unreadable camera frame: row kept, no file
    s = load_session(tmp_path / "s")
    assert s.frame_files == ["000000.jpg", ""]


CHILD = textwrap.dedent('''
    import sys, time
    import numpy as np
    sys.path.insert(0, {tests!r})
    from test_recording import frame_image
    from whisker.design import default_design
    from whisker.data.recording import Recorder

    d = default_design()
    rec = Recorder(sys.argv[1], d, fsync=sys.argv[2] == "fsync")
    i = 0
    while True:
        rows = [f"{{i}},0,{{w}},{{i}},{{w}},{{i * 0.01}},0,1,ok,0,0,0,64" for w in range(8)]
        rec.log_actuation(rec.clock(), "retract", np.full(8, i % 7 / 10), np.full(8, i % 7 / 10))
        rec.write_frame(i, frame_image(i), track_rows=rows)
        print(i, flush=True)
        i += 1
''')


@pytest.mark.parametrize("durability", ["fsync", "flush"])
def test_sigkill_mid_recording_keeps_every_completed_frame(tmp_path, durability):
    script = tmp_path / "child.py"
    script.write_text(CHILD.format(tests=str(ROOT / "tests")))
    out = tmp_path / "session"
    p = subprocess.Popen([sys.executable, str(script), str(out), durability], stdout=subprocess.PIPE, text=True,
                         cwd=ROOT)
    done = -1
    try:
        while done < 25:
            line = p.stdout.readline()
            assert line, "the recorder child died"
            done = int(line)
    finally:
        p.send_signal(signal.SIGKILL)
        # read the rest through the same buffered reader as readline(): lines it already holds count too
        # (communicate(timeout=...) reads the raw pipe and would miss them, under-counting the frames)
        rest = p.stdout.read()
        p.wait(timeout=30)
    assert p.returncode == -signal.SIGKILL
    reported = [int(x) for x in rest.split()] or [done]
    last_reported = max(done, *reported)
    s = load_session(out)
    assert not s.complete  # killed: metadata never marked complete
    # every frame the child reported as written is there, in order, with its image and tracks
    assert s.frame_index.tolist()[: last_reported + 1] == list(range(last_reported + 1))
    assert len(s.frame_index) <= last_reported + 2  # at most the one being written when killed
    import cv2

    for i, f in zip(s.frame_index, s.frame_files):
        assert np.array_equal(cv2.imread(str(out / "frames" / f)), frame_image(int(i)))
    assert np.allclose(s.tracks["x_px"], s.frame_index[:, None])
    assert np.allclose(s.tracks["dx_px"][:, 0], s.frame_index * 0.01)
    assert len(s.act_time_s) >= len(s.frame_index)
    # no temporary or torn file is mistaken for a frame
    assert not [f for f in os.listdir(out / "frames") if f.endswith(".png") and not f[:6].isdigit()]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec") / "grasp"
    # The synthetic source is not paced: keep the grasp (60 ms) far shorter than rendering and writing
    # 35 frames takes even on an idle machine, so the whole sequence is recorded.
    res = run_cli("record", "--source", "synthetic:40", "--out", str(out), "--backend", "mock",
                  "--grasp", "every-second", "--retract-s", "0.02", "--hold-s", "0.02", "--release-s", "0.02",
                  "--tail-s", "5", "--trial", "test", "-q")
    assert res.returncode == 0, res.stderr
    return out


def test_cli_record_grasp_session(recorded):
    s = load_session(recorded)
    assert s.complete and s.meta["trial"] == "test" and s.meta["source"] == "synthetic:40"
    assert len(s.frame_index) == 40 and all((recorded / "frames" / f).exists() for f in s.frame_files)
    phases = [p for _, p in s.phase_times()]
    assert phases[:5] == ["neutral", "retract", "hold", "release", "neutral"]
    retract = s.act_applied[[p == "retract" for p in s.act_phase]][0]
    assert np.flatnonzero(retract).tolist() == [0, 2, 4, 6]
    assert s.tracks["x_px"].shape == (40, 8) and np.all(s.tracks["valid"] == 1)
    # one clock: actuation times lie within the recording's frame times
    assert s.frame_time_s[0] <= s.phase_times()[1][0] <= s.frame_time_s[-1]
    assert s.meta["guard"]["policy"] == "derate" and len(s.meta["sequence"]) == 4


def test_recording_replays_through_whisker_track(recorded, tmp_path):
    csv = tmp_path / "replay.csv"
    res = run_cli("track", "--source", str(recorded / "frames"), "--out", str(csv), "-q")
    assert res.returncode == 0, res.stderr
    replay = read_table(csv)
    s = load_session(recorded)
    x = np.array(replay["x_px"], dtype=float).reshape(-1, 8)
    assert x.shape == s.tracks["x_px"].shape
    assert np.allclose(x, s.tracks["x_px"], atol=1e-3)  # PNG frames are lossless


def _start_long_recording(out):
    """`whisker record` of a grasp whose hold lasts 100 s, in a subprocess, to be interrupted."""
    return subprocess.Popen([sys.executable, "-m", "whisker.cli", "record", "--source", "synthetic:400", "--out",
                             str(out), "--backend", "mock", "--grasp", "all", "--hold-s", "100", "-q"],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def test_cli_record_sigkill(tmp_path):
    """`whisker record` killed with SIGKILL mid-recording: the session reads back, frames replay."""
    out = tmp_path / "killed"
    p = _start_long_recording(out)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            fr = read_table(out / "frames.csv")
            if len(fr.get("frame", [])) >= 8:
                break
            assert p.poll() is None, p.stderr.read().decode()
            time.sleep(0.1)
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=30)
    s = load_session(out)
    assert not s.complete and len(s.frame_index) >= 8
    assert np.all(np.isfinite(s.tracks["x_px"]))
    assert "retract" in s.act_phase
    res = run_cli("track", "--source", str(out / "frames"), "-q")
    assert res.returncode == 0, res.stderr


def test_sim_end_to_end_actuation_moves_tracked_markers(tmp_path):
    """--source sim --backend sim: the grasp moves the simulated whiskers, the tracker sees it."""
    out = tmp_path / "sim"
    # retract + hold = 0.7 s: the guard starts derating a coil held at 3 V after 0.78 s (PWM from the
    # 7.5 V supply's 5.24 V full scale, benchmarks/results/actuation.md), and this test is about motion
    res = run_cli("record", "--source", "sim", "--backend", "sim", "--out", str(out), "--grasp", "opposite",
                  "--retract-s", "0.5", "--hold-s", "0.2", "--release-s", "0.6", "--tail-s", "0.2",
                  "--fps", "10", "--rest-frames", "3", "-q")
    assert res.returncode == 0, res.stderr
    s = load_session(out)
    d = s.displacement("px")
    t_ret = dict((p, t) for t, p in reversed(s.phase_times()))["retract"]
    t_rel = [t for t, p in s.phase_times() if p == "release"][0]
    rest = s.frame_time_s < t_ret
    held = (s.frame_time_s > t_ret + 0.4) & (s.frame_time_s < t_rel)
    assert rest.sum() >= 2 and held.sum() >= 1
    active = [0, 4]
    idle = [1, 2, 3, 5, 6, 7]
    assert np.nanmin(d[held][:, active]) > 5.0  # px: the driven whiskers retract visibly
    assert np.nanmax(d[rest]) < 1.0 and np.nanmax(d[held][:, idle]) < 1.0


def test_cli_record_sigterm_switches_off_and_closes_cleanly(tmp_path):
    out = tmp_path / "term"
    p = _start_long_recording(out)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if "retract" in read_table(out / "actuation.csv").get("phase", []):
                break
            assert p.poll() is None, p.stderr.read().decode()
            time.sleep(0.1)
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 128 + signal.SIGTERM
    s = load_session(out)
    assert s.complete and s.meta["stopped_by"] == "Terminated"
    assert s.act_phase[-1] == "off" and np.all(s.act_applied[-1] == 0)
    assert np.any(s.act_applied[:-1] > 0)
    assert s.meta["guard"]["policy"] == "derate"


def test_record_with_a_sequence_file(tmp_path):
    from click.testing import CliRunner

    from whisker.cli import main

    f = tmp_path / "s.toml"
    f.write_text('[[step]]\nphase = "pulse"\nduration_s = 0.1\nconfig = 2\nvolts = 2.0\n'
                 '[[step]]\nphase = "neutral"\nduration_s = 0.0\n')
    out = tmp_path / "rec"
    r = CliRunner().invoke(main, ["record", "--source", "synthetic:10", "--out", str(out), "--backend", "mock",
                                  "--sequence", str(f), "--rest-frames", "3", "-q"])
    assert r.exit_code == 0, r.stderr
    s = load_session(out)
    assert "pulse" in s.act_phase and s.meta["sequence"][0]["phase"] == "pulse"
    pulse = s.act_applied[s.act_phase.index("pulse")]
    assert np.flatnonzero(pulse).tolist() == [0, 4] and pulse[0] > 0
    r = CliRunner().invoke(main, ["record", "--source", "synthetic:3", "--out", str(tmp_path / "x"),
                                  "--sequence", str(f), "--grasp", "all", "--backend", "mock"])
    assert r.exit_code == 2 and "not both" in r.stderr
