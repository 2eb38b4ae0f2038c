"""whisker.data.dataset: the layout, rotation augmentation, loaders and their refusals of bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import peer_data
from whisker.data.dataset import PEER_REST_PX, DatasetError, augment_rotations, make_dataset, rotate, sense_from_positions
from whisker.data.dataset_files import load_csv_folder, load_peer, load_tracks, write_csv_folder


def synthetic(n_obj=3, trials=3, poses=6, R=2, W=8, seed=0, scale_px=8.0):
    rng = np.random.default_rng(seed)
    proto = rng.normal(0, scale_px, (n_obj, R, W, 2))
    X, y, t, p = [], [], [], []
    for c in range(n_obj):
        for tr in range(trials):
            for po in range(poses):
                X.append(proto[c] * (1 + 0.2 * np.sin(po)) + rng.normal(0, 1, (R, W, 2)))
                y.append(f"obj{c}")
                t.append(tr)
                p.append(po)
    return make_dataset(np.array(X), y, trial=t, pose=p, source="synthetic")


def ring(W, sense=1, phase=0.3, r=100.0):
    a = phase + sense * 2 * np.pi * np.arange(W) / W
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


# -- rotation -----------------------------------------------------------------------------------------
def test_rotate_known_case():
    X = np.zeros((4, 2))
    X[0] = (1.0, 0.0)
    out = rotate(X, 1, sense=1)
    np.testing.assert_allclose(out[1], (0.0, 1.0), atol=1e-12)
    assert np.abs(out[[0, 2, 3]]).max() == 0
    np.testing.assert_allclose(rotate(X, 1, sense=-1)[1], (0.0, -1.0), atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(W=st.integers(2, 12), a=st.integers(-20, 20), b=st.integers(-20, 20), sense=st.sampled_from([1, -1]),
       seed=st.integers(0, 1000))
def test_rotate_group_properties(W, a, b, sense, seed):
    X = np.random.default_rng(seed).normal(0, 10, (3, 2, W, 2))
    np.testing.assert_allclose(rotate(rotate(X, a, sense), b, sense), rotate(X, a + b, sense), atol=1e-9)
    np.testing.assert_allclose(rotate(X, W, sense), X, atol=1e-9)  # a full turn is the identity
    np.testing.assert_allclose(np.sort(np.linalg.norm(rotate(X, a, sense), axis=-1), axis=-1),
                               np.sort(np.linalg.norm(X, axis=-1), axis=-1), atol=1e-9)


@pytest.mark.parametrize("W", [3, 6, 8])
@pytest.mark.parametrize("sense", [1, -1])
def test_rotation_equals_turning_the_sensor(W, sense):
    """Markers on a ring, each displaced radially+tangentially by its own amounts: turning the sensor
    by one spacing must put whisker k's (rotated) vector on whisker k+1."""
    pos = ring(W, sense)
    assert sense_from_positions(pos) == sense
    u = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    tang = np.stack([-u[:, 1], u[:, 0]], axis=1)
    rad, tan = np.arange(1.0, W + 1), np.linspace(-2, 2, W)
    X = rad[:, None] * u + tan[:, None] * tang
    out = rotate(X[None], 1, sense)[0]
    k1 = np.roll(np.arange(W), -1)  # whisker k+1
    np.testing.assert_allclose(out[k1], rad[:, None] * u[k1] + tan[:, None] * tang[k1], atol=1e-9)


def test_sense_from_positions():
    assert sense_from_positions(PEER_REST_PX) == 1  # the authors' numbering (their tracker constants)
    assert sense_from_positions(PEER_REST_PX[::-1]) == -1
    with pytest.raises(DatasetError, match="not numbered around the ring"):
        sense_from_positions(PEER_REST_PX[[0, 2, 1, 3, 4, 5, 6, 7]])
    with pytest.raises(DatasetError, match="rest positions"):
        sense_from_positions(np.zeros((2, 2)))


def test_augment_keeps_groups_and_refuses_twice():
    ds = synthetic()
    aug = augment_rotations(ds)
    assert len(aug) == 8 * len(ds)
    assert sorted(np.unique(aug.rotation).tolist()) == list(range(8))
    for g in range(len(ds)):
        m = aug.group == g
        assert m.sum() == 8 and len(set(aug.y[m])) == 1 and len(set(aug.trial[m])) == 1
    np.testing.assert_allclose(aug.X[aug.rotation == 0], ds.X)
    with pytest.raises(DatasetError, match="already holds rotated copies"):
        augment_rotations(aug)


# -- folder loader ------------------------------------------------------------------------------------------
def test_csv_folder_roundtrip(tmp_path):
    ds = synthetic()
    write_csv_folder(ds, tmp_path)
    assert json.loads((tmp_path / "dataset.json").read_text())["trial_length"] == 6
    back = load_csv_folder(tmp_path)
    assert back.X.shape == ds.X.shape and back.classes == ds.classes
    np.testing.assert_allclose(back.X, ds.X, rtol=1e-5, atol=1e-4)
    np.testing.assert_array_equal(back.trial, ds.trial)
    np.testing.assert_array_equal(back.pose, ds.pose)


def test_csv_folder_refusals(tmp_path):
    (tmp_path / "a.csv").write_text("1,2,3,4\n5,6,7,8\n")
    with pytest.raises(DatasetError, match="not a whole number of records"):
        load_csv_folder(tmp_path, n_whiskers=8)
    (tmp_path / "a.csv").write_text("1,2,3,4\n5,6,7\n")
    with pytest.raises(DatasetError, match="different lengths"):
        load_csv_folder(tmp_path, n_whiskers=2)
    (tmp_path / "a.csv").write_text("1,2,3,4\n5,nan,7,8\n")
    with pytest.raises(DatasetError, match=r"non-finite value nan at sample 1, record 0, whisker 0, dy"):
        load_csv_folder(tmp_path, n_whiskers=2)
    (tmp_path / "a.csv").write_text("1,2,3,4\n5,x,7,8\n")
    with pytest.raises(DatasetError, match=r"a.csv:2: not a row of numbers"):
        load_csv_folder(tmp_path, n_whiskers=2)
    (tmp_path / "a.csv").write_text("1,2,3,4\n")
    with pytest.raises(DatasetError, match=r"unknown object\(s\) \['b'\]"):
        load_csv_folder(tmp_path, objects=["b"], n_whiskers=2)
    with pytest.raises(DatasetError, match="unknown object"):
        load_csv_folder(tmp_path, n_whiskers=2).select(["zebra"])


# -- tracks loader -------------------------------------------------------------------------------------------
def write_tracks(path, frames=4, W=8, sense=1, invalid=(), step_px=0.5):
    """A tracks CSV in `whisker track`'s own format (its header; an untracked marker's numbers empty)."""
    from whisker.vision.trackfile import CSV_HEADER

    cols = CSV_HEADER.split(",")
    pos = ring(W, sense) + 240
    lines = [CSV_HEADER + "\n"]
    for f in range(frames):
        for w in range(W):
            ok = (f, w) not in invalid
            dx, dy = (f + 1) * step_px * (w + 1), -f * 0.25
            row = {"frame": f, "time_s": f"{f / 30:.4f}", "whisker": w, "x_px": f"{pos[w, 0] + dx:.3f}",
                   "y_px": f"{pos[w, 1] + dy:.3f}", "dx_px": dx, "dy_px": dy, "valid": 1, "status": "ok",
                   "theta_deg": 0.1, "tip_x_mm": 0, "tip_y_mm": 0, "tip_z_mm": 20}
            if not ok:
                row.update(x_px="", y_px="", dx_px="", dy_px="", valid=0, status="lost", theta_deg="",
                           tip_x_mm="", tip_y_mm="", tip_z_mm="")
            lines.append(",".join(str(row[c]) for c in cols) + "\n")
    path.write_text("".join(lines))
    return path


def test_tracks_loader(tmp_path):
    a = write_tracks(tmp_path / "a.csv", frames=4)
    b = write_tracks(tmp_path / "b.csv", frames=5)
    ds = load_tracks([a, b], ["cup", "pen"], records_per_sample=2)
    assert ds.X.shape == (4, 2, 8, 2)  # 2 + 2 samples; b's fifth frame is left over
    assert ds.y.tolist() == ["cup", "cup", "pen", "pen"] and ds.trial.tolist() == [0, 0, 1, 1]
    assert ds.sense == 1
    np.testing.assert_allclose(ds.X[0, 1, 3], (2 * 0.5 * 4, -0.25))  # frame 1, whisker 3
    c = write_tracks(tmp_path / "c.csv", sense=-1)
    assert load_tracks(c, "cup").sense == -1


def test_tracks_invalid_whiskers(tmp_path):
    p = write_tracks(tmp_path / "a.csv", frames=4, invalid={(2, 5)})
    with pytest.raises(DatasetError, match="whisker 5 invalid or missing at frame 2"):
        load_tracks(p, "cup")
    ds = load_tracks(p, "cup", invalid="zero")
    assert not ds.valid[2, 0, 5] and ds.valid.sum() == 4 * 8 - 1
    assert (ds.X[2, 0, 5] == 0).all() and np.isfinite(ds.X).all()
    dropped = load_tracks(p, "cup", records_per_sample=2, invalid="drop")
    assert len(dropped) == 1 and dropped.valid.all()
    (tmp_path / "bad.csv").write_text("frame,whisker,dx_px\n0,0,1\n")
    with pytest.raises(DatasetError, match=r"missing column\(s\)"):
        load_tracks(tmp_path / "bad.csv", "cup")
    with pytest.raises(DatasetError, match="invalid='maybe'"):
        load_tracks(p, "cup", invalid="maybe")


def test_pose_major_folder_and_design_defaults(tmp_path):
    from whisker.data.dataset_files import design_sense
    from whisker.design import default_design

    ds = synthetic(n_obj=2, trials=3, poses=4, R=1, W=6)
    for c in ds.classes:  # the simulator's order: rotations (poses) x trials, pose-major
        sub = ds.subset(ds.y == c)
        order = np.lexsort((sub.trial, sub.pose))
        (tmp_path / f"{c}.csv").write_text("\n".join(",".join(f"{v:.6g}" for v in r) for r in sub.features()[order]))
    (tmp_path / "dataset.json").write_text(json.dumps({"trials_per_pose": 3}))
    six = default_design("whiskers.count=6", "whiskers.ring_radius=10")
    back = load_csv_folder(tmp_path, design=six)
    assert back.n_whiskers == 6 and back.n_records == 1
    assert back.sense == design_sense(six) and design_sense(default_design()) in (1, -1)
    assert back.trial[:6].tolist() == [0, 1, 2, 0, 1, 2] and back.pose[:6].tolist() == [0, 0, 0, 1, 1, 1]
    np.testing.assert_allclose(back.X[back.y == "obj0"][4], ds.X[(ds.y == "obj0") & (ds.trial == 1) & (ds.pose == 1)][0],
                               rtol=1e-5, atol=1e-4)
    (tmp_path / "dataset.json").write_text(json.dumps({"trials_per_pose": 3, "trial_length": 4}))
    with pytest.raises(DatasetError, match="not both"):
        load_csv_folder(tmp_path)
    (tmp_path / "dataset.json").write_text("{oops")
    with pytest.raises(DatasetError, match="not JSON"):
        load_csv_folder(tmp_path)


def test_design_whisker_count(tmp_path):
    from whisker.data.dataset import check_design
    from whisker.design import default_design

    ds = synthetic(W=6)
    with pytest.raises(DatasetError, match="6 whiskers but the design has 8"):
        check_design(ds, default_design())
    check_design(synthetic(W=8), default_design())


# -- the authors' data: the layout claims in the module docstring, measured ----------------------------------------
needs_peer = pytest.mark.skipif(peer_data() is None, reason="WHISKER_PEER_DATA not set: the authors' data is "
                                "not in the repository (CI sets it)")


@pytest.fixture(scope="module")
def peer():
    return load_peer(peer_data())


@needs_peer
def test_peer_shape_and_ids(peer):
    assert peer.X.shape == (1800, 8, 8, 2) and len(peer.classes) == 10
    assert np.array_equal(peer.X, np.round(peer.X))  # integer pixels
    assert peer.trial.max() == 4 and peer.pose.max() == 35 and peer.sense == 1


@needs_peer
def test_peer_dx_dy_interleaved(peer):
    flat = np.abs(peer.features()).reshape(-1, 8, 16)
    inter = [np.corrcoef(flat[:, r, 2 * k], flat[:, r, 2 * k + 1])[0, 1] for r in range(8) for k in range(8)]
    blocked = [np.corrcoef(flat[:, r, k], flat[:, r, k + 8])[0, 1] for r in range(8) for k in range(8)]
    assert np.nanmedian(inter) > 0.3 > 0.1 > np.nanmedian(blocked)


@needs_peer
def test_peer_records_are_direction_pairs(peer):
    """Records 2d, 2d+1: the odd one (1 cm approach) moves more; the near records point 4 ways."""
    z = peer.X[..., 0] + 1j * peer.X[..., 1]
    size = np.abs(z).mean(axis=(0, 2))
    assert np.all(size[1::2] > 2 * size[0::2])  # measured 2.5-5x
    ang = [np.degrees(np.angle(z[:, 2 * d + 1].sum())) for d in range(4)]
    steps = np.abs(np.angle(np.exp(1j * np.radians(np.diff(ang + ang[:1])))))
    assert np.all(np.degrees(steps) > 60)  # four distinct approach directions, roughly 90 deg apart


@needs_peer
def test_peer_rows_are_5_trials_of_36(peer):
    hits = 0
    for c in peer.classes:
        a = peer.features()[peer.y == c]
        lag = [np.linalg.norm(a[k:] - a[:-k], axis=1).mean() for k in range(20, 53)]
        hits += int(np.argmin(lag) + 20 == 36)
    assert hits >= 8  # 9 of 10 measured (pinecone shows no structure)


@needs_peer
def test_peer_has_no_rotated_copies(peer):
    from scipy.spatial.distance import cdist

    a = peer.features()[peer.y == "yuanbao"]
    same = cdist(a, a)
    np.fill_diagonal(same, np.inf)
    for k in (1, 2, 4):
        for sense in (1, -1):
            rot = rotate(a.reshape(-1, 8, 8, 2), k, sense).reshape(len(a), -1)
            assert np.median(cdist(rot, a).min(axis=1)) > 3 * np.median(same.min(axis=1))


def test_simulated_dataset_loads(tmp_path):
    """The simulator's classification scene writes the authors' folder layout (contract between issues 8
    and 9); one trial per sensor rotation keeps it to a few seconds."""
    pytest.importorskip("whisker.sim", reason="the simulator (issue 8) is not installed")
    from conftest import ROOT, run_cli
    from whisker.design import default_design

    scene = ROOT / "software" / "whisker" / "sim" / "scenes" / "classification.toml"
    res = run_cli("sim", str(scene), "--trials", "1", "--out", str(tmp_path / "run"), "-q")
    assert res.returncode == 0, res.stderr
    ds = load_csv_folder(tmp_path / "run" / "dataset", trials_per_pose=1, design=default_design())
    assert ds.X.shape[1:] == (8, 8, 2) and len(ds.classes) == 5
    assert np.array_equal(ds.X, np.round(ds.X)) and np.abs(ds.X).max() > 0
    assert ds.pose.max() == 5 and (ds.trial == 0).all()  # 6 sensor rotations, pose-major rows
