"""`whisker calibrate camera` / `board`: lens calibration on ChArUco views rendered with a known lens."""

from __future__ import annotations

import re
import zlib

import numpy as np
import pytest

from conftest import run_cli
from whisker.bringup.charuco import (DEMO_LENS, MIN_VIEWS, CalibrationInputError, View, board_for, calibrate_views, detect,
                                 random_poses, render_board_view, synthetic_board_views)
from whisker.design import default_design
from whisker.vision.lens import Lens, load_lens, undistort_points
from whisker.vision.render import marker_pixels, render_frame
from whisker.vision.geometry import rest_marker_xyz
from whisker.vision.tracking import Tracker

D = default_design()
SIZE = (D.camera.width_px, D.camera.height_px)
# the truth: a fisheye lens near the authors' (f ~ 349 px), principal point off the image centre
TRUE = DEMO_LENS
POSES = 18


@pytest.fixture(scope="module")
def views_dir(tmp_path_factory):
    """18 JPEG views (noise 2 grey levels, blur, JPEG quality 85) of the design's board at random poses
    through the known fisheye lens, written as files: the command reads them as an image folder."""
    import cv2

    folder = tmp_path_factory.mktemp("board_views")
    for i, img in enumerate(synthetic_board_views(D, POSES)):
        assert img.shape == (SIZE[1], SIZE[0], 3)
        cv2.imwrite(str(folder / f"view_{i:02d}.png"), img)  # already JPEG-coded once
    return folder


@pytest.fixture(scope="module")
def calibrated(views_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("lens") / "lens.npz"
    res = run_cli("calibrate", "camera", "--source", str(views_dir), "--out", str(out), "-q")
    assert res.returncode == 0, res.stderr
    return out, res.stdout


def test_board_is_sized_for_the_design():
    spec = board_for(D)
    # squares of ~40 px at the marker plane, the board 1.3x the field of view there
    assert abs(spec.square_mm / D.mm_per_px - 40.0) < 1.0
    w, h = spec.size_mm
    assert w >= 1.3 * SIZE[0] * D.mm_per_px - 1e-9 and h >= 1.3 * SIZE[1] * D.mm_per_px - 1e-9
    assert spec.board().getChessboardSize() == (spec.squares_x, spec.squares_y)
    # a larger camera distance makes larger squares
    far = board_for(default_design("camera.distance=50"))
    assert far.square_mm > spec.square_mm


def test_recovers_focal_length_and_principal_point(calibrated):
    out, stdout = calibrated
    lens = load_lens(out)
    assert lens.image_size == SIZE
    f_err = np.abs(np.diag(lens.mtx)[:2] / np.diag(TRUE.mtx)[:2] - 1.0)
    assert np.all(f_err < 0.01), lens.mtx
    assert np.hypot(*(lens.mtx[:2, 2] - TRUE.mtx[:2, 2])) < 2.0, lens.mtx
    with np.load(out) as z:
        assert float(z["rms_px"]) < 0.5 and int(z["views"]) >= 15
    report = out.with_suffix(".report.json")
    import json

    rep = json.loads(report.read_text())
    # the true lens is a fisheye: the fisheye model fits the held-out views at least as well
    assert rep["model"] == lens.model
    held = rep["heldout_rms_px"]
    assert held[lens.model] == min(v for v in held.values() if v is not None)
    assert rep["mm_per_px"]["design"] == pytest.approx(D.mm_per_px)
    assert rep["mm_per_px"]["at_design_distance"] == pytest.approx(D.camera.distance / np.sqrt(352.0 * 350.6), rel=0.01)
    assert 100 < rep["field_of_view_deg"]["diagonal"] < 170
    assert out.with_suffix(".undistorted.png").stat().st_size > 1000
    assert "held-out RMS px" in stdout


def test_tracking_with_the_written_file_finds_the_true_marker_positions(calibrated):
    """Markers rendered through the TRUE fisheye lens; tracked and undistorted with the FITTED file:
    the marker's direction (normalized coordinates x f) is within 0.1 px of the truth."""
    out, _ = calibrated
    lens = load_lens(out)
    raw = marker_pixels(D, rest_marker_xyz(D), mtx=TRUE.mtx, dist=TRUE.dist, model="fisheye")
    frames = [render_frame(D, raw, seed=s, noise_sigma=1.0, blur_px=0.7) for s in range(3)]
    for method in ("roi", "fit"):
        trk = Tracker(D, method, calibration=out)
        trk.calibrate(frames)
        r = trk.track(frames[0])
        assert r.all_valid, r.status
        est = (r.positions_px - lens.mtx[:2, 2]) / np.diag(lens.mtx)[:2]     # normalized, fitted lens
        truth = undistort_points(TRUE, raw)                                  # normalized, true lens
        err_px = np.hypot(*((est - truth) * np.diag(TRUE.mtx)[:2]).T)
        assert err_px.max() < 0.1, (method, err_px)


def test_sim_camera_accepts_a_fisheye_file(calibrated):
    from whisker.sim.contract import load_calibration, marker_pixels as sim_pixels

    out, _ = calibrated
    mtx, dist, model = load_calibration(out)
    assert model == load_lens(out).model
    px = sim_pixels(D, rest_marker_xyz(D), mtx, dist, model)
    assert np.all(np.isfinite(px)) and px.shape == (D.whiskers.count, 2)


def test_too_few_views_one_line_and_the_old_file_kept(views_dir, tmp_path):
    import shutil

    few = tmp_path / "few"
    few.mkdir()
    for p in sorted(views_dir.iterdir())[:MIN_VIEWS - 3]:
        shutil.copy(p, few / p.name)
    (few / "broken.jpg").write_bytes(b"not an image")        # the camera returned nothing here
    out = tmp_path / "lens.npz"
    out.write_bytes(b"previous calibration")
    res = run_cli("calibrate", "camera", "--source", str(few), "--out", str(out), "-q")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "usable board view" in lines[0] and "Traceback" not in res.stderr, res.stderr
    assert out.read_bytes() == b"previous calibration"
    assert not (tmp_path / "lens.report.json").exists()


def test_blurred_and_partly_visible_boards_are_refused_with_a_reason():
    spec = board_for(D)
    rng = np.random.default_rng(3)
    (r, t), = random_poses(spec, 1, D.camera.distance, rng)
    blurred = render_board_view(spec, TRUE, r, t, SIZE, blur_px=6.0)
    why = detect(spec, blurred)
    assert isinstance(why, str) and ("blurred" in why or "partly" in why)
    # the board far to the side: a corner of it in the image
    from whisker.bringup.charuco import board_pose

    r2, t2 = board_pose(spec, D.camera.distance, 0.0, 0.0, 0.0, offset_mm=(75.0, 58.0))
    edge = render_board_view(spec, TRUE, r2, t2, SIZE)
    why = detect(spec, edge)
    assert isinstance(why, str) and ("partly" in why or "not found" in why), why
    assert isinstance(detect(spec, None), str)
    with pytest.raises(CalibrationInputError, match="usable board view"):
        calibrate_views([], SIZE, [("frame 0", why)])


def test_a_source_that_gives_nothing_is_refused_in_one_line(tmp_path):
    empty = tmp_path / "empty.avi"
    empty.write_bytes(b"")
    res = run_cli("calibrate", "camera", "--source", str(empty), "--out", str(tmp_path / "x.npz"), "-q")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert "cannot open" in res.stderr and not (tmp_path / "x.npz").exists()
    blank = tmp_path / "blank"
    blank.mkdir()
    for i in range(3):
        (blank / f"{i}.png").write_bytes(b"")                 # frames that decode to nothing
    res = run_cli("calibrate", "camera", "--source", str(blank), "--out", str(tmp_path / "x.npz"), "-q")
    assert res.returncode == 2 and "no image" in res.stderr and len(res.stderr.strip().splitlines()) == 1


def _pdf_streams(data: bytes) -> str:
    out = []
    for m in re.finditer(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            out.append(zlib.decompress(m.group(1)).decode("latin-1"))
        except zlib.error:
            pass
    return "\n".join(out)


def test_board_pdf_is_true_scale_and_png_detects(tmp_path):
    import cv2

    res = run_cli("calibrate", "board", "--out", str(tmp_path), "--dpi", "300")
    assert res.returncode == 0, res.stderr
    spec = board_for(D)
    pdf = (tmp_path / "charuco_board.pdf").read_bytes()
    # the board image is drawn (w + 2 margins) mm wide, in points (72 per inch), to 0.1 mm
    w, h = spec.size_mm
    want_w, want_h = (w + 2 * spec.square_mm) / 25.4 * 72, (h + 2 * spec.square_mm) / 25.4 * 72
    cms = re.findall(r"([\d.]+) 0 0 ([\d.]+) [\d.]+ [\d.]+ cm\s*/I\w*\s+Do", _pdf_streams(pdf))
    assert cms, "no image placement found in the PDF"
    assert any(abs(float(a) - want_w) < 0.3 and abs(float(b) - want_h) < 0.3 for a, b in cms), (cms, want_w, want_h)
    img = cv2.imread(str(tmp_path / "charuco_board.png"))
    got = detect(spec, img)
    assert isinstance(got, View) and len(got.ids) == (spec.squares_x - 1) * (spec.squares_y - 1)
    # 300 dpi: a square is square_mm * 300 / 25.4 px
    d = np.diff(got.image_px[:2], axis=0)
    assert np.hypot(*d[0]) == pytest.approx(spec.square_mm * 300 / 25.4, rel=0.01)


def test_plane_view_measures_distance_and_mm_per_px():
    """A fronto-parallel board at the marker plane (as the board holder sets it): its distance and mm/px."""
    from whisker.bringup.charuco import board_pose, plane_mm_per_px

    spec = board_for(D)
    r, t = board_pose(spec, D.camera.distance, 0.0, 0.0, 10.0)
    view = detect(spec, render_board_view(spec, TRUE, r, t, SIZE))
    assert isinstance(view, View)
    z, k = plane_mm_per_px(TRUE, view)
    assert z == pytest.approx(D.camera.distance, abs=0.05)
    assert k == pytest.approx(D.camera.distance / np.sqrt(352.0 * 350.6), rel=1e-3)


@pytest.mark.parametrize("sub", ["", "camera", "board", "wiring", "stiffness"])
def test_every_calibrate_command_has_help(sub):
    res = run_cli("calibrate", *([sub] if sub else []), "--help")
    assert res.returncode == 0 and "Usage" in res.stdout


def test_sim_scene_runs_through_a_fisheye_lens_file(calibrated):
    """The simulator's camera renders through the written (fisheye) file and the tracker undoes it."""
    from whisker.sim import scene_from_dict, simulate
    from whisker.sim.camera import camera_run

    out, _ = calibrated
    d = default_design("drive.full_scale_voltage=3.0")
    s = scene_from_dict({
        "scene": {"duration": 0.2, "timestep": 1e-3, "seed": 4}, "sensor": {"facing": "up"},
        "actuation": {"schedule": [{"t": 0.0, "level": 0.5, "whiskers": [0, 2, 4, 6]}]},
        "camera": {"enabled": True, "fps": 20, "method": "roi", "geometry": "exact", "calibration": str(out)},
        "fidelity": {"heating": "off", "solver": "dynamic"}})
    cr = camera_run(s, d, simulate(s, d))
    assert cr.valid.all() and cr.px_rms < 0.1 and cr.tip_rms_mm < 0.2
    # the rendered markers really carry the fisheye distortion (differ from the pinhole projection)
    pinhole = marker_pixels(d, rest_marker_xyz(d), mtx=load_lens(out).mtx)
    assert np.abs(cr.true_px[0] - pinhole).max() > 1.0
