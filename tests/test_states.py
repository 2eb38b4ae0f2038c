"""The adaptive state estimator, scoring, the tracks reader, `whisker states` and `whisker live`."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import run_cli
from whisker.design import load_design
from whisker.sensing.states import (CONTACT, DYNAMIC, REST, AdaptiveEstimator, AuthorsEstimator, StateInputError,
                                    make_estimator)
from whisker.sensing.states_offline import run_estimator, state_scores
from whisker.vision.trackfile import TracksError, read_tracks


@pytest.fixture(scope="module")
def design():
    return load_design()


def _step(fps, n_rest_s=1.5, n_hold_s=1.0, amp=5.0, sigma=0.2, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(0, n_rest_s + n_hold_s, 1 / fps)
    dx = np.where(t >= n_rest_s, amp, 0.0) + rng.normal(0, sigma, t.size)
    dy = rng.normal(0, sigma, t.size)
    return t, dx[:, None], dy[:, None], int(np.argmax(t >= n_rest_s))


@pytest.mark.parametrize("fps", [15, 90])
def test_adaptive_labels_a_held_push_contact_in_the_first_frame(fps):
    t, dx, dy, k0 = _step(fps)
    lab = run_estimator(AdaptiveEstimator(1), t, dx, dy)[:, 0]
    assert np.all(lab[:k0] == REST)
    assert lab[k0] == CONTACT                     # reacts within the frame of the contact
    assert np.mean(lab[k0:] == CONTACT) > 0.97
    # the authors' method needs a full window: dynamic first, contact only ~N frames later
    auth = run_estimator(AuthorsEstimator(1), t, dx, dy)[:, 0]
    assert auth[k0] != CONTACT


def test_own_actuation_is_not_contact_when_the_command_is_known():
    t, dx, dy, k0 = _step(30)
    exp = np.zeros((t.size, 1, 2))
    exp[k0:, 0, 0] = 5.0                           # the coil was told to move it 5 px
    lab = run_estimator(AdaptiveEstimator(1), t, dx, dy, exp)[:, 0]
    assert np.mean(lab[k0:] == REST) > 0.95
    assert np.mean(run_estimator(AdaptiveEstimator(1), t, dx, dy)[k0:, 0] == CONTACT) > 0.95


@settings(max_examples=20, deadline=None)
@given(sigma=st.floats(0.01, 3.0), offset=st.floats(-20, 20), fps=st.sampled_from([15.0, 30.0, 90.0]))
def test_noise_is_learned_per_whisker(sigma, offset, fps):
    """Still whiskers at any offset and any tracking noise stay at rest after the learning second."""
    rng = np.random.default_rng(1)
    t = np.arange(0, 6.0, 1 / fps)
    dx = offset + rng.normal(0, sigma, (t.size, 2))
    dy = rng.normal(0, sigma, (t.size, 2))
    lab = run_estimator(AdaptiveEstimator(2), t, dx, dy)
    assert np.mean(lab == REST) > 0.97


def test_oscillation_is_dynamic_at_any_frame_rate():
    for fps in (15, 90):
        t = np.arange(0, 5.0, 1 / fps)
        rng = np.random.default_rng(2)
        osc = np.where(t > 2.0, 3.0 * np.sin(2 * np.pi * 2.3 * t), 0.0)
        lab = run_estimator(AdaptiveEstimator(1), t, (osc + rng.normal(0, 0.2, t.size))[:, None],
                            rng.normal(0, 0.2, (t.size, 1)))[:, 0]
        assert np.mean(lab[t > 2.6] == DYNAMIC) > 0.9, fps


def test_lost_marker_holds_the_label_and_counts():
    t, dx, dy, k0 = _step(30)
    dx[k0 + 5:k0 + 8] = np.nan
    est = AdaptiveEstimator(1)
    lab = run_estimator(est, t[:k0 + 8], dx[:k0 + 8], dy[:k0 + 8])[:, 0]
    assert np.all(lab[k0 + 4:] == CONTACT) and est.lost[0] == 3


def test_bad_frames_are_refused():
    est = AdaptiveEstimator(2)
    est.update(0.0, [0, 0], [0, 0])
    with pytest.raises(StateInputError, match="increase"):
        est.update(0.0, [0, 0], [0, 0])
    with pytest.raises(StateInputError, match="unknown state method"):
        make_estimator("nope", 2)


def test_state_scores_on_a_hand_case():
    truth = np.array([[0], [0], [1], [1], [1], [0], [2], [2]])
    labels = np.array([[0], [1], [2], [1], [1], [1], [2], [2]])
    sc = state_scores(truth, labels)
    assert sc["accuracy"]["contact"] == pytest.approx(2 / 3)
    assert sc["accuracy"]["rest"] == pytest.approx(1 / 3)
    assert sc["latency"]["contact"] == [1] and sc["latency"]["dynamic"] == [0]
    assert sc["latency"]["rest"] == [] and sc["missed"]["rest"] == 1


def test_adaptive_beats_the_authors_method_on_a_simulated_sequence(design):
    from whisker.sim.experiments.state_sequences import labelled_sequence

    seq = labelled_sequence(design, fps=15, seed=7)
    assert {REST, CONTACT, DYNAMIC} <= set(np.unique(seq.truth))
    bal = {}
    for m in ("authors", "adaptive"):
        lab = run_estimator(make_estimator(m, 8), seq.t_s, seq.dx_px, seq.dy_px, seq.expected_px)
        bal[m] = np.mean(list(state_scores(seq.truth, lab)["accuracy"].values()))
    assert bal["adaptive"] > 0.8 and bal["adaptive"] > bal["authors"] + 0.2


# --- tracks files and commands ------------------------------------------------------------------

def _write_track_csv(path, frames=40, n=2):
    from whisker.vision.trackfile import CSV_HEADER
    rows = [CSV_HEADER]
    for k in range(frames):
        for w in range(n):
            dx = 6.0 if (w == 1 and k >= 30) else 0.01 * ((k * 7 + w) % 5)
            valid = "0" if (w == 0 and k == 35) else "1"
            rows.append(f"{k},{k / 15:.4f},{w},100,100,{dx:.4f},0.0000,{valid},ok,0,0,0,0")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_read_tracks_both_layouts(tmp_path):
    tr = read_tracks(_write_track_csv(tmp_path / "t.csv"))
    assert tr.dx_px.shape == (40, 2) and np.isnan(tr.dx_px[35, 0]) and tr.dx_px[31, 1] == 6.0
    (tmp_path / "a.csv").write_text("Time,dx,dy\n0.0,0,0\n0.1,1.5,2\n")
    tr = read_tracks(tmp_path / "a.csv")
    assert tr.layout == "authors" and tr.dy_px[1, 0] == 2.0
    (tmp_path / "b.csv").write_text("Time,dx,dy\n0.0,0,0\n0.0,1,1\n")
    with pytest.raises(TracksError, match="does not increase"):
        read_tracks(tmp_path / "b.csv")
    (tmp_path / "c.csv").write_text("a,b\n1,2\n")
    with pytest.raises(TracksError, match="unknown columns"):
        read_tracks(tmp_path / "c.csv")


def test_states_command(tmp_path):
    src = _write_track_csv(tmp_path / "t.csv")
    res = run_cli("states", str(src), "--set", "whiskers.count=2", "--out", str(tmp_path / "s.csv"))
    assert res.returncode == 0, res.stderr
    lines = [json.loads(x) for x in res.stdout.splitlines()]
    assert len(lines) == 40 and lines[-1]["states"][1] == "contact" and lines[35]["dx"][0] is None
    body = (tmp_path / "s.csv").read_text().splitlines()
    assert len(body) == 1 + 80 and body[-1].endswith(",contact")
    bad = run_cli("states", str(tmp_path / "missing.csv"))
    assert bad.returncode == 2 and "does not exist" in bad.stderr and "Traceback" not in bad.stderr


def test_live_on_the_simulator_streams_json(tmp_path):
    res = run_cli("live", "--source", "sim", "--fps", "15", "--max-frames", "17", "--record", str(tmp_path / "v.mp4"))
    assert res.returncode == 0, res.stderr
    lines = [json.loads(x) for x in res.stdout.splitlines()]
    assert len(lines) == 17 and all(len(x["states"]) == 8 and all(x["valid"]) for x in lines)
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    bad = run_cli("live", "--source", str(tmp_path / "nothing.mp4"))
    assert bad.returncode == 2 and "Traceback" not in bad.stderr


# --- issue 30: what the estimators cannot decide, and the synthetic source ------------------------

@pytest.fixture(scope="module")
def synthetic_tracks(tmp_path_factory):
    path = tmp_path_factory.mktemp("syn") / "tracks.csv"
    res = run_cli("track", "--source", "synthetic:100", "--out", str(path))
    assert res.returncode == 0, res.stderr
    return path


def test_default_estimator_labels_the_synthetic_swing_dynamic(synthetic_tracks):
    """The synthetic source swings every whisker from its first frame (no rest segment at the
    start): the default estimator must call that motion dynamic (recall >= 0.9), and say where its
    rest reference came from."""
    res = run_cli("states", str(synthetic_tracks))
    assert res.returncode == 0, res.stderr
    states = np.array([json.loads(x)["states"] for x in res.stdout.splitlines()])
    assert states.shape == (100, 8)
    assert np.mean(states == "dynamic") >= 0.9, np.mean(states == "dynamic", axis=0)
    assert "never still" in res.stderr


def test_states_refuses_what_it_cannot_decide(tmp_path, synthetic_tracks):
    lines = synthetic_tracks.read_text().splitlines()
    short = tmp_path / "short.csv"
    short.write_text("\n".join(lines[:1 + 8 * 5]) + "\n")          # 5 frames
    for est in ("adaptive", "authors"):
        res = run_cli("states", str(short), "--estimator", est)
        assert res.returncode == 2 and "cannot decide" in res.stderr and len(res.stderr.splitlines()) == 1, res.stderr
    # a whisker held 8 px off its baseline for the whole recording: contact or displaced rest?
    t = np.arange(0, 3.0, 1 / 15)
    rng = np.random.default_rng(0)
    held = tmp_path / "held.csv"
    held.write_text("Time,dx,dy\n" + "".join(f"{a:.4f},{8 + 3 * np.sin(9 * a) + rng.normal(0, .2):.4f},"
                                             f"{rng.normal(0, .2):.4f}\n" for a in t))
    res = run_cli("states", str(held), "--set", "whiskers.count=1")
    assert res.returncode == 2 and "no rest segment" in res.stderr, res.stderr


@pytest.mark.parametrize("cell,what", [("inf", "not finite"), ("nan", "not finite"), ("abc", "not a number")])
def test_states_refuses_non_finite_tracks(tmp_path, cell, what):
    src = _write_track_csv(tmp_path / "t.csv", n=8)
    rows = src.read_text().splitlines()
    parts = rows[5].split(",")
    parts[5] = cell
    rows[5] = ",".join(parts)
    src.write_text("\n".join(rows) + "\n")
    res = run_cli("states", str(src))
    assert res.returncode == 2 and what in res.stderr and len(res.stderr.splitlines()) == 1, res.stderr
    air = tmp_path / "air.csv"
    air.write_text("Time,dx,dy\n" + "".join(f"{k / 15:.4f},{cell},{cell}\n" for k in range(40)))
    res = run_cli("states", str(air), "--set", "whiskers.count=1")
    assert res.returncode == 2 and what in res.stderr, res.stderr


def test_states_refuses_whiskers_outside_the_design(tmp_path):
    src = _write_track_csv(tmp_path / "t.csv", n=8)
    rows = src.read_text().splitlines()
    rows[3] = rows[3].split(",", 3)[0] + "," + rows[3].split(",", 3)[1] + ",99," + rows[3].split(",", 3)[3]
    src.write_text("\n".join(rows) + "\n")
    res = run_cli("states", str(src))
    assert res.returncode == 2 and "whisker index 99 is outside the design's 8 whiskers" in res.stderr, res.stderr
    empty = tmp_path / "empty.csv"
    empty.write_text("Time,dx,dy\n" + "".join(f"{k / 15:.4f},,\n" for k in range(40)))
    res = run_cli("states", str(empty), "--set", "whiskers.count=1")
    assert res.returncode == 2 and "no valid (finite) displacement" in res.stderr


def test_live_is_not_silent_when_it_decides_nothing():
    res = run_cli("live", "--source", "synthetic:5", "--rest-frames", "1000", "-q")
    assert res.returncode != 0 and "fewer than the 1000 --rest-frames" in res.stderr
    res = run_cli("live", "--source", "synthetic:12", "-q")
    assert res.returncode != 0 and "could decide" in res.stderr


def test_live_on_the_simulator_sees_a_scheduled_contact():
    """`live --source sim --contact`: an object pushing whisker 2 from 1.6 s to 2.6 s is labelled a
    contact on that whisker only; without a stimulus the command says nothing touches the whiskers."""
    res = run_cli("live", "--source", "sim", "--contact", "2:1.6-2.6:6", "--max-frames", "50", "-q")
    assert res.returncode == 0, res.stderr
    recs = [json.loads(x) for x in res.stdout.splitlines()]
    w2 = [r["states"][2] for r in recs if 1.9 <= r["t"] <= 2.5]
    assert w2 and w2.count("contact") >= 0.6 * len(w2), w2
    assert all(s == "rest" for r in recs for i, s in enumerate(r["states"]) if i != 2)
    bad = run_cli("live", "--source", "sim", "--contact", "9:1-2:5", "--max-frames", "2")
    assert bad.returncode == 2 and "whiskers 0-7" in bad.stderr
