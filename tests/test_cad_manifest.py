"""The manifest records a hash for every file; a build killed while it publishes is found and
rebuilt by the next `whisker cad build` (what `make stl` runs), never reported as up to date."""

from __future__ import annotations

import os
import signal
import subprocess
import time

from conftest import ROOT, WHISKER, load_manifest, run_cli
from whisker.cad.buildkey import file_sha256


def _consistent(out) -> bool:
    manifest = load_manifest(out)
    return all(file_sha256(out / name) == h for name, h in manifest["file_sha256"].items())


def test_manifest_hashes_every_file(default_build):
    manifest = load_manifest(default_build)
    listed = {f for p in manifest["parts"].values() for f in p.get("files", {}).values()} | {"assembly.step"}
    assert set(manifest["file_sha256"]) == listed
    assert _consistent(default_build)


def test_sigkill_while_publishing_is_rebuilt(tmp_path):
    out = tmp_path / "exports"
    assert run_cli("cad", "build", "--out", str(out), "-q").returncode == 0
    before = load_manifest(out)
    # Another design, killed after its first published file (the pause makes the moment certain).
    env = {**os.environ, "WHISKER_PUBLISH_PAUSE_S": "3"}
    proc = subprocess.Popen([*WHISKER, "cad", "build", "--set", "whiskers.count=6", "--set", "whiskers.ring_radius=10",
                             "--out", str(out)], cwd=ROOT, env=env, stderr=subprocess.PIPE, text=True)
    for line in proc.stderr:
        if "publishing" in line:
            break
    time.sleep(1.0)  # the first file has been renamed into place; the rest are still staged
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert load_manifest(out)["design_digest"] == before["design_digest"]  # the old manifest stayed
    assert not _consistent(out)  # ... beside a file of the killed build

    res = run_cli("cad", "build", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert "up to date" not in res.stdout  # it rebuilt
    assert _consistent(out)
    again = run_cli("cad", "build", "--out", str(out))
    assert "up to date" in again.stdout  # and now it is a no-op
    assert not list(tmp_path.glob(".exports.tmp-*"))  # the killed build's staging folder is gone
