"""The committed ready files (exports/) are what `make stl` builds from the current CAD (issue 29).

STL bytes are the same on every run (OpenCASCADE's tessellation is deterministic: built twice, every
STL identical); a STEP file gets a fixed write time (SOURCE_DATE_EPOCH, else the epoch:
whisker.cad.buildkey.step_timestamp), so the parts' STEP files are byte-identical too; the assembly's
colour entities come in a different order from run to run, which the manifest's ``content_sha256``
leaves out (whisker.cad.buildkey.content_digest). The committed manifest is read from git (HEAD), because CI
runs `make stl` into exports/ before the tests.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from conftest import load_manifest
from whisker.cad.buildkey import content_digest

ROOT = Path(__file__).resolve().parents[1]


def _git_show(path: str) -> bytes | None:
    try:
        res = subprocess.run(["git", "show", f"HEAD:{path}"], cwd=ROOT, capture_output=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    return res.stdout if res.returncode == 0 else None


@pytest.fixture(scope="module")
def committed() -> dict:
    data = _git_show("exports/manifest.json")
    if data is None:
        if not (ROOT / ".git").exists():
            pytest.skip("not a git checkout (an installed package): no committed exports to compare")
        pytest.fail("exports/manifest.json is not committed: run `make stl` and commit exports/")
    return json.loads(data)


def test_make_stl_reproduces_the_committed_exports(default_build, committed):
    fresh = load_manifest(default_build)
    want, got = committed["content_sha256"], fresh["content_sha256"]
    assert set(got) == set(want), f"files differ: new {sorted(set(got) - set(want))}, gone {sorted(set(want) - set(got))}"
    stale = sorted(n for n in want if want[n] != got[n])
    assert not stale, f"exports/ is stale for {stale}: run `make stl` and commit exports/"
    # byte for byte, except the assembly's colour order: a rebuild leaves the committed files clean in git
    moved = sorted(n for n in want if n != "assembly.step" and committed["file_sha256"][n] != fresh["file_sha256"][n])
    assert not moved, f"{moved} differ byte for byte from the committed files"
    assert committed["design_digest"] == fresh["design_digest"]
    assert committed["all_checks_passed"] is True


def test_committed_files_are_the_manifests(committed):
    """Every file the committed manifest lists is committed with the content it records."""
    for name, digest in committed["content_sha256"].items():
        data = _git_show(f"exports/{name}")
        assert data is not None, f"exports/{name} is not committed"
        assert content_digest(data, Path(name).suffix) == digest, f"exports/{name} differs from its manifest"


def test_readme_starts_with_the_ready_files():
    head = "\n".join((ROOT / "README.md").read_text().splitlines()[:10])
    assert "exports/" in head and "docs/build.md" in head and "No Python" in head
    assert (ROOT / "exports" / "README.md").is_file()
