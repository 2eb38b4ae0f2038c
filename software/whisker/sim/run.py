"""The run folder: everything one `whisker sim` run writes, published atomically.

Layout of ``<out>/``: ``plan.json`` (effects built/skipped with reasons), ``tracks.csv`` (one row per
recorded time and whisker), ``summary.json`` (what ran, how long, key numbers; written last),
``*.png`` plots, experiment tables (``*.md``/``*.csv``) and ``dataset/<object>.csv`` for the
classification experiment. Files are staged in a sibling temporary folder and moved in one rename
each (summary.json last), so a reader never sees a half-written run.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from whisker.files import atomic_write_json, publish, staging_dir


def tracks_csv(result) -> str:
    """tracks.csv text: t_s, whisker, level, theta_r_deg, theta_t_deg, tip xyz mm, marker xyz mm."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["t_s", "whisker", "level", "theta_r_deg", "theta_t_deg", "tip_x_mm", "tip_y_mm", "tip_z_mm",
                "marker_x_mm", "marker_y_mm", "marker_z_mm"])
    th = result.theta_deg
    for k, t in enumerate(result.t_s):
        for i in range(th.shape[1]):
            w.writerow([f"{t:.6g}", i, f"{result.levels[k, i]:.4g}", f"{th[k, i, 0]:.6g}", f"{th[k, i, 1]:.6g}",
                        *(f"{v:.6g}" for v in result.tips_mm[k, i]), *(f"{v:.6g}" for v in result.markers_mm[k, i])])
    return buf.getvalue()


def plot_angles(result, path: Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for i in range(result.theta_rad.shape[1]):
        ax.plot(result.t_s, result.theta_deg[:, i, 0], lw=1, label=f"whisker {i}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("radial tilt (deg, + retract)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, ncol=4)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_run(out: Path, files: dict[str, bytes | str], summary: dict) -> Path:
    """Publish `files` (name -> content) and summary.json into `out` atomically (summary last)."""
    out = Path(out)
    with staging_dir(out) as tmp:
        names = []
        for name, data in files.items():
            p = tmp / name
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data.encode() if isinstance(data, str) else data)
            names.append(name)
        atomic_write_json(tmp / "summary.json", summary)
        names.append("summary.json")
        old = [str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()] if out.exists() else []
        publish(tmp, out, names, stale=old)
    return out


def png_bytes(draw) -> bytes:
    """Render a matplotlib figure through `draw(path)` into bytes."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "f.png"
        draw(p)
        return p.read_bytes()


def finite_summary(d: dict) -> dict:
    """Round floats for the summary; numpy scalars to Python."""
    def conv(v):
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        if isinstance(v, (np.floating, float)):
            return float(v)
        if isinstance(v, np.integer):
            return int(v)
        if isinstance(v, np.ndarray):
            return conv(v.tolist())
        return v
    return conv(d)
