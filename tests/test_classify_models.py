"""whisker.data.models / features / symmetry: the classifiers beyond the paper's MLP and the pairing test."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import peer_data, run_cli
from test_dataset import synthetic
from whisker.data import classify as C
from whisker.data.dataset import PAPER_OBJECTS, augment_rotations, rotate
from whisker.data.dataset_files import load_peer, write_csv_folder
from whisker.data.features import CyclicDFTFeatures, PolarFeatures
from whisker.data.models import KINDS, make_model
from whisker.data.symmetry import contact_pattern, pairing_table


@settings(max_examples=40, deadline=None)
@given(st.integers(-9, 9), st.sampled_from([1, -1]), st.integers(0, 2 ** 31 - 1), st.sampled_from([4, 6, 8]))
def test_dft_features_invariant_to_every_rotation(k, sense, seed, W):
    X = np.random.default_rng(seed).normal(0, 5, (3, 2, W, 2))
    f = CyclicDFTFeatures(n_records=2, n_whiskers=W)
    a = f.fit_transform(X.reshape(3, -1))
    b = f.transform(rotate(X, k, sense).reshape(3, -1))
    np.testing.assert_allclose(a, b, atol=1e-9)
    # ... but not to an index shift paired with the wrong vector turn, unless the turn is trivial
    if (k * 4) % W:
        c = f.transform(np.roll(X, k, axis=-2)[..., ::-1].reshape(3, -1))
        assert not np.allclose(a, c, atol=1e-6)


def test_polar_features_known_values():
    X = np.zeros((1, 1, 2, 2))
    X[0, 0, 0] = (3.0, 4.0)       # |d| = 5 px
    X[0, 0, 1] = (0.5, 0.0)       # below the 1 px floor: direction scaled down, not blown up
    out = PolarFeatures(n_records=1, n_whiskers=2).fit_transform(X.reshape(1, -1))
    np.testing.assert_allclose(out[0], [np.log(6.0), np.log(1.5), 0.6, 0.8, 0.5, 0.0])
    with pytest.raises(ValueError, match="floor_px"):
        PolarFeatures(floor_px=0).fit(X.reshape(1, -1))


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_learns_separable_data_and_follows_sklearn(kind):
    from sklearn.base import clone

    ds = synthetic(n_obj=3, trials=3, poses=24, R=2, W=8)       # enough for the trees' leaves (20 samples)
    train, test = C.split(ds, "trial", seed=0)
    model = make_model(kind, seed=0, n_records=2, n_whiskers=8)
    clone(model)                                              # parameters live in the constructors
    C.fit_quiet(model, train.features(), train.y)
    assert np.mean(model.predict(test.features()) == test.y) > 0.9
    p = model.predict_proba(test.features())
    np.testing.assert_allclose(p.sum(axis=1), 1.0, atol=1e-6)


def test_bad_model_requests():
    with pytest.raises(ValueError, match="unknown model"):
        make_model("forest")
    with pytest.raises(ValueError, match="bad parameter"):
        make_model("trees", n_trees=3)


def test_study_runs_seeds_in_parallel_in_order():
    ds = synthetic(n_obj=2, trials=3, poses=4, R=2, W=8)
    serial = C.study(ds, ("trial",), range(3), kind="svc")
    parallel = C.study(ds, ("trial",), range(3), kind="svc", n_jobs=2)
    assert [r.seed for r in parallel] == [0, 1, 2]
    assert [r.accuracy for r in serial] == [r.accuracy for r in parallel]


def test_pairing_table_finds_symmetry_only_where_it_is():
    ds = synthetic(n_obj=2, trials=2, poses=4, R=4, W=8)
    from dataclasses import replace

    aug = augment_rotations(ds)                                # closed under the array's turns
    sym = replace(aug, rotation=np.zeros(len(aug), int))      # rotated copies recorded as if real
    rows = {(r["k"], r["sense"], r["record_roll"]): r for r in pairing_table(sym)}
    assert rows[(2, 1, 0)]["median_nn_px"] < 1e-9 and rows[(2, 1, 0)]["same_object_frac"] == 1.0
    plain = {(r["k"], r["sense"], r["record_roll"]): r for r in pairing_table(ds)}
    assert plain[(2, 1, 0)]["median_nn_px"] > 5 * plain[(0, 0, 0)]["median_nn_px"]
    pat = contact_pattern(ds, threshold_px=2.0)
    assert pat.shape == (4, 8) and 0 <= pat.min() and pat.max() <= 1


def test_cli_train_with_kind(tmp_path):
    # 5 px prototypes keep every value inside what the design's 11 deg end stop lets a marker move
    ds = synthetic(n_obj=2, trials=3, poses=4, R=8, W=8, scale_px=5.0)
    write_csv_folder(ds, tmp_path / "data")
    res = run_cli("classify", "train", "--data", str(tmp_path / "data"), "--kind", "svc", "--protocol", "trial",
                  "--out", str(tmp_path / "m.joblib"))
    assert res.returncode == 0, res.stderr
    res = run_cli("classify", "predict", "--model", str(tmp_path / "m.joblib"), "--input",
                  str(tmp_path / "data" / "obj0.csv"), "--json")
    assert res.returncode == 0 and res.stdout.count('"obj0"') >= 10, res.stderr
    bad = run_cli("classify", "train", "--data", str(tmp_path / "data"), "--kind", "forest", "--out",
                  str(tmp_path / "x.joblib"))
    assert bad.returncode == 2 and "forest" in bad.stderr


# -- the authors' data, reduced ---------------------------------------------------------------------------
@pytest.mark.skipif(peer_data() is None, reason="WHISKER_PEER_DATA not set: the authors' data is not in the "
                    "repository (CI sets it)")
def test_peer_polar_svm_beats_the_paper_mlp_on_held_out_trials_and_poses():
    """Reduced real case (5 objects, 2 seeds per protocol): the polar-feature SVM is at least as good
    as the paper's MLP on both leak-free protocols and above 98 % on unseen orientations (10 seeds in
    benchmarks/results/classify.md: 99.85 %; held-out trials stop near 95 % at cherry's outlying cycle)."""
    ds = load_peer(peer_data(), PAPER_OBJECTS)
    for protocol, floor in (("trial", 0.85), ("pose", 0.98)):
        svc = [C.run(ds, protocol, s, kind="svc").accuracy for s in (0, 1)]
        mlp = [C.run(ds, protocol, s, kind="mlp").accuracy for s in (0, 1)]
        assert np.mean(svc) > floor and np.mean(svc) >= np.mean(mlp), (protocol, svc, mlp)


@pytest.mark.skipif(peer_data() is None, reason="WHISKER_PEER_DATA not set: the authors' data is not in the "
                    "repository (CI sets it)")
def test_peer_rotated_copies_do_not_land_on_recorded_rows():
    """The authors' data holds no pairing of the array's rotations: every turned copy lies far from the
    recorded rows and its nearest row is of a random object (docs/classification.md)."""
    rows = pairing_table(load_peer(peer_data()))
    base, turned = rows[0], rows[1:]
    assert base["same_object_frac"] > 0.95
    assert min(r["median_nn_px"] for r in turned) > 3 * base["median_nn_px"]
    assert max(r["same_object_frac"] for r in turned) < 0.25
