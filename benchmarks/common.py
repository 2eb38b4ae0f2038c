"""Helpers shared by the benchmarks: timing and atomic table/plot output into benchmarks/results/."""

from __future__ import annotations

import csv
import io
import platform
import re
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


#: A block another benchmark keeps inside a results file: `<!-- begin NAME -->` ... `<!-- end NAME -->`.
BLOCK = re.compile(r"<!-- begin ([\w-]+) -->\n.*?<!-- end \1 -->\n", re.S)


def write_text(name: str, text: str) -> Path:
    """Write a results file; the marked blocks that other benchmarks put in it (see `write_block`)
    are carried over (appended) when the new text lacks them."""
    path = RESULTS / name
    if path.exists():
        have = {m.group(1) for m in BLOCK.finditer(text)}
        kept = [m.group(0) for m in BLOCK.finditer(path.read_text()) if m.group(1) not in have]
        if kept:
            text = text.rstrip("\n") + "\n\n" + "\n".join(kept)
    return atomic_write_text(path, text)


def write_block(name: str, block: str, text: str) -> Path:
    """Put `text` into results file `name` as the marked block `block` (replacing an earlier one, else
    appended), so a benchmark can add its section to a file another benchmark writes."""
    path = RESULTS / name
    body = path.read_text() if path.exists() else ""
    new = f"<!-- begin {block} -->\n{text.rstrip()}\n<!-- end {block} -->\n"
    pat = re.compile(rf"<!-- begin {re.escape(block)} -->\n.*?<!-- end {re.escape(block)} -->\n", re.S)
    body = pat.sub(lambda _: new, body) if pat.search(body) else body.rstrip("\n") + "\n\n" + new
    return atomic_write_text(path, body)


def save_figure(fig, name: str) -> Path:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return atomic_write_bytes(RESULTS / name, buf.getvalue())
