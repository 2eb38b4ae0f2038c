"""Camera board profiles from published mechanical drawings (hw/camera_boards.toml).

A profile gives a board's outline, hole pattern, lens axis, lens holder and connector edge in the
board frame (origin at the hole pattern's centre, +y towards the flat-cable connector; see the
data file's header). :func:`placement` puts a board into the sensor frame so that its optical
axis is the sensor axis (x = y = 0) and its cable leaves towards a given direction; the camera
seat, the optical axis and the tracking's image centre all follow from that.

Units: mm. Bad input (unknown profile, inconsistent numbers) raises :class:`CameraBoardError`
with one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from whisker.resources import hw_dir

DATA = hw_dir() / "camera_boards.toml"


class CameraBoardError(ValueError):
    """A camera profile that cannot be used; the message is one line."""


class _M(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Board(_M):
    width: float = Field(gt=0, description="mm, along x")
    height: float = Field(gt=0, description="mm, along y")
    thickness: float = Field(gt=0, description="mm, PCB")
    centre: tuple[float, float] = Field(description="mm, outline centre in the board frame")


class Holes(_M):
    spacing_x: float = Field(gt=0)
    spacing_y: float = Field(gt=0)
    diameter: float = Field(gt=0)


class Lens(_M):
    offset: tuple[float, float] = Field(description="mm, optical axis in the board frame")
    holder: tuple[float, float] = Field(description="mm, holder footprint x, y")
    holder_height: float = Field(gt=0, description="mm above the PCB's front face")
    optical_centre_height: float = Field(gt=0, description="mm, PCB front face to the optical centre")


class Connector(_M):
    side: Literal["+x", "-x", "+y", "-y"]
    kind: str = Field(min_length=1)


class Profile(_M):
    name: str
    title: str = Field(min_length=1)
    drawing: str = Field(min_length=10, description="the published drawing the numbers come from")
    board: Board
    holes: Holes
    lens: Lens
    connector: Connector
    estimated: tuple[str, ...] = ()

    @model_validator(mode="after")
    def _fits(self) -> "Profile":
        b, h, ln = self.board, self.holes, self.lens
        x0, x1 = b.centre[0] - b.width / 2, b.centre[0] + b.width / 2
        y0, y1 = b.centre[1] - b.height / 2, b.centre[1] + b.height / 2
        r = h.diameter / 2
        for hx, hy in self.hole_positions():
            if not (x0 + r < hx < x1 - r and y0 + r < hy < y1 - r):
                raise ValueError(f"hole at ({hx:g}, {hy:g}) lies outside the board outline")
        lx, ly = ln.offset
        if not (x0 <= lx - ln.holder[0] / 2 and lx + ln.holder[0] / 2 <= x1
                and y0 <= ly - ln.holder[1] / 2 and ly + ln.holder[1] / 2 <= y1):
            raise ValueError("lens holder reaches past the board outline")
        for hx, hy in self.hole_positions():
            if abs(hx - lx) < ln.holder[0] / 2 + r and abs(hy - ly) < ln.holder[1] / 2 + r:
                raise ValueError(f"lens holder covers the hole at ({hx:g}, {hy:g})")
        return self

    def hole_positions(self) -> list[tuple[float, float]]:
        """Hole centres in the board frame (mm)."""
        hx, hy = self.holes.spacing_x / 2, self.holes.spacing_y / 2
        return [(sx * hx, sy * hy) for sx in (-1, 1) for sy in (-1, 1)]

    @property
    def lens_offset_from_holes(self) -> float:
        """Distance from the hole pattern's centre to the optical axis (mm)."""
        return math.hypot(*self.lens.offset)


@lru_cache(maxsize=4)
def load_profiles(path: str | Path = DATA) -> dict[str, Profile]:
    """Every profile in the data file (default hw/camera_boards.toml), validated, by name."""
    from whisker.design.validation import one_line_errors
    from whisker.files import read_toml

    data = read_toml(path, "camera board", CameraBoardError)
    out = {}
    for name, raw in (data.get("profiles") or {}).items():
        try:
            out[name] = Profile.model_validate({"name": name, **raw})
        except ValidationError as err:
            raise CameraBoardError(f"camera board profile {name!r} in {path}: {one_line_errors(err)}") from None
    if not out:
        raise CameraBoardError(f"camera board file {path}: no [profiles.*] tables")
    return out


def profile(name: str, profiles: dict[str, Profile] | None = None) -> Profile:
    """The named profile; an unknown name lists the known ones."""
    profiles = load_profiles() if profiles is None else profiles
    if name not in profiles:
        raise CameraBoardError(f"unknown camera board {name!r}; known: {', '.join(profiles)}")
    return profiles[name]


_SIDE_DEG = {"+x": 0.0, "+y": 90.0, "-x": 180.0, "-y": 270.0}


@dataclass(frozen=True)
class Placement:
    """A board in the sensor frame (xy, mm): the optical axis at the origin, cable towards `cable_deg`."""

    profile: Profile
    rotation_deg: float                 # board frame -> sensor frame, about z
    board_centre: tuple[float, float]   # outline centre
    board_size: tuple[float, float]     # outline extent along the sensor's x, y (rotated by a multiple of 90)
    holes: list[tuple[float, float]]
    holder_centre: tuple[float, float]
    holder_size: tuple[float, float]
    lens: tuple[float, float]           # (0, 0) by construction

    def to_sensor(self, x: float, y: float) -> tuple[float, float]:
        return _to_sensor(self.profile, self.rotation_deg, x, y)


def _to_sensor(p: Profile, rot_deg: float, x: float, y: float) -> tuple[float, float]:
    lx, ly = p.lens.offset
    a = math.radians(rot_deg)
    dx, dy = x - lx, y - ly
    c, s = round(math.cos(a), 12), round(math.sin(a), 12)
    return (c * dx - s * dy, s * dx + c * dy)


def placement(p: Profile, cable_deg: float = 270.0) -> Placement:
    """Place profile `p` with its lens on the sensor axis and its connector edge facing `cable_deg`
    (deg CCW from +x; 270 = -y, where the mount's flat-cable slot is). Only multiples of 90 deg are
    allowed so the board's outline stays axis-aligned (a box pocket)."""
    rot = (cable_deg - _SIDE_DEG[p.connector.side]) % 360.0
    if abs(rot / 90.0 - round(rot / 90.0)) > 1e-9:
        raise CameraBoardError(f"cable direction {cable_deg:g} deg: only multiples of 90 deg are supported")
    quarter = int(round(rot / 90.0)) % 2 == 1

    def size(w: float, h: float) -> tuple[float, float]:
        return (h, w) if quarter else (w, h)

    return Placement(p, rot, _to_sensor(p, rot, *p.board.centre), size(p.board.width, p.board.height),
                     [_to_sensor(p, rot, *h) for h in p.hole_positions()], (0.0, 0.0), size(*p.lens.holder),
                     (0.0, 0.0))


def describe(profiles: dict[str, Profile] | None = None) -> list[str]:
    """One line per profile for `whisker design show`: name, title, lens offset, drawing."""
    profiles = load_profiles() if profiles is None else profiles
    return [f"{n}: {p.title}; board {p.board.width:g} x {p.board.height:g} mm, holes {p.holes.spacing_x:g} x "
            f"{p.holes.spacing_y:g} mm d{p.holes.diameter:g}, lens {p.lens_offset_from_holes:.2f} mm off the hole "
            f"centre, cable at {p.connector.side}" for n, p in profiles.items()]
