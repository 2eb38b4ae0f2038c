"""The design explorer's grid: ``--vary section.key=VALUES`` options -> one override list per design.

VALUES is a list ``a,b,c`` (each a TOML value: ``6``, ``10.5``, ``"N52"``) or an inclusive range
``start:stop:step`` of numbers (integers when all three are integers). The grid is the Cartesian
product of the ``--vary`` options in the order given, the last one changing fastest; ``--set``
overrides apply to every point. Every key is checked against the base design file before anything
runs, so a typo is refused with one line (:class:`ExploreError`), not found after an hour.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from whisker.design import DEFAULT_DESIGN, DesignError, apply_overrides, load_design, parse_value
from whisker.files import read_toml

#: more points than this is a typo (a step of 0.001 mm), not a study: refused before anything runs
MAX_POINTS = 100_000


class ExploreError(ValueError):
    """An explore request that cannot run; the one-line message names the option and value."""


@dataclass(frozen=True)
class Vary:
    key: str                  # "section.key"
    values: tuple             # parsed values, in the order given


@dataclass(frozen=True)
class Point:
    """One grid point: its index, the overrides that make it, and the design or the refusal."""
    index: int
    assignment: tuple         # ((key, value), ...) of the --vary options
    overrides: tuple[str, ...]
    design: Any = None        # whisker.design.Design when the design model accepts it
    refusal: str = ""         # else the design model's one-line reason

    @property
    def digest(self) -> str:
        return self.design.digest() if self.design is not None else ""


def toml_literal(value) -> str:
    """A value as TOML text (6, 10.5, "N52", [1, 2]) for an override or a design file."""
    import tomli_w

    return tomli_w.dumps({"v": value}).split("=", 1)[1].strip()


def _number(text: str, what: str) -> int | float:
    v = parse_value(text.strip())
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ExploreError(f"--vary {what}: {text.strip()!r} is not a finite number")
    return v


def parse_values(text: str, what: str) -> tuple:
    """'a,b,c' or 'start:stop:step' (inclusive) -> the values; an empty result is refused."""
    text = text.strip()
    if not text:
        raise ExploreError(f"--vary {what}: no values after '='; give a,b,c or start:stop:step")
    if ":" in text and not text.startswith(("[", '"', "'")):
        parts = text.split(":")
        if len(parts) != 3:
            raise ExploreError(f"--vary {what}={text}: a range is start:stop:step (three numbers)")
        a, b, s = (_number(p, what) for p in parts)
        if s == 0:
            raise ExploreError(f"--vary {what}={text}: the step is 0")
        if (b - a) / s < -1e-6:
            raise ExploreError(f"--vary {what}={text}: empty range (stop is not reached from start by step)")
        n = int(math.floor((b - a) / s + 1e-6)) + 1     # typed decimals: 0.1 steps land on their stop
        if n > MAX_POINTS:
            raise ExploreError(f"--vary {what}={text}: {n} values, more than {MAX_POINTS}")
        if all(isinstance(x, int) for x in (a, b, s)):
            return tuple(a + i * s for i in range(n))
        return tuple(round(a + i * s, 9) for i in range(n))
    vals = tuple(parse_value(v.strip()) for v in text.split(","))
    if any(isinstance(v, str) and not v for v in vals):
        raise ExploreError(f"--vary {what}={text}: an empty value in the list")
    for v in vals:
        if isinstance(v, float) and not math.isfinite(v):
            raise ExploreError(f"--vary {what}={text}: {v} is not a finite number")
    return vals


def parse_vary(spec: str, base: dict) -> Vary:
    """One ``section.key=VALUES`` option, its key checked against the base design's data."""
    if "=" not in spec:
        raise ExploreError(f"--vary {spec!r}: expected section.key=a,b,c or section.key=start:stop:step")
    key, text = (s.strip() for s in spec.split("=", 1))
    if not key:
        raise ExploreError(f"--vary {spec!r}: no key before '='")
    values = parse_values(text, key)
    try:
        apply_overrides(base, [f"{key}={toml_literal(values[0])}"])
    except DesignError as err:
        raise ExploreError(f"--vary: {err}") from None
    return Vary(key, values)


def base_data(design_file: str | Path | None) -> dict:
    """The base design file's data (default: the paper's sensor, hw/sensor.toml)."""
    return read_toml(Path(design_file) if design_file else DEFAULT_DESIGN, "design", ExploreError)


def grid(design_file: str | Path | None, sets: tuple[str, ...], varies: list[str]) -> list[Point]:
    """Every grid point with its design resolved (or the design model's refusal)."""
    base = base_data(design_file)
    try:
        apply_overrides(base, sets)
    except DesignError as err:
        raise ExploreError(f"--set: {err}") from None
    vs = [parse_vary(s, base) for s in varies]
    keys = [v.key for v in vs]
    if len(set(keys)) != len(keys):
        dup = next(k for k in keys if keys.count(k) > 1)
        raise ExploreError(f"--vary {dup}: given twice; list every value in one option")
    total = math.prod(len(v.values) for v in vs)
    if total > MAX_POINTS:
        raise ExploreError(f"--vary: {total} designs, more than {MAX_POINTS}; use coarser steps")
    points = []
    for i, combo in enumerate(itertools.product(*(v.values for v in vs))):
        assignment = tuple(zip(keys, combo))
        ov = tuple(sets) + tuple(f"{k}={toml_literal(v)}" for k, v in assignment)
        try:
            points.append(Point(i, assignment, ov, design=load_design(design_file, ov)))
        except DesignError as err:
            points.append(Point(i, assignment, ov, refusal=f"design model: {err}"))
    return points
