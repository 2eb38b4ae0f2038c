"""Pictures a maker reads (issue 29): callouts in the assembly pictures, the LED strip as bought,
hardware in place, the winding jig in use and the numbered camera view."""

from __future__ import annotations

import io
import re
import math

import numpy as np
import pytest
from PIL import Image

from whisker.cad.pictures import assembly_images as ai
from whisker.cad.pictures import guide_images
from whisker.cad.solids import reference, winding_jig
from whisker.design import default_design, sizing


@pytest.fixture(scope="module")
def d():
    return default_design()


def _view(name):
    return next(v for v in ai.views() if v.name == name)


def test_magnet_step_names_parts_numbers_whiskers_and_the_pole(d):
    _, _, labels = ai.labelled_scene(d, _view("magnets into their pockets"))
    texts = [t for _, t in labels]
    assert [t for t in texts if re.fullmatch(r"w\d+", t)] == [f"w{i}" for i in range(d.whiskers.count)]
    assert "+x ->" in texts and any("N faces the centre" in t for t in texts)
    assert "mount" in texts and "magnets (new)" in texts and "heat-set inserts" in texts
    # whisker 0 is labelled on +x, the others counter-clockwise
    p0 = next(p for p, t in labels if t == "w0")
    assert abs(math.degrees(math.atan2(p0[1], p0[0])) - d.whiskers.first_angle_deg) < 1e-6


def test_adapter_step_draws_its_screws(d):
    items, _, labels = ai.labelled_scene(d, _view("robot adapter under the mount"))
    texts = [t for _, t in labels]
    assert "screws (ISO 4762)" in texts and any(t.startswith("adapter + flange plate") for t in texts)
    screws = ai._hardware(d, "adapter")
    assert len(screws) == d.mount.mounting_hole_count + d.adapter.coupling_count


def test_led_strip_is_drawn_as_bought(d):
    """The strip covers the BOM's length (whole segments) of the channel, its gap centred at -y."""
    circ, _, length = sizing.led_strip(d)
    strip = reference.led_strip(d)
    full = reference.led_strip(default_design("bom.led_cut_pitch=1.0"))  # nearly the whole ring
    share = strip.Volume() / full.Volume()
    assert share == pytest.approx(length / (math.floor(circ) * 1.0), rel=0.02)
    bb = strip.BoundingBox()
    assert bb.ymin > -sizing.led_outer_radius(d) + 1.0 and abs(bb.xmin + bb.xmax) < 1e-3


def test_winding_picture_puts_the_bobbin_in_the_jig_pocket(d):
    meshes, paths, labels = guide_images.winding_scene(d)
    _, bob, _ = (m for m, _ in meshes)
    J = winding_jig.layout(d)
    w, y0, y1 = J["tab"]
    floor = J["disc"][1] - J["pocket_depth"]
    lo, hi = bob.bounds
    assert lo[2] == pytest.approx(floor, abs=0.02)
    assert lo[0] >= -w / 2 - 0.02 and hi[0] <= w / 2 + 0.02 and lo[1] >= y0 - 0.02
    assert len(paths) == 1 and any("tension" in t for _, t in labels)


def test_camera_view_numbers_every_marker(d):
    png = guide_images.camera_picture(d, 0.0)
    img = np.asarray(Image.open(io.BytesIO(png)))
    assert img.shape[:2] == (d.camera.height_px, d.camera.width_px)



