"""Feasibility sweep over whisker count and ring radius: which designs build and pass every check.

Each point is the design with `whiskers.count` and `whiskers.ring_radius` changed (every size set to
"auto" follows the ring); it is either feasible or refused with the physical conflict behind it.
Points run in parallel with joblib. Results: a CSV table, a Markdown summary and a plot of the
feasible region with the small-ring bound (:func:`whisker.design.sizing.crowding_bound_radius`) drawn over it.
"""

from __future__ import annotations

import csv
import io
import time
from pathlib import Path
from typing import Callable, Iterable

from whisker.design import DesignError, load_design
from whisker.files import atomic_write_bytes, atomic_write_text

FIELDS = ("count", "ring_radius_mm", "feasible", "conflict", "kind", "reason", "bound_mm", "seconds")


def evaluate_point(design_file: str | None, overrides: tuple[str, ...], count: int, radius: float,
                   closed_form: bool = True) -> dict:
    """One (count, radius) cell: feasible, or the first failed check (its kind says whether it is a
    physical conflict of the design or a fault of the CAD), with the crowding bound for this count.
    closed_form: a cell that a closed-form bound (whisker.design.bounds) rules out is refused
    without building (conflict "<bound> (closed-form bound)")."""
    from whisker.design.sizing import crowding_bound_radius

    t0 = time.perf_counter()
    row = {"count": count, "ring_radius_mm": radius, "feasible": False, "conflict": "", "kind": "", "reason": "",
           "bound_mm": "", "seconds": 0.0}
    try:
        d = load_design(design_file, (*overrides, f"whiskers.count={count}", f"whiskers.ring_radius={radius}"))
    except DesignError as err:
        row.update(conflict="design model", kind="conflict", reason=str(err))
        return row
    row["bound_mm"] = round(crowding_bound_radius(d), 4)
    if closed_form:
        from whisker.design.bounds import refusal

        why = refusal(d)
        if why:
            row.update(conflict=f"{why.split(':')[0]} (closed-form bound)", kind="conflict", reason=why,
                       seconds=round(time.perf_counter() - t0, 3))
            return row
    from whisker.cad.build import evaluate  # CadQuery loads in the worker only

    try:
        results = evaluate(d)
    except Exception as err:  # a CAD kernel failure is a fault of ours, reported as such
        row.update(conflict="CAD kernel", kind="fault", reason=f"{type(err).__name__}: {err}")
        return row
    failed = [c for c in results if not c.ok]
    if failed:
        row.update(conflict=f"{failed[0].part}: {failed[0].name}", kind=failed[0].kind, reason=failed[0].line())
    else:
        row["feasible"] = True
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


def sweep(counts: Iterable[int], radii: Iterable[float], design_file: str | None = None,
          overrides: tuple[str, ...] = (), workers: int = -1,
          progress: Callable[[int, int], None] | None = None, closed_form: bool = True) -> list[dict]:
    """Evaluate every (count, radius) cell on `workers` processes (joblib; -1 = every core);
    closed_form=False builds even the cells a closed-form bound rules out (to test the bound)."""
    from joblib import Parallel, delayed

    jobs = [(n, float(r)) for n in counts for r in radii]
    rows: list[dict] = []
    run = Parallel(n_jobs=workers, return_as="generator_unordered")
    for row in run(delayed(evaluate_point)(design_file, tuple(overrides), n, r, closed_form) for n, r in jobs):
        rows.append(row)
        if progress:
            progress(len(rows), len(jobs))
    return sorted(rows, key=lambda r: (r["count"], r["ring_radius_mm"]))


BOUND_TEXT = ("small-ring bound: neighbouring coils at full inward swing, "
              "2 rho sin(pi/N) - D cos(pi/N) >= c, rho = R - a cos(theta) - h sin(theta) "
              "(a = bobbin.tab / 2, h = pivot to marker plane)")


def write_reports(rows: list[dict], out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(FIELDS))
    w.writeheader()
    w.writerows(rows)
    paths = [atomic_write_text(out / "sweep.csv", buf.getvalue())]

    counts = sorted({r["count"] for r in rows})
    radii = sorted({r["ring_radius_mm"] for r in rows})
    cell = {(r["count"], r["ring_radius_mm"]): r for r in rows}
    ok = sum(r["feasible"] for r in rows)
    lines = ["# Feasible designs: whisker count x ring radius", "",
             f"{ok} of {len(rows)} designs build and pass every check. `ok` builds; otherwise the physical "
             "conflict that refused it. Bold: the first radius on the feasible side of the "
             f"{BOUND_TEXT} (docs/sweep.md).", "",
             "| count \\ radius (mm) | bound (mm) | " + " | ".join(f"{r:g}" for r in radii) + " |",
             "|---|---|" + "---|" * len(radii)]
    for n in counts:
        bound = next((cell[(n, r)]["bound_mm"] for r in radii if cell[(n, r)]["bound_mm"] != ""), "")
        marks = []
        for r in radii:
            c = cell[(n, r)]
            text = "ok" if c["feasible"] else _short(c["conflict"])
            edge = bound != "" and r >= bound and not any(bound <= q < r for q in radii)
            marks.append(f"**{text}**" if edge else text)
        lines.append(f"| {n} | {bound} | " + " | ".join(marks) + " |")
    reasons = sorted({r["conflict"] for r in rows if not r["feasible"]})
    lines += ["", "Conflicts seen:", *[f"- `{x}`" for x in reasons], ""]
    paths.append(atomic_write_text(out / "sweep.md", "\n".join(lines)))
    paths.append(_plot(rows, counts, radii, out / "sweep.png"))
    return paths


def _short(check: str) -> str:
    return check.split(": ", 1)[-1][:28]


def _plot(rows, counts, radii, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reasons = sorted({r["conflict"] for r in rows if not r["feasible"]})
    fig, ax = plt.subplots(figsize=(10, 5.5))
    ok = [r for r in rows if r["feasible"]]
    ax.scatter([r["ring_radius_mm"] for r in ok], [r["count"] for r in ok], marker="s", s=60, c="tab:green",
               label="feasible")
    markers = "xv^<>dph*+"
    for i, reason in enumerate(reasons):
        pts = [r for r in rows if r["conflict"] == reason]
        ax.scatter([r["ring_radius_mm"] for r in pts], [r["count"] for r in pts], marker=markers[i % len(markers)],
                   s=40, label=f"refused: {_short(reason)}")
    bounds = {r["count"]: r["bound_mm"] for r in rows if r["bound_mm"] != ""}
    if bounds:
        ns = sorted(bounds)
        ax.plot([bounds[n] for n in ns], ns, "k--", lw=1.2,
                label="bound: 2 rho sin(pi/N) - D cos(pi/N) = c")
    ax.set_xlabel("ring radius R (mm)")
    ax.set_ylabel("whisker count N")
    ax.set_xticks(radii)
    ax.set_yticks(counts)
    ax.grid(alpha=0.3)
    ax.set_title("Feasible region (every other size follows the ring)")
    # below the axes, inside the saved figure (bbox_inches="tight" grows the canvas to hold it)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())
