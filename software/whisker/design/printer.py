"""The printer profile: a PrusaSlicer .ini file, read once, used by the slicer AND the design.

The same file is handed to ``prusa-slicer --load`` when a part is sliced and read here for the
numbers the design needs (bed size, maximum height, nozzle, layers, filament density), so the
printer's numbers are written in one place only (default: ``hw/printer/prusa_mk3s_pla_0.2mm.ini``).

Format (PrusaSlicer's config export): one ``key = value`` per line; lines starting with ``#`` or
``;`` are comments. ``bed_shape`` is the bed outline as ``x0xy0,x1xy1,...`` points in mm.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

from whisker.resources import hw_dir

# Relative profile paths are resolved against the folder that holds the default design file.
HW_DIR = hw_dir()


class ProfileError(ValueError):
    """A missing or unusable printer profile; the message is one line."""


@dataclass(frozen=True)
class PrinterProfile:
    """The numbers of a PrusaSlicer profile the rest of the project reads (mm, g/cm^3, deg)."""

    path: Path
    bed_x: float            # mm, bed outline's extent in x
    bed_y: float            # mm
    max_height: float       # mm, max_print_height
    nozzle_diameter: float  # mm
    layer_height: float     # mm
    first_layer_height: float  # mm
    filament_diameter: float   # mm
    filament_density: float    # g/cm^3
    support_threshold_deg: float  # slope from horizontal below which an overhang needs support
    settings: tuple[tuple[str, str], ...] = ()

    def get(self, key: str, default: str | None = None) -> str | None:
        return dict(self.settings).get(key, default)


def resolve(path: str | Path) -> Path:
    """An absolute path as is; a relative one against ``hw/`` (where the default design lives)."""
    p = Path(path).expanduser()
    return p if p.is_absolute() else (HW_DIR / p).resolve()


def parse_ini(text: str) -> dict[str, str]:
    """PrusaSlicer config text -> {key: raw value}. Lines without '=' (other than comments) are errors."""
    out: dict[str, str] = {}
    for n, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s[0] in "#;":
            continue
        if s.startswith("[") and s.endswith("]"):  # a bundle section header: not a flat profile
            raise ProfileError(f"line {n}: section {s} - export a single flat profile (File > Export > Config)")
        if "=" not in s:
            raise ProfileError(f"line {n}: expected 'key = value', got {s[:40]!r}")
        key, value = s.split("=", 1)
        out[key.strip()] = value.strip()
    return out


def _number(settings: dict[str, str], key: str, default: float | None = None, lo: float = 0.0) -> float:
    raw = settings.get(key)
    if raw is None:
        if default is None:
            raise ProfileError(f"{key} missing")
        return default
    first = raw.split(",")[0].rstrip("%")  # per-extruder lists: take the first extruder
    try:
        v = float(first)
    except ValueError:
        raise ProfileError(f"{key} = {raw!r} is not a number") from None
    if not math.isfinite(v) or v <= lo:
        raise ProfileError(f"{key} = {raw!r} must be a finite number > {lo:g}")
    return v


def bed_extent(bed_shape: str) -> tuple[float, float]:
    """(x, y) extent in mm of a ``bed_shape`` outline such as ``0x0,250x0,250x210,0x210``."""
    try:
        pts = [tuple(float(c) for c in p.strip().split("x")) for p in bed_shape.split(",")]
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    except (ValueError, IndexError):
        raise ProfileError(f"bed_shape = {bed_shape!r}: expected points like 0x0,250x0,250x210,0x210") from None
    if len(pts) < 3 or any(len(p) != 2 for p in pts):
        raise ProfileError(f"bed_shape = {bed_shape!r}: needs at least 3 points x0xy0,x1xy1,...")
    x, y = max(xs) - min(xs), max(ys) - min(ys)
    if not (x > 0 and y > 0 and math.isfinite(x) and math.isfinite(y)):
        raise ProfileError(f"bed_shape = {bed_shape!r}: the bed has no area")
    return x, y


@functools.lru_cache(maxsize=32)
def _load(path: Path, mtime_ns: int) -> PrinterProfile:
    s = parse_ini(path.read_text())
    if "bed_shape" not in s:
        raise ProfileError("bed_shape missing")
    bx, by = bed_extent(s["bed_shape"])
    return PrinterProfile(
        path=path, bed_x=bx, bed_y=by, max_height=_number(s, "max_print_height"),
        nozzle_diameter=_number(s, "nozzle_diameter"), layer_height=_number(s, "layer_height"),
        first_layer_height=_number(s, "first_layer_height", _number(s, "layer_height")),
        filament_diameter=_number(s, "filament_diameter"), filament_density=_number(s, "filament_density"),
        support_threshold_deg=_number(s, "support_material_threshold", 45.0),
        settings=tuple(sorted(s.items())))


def load_profile(path: str | Path) -> PrinterProfile:
    """Read and check a printer profile. Raises :class:`ProfileError` with a one-line message that
    names the file and the bad key."""
    p = resolve(path)
    try:
        return _load(p, p.stat().st_mtime_ns)
    except FileNotFoundError:
        raise ProfileError(f"printer profile not found: {p} (relative paths start in {HW_DIR})") from None
    except ProfileError as err:
        raise ProfileError(f"printer profile {p}: {err}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise ProfileError(f"printer profile {p}: cannot read ({err})") from None
