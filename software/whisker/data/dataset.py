"""Whisker-contact datasets in one layout: samples x records x whiskers x (dx, dy).

The layout
----------
A `WhiskerDataset` holds

- ``X``: float array (n, R, W, 2), pixel displacements of each whisker's tracked marker from its
  rest position, image coordinates (x right, y down), px. ``R`` records per sample (one record =
  one camera frame / one contact), ``W`` whiskers, last axis (dx, dy).
- ``y``: (n,) object labels (str); ``classes``: the sorted label set.
- ``trial``: (n,) int, the physical trial (repeated run) each sample came from, -1 if unknown.
- ``pose``: (n,) int, the step within a trial (e.g. object orientation), -1 if unknown.
- ``group``: (n,) int, the original sample id; rotated copies made by `augment_rotations` share
  it, so a split by ``group`` never puts a rotated copy of a test sample in training.
- ``rotation``: (n,) int, how many 360/W steps the sample was rotated (0 = as recorded).
- ``valid``: (n, R, W) bool, False where the tracker lost the whisker (only `load_tracks` with
  ``invalid="zero"`` produces False entries; such whiskers are imputed as (0, 0) = at rest).
- ``sense``: +1 if whisker k+1 sits +360/W degrees from whisker k measured as atan2(dy, dx) in
  the displacement coordinates, -1 if the other way. Rotation augmentation needs it.

The flat feature vector of a sample (what the classifier sees, and one row of an authors' CSV) is
``X[i].reshape(-1)``: record-major, then whisker, then (dx, dy) interleaved:
``[r0w0dx, r0w0dy, r0w1dx, r0w1dy, ..., r7w7dy]`` for R = W = 8 (128 values).

The file formats (CSV folders, the authors' data, tracks files) are read and written by
`whisker.data.dataset_files`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Iterable, Sequence

import numpy as np

PEER_SCALE = 229.0
"""The authors' notebook divides the integer pixel displacements by 229 before training."""

PEER_TRIAL_LENGTH = 36
"""Rows per repeated cycle in the authors' CSVs (5 cycles x 36 steps = 180 rows), measured."""

PEER_REST_PX = np.array([(282, 297), (190, 287), (130, 220), (135, 127),
                         (202, 66), (295, 74), (353, 142), (345, 233)], dtype=float)
"""Rest centroids (px, image coordinates) of whiskers 0..7 in the authors' numbering: their
whiskerTrack.py ``curveFitCenterPtList`` after their ``rearrangeList`` (MIT licence)."""

PAPER_OBJECTS = ("cherry", "eraser", "lightbulb", "strawberry", "yuanbao")
"""The five objects of the conference paper (its Fig. 6); the CSV folder holds ten."""

TRACKS_COLUMNS = ("frame", "whisker", "x_px", "y_px", "dx_px", "dy_px", "valid")
"""Columns `load_tracks` needs from a tracks CSV written by `whisker track` (one row per frame and
whisker; it also writes time_s, status, theta_deg and tip_*_mm, and leaves the numbers of an
untracked marker empty)."""


class DatasetError(ValueError):
    """A dataset or an input sample is unusable; the message names what and where."""


@dataclass(frozen=True, eq=False)
class WhiskerDataset:
    """Samples x records x whiskers x (dx, dy) in px with labels and provenance (see module doc)."""

    X: np.ndarray
    y: np.ndarray
    trial: np.ndarray
    pose: np.ndarray
    group: np.ndarray
    rotation: np.ndarray
    valid: np.ndarray
    sense: int = 1
    source: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        X = np.asarray(self.X, dtype=float)
        if X.ndim != 4 or X.shape[-1] != 2:
            raise DatasetError(f"X must be (samples, records, whiskers, 2), got shape {X.shape}")
        n = len(X)
        for name in ("y", "trial", "pose", "group", "rotation"):
            if len(getattr(self, name)) != n:
                raise DatasetError(f"{name} has {len(getattr(self, name))} entries for {n} samples")
        if np.shape(self.valid) != X.shape[:3]:
            raise DatasetError(f"valid must be {X.shape[:3]}, got {np.shape(self.valid)}")
        if self.sense not in (1, -1):
            raise DatasetError(f"sense must be +1 or -1, got {self.sense}")
        check_finite(X, self.source)
        object.__setattr__(self, "X", X)

    # -- shape -------------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.X)

    @property
    def n_records(self) -> int:
        return self.X.shape[1]

    @property
    def n_whiskers(self) -> int:
        return self.X.shape[2]

    @property
    def n_features(self) -> int:
        return self.n_records * self.n_whiskers * 2

    @property
    def classes(self) -> tuple[str, ...]:
        return tuple(sorted(set(self.y.tolist())))

    def features(self) -> np.ndarray:
        """(n, R*W*2) flat features in the authors' column order (record, whisker, dx/dy), px."""
        return self.X.reshape(len(self.X), -1)

    def subset(self, index) -> "WhiskerDataset":
        """The samples selected by a boolean mask or an index array."""
        idx = np.asarray(index)
        return replace(self, X=self.X[idx], y=self.y[idx], trial=self.trial[idx],
                       pose=self.pose[idx], group=self.group[idx], rotation=self.rotation[idx],
                       valid=self.valid[idx])

    def select(self, objects: Iterable[str]) -> "WhiskerDataset":
        """Only the samples of the named objects; an unknown name is an error naming the known ones."""
        objects = list(objects)
        unknown = sorted(set(objects) - set(self.classes))
        if unknown:
            raise DatasetError(f"unknown object(s) {unknown}; this dataset has {list(self.classes)}")
        return self.subset(np.isin(self.y, objects))

    def summary(self) -> dict:
        labels, counts = np.unique(self.y, return_counts=True)
        return {"source": self.source, "samples": len(self), "records": self.n_records,
                "whiskers": self.n_whiskers, "features": self.n_features,
                "classes": dict(zip(labels.tolist(), counts.tolist())),
                "trials_known": bool((self.trial >= 0).all()),
                "rotated_copies": int((self.rotation != 0).sum()), "sense": self.sense}


def check_finite(X: np.ndarray, where: str = "") -> None:
    """Refuse NaN/inf, naming the first bad sample, record, whisker and component."""
    X = np.asarray(X, dtype=float)
    bad = ~np.isfinite(X)
    if bad.any():
        pos = tuple(int(i) for i in np.argwhere(bad)[0])
        if X.ndim == 4:
            s, r, w, c = pos
            what = f"sample {s}, record {r}, whisker {w}, {'dy' if c else 'dx'}"
        else:
            what = f"position {pos}"
        raise DatasetError(f"non-finite value {X[bad][0]} at {what}" + (f" in {where}" if where else "")
                           + f" ({int(bad.sum())} bad values); fix the input or drop those samples")


#: margin over the design's largest marker travel: tracking error, the marker off the focal plane
FEATURE_LIMIT_MARGIN = 2.0


def feature_limit_px(design) -> float:
    """Largest plausible |dx| or |dy| of a marker, px: the marker's travel at the design's largest
    tilt, l_l sin(whiskers.max_deflection_deg) / (mm per px), times FEATURE_LIMIT_MARGIN."""
    import math

    d = design.derived()
    travel = d["l_l_mm"] * math.sin(math.radians(design.whiskers.max_deflection_deg)) / d["mm_per_px"]
    return FEATURE_LIMIT_MARGIN * travel


def check_plausible(X: np.ndarray, limit_px: float, where: str = "") -> None:
    """Refuse values no whisker of the design can produce (|value| > limit_px), naming the first."""
    check_finite(X, where)
    X = np.asarray(X, dtype=float)
    bad = np.abs(X) > limit_px
    if bad.any():
        pos = tuple(int(i) for i in np.argwhere(bad)[0])
        what = (f"sample {pos[0]}, record {pos[1]}, whisker {pos[2]}, {'dy' if pos[3] else 'dx'}"
                if X.ndim == 4 else f"position {pos}")
        raise DatasetError(f"value {X[bad][0]:.6g} px at {what}" + (f" in {where}" if where else "")
                           + f" is beyond the {limit_px:.3g} px a marker can move (the design's largest tilt, "
                           f"x{FEATURE_LIMIT_MARGIN:g}); {int(bad.sum())} such value(s): wrong units or a "
                           "corrupt file?")


def as_samples(X, n_records: int, n_whiskers: int, where: str = "input") -> np.ndarray:
    """Flat rows (n, R*W*2) or (n, R, W, 2) -> checked float (n, R, W, 2).

    A wrong feature count or NaN/inf raises `DatasetError` naming what was expected.
    """
    X = np.asarray(X, dtype=float)
    expected = n_records * n_whiskers * 2
    if X.ndim == 1:
        X = X[None, :]
    if X.ndim == 2:
        if X.shape[1] != expected:
            raise DatasetError(f"{where}: {X.shape[1]} features per sample, expected {expected} "
                               f"({n_records} records x {n_whiskers} whiskers x (dx, dy))")
        X = X.reshape(len(X), n_records, n_whiskers, 2)
    if X.ndim != 4 or X.shape[1:] != (n_records, n_whiskers, 2):
        raise DatasetError(f"{where}: shape {X.shape}, expected (n, {n_records}, {n_whiskers}, 2) "
                           f"or (n, {expected})")
    check_finite(X, where)
    return X


def make_dataset(X, y, *, trial=None, pose=None, sense: int = 1, source: str = "",
                 valid=None, meta=None) -> WhiskerDataset:
    """Build a dataset from (n, R, W, 2) displacements and labels; missing ids become -1."""
    X = np.asarray(X, dtype=float)
    n = len(X)
    neg = np.full(n, -1, dtype=int)
    return WhiskerDataset(
        X=X, y=np.asarray(y, dtype=str), trial=neg.copy() if trial is None else np.asarray(trial, int),
        pose=neg.copy() if pose is None else np.asarray(pose, int), group=np.arange(n),
        rotation=np.zeros(n, dtype=int),
        valid=np.ones(X.shape[:3], bool) if valid is None else np.asarray(valid, bool),
        sense=sense, source=source, meta=dict(meta or {}))


def concat(datasets: Sequence[WhiskerDataset]) -> WhiskerDataset:
    """Join datasets of the same records x whiskers layout; groups and trials are kept distinct."""
    if not datasets:
        raise DatasetError("nothing to concatenate")
    first = datasets[0]
    for d in datasets[1:]:
        if d.X.shape[1:] != first.X.shape[1:] or d.sense != first.sense:
            raise DatasetError(f"cannot join {d.source} ({d.X.shape[1:]}, sense {d.sense}) with "
                               f"{first.source} ({first.X.shape[1:]}, sense {first.sense})")
    g_off = t_off = 0
    groups, trials = [], []
    for d in datasets:
        groups.append(d.group + g_off)
        g_off += int(d.group.max()) + 1 if len(d) else 0
        trials.append(np.where(d.trial >= 0, d.trial + t_off, -1))
        t_off += int(d.trial.max()) + 1 if len(d) and d.trial.max() >= 0 else 0
    cat = lambda name: np.concatenate([getattr(d, name) for d in datasets])  # noqa: E731
    return WhiskerDataset(X=cat("X"), y=cat("y"), trial=np.concatenate(trials), pose=cat("pose"),
                          group=np.concatenate(groups), rotation=cat("rotation"), valid=cat("valid"),
                          sense=first.sense, source="+".join(d.source for d in datasets), meta=first.meta)


# -- rotation ---------------------------------------------------------------------------------
def rotate(X: np.ndarray, k: int, sense: int = 1) -> np.ndarray:
    """Rotate samples (..., W, 2) by k steps of 360/W deg: whisker i's vector moves to whisker
    i + k and turns by sense * k * 360/W deg (the whole sensor turned by k whisker spacings).

    With ``sense`` = +1 the whisker index increases with atan2(dy, dx) (the authors' numbering).
    Pure and exact for k = 0 and for a full turn (k = W).
    """
    X = np.asarray(X, dtype=float)
    n_w = X.shape[-2]
    k = int(k) % n_w
    if k == 0:
        return X.copy()
    a = sense * 2.0 * np.pi * k / n_w
    c, s = np.cos(a), np.sin(a)
    dx, dy = X[..., 0], X[..., 1]
    out = np.stack([c * dx - s * dy, s * dx + c * dy], axis=-1)
    return np.roll(out, k, axis=-2)


def augment_rotations(ds: WhiskerDataset, steps: Iterable[int] | None = None) -> WhiskerDataset:
    """Append rotated copies (default: all W - 1 non-trivial steps of 360/W deg) to the dataset.

    Copies keep their source sample's ``group``, ``trial`` and ``pose`` and record their step in
    ``rotation``, so a later split by group keeps all copies of a sample on one side.
    """
    steps = list(range(1, ds.n_whiskers) if steps is None else steps)
    if (ds.rotation != 0).any():
        raise DatasetError("dataset already holds rotated copies; augment the originals only")
    parts = [ds]
    for k in steps:
        if k % ds.n_whiskers == 0:
            continue
        parts.append(replace(ds, X=rotate(ds.X, k, ds.sense), valid=np.roll(ds.valid, k, axis=-1),
                             rotation=np.full(len(ds), k % ds.n_whiskers)))
    return WhiskerDataset(X=np.concatenate([p.X for p in parts]), y=np.concatenate([p.y for p in parts]),
                          trial=np.concatenate([p.trial for p in parts]),
                          pose=np.concatenate([p.pose for p in parts]),
                          group=np.concatenate([p.group for p in parts]),
                          rotation=np.concatenate([p.rotation for p in parts]),
                          valid=np.concatenate([p.valid for p in parts]), sense=ds.sense,
                          source=ds.source, meta=ds.meta)


def sense_from_positions(xy: np.ndarray) -> int:
    """+1 if the whisker index increases with atan2(y, x) about the markers' centroid, else -1
    (:func:`whisker.vision.geometry.sense_from_positions`; refusals as :class:`DatasetError`)."""
    from whisker.vision.geometry import NumberingError, sense_from_positions as _sense

    try:
        return _sense(xy)
    except NumberingError as err:
        raise DatasetError(str(err)) from None


def check_design(ds: WhiskerDataset, design) -> None:
    """The dataset's whisker count must be the design's (the rotation step is 360/N)."""
    if design is not None and ds.n_whiskers != design.whiskers.count:
        raise DatasetError(f"dataset has {ds.n_whiskers} whiskers but the design has "
                           f"{design.whiskers.count}; pass the design the data was recorded with")
