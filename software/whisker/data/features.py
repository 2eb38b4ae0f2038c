"""Feature steps for the whisker classifiers, as scikit-learn transformers (see whisker.data.models).

- `PolarFeatures`: per record and whisker, log(1 + |d|/px) and the direction d / max(|d|, floor_px).
  A marker's displacement is the tilt of its whisker (magnitude ~ contact force / distance, direction
  ~ where the object pushes); the log compresses the 1-20 px range so a softly touched whisker weighs
  like a hard one, and the floor keeps the direction of a resting whisker (pixel noise) near zero.
- `CyclicDFTFeatures`: log(1 + |FFT_k|) over the whisker index of z = dx + i dy, per record. Invariant
  to a cyclic shift of the whisker index AND to a common rotation of all vectors (|FFT| ignores a
  shift's phase ramp and a global phase), so it is invariant to the array's 360/N rotations in either
  sense (`whisker.data.dataset.rotate`): the symmetric model, for data that holds the array's symmetry.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin


def _samples(X, n_records: int, n_whiskers: int) -> np.ndarray:
    """Flat rows (n, R*W*2) -> (n, R, W, 2) float (shape checked by the dataset layer before)."""
    X = np.asarray(X, dtype=float)
    return X.reshape(len(X), n_records, n_whiskers, 2)


class PolarFeatures(TransformerMixin, BaseEstimator):
    """(n, R*W*2) px -> (n, 3*R*W): log(1 + |d|/px) per record and whisker, then d / max(|d|, floor_px)."""

    def __init__(self, n_records: int = 8, n_whiskers: int = 8, floor_px: float = 1.0):
        self.n_records = n_records
        self.n_whiskers = n_whiskers
        self.floor_px = floor_px

    def fit(self, X, y=None):
        if self.floor_px <= 0:
            raise ValueError(f"floor_px must be > 0, got {self.floor_px}")
        return self

    def transform(self, X):
        S = _samples(X, self.n_records, self.n_whiskers)
        mag = np.linalg.norm(S, axis=-1)
        unit = S / np.maximum(mag, self.floor_px)[..., None]
        return np.concatenate([np.log1p(mag).reshape(len(S), -1), unit.reshape(len(S), -1)], axis=1)


class CyclicDFTFeatures(TransformerMixin, BaseEstimator):
    """(n, R*W*2) px -> (n, R*W): log(1 + |DFT over the whisker index of dx + i dy|) per record.

    Invariant to ``rotate(X, k, sense)`` of whisker.data.dataset for every k and either sense.
    """

    def __init__(self, n_records: int = 8, n_whiskers: int = 8):
        self.n_records = n_records
        self.n_whiskers = n_whiskers

    def fit(self, X, y=None):
        return self

    def transform(self, X):
        S = _samples(X, self.n_records, self.n_whiskers)
        spectrum = np.abs(np.fft.fft(S[..., 0] + 1j * S[..., 1], axis=-1))
        return np.log1p(spectrum).reshape(len(S), -1)
