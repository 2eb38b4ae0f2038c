"""`whisker sim --explain` validates exactly as the run does (issue 22), over generated scenes.

A scene `--explain` accepts (exit 0) runs without being refused: it ends with exit 0, or 1 only when
the run itself is flagged unphysical. A scene `--explain` refuses (exit 2) is refused by the run with
the same line, before anything is written.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import tomli_w
from click.testing import CliRunner
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from whisker.cli import main

EXAMPLES = int(os.environ.get("WHISKER_FUZZ_EXAMPLES", "30"))

sizes = st.sampled_from([0.5, 2.0, 5.0, 12.0, 40.0])
objects = st.lists(st.fixed_dictionaries({
    "shape": st.sampled_from(["sphere", "box"]),
    "r": sizes,
    "mass": st.sampled_from([0.2, 1.0, 10.0]),
    "pos": st.tuples(st.sampled_from([0.0, 8.0, 30.0, 60.0]), st.sampled_from([0.0, 12.0])),
}), max_size=2)


@st.composite
def scenes(draw) -> dict:
    objs = []
    for i, o in enumerate(draw(objects)):
        size = [o["r"]] if o["shape"] == "sphere" else [o["r"]] * 3
        objs.append({"name": f"o{i}", "shape": o["shape"], "size": size, "mass": o["mass"], "pos": list(o["pos"])})
    h0 = draw(st.sampled_from([-5.0, 0.0, 3.0, 20.0, 70.0]))
    path = [[0.0, 0.0, 0.0, h0, 0.0]]
    if draw(st.booleans()):
        path.append([0.02, draw(st.sampled_from([0.0, 10.0])), 0.0, draw(st.sampled_from([-2.0, 2.0, 20.0])), 0.0])
    scene = {"scene": {"name": "generated", "duration": draw(st.sampled_from([0.0, 0.01, 0.02])),
                       "timestep": draw(st.sampled_from([1e-4, 1e-3, 0.02, 0.05])),
                       "initial_tilt_deg": draw(st.sampled_from([0.0, 5.0]))},
             "sensor": {"path": path}, "objects": objs,
             "outputs": {"plots": False}}
    if draw(st.booleans()):
        scene["actuation"] = {"schedule": [{"t": 0.0, "level": draw(st.sampled_from([0.3, 1.0]))}]}
    return scene


@settings(max_examples=EXAMPLES, deadline=None, derandomize=not os.environ.get("WHISKER_FUZZ_RANDOM"),
          suppress_health_check=[HealthCheck.too_slow])
@given(scene=scenes())
def test_explain_accepts_exactly_what_the_run_accepts(scene):
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "scene.toml"
        f.write_text(tomli_w.dumps(scene))
        env = {"WHISKER_DEBUG": ""}
        ex = CliRunner().invoke(main, ["sim", str(f), "--explain"], env=env)
        assert ex.exit_code in (0, 2) and "Traceback" not in ex.output, ex.output
        event(f"explain exit {ex.exit_code}")
        out = Path(tmp) / "run"
        run = CliRunner().invoke(main, ["sim", str(f), "--out", str(out), "-q"], env=env)
        assert "Traceback" not in run.output and "internal error" not in run.output
        if ex.exit_code == 2:
            assert run.exit_code == 2 and run.stderr.strip().splitlines()[-1] == ex.stderr.strip().splitlines()[-1]
            assert not out.exists()
        else:
            assert run.exit_code == 0 or (run.exit_code == 1 and "unphysical" in run.stderr), run.stderr
            event(f"run exit {run.exit_code}")
            assert (out / "summary.json").is_file()
