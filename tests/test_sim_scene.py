"""Scene model, effect graph, --explain and pruning (issue 8, step a)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import _sim_doubles
from conftest import ROOT, run_cli

_sim_doubles.install()

from whisker.design import default_design  # noqa: E402
from whisker.sim import SceneError, load_scene, plan, scene_from_dict, simulate  # noqa: E402

SCENES = ROOT / "software" / "whisker" / "sim" / "scenes"


def scene(**sections):
    return scene_from_dict(sections)


BALL = {"name": "ball", "shape": "sphere", "size": [7.5], "mass": 0.15, "friction": 0.6, "pos": [0, 0]}


def test_example_scenes_load_and_plan():
    d = default_design()
    files = sorted(SCENES.glob("*.toml"))
    assert len(files) >= 2
    for f in files:
        s = load_scene(f)
        p = plan(s, d)
        assert p.built("kinematics") and p.solver in ("static", "free", "mujoco"), f.name


@pytest.mark.parametrize("data, words", [
    ({"scene": {"duration": -1}}, "scene.duration"),
    ({"scene": {"bogus": 1}}, "scene.bogus"),
    ({"sensor": {"path": [[0, 0, 0, 10]]}}, "waypoint 0"),
    ({"sensor": {"path": [[1, 0, 0, 10, 0], [0.5, 0, 0, 5, 0]]}}, "increase"),
    ({"objects": [{**BALL, "size": [1, 2]}]}, "needs 1 size"),
    ({"objects": [{**BALL, "mass": 0}]}, "objects.0.mass"),
    ({"objects": [BALL, BALL]}, "unique"),
    ({"actuation": {"schedule": [{"t": 1, "level": 2}]}}, "level"),
    ({"actuation": {"schedule": [{"t": 1, "level": float("nan")}]}}, "level"),
    ({"actuation": {"schedule": [{"t": 1, "level": 1}, {"t": 0.5, "level": 0}]}}, "time order"),
    ({"experiment": {"kind": "grasp", "objects": ["nothing"]}}, "nothing"),
    ({"actuation": {"voltage": 3.0}}, "drive.full_scale_voltage=3"),
])
def test_bad_scenes_refused_in_one_line(data, words):
    with pytest.raises(SceneError) as err:
        scene_from_dict(data)
    msg = str(err.value)
    assert words in msg and "\n" not in msg


def test_missing_and_broken_files(tmp_path):
    with pytest.raises(SceneError, match="does not exist"):
        load_scene(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[scene\nname=")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(bad)


def test_whisker_index_out_of_range_refused():
    s = scene(scene={"duration": 0.01}, actuation={"schedule": [{"t": 0, "level": 1, "whiskers": [9]}]})
    with pytest.raises(SceneError, match="whisker 9"):
        simulate(s, default_design())


def test_no_objects_builds_no_contact_and_no_actuation_no_magnetics():
    d = default_design()
    p = plan(scene(scene={"duration": 0.1}), d)
    assert not p.built("contact") and "no objects" in p.effect("contact").reason
    assert not p.built("magnetics") and "no actuation" in p.effect("magnetics").reason
    assert not p.built("heating") and not p.built("camera")
    p2 = plan(scene(scene={"duration": 0.5}, objects=[BALL],
                    sensor={"path": [[0, 0, 0, 20, 0], [0.5, 0, 0, 2, 0]]},
                    actuation={"schedule": [{"t": 0.2, "level": 1}]}), d)
    assert p2.built("contact") and p2.built("magnetics") and p2.built("motion") and p2.solver == "mujoco"


def test_object_out_of_reach_is_said_and_pruned():
    d = default_design()
    far = {**BALL, "pos": [200.0, 0.0]}
    p = plan(scene(scene={"duration": 0.1}, objects=[far]), d)
    assert not p.built("contact") and "out of reach" in p.effect("contact").reason
    high = plan(scene(scene={"duration": 0.1}, objects=[BALL], sensor={"path": [[0, 0, 0, 60, 0]]}), d)
    assert not high.built("contact")


def test_static_solver_only_when_nothing_moves():
    d = default_design()
    assert plan(scene(actuation={"schedule": [{"t": 0, "level": 0.5}]}), d).solver == "static"
    assert plan(scene(scene={"duration": 0.2}, actuation={"schedule": [{"t": 0.1, "level": 0.5}]}), d).solver == "free"
    with pytest.raises(SceneError, match="static"):
        plan(scene(scene={"duration": 0.2}, fidelity={"solver": "static"},
                   actuation={"schedule": [{"t": 0.1, "level": 0.5}]}), d)


def test_explain_cli_subprocess_lists_effects_with_reasons(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[scene]\nname = "quiet"\nduration = 0.1\n')
    res = run_cli("sim", str(f), "--explain")
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "skipped contact" in out and "no objects" in out
    assert "skipped magnetics" in out and "no actuation" in out
    assert "built   kinematics" in out
    js = run_cli("sim", str(f), "--explain", "--json")
    d = json.loads(js.stdout)
    assert {e["name"] for e in d["effects"] if not e["built"]} >= {"contact", "magnetics", "camera"}


def test_cli_refuses_bad_scene_in_one_line(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[scene]\nduration = "long"\n')
    res = run_cli("sim", str(f), "--explain")
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "scene.duration" in res.stderr


def test_pruned_magnetics_equals_full_when_no_drive():
    """Magnetics skipped (no drive) vs built with every level 0: identical trajectories."""
    d = default_design()
    base = scene(scene={"duration": 0.3, "timestep": 1e-3, "initial_tilt_deg": 5.0}, sensor={"facing": "up"})
    pruned = plan(base, d)
    assert not pruned.built("magnetics") and pruned.solver == "free"
    # the full model: magnetics built (a schedule of zeros still counts as no drive, so force it)
    from whisker.sim.effects.plan import Effect, Plan
    full = Plan(effects=tuple(Effect(e.name, True if e.name == "magnetics" else e.built, e.reason)
                              for e in pruned.effects), solver="free")
    a = simulate(base, d, pruned)
    b = simulate(base, d, full)
    assert np.ptp(a.theta_rad[:, 0, 0]) > math.radians(4)  # the pluck really rings
    np.testing.assert_allclose(a.theta_rad, b.theta_rad, rtol=0, atol=1e-15)


def test_run_folder_written(tmp_path):
    from click.testing import CliRunner

    from whisker.commands.sensor.sim import cli

    out = tmp_path / "run"
    r = CliRunner().invoke(cli, [str(SCENES / "step_response.toml"), "--out", str(out), "-q"])
    assert r.exit_code == 0, r.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["solver"] == "free" and "magnetics" in summary["effects"]
    assert (out / "tracks.csv").read_text().count("\n") > 8 * 100
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging left behind


def test_object_parts_share_mass_by_volume_and_rest_on_the_table():
    o = scene_from_dict({"objects": [{"name": "lumpy", "shape": "sphere", "size": [4.0], "mass": 1.0,
                                      "parts": [{"shape": "sphere", "size": [4.0], "pos": [6.0, 0.0, -2.0]}]}]}).objects[0]
    g = o.geoms()
    assert [round(x[3], 12) for x in g] == [0.5, 0.5] and math.isclose(sum(x[3] for x in g), 1.0)
    assert o.half_height == 6.0                        # the part's bottom (z -2 - 4) sets the rest height
    assert o.bounding_radius == pytest.approx(math.hypot(6, 2) + 4)
    with pytest.raises(SceneError, match="part sphere"):
        scene_from_dict({"objects": [{"name": "bad", "size": [1.0], "mass": 1.0,
                                      "parts": [{"shape": "sphere", "size": [0.0]}]}]})


def test_level_one_is_the_full_scale_coil_voltage():
    """A level is a fraction of whisker.drive.guard.full_scale_voltage(design) in a scene and in the backend."""
    guard = pytest.importorskip("whisker.drive.guard", reason="whisker.drive.guard (issue 7) not installed")
    from whisker.sim.contract import current_A
    from whisker.coil.kinematics import static_equilibrium, whisker_body

    for d in (default_design(), default_design("drive.full_scale_voltage=1.5")):
        vfs = guard.full_scale_voltage(d)
        s = scene_from_dict({"actuation": {"schedule": [{"t": 0.0, "level": 0.5}]}, "sensor": {"facing": "down"}})
        got = simulate(s, d).theta_deg[0, 0, 0]
        want = static_equilibrium(d, whisker_body(d), current_A(d, np.array([0.5 * vfs])), facing="down").theta_rad[0]
        assert got == pytest.approx(math.degrees(want), abs=1e-9)
    assert guard.full_scale_voltage(default_design("drive.full_scale_voltage=1.5")) == 1.5
    from whisker.sim import actuation_backend
    assert actuation_backend(d).volts_full_scale == pytest.approx(guard.full_scale_voltage(d))


def test_camera_tracks_with_roi_unless_the_scene_asks():
    assert scene_from_dict({"camera": {"enabled": True}}).camera.method == "roi"
    assert scene_from_dict({"camera": {"enabled": True, "method": "paper"}}).camera.method == "paper"


def test_objects_from_shares_one_definition_of_the_paper_objects(tmp_path):
    from whisker.sim import load_scene

    scenes = ROOT / "software" / "whisker" / "sim" / "scenes"
    grasp, disp = load_scene(scenes / "grasp.toml"), load_scene(scenes / "displacement.toml")
    g = {o.name: o for o in grasp.objects}
    assert len(g) == 5 and all(g[o.name] == o for o in disp.objects)       # the same objects, not copies
    assert disp.experiment.objects == ["foam ball", "mini pinecone"]
    # a scene adds its own objects after the shared ones; a bad reference is refused in one line
    (tmp_path / "objs.toml").write_text('[[objects]]\nname = "a"\nshape = "sphere"\nsize = [5.0]\nmass = 1.0\n')
    (tmp_path / "s.toml").write_text('objects_from = "objs.toml"\n[[objects]]\nname = "b"\nshape = "sphere"\n'
                                     'size = [4.0]\nmass = 0.5\n')
    assert [o.name for o in load_scene(tmp_path / "s.toml").objects] == ["a", "b"]
    (tmp_path / "bad.toml").write_text('objects_from = "missing.toml"\n')
    with pytest.raises(SceneError, match="objects_from: no such file"):
        load_scene(tmp_path / "bad.toml")
    (tmp_path / "empty.toml").write_text('x = 1\n')
    (tmp_path / "e.toml").write_text('objects_from = "empty.toml"\n')
    with pytest.raises(SceneError, match="has no"):
        load_scene(tmp_path / "e.toml")
