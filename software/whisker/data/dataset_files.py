"""The dataset's files: folders of ``<object>.csv`` rows (the authors' layout, and simulated datasets),
the authors' published data, and tracks files from ``whisker track``; all into a `WhiskerDataset`
(`whisker.data.dataset`, which describes the layout).

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
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from whisker.data.dataset import (
    PEER_SCALE, PEER_TRIAL_LENGTH, PEER_REST_PX, TRACKS_COLUMNS, DatasetError, WhiskerDataset, check_finite, make_dataset, concat, sense_from_positions,
)


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
