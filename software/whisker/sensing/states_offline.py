"""States of a whole recording, offline: every frame labelled, and labels scored against truth.

`run_estimator` streams a recording's arrays through an estimator of `whisker.sensing.states`;
`label_recording` (what `whisker states` runs) first finds each whisker's rest reference in the whole
recording, so every frame, the first ones included, is judged; `state_scores` and `precision_recall`
compare labels with the true states of a simulated sequence (benchmarks/bench_states.py).
Labels: 0 = rest, 1 = contact, 2 = dynamic (`whisker.sensing.states`).
"""

from __future__ import annotations

import numpy as np

from whisker.sensing.states import (ESTIMATORS, STATE_NAMES, AdaptiveEstimator, AdaptiveParams, AuthorsEstimator,
                                    AuthorsParams, StateInputError, noise_sigma, rest_statistics)

def run_estimator(est, t_s, dx, dy, expected=None) -> np.ndarray:
    """Labels (frames x whiskers, int8) of `est` over whole arrays (frames x whiskers) of a recording;
    `expected` (frames x whiskers x 2 px): displacement from the own actuation, or None."""
    t_s = np.asarray(t_s, dtype=float)
    dx = np.asarray(dx, dtype=float)
    dy = np.asarray(dy, dtype=float)
    if dx.ndim != 2 or dx.shape != dy.shape or t_s.shape != (dx.shape[0],):
        raise StateInputError(f"need time (T,) and dx, dy (T, whiskers); got {t_s.shape}, {dx.shape}, {dy.shape}")
    out = np.empty(dx.shape, dtype=np.int8)
    for k in range(dx.shape[0]):
        out[k] = est.update(t_s[k], dx[k], dy[k], None if expected is None else expected[k])
    return out


class StatesUndecided(StateInputError):
    """The recording does not let the estimator decide (too few frames, no rest reference)."""


def _still_windows(t_s, xy, p: AdaptiveParams):
    """Start/stop frame indices of every learn_s-long window (stride: a quarter of it) of `xy`."""
    T = len(t_s)
    k = 0
    out = []
    while k < T:
        stop = int(np.searchsorted(t_s, t_s[k] + p.learn_s, side="left"))
        stop = max(stop, k + p.learn_frames)
        if stop > T:
            break
        out.append((k, stop))
        k += max(1, (stop - k) // 4)
    return out


def _ids(ws) -> str:
    return ", ".join(str(w) for w in ws) if len(ws) < 3 or list(ws) != list(range(ws[0], ws[-1] + 1)) \
        else f"{ws[0]}-{ws[-1]}"


def label_recording(method: str, t_s, dx, dy, *, window: int = 30, params: AdaptiveParams | None = None,
                    expected=None) -> tuple[np.ndarray, list[str]]:
    """Labels (frames x whiskers) of a whole recording, and notes (one line each) on how the rest
    reference was found. Offline: every frame, the first ones included, is judged.

    authors: their streaming method as it is (its first `window` frames are rest by construction).
    adaptive: calibrated before the first frame, per whisker, from (1) the first learn_s seconds if
    the whisker is still there; else (2) the still learn_s window nearest the tracks' zero; else
    (3) the tracks' zero itself (the tracker's rest baseline) when the whisker comes back within
    the contact threshold of it (noise from second differences). Raises `StatesUndecided` (one
    line) when the recording is too short to learn the noise, or a whisker has none of the three:
    then nothing tells a held contact from a displaced rest."""
    t_s = np.asarray(t_s, dtype=float)
    dx = np.asarray(dx, dtype=float)
    dy = np.asarray(dy, dtype=float)
    if dx.ndim != 2 or dx.shape != dy.shape or t_s.shape != (dx.shape[0],):
        raise StateInputError(f"need time (T,) and dx, dy (T, whiskers); got {t_s.shape}, {dx.shape}, {dy.shape}")
    T, n = dx.shape
    if method == "authors":
        if T <= window:
            raise StatesUndecided(f"{T} frames: the authors' method labels its first {window} frames rest by "
                                  f"construction and needs more than {window} to decide anything")
        return run_estimator(AuthorsEstimator(n, AuthorsParams(window=window)), t_s, dx, dy, expected), []
    if method != "adaptive":
        raise StateInputError(f"unknown state method {method!r}; use one of {', '.join(ESTIMATORS)}")
    est = AdaptiveEstimator(n, params)
    p = est.p
    if T < p.learn_frames:
        raise StatesUndecided(f"{T} frames: the adaptive estimator needs at least {p.learn_frames} frames "
                              f"to learn the tracking noise")
    xy = np.stack([dx, dy], axis=-1)
    wins = _still_windows(t_s, xy, p) or [(0, T)]
    a, b = wins[0]
    med, sigma, still = rest_statistics(xy[a:b], p)
    rest = np.where(still[:, None], med, np.nan)
    whole_sigma = noise_sigma(xy)
    found, zero = [], []
    moved = [w for w in range(n) if not still[w]]
    undecided = []
    for w in moved:
        best = None
        for a, b in wins[1:]:
            m, sg, st_ = rest_statistics(xy[a:b, w:w + 1], p)
            if st_[0] and (best is None or np.hypot(*m[0]) < np.hypot(*best[0])):
                best = (m[0], sg[0])
        if best is not None:
            rest[w], sigma[w] = best
            found.append(w)
            continue
        sg = whole_sigma[w]
        sg = np.maximum(np.where(np.isfinite(sg), sg, p.noise_floor_px), p.noise_floor_px)
        thr = max(p.contact_on * float(np.hypot(*sg)), p.contact_min_px)
        with np.errstate(invalid="ignore"):
            closest = np.nanmin(np.hypot(xy[:, w, 0], xy[:, w, 1])) if np.any(np.isfinite(xy[:, w])) else np.inf
        if closest <= thr:
            rest[w], sigma[w] = 0.0, sg
            zero.append(w)
        else:
            undecided.append((w, closest))
    if undecided:
        w, c = undecided[0]
        raise StatesUndecided(
            f"no rest segment for whisker(s) {', '.join(str(u[0]) for u in undecided)}: never still for "
            f"{p.learn_s:g} s and never back at the tracks' zero (whisker {w} stays {c:.1f} px away), so a held "
            f"contact cannot be told from a displaced rest; record rest frames first")
    notes = []
    if found:
        notes.append(f"whisker(s) {_ids(found)} moving in the first {p.learn_s:g} s: rest learnt from a later "
                     f"still stretch")
    if zero:
        notes.append(f"whisker(s) {_ids(zero)} never still for {p.learn_s:g} s: rest = the tracks' zero (the "
                     f"tracker's rest baseline), which they pass within the contact threshold")
    est.rest = rest
    est.sigma = sigma
    est.still = still
    est.ready = True
    est._t0 = float(t_s[0])
    return run_estimator(est, t_s, dx, dy, expected), notes


def state_scores(truth, labels) -> dict:
    """Per-state accuracy and latency of `labels` against `truth` (both frames x whiskers).

    accuracy[s]: fraction of the frames whose truth is s labelled s. latency[s]: for every run of
    truth s (per whisker, not starting at frame 0), frames from the run's first frame to the first
    frame labelled s inside the run; runs never labelled s count in `missed[s]`.
    """
    truth = np.asarray(truth)
    labels = np.asarray(labels)
    if truth.shape != labels.shape or truth.ndim != 2:
        raise StateInputError(f"truth and labels must be equal (frames, whiskers) arrays ({truth.shape}, {labels.shape})")
    out = {"accuracy": {}, "latency": {}, "missed": {}, "runs": {}}
    for s, name in enumerate(STATE_NAMES):
        sel = truth == s
        out["accuracy"][name] = float(np.mean(labels[sel] == s)) if sel.any() else float("nan")
        lat, missed, runs = [], 0, 0
        for w in range(truth.shape[1]):
            col, lab = truth[:, w], labels[:, w]
            starts = np.flatnonzero((col == s) & (np.r_[-1, col[:-1]] != s))
            for a in starts:
                if a == 0:
                    continue
                b = a
                while b < len(col) and col[b] == s:
                    b += 1
                runs += 1
                hit = np.flatnonzero(lab[a:b] == s)
                if hit.size:
                    lat.append(int(hit[0]))
                else:
                    missed += 1
        out["latency"][name] = lat
        out["missed"][name] = missed
        out["runs"][name] = runs
    return out


def precision_recall(truth, labels) -> dict:
    """Per-class precision, recall and support of `labels` against `truth` (same-shape int arrays).

    precision[s] = frames labelled s whose truth is s / frames labelled s (NaN when none is
    labelled s); recall[s] = frames of truth s labelled s / frames of truth s (NaN when none);
    support[s] = frames of truth s; predicted[s] = frames labelled s."""
    truth = np.asarray(truth).ravel()
    labels = np.asarray(labels).ravel()
    if truth.shape != labels.shape:
        raise StateInputError(f"truth and labels differ in size ({truth.size}, {labels.size})")
    out = {"precision": {}, "recall": {}, "support": {}, "predicted": {}}
    for s, name in enumerate(STATE_NAMES):
        tp = int(np.sum((truth == s) & (labels == s)))
        n_true, n_pred = int(np.sum(truth == s)), int(np.sum(labels == s))
        out["precision"][name] = tp / n_pred if n_pred else float("nan")
        out["recall"][name] = tp / n_true if n_true else float("nan")
        out["support"][name] = n_true
        out["predicted"][name] = n_pred
    return out
