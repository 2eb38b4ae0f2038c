"""Does a dataset hold the array's rotational symmetry? Tests for the rotation pairing.

Rotation augmentation (`whisker.data.dataset.rotate`) assumes that turning the whole scene by k
whisker spacings maps a recorded sample onto another physically possible sample: whisker i's vector
moves to whisker i + k and turns by sense x k x 360/N. When the records of a sample are taken from
several approach directions fixed to the sensor (the authors' data: 4 directions x 2 distances,
direction-major), a turn by a multiple of the directions' spacing must also move each direction's
records to the next direction (``record_roll``). If some pairing is physical, rotated copies of the
recorded samples land near recorded samples of the SAME object (the turned object was recorded at
another orientation step); if none is, they land at the distance of unrelated rows and their nearest
recorded row is of a random object.

`pairing_table` measures this for every index shift k, both senses and every roll of the approach
directions; `contact_pattern` gives which whiskers each record moves (a symmetric setup moves a
shifted set of whiskers in each direction).
"""

from __future__ import annotations

import numpy as np

from whisker.data.dataset import WhiskerDataset, rotate


def contact_pattern(ds: WhiskerDataset, threshold_px: float = 2.0) -> np.ndarray:
    """(R, W) fraction of samples in which each record moves each whisker by more than threshold_px."""
    return (np.linalg.norm(ds.X, axis=-1) > threshold_px).mean(axis=0)


def turn(X: np.ndarray, k: int, sense: int, record_roll: int = 0, n_directions: int = 4) -> np.ndarray:
    """`rotate` by k whisker spacings, then roll the records' approach directions by record_roll
    (records = n_directions blocks of R / n_directions, direction-major)."""
    Y = rotate(X, k, sense)
    n, R = Y.shape[:2]
    if R % n_directions:
        raise ValueError(f"{R} records do not split into {n_directions} approach directions")
    Y = Y.reshape(n, n_directions, R // n_directions, *Y.shape[2:])
    return np.roll(Y, record_roll, axis=1).reshape(X.shape)


def _nearest(query: np.ndarray, ref: np.ndarray, exclude_self: bool) -> tuple[np.ndarray, np.ndarray]:
    """(distance px, index) of each query row's nearest reference row (Euclidean on flat rows)."""
    from sklearn.neighbors import NearestNeighbors

    nn = NearestNeighbors(n_neighbors=2 if exclude_self else 1).fit(ref)
    d, i = nn.kneighbors(query)
    col = 1 if exclude_self else 0
    return d[:, col], i[:, col]


def pairing_table(ds: WhiskerDataset, n_directions: int = 4) -> list[dict]:
    """One row per pairing (k, sense, record_roll), plus the recorded rows themselves (k = 0):
    median distance (px) from each turned copy to its nearest recorded row, and the fraction of
    copies whose nearest recorded row is the same object (chance = 1 / number of objects)."""
    flat = ds.features()
    d0, i0 = _nearest(flat, flat, exclude_self=True)
    rows = [{"k": 0, "sense": 0, "record_roll": 0, "median_nn_px": float(np.median(d0)),
             "same_object_frac": float(np.mean(ds.y[i0] == ds.y))}]
    for k in range(1, ds.n_whiskers):
        for sense in (1, -1):
            for roll in range(n_directions):
                turned = turn(ds.X, k, sense, roll, n_directions).reshape(len(ds), -1)
                d, i = _nearest(turned, flat, exclude_self=False)
                rows.append({"k": k, "sense": sense, "record_roll": roll, "median_nn_px": float(np.median(d)),
                             "same_object_frac": float(np.mean(ds.y[i] == ds.y))})
    return rows
