"""Property tests of the pure parts of the calibration: wiring diagnosis and design-file edits."""

from __future__ import annotations

import types

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.design.edit import set_keys
from whisker.bringup.wiring import diagnose, override_for


@st.composite
def harness(draw):
    n = draw(st.integers(2, 12))
    perm = draw(st.permutations(list(range(n))))
    signs = draw(st.lists(st.sampled_from([1, -1]), min_size=n, max_size=n))
    return n, list(perm), signs


@settings(max_examples=60, deadline=None)
@given(harness(), st.floats(1.5, 20.0), st.integers(0, 2**16))
def test_diagnosis_recovers_any_permutation_and_polarity(h, move_px, seed):
    n, perm, signs = h
    rng = np.random.default_rng(seed)
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    rest = 320 + 120 * np.column_stack([np.cos(ang), np.sin(ang)])
    out_dir = np.column_stack([np.cos(ang), np.sin(ang)])
    resp = rng.normal(0, 0.05, (n, n, 2))                  # tracking noise on every marker
    for ch in range(n):
        resp[ch, perm[ch]] += signs[ch] * move_px * out_dir[perm[ch]]
    diag = diagnose(resp, rest)
    assert diag.marker_of == perm and diag.sign == signs and not diag.dead
    assert diag.reversed == [i for i in range(n) if signs[i] < 0]
    assert sorted(i for c in diag.swapped for i in c) == [i for i in range(n) if perm[i] != i]
    # the override routes whisker w to the channel that moves marker w, with the sign that retracts
    design = types.SimpleNamespace(wiring=types.SimpleNamespace(coil_order=(), coil_polarity=()))
    order, pol = override_for(design, diag)
    for w in range(n):
        assert perm[order[w]] == w and pol[w] * signs[order[w]] == 1


@settings(max_examples=40, deadline=None)
@given(st.dictionaries(st.sampled_from(["a", "b_c", "gap", "coil_order"]), st.integers(-5, 5), min_size=1),
       st.booleans())
def test_set_keys_sets_exactly_the_given_keys(values, section_exists):
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover
        import tomli as tomllib
    text = "[top]\nx = 1  # kept\n" + ("\n[sec]\na = 0\nother = 2\n               # a continuation\n" if section_exists else "") \
        + "\n[tail]\ny = 3\n"
    out = tomllib.loads(set_keys(text, "sec", {k: str(v) for k, v in values.items()}, "why"))
    assert out["top"] == {"x": 1} and out["tail"] == {"y": 3}
    want = ({"a": 0, "other": 2} if section_exists else {}) | values
    assert out["sec"] == want
