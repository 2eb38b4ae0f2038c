"""Per-whisker live state from the tracked displacement: rest, contact or dynamic.

Two estimators with one streaming interface, ``update(t_s, dx_px, dy_px) -> labels`` (one int per
whisker, `REST`/`CONTACT`/`DYNAMIC`), so `whisker states`, `whisker live`, the benchmark and the
grasp controller can use either:

- `AuthorsEstimator`: the authors' journal-version method, reproduced exactly (their
  ``airflowCharacterizationRealtime.py`` functions ``fftProcess``/``flowProcess``/``dataSmooth`` as
  driven by ``airflowCharacterizationOffline.classify_offline``; Hu et al., MIT licence). Per frame:
  smooth each coordinate (keep the previous value when it changed by <= 1 px); during the first N
  frames label rest; then over the last N frames: *static* when the largest FFT magnitude of
  dx + i dy, DC excluded, is below 5; *contact* when the window's peak or valley of dx or dy moved
  by more than 4 px from the previous window's; rest when static or contact and the smoothed
  displacement is within sqrt(13) px, contact when static or contact and farther, dynamic otherwise.
  It counts frames, so its time constants scale with the frame rate, and its thresholds are fixed
  pixels, whatever the camera's noise.
- `AdaptiveEstimator`: causal, frame-rate independent (time constants in seconds, integrated with
  each frame's own dt), per-whisker noise learned from rest frames, hysteresis on every decision,
  and an optional expected displacement from the whisker's own actuation (so a coil pulling its
  own whisker is not a contact). See docs/states.md for what it wins and costs.

Labels follow the authors' codes: 0 = rest ("Origin"), 1 = contact, 2 = dynamic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

REST, CONTACT, DYNAMIC = 0, 1, 2
STATE_NAMES = ("rest", "contact", "dynamic")


class StateInputError(ValueError):
    """Bad input to an estimator (shape, NaN where a number is needed, bad parameter)."""


def _frame(dx, dy, n: int | None) -> tuple[np.ndarray, np.ndarray]:
    dx = np.atleast_1d(np.asarray(dx, dtype=float))
    dy = np.atleast_1d(np.asarray(dy, dtype=float))
    if dx.ndim != 1 or dx.shape != dy.shape:
        raise StateInputError(f"dx and dy must be two equal 1-D arrays (got {dx.shape} and {dy.shape})")
    if n is not None and dx.size != n:
        raise StateInputError(f"expected {n} whiskers per frame, got {dx.size}")
    return dx, dy


# --------------------------------------------------------------------------------------------
# The authors' method
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class AuthorsParams:
    """The authors' constants (their offline defaults; the realtime script on the Pi uses N = 15).

    window: N, frames per sliding window. fft_n: their ``fftProcess`` N argument, which sets how
    many spectrum bins are looked at (``|FFT|[:fft_n // 2]``, DC dropped); None = window, as in
    their offline classifier. static_magnitude: 5 (FFT magnitude units, px). contact_px: 4
    (``magThre``). smooth_px: 1 (``threshold``). rest_radius_px: sqrt(13).
    """
    window: int = 30
    fft_n: int | None = None
    static_magnitude: float = 5.0
    contact_px: float = 4.0
    smooth_px: float = 1.0
    rest_radius_px: float = float(np.sqrt(13.0))

    def __post_init__(self):
        n_bins = (self.window if self.fft_n is None else self.fft_n) // 2
        if self.window < 2 or n_bins < 2:
            raise StateInputError(f"window {self.window} / fft_n {self.fft_n} leave no non-DC FFT bin")


def peak_valley(a: np.ndarray) -> tuple[float, float]:
    """The authors' ``findPeakValley``: the largest signed value at a local maximum of |a| and the
    smallest at a local minimum of |a| (scipy.signal.find_peaks, plateaus as find_peaks treats
    them); the window's first value when there is none."""
    mag = np.abs(a)
    peaks, _ = find_peaks(mag)
    valleys, _ = find_peaks(-mag)
    peak = float(np.max(a[peaks])) if peaks.size else float(a[0])
    valley = float(np.min(a[valleys])) if valleys.size else float(a[0])
    return peak, valley


class AuthorsEstimator:
    """Streaming form of the authors' classifier for `n` whiskers (see the module docstring).

    `update` ignores the time stamp (the method counts frames). Invalid (NaN) samples are not part
    of their method; they are replaced by the previous smoothed value (a held marker).
    """

    name = "authors"

    def __init__(self, n: int, params: AuthorsParams | None = None):
        self.n = int(n)
        self.p = params or AuthorsParams()
        self.reset()

    def reset(self) -> None:
        n, w = self.n, self.p.window
        self._prev = np.zeros((2, n))                 # dxFormer, dyFormer
        self._buf = np.zeros((w, 2, n))               # ring buffer of smoothed dx, dy
        self._count = 0
        self._pv = np.zeros((4, n))                   # dxPeak, dxValley, dyPeak, dyValley
        self.static = np.ones(n, dtype=bool)
        self.contact = np.zeros(n, dtype=bool)
        self.smoothed = np.zeros((2, n))

    def update(self, t_s, dx, dy) -> np.ndarray:
        dx, dy = _frame(dx, dy, self.n)
        p = self.p
        cur = np.stack([dx, dy])
        cur = np.where(np.isfinite(cur), cur, self._prev)
        # dataSmooth: keep the previous value when the change is at most smooth_px.
        cur = np.where(np.abs(cur - self._prev) <= p.smooth_px, self._prev, cur)
        self._prev = cur
        self.smoothed = cur
        self._buf[self._count % p.window] = cur
        self._count += 1
        labels = np.full(self.n, REST, dtype=np.int8)
        if self._count <= p.window:         # their `j < N`: the first N frames are rest
            return labels
        order = np.arange(self._count - p.window, self._count) % p.window
        win = self._buf[order]                                   # (N, 2, n), oldest first
        z = win[:, 0, :] + 1j * win[:, 1, :]
        n_bins = (p.window if p.fft_n is None else p.fft_n) // 2
        mag = np.abs(np.fft.fft(z, axis=0))[:n_bins][1:]
        self.static = mag.max(axis=0) < p.static_magnitude
        pv = np.empty((4, self.n))
        for j in range(self.n):
            pv[0, j], pv[1, j] = peak_valley(win[:, 0, j])
            pv[2, j], pv[3, j] = peak_valley(win[:, 1, j])
        self.contact = np.any(np.abs(pv - self._pv) > p.contact_px, axis=0)
        self._pv = pv
        near = np.hypot(cur[0], cur[1]) <= p.rest_radius_px
        labels[:] = np.where(self.static | self.contact, np.where(near, REST, CONTACT), DYNAMIC)
        return labels


def run_estimator(est, t_s, dx, dy) -> np.ndarray:
    """Labels (frames x whiskers, int8) of `est` over whole arrays (frames x whiskers) of a recording."""
    t_s = np.asarray(t_s, dtype=float)
    dx = np.asarray(dx, dtype=float)
    dy = np.asarray(dy, dtype=float)
    if dx.ndim != 2 or dx.shape != dy.shape or t_s.shape != (dx.shape[0],):
        raise StateInputError(f"need time (T,) and dx, dy (T, whiskers); got {t_s.shape}, {dx.shape}, {dy.shape}")
    out = np.empty(dx.shape, dtype=np.int8)
    for k in range(dx.shape[0]):
        out[k] = est.update(t_s[k], dx[k], dy[k])
    return out
