"""Camera effect end to end: scene -> rendered frames -> tracker -> geometry vs ground truth (step d)."""

from __future__ import annotations

import numpy as np
import pytest

import _sim_doubles
from conftest import peer_data

_sim_doubles.install()
pytest.importorskip("whisker.vision.render", reason="whisker.vision.render (issue 6) not installed")
pytest.importorskip("whisker.vision.tracking", reason="whisker.vision.tracking (issue 6) not installed")
pytest.importorskip("cv2", reason="OpenCV is needed by the renderer and the tracker")

from whisker.design import default_design  # noqa: E402
from whisker.sim import plan, scene_from_dict, simulate  # noqa: E402
from whisker.sim.camera import camera_run  # noqa: E402

D = default_design("drive.full_scale_voltage=3.0")   # level 1 = 3 V at the coil


def _scene(method="roi", geometry="exact", **cam):
    return scene_from_dict({
        "scene": {"duration": 0.3, "timestep": 1e-3, "seed": 4}, "sensor": {"facing": "up"},
        "actuation": {"schedule": [{"t": 0.0, "level": 0.5, "whiskers": [0, 2, 4, 6]},
                                                   {"t": 0.0, "level": -0.8, "whiskers": [1, 3, 5, 7]}]},
        "camera": {"enabled": True, "fps": 20, "method": method, "geometry": geometry, **cam},
        "fidelity": {"heating": "off", "solver": "dynamic"}})


def test_end_to_end_tip_error_small_with_roi_tracker():
    s = _scene()
    p = plan(s, D)
    assert p.built("camera") and p.built("tracking")
    r = simulate(s, D, p)
    cr = camera_run(s, D, r)
    assert len(cr.t_s) == 7 and cr.valid.all()
    assert np.abs(cr.true_tip_mm).max() > 3.0               # the whiskers really moved (mm at the tips)
    assert cr.tip_rms_mm < 0.05 and cr.px_rms < 0.1


def test_end_to_end_paper_pipeline_loses_small_markers_roi_does_not():
    """The paper's pipeline (10x10 erosion) erodes small dots (docs/tracking.md): on the paper's
    1.2 mm dots (~12 px) it loses the markers and refuses its rest calibration, while roi keeps every
    one; on the calibrated 1.4 mm dots (~14 px) it keeps them, but tracks them far worse.

    The trackers are compared through the exact geometry (and in pixels): the paper's pixel-to-tip
    conversion has an error of its own that grows with the tilt, and with the end-stop design these
    drives take the whiskers to 10.7-11 deg, where that conversion alone is 0.32 mm off for a perfect
    tracker (roi: 0.014 px); through it both trackers' tip errors are dominated by the same geometry
    error (0.42 against 0.32 mm), which says nothing about the trackers (measured: 0.74 px against
    0.014 px, 0.175 mm against 0.012 mm at the tips)."""
    from whisker.vision.tracking import CalibrationError

    s = _scene(method="paper", geometry="paper")
    small = default_design("drive.full_scale_voltage=3.0", "coil.marker_diameter=1.2")
    r = simulate(s, small)
    assert camera_run(_scene(geometry="paper"), small, r).valid.mean() == 1.0
    with pytest.raises(CalibrationError, match="rest frame"):
        camera_run(s, small, r)
    r = simulate(s, D)
    roi = camera_run(_scene(), D, r)
    cr = camera_run(_scene(method="paper"), D, r)
    assert roi.valid.mean() == 1.0 and cr.valid.mean() > 0.9
    assert cr.px_rms > 10 * roi.px_rms and cr.tip_rms_mm > 5 * roi.tip_rms_mm
    # through the paper's geometry the shared conversion error dominates: still worse, not several times
    roi_p, cr_p = camera_run(_scene(geometry="paper"), D, r), camera_run(s, D, r)
    assert cr_p.tip_rms_mm > roi_p.tip_rms_mm > 10 * roi.tip_rms_mm


def test_camera_pruned_when_off_or_nothing_asked():
    s = _scene()
    off = s.with_(camera={**s.camera.model_dump(), "enabled": False})
    assert not plan(off, D).built("camera") and "camera off" in plan(off, D).effect("camera").reason
    none = s.with_(outputs={"tracks": False, "frames": False, "video": False})
    p = plan(none, D)
    assert not p.built("camera") and not p.built("tracking")


def test_frames_and_video_written_by_the_cli(tmp_path):
    from click.testing import CliRunner

    from whisker.commands.sensor.sim import cli

    f = tmp_path / "s.toml"
    f.write_text('[scene]\nname = "cam"\nduration = 0.2\ntimestep = 0.001\n[sensor]\nfacing = "up"\n'
                 '[actuation]\nschedule = [{ t = 0.05, level = 0.5 }]\n'
                 '[camera]\nenabled = true\nfps = 10\nmethod = "roi"\ngeometry = "exact"\n'
                 '[outputs]\nframes = true\nvideo = true\n')
    r = CliRunner().invoke(cli, [str(f), "--out", str(tmp_path / "run"), "-q"])
    assert r.exit_code == 0, r.output
    assert len(list((tmp_path / "run" / "frames").glob("frame_*.png"))) == 3
    assert (tmp_path / "run" / "video.mp4").stat().st_size > 1000
    assert "tip RMS error" in r.output


@pytest.mark.skipif(peer_data() is None, reason="WHISKER_PEER_DATA not set: the authors' lens calibration is not available")
def test_end_to_end_with_the_authors_lens_distortion():
    s = _scene(calibration=str(peer_data() / "img" / "calibration_data.npz"))
    cr = camera_run(s, D, simulate(s, D))
    assert cr.valid.mean() > 0.9 and cr.tip_rms_mm < 0.2
