"""whisker.sensing.locate_live: a sweep inside the live frame loop (`whisker live --locate`), on the
simulator with a rod contact at a known distance (whisker.drive.simulated.Contact r_mm)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from whisker.design import default_design
from whisker.drive.simulated import Contact, SimBackend, SimClock
from whisker.sensing import locate as L
from whisker.sensing.locate_live import LiveLocator

DESIGN = default_design()
FPS = 30.0


def _run(contacts, frames, locator):
    """Sim clock -> backend -> rendered frames -> fit tracker -> states -> locator (as `whisker live`)."""
    from whisker.data.recording import SimCamera
    from whisker.sensing.live import LivePipeline
    from whisker.sensing.states import make_estimator
    from whisker.vision.tracking import Tracker

    clk = SimClock(0.005)
    backend = SimBackend(DESIGN, clock=clk)
    for c in contacts:
        backend.add_contact(c)
    cam = SimCamera(DESIGN, backend, fps=FPS, count=frames, clock=clk, sleep=clk.sleep, noise_sigma=2.0)
    it = iter(cam)
    tracker = Tracker(DESIGN, "fit")
    tracker.calibrate([next(it) for _ in range(5)])
    pipe = LivePipeline(tracker, make_estimator("adaptive", tracker.n))
    out = []
    for frame in it:
        rec = locator.update(pipe.step(frame), tracker)
        if rec is not None:
            out.append(rec)
        lv = locator.next_levels()
        backend.set_levels(np.zeros(DESIGN.whiskers.count) if lv is None else lv)
    end = locator.finish()
    return out + ([end] if end else [])


def test_live_sweep_locates_a_rod_contact():
    """Object 30 mm along whisker 0's rod, pushed to -2 deg: the sweep (60 rendered, tracked frames)
    gives the distance within a loose bound, and the coil is off after it."""
    loc = LiveLocator(DESIGN, fps=FPS)
    recs = _run([Contact(0, 0.5, 100.0, -2.0, r_mm=30.0)], 5 + 40 + len(loc.lev_plan), loc)
    assert len(recs) == 1 and recs[0]["whisker"] == 0, recs
    assert recs[0]["status"] == "ok", recs[0]["message"]
    assert abs(recs[0]["distance_mm"] - 30.0) < 10.0, recs[0]
    assert loc.next_levels() is None


def test_live_without_contact_says_no_contact():
    loc = LiveLocator(DESIGN, fps=FPS)
    recs = _run([], 5 + 20, loc)
    assert [r["status"] for r in recs] == ["no contact"] and recs[0]["distance_mm"] is None


def test_live_locator_refuses_a_sweep_past_the_thermal_limit():
    with pytest.raises(L.LocateError, match="thermal guard"):
        LiveLocator(DESIGN, amplitude=1.0, duration_s=10.0)


def test_contact_distance_parsing_and_range():
    assert Contact.parse("0:2-4:-5@30").r_mm == 30.0 and Contact.parse("0:2-4:5").r_mm is None
    for bad in ("0:2-4:5@", "0:2-4:5@-3", "0:2-4:5@x"):
        with pytest.raises(ValueError, match="MM"):
            Contact.parse(bad)
    with pytest.raises(ValueError, match="beyond the rod"):
        SimBackend(DESIGN).add_contact(Contact(0, 0, 1, -2, r_mm=10 * DESIGN.whiskers.protrusion))


def test_cli_live_locate_refusals():
    res = run_cli("live", "--source", "synthetic:3", "--locate")
    assert res.returncode == 2 and "--source sim" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    res = run_cli("live", "--source", "sim", "--locate", "--sweep-duration", "30")
    assert res.returncode == 2 and "thermal guard" in res.stderr
    res = run_cli("live", "--source", "sim", "--sweep-level", "0.5")
    assert res.returncode == 2 and "go with --locate" in res.stderr


def test_closed_loop_grasp_reports_where_the_object_sits():
    """One simulated closed-loop grasp with locate: per holding whisker the estimated distance along
    the rod (locate sweep on the membrane + beam model at MuJoCo's true contact) and the truth."""
    pytest.importorskip("mujoco", reason="the grasp scene needs the simulator extra (pip install -e '.[sim]')")
    from pathlib import Path

    from whisker.sim import load_scene, scene_design
    from whisker.sim.experiments import grasp_locate
    from whisker.sim.experiments.grasp_closed import closed_loop_table
    from whisker.sim.experiments.paper import configurations

    scene = load_scene(Path(grasp_locate.__file__).resolve().parents[1] / "scenes" / "grasp.toml")
    design = scene_design(scene)
    noise = np.random.default_rng(0).normal(0.0, 7e-5, (200, 2))        # ~ the fit tracker's tilt error, rad
    tab = closed_loop_table(scene, design, attempts=1, configs=[c for c in configurations(scene, design) if len(c) == 8],
                            objects=["paper flower"], locate_noise=noise)
    closed = [r for r in tab["runs"] if r["mode"] == "closed"][0]
    assert [r["locate"] for r in tab["runs"] if r["mode"] == "open"] == [""]
    cells = closed["locate"].split("; ")
    assert closed["success"] and len(cells) >= 4, closed
    for cell in cells:                                        # "w3 62.5+-1.3 (63.0)"
        est, truth = float(cell.split()[1].split("+-")[0]), float(cell.split("(")[1].rstrip(")"))
        assert abs(est - truth) < 5.0, cell


def test_cli_closedloop_locate_is_for_the_simulator(tmp_path):
    from click.testing import CliRunner

    from whisker.cli import main

    r = CliRunner().invoke(main, ["closedloop", "--backend", "mock", "--locate", "--source", str(tmp_path)])
    assert r.exit_code == 2 and "--locate is for --backend sim" in r.output
