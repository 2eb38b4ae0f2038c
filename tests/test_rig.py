"""The closed-loop grasp on the hardware path (whisker.rig): the simulator's camera frames written to a
folder and replayed through tracker -> GraspController -> Actuator on gpiozero's MockFactory pins.
The hardware path runs the same controller code as the sim path and must take the same decisions on
the same frames; every fail-safe stop leaves every pin low."""

from __future__ import annotations

import csv
import json
import shutil
import time

import numpy as np
import pytest

from whisker.grasp_control import GraspController
from whisker.guard import ThermalGuard

FPS = 15.0
REST = 5


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A closed-loop grasp of the foam ball in MuJoCo (sim path: rendered camera -> tracker -> controller),
    its frames written to a folder (PNG + times.csv) and the commands it gave."""
    pytest.importorskip("mujoco", reason="MuJoCo (the `sim` extra) renders the recorded grasp")
    import cv2

    from conftest import ROOT
    from whisker.sim import load_scene, scene_design
    from whisker.sim.closed_loop import SimGraspRig, free_closing_px
    from whisker.sim.paper import Placement, experiment_objects
    from whisker.tracking import Tracker

    scene = load_scene(ROOT / "software/whisker/sim/scenes/grasp.toml")
    design = scene_design(scene)
    obj = {o.name: o for o in experiment_objects(scene)}["foam ball"]
    expected = free_closing_px(design)
    rig = SimGraspRig(scene, design, obj, list(range(8)), Placement(), fps=FPS)
    folder = tmp_path_factory.mktemp("grasp_frames")
    times = []

    def save(t, img):
        name = f"frame_{len(times):04d}.png"
        cv2.imwrite(str(folder / name), img)
        times.append((name, repr(float(t))))

    tracker = Tracker(design, "roi")
    rest = []
    for _ in range(REST):                                 # coils off, arm still: the rest baseline
        t, img = rig.frame()
        save(t, img)
        rest.append(img)
        rig.advance(np.zeros(8), 0.0)
    tracker.calibrate(rest)
    params = rig.params()
    ctl = GraspController(8, range(8), params, expected, guard=ThermalGuard(design, clock=lambda: 0.0))
    cmds = []
    while rig.t < 6.0:
        t, img = rig.frame()
        save(t, img)
        res = tracker.track(img)
        cmd = ctl.step(t, res.dx_px, res.dy_px, res.valid)
        cmds.append((t, cmd.phase, cmd.levels.copy(), cmd.arm_mm_s))
        rig.advance(cmd.levels, cmd.arm_mm_s)
        if cmd.phase in ("done", "abort"):
            break
    with open(folder / "times.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["file", "time_s"])
        w.writerows(times)
    return {"design": design, "folder": folder, "params": params, "expected": expected, "commands": cmds,
            "events": list(ctl.log.events), "lifted": rig.lift_mm()}


def _hardware(rec, folder=None, *, log=None, guard_C=None, watchdog_s=30.0, on_frame=None, source=None):
    from whisker.actuation import Actuator, mock_backend
    from whisker.camera import FolderSource
    from whisker.rig import HandHeldArm, HardwareRig
    from whisker.tracking import Tracker

    design = rec["design"]
    backend = mock_backend(design)
    act = Actuator(design, backend, guard=ThermalGuard(design, initial_C=guard_C), watchdog=False)
    ctl = GraspController(8, range(8), rec["params"], rec["expected"], guard=ThermalGuard(design, clock=lambda: 0.0))
    prompts = []
    src = source if source is not None else FolderSource(folder or rec["folder"], fps=FPS)
    rig = HardwareRig(design, src, Tracker(design, "roi"), act, ctl, arm=HandHeldArm(echo=prompts.append),
                      log=log, rest_frames=REST, watchdog_s=watchdog_s, on_frame=on_frame)
    res = rig.run()
    act.close()
    return res, backend, prompts


def _pins(backend):
    """(forward, backward) duty of every coil read from the mock pins themselves."""
    f = backend.factory
    return np.array([[f.pin(c.forward).state, f.pin(c.backward).state] for c in backend.channels], dtype=float)


def test_replay_gives_the_sim_paths_decisions_and_drives_the_bridges_forward(recording, tmp_path):
    seen = []

    def on_frame(rig, cmd, rec):
        seen.append((rec["phase"], _pins(rig.actuator.backend), rig.actuator.applied.copy()))

    log = tmp_path / "grasp.jsonl"
    res, backend, prompts = _hardware(recording, log=log, on_frame=on_frame)
    sim = recording["commands"]
    assert sim[-1][1] == "done" and recording["lifted"] > 5.0, recording["events"]     # the sim grasp held
    assert res.phase == "done" and res.exit_code == 0, res.reason
    assert len(res.commands) == len(sim)
    for (t_s, ph_s, lv_s, v_s), (t_h, ph_h, lv_h, v_h) in zip(sim, res.commands):
        assert (t_h, ph_h, v_h) == (t_s, ph_s, v_s)
        assert np.array_equal(lv_h, lv_s)
    # H-bridge directions: a retracting level is duty on IN1 (forward) with IN2 low, never both
    closing = [s for s in seen if s[0] in ("close", "tighten", "lift", "hold")]
    assert closing
    for _, pins, applied in closing:
        assert np.allclose(pins[:, 0], applied, atol=1e-6) and np.all(pins[:, 1] == 0)
        assert np.all(applied > 0)
    assert np.all(_pins(backend) == 0)                   # released: every input low
    lines = [json.loads(s) for s in log.read_text().splitlines()]
    assert len(lines) == res.frames and [r["phase"] for r in lines] == [c[1] for c in sim]
    assert {"levels", "applied", "states", "reason", "force_mN", "direction_deg"} <= set(lines[0])
    assert not list(tmp_path.glob(".grasp.jsonl.*"))     # finalised: no temporary file left
    assert any("lift" in p for p in prompts) and any("lower" in p for p in prompts)
