"""The robot adapter in two plates: the flange plate's ISO 9409-1 bolt pattern measured on its mesh
for each preset, the adapter's screws on the mount's holes and over the flange plate's inserts, the
coupling screws reachable past the mount, screw engagement and walls for every preset."""

from __future__ import annotations

import math

import pytest

from whisker.design import fasteners as fz
from whisker.design import flanges
from whisker.cad.solids import adapter, mount
from whisker.cad.verify import walls
from whisker.cad.verify.checks import describe_circles, holes, section, to_mesh
from whisker.design import DesignError, default_design

PRESETS = ("iso9409_50_4_m6", "iso9409_31_5_4_m5", "plain")


@pytest.fixture(scope="module")
def d():
    return default_design()


@pytest.fixture(scope="module")
def meshes(d):
    return {p: (to_mesh(adapter.adapter(d, p), 0.01, 0.2), to_mesh(adapter.flange_plate(d, p), 0.01, 0.2))
            for p in PRESETS}


def _circles(mesh, z):
    return describe_circles(holes(section(mesh, z)))


@pytest.mark.parametrize("preset", PRESETS[:2])
def test_bolt_pattern_on_the_mesh_matches_the_preset(d, meshes, preset):
    fl = flanges.flange(preset)
    L = adapter.layout(d, preset)
    plate = meshes[preset][1]
    clear = fz.hole(fl.thread, "through").diameter
    # under the bolts' counterbores (from the top)
    z = (L["plate_bottom"] + L["plate_top"] - L["robot"].head_height - 0.5) / 2
    circles = _circles(plate, z)
    bolts = [c for c in circles if abs(c[2] - clear) < 0.15 and abs(c[0] - fl.pitch_diameter / 2) < 1.0]
    assert len(bolts) == fl.bolt_count
    assert adapter.bolt_circle_error(bolts, fl) < 0.05                  # pitch circle d1
    angles = sorted(c[1] for c in bolts)
    steps = [(b - a) % 360 for a, b in zip(angles, angles[1:] + angles[:1])]
    assert max(abs(s - 360 / fl.bolt_count) for s in steps) < 0.5      # evenly spaced
    pins = [c for c in circles if abs(c[2] - fl.pin_diameter) < 0.15 and abs(c[0] - fl.pitch_diameter / 2) < 1]
    assert len(pins) == 1                                               # one positioning pin on d1
    gaps = sorted((p - pins[0][1]) % 360 for p in angles)
    assert gaps[0] == pytest.approx(180 / fl.bolt_count, abs=0.5)       # between two bolts
    # the centring spigot: the mesh's lowest section is the spigot's circle
    spigot = section(plate, L["plate_bottom"] - fl.centring_depth / 2)
    assert len(spigot) == 1
    assert 2 * math.sqrt(spigot[0].area / math.pi) == pytest.approx(fl.centring_diameter - 0.1, abs=0.05)


def test_plain_plate_has_no_robot_pattern(d, meshes):
    L = adapter.layout(d, "plain")
    circles = _circles(meshes["plain"][1], (L["plate_bottom"] + L["plate_top"]) / 2)
    # a blank: through its middle only the coupling inserts (from the top) are cut
    ins = [c for c in circles if abs(c[2] - L["insert"].diameter) < 0.15]
    assert len(circles) == len(ins)
    assert section(meshes["plain"][1], L["plate_bottom"] - 0.5) == []   # no spigot


@pytest.mark.parametrize("preset", PRESETS)
def test_mount_screws_land_on_the_mounts_holes(d, meshes, preset):
    L = adapter.layout(d, preset)
    clear = fz.hole(d.fasteners.mount_screw, "through").diameter
    circles = _circles(meshes[preset][0], (L["bottom"] + L["top"]) / 2)
    found = [c for c in circles if abs(c[2] - clear) < 0.15 and abs(c[0] - d.mount.mounting_bolt_radius) < 1]
    assert len(found) == d.mount.mounting_hole_count
    assert all(abs(c[0] - d.mount.mounting_bolt_radius) < 0.05 for c in found)
    assert sorted(round(c[1]) % 360 for c in found) == sorted(round(a) % 360 for a in adapter.sensor_angles(d))


@pytest.mark.parametrize("preset", PRESETS)
def test_coupling_screws_sit_over_the_inserts_and_clear_the_mount(d, meshes, preset):
    L = adapter.layout(d, preset)
    top_mesh, plate = meshes[preset]
    clear = fz.hole(d.fasteners.mount_screw, "through").diameter
    through = [c for c in _circles(top_mesh, (L["bottom"] + L["top"]) / 2)
               if abs(c[2] - clear) < 0.15 and abs(c[0] - L["coupling_radius"]) < 1]
    inserts = [c for c in _circles(plate, L["plate_top"] - 1.0) if abs(c[2] - L["insert"].diameter) < 0.15]
    assert len(through) == len(inserts) == d.adapter.coupling_count
    key = lambda c: c[1] % 360  # noqa: E731
    for a, b in zip(sorted(through, key=key), sorted(inserts, key=key)):
        x = math.dist((a[0] * math.cos(math.radians(a[1])), a[0] * math.sin(math.radians(a[1]))),
                      (b[0] * math.cos(math.radians(b[1])), b[0] * math.sin(math.radians(b[1]))))
        assert x < 0.05
    # a hex key straight down into each counterbore misses the mount
    m = to_mesh(mount.mount(d), 0.02, 0.3)
    cb = [c for c in _circles(top_mesh, L["top"] - 0.5) if abs(c[2] - L["counterbore_sensor"]) < 0.15]
    assert len(cb) == d.adapter.coupling_count
    for r, ang, dia in cb:
        rr = r - dia / 2 + 0.02
        origin = (rr * math.cos(math.radians(ang)), rr * math.sin(math.radians(ang)), 200.0)
        hits, _, _ = m.ray.intersects_location([origin], [(0, 0, -1)])
        assert len(hits) == 0


@pytest.mark.parametrize("preset", PRESETS)
def test_screw_engagement_within_the_tables_range(d, preset):
    joints = adapter.joints(d, preset)
    assert len(joints) == (3 if flanges.flange(preset).bolt_count else 2)
    for j in joints:
        length, engaged = fz.screw_length(j.size, j.kind, j.clamp, j.engage_max)
        lo, hi = fz.fastener(j.size).engagement(j.kind)
        assert lo <= engaged <= min(hi, j.engage_max or hi)
        assert length in fz.fastener(j.size).stock_lengths


@pytest.mark.parametrize("preset", PRESETS)
def test_both_plates_pass_the_wall_check(d, meshes, preset):
    top_mesh, plate = meshes[preset]
    c = walls.wall_check("adapter", top_mesh, {**adapter.adapter_tools(d, preset), **adapter.edges(d, preset)},
                         d.print.min_wall, separate=adapter.separate(d, preset))
    assert c.ok, c.line()
    c = walls.wall_check("flange_plate", plate, {**adapter.plate_tools(d, preset), **adapter.plate_edges(d, preset)},
                         d.print.min_wall, separate=adapter.plate_separate(d, preset))
    assert c.ok, c.line()


def test_the_small_flanges_bolts_lie_under_the_mount(d):
    """Why two plates: the 31.5-4-M5 bolts' counterbores are inside the mount's outline, out of a
    hex key's reach once the mount is on; the flange plate is bolted to the robot first."""
    L = adapter.layout(d, "iso9409_31_5_4_m5")
    assert L["flange"].pitch_diameter / 2 + L["counterbore_robot"] / 2 < d.mount.outer_radius


def test_unknown_preset_is_one_line(d):
    with pytest.raises(DesignError) as e:
        adapter.adapter(d, "iso9409_40_4_m6")
    assert "\n" not in str(e.value) and all(p in str(e.value) for p in PRESETS)
