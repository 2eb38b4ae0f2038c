"""Printing: printer profile, parsers of the slicer's output, overhang check, and the real slicer.

Tests that run PrusaSlicer/admesh FAIL (never skip) when the tools are missing, with the install
command, so CI (which installs them from .ci/apt-packages) cannot pass without slicing. On a
developer machine without them, set WHISKER_ALLOW_NO_SLICER=1 to skip those tests (stated reason).
They slice with coarse settings (0.3 mm layers, 1 perimeter, no infill) to keep CI time modest: this
proves the parts slice; the real times and grams come from `make check-print` (docs/printing.md).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings, strategies as st

from conftest import ROOT, load_manifest, run_cli
from whisker.cad.verify import printcheck as pc
from whisker.design import DesignError, default_design, design_from_dict
from whisker.design.printer import ProfileError, bed_extent, load_profile, parse_ini

PROFILE = ROOT / "hw" / "printer" / "prusa_mk3s_pla_0.2mm.ini"


def tools() -> tuple[str, str]:
    try:
        return pc.find_tool("prusa-slicer"), pc.find_tool("admesh")
    except pc.ToolMissing as err:
        if os.environ.get("WHISKER_ALLOW_NO_SLICER") == "1":
            pytest.skip(f"WHISKER_ALLOW_NO_SLICER=1 and {err}")
        pytest.fail(str(err))


def small_profile(tmp_path: Path, bed: str, height: float) -> Path:
    text = PROFILE.read_text().replace("bed_shape = 0x0,250x0,250x210,0x210", f"bed_shape = {bed}")
    text = text.replace("max_print_height = 210", f"max_print_height = {height:g}")
    p = tmp_path / f"small_{height:g}.ini"
    p.write_text(text)
    return p


# ---- printer profile: the one source of the bed size ------------------------------------------

def test_design_reads_bed_and_filament_from_the_profile():
    d = default_design()
    p = load_profile(d.print.profile)
    assert p.path == PROFILE
    assert (d.print.bed_x, d.print.bed_y, d.print.max_height) == (250.0, 210.0, 210.0)
    assert (d.print.nozzle_diameter, d.print.layer_height, d.print.filament_density) == (0.4, 0.2, 1.24)
    assert "bed_x" not in (ROOT / "hw" / "sensor.toml").read_text()  # typed once: in the profile


def test_another_profile_changes_the_design_and_its_digest(tmp_path):
    small = small_profile(tmp_path, "0x0,120x0,120x100,0x100", 90)
    d = default_design(f'print.profile="{small}"')
    assert (d.print.bed_x, d.print.bed_y, d.print.max_height) == (120.0, 100.0, 90.0)
    assert d.digest() != default_design().digest()


def test_design_round_trips_and_refuses_a_bed_that_disagrees_with_the_profile():
    d = default_design()
    assert design_from_dict(d.to_dict()) == d
    data = d.to_dict()
    data["print"]["bed_x"] = 300.0
    with pytest.raises(DesignError, match=r"print\.bed_x: comes from the printer profile") as err:
        design_from_dict(data)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("text, match", [
    ("max_print_height = 210\n", "bed_shape missing"),
    ("bed_shape = 0x0,250x0\nmax_print_height = 210\n", "at least 3 points"),
    ("bed_shape = 0x0,ax0,1x1\n", "expected points"),
    ("bed_shape = 0x0,250x0,250x210\nmax_print_height = -3\n", "max_print_height"),
    ("[printer:MK3S]\nbed_shape = 0x0,1x0,1x1\n", "single flat profile"),
    ("just words\n", "expected 'key = value'"),
])
def test_bad_profiles_are_refused_in_one_line(tmp_path, text, match):
    p = tmp_path / "bad.ini"
    p.write_text(text)
    with pytest.raises(ProfileError, match=match) as err:
        load_profile(p)
    assert str(p) in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(DesignError, match=r"^print\.profile: printer profile"):
        default_design(f'print.profile="{p}"')


def test_missing_profile_names_the_path():
    with pytest.raises(DesignError, match=r"print\.profile: printer profile not found: .*nope\.ini"):
        default_design('print.profile="nope.ini"')


def test_profile_parser_reads_comments_and_lists():
    s = parse_ini("# c\n; c\nnozzle_diameter = 0.4,0.6\n fill_density = 15% \n")
    assert s == {"nozzle_diameter": "0.4,0.6", "fill_density": "15%"}
    assert bed_extent("10x5,260x5,260x215,10x215") == (250.0, 210.0)


# ---- parsing the tools' real output -----------------------------------------------------------

INFO = """[broken.stl]
size_x = 42.610050
size_z = 4.000000
number_of_facets = 5336
manifold = no
open_edges = 22
number_of_parts =  1
volume = 5219.483887
"""

ADMESH = """========= Facet Status ========== Original ============ Final ====
Number of facets                 :  5336                5356
Facets with 1 disconnected edge  :    22                   0
Facets with 2 disconnected edges :     0                   0
Facets with 3 disconnected edges :     0                   0
Total disconnected facets        :    22                   0
=== Processing Statistics ===     ===== Other Statistics =====
Number of parts       :     1        Volume   :  5318.291016
Degenerate facets     :     0
Facets reversed       :    16
Backwards edges       :     0
"""

GCODE = """; generated by PrusaSlicer 2.5.0
;LAYER_CHANGE
;Z:0.2
;TYPE:Skirt/Brim
;AFTER_LAYER_CHANGE
;LAYER_CHANGE
;Z:0.4
;TYPE:Support material interface
; filament used [mm] = 8419.68
; filament used [cm3] = 20.25
; total filament used [g] = 25.11
; estimated printing time (normal mode) = 1d 2h 22m 5s
"""


def test_parsers_read_the_tools_output():
    info = pc.parse_info(INFO)
    assert info["manifold"] == "no" and info["open_edges"] == "22" and info["number_of_parts"] == "1"
    am = pc.parse_admesh(ADMESH)
    assert am["disconnected"] == 22 and am["facets"] == 5336 and am["facets_reversed"] == 16 and am["parts"] == 1
    g = pc.parse_gcode(GCODE)
    assert g["layers"] == 2 and g["max_z_mm"] == 0.4 and g["support_material"]
    assert g["filament_g"] == 25.11 and g["filament_mm"] == 8419.68
    assert g["time_s"] == 86400 + 2 * 3600 + 22 * 60 + 5


@given(st.integers(0, 5), st.integers(0, 23), st.integers(0, 59), st.integers(0, 59))
@settings(max_examples=30, deadline=None)
def test_duration_round_trip(d, h, m, s):
    text = (f"{d}d " if d else "") + (f"{h}h " if h or d else "") + f"{m}m {s}s"
    assert pc.parse_duration(text) == d * 86400 + h * 3600 + m * 60 + s


def test_duration_without_numbers_is_an_error():
    with pytest.raises(ValueError, match="no duration"):
        pc.parse_duration("unknown")


# ---- fits the printer, overhangs (pure geometry) --------------------------------------------------

@given(st.floats(1, 400), st.floats(1, 400), st.floats(1, 400))
@settings(max_examples=60, deadline=None)
def test_fits_printer_matches_the_bed_either_way_round(x, y, z):
    p = load_profile(PROFILE)
    ok, why = pc.fits_printer((x, y, z), p)
    expect = z <= 210 and ((x <= 250 and y <= 210) or (y <= 250 and x <= 210))
    assert ok == expect
    if not ok:
        assert ("too tall" in why) if z > 210 else ("too wide" in why)


def _box(lo, hi):
    return trimesh.creation.box(bounds=[lo, hi])


def test_overhang_check_wants_supports_under_a_wide_ceiling_only():
    bed = _box([0, 0, 0], [20, 20, 5])
    assert pc.overhangs(bed, 45.0)["area_mm2"] == 0  # the bottom lies on the bed
    assert pc.bed_contact_mm2(bed) == pytest.approx(400.0)
    mushroom = trimesh.boolean.union([_box([8, 8, 0], [12, 12, 10]), _box([-10, -10, 10], [30, 30, 13])],
                                     engine="manifold")
    oh = pc.overhangs(mushroom, 45.0)
    assert oh["needs_supports"] and oh["largest_unbridgeable"]["z_mm"] == pytest.approx(10.0)
    assert oh["area_mm2"] == pytest.approx(40 * 40 - 16, rel=1e-6)
    assert pc.bed_contact_mm2(mushroom) == pytest.approx(16.0)  # only the stem touches the bed
    # A narrow ledge (3 mm) is bridged/overhung without supports.
    ledge = trimesh.boolean.union([_box([0, 0, 0], [20, 20, 10]), _box([-3, 0, 10], [20, 20, 13])], engine="manifold")
    assert not pc.overhangs(ledge, 45.0)["needs_supports"]
    # A 45-degree chamfer is steep enough at a 40 deg threshold but not at 50 deg.
    wedge = trimesh.Trimesh(vertices=[[0, 0, 0], [10, 0, 0], [0, 30, 0], [10, 30, 0], [-20, 0, 20], [-20, 30, 20],
                                      [10, 0, 20], [10, 30, 20]],
                            faces=[[0, 2, 1], [1, 2, 3], [0, 4, 2], [2, 4, 5], [1, 3, 6], [3, 7, 6], [4, 6, 5],
                                   [5, 6, 7], [0, 1, 4], [1, 6, 4], [2, 5, 3], [3, 5, 7]])
    assert wedge.is_watertight and wedge.volume > 0
    assert pc.overhangs(wedge, 40.0)["area_mm2"] == 0
    assert pc.overhangs(wedge, 50.0)["needs_supports"]


# ---- the real slicer --------------------------------------------------------------------------

def test_missing_slicer_says_how_to_install_it(tmp_path):
    env = {**os.environ, "WHISKER_PRUSA_SLICER": "no-such-prusa-slicer"}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("WHISKER_PRUSA_SLICER", "no-such-prusa-slicer")
        with pytest.raises(pc.ToolMissing, match="apt-get install prusa-slicer"):
            pc.find_tool("prusa-slicer")
    res = subprocess.run([sys.executable, "-m", "whisker.cli", "print", "check", "--build", str(tmp_path)],
                         capture_output=True, text=True, env=env, cwd=ROOT, timeout=120)
    assert res.returncode == 3
    assert "prusa-slicer not found" in res.stderr and "sudo apt-get install prusa-slicer" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "manifest.json").exists()  # refused before building anything


def test_broken_mesh_is_rejected_with_the_reason(default_build, tmp_path):
    slicer, admesh = tools()
    mesh = trimesh.load_mesh(default_build / "mold_lid.stl")
    mesh.update_faces(np.arange(len(mesh.faces))[12:])  # remove 12 faces: holes in the surface
    stl = tmp_path / "broken.stl"
    mesh.export(stl)
    res = pc.check_part("broken", stl, load_profile(PROFILE), tmp_path / "broken.gcode", slicer, admesh, coarse=True)
    assert not res.ok
    text = "; ".join(res.reasons)
    assert "manifold = no" in text and "open_edges" in text and "faces are missing" in text
    assert "admesh: disconnected = " in text
    assert not (tmp_path / "broken.gcode").exists()  # not sliced: its numbers would mean nothing
    assert "NOT printable" in res.line()


def test_parts_too_wide_or_too_tall_for_the_printer_are_rejected(default_build, tmp_path):
    slicer, admesh = tools()
    narrow = load_profile(small_profile(tmp_path, "0x0,30x0,30x30,0x30", 210))
    low = load_profile(small_profile(tmp_path, "0x0,250x0,250x210,0x210", 40))
    wide = pc.check_part("mold_lid", default_build / "mold_lid.stl", narrow, tmp_path / "a.gcode", slicer, admesh, True)
    lid = trimesh.load_mesh(default_build / "mold_lid.stl").extents
    assert not wide.ok and f"too wide for the printer: {lid[0]:.1f} x {lid[1]:.1f} mm > bed 30 x 30 mm" in wide.reasons[0]
    tall = pc.check_part("whisker_ring", default_build / "whisker_ring.stl", low, tmp_path / "b.gcode", slicer,
                         admesh, True)
    assert not tall.ok and "too tall for the printer: 62.0 mm > max_print_height 40 mm" in tall.reasons[0]


def test_the_slicer_itself_refuses_a_part_wider_than_its_bed(default_build, tmp_path):
    """Why the check reads the slicer's words: it exits 0 and writes no G-code."""
    slicer, _ = tools()
    narrow = small_profile(tmp_path, "0x0,30x0,30x30,0x30", 210)
    out = tmp_path / "x.gcode"
    res = subprocess.run([slicer, "--loglevel=1", "--load", str(narrow), *pc.COARSE_ARGS, "-g", "-o", str(out),
                          str(default_build / "mold_lid.stl")], capture_output=True, text=True, timeout=300)
    assert "could not fit on the bed" in res.stdout + res.stderr and not out.exists()


def _check_print_cli(out: Path, *sets: str) -> dict:
    args = [a for s in sets for a in ("--set", s)]
    res = run_cli("print", "check", *args, "--build", str(out), "--coarse", "-q")
    assert res.returncode == 0, res.stdout + res.stderr
    return json.loads((out / "print_report.json").read_text())


SENSOR_PARTS = ("mount", "mold_base", "mold_lid", "whisker_ring", "adapter", "flange_plate", "cover", "winding_jig")


def _assert_sliced(p: dict):
    assert p["ok"], p["reasons"]
    assert p["info"]["manifold"] == "yes" and p["admesh"]["disconnected"] == 0
    g = p["gcode"]
    assert g["layers"] >= 10 and g["time_s"] > 60 and g["filament_g"] > 0.1
    # The G-code reaches the part's top (within a coarse layer).
    assert g["max_z_mm"] == pytest.approx(p["size_mm"][2], abs=0.35)


def test_default_design_slices_every_printable_part(default_build, tmp_path):
    tools()
    out = tmp_path / "exports"
    shutil.copytree(default_build, out)  # the shared build stays untouched
    report = _check_print_cli(out)
    manifest = load_manifest(out)
    printable = {n for n, p in manifest["parts"].items() if p.get("printable")}
    assert printable == {*SENSOR_PARTS, *pc.CALIBRATION_PARTS}
    assert set(report["parts"]) == printable and report["summary"]["all_ok"]
    for name in printable:
        _assert_sliced(report["parts"][name])
        entry = manifest["parts"][name]["print"]
        assert entry["ok"] and entry["layers"] > 0 and (out / entry["gcode"]).exists()
    s = report["summary"]
    assert s["sensor_parts"] == list(SENSOR_PARTS) and s["calibration_parts"] == sorted(pc.CALIBRATION_PARTS)
    assert s["total_filament_g"] == pytest.approx(
        sum(report["parts"][n]["gcode"]["filament_g"] for n in SENSOR_PARTS), abs=0.01)
    assert manifest["print"]["all_ok"] and manifest["print"]["total_time_s"] == s["total_time_s"]
    md = (out / "print_report.md").read_text()
    assert all(f"| {n} |" in md for n in printable) and "Whole sensor" in md and "Coarse slicing" in md


@pytest.mark.parametrize("count, radius", [(6, 10), (12, 12), (16, 20)])
def test_six_and_twelve_whisker_parts_slice(count, radius, tmp_path):
    """The parts whose geometry changes with the whisker count, straight from the part models in
    their printing pose (no full CAD build, to keep CI short; `make check-print WHISKERS=6 RADIUS=10`
    and `WHISKERS=12` run the whole thing, see docs/printing.md)."""
    import cadquery as cq

    from whisker.cad.parts import BY_NAME, print_pose

    slicer, admesh = tools()
    d = default_design(f"whiskers.count={count}", f"whiskers.ring_radius={radius}")
    profile = load_profile(d.print.profile)
    for name in SENSOR_PARTS:
        spec = BY_NAME[name]
        stl = tmp_path / f"{name}.stl"
        cq.exporters.export(cq.Workplane().add(print_pose(spec, spec.build(d))), str(stl),
                            tolerance=d.export.linear_tolerance, angularTolerance=d.export.angular_tolerance)
        res = pc.check_part(name, stl, profile, tmp_path / f"{name}.gcode", slicer, admesh, coarse=True)
        from dataclasses import asdict
        _assert_sliced(asdict(res))


# ---- the tolerance coupon ----------------------------------------------------------------------

def test_coupon_has_rod_holes_and_magnet_pockets_at_every_clearance(default_build):
    from conftest import load_part_mesh, section_polygons
    from shapely.geometry import Polygon

    from whisker.cad.solids.coupon import column_x, layout

    d = default_design()
    lay = layout(d)
    mesh = load_part_mesh(default_build, "tolerance_coupon")  # back from the bed into model coordinates
    cs = d.print.coupon_clearances
    # Rod holes: through the plate, vertical, one per clearance, left to right.
    holes = sorted((Polygon(r) for p in section_polygons(mesh, lay["plate_t"] / 2) for r in p.interiors),
                   key=lambda h: h.centroid.x)
    assert len(holes) == len(cs)
    for h, c, x in zip(holes, cs, column_x(d)):
        dia = 2 * np.sqrt(h.area / np.pi)
        assert dia == pytest.approx(d.whiskers.rod_diameter + 2 * c, abs=0.05)
        assert h.centroid.x == pytest.approx(x, abs=0.01)
    # Magnet pockets: horizontal, in the wall; a cut parallel to the wall face shows them.
    path = mesh.section(plane_origin=[0, lay["wall_y0"] + lay["pocket_depth"] / 2, 0], plane_normal=[0, 1, 0])
    planar, _ = path.to_2D()
    pockets = sorted((Polygon(r) for p in planar.polygons_full for r in p.interiors), key=lambda h: h.area)
    assert len(pockets) == len(cs)
    for h, c in zip(pockets, cs):
        assert 2 * np.sqrt(h.area / np.pi) == pytest.approx(d.magnet.diameter + 2 * c, abs=0.05)
    # Labels: engraved into the plate's top, so just under the top there are extra openings.
    under_top = [r for p in section_polygons(mesh, lay["plate_t"] - 0.3) for r in p.interiors]
    assert len(under_top) >= 2 * len(cs)


def test_coupon_follows_the_design_clearances():
    from whisker.cad.solids.coupon import label, layout

    d = default_design("print.coupon_clearances=[0.05, 0.15, 0.25]")
    assert d.print.coupon_clearances == (0.05, 0.15, 0.25)
    assert [label(c) for c in d.print.coupon_clearances] == ["0.05", "0.15", "0.25"]
    assert layout(d)["width"] < layout(default_design())["width"]
    with pytest.raises(DesignError, match="coupon_clearances"):
        default_design("print.coupon_clearances=[0.1, 0.1]")


# ---- previews --------------------------------------------------------------------------------------

def test_render_writes_a_png_of_the_requested_size():
    import io

    from matplotlib.image import imread

    from whisker.cad.pictures.preview import fine, render

    box = trimesh.creation.box(extents=[30, 10, 5])
    split = fine(box, 2.0)
    assert split.edges_unique_length.max() <= 2.0 + 1e-9 and split.area == pytest.approx(box.area)
    png = render([(box, "#d99a9a")], "box", (240, 180), bed=(250, 210))
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(io.BytesIO(png))
    assert img.shape[:2] == (180, 240)
    assert img[..., :3].std() > 0.05  # something was drawn, not a blank canvas


def test_assembly_has_every_whiskers_rod_coil_and_magnet(default_build):
    from whisker.cad.pictures.preview import assembly_meshes

    d = default_design()
    items = assembly_meshes(d, default_build, load_manifest(default_build))
    assert len(items) == 2 + 3 * d.whiskers.count
    mount = items[0][0]
    assert mount.is_watertight and mount.bounds[0, 1] == pytest.approx(0.0, abs=1e-3)  # cut open at y = 0 (+0.1 um)
    rods = items[2:2 + d.whiskers.count]
    centres = [np.degrees(np.arctan2(m.centroid[1], m.centroid[0])) for m, _ in rods]
    for want in d.whisker_angles_deg:  # every whisker angle has a rod (angular distance, wraps at 360)
        assert min(abs((c - want + 180) % 360 - 180) for c in centres) < 0.5


def test_a_part_that_needs_supports_is_sliced_with_them(tmp_path):
    slicer, admesh = tools()
    mushroom = trimesh.boolean.union([_box([-3, -3, 0], [3, 3, 6]), _box([-12, -12, 6], [12, 12, 8])],
                                     engine="manifold")
    stl = tmp_path / "mushroom.stl"
    mushroom.export(stl)
    res = pc.check_part("mushroom", stl, load_profile(PROFILE), tmp_path / "m.gcode", slicer, admesh, coarse=True)
    assert res.ok, res.reasons
    assert res.supports and res.overhang["largest_unbridgeable"]["extent_mm"] == [24.0, 24.0]
    assert res.gcode["support_material"]  # the slicer did generate support under the cap
    assert "supports yes" in res.line()


def test_check_exports_reports_a_missing_stl_and_removes_stale_gcode(default_build, tmp_path):
    tools()
    out = tmp_path / "exports"
    out.mkdir()
    manifest = load_manifest(default_build)
    keep = {"mold_lid"}
    for name in list(manifest["parts"]):
        if manifest["parts"][name].get("printable") and name not in keep | {"mold_base"}:
            manifest["parts"][name]["printable"] = False  # only two parts, to stay quick
    shutil.copy(default_build / "mold_lid.stl", out / "mold_lid.stl")
    manifest["parts"]["mold_base"]["files"] = {}  # a build without STL for this part
    (out / "manifest.json").write_text(json.dumps(manifest))
    (out / "gcode").mkdir()
    (out / "gcode" / "mold_base.gcode").write_text("; stale\n")
    report = pc.check_exports(default_design(), out, coarse=True)
    assert report["parts"]["mold_lid"]["ok"] and not report["summary"]["all_ok"]
    assert report["parts"]["mold_base"]["reasons"] == ["no STL in the build (build with STL)"]
    assert not (out / "gcode" / "mold_base.gcode").exists()
    written = load_manifest(out)
    assert written["print"]["printable"] == 1 and written["parts"]["mold_base"]["print"]["ok"] is False
    assert "FAILED: no STL" in (out / "print_report.md").read_text()
