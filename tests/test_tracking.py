"""whisker.vision.tracking on synthetic frames with known subpixel marker positions, plus the hard cases."""

from __future__ import annotations

import numpy as np
import pytest

from whisker.vision import geometry
from whisker.vision import render
from whisker.design import default_design
from whisker.vision.markers import METHODS, assign, load_calibration, load_mask
from whisker.vision.tracking import CalibrationError, Tracker

D = default_design()
BIG = default_design("coil.marker_diameter=1.9")  # ~20 px red discs, the size the paper's 10x10 erosion needs
KW = dict(noise_sigma=4.0, blur_px=0.8)


def frame(design, tilt=0.0, seed=0, offset=(0.0, 0.0), **kw):
    pts = render.scene_markers(design, tilt, offset_px=offset)
    return pts, render.render_frame(design, pts, seed=seed, **{**KW, **kw})


@pytest.fixture(scope="module")
def rest_big():
    return frame(BIG, seed=100)


@pytest.mark.parametrize("method", METHODS)
def test_every_method_finds_every_marker_with_the_right_identity(method, rest_big):
    t = Tracker(BIG, method)
    t.calibrate([rest_big[1]])
    rng = np.random.default_rng(3)
    tilt = rng.uniform(0, 12, 8)
    pts, img = frame(BIG, tilt, seed=5, offset=(0.3, -0.2))
    r = t.track(img)
    assert r.all_valid, r.status
    err = np.hypot(*(r.positions_px - pts).T)
    # identity: whisker i is within a pixel of ITS true marker (neighbours are ~100 px away)
    limit = {"paper": 1.0, "contour": 0.4, "blob": 0.1, "roi": 0.1, "fit": 0.1}[method]
    assert err.max() < limit, err
    # displacements point radially outward for a retraction (positive tilt)
    base = t.baseline.out_xy
    radial = ((r.positions_px - base) * (base - base.mean(axis=0))).sum(axis=1)
    assert np.all(radial > 0)


def test_identity_follows_the_design_for_other_counts_and_orientations():
    for over in (("whiskers.count=6", "tracking.image_up_deg=0"), ("whiskers.count=5", "whiskers.first_angle_deg=17")):
        d = default_design(*over)
        pts, img = frame(d, 0.0, seed=1)
        t = Tracker(d, "roi")
        t.calibrate([img])
        assert np.allclose(t.baseline.out_xy, pts, atol=0.1)
        r = t.track(frame(d, 8.0, seed=2)[1])
        assert r.all_valid and np.allclose(r.positions_px, render.scene_markers(d, 8.0), atol=0.1)


def test_roi_tracks_a_sequence_subpixel_and_recovers_a_lost_marker():
    t = Tracker(D, "roi")
    t.calibrate([frame(D, 0.0, seed=s)[1] for s in range(3)])
    errs = []
    for i, tilt in enumerate(np.linspace(0, 15, 8)):
        pts, img = frame(D, tilt, seed=10 + i)
        r = t.track(img)
        assert r.all_valid
        errs.append(r.positions_px - pts)
    assert np.sqrt(np.mean(np.sum(np.square(errs), axis=2))) < 0.06
    # whisker 3 vanishes (marker hidden), then comes back far from its last position
    pts = render.scene_markers(D, 15.0)
    hidden = pts.copy()
    hidden[3] = np.nan
    r = t.track(render.render_frame(D, hidden, seed=30, **KW))
    assert r.status[3] == "lost" and not r.valid[3] and r.valid.sum() == 7 and np.isnan(r.dx_px[3])
    back = render.scene_markers(D, 0.0)
    r = t.track(render.render_frame(D, back, seed=31, **KW))
    assert r.all_valid and np.allclose(r.positions_px, back, atol=0.1)


@pytest.mark.parametrize("method", METHODS)
def test_bad_frames_never_raise(method, rest_big):
    t = Tracker(BIG, method)
    t.calibrate([rest_big[1]])
    h, w = rest_big[1].shape[:2]
    cases = {
        "empty": np.zeros((0, 0, 3), np.uint8),
        "none": None,
        "list": [[1, 2, 3]],
        "gray": np.zeros((h, w), np.uint8),
        "float": np.zeros((h, w, 3), np.float32),
        "wrong size": np.zeros((h // 2, w, 3), np.uint8),
        "four channels": np.zeros((h, w, 4), np.uint8),
    }
    for name, img in cases.items():
        r = t.track(img)
        assert not r.valid.any() and r.message and set(r.status) == {"bad-frame"}, name
        assert np.all(np.isnan(r.positions_px)) and np.all(np.isnan(r.dx_px))
    for name, value in {"black": 0, "white": 255}.items():
        r = t.track(np.full((h, w, 3), value, np.uint8))
        assert not r.valid.any() and set(r.status) <= {"lost", "merged"}, (name, r.status)
    red = np.zeros((h, w, 3), np.uint8)
    red[..., 2] = 220
    r = t.track(red)
    assert not r.valid.any(), r.status
    # and the tracker still works afterwards
    assert t.track(rest_big[1]).all_valid


def test_markers_leaving_the_image_are_flagged_not_misplaced():
    t = Tracker(BIG, "roi")
    pts, img = frame(BIG, 0.0, seed=1)
    t.calibrate([img])
    moved = pts.copy()
    i = int(np.argmin(pts[:, 0]))  # leftmost marker slides over the left edge
    moved[i, 0] = 3.0
    r = t.track(render.render_frame(BIG, moved, seed=2, **KW))
    assert not r.valid[i] and r.status[i] in ("border", "lost")
    others = np.arange(8) != i
    assert r.valid[others].all() and np.allclose(r.positions_px[others], pts[others], atol=0.1)
    moved[i, 0] = -40.0  # entirely outside
    r = t.track(render.render_frame(BIG, moved, seed=3, **KW))
    assert not r.valid[i] and r.valid[others].all()


@pytest.mark.parametrize("method", ["roi", "fit", "blob", "contour"])
def test_merging_markers_are_flagged_and_never_swap(method):
    t = Tracker(BIG, method)
    pts, img = frame(BIG, 0.0, seed=1)
    t.calibrate([img])
    # whiskers 2 and 3 walk towards each other until they overlap, then apart again
    a, b = pts[2].copy(), pts[3].copy()
    mid = (a + b) / 2
    seen_merge = False
    for f in list(np.linspace(0, 1, 9)) + list(np.linspace(1, 0, 9)):
        p = pts.copy()
        p[2] = a + f * (mid - a) * 0.995
        p[3] = b + f * (mid - b) * 0.995
        r = t.track(render.render_frame(BIG, p, seed=int(f * 100), **KW))
        for i in (2, 3):
            if r.valid[i]:
                # a valid position is always that whisker's own marker, never the neighbour's
                assert np.hypot(*(r.positions_px[i] - p[i])) < 1.0, (f, i, r.status)
        seen_merge |= any(r.status[i] == "merged" or not r.valid[i] for i in (2, 3))
    assert seen_merge
    assert r.all_valid  # apart again: both recovered with their own identities


def test_calibration_refuses_frames_without_markers():
    t = Tracker(D, "roi")
    with pytest.raises(CalibrationError, match=r"whisker\(s\) \[0, 1, 2, 3, 4, 5, 6, 7\]"):
        t.calibrate([np.zeros((480, 640, 3), np.uint8)])
    with pytest.raises(CalibrationError, match="no usable rest frame"):
        t.calibrate([None, np.zeros((2, 2), np.uint8)])


def test_undistortion_points_and_image_agree_with_the_camera_model(tmp_path):
    mtx = geometry.camera_matrix(D).copy()
    mtx[0, 2] += 4.0
    dist = np.array([0.3, -0.5, 0.0, 0.0, 0.2])
    np.savez(tmp_path / "cal.npz", mtx=mtx, dist=dist)
    xyz = geometry.tilted_marker_xyz(D, 10.0)
    raw = render.marker_pixels(D, xyz, mtx=mtx, dist=dist)
    ideal = render.marker_pixels(D, xyz, mtx=mtx)
    rest_raw = render.marker_pixels(D, geometry.rest_marker_xyz(D), mtx=mtx, dist=dist)
    assert np.abs(raw - ideal).max() > 2.0  # the distortion matters at the ring
    for mode, tol in (("points", 0.1), ("image", 0.4)):
        t = Tracker(D, "roi", calibration=tmp_path / "cal.npz", undistort=mode)
        t.calibrate([render.render_frame(D, rest_raw, seed=1, **KW)])
        r = t.track(render.render_frame(D, raw, seed=2, **KW))
        assert r.all_valid and np.abs(r.positions_px - ideal).max() < tol, (mode, r.positions_px - ideal)


def test_mask_hides_markers_outside_it(rest_big):
    mask = np.zeros(rest_big[1].shape[:2], np.uint8)
    pts = rest_big[0]
    right = pts[:, 0] > pts[:, 0].mean()
    mask[:, int(pts[:, 0].mean()):] = 255
    t = Tracker(BIG, "blob", mask=mask)
    t_res = t.detect(rest_big[1])
    assert len(t_res.xy) == right.sum()
    with pytest.raises(ValueError, match="empty"):
        load_mask(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="not a readable image"):
        load_mask("/nonexistent/mask.png")


def test_bad_configuration_gets_one_line_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown tracking method"):
        Tracker(D, "magic")
    with pytest.raises(ValueError, match="does not exist"):
        load_calibration(tmp_path / "missing.npz")
    np.savez(tmp_path / "nomtx.npz", dist=np.zeros(5))
    with pytest.raises(ValueError, match="'mtx'"):
        load_calibration(tmp_path / "nomtx.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(ValueError, match="not a readable"):
        load_calibration(tmp_path / "junk.npz")


def test_assign_is_one_to_one_and_gated():
    ref = np.array([[0.0, 0.0], [10.0, 0.0], [np.nan, np.nan]])
    det = np.array([[9.0, 0.0], [1.0, 0.0], [50.0, 50.0]])
    assert assign(det, ref, gate=3.0).tolist() == [1, 0, -1]
    assert assign(det[:1], ref, gate=3.0).tolist() == [-1, 0, -1]
    assert assign(np.zeros((0, 2)), ref, gate=3.0).tolist() == [-1, -1, -1]


@pytest.mark.parametrize("count", [1, 2, 16])
def test_uncalibrated_positions_then_calibrated_displacements_for_any_count(count):
    d = default_design(f"whiskers.count={count}")
    t = Tracker(d, "roi")
    pts, img = frame(d, 0.0, seed=1)
    r = t.track(img)  # before calibration: positions and identities, no displacement
    assert r.all_valid and np.allclose(r.positions_px, pts, atol=0.1) and np.all(np.isnan(r.dx_px))
    t.calibrate([img])
    moved, img2 = frame(d, 10.0, seed=2)
    r = t.track(img2)
    assert r.all_valid and np.allclose(r.positions_px, moved, atol=0.1)
    assert np.allclose(r.dx_px, r.positions_px[:, 0] - t.baseline.out_xy[:, 0], atol=1e-9)
    assert np.allclose(r.dx_px, moved[:, 0] - pts[:, 0], atol=0.15)


def test_fit_refines_the_centroid_towards_the_truth():
    rest = frame(BIG, 0.0, seed=7, noise_sigma=0.0)[1]
    errs = {}
    for method in ("roi", "fit"):
        t = Tracker(BIG, method)
        t.calibrate([rest])
        e = []
        for i, tilt in enumerate((2.0, 5.0, 8.0, 11.0)):
            pts, img = frame(BIG, tilt, seed=40 + i, noise_sigma=12.0)
            r = t.track(img)
            assert r.all_valid
            e.append(r.positions_px - pts)
        errs[method] = float(np.sqrt(np.mean(np.sum(np.square(e), axis=2))))
    assert errs["fit"] < 0.9 * errs["roi"] < 0.1, errs
