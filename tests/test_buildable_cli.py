"""Bad input to `whisker cad build` for the issue-21 settings: one line, exit 2, exports untouched."""

from __future__ import annotations

import pytest

from conftest import run_cli


@pytest.mark.parametrize("setting,words", [
    ("camera.board=rpi_v9", ["unknown camera board 'rpi_v9'", "rpi_v2", "ov5647_m12"]),
    ("fasteners.mount_screw=M4", ["unknown fastener size 'M4'", "M2.5", "M6"]),
    ("mount.mounting_hole_depth=5", ["insert", "6.7 mm deep hole", "the wall is 5 mm"]),
    ("adapter.preset=iso9409_40_4_m6", ["unknown flange", "iso9409_50_4_m6"]),
])
def test_bad_setting_is_one_line_and_leaves_exports(tmp_path, setting, words):
    out = tmp_path / "exports"
    out.mkdir()
    (out / "keep.txt").write_text("previous build")
    r = run_cli("cad", "build", "--set", setting, "--out", str(out))
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and all(w in lines[0] for w in words), r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    assert (out / "keep.txt").read_text() == "previous build"
