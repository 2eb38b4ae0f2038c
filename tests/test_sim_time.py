"""Simulated time is simulated (issue 30): a simulated recording has exactly fps x duration frames,
and the guard's derates and cuts are events in it, whatever the machine's load."""

from __future__ import annotations

import time

import numpy as np
from click.testing import CliRunner

from whisker.cli import main
from whisker.data.session import load_session


def _slow_render(monkeypatch, delay_s):
    from whisker.vision import render

    real = render.render_frame

    def slow(*a, **kw):
        time.sleep(delay_s)              # a busy machine: each frame takes longer than 1/fps
        return real(*a, **kw)

    monkeypatch.setattr(render, "render_frame", slow)


def test_15_fps_for_6_s_is_90_frames_on_a_busy_machine(tmp_path, monkeypatch):
    _slow_render(monkeypatch, 0.075)     # > 1/15 s per frame
    out = tmp_path / "busy"
    t0 = time.monotonic()
    res = CliRunner().invoke(main, ["record", "--source", "sim", "--backend", "sim", "--fps", "15", "--duration", "6",
                                    "--out", str(out), "--no-fsync", "-q"])
    wall = time.monotonic() - t0
    assert res.exit_code == 0, res.output
    s = load_session(out)
    assert len(s.frame_time_s) == 90
    assert wall > 90 * 0.075                                     # the slow step really ran
    np.testing.assert_allclose(np.diff(s.frame_time_s), 1 / 15, atol=1e-6)   # regular simulated time
    assert "simulated" in s.meta["clock"]


def test_15_fps_for_6_s_is_90_frames_on_an_idle_machine(tmp_path):
    out = tmp_path / "idle"
    res = CliRunner().invoke(main, ["record", "--source", "sim", "--backend", "sim", "--fps", "15", "--duration", "6",
                                    "--out", str(out), "--no-fsync", "--no-track", "-q"])
    assert res.exit_code == 0, res.output
    assert len(load_session(out).frame_time_s) == 90


def test_guard_events_are_recorded_and_printed(tmp_path, monkeypatch):
    """A long hold at full level heats the coils past the derate start: the event is a row of
    events.csv, a line on stderr, and an interval recplot shades."""
    from whisker.data.recplot import fig8_data

    out = tmp_path / "hot"
    res = CliRunner().invoke(
        main, ["record", "--source", "sim", "--backend", "sim", "--grasp", "all", "--level", "1", "--hold-level", "1",
               "--hold-s", "3", "--out", str(out), "--no-fsync", "-q"])
    assert res.exit_code == 0, res.stderr
    s = load_session(out)
    kinds = [e[1] for e in s.events]
    assert "derate" in kinds or "cut" in kinds, s.events
    assert any("guard" in line and ("derates" in line or "cuts" in line) for line in res.stderr.splitlines())
    data = fig8_data([s])
    assert data.shades and all(a <= b for a, b, _ in data.shades)
    assert np.isfinite(data.mean).mean() > 0.95          # shaded, not blanked


def test_recplot_names_empty_and_non_finite_frame_tables(tmp_path):
    """An empty frames.csv and NaN frame times are refused with their cause (not "min() arg is an
    empty sequence" or "give a larger --dt")."""
    from conftest import run_cli
    from test_recording_plot import make_trial
    from whisker.design import default_design

    for name, edit in (("empty", lambda rows: rows[:1]),
                       ("nan", lambda rows: rows[:5] + [",".join(["5", "nan"] + rows[5].split(",")[2:])] + rows[6:])):
        folder = tmp_path / name
        make_trial(folder, default_design(), offset_s=0.2, amplitude=2.0)
        rows = (folder / "frames.csv").read_text().splitlines()
        (folder / "frames.csv").write_text("\n".join(edit(rows)) + "\n")
        res = run_cli("recplot", str(folder), "--out", str(tmp_path / f"{name}.png"))
        assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert ("no frames" if name == "empty" else "frame times that are not finite") in res.stderr, res.stderr
        assert "larger --dt" not in res.stderr and "min() arg" not in res.stderr
