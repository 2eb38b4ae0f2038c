"""Every dotted ``whisker...`` path that the README and docs/ name resolves: the module imports and the
name after it exists, so no doc sends a reader to a path the package layout no longer has."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
# `whisker.x.y` inside backticks or in running text; a trailing dot ends a sentence, not a path
PATH = re.compile(r"(?<![\w./-])whisker(?:\.[A-Za-z_]\w*)+")


def _named_paths() -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for doc in DOCS:
        for m in PATH.finditer(doc.read_text()):
            out.setdefault(m.group(0), []).append(doc.name)
    return out


NAMED = _named_paths()


def resolve(path: str):
    """The object a dotted path names: the longest importable module prefix, then attributes."""
    parts = path.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError as err:
            if err.name and not ".".join(parts[:k]).startswith(err.name):
                raise  # a module that exists but needs an extra that is missing: a real failure
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(path)


def test_the_docs_name_paths():
    assert "whisker.design.load_design" in NAMED and len(NAMED) > 20


@pytest.mark.parametrize("path", sorted(NAMED))
def test_every_path_the_docs_name_resolves(path):
    try:
        resolve(path)
    except (ImportError, AttributeError) as err:
        pytest.fail(f"{path} (named in {', '.join(sorted(set(NAMED[path])))}) does not resolve: {err}")
