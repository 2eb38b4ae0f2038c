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

Labels follow the authors' codes: 0 = rest ("Origin"), 1 = contact, 2 = dynamic. A whole recording
labelled offline (the rest reference found first) and labels scored against truth:
`whisker.sensing.states_offline`.
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

    @property
    def ready(self) -> bool:
        """True once a frame was judged (their first `window` frames are rest by construction)."""
        return self._count > self.p.window

    @property
    def needs(self) -> str:
        return f"more than {self.p.window} frames"

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

    def update(self, t_s, dx, dy, expected=None) -> np.ndarray:
        """Labels of this frame. `t_s` and `expected` are not used: the method counts frames and
        knows nothing of the actuation command."""
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


# --------------------------------------------------------------------------------------------
# A better method: causal, in seconds, noise-aware, with hysteresis
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class AdaptiveParams:
    """Constants of `AdaptiveEstimator` (times in s, thresholds in units of the learned noise).

    learn_s: the first seconds are rest frames: per-whisker rest offset (median) and noise (1.4826
    x median absolute deviation, per axis) come from them. contact_on/off: displacement from rest,
    in noise std, that starts/ends a contact (hysteresis), never below contact_min_px/off_min_px.
    motion_s: window of the motion test; lag_s: the change is taken over this lag (at least one
    frame), so the test means the same at any frame rate; motion_on/off: median |change| in that
    window, in multiples of that median for pure noise (Rayleigh: 1.665 sigma per axis), that
    starts/ends dynamic, never below motion_min_px. drift_s: time constant of the rest offset's
    slow update while at rest. expected_tolerance: the share of the expected (own-actuation)
    displacement added to the contact thresholds, for the error of the free-closing model (the
    simulator's static map is 6-9 % off MuJoCo's warm coils). still_spread, still_min_px: a learning
    window is a rest segment when its spread about the median is within still_spread x the noise
    (from second differences, which smooth motion hardly enters) and still_min_px; a whisker that
    moves during it keeps the tracks' zero (the tracker's rest baseline) as its rest offset.
    """
    learn_s: float = 1.0
    learn_frames: int = 10
    contact_on: float = 6.0
    contact_off: float = 3.0
    contact_min_px: float = 1.5
    off_min_px: float = 0.8
    motion_s: float = 0.4
    lag_s: float = 0.066
    motion_on: float = 2.5
    motion_off: float = 1.6
    motion_min_px: float = 0.6
    drift_s: float = 10.0
    noise_floor_px: float = 0.05
    expected_tolerance: float = 0.0
    still_spread: float = 2.5
    still_min_px: float = 0.8


def noise_sigma(xy: np.ndarray) -> np.ndarray:
    """Tracking noise std per whisker and axis (px) of frames `xy` (F, n, 2) that may be moving.

    1.4826 x the median absolute deviation of the second differences x[k+1] - 2 x[k] + x[k-1],
    divided by sqrt(6) (the std of a second difference of white noise of std sigma): smooth motion
    (a swing, a slow push) hardly enters it, unlike the spread about the median. NaN where fewer
    than 3 finite second differences exist."""
    d2 = xy[2:] - 2.0 * xy[1:-1] + xy[:-2]
    with np.errstate(all="ignore"):
        med = np.nanmedian(d2, axis=0)
        mad = np.nanmedian(np.abs(d2 - med), axis=0)
    ok = np.sum(np.isfinite(d2), axis=0) >= 3
    return np.where(ok, 1.4826 * mad / np.sqrt(6.0), np.nan)


def rest_statistics(xy: np.ndarray, p: "AdaptiveParams") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(median (n, 2) px, noise sigma (n, 2) px, still (n,) bool) of frames `xy` (F, n, 2).

    sigma: the smaller of the spread about the median (1.4826 MAD) and the second-difference
    estimate (`noise_sigma`), floored at `p.noise_floor_px`. still: 90 % of the frames lie within
    `p.still_spread` x hypot(sigma) (and `p.still_min_px`) of the median, i.e. the frames are a rest
    segment rather than a motion the learning window happened to see."""
    with np.errstate(all="ignore"):
        med = np.nanmedian(xy, axis=0)
        spread = 1.4826 * np.nanmedian(np.abs(xy - med), axis=0)
        reach = np.nanpercentile(np.hypot(*(xy - med).transpose(2, 0, 1)), 90, axis=0)    # (n,) px
    d2 = noise_sigma(xy)
    sigma = np.where(np.isfinite(d2), np.fmin(spread, d2), spread)
    sigma = np.maximum(np.where(np.isfinite(sigma), sigma, p.noise_floor_px), p.noise_floor_px)
    s = np.hypot(sigma[:, 0], sigma[:, 1])
    # 90 % of 2-D Gaussian noise lies within 1.52 x hypot(sigma_x, sigma_y) of the median
    still = reach <= np.maximum(p.still_spread * s, p.still_min_px)
    return med, sigma, still & np.all(np.isfinite(med), axis=1)


class AdaptiveEstimator:
    """Causal per-whisker state (see the module docstring); `update(t_s, dx, dy, expected=None)`.

    `expected` (n, 2) px: the displacement the whisker's own actuation should cause (from the
    command), subtracted before the tests, so a whisker moved by its own coil is at rest.
    Everything is in seconds and noise units, so a 15 or 90 frames/s camera gives the same
    decisions up to sampling. NaN (lost marker) samples hold the last label and leave the
    statistics untouched; `lost` counts consecutive NaN frames per whisker.
    """

    name = "adaptive"

    @property
    def needs(self) -> str:
        return f"{self.p.learn_s:g} s and {self.p.learn_frames} frames of rest"

    def __init__(self, n: int, params: AdaptiveParams | None = None):
        self.n = int(n)
        self.p = params or AdaptiveParams()
        self.reset()

    def reset(self) -> None:
        n = self.n
        self._learn: list[np.ndarray] = []
        self._t0: float | None = None
        self.ready = False
        self.rest = np.zeros((n, 2))
        self.sigma = np.full((n, 2), 0.3)
        self._hist: list[tuple[float, np.ndarray]] = []     # (t, |change| per whisker)
        self._past: list[tuple[float, np.ndarray]] = []     # (t, xy) of the last lag_s seconds
        self.contact = np.zeros(n, dtype=bool)
        self.moving = np.zeros(n, dtype=bool)
        self.labels = np.full(n, REST, dtype=np.int8)
        self.displacement = np.zeros((n, 2))
        self.lost = np.zeros(n, dtype=int)
        self.still = np.ones(n, dtype=bool)
        self._t_prev: float | None = None

    def calibrate(self, dx, dy) -> np.ndarray:
        """Learn rest offset and noise from rest frames (arrays frames x whiskers); returns the
        per-whisker `still` flags (see `rest_statistics`). A whisker that was not still keeps the
        rest offset of the tracks' zero (the tracker's rest baseline) instead of the frames' median."""
        xy = np.stack([np.asarray(dx, float), np.asarray(dy, float)], axis=-1)   # (F, n, 2)
        if xy.ndim != 3 or xy.shape[1] != self.n or xy.shape[0] < 3:
            raise StateInputError(f"calibration needs at least 3 rest frames of {self.n} whiskers")
        med, sigma, still = rest_statistics(xy, self.p)
        if not np.all(np.isfinite(med)):
            raise StateInputError("a whisker has no valid marker in the rest frames")
        self.rest = np.where(still[:, None], med, 0.0)
        self.sigma = sigma
        self.still = still
        self.ready = True
        return still

    def update(self, t_s, dx, dy, expected=None) -> np.ndarray:
        dx, dy = _frame(dx, dy, self.n)
        t = float(t_s)
        if not np.isfinite(t):
            raise StateInputError("frame time must be finite")
        if self._t_prev is not None and t <= self._t_prev:
            raise StateInputError(f"frame times must increase (got {t} after {self._t_prev})")
        p = self.p
        xy = np.stack([dx, dy], axis=-1)
        if self._t0 is None:
            self._t0 = t
        if not self.ready:
            self._learn.append(xy)
            if not (t - self._t0 >= p.learn_s and len(self._learn) >= p.learn_frames):
                self._t_prev = t
                return self.labels.copy()
            arr = np.array(self._learn)
            self.calibrate(arr[..., 0], arr[..., 1])      # then this frame is judged too
            self._past = [(self._t_prev, arr[-2])] if len(arr) > 1 else [(t, xy.copy())]
        if self._t_prev is None:           # calibrated beforehand (label_recording): judge from frame 0
            self._t_prev = t
            self._past = [(t, np.where(np.isfinite(xy), xy, self.rest))]
        dt = t - self._t_prev
        self._t_prev = t
        ok = np.all(np.isfinite(xy), axis=1)
        self.lost = np.where(ok, 0, self.lost + 1)
        exp = np.zeros((self.n, 2)) if expected is None else np.asarray(expected, float).reshape(self.n, 2)
        d = xy - self.rest - exp
        s = np.hypot(self.sigma[:, 0], self.sigma[:, 1])         # rms of |d| from noise, px
        # contact / displaced test on this frame alone: reacts within one frame
        mag = np.hypot(d[:, 0], d[:, 1])
        slack = p.expected_tolerance * np.hypot(exp[:, 0], exp[:, 1])
        on = mag > np.maximum(p.contact_on * s, p.contact_min_px) + slack
        off = mag < np.maximum(p.contact_off * s, p.off_min_px) + slack
        self.contact = np.where(ok, np.where(self.contact, ~off, on), self.contact)
        # motion test: median |change over lag_s| within the last motion_s seconds (a step, such
        # as a contact's onset, changes lag_s / motion_s of them and does not move the median)
        while len(self._past) > 1 and self._past[1][0] <= t - p.lag_s + 1e-9:
            self._past.pop(0)
        with np.errstate(invalid="ignore"):
            ch = np.hypot(*(xy - self._past[0][1]).T)
        last = self._past[-1][1]
        self._past.append((t, np.where(ok[:, None], xy, last)))
        self._hist.append((t, ch))
        while self._hist and self._hist[0][0] < t - p.motion_s:
            self._hist.pop(0)
        arr = np.array([h[1] for h in self._hist])
        if np.all(np.isfinite(arr)):
            med = np.median(arr, axis=0)          # nanmedian's masked path is ~30x slower on small arrays
        else:
            with np.errstate(all="ignore"):
                med = np.nanmedian(arr, axis=0)
        med = np.where(np.isfinite(med), med, 0.0)
        # |change| of pure noise is Rayleigh with scale sqrt(2) sigma: median 1.665 sigma
        noise_med = 1.665 * self.sigma.mean(axis=1)
        m_on = med > np.maximum(p.motion_on * noise_med, p.motion_min_px)
        m_off = med < np.maximum(p.motion_off * noise_med, 0.6 * p.motion_min_px)
        self.moving = np.where(ok, np.where(self.moving, ~m_off, m_on), self.moving)
        lab = np.where(self.moving, DYNAMIC, np.where(self.contact, CONTACT, REST)).astype(np.int8)
        self.labels = np.where(ok, lab, self.labels).astype(np.int8)
        self.displacement = np.where(ok[:, None], d, self.displacement)
        # slow drift of the rest offset while at rest
        at_rest = ok & (self.labels == REST) & (exp == 0).all(axis=1)
        if dt > 0 and p.drift_s > 0:
            a = 1.0 - np.exp(-dt / p.drift_s)
            self.rest = np.where(at_rest[:, None], self.rest + a * (xy - self.rest), self.rest)
        return self.labels.copy()


ESTIMATORS = {"authors": AuthorsEstimator, "adaptive": AdaptiveEstimator}


def make_estimator(method: str, n: int):
    try:
        return ESTIMATORS[method](n)
    except KeyError:
        raise StateInputError(f"unknown state method {method!r}; use one of {', '.join(ESTIMATORS)}") from None
