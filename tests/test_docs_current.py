"""Docs that cannot go stale (issue 30): every generated figure and table under docs/ and
benchmarks/results/ carries a stamp in docs/generated.json (command, design digest, model numbers,
sha256; whisker.data.provenance), and the stamp matches today's design and model.

When this fails, the message names each file and what differs (e.g. "coil_resistance_ohm 5.872 ->
6.1"); `make docs` regenerates and re-stamps them (README, "Every generated figure and table is current").
It runs in CI unskipped: a merge that changes the design or a model number comes with the regenerated
files (`make docs-GROUP` for the groups the message names)."""

from __future__ import annotations

import json

import pytest

from whisker.data import provenance as P


def test_every_generated_file_is_current():
    bad = P.problems(expected=P.generated_files())
    assert not bad, f"{len(bad)} generated file(s) not current:\n" + "\n".join(bad)


def test_the_check_names_the_file_and_what_differs(tmp_path, monkeypatch):
    """A file stamped from another design is reported with the model number that changed, a file
    edited after stamping and an unstamped one are named too."""
    monkeypatch.setattr(P, "ROOT", tmp_path)
    man = tmp_path / "generated.json"
    (tmp_path / "a.png").write_bytes(b"a")
    (tmp_path / "b.md").write_text("b")
    P.stamp([tmp_path / "a.png"], "make a", ["--set", "coil.turns=300"], manifest=man)
    P.stamp([tmp_path / "b.md"], "make b", [], manifest=man)
    assert P.problems(man) == []
    data = json.loads(man.read_text())
    data["a.png"]["design_args"] = []                    # as if today's design were the default again
    man.write_text(json.dumps(data))
    (tmp_path / "b.md").write_text("edited")
    lines = P.problems(man, expected=["a.png", "b.md", "c.csv"])
    a = next(x for x in lines if x.startswith("a.png"))
    assert "coil_turns 300 -> 370" in a and "regenerate: make a" in a
    assert any(x.startswith("b.md") and "changed after it was stamped" in x for x in lines)
    assert any(x.startswith("c.csv") and "no provenance stamp" in x for x in lines)


@pytest.mark.parametrize("args", [["--bogus"], ["--set"]])
def test_stamp_refuses_bad_design_arguments(tmp_path, args):
    with pytest.raises((ValueError, IndexError)):
        P._split_args(args)


def _docs_mk() -> str:
    return (P.ROOT / "mk" / "docs.mk").read_text()


def test_make_docs_runs_every_benchmark():
    """`make docs` has a group for every benchmarks/bench_*.py (bench_states runs in docs-states), and
    names the files each one writes."""
    import re

    text = _docs_mk().replace("\\\n", " ")
    bench = set(re.search(r"^DOCS_BENCH \?=(.*)$", text, re.M).group(1).split())
    have = {p.stem[len("bench_"):] for p in (P.ROOT / "benchmarks").glob("bench_*.py")} - {"states"}
    assert bench == have, f"make docs misses {sorted(have - bench)}, names unknown {sorted(bench - have)}"
    for b in sorted(bench):
        assert re.search(rf"^DOCS_BENCH_FILES_{b} =\s*\S", text, re.M), f"mk/docs.mk: no DOCS_BENCH_FILES_{b}"


def test_every_generated_file_has_a_generator_in_make_docs():
    """Each generated figure and table is named by a group of mk/docs.mk (its path, its name in a
    benchmark's file list, or a glob), so `make docs` can remake it; hand-made files are listed with a reason."""
    import fnmatch
    import re

    text = _docs_mk()
    words = set(re.split(r"[\s\"']+", text))
    globs = [w for w in words if "*" in w]
    orphans = [rel for rel in P.generated_files()
               if rel not in words and not (rel.startswith("benchmarks/results/") and rel.split("/")[-1] in words)
               and not any(fnmatch.fnmatch(rel, g) for g in globs)]
    assert not orphans, f"no group of mk/docs.mk makes {orphans}: add a generator or list it in NOT_GENERATED"
    for rel, why in P.NOT_GENERATED.items():
        assert (P.ROOT / rel).is_file() and why.strip(), rel
        assert rel not in P.load(), f"{rel} is listed as hand-made but carries a stamp"
