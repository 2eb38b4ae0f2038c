"""The build guide (docs/build.md), its data (hw/build_steps.toml), the pictures, the assembly
sequence (hw/assembly_sequence.toml) and the BOM (hw/bom.csv) tell one story (issue 29)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from whisker.cad.pictures import assembly_images, guide
from whisker.cad.assembly import sequence
from whisker.design import DesignError

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def data():
    tools, steps = guide.load()
    return tools, steps, guide.bom_lines()


def test_page_is_generated_from_the_data(data):
    """docs/build.md's step sections are exactly what the data renders (`make guide` rewrites them)."""
    tools, steps, bom = data
    text = (DOCS / "build.md").read_text()
    block = text.split(guide.BEGIN, 1)[1].split(guide.END, 1)[0].strip("\n")
    assert block == guide.render(tools, steps, bom), "docs/build.md is stale: run `make guide`"


def test_every_picture_named_in_the_guide_exists_and_make_guide_makes_it(data):
    from whisker.cad.pictures import guide_images
    from whisker.design import default_design

    _, steps, _ = data
    text = (DOCS / "build.md").read_text()
    named = set(re.findall(r'src="([^"]+)"', text))
    assert {guide.picture(s) for s in steps} <= named
    missing = [p for p in named if not (DOCS / p).is_file()]
    assert not missing, f"pictures named in docs/build.md but not in docs/: {missing} (make guide)"
    made = guide_images.generated(default_design())
    assert named <= made, f"pictures `make guide` does not regenerate: {sorted(named - made)}"
    mk = (ROOT / "mk" / "guide.mk").read_text()
    assert "write_guide_images" in mk and "print preview" in mk and "guide: assembly-images" in mk


def test_every_sequence_step_is_carried_out_once_in_order(data):
    """Each casting view and assembly-sequence step is one guide step, and the guide does them in an
    order the sequence allows (every `after` step earlier)."""
    _, steps, _ = data
    views = assembly_images.views()
    names = [v.name for v in views]
    done = [s.sequence for s in steps if s.sequence]
    assert sorted(done) == sorted(names), "guide steps and sequence/casting views differ"
    pos = {name: i for i, name in enumerate(done)}
    for v in views:
        for first in v.after:
            assert pos[first] < pos[v.name], f"{v.name!r} comes before {first!r} in the guide"
    # the sequence the CAD checks is the one the pictures show
    assert [s.name for s in sequence.load_steps()] == names[len(assembly_images.CASTING):]


def test_every_bom_line_is_used_and_every_part_is_bought(data):
    _, steps, bom = data
    used = {item for s in steps for item, _ in s.parts}
    assert not (used - set(bom)), f"parts in the guide that the BOM does not list: {sorted(used - set(bom))}"
    assert not (set(bom) - used), f"BOM lines no step uses: {sorted(set(bom) - used)}"


def test_each_step_has_what_a_maker_needs(data):
    tools, steps, _ = data
    assert len({s.id for s in steps}) == len(steps)
    for s in steps:
        assert s.check and s.do and s.title, s.id
        assert set(s.tools) <= set(tools), f"{s.id}: unknown tool {set(s.tools) - set(tools)}"
        for item, q in s.parts:
            assert q == "all" or float(q) > 0, f"{s.id}: quantity {q!r} of {item}"
    assert set(tools) == {t for s in steps for t in s.tools}, "a tool no step uses"


def test_numbered_once():
    """Only docs/build.md numbers the build: assembly.md and bringup.md carry no step numbers."""
    for page in ("assembly.md", "bringup.md"):
        text = (DOCS / page).read_text()
        assert not re.search(r"^#+ \d+\.", text, re.M), f"docs/{page} numbers its sections"
        assert not re.search(r"\*\*\d+\.\d+ ", text), f"docs/{page} numbers steps"
        assert "build.md" in text


def test_a_malformed_step_is_refused_in_one_line(tmp_path):
    bad = tmp_path / "steps.toml"
    bad.write_text('[[step]]\nid = "x"\n')
    with pytest.raises(DesignError, match="step 1 is malformed"):
        guide.load(bad)
