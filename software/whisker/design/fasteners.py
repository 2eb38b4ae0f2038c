"""Screws, holes and heat-set inserts for printed parts, from the table hw/fasteners.csv.

Every fastened joint picks a thread size (M2, M2.5, M3, M5, M6) and a kind:

- ``insert``: a heat-set brass insert in the printed part (hole and depth from the insert maker's
  datasheet); the screw engages the insert.
- ``tap``: the screw forms its own thread in a pilot hole in the plastic (EJOT PT guidance).
- ``through``: a clearance hole (ISO 273); the screw passes and engages a nut or a tapped metal part.

All dimensions are in mm. The sources of every number are named in the table's header; no
fastener dimension is written in code. Bad input (unknown size or kind, an insert deeper than the
wall it goes into, a stack no stock screw fits) raises :class:`FastenerError` with one line.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from whisker.resources import hw_dir

TABLE = hw_dir() / "fasteners.csv"
KINDS = ("insert", "tap", "through")
Kind = Literal["insert", "tap", "through"]
ClearanceSeries = Literal["fine", "medium", "coarse"]


class FastenerError(ValueError):
    """A fastener request that cannot be met; the message is one line naming what is wrong."""


class Fastener(BaseModel):
    """One row of hw/fasteners.csv (mm); see the table's header for each column's source."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    size: str = Field(pattern=r"^M\d+(\.\d+)?$")
    pitch: float = Field(gt=0)
    head_diameter: float = Field(gt=0)
    head_height: float = Field(gt=0)
    counterbore: float = Field(gt=0)
    clear_fine: float = Field(gt=0)
    clear_medium: float = Field(gt=0)
    clear_coarse: float = Field(gt=0)
    tap_pilot: float = Field(gt=0)
    tap_engage_min: float = Field(gt=0)
    tap_engage_max: float = Field(gt=0)
    insert_part: str = Field(min_length=1)
    insert_length: float = Field(gt=0)
    insert_od: float = Field(gt=0)
    insert_hole: float = Field(gt=0)
    insert_hole_depth: float = Field(gt=0)
    insert_min_wall: float = Field(gt=0)
    insert_engage_min: float = Field(gt=0)
    insert_engage_max: float = Field(gt=0)
    through_engage_min: float = Field(gt=0)
    through_engage_max: float = Field(gt=0)
    stock_lengths: tuple[float, ...] = Field(min_length=1)

    @field_validator("stock_lengths", mode="before")
    @classmethod
    def _lengths(cls, v):
        if isinstance(v, str):
            v = [float(x) for x in v.split()]
        v = tuple(v)
        if list(v) != sorted(set(v)):
            raise ValueError("stock lengths must be increasing and distinct")
        return v

    @model_validator(mode="after")
    def _consistent(self) -> "Fastener":
        d = self.nominal
        if not (d < self.clear_fine < self.clear_medium < self.clear_coarse):
            raise ValueError(f"{self.size}: clearance holes must grow fine < medium < coarse and exceed {d:g}")
        if not (d - 2 * self.pitch < self.tap_pilot < d):
            raise ValueError(f"{self.size}: tapping pilot must lie between the minor and the nominal diameter")
        if not self.counterbore > self.head_diameter:
            raise ValueError(f"{self.size}: counterbore must be wider than the head")
        if not (self.insert_od > self.insert_hole > d):
            raise ValueError(f"{self.size}: insert hole must lie between the thread and the insert's OD")
        if self.insert_hole_depth < self.insert_length:
            raise ValueError(f"{self.size}: insert hole shallower than the insert")
        for kind in KINDS:
            lo, hi = getattr(self, f"{kind}_engage_min"), getattr(self, f"{kind}_engage_max")
            if lo > hi:
                raise ValueError(f"{self.size}: {kind} engagement range is empty ({lo:g} > {hi:g})")
        return self

    @property
    def nominal(self) -> float:
        """Nominal (major) thread diameter d, mm."""
        return float(self.size[1:])

    def engagement(self, kind: str) -> tuple[float, float]:
        """(min, max) thread engagement for a joint of this kind, mm."""
        kind = _kind(kind)
        return getattr(self, f"{kind}_engage_min"), getattr(self, f"{kind}_engage_max")


def _kind(kind: str) -> str:
    if kind not in KINDS:
        raise FastenerError(f"unknown fastener kind {kind!r}; known: {', '.join(KINDS)}")
    return kind


def parse_table(text: str, source: str = "fasteners table") -> dict[str, Fastener]:
    """Parse the CSV text of a fastener table (``#`` lines are comments) into rows by size."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    rows: dict[str, Fastener] = {}
    for i, rec in enumerate(csv.DictReader(io.StringIO("\n".join(lines)))):
        try:
            f = Fastener.model_validate(rec)
        except ValidationError as err:
            from whisker.design.validation import one_line_errors

            raise FastenerError(f"{source} row {i + 1} ({rec.get('size', '?')}): {one_line_errors(err)}") from None
        if f.size in rows:
            raise FastenerError(f"{source}: size {f.size} appears twice")
        rows[f.size] = f
    if not rows:
        raise FastenerError(f"{source}: no fastener rows")
    return rows


@lru_cache(maxsize=4)
def load_table(path: str | Path = TABLE) -> dict[str, Fastener]:
    """The fastener table (default hw/fasteners.csv), validated, by size ("M3")."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as err:
        raise FastenerError(f"fastener table {p}: {err.strerror or err}") from None
    return parse_table(text, str(p))


def fastener(size: str, table: dict[str, Fastener] | None = None) -> Fastener:
    """The table row of thread `size` ("M3"); an unknown size names the known ones."""
    table = load_table() if table is None else table
    if size not in table:
        raise FastenerError(f"unknown fastener size {size!r}; known: {', '.join(table)}")
    return table[size]


@dataclass(frozen=True)
class Hole:
    """The hole a joint needs in the printed part (mm)."""

    size: str
    kind: str
    diameter: float       # as modelled (the table's value; the printed clearance is not added)
    depth: float | None   # blind depth the hole needs (insert); None = as deep as the screw goes / through
    source: str
    min_wall: float | None = None  # plastic the hole needs around it (insert: the table's insert_min_wall);
                                   # None = the printer's general minimum (print.min_wall)

    def wall(self, general: float) -> float:
        """The thinnest wall allowed around this hole, mm: the larger of the printer's general
        minimum and the hole's own (a heat-set insert's wall, hw/fasteners.csv insert_min_wall)."""
        return max(general, self.min_wall or 0.0)


def hole(size: str, kind: str, wall: float | None = None, series: ClearanceSeries = "medium",
         table: dict[str, Fastener] | None = None) -> Hole:
    """The hole for a joint of thread `size` and `kind` (insert | tap | through), mm.

    `wall` is the material depth (mm) the hole goes into; an insert whose hole is deeper than it is
    refused. Holes are the table's values: a heat-set or thread-forming hole must not get the
    printer's clearance added (it would lose its grip), a clearance hole already has ISO 273's.
    """
    f = fastener(size, table)
    kind = _kind(kind)
    if kind == "through":
        return Hole(size, kind, getattr(f, f"clear_{series}"), None, f"ISO 273 {series}")
    if kind == "tap":
        if wall is not None and wall < f.tap_engage_min:
            raise FastenerError(f"{size} tapped hole needs {f.tap_engage_min:g} mm of engagement, "
                                f"the wall is {wall:g} mm; use a through screw and a nut")
        return Hole(size, kind, f.tap_pilot, None, "EJOT PT: pilot 0.8 d")
    if wall is not None and wall < f.insert_hole_depth:
        raise FastenerError(f"{size} insert ({f.insert_part}, {f.insert_length:g} mm long) needs a "
                            f"{f.insert_hole_depth:g} mm deep hole, the wall is {wall:g} mm")
    return Hole(size, kind, f.insert_hole, f.insert_hole_depth, f"{f.insert_part} datasheet", f.insert_min_wall)


def screw_length(size: str, kind: str, clamp: float, engage_max: float | None = None,
                 table: dict[str, Fastener] | None = None) -> tuple[float, float]:
    """(stock screw length, thread engagement) for a screw clamping `clamp` mm of parts, mm.

    The clamp is everything under the head down to where the thread starts to engage (the part
    with the clearance hole, washers, a cover ...). The shortest ISO 4762 stock length whose
    engagement (length - clamp) lies within the table's range for `kind` is chosen; `engage_max`
    (e.g. a robot flange's thread depth) may tighten the upper limit.
    """
    f = fastener(size, table)
    lo, hi = f.engagement(kind)
    if engage_max is not None:
        hi = min(hi, float(engage_max))
    if not (math.isfinite(clamp) and clamp >= 0):
        raise FastenerError(f"{size} screw: clamped thickness must be a finite number >= 0 mm (got {clamp!r})")
    for length in f.stock_lengths:
        if lo - 1e-9 <= length - clamp <= hi + 1e-9:
            return length, length - clamp
    raise FastenerError(f"no stock {size} screw ({', '.join(f'{x:g}' for x in f.stock_lengths)} mm) clamps "
                        f"{clamp:g} mm with {lo:g}-{hi:g} mm of {kind} engagement")


@dataclass(frozen=True)
class Joint:
    """A fastened joint: `count` screws of `size`, `kind`, clamping `clamp` mm (mm)."""

    name: str
    size: str
    kind: str
    count: int
    clamp: float
    engage_max: float | None = None


def bom_lines(joints: list[Joint], table: dict[str, Fastener] | None = None) -> list[dict]:
    """Purchase lines for the joints' screws and inserts, summed by part (dicts: item, size, length
    (screws), quantity, unit, specification, notes). Screws are ISO 4762 socket head cap screws."""
    screws: dict[tuple[str, float], list[str]] = {}
    inserts: dict[str, list[tuple[str, int]]] = {}
    counts: dict[tuple[str, float], int] = {}
    for j in joints:
        if j.count < 0:
            raise FastenerError(f"joint {j.name}: screw count must be >= 0 (got {j.count})")
        length, _ = screw_length(j.size, j.kind, j.clamp, j.engage_max, table)
        key = (j.size, length)
        counts[key] = counts.get(key, 0) + j.count
        screws.setdefault(key, []).append(j.name)
        if j.kind == "insert":
            inserts.setdefault(j.size, []).append((j.name, j.count))
    out = []
    for (size, length), n in sorted(counts.items(), key=lambda kv: (float(kv[0][0][1:]), kv[0][1])):
        out.append({"item": f"screw_{size.lower()}x{length:g}", "size": size, "length": length, "quantity": n, "unit": "pcs",
                    "specification": f"ISO 4762 {size} x {length:g} socket head cap screw, steel 8.8 or A2",
                    "notes": "for " + ", ".join(screws[(size, length)])})
    for size, uses in sorted(inserts.items(), key=lambda kv: float(kv[0][1:])):
        f = fastener(size, table)
        out.append({"item": f"insert_{size.lower()}", "size": size, "quantity": sum(n for _, n in uses), "unit": "pcs",
                    "specification": f"{f.insert_part} heat-set brass insert, {size}, {f.insert_length:g} mm long, "
                                     f"OD {f.insert_od:g} mm, into a {f.insert_hole:g} mm hole "
                                     f"{f.insert_hole_depth:g} mm deep",
                    "notes": "for " + ", ".join(n for n, _ in uses)})
    return out
