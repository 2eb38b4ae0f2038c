"""whisker.vision.camera frame sources and the `whisker track` command on replayed frames."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from conftest import run_cli
from whisker.vision import render
from whisker.vision.camera import FolderSource, SourceError, SyntheticSource, VideoSource, open_source
from whisker.design import default_design
from whisker.vision.tracking import Tracker

D = default_design()


def _write_frames(folder, tilts, seed=0):
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    truth = []
    for i, tilt in enumerate(tilts):
        pts = render.scene_markers(D, tilt)
        cv2.imwrite(str(folder / f"f{i:03d}.png"), render.render_frame(D, pts, seed=seed + i, noise_sigma=3, blur_px=0.7))
        truth.append(pts)
    return np.array(truth)


def _write_video(path, frames, fps=30.0):
    import cv2

    h, w = frames[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    assert vw.isOpened()
    for f in frames:
        vw.write(f)
    vw.release()


def test_folder_source_replays_in_order_and_flags_unreadable_files(tmp_path):
    truth = _write_frames(tmp_path / "imgs", [0, 0, 5, 10])
    (tmp_path / "imgs" / "f999.jpg").write_bytes(b"not a jpeg")
    with open_source(str(tmp_path / "imgs")) as src:
        assert isinstance(src, FolderSource)
        frames = list(src)
    assert [f.index for f in frames] == [0, 1, 2, 3, 4]
    assert frames[-1].image is None and frames[0].image.shape == (480, 640, 3)
    t = Tracker(D, "roi")
    t.calibrate(frames[:2])
    res = [t.track(f.image) for f in frames[2:]]
    assert res[0].all_valid and np.allclose(res[1].positions_px, truth[3], atol=0.1)
    assert not res[2].valid.any() and "None" in res[2].message


def test_video_source_and_a_truncated_video(tmp_path):
    import cv2

    imgs = [render.render_frame(D, render.scene_markers(D, t), seed=i) for i, t in enumerate(np.linspace(0, 10, 12))]
    path = tmp_path / "clip.avi"
    _write_video(path, imgs)
    with open_source(str(path)) as src:
        assert isinstance(src, VideoSource) and src.fps == pytest.approx(30.0)
        frames = list(src)
    assert len(frames) == 12 and not src.truncated
    assert frames[3].time_s == pytest.approx(3 / 30.0)
    # cut the file in the middle: reading stops early, no exception escapes, `truncated` is set
    data = path.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 2])
    with open_source(str(cut)) as src:
        got = list(src)
    assert 0 < len(got) < 12 and src.truncated  # the header announced 12 frames
    t = Tracker(D, "roi")
    t.calibrate(got[:1])
    assert all(t.track(f.image).all_valid for f in got)
    assert cv2.imread(str(cut)) is None  # and it is not mistaken for an image


def test_unreadable_sources_get_one_line_errors(tmp_path):
    with pytest.raises(SourceError, match="no such file or folder"):
        open_source(str(tmp_path / "nothing.mp4"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(SourceError, match="holds no"):
        open_source(str(tmp_path / "empty"))
    (tmp_path / "junk.mp4").write_bytes(b"\x00" * 100)
    with pytest.raises(SourceError, match="cannot open video file"):
        open_source(str(tmp_path / "junk.mp4"))
    with pytest.raises(SourceError, match="empty source"):
        open_source("  ")
    with pytest.raises(SourceError, match="integer"):
        open_source("synthetic:many")


@pytest.mark.skipif(importlib.util.find_spec("picamera2") is not None, reason="picamera2 is installed here")
def test_picamera_without_picamera2_says_how_to_install():
    with pytest.raises(SourceError, match="apt install python3-picamera2"):
        open_source("picamera")


def test_synthetic_source_knows_its_truth():
    src = SyntheticSource(D, 6, amplitude_deg=12.0, period_frames=6, noise_sigma=2.0)
    frames = list(src)
    assert len(frames) == 6 and src.truth.shape == (6, 8, 2)
    t = Tracker(D, "roi")
    t.calibrate([render.render_frame(D, render.scene_markers(D, 0.0))])
    for f in frames:
        r = t.track(f.image)
        assert r.all_valid and np.abs(r.positions_px - src.truth[f.index]).max() < 0.1


def test_cli_tracks_a_folder_and_writes_csv_and_video(tmp_path):
    _write_frames(tmp_path / "imgs", [0, 0, 0, 4, 8, 12])
    out = tmp_path / "tracks.csv"
    rec = tmp_path / "annotated.avi"
    res = run_cli("track", "--source", str(tmp_path / "imgs"), "--rest-frames", "3", "--out", str(out),
                  "--record", str(rec), "--model", "exact", "-q")
    assert res.returncode == 0, res.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == ("frame,time_s,whisker,x_px,y_px,dx_px,dy_px,valid,status,theta_deg,"
                        "tip_x_mm,tip_y_mm,tip_z_mm")
    rows = [r.split(",") for r in lines[1:]]
    assert len(rows) == 6 * 8 and all(r[7] == "1" for r in rows)
    theta = np.array([float(r[9]) for r in rows]).reshape(6, 8)
    assert np.allclose(theta[:3], 0.0, atol=0.2) and np.allclose(theta[5], 12.0, atol=0.3)
    assert rec.stat().st_size > 10_000


def test_cli_refuses_bad_sources_in_one_line(tmp_path):
    res = run_cli("track", "--source", str(tmp_path / "missing.mp4"), "-q")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and "no such file" in res.stderr
    empty = tmp_path / "black"
    empty.mkdir()
    import cv2

    cv2.imwrite(str(empty / "a.png"), np.zeros((480, 640, 3), np.uint8))
    res = run_cli("track", "--source", str(empty), "--rest-frames", "1", "-q")
    assert res.returncode == 2 and "calibration" in res.stderr
    res = run_cli("track", "--help")
    assert res.returncode == 0 and "--source" in res.stdout and "--record" in res.stdout


def test_cli_show_without_a_display_writes_the_annotated_video(tmp_path):
    import os
    import subprocess
    import sys

    out = tmp_path / "t.csv"
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    res = subprocess.run([sys.executable, "-m", "whisker.cli", "track", "--source", "synthetic:4", "--rest-frames", "2",
                          "--out", str(out), "--show", "-q"], capture_output=True, text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "annotated video" in res.stderr and (tmp_path / "t.mp4").stat().st_size > 10_000
    assert len(out.read_text().splitlines()) == 1 + 4 * 8
