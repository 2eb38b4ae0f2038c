"""Simulated time is simulated (issue 30): a simulated recording has exactly fps x duration frames,
and the guard's derates and cuts are events in it, whatever the machine's load."""

from __future__ import annotations

import time

import numpy as np
from click.testing import CliRunner

from whisker.cli import main
from whisker.data.recording import load_session


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
