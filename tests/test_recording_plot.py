"""Fig. 8 from recordings: mean and band across trials, aligned on the retract command."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import run_cli
from whisker.design import default_design
from whisker.data.recording import Recorder
from whisker.data.session import load_session
from whisker.data.recplot import fig8_data, plot_fig8

FPS = 20.0


def make_trial(folder, design, *, offset_s, amplitude, jitter=0.0, seed=0, invalid=()):
    """A session whose whisker w moves amplitude*(w+1) px from the retract command to the release.

    Frames start `offset_s` before the retract command, so trials are misaligned in session time.
    """
    rng = np.random.default_rng(seed)
    t_frames = np.arange(60) / FPS + rng.uniform(0, jitter, 60)
    t_retract, t_hold, t_release = offset_s, offset_s + 0.5, offset_s + 1.5
    with Recorder(folder, design) as rec:
        for phase, t in (("retract", t_retract), ("hold", t_hold), ("release", t_release)):
            lv = np.full(8, 0.9 if phase != "release" else 0.0)
            rec.log_actuation(rec.t0 + t, phase, lv, lv)
        for i, t in enumerate(t_frames):
            on = t_retract <= t < t_release
            rows = []
            for w in range(8):
                dx = amplitude * (w + 1) if on else 0.0
                valid = 0 if (i, w) in invalid else 1
                rows.append(f"{i},{t},{w},0,0,{dx},0,{valid},ok,0,0,0,64")
            rec.write_frame(i, None, time_s=float(t), track_rows=rows)
    return load_session(folder)


def test_mean_band_and_phases(tmp_path):
    d = default_design()
    trials = [make_trial(tmp_path / f"t{k}", d, offset_s=0.5 + 0.25 * k, amplitude=1.0 + 0.2 * k, seed=k)
              for k in range(3)]
    data = fig8_data(trials, dt_s=0.05)
    assert data.trials == 3 and data.mean.shape[1] == 8
    # aligned: time 0 = each trial's retract command; phases at their mean offsets
    assert data.phases == pytest.approx({"retract": 0.0, "hold": 0.5, "release": 1.5})
    mid = np.argmin(np.abs(data.t_s - 1.0))  # well inside the hold
    amps = np.array([1.0, 1.2, 1.4])
    for w in range(8):
        assert data.mean[mid, w] == pytest.approx(amps.mean() * (w + 1))
        sd = amps.std() * (w + 1)
        assert data.band_hi[mid, w] - data.mean[mid, w] == pytest.approx(sd)
    before = np.argmin(np.abs(data.t_s + 0.3))
    assert np.allclose(data.mean[before], 0) and np.allclose(data.band_hi[before], 0)
    # trial 0 starts recording 0.5 s before its retract, trial 2 1.0 s before: fewer trials early
    assert data.count[0, 0] == 1 and data.count[mid, 0] == 3
    out = plot_fig8(data, tmp_path / "fig8.png", title="test")
    assert out.stat().st_size > 10_000
    plot_fig8(data, tmp_path / "fig8_grid.png", grid=True)
    assert (tmp_path / "fig8_grid.png").stat().st_size > 10_000


def test_invalid_frames_and_single_trial(tmp_path):
    d = default_design()
    invalid = {(i, 3) for i in range(20, 24)} | {(i, 5) for i in range(60)}
    s = make_trial(tmp_path / "a", d, offset_s=0.5, amplitude=2.0, jitter=0.01, invalid=invalid)
    data = fig8_data([s], band="minmax")
    assert np.all(np.isnan(data.mean[:, 5]))  # never valid: no line, no invented numbers
    assert np.isfinite(data.mean[:, 3]).sum() > 40  # the 0.25 s gap stays open (default: 3 grid steps) ...
    data_wide = fig8_data([s], band="sem", max_gap_s=0.3)
    assert np.isfinite(data_wide.mean[:, 3]).sum() > np.isfinite(data.mean[:, 3]).sum()  # ... unless bridged
    assert np.allclose(np.nan_to_num(data.band_hi - data.band_lo), 0)  # one trial: no spread
    plot_fig8(data, tmp_path / "one.svg")
    assert (tmp_path / "one.svg").read_text().startswith("<?xml")


def test_refusals(tmp_path):
    d = default_design()
    s = make_trial(tmp_path / "a", d, offset_s=0.2, amplitude=1.0)
    with pytest.raises(ValueError, match="no sessions"):
        fig8_data([])
    with pytest.raises(ValueError, match="band"):
        fig8_data([s], band="iqr")
    with pytest.raises(ValueError, match="positive"):
        fig8_data([s], dt_s=0.0)
    with pytest.raises(ValueError, match="displacement quantity"):
        fig8_data([s], quantity="furlongs")
    six = default_design("whiskers.count=6")
    with Recorder(tmp_path / "six", six) as rec:
        rec.write_frame(0, None, track_rows=[f"0,0,{w},0,0,0,0,1,ok,0,0,0,64" for w in range(6)])
    with pytest.raises(ValueError, match="different whisker counts"):
        fig8_data([s, load_session(tmp_path / "six")])
    with Recorder(tmp_path / "untracked", d) as rec:
        rec.write_frame(0, None)
    with pytest.raises(ValueError, match="no tracks"):
        fig8_data([load_session(tmp_path / "untracked")])


def test_cli(tmp_path):
    d = default_design()
    folders = [str(make_trial(tmp_path / f"t{k}", d, offset_s=0.3, amplitude=1 + k).folder) for k in range(2)]
    out = tmp_path / "fig.png"
    res = run_cli("recplot", *folders, "--out", str(out), "--quantity", "px")
    assert res.returncode == 0, res.stderr
    assert out.exists() and out.with_suffix(".csv").read_text().startswith("t_s,mean_0,lo_0,hi_0,count_0")
    bad = run_cli("recplot", str(tmp_path), "--out", str(tmp_path / "x.png"))
    assert bad.returncode == 2 and "not a recording session" in bad.stderr
