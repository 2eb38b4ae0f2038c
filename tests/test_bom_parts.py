"""Part numbers in the BOM come from hw/bom_parts.csv (vendor and source named); every printed part
of `make stl` and every fastened joint's screws and inserts have a BOM line."""

from __future__ import annotations

import re

import pytest

from conftest import load_manifest
from whisker import bom
from whisker.bom import BomError, bom_rows, coil_wire
from whisker.part_numbers import find_part, load_parts_table
from whisker.cad.solids import adapter, cover, mount
from whisker.design import default_design


def _rows(d):
    vols = {name: 1000.0 * (i + 1) for i, name in enumerate((*bom.PRINTED_PARTS, *bom.RESIN_PARTS, bom.MEMBRANE_PART))}
    return {r.item: r for r in bom_rows(d, vols, coil_wire(d))}


@pytest.fixture(scope="module")
def rows():
    return _rows(default_design())


def test_table_rows_name_vendor_and_source():
    table = load_parts_table()
    assert table and all(p.vendor and p.source and p.part_number for p in table)
    assert {p.kind for p in table} <= {"exact", "example"}


def test_well_known_parts_carry_their_numbers(rows):
    want = {"magnet": "D31", "ecoflex": "Ecoflex 00-30", "magnet_wire": "38 AWG", "h_bridge": "L298N",
            "camera": "OV5647", "lens": "M12 x 0.5", "raspberry_pi": "Raspberry Pi 4 Model B"}
    for item, number in want.items():
        assert number in rows[item].part_number, item
        assert rows[item].example_source  # the vendor and where the number comes from
    for item, r in rows.items():
        if item.startswith("screw_"):
            size, length = re.fullmatch(r"screw_m([\d.]+)x([\d.]+)", item).groups()
            assert r.part_number == f"ISO 4762 - M{size.upper()} x {length} - 8.8 (DIN 912 M{size} x {length})"
        if item.startswith("insert_"):
            assert r.part_number.startswith("ruthex RX-M")
    assert any(i.startswith("screw_") for i in rows) and any(i.startswith("insert_") for i in rows)


def test_part_numbers_follow_the_design():
    odd = _rows(default_design("magnet.diameter=5", "camera.board=\"rpi_v2\""))
    assert odd["magnet"].part_number == ""          # a 5 mm magnet is not a K&J D31
    assert "Camera Module 2" in odd["camera"].part_number
    assert "lens" not in odd                          # the Pi boards come with their lens
    assert find_part("pwm_expander", default_design("wiring.expander=\"pca9685\"")).part_number == "Adafruit 815"


def test_bad_table_is_one_line(tmp_path):
    p = tmp_path / "parts.csv"
    p.write_text("item,part_number,vendor,kind,matches,source\nmagnet,D31,,exact,,somewhere\n")
    with pytest.raises(BomError) as e:
        load_parts_table(p)
    assert "\n" not in str(e.value) and "row 1" in str(e.value)
    p.write_text("item,part_number,vendor,kind,matches,source\nmagnet,D31,K&J,exact,magnet.colour=red,x\n")
    with pytest.raises(BomError, match="unknown design value 'magnet.colour'"):
        find_part("magnet", default_design(), load_parts_table(p))


def test_every_printed_part_of_make_stl_has_a_bom_line(default_build, rows):
    manifest = load_manifest(default_build)
    printed = {n for n, p in manifest["parts"].items() if p.get("printable")} | set(bom.RESIN_PARTS)
    assert printed - {"bobbin"} == set(bom.PRINTED_PARTS) | set(bom.CALIBRATION_PARTS)
    for name in printed:
        item = name if name in bom.RESIN_PARTS else f"print_{name}"
        assert item in rows and rows[item].value >= 1, name


def test_every_fastened_joint_has_its_screws_and_inserts(rows):
    """Screw holes counted from the parts' own named cuts (not from the BOM's joint list) equal the
    screws bought, and the insert holes equal the inserts."""
    d = default_design()
    tools = {**{f"mount/{k}": v for k, v in mount.mount_tools(d).items()},
             **{f"adapter/{k}": v for k, v in adapter.adapter_tools(d).items()},
             **{f"plate/{k}": v for k, v in adapter.plate_tools(d).items()},
             **{f"cover/{k}": v for k, v in cover.cover_tools(d).items()}}
    screws = [k for k in tools if re.search(r"(camera M2 hole|mount screw|coupling screw|robot bolt|cover/screw) \d+$", k)]
    inserts = [k for k in tools if re.search(r"coupling insert \d+$", k)]
    if d.fasteners.mount_joint == "insert":
        inserts += [k for k in tools if re.search(r"mount/mounting hole \d+$", k)]
    bought = sum(r.value for i, r in rows.items() if i.startswith("screw_"))
    assert bought == len(screws) == 4 + 3 + 4 + 4 + 2
    assert sum(r.value for i, r in rows.items() if i.startswith("insert_")) == len(inserts) == 3 + 4
