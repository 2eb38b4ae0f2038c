"""Plots from recordings: each whisker's displacement against time, mean and error band across
trials, with the actuation phases marked (the paper's Fig. 8).

The paper (Fig. 8) plots, for 5 grasp trials of one object with 8 whiskers, the mean displacement
of every whisker against the frame number with an error band, and marks three commands: (1)
neutral -> retraction, (2) the robot arm moving up, (3) retraction -> neutral. Here the trials are
session folders written by ``whisker record``; the commands come from their actuation tables
(``retract``, ``hold`` = the arm lifts, ``release``), and time is seconds since each trial's first
``retract`` command (the trials are aligned on it), resampled onto one grid by linear
interpolation between valid frames (never across a gap of invalid frames longer than ``max_gap_s``).

`fig8_data` is pure (numbers in, numbers out); `plot_fig8` draws and writes atomically.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from whisker.data.session import Session, load_session

#: most points of the common time grid (a day at 10 ms)
MAX_GRID_POINTS = 10_000_000
#: The paper's phase markers: actuation phase name -> label on the plot.
PHASE_MARKS = {"retract": "(1) retract", "hold": "(2) arm up", "release": "(3) release"}
UNITS = {"px": "marker displacement (px)", "mm": "tip displacement (mm)", "deg": "tilt theta (deg)"}


@dataclass
class Fig8Data:
    """t_s (T,); mean, band_lo, band_hi (T, N); count (T, N) trials contributing; phases: name ->
    mean time (s, relative to the alignment event) across trials; quantity; trials."""

    t_s: np.ndarray
    mean: np.ndarray
    band_lo: np.ndarray
    band_hi: np.ndarray
    count: np.ndarray
    phases: dict
    quantity: str
    trials: int
    band: str
    #: (start_s, end_s, label) intervals the plot shades: the guard's derates and cuts, and gaps
    #: with no frame longer than max_gap_s (bridged by interpolation, not blanked)
    shades: list = None


def _interp_valid(t_grid, t, y, max_gap_s):
    """Interpolate y(t) onto t_grid from its finite samples; NaN outside them, and across a gap
    longer than max_gap_s that holds invalid frames (lost markers). A gap with no frame at all
    (the camera was late) is bridged: `frame_gaps` reports it, for the plot to shade."""
    ok = np.isfinite(y) & np.isfinite(t)
    out = np.full(t_grid.shape, np.nan)
    if ok.sum() == 0:
        return out
    tv, yv = t[ok], y[ok]
    if ok.sum() == 1:
        out[np.isclose(t_grid, tv[0])] = yv[0]
        return out
    out = np.interp(t_grid, tv, yv, left=np.nan, right=np.nan)
    # blank grid points that fall in a gap between valid samples longer than max_gap_s
    j = np.clip(np.searchsorted(tv, t_grid), 1, len(tv) - 1)
    gap = tv[j] - tv[j - 1]
    pos = np.flatnonzero(ok)
    invalid_between = (pos[j] - pos[j - 1]) > 1
    out[(gap > max_gap_s) & invalid_between] = np.nan
    return out


def frame_gaps(t, max_gap_s) -> list[tuple[float, float]]:
    """(start, end) s of every interval between consecutive frames longer than max_gap_s."""
    t = np.asarray(t, dtype=float)
    t = t[np.isfinite(t)]
    if t.size < 2:
        return []
    k = np.flatnonzero(np.diff(t) > max_gap_s)
    return [(float(t[i]), float(t[i + 1])) for i in k]


#: --align value that aligns every trial on its first frame instead of an actuation command
ALIGN_FIRST_FRAME = "frame"


def align_time(session: Session, align: str = "retract") -> float | None:
    """The alignment instant of a session, s: its first `align` command (None when it has none), or
    its first frame for align = "frame"."""
    if align == ALIGN_FIRST_FRAME:
        if len(session.frame_time_s) == 0:
            raise ValueError(f"session {session.folder} has no frames")
        return float(session.frame_time_s[0])
    for t, p in session.phase_times():
        if p == align and np.isfinite(t):
            return float(t)
    return None


def _check_align(sessions: Sequence[Session], align: str) -> None:
    """Refuse an alignment that is unknown, or that some trials cannot follow (naming them)."""
    if align == ALIGN_FIRST_FRAME:
        return
    seen = sorted({p for s in sessions for _, p in s.phase_times()})
    if align not in PHASE_MARKS and align not in seen:
        raise ValueError(f"unknown --align {align!r}: use {ALIGN_FIRST_FRAME!r} (first frame) or an actuation "
                         f"phase ({', '.join(sorted(set(PHASE_MARKS) | set(seen)))})")
    missing = [str(s.folder) for s in sessions if align_time(s, align) is None]
    if missing:
        raise ValueError(f"no {align!r} command to align on in {len(missing)} trial(s): {', '.join(missing)} "
                         "(empty or unreadable actuation.csv?); record them with actuation, or give "
                         f"--align {ALIGN_FIRST_FRAME} to align every trial on its first frame")


def fig8_data(sessions: Sequence[Session], *, quantity: str = "px", align: str = "retract",
              dt_s: Optional[float] = None, band: str = "std", max_gap_s: Optional[float] = None) -> Fig8Data:
    """Mean and band of each whisker's displacement across trials, on a common time grid.

    quantity: "px" (marker |(dx, dy)|), "mm" (tip |(x, y)| displacement) or "deg" (theta).
    band: "std" (mean +- one standard deviation), "sem" (+- standard error) or "minmax".
    dt_s: grid step (default: the median frame interval of all trials). max_gap_s: longest run of
    invalid frames bridged by interpolation (default 3 grid steps).
    """
    if not sessions:
        raise ValueError("fig8: no sessions given")
    if band not in ("std", "sem", "minmax"):
        raise ValueError(f"band must be std, sem or minmax, got {band!r}")
    n = {int(s.meta["whiskers"]) for s in sessions}
    if len(n) != 1:
        raise ValueError(f"fig8: the sessions have different whisker counts {sorted(n)}")
    n = n.pop()
    for s in sessions:
        if not s.tracks:
            raise ValueError(f"session {s.folder} has no tracks (recorded with --no-track?): "
                             "track it first or record with tracking")
    _check_align(sessions, align)
    series, phases = [], {}
    intervals, shades = [], []
    empty = [str(s.folder) for s in sessions if len(s.frame_time_s) == 0]
    if empty:
        raise ValueError(f"no frames in {', '.join(empty)} (frames.csv has no complete row): nothing to plot")
    for s in sessions:
        t0 = align_time(s, align)
        t = s.frame_time_s - t0
        if not np.all(np.isfinite(s.frame_time_s)):
            raise ValueError(f"session {s.folder}: frames.csv has frame times that are not finite numbers; "
                             "the recording is damaged (check frames.csv)")
        for a, b, kind, coils in s.guard_intervals():
            shades.append((a - t0, b - t0, f"guard {kind}"))
        series.append((t, s.displacement(quantity)))
        if len(t) > 1:
            intervals.append(np.diff(t))
        for tp, p in s.phase_times():
            if p in PHASE_MARKS:
                phases.setdefault(p, []).append(tp - t0)
    if dt_s is None:
        allint = np.concatenate(intervals) if intervals else np.array([])
        allint = allint[allint > 0]
        dt_s = float(np.median(allint)) if allint.size else 1.0
    if not (dt_s > 0 and np.isfinite(dt_s)):
        raise ValueError(f"fig8: time step must be a positive number, got {dt_s}")
    max_gap_s = 3.0 * dt_s if max_gap_s is None else float(max_gap_s)
    for t, _ in series:
        shades += [(a, b, "no frames") for a, b in frame_gaps(t, max_gap_s)]
    t_min = min(float(np.min(t)) for t, _ in series if len(t))
    t_max = max(float(np.max(t)) for t, _ in series if len(t))
    span = (t_max - t_min) / dt_s
    if not span < MAX_GRID_POINTS:
        raise ValueError(f"fig8: {span:.3g} grid points (dt_s={dt_s:g} s over {t_max - t_min:g} s), over "
                         f"{MAX_GRID_POINTS:,}; give a larger --dt")
    steps = int(np.floor(span + 1e-9)) + 1
    grid = t_min + dt_s * np.arange(steps)
    stack = np.full((len(series), steps, n), np.nan)
    for k, (t, d) in enumerate(series):
        for w in range(n):
            stack[k, :, w] = _interp_valid(grid, t, d[:, w], max_gap_s)
    count = np.sum(np.isfinite(stack), axis=0)
    if not count.any():
        raise ValueError(f"no valid point: every {quantity} value of the {len(sessions)} trial(s) is invalid, NaN "
                         "or infinite (markers lost?); check the tracks (whisker track) before plotting")
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            mean = np.nanmean(stack, axis=0)
            if band == "minmax":
                lo, hi = np.nanmin(stack, axis=0), np.nanmax(stack, axis=0)
            else:
                sd = np.nanstd(stack, axis=0, ddof=0)
                if band == "sem":
                    sd = sd / np.sqrt(np.maximum(count, 1))
                lo, hi = mean - sd, mean + sd
    return Fig8Data(grid, mean, lo, hi, count, {p: float(np.mean(v)) for p, v in phases.items()},
                    quantity, len(sessions), band, _merge_shades(shades))


def _merge_shades(shades) -> list[tuple[float, float, str]]:
    """Overlapping intervals of one label merged (one shade per derate across coils and trials)."""
    out = []
    for label in sorted({x[2] for x in shades}):
        iv = sorted((a, b) for a, b, lab in shades if lab == label)
        merged = []
        for a, b in iv:
            if merged and a <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], b)
            else:
                merged.append([a, b])
        out += [(a, b, label) for a, b in merged]
    return sorted(out)


def plot_fig8(data: Fig8Data, path, *, title: str = "", grid: bool = False) -> Path:
    """Draw Fig. 8 (one axes, a line + band per whisker; or one panel per whisker with grid=True)
    and write it atomically to `path` (format from the suffix, e.g. .png, .pdf, .svg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from whisker.files import atomic_write_bytes

    n = data.mean.shape[1]
    colors = plt.get_cmap("tab10" if n <= 10 else "tab20")
    if grid:
        cols = min(4, n)
        rows = int(np.ceil(n / cols))
        fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.4 * rows), sharex=True, sharey=True,
                                 squeeze=False)
        axs = [axes[i // cols, i % cols] for i in range(n)]
        for ax in axes.ravel()[n:]:
            ax.set_visible(False)
    else:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        axs = [ax] * n
    for w in range(n):
        ax = axs[w]
        c = colors(w % colors.N)
        ax.plot(data.t_s, data.mean[:, w], color=c, lw=1.5, label=f"whisker {w}")
        ax.fill_between(data.t_s, data.band_lo[:, w], data.band_hi[:, w], color=c, alpha=0.2, lw=0)
        if grid:
            ax.set_title(f"whisker {w}", fontsize=9)
    shade_colors = {"guard derate": "#f2c14e", "guard cut": "#d62728", "no frames": "#999999"}
    for ax in set(axs):
        seen = set()
        for a, b, label in data.shades or []:
            ax.axvspan(a, b, color=shade_colors.get(label, "#cccccc"), alpha=0.18, lw=0,
                       label=label if label not in seen else None)
            seen.add(label)
        for p, t in data.phases.items():
            ax.axvline(t, color="k", ls="--", lw=0.8)
            ax.annotate(PHASE_MARKS[p], (t, 1.0), xycoords=("data", "axes fraction"), fontsize=8,
                        rotation=90, va="top", ha="right")
        ax.grid(alpha=0.3)
    band = {"std": "mean +- 1 sd", "sem": "mean +- 1 sem", "minmax": "mean, min-max"}[data.band]
    label_ax = axs[0] if not grid else axes[-1, 0]
    label_ax.set_xlabel("time from the retract command (s)")
    label_ax.set_ylabel(UNITS[data.quantity])
    if not grid:
        axs[0].legend(fontsize=8, ncol=2, loc="upper right")
    elif data.shades:
        axs[0].legend(handles=[h for h in axs[0].get_legend_handles_labels()[0] if not h.get_label().startswith(
            "whisker")], fontsize=7, loc="upper right")
    fig.suptitle(title or f"{band} over {data.trials} trial(s)", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lstrip(".") or "png", dpi=150)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


def fig8_csv(data: Fig8Data) -> str:
    """The curves as CSV: t_s, then mean/lo/hi/count per whisker."""
    n = data.mean.shape[1]
    head = ["t_s"] + [f"{k}_{w}" for w in range(n) for k in ("mean", "lo", "hi", "count")]
    lines = [",".join(head)]

    def f(v):
        return "" if not np.isfinite(v) else f"{v:.6g}"

    for i, t in enumerate(data.t_s):
        cells = [f"{t:.6f}"]
        for w in range(n):
            cells += [f(data.mean[i, w]), f(data.band_lo[i, w]), f(data.band_hi[i, w]), str(int(data.count[i, w]))]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def load_sessions(folders) -> list[Session]:
    return [load_session(Path(f)) for f in folders]
