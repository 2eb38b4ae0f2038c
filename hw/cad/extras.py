"""Settings of the issue-21 parts (adapter, cover, bobbin, winding jig) and the robot flange table.

Until hw/sensor.toml and whisker.design carry these sections, their defaults come from
hw/proposed_sections.toml; :func:`section` returns the design's own section when it has one, so
the parts need no change when the sections move into the design. Units: mm.
"""

from __future__ import annotations

import csv
import io
from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from whisker.design import Design, DesignError, one_line_errors
from whisker.files import read_toml

HW = Path(__file__).resolve().parents[1]  # hw/ (this file is hw/cad/extras.py)
PROPOSED = HW / "proposed_sections.toml"
FLANGES = HW / "flanges.csv"
Joint = Literal["insert", "tap", "through"]


class _S(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Adapter(_S):
    preset: str
    under_head: float = Field(gt=0)
    sensor_screw: str
    sensor_joint: Joint
    relief_depth: float = Field(ge=0)


class Cover(_S):
    thickness: float = Field(gt=0)
    relief_depth: float = Field(ge=0)
    margin: float = Field(gt=0)
    screw: str
    joint: Joint


class Bobbin(_S):
    flange: float = Field(gt=0)
    rim_margin: float = Field(ge=0)
    tab: float = Field(gt=0)
    socket_depth: float = Field(gt=0)
    lead_hole: float = Field(gt=0)
    min_wall: float = Field(gt=0)


class WindingJig(_S):
    shank_diameter: float = Field(gt=0)
    shank_length: float = Field(gt=0)
    disc_diameter: float = Field(gt=0)
    disc_thickness: float = Field(gt=0)
    flag_length: float = Field(gt=0)
    flag_width: float = Field(gt=0)
    counter_magnet: tuple[float, float]


MODELS = {"adapter": Adapter, "cover": Cover, "bobbin": Bobbin, "winding_jig": WindingJig}


@lru_cache(maxsize=1)
def _proposed() -> dict:
    return read_toml(PROPOSED, "proposed sections", DesignError)


def section(d: Design, name: str, **overrides):
    """The design's [name] section, or the proposed default, with keyword overrides (validated)."""
    own = getattr(d, name, None)
    data = own.model_dump() if own is not None else dict(_proposed().get(name, {}))
    data.update(overrides)
    try:
        return MODELS[name].model_validate(data)
    except ValidationError as err:
        raise DesignError(f"[{name}] " + one_line_errors(err)) from None


class Flange(_S):
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
