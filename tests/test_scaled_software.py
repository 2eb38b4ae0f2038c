"""The software follows a scaled design: the simulated camera, the tracker and the geometry give
the tips back on off-paper sensors; the BOM, the pin map and the netlist count N whiskers; the
classifier's rotations step by 360/N."""

from __future__ import annotations

import math

import numpy as np
import pytest

from whisker.design import default_design

EXPANDER = "wiring.expander=\"pca9685\""
SCALED = [("whiskers.count=5", "whiskers.ring_radius=14"),
          ("whiskers.count=16", "whiskers.ring_radius=20", EXPANDER)]


@pytest.mark.parametrize("overrides", SCALED, ids=["5@14mm", "16@20mm"])
def test_sim_camera_tracker_and_geometry_give_the_tips_back(overrides):
    pytest.importorskip("cv2", reason="OpenCV renders and tracks the frames")
    from whisker.sim import plan, scene_from_dict, simulate
    from whisker.sim.camera import camera_run

    d = default_design(*overrides, "drive.full_scale_voltage=3.0")
    n = d.whiskers.count
    s = scene_from_dict({
        "scene": {"duration": 0.3, "timestep": 1e-3, "seed": 4}, "sensor": {"facing": "up"},
        "actuation": {"schedule": [{"t": 0.0, "level": 0.5, "whiskers": list(range(0, n, 2))},
                                   {"t": 0.0, "level": -0.8, "whiskers": list(range(1, n, 2))}]},
        "camera": {"enabled": True, "fps": 20, "method": "roi", "geometry": "exact"},
        "fidelity": {"heating": "off", "solver": "dynamic"}})
    p = plan(s, d)
    assert p.built("camera") and p.built("tracking")
    cr = camera_run(s, d, simulate(s, d, p))
    assert cr.valid.all() and cr.true_tip_mm.shape[-2] == n
    assert np.abs(cr.true_tip_mm).max() > 3.0  # every whisker really moved
    # the ring keeps its size in the image, so the pixel error stays the paper's; in mm it scales with k
    assert cr.px_rms < 0.1
    assert cr.tip_rms_mm < 0.05 * d.mm_per_px / default_design().mm_per_px


@pytest.mark.parametrize("overrides", SCALED, ids=["5@14mm", "16@20mm"])
def test_pin_map_netlist_and_bom_count_n(overrides):
    from whisker.bom import bom_rows, coil_wire
    from whisker.part_measures import print_settings
    from whisker.pcb import netlist
    from whisker.drive.pins import modules_needed, pin_map

    d = default_design(*overrides)
    n = d.whiskers.count
    pm = pin_map(d)
    assert [c.whisker for c in pm] == list(range(n))
    board = netlist.build_circuit(d)
    report = netlist.run_erc(board)
    assert report.errors == 0, report.messages
    assert sum(1 for r in board.parts if r.startswith("L")) == n
    volumes = {"membrane": 2500.0, "mount": 40000.0, "mold_base": 9000.0, "mold_lid": 5000.0, "whisker_ring": 20000.0,
               "adapter": 40000.0, "flange_plate": 20000.0, "cover": 4700.0, "winding_jig": 2500.0, "bobbin": 44.0}
    areas = {k: v / 5 for k, v in volumes.items()}
    rows = {r.item: r for r in bom_rows(d, volumes, coil_wire(d), None, areas, print_settings(d))}
    assert rows["rod"].value == rows["coil"].value == rows["magnet"].value == n
    assert rows["h_bridge"].value == modules_needed(n) == math.ceil(n / 2)


@pytest.mark.parametrize("n", [5, 16])
def test_rotation_steps_by_360_over_n(n):
    """Turning the whole sensor by one whisker spacing maps a radial deflection pattern onto itself,
    with each whisker's magnitude moved one index on, for the design's own whisker angles."""
    from whisker.data.dataset import rotate

    d = default_design(f"whiskers.count={n}")
    a = np.radians(d.whisker_angles_deg)
    mag = np.arange(1.0, n + 1.0)
    X = np.stack([mag * np.cos(a), mag * np.sin(a)], axis=-1)
    R = rotate(X, 1, sense=1)
    expect = np.stack([np.roll(mag, 1) * np.cos(a), np.roll(mag, 1) * np.sin(a)], axis=-1)
    assert np.allclose(R, expect, atol=1e-12)
    assert np.allclose(rotate(X, n), X)
