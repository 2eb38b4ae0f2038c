"""Build key: what a build's output depends on, computed without importing CadQuery (fast no-op)."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import whisker
from whisker.design import Design
from whisker.resources import hw_dir

# Every build writes both; the key names them so a future STL-only build cannot pass for a full one.
FORMATS = ("stl", "step")

# software/whisker in a clone, site-packages/whisker from a wheel.
_PACKAGE = Path(whisker.__file__).resolve().parent


def source_digest() -> str:
    """Hash of the CAD sources, the design model and the data tables the parts read: a change to
    any of them invalidates old exports."""
    h = hashlib.sha256()
    hw = hw_dir()
    cad = Path(__file__).resolve().parent
    sources = (sorted(cad.rglob("*.py"))   # the subpackages (solids/, verify/, ...) too
               + sorted((_PACKAGE / "design").glob("*.py")) + [_PACKAGE / "files.py"]
               # the data the parts are built from (standards and datasheets, board drawings, the sequence)
               + [hw / n for n in ("fasteners.csv", "camera_boards.toml", "flanges.csv", "assembly_sequence.toml")])
    for p in sources:
        h.update((str(p.relative_to(cad)) if p.is_relative_to(cad) else p.name).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def build_key(d: Design, formats: tuple[str, ...]) -> str:
    return f"{d.digest()}-{source_digest()}-{'+'.join(sorted(formats))}"


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def up_to_date(out: str | Path, d: Design, formats: tuple[str, ...] = FORMATS) -> bool:
    """True when `out` holds a complete build of exactly this design and CAD code: the manifest's
    build key matches and every file it lists has the hash it records (a build killed while it
    published leaves the old manifest beside some new files; this finds them)."""
    out = Path(out)
    try:
        manifest = json.loads((out / "manifest.json").read_text())
        hashes = manifest["file_sha256"]
        if manifest.get("build_key") != build_key(d, formats) or not hashes:
            return False
        return all(file_sha256(out / name) == digest for name, digest in hashes.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


_STEP_STAMP = re.compile(rb"^(FILE_NAME\('[^']*',)'[^']*'", re.M)
_STEP_ID = re.compile(rb"#\d+")
_STEP_STYLE = b"MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION"


def step_timestamp() -> str:
    """The write time put in every STEP file's FILE_NAME: SOURCE_DATE_EPOCH (the reproducible-builds
    convention) when set, else the epoch, so a rebuild of unchanged parts writes the same bytes and
    the committed exports/ stay clean in git."""
    import os
    from datetime import datetime, timezone

    try:
        t = int(os.environ.get("SOURCE_DATE_EPOCH", "0"))
    except ValueError:
        t = 0
    return datetime.fromtimestamp(t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")


def fix_step_timestamp(path: str | Path) -> None:
    """Rewrite the STEP file's FILE_NAME write time to :func:`step_timestamp` (in place; the file is
    in the build's staging folder, published atomically afterwards)."""
    p = Path(path)
    data = p.read_bytes()
    new = _STEP_STAMP.sub(rb"\1'" + step_timestamp().encode() + rb"'", data, count=1)
    if new != data:
        p.write_bytes(new)


def content_sha256(path: str | Path) -> str:
    """Hash of what a file holds, for the reproduction test (tests/test_exports.py), hex.

    STL files are hashed as they are: OpenCASCADE's tessellation writes the same bytes on every run
    (checked by building twice). A STEP file carries its write time in FILE_NAME, and an assembly's
    colour section (after the first MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION) comes in
    a different order from run to run; the hash leaves out the time and takes that section's entities
    as a sorted list with their ``#n`` ids blanked (which colours are used, not in which order).
    """
    return content_digest(Path(path).read_bytes(), Path(path).suffix)


def content_digest(data: bytes, suffix: str) -> str:
    """:func:`content_sha256` of a file's bytes; `suffix` (".stl", ".step") says how to read them."""
    if suffix.lower() not in (".step", ".stp"):
        return hashlib.sha256(data).hexdigest()
    data = _STEP_STAMP.sub(rb"\1''", data, count=1)
    head, sep, tail = data.partition(_STEP_STYLE)
    if sep:
        body, _, end = (sep + tail).rpartition(b"ENDSEC;")
        ents = sorted(_STEP_ID.sub(b"#", e.strip()) for e in body.split(b";") if e.strip())
        data = head + b";".join(ents) + b"ENDSEC;" + end
    return hashlib.sha256(data).hexdigest()
