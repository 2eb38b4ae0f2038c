"""Robot flange presets (hw/flanges.csv, ISO 9409-1) and the design sections of the issue-21 parts.

Units: mm.
"""

from __future__ import annotations

import csv
import io
from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from whisker.design import Design, DesignError, one_line_errors
from whisker.resources import hw_dir

HW = hw_dir()  # hw/ in a clone, whisker/hw in a wheel
FLANGES = HW / "flanges.csv"


def section(d: Design, name: str, **overrides):
    """The design's [name] section with keyword overrides, validated."""
    own = getattr(d, name)
    if not overrides:
        return own
    try:
        return type(own).model_validate({**own.model_dump(), **overrides})
    except ValidationError as err:
        raise DesignError(f"[{name}] " + one_line_errors(err)) from None


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
    table = flanges()
    if name not in table:
        raise DesignError(f"adapter.preset: unknown flange {name!r}; known: {', '.join(table)}")
    return table[name]
