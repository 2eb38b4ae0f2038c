"""The closed-loop grasp on the hardware path (whisker.sensing.rig): the simulator's camera frames written to a
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

from whisker.sensing.grasp_control import GraspController
from whisker.drive.guard import ThermalGuard

FPS = 15.0
REST = 5


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A closed-loop grasp of the foam ball in MuJoCo (sim path: rendered camera -> tracker -> controller),
    its frames written to a folder (PNG + times.csv) and the commands it gave. The ball is the lightest
    object and the one the paper's protocol always holds with 8 whiskers. It holds only while the coils
    stay above ~0.8 of the paper's level through the lift: with the guard derating from 40 C (a 10 K
    band) it dropped and the recording used the pom-pom; from 45 C (drive.guard_derate_band = 5) it
    holds, which the replay test below asserts."""
    pytest.importorskip("mujoco", reason="MuJoCo (the `sim` extra) renders the recorded grasp")
    import cv2

    from conftest import ROOT
    from whisker.sim import load_scene, scene_design
    from whisker.sim.experiments.closed_loop import SimGraspRig, free_closing_px
    from whisker.sim.experiments.paper import Placement, experiment_objects
    from whisker.vision.tracking import Tracker

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


def _hardware(rec, folder=None, *, log=None, guard_C=None, watchdog_s=30.0, on_frame=None, source=None, arm=None):
    from whisker.drive.actuation import Actuator
    from whisker.drive.hbridge import mock_backend
    from whisker.vision.camera import FolderSource
    from whisker.sensing.rig import HandHeldArm, HardwareRig
    from whisker.vision.tracking import Tracker

    design = rec["design"]
    backend = mock_backend(design)
    act = Actuator(design, backend, guard=ThermalGuard(design, initial_C=guard_C), watchdog=False)
    ctl = GraspController(8, range(8), rec["params"], rec["expected"], guard=ThermalGuard(design, clock=lambda: 0.0))
    prompts = []
    src = source if source is not None else FolderSource(folder or rec["folder"], fps=FPS)
    rig = HardwareRig(design, src, Tracker(design, "roi"), act, ctl, arm=arm or HandHeldArm(echo=prompts.append),
                      log=log, rest_frames=REST, watchdog_s=watchdog_s, on_frame=on_frame)
    try:
        res = rig.run()
    finally:
        act.close()
    return res, backend, prompts


def _derate_slope_per_s(design, level):
    """Upper bound of how fast the guard lowers `level` (per s) inside its derate band: the coil's
    heating rate at the band's start, at that level, over the band's width (whisker.drive.guard)."""
    g = ThermalGuard(design, clock=lambda: 0.0)
    g.temperatures[:] = g.derate_from_C
    dt = 0.01
    rate_K_s = float(np.max(g.predict(np.full(g.n, level), dt) - g.derate_from_C)) / dt
    return level * rate_K_s / (g.cut_C - g.derate_from_C)


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


def _copy(rec, tmp_path):
    dst = tmp_path / "frames"
    shutil.copytree(rec["folder"], dst)
    return dst


def _frame_of(rec, phase, k=0):
    """File index of the k-th frame the sim controller answered with `phase`."""
    idx = [i for i, c in enumerate(rec["commands"]) if c[1] == phase]
    return REST + idx[k]


def _assert_safe_abort(res, backend, log, words):
    assert res.phase == "abort" and res.exit_code != 0, (res.phase, res.reason)
    assert words in res.reason, res.reason
    assert np.all(_pins(backend) == 0)                   # every H-bridge input low
    last = json.loads(log.read_text().splitlines()[-1])
    assert last["phase"] == "abort" and words in last["reason"]


def test_lost_marker_in_the_lift_turns_every_coil_off(recording, tmp_path):
    import cv2

    from whisker.vision.tracking import Tracker

    folder = _copy(recording, tmp_path)
    files = sorted(folder.glob("*.png"))
    trk = Tracker(recording["design"], "roi")
    trk.calibrate([cv2.imread(str(f)) for f in files[:REST]])
    k = _frame_of(recording, "lift", 1)
    for f in files[k:k + 2]:                             # marker 2 covered for two frames
        img = cv2.imread(str(f))
        pos = trk.track(img).positions_px[2]
        bg = [int(v) for v in np.median(img.reshape(-1, 3), axis=0)]
        cv2.circle(img, (int(round(pos[0])), int(round(pos[1]))), int(3 * trk.marker_r) + 2, bg, -1)
        cv2.imwrite(str(f), img)
    log = tmp_path / "lost.jsonl"
    res, backend, _ = _hardware(recording, folder, log=log)
    _assert_safe_abort(res, backend, log, "whisker 2 lost")
    assert res.commands[-1][0] == recording["commands"][k - REST + 1][0]     # on the second covered frame


def test_dropped_frames_turn_every_coil_off(recording, tmp_path):
    folder = _copy(recording, tmp_path)
    k = _frame_of(recording, "lift", 1)
    for f in sorted(folder.glob("*.png"))[k:k + 2]:      # two frames never arrive (times.csv keeps the others')
        f.unlink()
    log = tmp_path / "dropped.jsonl"
    res, backend, _ = _hardware(recording, folder, log=log)
    _assert_safe_abort(res, backend, log, "dropped frames")


def test_contact_before_actuation_never_drives_a_coil(recording, tmp_path):
    folder = _copy(recording, tmp_path)
    files = sorted(folder.glob("*.png"))
    late = _frame_of(recording, "lift", 0)               # whiskers closed on the ball
    first = _frame_of(recording, "descend", 3)           # after the rest statistics are learned
    for j, f in enumerate(files[first:_frame_of(recording, "close", 0)]):
        shutil.copyfile(files[late], f)                  # displaced whiskers while the coils are still off
    driven = []
    log = tmp_path / "early.jsonl"
    res, backend, _ = _hardware(recording, folder, log=log,
                                on_frame=lambda rig, cmd, rec: driven.append(_pins(rig.actuator.backend).max()))
    _assert_safe_abort(res, backend, log, "contact before actuation")
    assert max(driven) == 0.0                            # no coil was ever energised


def test_thermal_cut_turns_every_coil_off(recording, tmp_path):
    log = tmp_path / "hot.jsonl"
    res, backend, _ = _hardware(recording, log=log, guard_C=300.0)     # the actuator's guard: far too hot
    _assert_safe_abort(res, backend, log, "thermal guard cut coil")
    levels = [c[2] for c in res.commands]
    assert np.all(levels[-1] > 0) and all(np.all(lv == 0) for lv in levels[:-1])   # at the first request


def test_a_stalled_camera_turns_the_coils_off_without_waiting_for_a_frame(recording, tmp_path):
    from whisker.vision.camera import FolderSource

    k = _frame_of(recording, "close", 1)
    during = []

    class Stalling(FolderSource):
        def __iter__(self):
            for f in super().__iter__():
                if f.index == k:
                    before = _pins(self.backend).max()
                    time.sleep(1.0)                      # the camera hangs for 1 s (watchdog 0.2 s)
                    during.append((before, _pins(self.backend).max()))
                yield f

    src = Stalling(recording["folder"], fps=FPS)
    log = tmp_path / "stall.jsonl"

    def grab_backend(rig, cmd, rec):
        src.backend = rig.actuator.backend
    res, backend, _ = _hardware(recording, log=log, watchdog_s=0.2, source=src, on_frame=grab_backend)
    assert during and during[0][0] > 0 and during[0][1] == 0     # driven before the stall, off during it
    _assert_safe_abort(res, backend, log, "no camera frame")


def test_a_camera_that_ends_early_turns_the_coils_off(recording, tmp_path):
    folder = _copy(recording, tmp_path)
    for f in sorted(folder.glob("*.png"))[_frame_of(recording, "lift", 0):]:
        f.unlink()
    log = tmp_path / "short.jsonl"
    res, backend, _ = _hardware(recording, folder, log=log)
    _assert_safe_abort(res, backend, log, "camera stopped")


def test_cli_replays_a_recording_on_mock_pins(recording, tmp_path):
    from click.testing import CliRunner

    from whisker.cli import main

    log = tmp_path / "cli.jsonl"
    r = CliRunner().invoke(main, ["closedloop", "--backend", "mock", "--source", str(recording["folder"]), "--log",
                                  str(log), "--descend-mm", "15", "--descend-s", "0.3", "--lift-mm", "30",
                                  "--lift-s", "0.5", "--hold-s", "0.4", "-q"])
    assert r.exit_code == 0, r.output
    lines = [json.loads(s) for s in log.read_text().splitlines()]
    assert lines[-1]["phase"] == "done" and any(x["phase"] == "lift" for x in lines)
    folder = _copy(recording, tmp_path)
    for f in sorted(folder.glob("*.png"))[_frame_of(recording, "lift", 1):][:3]:
        f.unlink()
    r = CliRunner().invoke(main, ["closedloop", "--backend", "mock", "--source", str(folder), "--log",
                                  str(tmp_path / "cli2.jsonl"), "--descend-s", "0.3", "-q"])
    assert r.exit_code == 1 and "ABORT" in r.output and "dropped frames" in r.output


def test_cli_refuses_options_of_the_other_backend(tmp_path):
    from click.testing import CliRunner

    from whisker.cli import main

    r = CliRunner().invoke(main, ["closedloop", "--source", "picamera"])
    assert r.exit_code == 2 and "is for --backend mock or gpio" in r.output
    r = CliRunner().invoke(main, ["closedloop", "--backend", "mock", "--attempts", "3", "--source", str(tmp_path)])
    assert r.exit_code == 2 and "--attempts is for --backend sim" in r.output
    r = CliRunner().invoke(main, ["closedloop", "--backend", "mock"])
    assert r.exit_code == 2 and "needs --source" in r.output


def test_a_lossless_video_of_the_recording_replays_to_the_same_decisions(recording, tmp_path):
    import cv2

    from whisker.vision.camera import VideoSource

    files = sorted(recording["folder"].glob("*.png"))
    times = [float(r["time_s"]) for r in csv.DictReader(open(recording["folder"] / "times.csv"))]
    period = (times[-1] - times[0]) / (len(times) - 1)
    path = tmp_path / "grasp.mkv"
    first = cv2.imread(str(files[0]))
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 1.0 / period, (first.shape[1], first.shape[0]))
    if not w.isOpened():
        pytest.skip("this OpenCV build has no FFV1 (lossless) video writer")
    for f in files:
        w.write(cv2.imread(str(f)))
    w.release()
    src = VideoSource(str(path))
    res, backend, _ = _hardware(recording, source=src)
    src.close()
    sim = recording["commands"]        # the container stores the frame rate as a rational: times agree to 1 ms
    tol = 1e-3 * _derate_slope_per_s(recording["design"], max(float(np.max(np.abs(c[2]))) for c in sim))
    assert res.phase == "done" and len(res.commands) == len(sim)
    for (t_s, ph_s, lv_s, v_s), (t_h, ph_h, lv_h, v_h) in zip(sim, res.commands):
        assert t_h == pytest.approx(t_s, abs=1e-3) and ph_h == ph_s and v_h == pytest.approx(v_s)
        # the guard integrates the coil temperature on these times: within its derate band the level
        # moves (heating rate / band) per s, so 1 ms of time shifts it by at most that much (exact
        # when not derating)
        assert np.allclose(lv_h, lv_s, rtol=0, atol=tol)
    assert np.all(_pins(backend) == 0)


def test_folder_times_csv_is_checked(tmp_path):
    import cv2

    from whisker.vision.camera import FolderSource, SourceError

    for i in range(3):
        cv2.imwrite(str(tmp_path / f"f{i}.png"), np.zeros((8, 8, 3), np.uint8))
    (tmp_path / "times.csv").write_text("file,time_s\nf0.png,0\nf1.png,0.1\nf2.png,0.5\n")
    assert [f.time_s for f in FolderSource(tmp_path)] == [0.0, 0.1, 0.5]       # the gap is kept
    (tmp_path / "times.csv").write_text("file,time_s\nf0.png,0\nf1.png,0.1\n")
    with pytest.raises(SourceError, match="no time for f2.png"):
        FolderSource(tmp_path)
    (tmp_path / "times.csv").write_text("file,time_s\nf0.png,0\nf1.png,0.1\nf2.png,0.05\n")
    with pytest.raises(SourceError, match="increase"):
        FolderSource(tmp_path)
    (tmp_path / "times.csv").write_text("name,t\nf0.png,0\n")
    with pytest.raises(SourceError, match="columns file,time_s"):
        FolderSource(tmp_path)


def test_ctrl_c_turns_the_coils_off_and_finalises_the_log(recording, tmp_path):
    def interrupt(rig, cmd, rec):
        if rec["phase"] == "lift":
            raise KeyboardInterrupt
    log = tmp_path / "int.jsonl"
    with pytest.raises(KeyboardInterrupt):
        _hardware(recording, log=log, on_frame=interrupt)
    lines = [json.loads(s) for s in log.read_text().splitlines()]
    assert lines[-2]["phase"] == "lift" and lines[-1] == {"frame": None, "phase": "abort",
                                                           "reason": "interrupted (Ctrl-C)"}
    assert any("whiskers hold" in x["reason"] for x in lines)      # the frame's event is its reason


class RecordingArm:
    """An `Arm` as a robot driver would implement it: it records what it was told."""

    def __init__(self):
        self.velocities, self.stops = [], 0

    def command(self, velocity_mm_s, phase):
        self.velocities.append((phase, velocity_mm_s))

    def stop(self):
        self.stops += 1


def test_a_robot_arm_gets_the_controllers_velocities_and_a_stop(recording, tmp_path):
    arm = RecordingArm()
    res, _, _ = _hardware(recording, arm=arm)
    sim = [(c[1], c[3]) for c in recording["commands"]]
    assert res.phase == "done" and arm.velocities == sim
    assert any(v > 0 for ph, v in arm.velocities if ph == "lift") and any(v < 0 for ph, v in arm.velocities)
    folder = _copy(recording, tmp_path)
    for f in sorted(folder.glob("*.png"))[_frame_of(recording, "lift", 1):][:3]:
        f.unlink()
    arm = RecordingArm()
    res, _, _ = _hardware(recording, folder, arm=arm)
    assert res.phase == "abort" and arm.stops >= 1 and arm.velocities[-1][0] == "lift"   # stopped, not told to move
