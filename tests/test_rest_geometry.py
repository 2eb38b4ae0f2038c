"""Image orientation, marker radius and ring scale measured on a rest frame (whisker.vision.rest_geometry)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import peer_data
from whisker.design import default_design
from whisker.vision.render import render_frame, scene_markers
from whisker.vision.rest_geometry import RestGeometryError, measure
from whisker.vision.tracking import Tracker

D = default_design()


def test_synthetic_orientation_and_marker_size_are_recovered():
    truth = default_design("tracking.image_up_deg=100")          # the camera turned 12.5 deg from the design
    frame = render_frame(truth, scene_markers(truth, 0.0), noise_sigma=3.0, blur_px=0.7, marker_radius=8.0)
    g = measure(D, frame)
    assert g.image_up_deg == pytest.approx(100.0, abs=0.1)
    assert g.image_up_design_deg == 112.5
    assert g.edge_radius_px == pytest.approx(8.0, abs=0.15)
    assert g.mm_per_px == pytest.approx(D.mm_per_px, rel=0.002)
    # the measured sizes make the fit method track these 8 px markers with no refusal
    moved = render_frame(truth, scene_markers(truth, 6.0), seed=2, noise_sigma=3.0, blur_px=0.7, marker_radius=8.0)
    rest_trk = Tracker(truth, "fit", marker_radius_px=g.marker_radius_px, edge_radius_px=g.edge_radius_px)
    rest_trk.calibrate([frame])
    r = rest_trk.track(moved)
    assert r.all_valid and r.fit_refused == 0
    want = scene_markers(truth, 6.0)
    assert np.abs(r.positions_px - want).max() < 0.15


def test_refused_disc_fits_are_counted():
    frame = render_frame(D, scene_markers(D, 0.0), noise_sigma=2.0, blur_px=0.7)
    pts = scene_markers(D, 0.0)
    mask = np.full(frame.shape[:2], 255, np.uint8)
    x, y = np.rint(pts[0]).astype(int)
    mask[y + 9:y + 12, x - 3:x + 3] = 0                 # cuts whisker 0's window, not its marker
    trk = Tracker(D, "fit", mask=mask)
    trk.calibrate([frame])
    r = trk.track(frame)
    assert r.all_valid and r.fit_refused == 1
    assert Tracker(D, "roi").track(frame).fit_refused == 0


def test_a_frame_without_the_markers_is_refused_in_one_line():
    blank = np.full((D.camera.height_px, D.camera.width_px, 3), 90, np.uint8)
    with pytest.raises(RestGeometryError, match="marker-sized red blobs"):
        measure(D, blank)
    with pytest.raises(RestGeometryError, match="frame is None"):
        measure(D, None)


DATA = peer_data()


@pytest.mark.skipif(DATA is None, reason="WHISKER_PEER_DATA is not set to the authors' data folder")
def test_authors_rest_frame_agrees_with_the_design_file():
    """hw/sensor.toml: image_up_deg 112.5, marker_diameter 1.4 mm (6.94 px at 0.1009 mm/px).
    Measured on org.jpg (undistorted with their lens file): image_up 112.72 deg (+0.22 deg), blob
    radius 7.01 px (+1 %), half-contrast edge radius 4.6 px (their dots have soft edges), ring 118.9 px
    -> 0.1009 mm/px (within 0.1 % of the design's)."""
    import cv2

    img = DATA / "img"
    g = measure(D, cv2.imread(str(img / "org.jpg")), calibration=img / "calibration_data.npz",
                mask=img / "polygonMask.png")
    print("\n".join(g.lines()))
    assert abs(g.image_up_deg - D.tracking.image_up_deg) < 1.0
    assert g.marker_radius_px == pytest.approx(D.coil.marker_diameter / 2 / D.mm_per_px, rel=0.05)
    assert 3.5 < g.edge_radius_px < g.marker_radius_px
    assert g.mm_per_px == pytest.approx(D.mm_per_px, rel=0.01)
    assert g.orientation_spread_deg < 3.0
