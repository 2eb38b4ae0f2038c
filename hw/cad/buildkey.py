"""Build key: what a build's output depends on, computed without importing CadQuery (fast no-op)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from whisker.design import Design

_PACKAGE = Path(__file__).resolve().parents[2] / "software" / "whisker"


def source_digest() -> str:
    """Hash of the CAD sources and the design model: a code change invalidates old exports."""
    h = hashlib.sha256()
    sources = sorted(Path(__file__).resolve().parent.glob("*.py")) + [_PACKAGE / "design.py", _PACKAGE / "files.py"]
    for p in sources:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def build_key(d: Design, formats: tuple[str, ...]) -> str:
    return f"{d.digest()}-{source_digest()}-{'+'.join(sorted(formats))}"
