"""Helpers shared by the benchmarks: timing and atomic table/plot output into benchmarks/results/."""

from __future__ import annotations

import csv
import io
import platform
import time
from pathlib import Path
from typing import Callable, Sequence

from whisker.files import atomic_write_bytes, atomic_write_text

RESULTS = Path(__file__).resolve().parent / "results"


def best_time_s(fn: Callable[[], object], repeat: int = 5, number: int = 1) -> float:
    """Best of `repeat` wall-clock timings of `number` calls, per call (s). Best-of resists noise."""
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t) / number)
    return best


def machine_line() -> str:
    import os

    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"


def write_csv(name: str, rows: Sequence[dict]) -> Path:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    return atomic_write_text(RESULTS / name, buf.getvalue())


def markdown_table(rows: Sequence[dict], columns: Sequence[str], fmt: dict[str, str] | None = None) -> str:
    fmt = fmt or {}
    out = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        out.append("| " + " | ".join(format(r[c], fmt.get(c, "")) if c in fmt else str(r[c]) for c in columns) + " |")
    return "\n".join(out)


def write_text(name: str, text: str) -> Path:
    return atomic_write_text(RESULTS / name, text)


def save_figure(fig, name: str) -> Path:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return atomic_write_bytes(RESULTS / name, buf.getvalue())
