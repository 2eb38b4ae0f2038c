"""Part numbers of purchased parts: hw/bom_parts.csv matched against the design's values.

A row names an item, its part number, vendor and source, and the design values it needs (``matches``:
``section.key=value``; numbers match within 1 %). `with_part_number` fills a BOM row from it.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

from whisker.design import Design
from whisker.errors import BomError
from whisker.resources import hw_dir

#: Part numbers of well-known purchased parts, with their vendor and source (data, not code).
PARTS_TABLE = hw_dir() / "bom_parts.csv"


@dataclass(frozen=True)
class CatalogPart:
    """A row of hw/bom_parts.csv: a purchased part's number, vendor and source."""

    item: str
    part_number: str
    vendor: str
    kind: str  # exact | example
    matches: tuple[tuple[str, str], ...]
    source: str


def load_parts_table(path: str | Path = PARTS_TABLE) -> list[CatalogPart]:
    """The part-number table (hw/bom_parts.csv; '#' lines are comments)."""
    try:
        text = Path(path).read_text()
    except OSError as err:
        raise BomError(f"part-number table {path}: {err.strerror or err}") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    out = []
    for i, rec in enumerate(csv.DictReader(io.StringIO("\n".join(lines)))):
        try:
            matches = tuple(tuple(x.split("=", 1)) for x in (rec["matches"] or "").split(";") if x.strip())
            if any(len(m) != 2 for m in matches) or rec["kind"] not in ("exact", "example"):
                raise ValueError("matches must be key=value; kind exact or example")
            if not (rec["item"] and rec["part_number"] and rec["vendor"] and rec["source"]):
                raise ValueError("item, part_number, vendor and source are required")
            out.append(CatalogPart(rec["item"], rec["part_number"], rec["vendor"], rec["kind"], matches, rec["source"]))
        except (KeyError, TypeError, ValueError) as err:
            raise BomError(f"part-number table {path} row {i + 1}: {err}") from None
    return out


def _matches(design: Design, key: str, want: str) -> bool:
    obj = design
    for k in key.split("."):
        obj = getattr(obj, k, None)
    if obj is None:
        raise BomError(f"part-number table: unknown design value {key!r}")
    if isinstance(obj, (int, float)) and not isinstance(obj, bool):
        try:
            w = float(want)
        except ValueError:
            return False
        return abs(float(obj) - w) <= 0.01 * abs(w)
    return str(obj) == want


def find_part(item: str, design: Design, table: list[CatalogPart] | None = None) -> CatalogPart | None:
    """The first row of the part-number table for `item` whose design values match, or None."""
    table = load_parts_table() if table is None else table
    for p in table:
        if p.item == item and all(_matches(design, k, v) for k, v in p.matches):
            return p
    return None


def with_part_number(row, design: Design, fastener_line: dict | None):
    """The `whisker.bom.BomRow` with its part number and vendor from hw/bom_parts.csv (screws and
    inserts from their hw/fasteners.csv line)."""
    from dataclasses import replace

    item, fill = row.item, {}
    if fastener_line is not None:
        from whisker.design.fasteners import fastener

        item = "screw" if row.item.startswith("screw_") else "insert"
        f = fastener(fastener_line["size"])
        fill = {"size": f.size, "length": f"{fastener_line.get('length', 0):g}", "insert_part": f.insert_part}
    part = find_part(item, design)
    if part is None:
        return row
    number = part.part_number.format(**fill) if fill else part.part_number
    how = "" if part.kind == "exact" else "example: "
    return replace(row, part_number=number, example_source=f"{how}{part.vendor} ({part.source})")
