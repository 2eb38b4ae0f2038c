"""Robot flange presets (hw/flanges.csv: ISO 9409-1 mechanical interfaces, and a plain plate) by name.

The table is data with its source named in the file; this module only reads and validates it. The
robot adapter (whisker.cad.solids.adapter) and the design's [adapter] section read it. Units: mm.
"""

from __future__ import annotations

import csv
import io
from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from whisker.design.validation import DesignError, one_line_errors
from whisker.resources import hw_dir

FLANGES = hw_dir() / "flanges.csv"  # hw/ in a clone, whisker/hw in a wheel


class Flange(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: str
    designation: str
    pitch_diameter: float = Field(ge=0)
    bolt_count: int = Field(ge=0, le=12)
    thread: str
    centring_diameter: float = Field(ge=0)
    flange_diameter: float = Field(ge=0)
    pin_diameter: float = Field(ge=0)
    thread_depth: float = Field(ge=0)
    centring_depth: float = Field(ge=0)


@lru_cache(maxsize=2)
def flanges(path: Path = FLANGES) -> dict[str, Flange]:
    """Robot flange presets (hw/flanges.csv, ISO 9409-1) by name."""
    text = "\n".join(ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#"))
    out = {}
    for rec in csv.DictReader(io.StringIO(text)):
        try:
            out[rec["name"]] = Flange.model_validate(rec)
        except ValidationError as err:
            raise DesignError(f"{path} row {rec.get('name')}: {one_line_errors(err)}") from None
    return out


def flange(name: str) -> Flange:
    """The preset `name` of hw/flanges.csv; an unknown name is refused naming the known ones."""
    table = flanges()
    if name not in table:
        raise DesignError(f"adapter.preset: unknown flange {name!r}; known: {', '.join(table)}")
    return table[name]
