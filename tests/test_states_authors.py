"""The authors' live state method (whisker.sensing.states.AuthorsEstimator) against their own code.

The oracle is the authors' published code itself (Hu et al., MIT licence), not a copy: the test
reads `airflowCharacterizationRealtime.py` and `airflowCharacterizationOffline.py` from a checkout
of their repository (env WHISKER_PEER_CODE, e.g. `git clone
https://github.com/ZhixianHu/Vibrissae-Inspired-Vision-Based-Magnetic-Actuated-Whisker`) and executes
only their function definitions (`fftProcess`, `flowProcess`, `dataSmooth`, `classify_offline`),
because importing the realtime script would open the Pi camera libraries and create folders.
"""

from __future__ import annotations

import ast
import copy
import os
from pathlib import Path

import numpy as np
import pytest

from conftest import peer_data
from whisker.sensing.states import CONTACT, DYNAMIC, REST, AuthorsEstimator, AuthorsParams
from whisker.sensing.states_offline import run_estimator


def peer_code() -> Path | None:
    p = os.environ.get("WHISKER_PEER_CODE")
    if p and (Path(p) / "airflowCharacterizationRealtime.py").is_file():
        return Path(p)
    return None


def _their_functions(folder: Path) -> dict:
    """Execute only the named top-level function definitions of the authors' two scripts."""
    import scipy.signal as signal
    from scipy.fftpack import fft, ifft

    ns = {"np": np, "signal": signal, "fft": fft, "ifft": ifft, "copy": copy}
    wanted = {"airflowCharacterizationRealtime.py": {"fftProcess", "flowProcess", "dataSmooth"},
              "airflowCharacterizationOffline.py": {"classify_offline"}}
    for fname, names in wanted.items():
        tree = ast.parse((folder / fname).read_text())
        defs = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name in names]
        assert {d.name for d in defs} == names, f"{fname} no longer defines {names}"
        exec(compile(ast.Module(body=defs, type_ignores=[]), str(folder / fname), "exec"), ns)
    return ns


def _demo():
    data = peer_data()
    arr = np.genfromtxt(data / "airflow" / "airflowDemoData.csv", delimiter=",", names=True)
    return arr["Time"], arr["dx"][:, None], arr["dy"][:, None]


needs_both = pytest.mark.skipif(
    peer_data() is None or peer_code() is None,
    reason="WHISKER_PEER_DATA (the authors' demo CSV) and WHISKER_PEER_CODE (a checkout of their "
           "repository, the oracle) must both be set")


@needs_both
@pytest.mark.parametrize("window", [30, 15])
def test_every_demo_frame_matches_their_code(window):
    t, dx, dy = _demo()
    ns = _their_functions(peer_code())
    theirs, _ = ns["classify_offline"](t, dx, dy, T=1 / 15, N=window, smooth_threshold=1.0)
    theirs = np.asarray(theirs)
    ours = run_estimator(AuthorsEstimator(1, AuthorsParams(window=window)), t, dx, dy)
    assert ours.shape == theirs.shape == (2337, 1)
    mismatch = np.flatnonzero(ours[:, 0] != theirs[:, 0])
    assert mismatch.size == 0, f"{mismatch.size} frames differ, first at {mismatch[:5]}"
    # the demo exercises all three states, so agreement is not trivial
    assert set(np.unique(theirs)) == {REST, CONTACT, DYNAMIC}


@needs_both
def test_multi_whisker_layout_matches_their_code():
    """Eight whiskers made from shifted copies of the demo: whiskers are independent in both."""
    t, dx, dy = _demo()
    shifts = [0, 100, 250, 400, 700, 900, 1200, 1500]
    dx8 = np.stack([np.roll(dx[:, 0], s) for s in shifts], axis=1)
    dy8 = np.stack([np.roll(dy[:, 0], s) for s in shifts], axis=1)
    ns = _their_functions(peer_code())
    theirs, _ = ns["classify_offline"](t, dx8, dy8)
    ours = run_estimator(AuthorsEstimator(8), t, dx8, dy8)
    np.testing.assert_array_equal(ours, np.asarray(theirs))


def _labels(dx, dy=None, **kw):
    dx = np.asarray(dx, float)[:, None]
    dy = np.zeros_like(dx) if dy is None else np.asarray(dy, float)[:, None]
    return run_estimator(AuthorsEstimator(1, AuthorsParams(**kw)), np.arange(len(dx)) / 15, dx, dy)[:, 0]


def test_still_whisker_is_rest_and_held_deflection_is_contact():
    assert np.all(_labels(np.zeros(80)) == REST)
    step = np.r_[np.zeros(40), np.full(80, 8.0)]          # pushed 8 px and held
    lab = _labels(step)
    assert np.all(lab[:40] == REST)
    # While the step is inside the 30-frame window its spectrum is not flat and the edge sample
    # is no find_peaks peak, so the method says dynamic until the step leaves the window ...
    assert np.all(lab[40:69] == DYNAMIC)
    # ... then the window's peak jumps by 8 > 4 px (contact), and stays static beyond sqrt(13).
    assert np.all(lab[69:] == CONTACT)


def test_oscillation_is_dynamic_and_small_wobble_is_smoothed_away():
    k = np.arange(120)
    lab = _labels(3.0 * np.sin(2 * np.pi * 3.0 * k / 15))   # 3 Hz, 3 px: FFT peak >> 5
    assert np.mean(lab[40:] == DYNAMIC) > 0.9
    wobble = 0.9 * np.sin(2 * np.pi * 2.0 * k / 15)         # every change <= 1 px: held at 0
    assert np.all(_labels(wobble) == REST)


def test_bad_input_is_refused():
    from whisker.sensing.states import StateInputError
    est = AuthorsEstimator(2)
    with pytest.raises(StateInputError, match="expected 2 whiskers"):
        est.update(0.0, [1.0], [1.0])
    with pytest.raises(StateInputError, match="FFT bin"):
        AuthorsParams(window=3)
