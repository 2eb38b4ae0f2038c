"""Assembly pictures (whisker.cad.pictures.assembly_images): one PNG per step, the new parts highlighted."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.colors import to_rgb
from matplotlib.image import imread

from whisker.cad.pictures import assembly_images as ai
from whisker.cad.assembly import sequence
from whisker.design import default_design

DOCS = Path(__file__).resolve().parents[1] / "docs" / "images" / "assembly"


def _highlighted(img: np.ndarray) -> np.ndarray:
    """Pixels of the highlight's hue: the shading scales its colour, so compare ratios, not values."""
    rgb = img[..., :3].astype(float)
    hr, hg, hb = to_rgb(ai.HIGHLIGHT)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r > 0.15) & (np.abs(g / np.maximum(r, 1e-6) - hg / hr) < 0.12) & (b < r * (hb / hr + 0.15))


def test_one_view_per_step_and_the_committed_images_match():
    steps = sequence.load_steps()
    views = ai.views(steps)
    assert len(views) == len(ai.CASTING) + len(steps)
    assert [v.name for v in views[len(ai.CASTING):]] == [s.name for s in steps]
    names = [v.file_name(i) for i, v in enumerate(views, start=1)]
    assert len(set(names)) == len(names)
    # docs/images/assembly holds exactly the pictures of the current sequence (make assembly-images)
    assert sorted(p.name for p in DOCS.glob("*.png")) == sorted(names)


def test_a_step_renders_with_its_new_parts_highlighted(tmp_path):
    d = default_design()
    seq_first = len(ai.CASTING) + 1  # magnets into their pockets: the mount is cut open
    paths = ai.write_assembly_images(d, tmp_path, (480, 360), only=lambda i, v: i in (1, seq_first))
    assert [p.name for p in paths] == [ai.views()[0].file_name(1), ai.views()[seq_first - 1].file_name(seq_first)]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = imread(p)
        assert img.shape[:2] == (360, 480)
        share = _highlighted(img).mean()
        assert 0.002 < share < 0.5, (p.name, share)
    # the neutral colours are not mistaken for the highlight
    neutral = np.array([[to_rgb(c) for c in ai.NEUTRAL.values()]])
    assert not _highlighted(neutral).any()


def test_scene_moves_the_new_parts_back_along_their_path():
    d = default_design()
    view = next(v for v in ai.views() if v.new == ("camera",))
    items, paths = ai.scene(d, view)
    new = [m for m, c in items if c == ai.HIGHLIGHT]
    placed = [m for m, c in items if c != ai.HIGHLIGHT]
    # the camera comes up from below: drawn below everything already in place, arrows pointing up
    assert max(m.bounds[1, 2] for m in new) < min(m.bounds[0, 2] for m in placed)
    assert paths and all(p[-1, 2] - p[0, 2] == pytest.approx(ai.explode_distance(d)) for p in paths)


def test_cli_writes_the_images_and_refuses_a_bad_size(tmp_path):
    from whisker.commands.build.cad import cli

    bad = CliRunner().invoke(cli, ["assembly-images", "--out", str(tmp_path), "--size", "big"])
    assert bad.exit_code == 2 and "--size" in bad.output and "Traceback" not in bad.output
    assert not list(tmp_path.iterdir())


def test_the_committed_page_holds_the_current_sequence_table(tmp_path):
    d = default_design()
    page = DOCS.parents[1] / "assembly.md"
    assert ai.sequence_table(d) in page.read_text(), "docs/assembly.md is stale: run make assembly-images"
    table = ai.sequence_table(d)
    for step in sequence.load_steps():
        assert f"| {step.name} |" in table
    # the block is replaced, the text around it kept; a page without the block is refused
    copy = tmp_path / "a.md"
    copy.write_text(f"before\n{ai.TABLE_BEGIN}\nold\n{ai.TABLE_END}\nafter\n")
    assert ai.update_page(copy, d) and not ai.update_page(copy, d)
    text = copy.read_text()
    assert text.startswith("before\n") and text.endswith("after\n") and "old" not in text
    copy.write_text("no table here\n")
    with pytest.raises(ValueError, match="SEQUENCE TABLE"):
        ai.update_page(copy, d)


def test_the_pages_link_only_pictures_that_exist():
    import re

    docs = DOCS.parents[1]
    for page in ("build.md", "assembly.md"):
        links = re.findall(r'src="(images/assembly/[^"]+)"', (docs / page).read_text())
        assert links, page
        assert all((docs / link).is_file() for link in links), page
