"""`whisker explore`: the grid, the paper's design against `make sim-grasp`, the same table from every
engine and after an interrupt, refusals, failing tasks and hostile input. About a minute on 2 cores
(every run is 2 designs x 5 objects x 3 configurations x 2 attempts, or smaller)."""

from __future__ import annotations

import csv
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st


pytest.importorskip("mujoco", reason="MuJoCo (pip install mujoco) is needed for the grasp attempts")

from whisker.cli import main  # noqa: E402
from whisker.design import default_design, load_design  # noqa: E402
from whisker.explore.grid import ExploreError, grid, parse_values  # noqa: E402

WHISKER = Path(sys.executable).with_name("whisker")
#: the small grid: the paper's sensor and a 6-whisker one; 2 attempts, 1 per task (so a kill lands mid-run)
SMALL = ["--vary", "whiskers.count=8,6", "--attempts", "2", "--chunk", "1", "--cad", "skip", "-q"]


def explore(*args, cwd=None, check=True) -> subprocess.CompletedProcess:
    res = subprocess.run([str(WHISKER), "explore", *map(str, args)], capture_output=True, text=True, timeout=600,
                         cwd=cwd, env={**os.environ, "MPLBACKEND": "Agg"})
    if check:
        assert res.returncode == 0, res.stderr[-2000:]
    return res


def rows(folder: Path) -> list[dict]:
    with open(folder / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def serial(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("serial") / "explore"
    explore(*SMALL, "--jobs", "1", "--out", out)
    return out


# ---- the grid ----------------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(a=st.integers(-50, 50), n=st.integers(1, 40), s=st.integers(1, 9))
def test_integer_ranges_are_inclusive(a, n, s):
    b = a + (n - 1) * s
    assert parse_values(f"{a}:{b}:{s}", "k") == tuple(range(a, b + 1, s))


@settings(max_examples=60, deadline=None)
@given(a=st.floats(0.5, 30), n=st.integers(1, 30), s=st.sampled_from([0.1, 0.25, 0.5, 2.0]))
def test_float_ranges_reach_their_stop_without_drift(a, n, s):
    a = round(a, 3)                                   # as typed
    b = round(a + (n - 1) * s, 6)
    vals = parse_values(f"{a}:{b}:{s}", "k")
    assert len(vals) == n and abs(vals[-1] - b) < 1e-6 and all(y > x for x, y in zip(vals, vals[1:]))


def test_grid_is_every_combination_last_option_fastest_with_refusals_kept():
    pts = grid(None, ("actuation.voltage=2.5",), ["whiskers.count=0,6", "whiskers.ring_radius=10,12"])
    assert [p.assignment for p in pts] == [(("whiskers.count", c), ("whiskers.ring_radius", r))
                                           for c in (0, 6) for r in (10, 12)]
    assert all(p.design is None and "whiskers.count" in p.refusal for p in pts[:2])   # count 0: refused
    assert pts[3].design == default_design("actuation.voltage=2.5", "whiskers.count=6", "whiskers.ring_radius=12")


@pytest.mark.parametrize("spec, words", [("whiskers.cuont=4", "no parameter 'cuont'"),
                                          ("whiskers.ring_radius=16:8:2", "empty range"),
                                          ("whiskers.count=1:4:0", "step is 0"),
                                          ("whiskers.count=", "no values"),
                                          ("whiskers.count=nan:4:1", "not a finite number"),
                                          ("nosection.key=1", "no section")])
def test_bad_vary_is_refused_naming_it(spec, words):
    with pytest.raises(ExploreError, match=words):
        grid(None, (), [spec])


# ---- the paper's design, engines, resume ---------------------------------------------------------

def test_paper_design_reproduces_make_sim_grasp(serial, tmp_path):
    """The paper's design is in the table (its digest) and every cell equals `whisker sim grasp` (what
    `make sim-grasp` runs) at the same seed and attempts."""
    paper = next(r for r in rows(serial) if r["whiskers.count"] == "8")
    assert paper["design_digest"] == default_design().digest() and paper["status"] == "ok"
    res = subprocess.run([str(WHISKER), "sim", "grasp", "--attempts", "2", "-q", "--out", str(tmp_path / "g")],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    with open(tmp_path / "g" / "grasp_table.csv", newline="") as fh:
        sim = list(csv.DictReader(fh))
    label = {"8": "all", "4": "half", "2": "pair"}
    slug = {"paper flower": "paper_flower", "pom-pom": "pom_pom", "mini pinecone": "mini_pinecone",
            "popcorn": "popcorn", "foam ball": "foam_ball"}
    assert len(sim) == 15
    for s in sim:
        held = int(paper[f"held_{slug[s['object']]}_{label[s['active_whiskers']]}"])
        assert f"{100 * held / 2:.1f}" == s["success_pct_sim"], s
    totals = {lab: sum(int(paper[f"held_{o}_{lab}"]) for o in slug.values()) for lab in label.values()}
    assert float(paper["grasp_all_pct"]) == pytest.approx(100 * totals["all"] / 10)
    assert float(paper["grasp_all_lo"]) <= float(paper["grasp_all_pct"]) <= float(paper["grasp_all_hi"])


def test_dask_local_cluster_gives_the_same_table(serial, tmp_path):
    """Two worker processes (a Dask LocalCluster, processes=True): the same table, byte for byte."""
    res = explore(*SMALL, "--workers", "2", "--out", tmp_path / "w2")
    assert (tmp_path / "w2" / "results.csv").read_text() == (serial / "results.csv").read_text()
    assert "Dask LocalCluster, 2 worker processes" in (tmp_path / "w2" / "summary.md").read_text()


def test_existing_dask_cluster_gives_the_same_table(serial, tmp_path):
    """--scheduler ADDRESS: a cluster started elsewhere (here: a LocalCluster of this test process)."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        explore(*SMALL, "--scheduler", cluster.scheduler_address, "--out", tmp_path / "ext")
    assert (tmp_path / "ext" / "results.csv").read_text() == (serial / "results.csv").read_text()
    assert f"Dask scheduler {cluster.scheduler_address}" in (tmp_path / "ext" / "summary.md").read_text()


def test_killed_run_resumes_to_the_same_table(serial, tmp_path):
    """SIGKILL part-way (only whole task files are left), then the same command: it runs only what is
    missing and the table is the serial one."""
    out = tmp_path / "resume"
    cmd = [str(WHISKER), "explore", *SMALL, "--jobs", "1", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while len(list(out.glob("cache/*/grasp-*.json"))) < 8 and time.monotonic() < deadline:
            assert proc.poll() is None, "the run finished before it could be interrupted"
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert not (out / "results.csv").exists()
    done = len(list(out.glob("cache/*/*.json")))
    assert 8 <= done < 62 and not list(out.glob("cache/*/.*.tmp"))
    explore(*SMALL, "--jobs", "1", "--out", out)
    assert (out / "results.csv").read_text() == (serial / "results.csv").read_text()
    summary = (out / "summary.md").read_text()
    assert f"{62 - done} tasks run, {done} from the cache" in summary


# ---- refusals, Pareto designs, failures, hostile input -------------------------------------------

def test_cad_refusal_is_recorded_and_a_pareto_design_loads(tmp_path):
    """A ring 1 mm inside the small-ring bound (whisker.design.sizing.crowding_bound_radius) with 6 whiskers: the
    CAD checks refuse it (coils collide at full swing, as `make sweep` says); R = 12 mm builds, is
    simulated and is written as a design file that loads to the same design."""
    pytest.importorskip("cadquery", reason="CadQuery ([cad]) runs the CAD checks")
    from whisker.design import default_design
    from whisker.design.sizing import crowding_bound_radius

    inside = math.floor(crowding_bound_radius(default_design("whiskers.count=6"))) - 1
    out = tmp_path / "cad"
    explore("--set", "whiskers.count=6", "--vary", f"whiskers.ring_radius={inside},12", "--attempts", "1", "--jobs", "1",
            "--cad", "evaluate", "-q", "--out", out)
    r7, r12 = rows(out)
    assert r7["status"] == "refused" and r7["reason"].startswith("CAD: assembly: coil clearance over full deflection")
    assert r7["grasp_all_pct"] == "" and r12["status"] == "ok" and r12["cad"] == "ok"
    files = list((out / "pareto").glob("design-*.toml"))
    assert [f.name for f in files] == [f"design-{r12['design_digest']}.toml"]
    d = load_design(files[0])
    assert d.digest() == r12["design_digest"] and d.whiskers.count == 6 and d.whiskers.ring_radius == 12
    assert d.source("membrane.inscribed_radius").startswith("rule")      # "auto" sizes stay rules
    assert "make stl DESIGN=" in files[0].read_text()


def test_a_failing_task_is_reported_with_its_design_and_the_rest_finish(tmp_path, monkeypatch):
    """One object's grasp raises: its design is marked failed naming the task, the other design is
    complete, the command exits 1 with one line; a rerun retries only the failed tasks."""
    import whisker.sim.experiments.paper as paper

    real = paper.grasp_attempt

    def flaky(scene, design, obj, active, *a, **kw):
        if obj.name == "popcorn" and design.whiskers.count == 6:
            raise RuntimeError("solver exploded")
        return real(scene, design, obj, active, *a, **kw)

    monkeypatch.setattr(paper, "grasp_attempt", flaky)
    out = tmp_path / "fail"
    res = CliRunner().invoke(main, ["explore", "--vary", "whiskers.count=8,6", "--attempts", "1", "--cad", "skip",
                                    "--jobs", "1", "-q", "--out", str(out)])
    assert res.exit_code == 1
    last = res.output.strip().splitlines()[-1]
    assert "3 tasks failed" in last and "'popcorn'" in last and "solver exploded" in last
    r8, r6 = rows(out)
    assert r8["status"] == "ok" and r6["status"] == "failed" and "popcorn" in r6["reason"]
    monkeypatch.setattr(paper, "grasp_attempt", real)
    res = CliRunner().invoke(main, ["explore", "--vary", "whiskers.count=8,6", "--attempts", "1", "--cad", "skip",
                                    "--jobs", "1", "-q", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert rows(out)[1]["status"] == "ok" and "3 tasks run, 29 from the cache" in (out / "summary.md").read_text()


@pytest.mark.parametrize("args, code, words", [
    (["--vary", "whiskers.cuont=4"], 2, "no parameter 'cuont'"),
    (["--vary", "whiskers.ring_radius=16:8:2"], 2, "empty range"),
    (["--vary", "whiskers.count=8", "--scheduler", "x"], 2, "not a Dask scheduler address"),
    (["--vary", "whiskers.count=8", "--scheduler", "tcp://127.0.0.1:9"], 1, "no Dask scheduler answers"),
])
def test_hostile_input_one_line(tmp_path, args, code, words):
    res = explore(*args, "--out", tmp_path / "h", check=False)
    assert res.returncode == code
    assert words in res.stderr and "Traceback" not in res.stderr
    assert len([ln for ln in res.stderr.splitlines() if ln.strip() and not ln.startswith(("Usage:", "Try "))]) == 1
    assert not (tmp_path / "h" / "results.csv").exists()


def test_task_cache_keeps_inf_and_treats_a_broken_file_as_missing(tmp_path):
    """A coil that never reaches its limit (time inf) survives the JSON cache; a file that is not a
    finished task's (e.g. cut short by a full disk) is run again, not trusted."""
    import math

    from whisker.explore.tasks import TaskCache

    c = TaskCache(tmp_path)
    c.put("d1", "design.json", {"time_to_limit_s": math.inf, "held": [True, False], "limit": "PLA softening"})
    assert c.get("d1", "design.json") == {"time_to_limit_s": math.inf, "held": [True, False], "limit": "PLA softening"}
    (tmp_path / "d1" / "broken.json").write_text('{"value": [tru')
    assert c.get("d1", "broken.json") is None and c.get("d2", "design.json") is None


def test_grid_markdown_lays_a_two_or_three_key_study_out_as_tables():
    """grid.md (docs/explore_grid.md): rows = the first --vary key, columns = the second, one table per
    value of the third; a cell is all [95 %] / half / pair, a design that did not run shows its status;
    the same grid from the study's numbers and from results.csv's strings."""
    from whisker.explore.report import grid_markdown

    varied = ["whiskers.count", "whiskers.ring_radius", "actuation.voltage"]
    rows = [{"whiskers.count": c, "whiskers.ring_radius": r, "actuation.voltage": v, "status": "ok",
             "grasp_all_pct": 10.0 * c + r + v, "grasp_all_lo": 1.0, "grasp_all_hi": 99.0,
             "grasp_half_pct": 5.0, "grasp_pair_pct": 0.0} for c in (4, 8) for r in (8, 10) for v in (2, 3)]
    rows[0].update(status="refused", grasp_all_pct=float("nan"))
    md = grid_markdown(rows, varied)
    assert md.count("| voltage = ") == 2 and "| 8 | 10 |" in md
    assert "| 4 | refused | 52 [1-99] / 5 / 0 |" in md                 # 4 whiskers at 2 V: 8 mm refused
    assert "| 8 | 91 [1-99] / 5 / 0 | 93 [1-99] / 5 / 0 |" in md         # 8 whiskers at 3 V
    as_text = [{k: str(v) for k, v in r.items()} for r in rows]
    assert grid_markdown(as_text, varied) == md
    assert grid_markdown(rows, varied[:1]) == ""
