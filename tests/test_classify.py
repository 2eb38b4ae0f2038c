"""whisker.data.classify and `whisker classify`: the paper's MLP, the split protocols, saved models, bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import peer_data, run_cli
from test_dataset import synthetic, write_tracks
from whisker.data import classify as C
from whisker.data.dataset import PAPER_OBJECTS, DatasetError
from whisker.data.dataset_files import load_peer, write_csv_folder


def test_paper_configuration():
    model = C.make_classifier(seed=0)
    mlp = model[-1]
    assert mlp.hidden_layer_sizes == (32,) and mlp.activation == "relu" and mlp.solver == "adam"
    assert mlp.learning_rate_init == 0.01 and mlp.max_iter == 10 and mlp.batch_size == 16 and mlp.alpha == 0
    ds = synthetic()
    C.fit_quiet(model, ds.features(), ds.y)
    assert mlp.n_iter_ == 10  # all ten epochs run, no early stop
    np.testing.assert_allclose(model[0].transform(np.full((1, 4), 229.0)), 1.0)
    with pytest.raises(ValueError, match="bad classifier parameters"):
        C.make_classifier(hidden=0)


@pytest.mark.parametrize("protocol", C.PROTOCOLS)
def test_split_protocols(protocol):
    ds = synthetic(trials=5, poses=10)
    train, test = C.split(ds, protocol, seed=3)
    aug = 8 if protocol == "paper" or protocol.endswith("+rot") else 1
    assert len(train) + len(test) == aug * len(ds)
    assert 0.2 < len(test) / (len(train) + len(test)) < 0.45
    for c in ds.classes:  # stratified: every object on both sides
        assert (train.y == c).any() and (test.y == c).any()
    shared_groups = set(train.group) & set(test.group)
    if protocol == "paper":
        assert shared_groups  # the paper's order leaks rotated copies of test samples into training
    else:
        assert not shared_groups
    if protocol.startswith("trial"):
        for c in ds.classes:
            assert not set(train.trial[train.y == c]) & set(test.trial[test.y == c])
    if protocol.startswith("pose"):
        for c in ds.classes:
            assert not set(train.pose[train.y == c]) & set(test.pose[test.y == c])


def test_split_refusals():
    ds = synthetic()
    with pytest.raises(ValueError, match="unknown protocol"):
        C.split(ds, "leaky", 0)
    from whisker.data.dataset import make_dataset

    no_ids = make_dataset(ds.X, ds.y)
    with pytest.raises(DatasetError, match="needs the trial"):
        C.split(no_ids, "trial", 0)
    with pytest.raises(DatasetError, match="needs the pose"):
        C.split(no_ids, "pose+rot", 0)
    C.split(no_ids, "random+rot", 0)  # the rotation-group split works without ids
    from whisker.data.dataset import augment_rotations

    with pytest.raises(DatasetError, match="split the recorded samples"):
        C.split(augment_rotations(ds), "random", 0)


def test_run_and_summary_on_separable_data():
    ds = synthetic(trials=4, poses=8)
    res = C.study(ds, protocols=("random", "trial+rot"), seeds=range(2), epochs=20)
    s = C.summarize(res)
    assert s["random"]["accuracy_mean"] > 0.9  # prototypes 8 px apart, noise 1 px: easy
    assert s["random"]["seeds"] == 2 and s["random"]["accuracy_std"] >= 0
    assert np.sum(s["trial+rot"]["confusion"]) == 2 * s["trial+rot"]["n_test"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    ds = synthetic(trials=3, poses=8)
    model = C.fit_quiet(C.make_classifier(seed=0, epochs=20), ds.features(), ds.y)
    path = tmp_path_factory.mktemp("model") / "m.joblib"
    C.save_model(path, model, ds, {"protocol": "random"})
    return ds, path


def test_saved_model_roundtrip_and_versions(trained):
    ds, path = trained
    bundle = C.load_model(path)
    import sklearn

    assert bundle["versions"]["scikit-learn"] == sklearn.__version__ and "numpy" in bundle["versions"]
    assert bundle["classes"] == list(ds.classes) and bundle["n_records"] == 2 and bundle["n_whiskers"] == 8
    labels, proba = C.predict(bundle, ds.X[:5])
    assert labels.tolist() == ds.y[:5].tolist()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


def test_version_mismatch_warns(trained, tmp_path):
    _, path = trained
    bundle = C.read_bundle(path)
    bundle["versions"]["scikit-learn"] = "0.0.1"
    C.write_bundle(tmp_path / "old.joblib", bundle)
    with pytest.warns(UserWarning, match="trained with scikit-learn 0.0.1"):
        C.load_model(tmp_path / "old.joblib")
    (tmp_path / "junk.joblib").write_bytes(b"not a model")
    with pytest.raises(DatasetError, match="not a whisker classify model"):
        C.load_model(tmp_path / "junk.joblib")
    with pytest.raises(DatasetError, match="no such model"):
        C.load_model(tmp_path / "missing.joblib")


def test_bad_input_is_refused(trained):
    ds, path = trained
    bundle = C.load_model(path)
    with pytest.raises(DatasetError, match="31 features per sample, expected 32"):
        C.predict(bundle, np.zeros((1, 31)))
    X = ds.X[:2].copy()
    X[1, 0, 4, 1] = np.nan
    with pytest.raises(DatasetError, match="sample 1, record 0, whisker 4, dy"):
        C.predict(bundle, X)
    X[1, 0, 4, 1] = np.inf
    with pytest.raises(DatasetError, match="non-finite value inf"):
        C.predict(bundle, X)
    valid = np.ones((2, 2, 8), bool)
    valid[0, 1, 6] = False
    with pytest.raises(DatasetError, match="record 1: whisker 6 was not tracked"):
        C.predict(bundle, ds.X[:2], valid)
    with pytest.raises(DatasetError, match=r"unknown label\(s\) \['teapot'\]"):
        C.check_labels(bundle, ["obj0", "teapot"])
    C.check_labels(bundle, ["obj0", "obj2"])


def test_confusion_plot(tmp_path):
    out = C.plot_confusion([[3, 1], [0, 4]], ["a", "b"], tmp_path / "c.png", "t")
    assert out.read_bytes()[:4] == b"\x89PNG"


# -- the command line ----------------------------------------------------------------------------------------
def test_cli_train_predict_evaluate(tmp_path):
    ds = synthetic(n_obj=3, trials=3, poses=6, R=8, W=8, scale_px=5.0)  # inside the 11 deg stop's marker travel
    write_csv_folder(ds, tmp_path / "data")
    model = tmp_path / "m.joblib"
    res = run_cli("classify", "train", "--data", str(tmp_path / "data"), "--protocol", "random", "--epochs", "30",
                  "--out", str(model), "--report", str(tmp_path / "rep"))
    assert res.returncode == 0, res.stderr
    assert "test accuracy (random" in res.stdout and model.is_file()
    assert (tmp_path / "rep" / "confusion.png").is_file() and "precision" in (tmp_path / "rep" / "report.txt").read_text()
    rows = (tmp_path / "data" / "obj1.csv").read_text().splitlines()[:2]
    (tmp_path / "in.csv").write_text("\n".join(rows) + "\n")
    res = run_cli("classify", "predict", "--model", str(model), "--input", str(tmp_path / "in.csv"))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0] == "sample\tlabel\tprobability"            # a header, then one row per sample
    assert [line.split("\t")[1] for line in lines[1:]] == ["obj1", "obj1"]
    assert "2 sample(s): obj1 2" in res.stderr                  # the count per predicted class
    (tmp_path / "short.csv").write_text(",".join(rows[0].split(",")[:100]) + "\n")
    res = run_cli("classify", "predict", "--model", str(model), "--input", str(tmp_path / "short.csv"))
    assert res.returncode == 2 and "100 features per sample, expected 128" in res.stderr
    tracks = write_tracks(tmp_path / "t.csv", frames=8, invalid={(3, 2)}, step_px=0.4)  # inside the stop's travel
    res = run_cli("classify", "predict", "--model", str(model), "--input", str(tracks), "--tracks")
    assert res.returncode == 2 and "whisker 2 invalid or missing at frame 3" in res.stderr
    res = run_cli("classify", "predict", "--model", str(model), "--input", str(tracks), "--tracks", "--invalid", "zero")
    assert res.returncode == 0 and len(res.stdout.splitlines()) == 2
    res = run_cli("classify", "evaluate", "--data", str(tmp_path / "data"), "--protocol", "trial",
                  "--protocol", "random+rot", "--seeds", "2", "--out", str(tmp_path / "ev"))
    assert res.returncode == 0, res.stderr
    assert "| trial |" in res.stdout and (tmp_path / "ev" / "confusion_random_rot.png").is_file()
    res = run_cli("classify", "train", "--data", str(tmp_path / "data"), "--set", "whiskers.count=6",
                  "--set", "whiskers.ring_radius=10", "--out", str(tmp_path / "x.joblib"))
    assert res.returncode == 2 and "8 whiskers but the design has 6" in res.stderr


# -- the authors' data ------------------------------------------------------------------------------------------
@pytest.mark.skipif(peer_data() is None, reason="WHISKER_PEER_DATA not set: the authors' data is not in the "
                    "repository (CI sets it)")
def test_peer_paper_objects_random_split():
    """The authors' notebook protocol on the paper's five objects (measured 98 % +- 0.4 over 10 seeds)."""
    ds = load_peer(peer_data(), PAPER_OBJECTS)
    r = C.run(ds, "random", seed=0)
    assert r.accuracy > 0.93 and r.n_test == 270
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no stray warnings from the 10-epoch fit
        C.run(ds, "trial", seed=1)
