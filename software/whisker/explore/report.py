"""The design explorer's outputs: results.csv, the Pareto fronts (PNG), the Pareto designs as design
files that ``make stl DESIGN=...`` builds, and a Markdown summary. Every file is written atomically.

Pareto fronts, over the designs that build (status ok):
- grasp success with every whisker driven (pooled over the objects, %; higher is better) against coil
  heating: the power in one coil at the grasp voltage (W, 20 C; lower is better; it sets the time to
  the first thermal limit, also in the table);
- the same success against sensing resolution: the tip travel one pixel of marker travel stands for
  (mm/px; lower is better).
A design is on a front when no other design is at least as good in both and better in one.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from whisker.files import atomic_write_bytes, atomic_write_text, drop_stale_staging, publish, staging_dir

HEAD = ["point", "status", "reason", "design_digest"]
PRED = ["whiskers", "ring_radius_mm", "volts", "tilt_deg", "stable", "tip_travel_mm", "force_rest_mN",
        "coil_power_W", "time_to_limit_s", "thermal_limit", "safe_duty_pct", "px_per_deg", "tip_mm_per_px",
        "cad", "attempts"]
#: (x column, x label, objective name, file)
FRONTS = (("coil_power_W", "coil heating: power in one coil at the grasp voltage (W)", "heat", "pareto_heat.png"),
          ("tip_mm_per_px", "sensing resolution: tip travel per pixel of marker travel (mm/px)", "resolution",
           "pareto_resolution.png"))
SUCCESS = "grasp_all_pct"


def columns(rows: list[dict], varied: list[str]) -> list[str]:
    """Fixed order: identity, the varied keys, predictions, grasp per configuration, held per object."""
    seen = list(dict.fromkeys(k for r in rows for k in r))
    grasp = [k for lab in ("all", "half", "pair") for k in (f"n_{lab}", f"grasp_{lab}_pct", f"grasp_{lab}_lo",
                                                             f"grasp_{lab}_hi") if k in seen]
    fixed = HEAD + varied + PRED + grasp
    rest = [k for k in seen if k not in fixed]
    return [k for k in fixed if k in seen] + sorted(k for k in rest if not k.startswith("held_")) + \
        [k for k in rest if k.startswith("held_")]


def _cell(v) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return "inf" if math.isinf(v) and v > 0 else format(v, ".6g")
    return str(v)


def results_csv(rows: list[dict], varied: list[str]) -> str:
    cols = columns(rows, varied)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([_cell(r.get(c, "")) for c in cols])
    return buf.getvalue()


def pareto(rows: list[dict], x: str) -> list[dict]:
    """The rows no other row dominates (higher success, lower ``x``), by ``x``; ties keep the first.
    Values are compared as the table prints them (6 significant digits): designs whose cameras differ
    by rounding alone are equal."""
    ok = [r for r in rows if r["status"] == "ok" and SUCCESS in r and math.isfinite(float(r[x]))]

    def v(r):
        return float(f"{r[SUCCESS]:.6g}"), float(f"{r[x]:.6g}")

    front = []
    for r in ok:
        (sr, xr) = v(r)
        dominated = any(so >= sr and xo <= xr and (so > sr or xo < xr) for so, xo in map(v, ok))
        twin = any(v(f) == (sr, xr) for f in front)
        if not dominated and not twin:
            front.append(r)
    return sorted(front, key=lambda r: r[x])


def label(r: dict, varied: list[str]) -> str:
    return ", ".join(f"{k.split('.')[-1]}={_cell(r[k])}" for k in varied) or f"point {r['point']}"


def plot_front(rows: list[dict], front: list[dict], x: str, xlabel: str, varied: list[str], base_digest: str = "") -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok" and SUCCESS in r]
    fig, ax = plt.subplots(figsize=(7.5, 5))
    if ok:
        ax.errorbar([r[x] for r in ok], [r[SUCCESS] for r in ok],
                    yerr=[[r[SUCCESS] - r["grasp_all_lo"] for r in ok], [r["grasp_all_hi"] - r[SUCCESS] for r in ok]],
                    fmt="o", color="0.6", ms=4, lw=0.8, capsize=2, label="designs (Wilson 95 %)")
    if front:      # a staircase: each front design is the best success up to the next one's cost
        ax.step([r[x] for r in front], [r[SUCCESS] for r in front], where="post", color="tab:red", lw=1)
        ax.plot([r[x] for r in front], [r[SUCCESS] for r in front], "o", color="tab:red", label="Pareto front")
    # every design is labelled; designs that land on the same point (as printed) share one label
    spots: dict = {}
    for r in ok:
        spots.setdefault((float(f"{r[x]:.4g}"), float(f"{r[SUCCESS]:.4g}")), []).append(r)
    for (px, py), group in spots.items():
        text = "; ".join(label(r, varied) for r in group[:4]) + (f" (+{len(group) - 4})" if len(group) > 4 else "")
        if len(group) > 1:
            text = f"{len(group)} designs: {text}"
        ax.annotate(text, (px, py), fontsize=6.5, xytext=(4, 4), textcoords="offset points",
                    color="tab:red" if any(r in front for r in group) else "0.3")
    base = [r for r in ok if r["design_digest"] == base_digest]
    if base:
        ax.plot([base[0][x]], [base[0][SUCCESS]], "*", ms=14, mfc="none", color="k", label="the base design")
    ax.margins(x=0.25)
    refused = sum(r["status"] == "refused" for r in rows)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("grasp success, every whisker driven (%)")
    ax.set_title(f"{len(ok)} designs simulated ({len(spots)} distinct points), {refused} refused", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best", framealpha=0.85)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def design_file_text(base_text: str, overrides: tuple[str, ...], header: str) -> str:
    """The base design file with the overrides written in (comments and every "auto" kept)."""
    from whisker.design.edit import set_keys

    text = base_text
    for item in overrides:
        key, value = item.split("=", 1)
        section, _, name = key.strip().rpartition(".")
        text = set_keys(text, section, {name: value.strip()}, comment="whisker explore")
    return "".join(f"# {line}\n" for line in header.splitlines()) + text


def grid_markdown(rows: list[dict], varied: list[str]) -> str:
    """For a study of two or three --vary keys: grasp success as a grid, rows = the first key, columns
    = the second, one table per value of the third: "all [95 % interval] / half / pair" (% pooled over
    the objects; every whisker, every second one, one opposite pair: 8/4/2 whiskers for an 8-whisker
    design). Rows may come from results.csv (strings) or from the study (numbers). "" otherwise."""
    if len(varied) not in (2, 3):
        return ""

    def num(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return math.nan

    def key(v):
        f = num(v)
        return (0, f) if math.isfinite(f) else (1, str(v))

    a, b = varied[0], varied[1]
    tables = sorted({str(r[varied[2]]) for r in rows}, key=key) if len(varied) == 3 else [None]
    out = []
    for t in tables:
        sub = [r for r in rows if t is None or str(r[varied[2]]) == t]
        cols = sorted({str(r[b]) for r in sub}, key=key)
        head = f"{varied[2].split('.')[-1]} = {t}: " if t is not None else ""
        out += [f"| {head}{a.split('.')[-1]} \\ {b.split('.')[-1]} | " + " | ".join(cols) + " |",
                "|---|" + "---|" * len(cols)]
        for av in sorted({str(r[a]) for r in sub}, key=key):
            cells = []
            for bv in cols:
                r = next((x for x in sub if str(x[a]) == av and str(x[b]) == bv), None)
                if r is None or str(r.get("status")) != "ok" or not math.isfinite(num(r.get(SUCCESS))):
                    cells.append("-" if r is None else str(r.get("status")))
                    continue
                extra = "".join(f" / {num(r[f'grasp_{k}_pct']):.0f}" for k in ("half", "pair")
                                if math.isfinite(num(r.get(f"grasp_{k}_pct"))))
                cells.append(f"{num(r[SUCCESS]):.0f} [{num(r['grasp_all_lo']):.0f}-{num(r['grasp_all_hi']):.0f}]{extra}")
            out.append(f"| {av} | " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


def write(out: Path, rows: list[dict], points, varied: list[str], base_text: str, summary: str,
          base_digest: str = "") -> list[Path]:
    """results.csv, grid.md (2-3 varied keys), pareto_*.png, pareto/*.toml (stale ones removed), summary.md;
    returns the paths.
    ``base_digest``: the design without the --vary values (marked in the plots when in the grid)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [atomic_write_text(out / "results.csv", results_csv(rows, varied))]
    grid = grid_markdown(rows, varied)
    if grid:
        paths.append(atomic_write_text(out / "grid.md", grid))
    chosen: dict[int, list[str]] = {}
    lines = [summary, ""]
    for x, xlabel, what, fname in FRONTS:
        front = pareto(rows, x)
        paths.append(atomic_write_bytes(out / fname, plot_front(rows, front, x, xlabel, varied, base_digest)))
        for r in front:
            chosen.setdefault(r["point"], []).append(what)
        lines += [f"## Pareto front: grasp success against {what}", "",
                  "| design | grasp all % [95 %] | coil W | time to limit s | tilt deg | force mN | tip mm per marker px | file |",
                  "|---|---|---|---|---|---|---|---|"]
        lines += [f"| {label(r, varied)} | {r[SUCCESS]:.0f} [{r['grasp_all_lo']:.0f}-{r['grasp_all_hi']:.0f}] | "
                  f"{r['coil_power_W']:.2f} | {r['time_to_limit_s']:.1f} | {r['tilt_deg']:.1f} | "
                  f"{r['force_rest_mN']:.1f} | {r['tip_mm_per_px']:.3f} | pareto/design-{r['design_digest']}.toml |"
                  for r in front]
        lines.append("")
    by_index = {p.index: p for p in points}
    target = out / "pareto"
    drop_stale_staging(target)                 # left by a killed earlier run
    names = []
    with staging_dir(target) as tmp:
        for i, whats in sorted(chosen.items()):
            p = by_index[i]
            row = next(r for r in rows if r["point"] == i)
            name = f"design-{p.digest}.toml"
            header = (f"whisker explore: on the Pareto front of grasp success against {' and '.join(whats)}\n"
                      f"grasp success (every whisker) {row[SUCCESS]:.1f} % over {row['attempts']} attempts per object; "
                      f"design digest {p.digest}\n"
                      f"overrides: {' '.join(p.overrides) or '(none)'}\nbuild it: make stl DESIGN=<this file>")
            (tmp / name).write_text(design_file_text(base_text, p.overrides, header))
            names.append(name)
        old = [q.name for q in target.glob("design-*.toml")] if target.exists() else []
        publish(tmp, target, names, stale=old)
    paths += [target / n for n in names]
    paths.append(atomic_write_text(out / "summary.md", "\n".join(lines)))
    return paths
