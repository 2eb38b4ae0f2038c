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

The authors' data (verified, see docs/classification.md for the evidence)
------------------------------------------------------------------------
``objCls/<object>.csv``: 180 rows x 128 integers, no header. Measured from the data:

- (dx, dy) are interleaved per whisker: |column 2k| correlates with |column 2k+1| (median r = 0.39)
  but not with |column k+8| (r = 0.04) inside each 16-column record.
- 8 records = 4 approach directions x 2 distances, direction-major: the odd record of each pair
  moves 2.5-5x more (mean |d| 4.0-5.2 px vs 0.9-2.1 px: the 1 cm approach; the even one is 3 cm); the
  near records' resultant directions (53, -22, -118, 149 deg) are roughly 90 deg apart, and the far
  record points the same way for 3 of 4 directions (in the other it barely moves).
- rows are 5 repeated cycles x 36 steps (trial-major, ``row = 36 * trial + pose``): the mean distance
  between rows ``lag`` apart has its minimum at lag 36 for 9 of 10 objects (pinecone: no structure),
  and the 2-fold symmetric objects (yuanbao, lemon, eraser) show a second dip at lag 18, as expected
  for a 10 deg orientation step over 360 deg.
- rows do NOT contain rotated copies: shifting the whisker index by k and rotating the vectors by
  k x 45 deg (either sense) puts every row >= 22 px from its nearest row, while unrotated rows have a
  neighbour at a median 9.8 px.
- whisker order: the authors' tracker (whiskerTrack.py, ``rearrangeList`` applied to its reference
  centroids) numbers the markers so that whisker k sits at about 71 + 45 k deg measured as
  atan2(y, x) in image coordinates, i.e. ``sense = +1`` (`PEER_REST_PX` below).
- their notebook divides the values by 229 (`PEER_SCALE`) before the MLP.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
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


# -- loaders ------------------------------------------------------------------------------------
def read_rows(path: Path) -> np.ndarray:
    rows = []
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise DatasetError(f"{path}: not a text CSV (byte {err.start} is not UTF-8)") from None
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip().strip("[]")
        if not line:
            continue
        try:
            rows.append([float(v) for v in line.split(",")])
        except ValueError as err:
            raise DatasetError(f"{path}:{lineno}: not a row of numbers ({err})") from None
    if not rows:
        raise DatasetError(f"{path}: no rows")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        bad = next(i for i, r in enumerate(rows, 1) if len(r) != len(rows[0]))
        raise DatasetError(f"{path}: rows have different lengths {sorted(widths)} (first odd row {bad})")
    return np.array(rows)


def design_sense(design) -> int:
    """Numbering sense of a design's markers in its camera image (:func:`whisker.vision.render.design_sense`)."""
    from whisker.vision.render import design_sense as _design_sense

    return _design_sense(design)


def load_csv_folder(path: str | Path, *, objects: Iterable[str] | None = None, n_whiskers: int | None = None,
                    trial_length: int | None = None, trials_per_pose: int | None = None,
                    sense: int | None = None, design=None) -> WhiskerDataset:
    """A folder of ``<object>.csv`` files, one sample per row (the authors' layout, also used for
    simulated datasets).

    Each row holds R records x ``n_whiskers`` x (dx, dy) interleaved, px. Row order, if known:
    ``trial_length`` = rows per trial, trial-major (row = trial_length * trial + pose, the authors'
    files), or ``trials_per_pose`` = repeats per pose, pose-major (row = trials_per_pose * pose +
    trial, the simulator's rotations x trials). Arguments not given are read from an optional
    ``dataset.json`` in the folder (keys ``n_whiskers``, ``sense``, ``trial_length``,
    ``trials_per_pose``); then from ``design`` (whisker count, and the sense of its camera image);
    else 8 whiskers, sense +1, trials unknown (-1: only the random splits apply).
    """
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"{path}: not a folder of <object>.csv files")
    info = {}
    if (path / "dataset.json").is_file():
        try:
            info = json.loads((path / "dataset.json").read_text(encoding="utf-8"))
        except ValueError as err:  # not JSON, or not UTF-8
            raise DatasetError(f"{path / 'dataset.json'}: not JSON ({' '.join(str(err).split())})") from None
        if not isinstance(info, dict):
            raise DatasetError(f"{path / 'dataset.json'}: expected an object of settings, got {type(info).__name__}")
        for key in ("n_whiskers", "trial_length", "trials_per_pose", "sense"):
            v = info.get(key)
            ok = {"n_whiskers": lambda x: 1 <= x <= 64, "sense": lambda x: x in (-1, 1)}.get(key, lambda x: 1 <= x <= 10 ** 6)
            if v is not None and (not isinstance(v, int) or isinstance(v, bool) or not ok(v)):
                raise DatasetError(f"{path / 'dataset.json'}: {key} = {v!r} is not a valid {key}")
    if n_whiskers is None:
        n_whiskers = int(info.get("n_whiskers") or (design.whiskers.count if design is not None else 8))
    trial_length = trial_length if trial_length is not None else info.get("trial_length")
    trials_per_pose = trials_per_pose if trials_per_pose is not None else info.get("trials_per_pose")
    if trial_length and trials_per_pose:
        raise DatasetError(f"{path}: give trial_length (trial-major rows) or trials_per_pose (pose-major), not both")
    if sense is None:
        sense = int(info["sense"]) if info.get("sense") is not None else (design_sense(design) if design is not None else 1)
    files = {p.stem: p for p in sorted(path.glob("*.csv"))}
    if not files:
        raise DatasetError(f"{path}: no .csv files")
    names = list(files) if objects is None else list(objects)
    unknown = [o for o in names if o not in files]
    if unknown:
        raise DatasetError(f"unknown object(s) {unknown}; {path} has {sorted(files)}")
    Xs, ys, trials, poses = [], [], [], []
    for name in names:
        rows = read_rows(files[name])
        if rows.shape[1] % (2 * n_whiskers):
            raise DatasetError(f"{files[name]}: {rows.shape[1]} values per row is not a whole number "
                               f"of records of {n_whiskers} whiskers x (dx, dy)")
        if Xs and rows.shape[1] != Xs[0].shape[1] * Xs[0].shape[2] * 2:
            raise DatasetError(f"{files[name]}: {rows.shape[1]} values per row, other files have "
                               f"{Xs[0].shape[1] * Xs[0].shape[2] * 2}")
        X = rows.reshape(len(rows), -1, n_whiskers, 2)
        check_finite(X, str(files[name]))
        i = np.arange(len(rows))
        Xs.append(X)
        ys.append(np.full(len(rows), name))
        if trial_length:
            trials.append(i // trial_length)
            poses.append(i % trial_length)
        elif trials_per_pose:
            trials.append(i % trials_per_pose)
            poses.append(i // trials_per_pose)
        else:
            trials.append(np.full(len(rows), -1))
            poses.append(np.full(len(rows), -1))
    trial = np.concatenate(trials)
    return make_dataset(np.concatenate(Xs), np.concatenate(ys), trial=trial, pose=np.concatenate(poses),
                        sense=sense, source=str(path),
                        meta={"trial_length": trial_length, "trials_per_pose": trials_per_pose,
                              "scale": info.get("scale")})


def load_peer(path: str | Path, objects: Iterable[str] | None = None) -> WhiskerDataset:
    """The authors' ``objCls`` folder (or its parent) with the measured layout: 8 records x 8
    whiskers, 5 trials of 36 steps, ``sense`` from their tracker's numbering (`PEER_REST_PX`)."""
    path = Path(path)
    if (path / "objCls").is_dir():
        path = path / "objCls"
    ds = load_csv_folder(path, objects=objects, n_whiskers=8, trial_length=PEER_TRIAL_LENGTH,
                         sense=sense_from_positions(PEER_REST_PX))
    if ds.n_records != 8:
        raise DatasetError(f"{path}: {ds.n_features} values per row, the authors' files have 128")
    ds.meta["scale"] = PEER_SCALE
    return ds


def write_csv_folder(ds: WhiskerDataset, path: str | Path) -> Path:
    """Write a dataset in the authors' layout (``<object>.csv`` + ``dataset.json``), atomically."""
    from whisker.files import atomic_write_json, atomic_write_text

    path = Path(path)
    if (ds.rotation != 0).any():
        raise DatasetError("write the original samples, not rotated copies")
    for name in ds.classes:
        sub = ds.subset(ds.y == name)
        order = np.lexsort((sub.pose, sub.trial))
        text = "\n".join(",".join(f"{v:.6g}" for v in row) for row in sub.features()[order]) + "\n"
        atomic_write_text(path / f"{name}.csv", text)
    lengths = set()
    if (ds.trial >= 0).all():
        for name in ds.classes:
            lengths |= set(np.unique(ds.trial[ds.y == name], return_counts=True)[1].tolist())
    info = {"n_whiskers": ds.n_whiskers, "sense": ds.sense,
            "trial_length": lengths.pop() if len(lengths) == 1 else None}
    atomic_write_json(path / "dataset.json", info)
    return path


def load_tracks(paths: str | Path | Sequence[str | Path], label: str | Sequence[str], *,
                records_per_sample: int = 1, invalid: str = "error", design=None) -> WhiskerDataset:
    """Project recordings: tracks CSVs written by `whisker track` -> samples.

    One file = one physical trial (its index is the ``trial`` id). Each frame is one record of all
    W whiskers (dx_px, dy_px); ``records_per_sample`` consecutive frames make one sample (the
    authors' layout is 8 records = 4 approach directions x 2 distances). Frames left over at the end
    are dropped. ``label``: one label for all files or one per file.

    Whiskers the tracker flagged invalid (valid = 0), or with NaN displacement:
    - ``invalid="error"`` (default): refuse, naming the file, frame and whisker;
    - ``invalid="zero"``: impute (0, 0) = at rest and keep ``valid`` False for them (documented
      imputation: an untracked whisker is treated as undeflected);
    - ``invalid="drop"``: drop every sample that contains one.
    ``sense`` comes from the x_px, y_px of the first frame (marker positions) via
    `sense_from_positions`.
    """
    import csv

    if invalid not in ("error", "zero", "drop"):
        raise DatasetError(f"invalid={invalid!r}: choose error, zero or drop")
    if isinstance(paths, (str, Path)):
        paths = [paths]
    labels = [label] * len(paths) if isinstance(label, str) else list(label)
    if len(labels) != len(paths):
        raise DatasetError(f"{len(labels)} labels for {len(paths)} track files")
    parts, sense = [], None
    for p, lab in zip(paths, labels):
        p = Path(p)
        try:
            with open(p, newline="", encoding="utf-8") as fh:
                reader = csv.DictReader(fh)
                missing = [c for c in TRACKS_COLUMNS if c not in (reader.fieldnames or [])]
                if missing:
                    raise DatasetError(f"{p}: missing column(s) {missing}; need {list(TRACKS_COLUMNS)} "
                                       "(a tracks CSV from `whisker track`)")
                rows = list(reader)
        except (UnicodeDecodeError, csv.Error) as err:
            raise DatasetError(f"{p}: not a text CSV ({' '.join(str(err).split())})") from None
        if not rows:
            raise DatasetError(f"{p}: no rows")
        try:
            frame = np.array([int(r["frame"]) for r in rows])
            whisker = np.array([int(r["whisker"]) for r in rows])
            num = np.array([[float(r[c]) if r[c] not in ("", None) else np.nan
                             for c in ("x_px", "y_px", "dx_px", "dy_px")] for r in rows])
            ok = np.array([str(r["valid"]).strip().lower() in ("1", "true", "yes") for r in rows])
        except (ValueError, TypeError) as err:
            raise DatasetError(f"{p}: unreadable value ({err})") from None
        if whisker.min() < 0 or whisker.max() >= 64:
            raise DatasetError(f"{p}: whisker index {int(whisker.min() if whisker.min() < 0 else whisker.max())} "
                               "is outside 0..63")
        n_w = int(whisker.max()) + 1
        if design is not None and n_w != design.whiskers.count:
            raise DatasetError(f"{p}: {n_w} whiskers, the design has {design.whiskers.count}")
        frames = np.unique(frame)
        fi = np.searchsorted(frames, frame)
        X = np.full((len(frames), n_w, 2), np.nan)
        V = np.zeros((len(frames), n_w), bool)
        pos = np.full((len(frames), n_w, 2), np.nan)
        X[fi, whisker] = num[:, 2:4]
        pos[fi, whisker] = num[:, 0:2]
        V[fi, whisker] = ok & np.isfinite(num[:, 2:4]).all(axis=1)
        if sense is None:
            good = np.isfinite(pos).all(axis=(1, 2))
            if not good.any():
                raise DatasetError(f"{p}: no frame with every marker position; cannot tell the numbering sense")
            sense = sense_from_positions(pos[np.argmax(good)])
        if not V.all():
            f, w = (int(v) for v in np.argwhere(~V)[0])
            if invalid == "error":
                raise DatasetError(f"{p}: whisker {w} invalid or missing at frame {int(frames[f])} "
                                   f"({int((~V).sum())} such entries); use invalid='zero' to impute "
                                   "rest (0, 0) or invalid='drop' to skip those samples")
            X[~V] = 0.0
        n_s = len(frames) // records_per_sample
        if n_s == 0:
            raise DatasetError(f"{p}: {len(frames)} frames, fewer than records_per_sample={records_per_sample}")
        keep = n_s * records_per_sample
        Xs = X[:keep].reshape(n_s, records_per_sample, n_w, 2)
        Vs = V[:keep].reshape(n_s, records_per_sample, n_w)
        sel = Vs.all(axis=(1, 2)) if invalid == "drop" else np.ones(n_s, bool)
        parts.append(make_dataset(Xs[sel], np.full(int(sel.sum()), lab), trial=np.zeros(int(sel.sum()), int),
                                  pose=np.arange(n_s)[sel], valid=Vs[sel], sense=sense, source=str(p)))
    return concat(parts)


def load(path: str | Path, objects: Iterable[str] | None = None, design=None) -> WhiskerDataset:
    """Any supported source: the authors' folder (detected by its ``objCls`` name or its parent) or a
    CSV folder with optional ``dataset.json`` (whisker count and sense from ``design`` otherwise)."""
    path = Path(path)
    if path.name == "objCls" or (path / "objCls").is_dir():
        return load_peer(path, objects)
    return load_csv_folder(path, objects=objects, design=design)
