"""Object classification from whisker contacts: the paper's MLP, its protocols, saved models.

The paper (Sec. 3.1) and the authors' notebook: an MLP with one hidden layer of 32 ReLU units,
softmax output, cross-entropy, Adam with learning rate 0.01, 10 epochs, mini-batches of 16, a 7:3
train/test split, inputs = pixel displacements / 229. Here it is scikit-learn's `MLPClassifier`
(``solver="adam"``, ``max_iter`` = epochs, no L2 penalty) behind a fixed 1/scale input step, so the
model is a plain scikit-learn `Pipeline` (fit/predict/predict_proba/score, picklable).

Split protocols (`split`), all stratified by object and driven by one seed. A protocol is a split
unit, optionally followed by ``+rot`` = add the W-1 rotations by 360/W of every sample AFTER the
split (each side gets the rotations of its own samples only):

- ``paper``: augment every sample with its rotations FIRST, then split 7:3 at random (the paper's
  order: rotated copies of a test sample are in training).
- ``random``: 7:3 random split of the recorded samples, no augmentation (the authors' notebook).
- ``trial``: hold out whole physical trials per object (round(0.3 x trials), at least 1).
- ``pose``: hold out a contiguous arc of round(0.3 x steps) poses (object orientations) of every
  trial per object: the test poses were never seen in training.
- ``random+rot``, ``trial+rot``, ``pose+rot``: the same splits, then augmented (leak-free: split by
  rotation group / physical trial / pose before augmenting).
"""

from __future__ import annotations

import io
import platform
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker.data.dataset import (PEER_SCALE, DatasetError, WhiskerDataset, as_samples, augment_rotations,
                             check_plausible)
from whisker.data.models import PAPER_PARAMS, _scale, make_classifier  # noqa: F401  (the paper's MLP; old model files name _scale here)

PROTOCOLS = ("paper", "random", "random+rot", "trial", "trial+rot", "pose", "pose+rot")
PAPER_ACCURACY = 0.9917
"""The paper's test accuracy on its 5 objects (Sec. 3.1)."""

MODEL_FORMAT = 2
"""Model file format: 2 = a dict with the model, its classes, version info and FEATURE_LAYOUT."""
FEATURE_LAYOUT = "records x whiskers x (dx_px, dy_px), flattened in that order"
_BUNDLE_KEYS = {"model": object, "classes": list, "n_records": int, "n_whiskers": int, "versions": dict,
                "feature_layout": str}


def fit_quiet(model, X, y):
    """fit() with the expected few-epoch ConvergenceWarning silenced."""
    from sklearn.exceptions import ConvergenceWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        return model.fit(X, y)


# -- protocols ----------------------------------------------------------------------------------
def _stratified_pick(ds: WhiskerDataset, rng, test_size: float) -> np.ndarray:
    """Boolean test mask over the recorded samples: test_size of each object, at random."""
    test = np.zeros(len(ds), bool)
    for c in ds.classes:
        idx = np.flatnonzero(ds.y == c)
        k = int(round(test_size * len(idx)))
        test[rng.choice(idx, size=k, replace=False)] = True
    return test


def check_classes(ds: WhiskerDataset) -> None:
    """A classifier needs two objects or more."""
    if len(ds.classes) < 2:
        raise DatasetError(f"{len(ds.classes)} object(s) ({', '.join(map(str, ds.classes)) or 'none'}): "
                           "a classifier needs at least 2; add another object's samples")


def _check_sides(ds, train, test, protocol: str) -> None:
    """Every object must be on both sides of the split, or its accuracy means nothing."""
    for side, part in (("training", train), ("test", test)):
        missing = [c for c in ds.classes if not np.any(part.y == c)]
        if missing:
            counts = {str(c): int(np.sum(ds.y == c)) for c in missing}
            raise DatasetError(f"protocol {protocol!r} leaves no {side} sample of object(s) "
                               f"{', '.join(f'{c} ({n} samples)' for c, n in counts.items())}; record more "
                               "samples of them or use another protocol")


def split(ds: WhiskerDataset, protocol: str, seed: int = 0, test_size: float = 0.3
          ) -> tuple[WhiskerDataset, WhiskerDataset]:
    """(train, test) under one of `PROTOCOLS` (see module doc). ``ds`` holds recorded samples."""
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r}; choose from {', '.join(PROTOCOLS)}")
    if not 0 < test_size < 1:
        raise ValueError(f"test_size must be in (0, 1), got {test_size}")
    if (ds.rotation != 0).any():
        raise DatasetError("split the recorded samples; the protocols add the rotated copies")
    check_classes(ds)
    rng = np.random.default_rng(seed)
    if protocol == "paper":
        aug = augment_rotations(ds)
        test = _stratified_pick(aug, rng, test_size)
        _check_sides(aug, aug.subset(~test), aug.subset(test), protocol)
        return aug.subset(~test), aug.subset(test)
    unit, _, rot = protocol.partition("+")
    if unit == "random":
        test = _stratified_pick(ds, rng, test_size)
    elif unit == "trial":
        if (ds.trial < 0).any():
            raise DatasetError("protocol 'trial' needs the trial of every sample; this dataset has none "
                               "(give trial_length or use protocol 'random+rot')")
        test = np.zeros(len(ds), bool)
        for c in ds.classes:
            m = ds.y == c
            trials = np.unique(ds.trial[m])
            if len(trials) < 2:
                raise DatasetError(f"object {c!r} has {len(trials)} trial(s); need 2+ to hold one out")
            k = min(len(trials) - 1, max(1, int(round(test_size * len(trials)))))
            test |= m & np.isin(ds.trial, rng.choice(trials, size=k, replace=False))
    else:  # pose
        if (ds.pose < 0).any():
            raise DatasetError("protocol 'pose' needs the pose of every sample; this dataset has none")
        test = np.zeros(len(ds), bool)
        for c in ds.classes:
            m = ds.y == c
            n_pose = int(ds.pose[m].max()) + 1
            if n_pose < 2:
                raise DatasetError(f"object {c!r} has {n_pose} pose(s); need 2+ to hold some out")
            k = min(n_pose - 1, max(1, int(round(test_size * n_pose))))
            arc = (rng.integers(n_pose) + np.arange(k)) % n_pose
            test |= m & np.isin(ds.pose, arc)
    train, held = ds.subset(~test), ds.subset(test)
    _check_sides(ds, train, held, protocol)
    if rot:
        return augment_rotations(train), augment_rotations(held)
    return train, held


@dataclass
class RunResult:
    protocol: str
    seed: int
    accuracy: float
    train_s: float
    predict_s_per_sample: float
    n_train: int
    n_test: int
    confusion: np.ndarray
    classes: tuple


def run(ds: WhiskerDataset, protocol: str, seed: int = 0, test_size: float = 0.3, kind: str = "mlp",
        **params) -> RunResult:
    """Split, train a model of `whisker.data.models.KINDS` (``mlp`` = the paper's; params as
    `whisker.data.models.make_model`), test; timings in seconds."""
    from sklearn.metrics import confusion_matrix

    from whisker.data.models import make_model

    train, test = split(ds, protocol, seed, test_size)
    model = make_model(kind, seed=seed, n_records=ds.n_records, n_whiskers=ds.n_whiskers, **params)
    t0 = time.perf_counter()
    fit_quiet(model, train.features(), train.y)
    t1 = time.perf_counter()
    pred = model.predict(test.features())
    t2 = time.perf_counter()
    classes = ds.classes
    return RunResult(protocol=protocol, seed=seed, accuracy=float(np.mean(pred == test.y)),
                     train_s=t1 - t0, predict_s_per_sample=(t2 - t1) / max(1, len(test)),
                     n_train=len(train), n_test=len(test),
                     confusion=confusion_matrix(test.y, pred, labels=list(classes)), classes=classes)


def study(ds: WhiskerDataset, protocols=PROTOCOLS, seeds=range(10), progress: bool = False,
          n_jobs: int = 1, kind: str = "mlp", **params) -> list[RunResult]:
    """`run` for every protocol and seed, the fits spread over ``n_jobs`` joblib workers (progress bar
    on stderr if asked). Results come back in (protocol, seed) order whatever ``n_jobs``."""
    from joblib import Parallel, delayed

    jobs = [(p, s) for p in protocols for s in seeds]
    if progress:
        from tqdm import tqdm

        jobs = tqdm(jobs, desc=f"classify {kind}", unit="fit")
    return Parallel(n_jobs=n_jobs)(delayed(run)(ds, p, s, kind=kind, **params) for p, s in jobs)


def summarize(results: list[RunResult]) -> dict:
    """Per protocol: mean and sample std (ddof=1) of accuracy over seeds, and the summed confusion."""
    out = {}
    for p in dict.fromkeys(r.protocol for r in results):
        rs = [r for r in results if r.protocol == p]
        acc = np.array([r.accuracy for r in rs])
        out[p] = {"seeds": len(rs), "accuracy_mean": float(acc.mean()),
                  "accuracy_std": float(acc.std(ddof=1)) if len(acc) > 1 else 0.0,
                  "accuracy_min": float(acc.min()), "train_s_mean": float(np.mean([r.train_s for r in rs])),
                  "n_train": rs[0].n_train, "n_test": rs[0].n_test,
                  "confusion": sum(r.confusion for r in rs).tolist(), "classes": list(rs[0].classes)}
    return out


# -- reports ----------------------------------------------------------------------------------------
def per_class_report(y_true, y_pred, classes) -> str:
    """scikit-learn's precision/recall/F1 table as text."""
    from sklearn.metrics import classification_report

    return classification_report(y_true, y_pred, labels=list(classes), digits=3, zero_division=0)


def plot_confusion(confusion, classes, path, title: str = "") -> Path:
    """The paper's Fig. 6: row-normalised confusion matrix (counts in the cells), PNG, atomic."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from whisker.files import atomic_write_bytes

    cm = np.asarray(confusion, dtype=float)
    rows = cm.sum(axis=1, keepdims=True)
    frac = np.divide(cm, rows, out=np.zeros_like(cm), where=rows > 0)
    n = len(classes)
    fig, ax = plt.subplots(figsize=(1.0 + 0.62 * n, 0.8 + 0.55 * n), dpi=110)
    ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    for i in range(n):
        for j in range(n):
            if cm[i, j]:
                ax.text(j, i, f"{frac[i, j]:.2f}\n({int(cm[i, j])})", ha="center", va="center", fontsize=7,
                        color="white" if frac[i, j] > 0.6 else "black")
    ax.set_xticks(range(n), classes, rotation=45, ha="right")
    ax.set_yticks(range(n), classes)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    if title:
        import textwrap

        ax.set_title("\n".join(textwrap.wrap(title, width=max(36, 7 * n))), fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


# -- saved models -------------------------------------------------------------------------------------
def versions() -> dict:
    """Library versions a model was trained with (stored in the model file)."""
    import joblib
    import sklearn

    import whisker

    return {"python": platform.python_version(), "numpy": np.__version__, "scikit-learn": sklearn.__version__,
            "joblib": joblib.__version__, "whisker": getattr(whisker, "__version__", "unknown")}


MODEL_MAGIC = b"WHISKER-CLASSIFY-MODEL"


def save_model(path, model, ds: WhiskerDataset, info: dict) -> Path:
    """Model file: a header line (magic, format, SHA-256 of the rest) then a joblib dict {'model',
    'classes', 'n_records', 'n_whiskers', 'sense', 'feature_layout', 'versions', ...}; atomic."""
    bundle = {"format": MODEL_FORMAT, "model": model, "classes": [str(c) for c in model.classes_],
              "n_records": ds.n_records, "n_whiskers": ds.n_whiskers, "sense": ds.sense,
              "feature_layout": FEATURE_LAYOUT, "versions": versions(), **info}
    return write_bundle(path, bundle)


def write_bundle(path, bundle: dict) -> Path:
    """Write a model dict with its header line (see save_model), atomically."""
    import hashlib

    import joblib

    from whisker.files import atomic_write_bytes

    buf = io.BytesIO()
    joblib.dump(bundle, buf)
    payload = buf.getvalue()
    head = MODEL_MAGIC + f" {MODEL_FORMAT} sha256={hashlib.sha256(payload).hexdigest()}\n".encode()
    return atomic_write_bytes(path, head + payload)


def read_bundle(path) -> dict:
    """The model dict of a file written by write_bundle. The header is checked before anything is
    unpickled: a file that is not ours, or one changed since it was written, is refused."""
    import hashlib

    import joblib

    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: no such model file")
    raw = path.read_bytes()
    head, nl, payload = raw.partition(b"\n")
    parts = head.split(b" ")
    if not nl or len(parts) != 3 or parts[0] != MODEL_MAGIC or not parts[2].startswith(b"sha256="):
        raise DatasetError(f"{path}: not a whisker classify model (no model header); train one with "
                           "`whisker classify train`")
    if parts[1] != str(MODEL_FORMAT).encode():
        raise DatasetError(f"{path}: model file format {parts[1].decode(errors='replace')!r}, this version reads "
                           f"{MODEL_FORMAT}; retrain it with `whisker classify train`")
    if hashlib.sha256(payload).hexdigest().encode() != parts[2][len(b"sha256="):]:
        raise DatasetError(f"{path}: damaged whisker classify model (its checksum does not match: truncated or "
                           "changed since it was written); retrain it or restore a copy")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # our own, clearer message follows
            return joblib.load(io.BytesIO(payload))
    except Exception as err:  # written by us but unreadable here (e.g. another library version)
        raise DatasetError(f"{path}: cannot read this whisker classify model ({type(err).__name__}: "
                           f"{' '.join(str(err).split())[:120]}); retrain it") from None


def load_model(path) -> dict:
    """Load a model file (header, checksum, fields and a trial prediction checked); warns (naming
    both) when the library versions differ from training."""
    bundle = read_bundle(path)
    if not isinstance(bundle, dict) or bundle.get("format") != MODEL_FORMAT:
        raise DatasetError(f"{path}: not a whisker classify model (format {MODEL_FORMAT})")
    bad = [k for k, t in _BUNDLE_KEYS.items() if not isinstance(bundle.get(k), t)]
    if bad or bundle["feature_layout"] != FEATURE_LAYOUT or not hasattr(bundle["model"], "predict_proba") \
            or not 1 <= bundle["n_whiskers"] <= 64 or not 1 <= bundle["n_records"] <= 10000:
        raise DatasetError(f"{path}: damaged whisker classify model (fields {bad or 'feature layout/sizes'}); "
                           "retrain it with `whisker classify train`")
    try:
        bundle["model"].predict_proba(np.zeros((1, bundle["n_records"] * bundle["n_whiskers"] * 2)))
    except Exception as err:
        raise DatasetError(f"{path}: the model in it does not predict ({type(err).__name__}); retrain it") from None
    now = versions()
    diff = {k: (v, now.get(k)) for k, v in bundle["versions"].items()
            if k in ("scikit-learn", "numpy") and now.get(k) != v}
    if diff:
        warnings.warn(f"{path}: trained with " + ", ".join(f"{k} {a}" for k, (a, b) in diff.items())
                      + "; running " + ", ".join(f"{k} {b}" for k, (a, b) in diff.items())
                      + "; predictions may differ, retrain to be sure", stacklevel=2)
    return bundle


def predict(bundle: dict, X, valid=None) -> tuple[np.ndarray, np.ndarray]:
    """(labels, probabilities) for samples X (flat rows or (n, R, W, 2), px).

    Wrong feature count or NaN/inf raises `DatasetError`; so does any whisker marked invalid in
    ``valid`` ((n, R, W) bool) unless the caller imputed it already (see `load_tracks`).
    """
    X = as_samples(X, bundle["n_records"], bundle["n_whiskers"])
    if valid is not None:
        valid = np.asarray(valid, bool)
        if valid.shape != X.shape[:3]:
            raise DatasetError(f"valid has shape {valid.shape}, expected {X.shape[:3]}")
        if not valid.all():
            s, r, w = (int(v) for v in np.argwhere(~valid)[0])
            raise DatasetError(f"sample {s}, record {r}: whisker {w} was not tracked (valid = 0); "
                               "impute it explicitly or drop the sample")
    limit = bundle.get("feature_limit_px")
    if isinstance(limit, (int, float)) and limit > 0:
        check_plausible(X, float(limit), "input")
    flat = X.reshape(len(X), -1)
    model = bundle["model"]
    return model.predict(flat), model.predict_proba(flat)


def check_labels(bundle: dict, labels) -> None:
    """Labels of an evaluation set must be classes the model knows."""
    unknown = sorted(set(np.asarray(labels, str).tolist()) - set(bundle["classes"]))
    if unknown:
        raise DatasetError(f"unknown label(s) {unknown}; the model knows {[str(c) for c in bundle['classes']]}")
