"""whisker.sensing.locate (contact distance by active whisking) against its simulator, and `whisker locate`."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import run_cli
from whisker.design import default_design
from whisker.sensing import locate as L
from whisker.sim.experiments import locate_sweep as S

DESIGN = default_design()


def _sweep(case, noise=None, seed=0, amplitude=L.DEFAULT_AMPLITUDE, sweep=True):
    t, lev = L.sweep_levels(amplitude if sweep else 0.0, L.DEFAULT_DURATION_S, 120.0)
    tilt = np.zeros((len(t), 2))
    for _ in range(3):
        tilt = S.response(DESIGN, case, L.coil_torque_Nmm(DESIGN, lev, tilt[:, 0]))
    if noise is not None:
        tilt = tilt + noise[np.random.default_rng(seed).integers(len(noise), size=len(t))]
    return L.Sweep(t, lev, tilt)


@settings(max_examples=25, deadline=None)
@given(st.floats(10.0, 60.0), st.floats(0.0, 10.0), st.floats(1.0, 5.0))
def test_noiseless_rigid_contact_is_located_exactly(r, approach, preload):
    """The simulator solves moment balance, beam and contact frame by frame; the estimator inverts the
    closed form K = k + 3EI/r: on noiseless stick contacts they must agree."""
    res = L.estimate(DESIGN, _sweep(S.Case(r, None, approach, preload)))
    assert res.status == "ok", res.message
    assert res.distance_mm == pytest.approx(r, rel=2e-3)
    truth_mN = 1e3 * L.membrane_stiffness_Nmm_per_rad(DESIGN)[0] * math.radians(preload) / r
    assert res.force_mN == pytest.approx(truth_mN, rel=0.02)


@pytest.fixture(scope="module")
def tracker_noise():
    """The real tracker's tilt error on 40 rendered rest frames (small: the benchmark uses 200)."""
    bank = S.tracker_noise_bank(DESIGN, 40)
    bank = bank[np.isfinite(bank).all(axis=1)]
    assert len(bank) >= 35 and 1e-6 < bank.std() < 1e-3
    return bank - bank.mean(axis=0)


def test_small_case_with_tracker_noise_meets_a_loose_bound(tracker_noise):
    """Looser than the benchmark's bar (median <= 2 mm, p90 <= 5 mm over 10-60 mm): 3 distances x 2 seeds."""
    err = []
    for r in (15.0, 35.0, 55.0):
        for seed in range(2):
            res, truth = S.run_case(DESIGN, S.Case(r), noise=tracker_noise, seed=seed, fps=120.0)
            assert res.status == "ok", res.message
            err.append(abs(res.distance_mm - r))
    assert np.median(err) <= 4.0 and max(err) <= 10.0, err


def test_without_the_sweep_there_is_no_number(tracker_noise):
    res, _ = S.run_case(DESIGN, S.Case(30.0), noise=tracker_noise, sweep=False)
    assert res.status == "refused" and "without actuation" in res.message
    with pytest.raises(L.LocateError, match="without actuation"):
        L.estimate(DESIGN, _sweep(S.Case(30.0), sweep=False))


def test_free_whisker_is_no_contact():
    t, lev = L.sweep_levels(L.DEFAULT_AMPLITUDE, 1.0, 120.0)
    k = L.membrane_stiffness_Nmm_per_rad(DESIGN)[0]
    tilt = np.zeros((len(t), 2))
    for _ in range(3):   # the coil's torque depends on the tilt (the gap closes): a free whisker's fixed point
        tilt = np.stack([L.coil_torque_Nmm(DESIGN, lev, tilt[:, 0]) / k, np.zeros(len(t))], axis=1)
    res = L.estimate(DESIGN, L.Sweep(t, lev, tilt))
    assert res.status == "no contact" and res.distance_mm is None


def test_slip_and_soft_objects_get_no_distance():
    res = L.estimate(DESIGN, _sweep(S.Case(30.0, None, approach_deg=40.0)))
    assert res.status == "slip or soft contact" and res.distance_mm is None
    res = L.estimate(DESIGN, _sweep(S.Case(15.0, "acrylic pile")))
    assert res.status == "slip or soft contact" and res.distance_mm is None


def test_known_compliance_removes_the_soft_object_bias():
    case = S.Case(30.0, "polyolefin foam")
    naive = L.estimate(DESIGN, _sweep(case))
    known = L.estimate(DESIGN, _sweep(case), contact_indentation_mm=S.hertz_compliance(DESIGN, case.material)[0])
    # Hertz makes the total compliance r/(3EI) + c/r^2 non-monotone: the truth is among the candidates
    found = [known.distance_mm] if known.status == "ok" else known.details.get("candidates_mm", [])
    assert known.status in ("ok", "ambiguous") and min(abs(np.array(found) - 30.0)) < 1.0, known.message
    assert naive.status != "ok" or naive.distance_mm > 35.0       # a soft object reads farther out


def test_thermal_limit_and_rating_refusals():
    heat = L.check_sweep(DESIGN, L.DEFAULT_AMPLITUDE, L.DEFAULT_DURATION_S)
    assert 0 < heat["rise_K"] and heat["peak_C"] <= heat["cut_C"]
    with pytest.raises(L.LocateError, match="thermal guard"):
        L.check_sweep(DESIGN, 1.0, 10.0)
    with pytest.raises(L.LocateError, match="thermal guard"):
        L.check_sweep(DESIGN, 1.0, 1.0, start_C=62.0)   # the resin at the winding derates from 63 C
    with pytest.raises(L.LocateError, match="largest level"):
        L.check_sweep(DESIGN, 1.5, 0.5)


def test_bad_arrays_are_refused():
    t, lev = L.sweep_levels(1.0, 1.0, 120.0)
    with pytest.raises(L.LocateError, match="disagree"):
        L.estimate(DESIGN, L.Sweep(t, lev, np.zeros((len(t) - 1, 2))))
    tilt = np.full((len(t), 2), np.nan)
    with pytest.raises(L.LocateError, match="tracked frames"):
        L.estimate(DESIGN, L.Sweep(t, lev, tilt))


def test_cli_help_and_refusals():
    res = run_cli("locate", "--help")
    assert res.returncode == 0 and "mm" in res.stdout and "N*mm" in res.stdout
    res = run_cli("locate")
    assert res.returncode == 2 and "SESSION" in res.stderr
    res = run_cli("locate", "--simulate", "30", "--duration", "10")
    assert res.returncode == 2 and "thermal guard" in res.stderr and len(res.stderr.strip().splitlines()) == 1


def test_cli_reads_a_recorded_session(tmp_path):
    """A `whisker record` session: actuation + tracks -> a status; without actuation rows -> refusal."""
    from test_recording_plot import make_trial
    from whisker.data.recording import Recorder

    make_trial(tmp_path / "swept", DESIGN, offset_s=0.2, amplitude=0.0)     # levels change, tips never move
    res = run_cli("locate", str(tmp_path / "swept"), "--whisker", "2", "--out", str(tmp_path / "out"))
    assert res.returncode == 0 and res.stdout.startswith("not observable"), res.stdout + res.stderr
    assert (tmp_path / "out" / "locate.md").is_file() and (tmp_path / "out" / "locate.png").is_file()
    with Recorder(tmp_path / "still", DESIGN) as rec:
        for i in range(20):
            rec.write_frame(i, None, time_s=i / 30, track_rows=[f"{i},{i / 30},{w},0,0,0,0,1,ok,0,0,0,64"
                                                                for w in range(8)])
    res = run_cli("locate", str(tmp_path / "still"))
    assert res.returncode == 2 and "without actuation" in res.stderr


def test_real_jitter_series_keeps_the_still_runs_only(tmp_path):
    """peer_jitter_series on a file like the authors' airflow demo: the still runs, each minus its mean,
    px -> rad by the marker lever; the moving part and its jumps are dropped."""
    rng = np.random.default_rng(1)
    t = np.arange(400) / 65.0
    xy = rng.normal(0.0, 0.1, (400, 2))
    xy[150:250] += np.linspace(0, 20, 100)[:, None]          # an air puff: the whisker moves 20 px
    xy[250:] += 20.0                                          # and holds there
    f = tmp_path / "air.csv"
    f.write_text("Time,dx,dy\n" + "\n".join(f"{a},{b},{c}" for a, (b, c) in zip(t, xy)))
    series, fps = S.peer_jitter_series(DESIGN, f)
    px_per_rad = DESIGN.derived()["l_l_mm"] / DESIGN.derived()["mm_per_px"]
    assert fps == pytest.approx(65.0, rel=1e-6)
    assert 200 <= len(series) < 400 and np.abs(series).max() * px_per_rad < 1.0
    assert series[:, 0].std() * px_per_rad == pytest.approx(0.1, rel=0.2)
    blocks = S.draw_noise(series, 100, np.random.default_rng(0), block=10)
    assert blocks.shape == (100, 2)
    i = int(np.flatnonzero((series == blocks[0]).all(axis=1))[0])
    assert np.array_equal(blocks[:10], series[i:i + 10])      # a block is a run of consecutive frames
