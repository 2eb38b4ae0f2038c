"""Feasibility sweep over whisker count and ring radius: which designs build and pass every check.

Each point is the default design with `whiskers.count` and `whiskers.ring_radius` changed; it is
either feasible or refused with the first failed check's one-line reason. Results: a CSV table,
a Markdown summary and a plot of the feasible region.
"""

from __future__ import annotations

import csv
import io
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Callable, Iterable

from whisker.design import DesignError, load_design
from whisker.files import atomic_write_bytes, atomic_write_text


def evaluate_point(args: tuple[str | None, tuple[str, ...], int, float]) -> dict:
    design_file, overrides, count, radius = args
    row = {"count": count, "ring_radius_mm": radius, "feasible": False, "failed_check": "", "reason": ""}
    try:
        d = load_design(design_file, (*overrides, f"whiskers.count={count}", f"whiskers.ring_radius={radius}"))
    except DesignError as err:
        row.update(failed_check="design validation", reason=str(err))
        return row
    from .build import evaluate  # CadQuery loads in the worker only

    try:
        results = evaluate(d)
    except Exception as err:  # a CAD kernel failure is a refusal of this point, with its reason
        row.update(failed_check="CAD kernel", reason=f"{type(err).__name__}: {err}")
        return row
    failed = [c for c in results if not c.ok]
    if failed:
        row.update(failed_check=f"{failed[0].part}: {failed[0].name}", reason=failed[0].line())
    else:
        row["feasible"] = True
    return row


def sweep(counts: Iterable[int], radii: Iterable[float], design_file: str | None = None,
          overrides: tuple[str, ...] = (), workers: int = 2,
          progress: Callable[[int, int], None] | None = None) -> list[dict]:
    jobs = [(design_file, tuple(overrides), n, float(r)) for n in counts for r in radii]
    rows: list[dict] = []
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        for i, row in enumerate(pool.map(evaluate_point, jobs), 1):
            rows.append(row)
            if progress:
                progress(i, len(jobs))
    return rows


def write_reports(rows: list[dict], out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    paths = [atomic_write_text(out / "sweep.csv", buf.getvalue())]

    counts = sorted({r["count"] for r in rows})
    radii = sorted({r["ring_radius_mm"] for r in rows})
    cell = {(r["count"], r["ring_radius_mm"]): r for r in rows}
    lines = ["# Feasible designs: whisker count x ring radius", "",
             "`ok` builds and passes every geometry check; otherwise the first failed check.", "",
             "| count \\ radius (mm) | " + " | ".join(f"{r:g}" for r in radii) + " |",
             "|---|" + "---|" * len(radii)]
    for n in counts:
        lines.append(f"| {n} | " + " | ".join("ok" if cell[(n, r)]["feasible"] else _short(cell[(n, r)]["failed_check"])
                                             for r in radii) + " |")
    reasons = sorted({r["failed_check"] for r in rows if not r["feasible"]})
    lines += ["", "Failed checks seen: " + ", ".join(f"`{x}`" for x in reasons) if reasons else "", ""]
    paths.append(atomic_write_text(out / "sweep.md", "\n".join(lines)))
    paths.append(_plot(rows, counts, radii, out / "sweep.png"))
    return paths


def _short(check: str) -> str:
    return check.split(": ", 1)[-1][:28]


def _plot(rows, counts, radii, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reasons = sorted({r["failed_check"] for r in rows if not r["feasible"]})
    fig, ax = plt.subplots(figsize=(9, 5.5))
    ok = [r for r in rows if r["feasible"]]
    ax.scatter([r["ring_radius_mm"] for r in ok], [r["count"] for r in ok], marker="s", s=120, c="tab:green",
               label="feasible")
    markers = "xv^<>dph*+"
    for i, reason in enumerate(reasons):
        pts = [r for r in rows if r["failed_check"] == reason]
        ax.scatter([r["ring_radius_mm"] for r in pts], [r["count"] for r in pts], marker=markers[i % len(markers)],
                   s=50, label=f"refused: {_short(reason)}")
    ax.set_xlabel("ring radius (mm)")
    ax.set_ylabel("whisker count")
    ax.set_xticks(radii)
    ax.set_yticks(counts)
    ax.grid(alpha=0.3)
    ax.set_title("Feasible region of the default design (everything else as in hw/sensor.toml)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())
