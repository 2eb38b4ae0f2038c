"""The fastener table and the hole / screw-length / BOM rules built on it (whisker.design.fasteners)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.design import fasteners as fz

SIZES = ("M2", "M2.5", "M3", "M5", "M6")


def test_table_covers_the_sizes_with_iso_273_holes():
    t = fz.load_table()
    assert set(SIZES) <= set(t)
    # ISO 273 medium series, spot values every printed-parts designer knows
    assert t["M3"].clear_medium == 3.4 and t["M6"].clear_medium == 6.6 and t["M2"].clear_fine == 2.2
    for f in t.values():
        assert f.tap_pilot < f.nominal < f.clear_fine < f.insert_hole < f.insert_od


@pytest.mark.parametrize("kind,attr", [("through", "clear_medium"), ("tap", "tap_pilot"), ("insert", "insert_hole")])
def test_hole_follows_the_kind(kind, attr):
    h = fz.hole("M3", kind)
    assert h.diameter == getattr(fz.fastener("M3"), attr)
    assert (h.depth is not None) == (kind == "insert")


def test_unknown_size_and_kind_are_one_line_naming_the_known_ones():
    with pytest.raises(fz.FastenerError) as e:
        fz.hole("M4", "insert")
    msg = str(e.value)
    assert "\n" not in msg and "'M4'" in msg and all(s in msg for s in SIZES)
    with pytest.raises(fz.FastenerError, match="known: insert, tap, through"):
        fz.hole("M3", "glue")


def test_insert_longer_than_its_wall_is_refused():
    f = fz.fastener("M3")
    assert fz.hole("M3", "insert", wall=f.insert_hole_depth).depth == f.insert_hole_depth
    with pytest.raises(fz.FastenerError) as e:
        fz.hole("M3", "insert", wall=f.insert_hole_depth - 0.1)
    assert "\n" not in str(e.value) and "insert" in str(e.value) and "wall" in str(e.value)


@settings(max_examples=200, deadline=None)
@given(size=st.sampled_from(SIZES), kind=st.sampled_from(fz.KINDS), clamp=st.floats(0, 40))
def test_screw_length_is_stock_and_engagement_in_range(size, kind, clamp):
    f = fz.fastener(size)
    lo, hi = f.engagement(kind)
    try:
        length, engage = fz.screw_length(size, kind, clamp)
    except fz.FastenerError as err:
        # refused only when no stock length lands in the range
        assert not any(lo <= s - clamp <= hi for s in f.stock_lengths), str(err)
        return
    assert length in f.stock_lengths
    assert lo - 1e-9 <= engage <= hi + 1e-9
    assert engage == pytest.approx(length - clamp)
    # the shortest such length: the next shorter stock length would not engage enough
    shorter = [s for s in f.stock_lengths if s < length]
    assert not shorter or shorter[-1] - clamp < lo - 1e-9 or shorter[-1] - clamp > hi + 1e-9


def test_flange_thread_depth_limits_the_screw():
    # M6 through a 10 mm plate into a flange with 8 mm of thread: 16 mm (6 mm engaged), not 20
    assert fz.screw_length("M6", "through", 10.0, engage_max=8.0) == (16.0, 6.0)
    with pytest.raises(fz.FastenerError, match="no stock M6 screw"):
        fz.screw_length("M6", "through", 10.0, engage_max=5.0)


def test_bom_lines_sum_screws_and_inserts():
    joints = [fz.Joint("camera board", "M2", "insert", 4, 1.0), fz.Joint("cover", "M2", "insert", 2, 1.0),
              fz.Joint("adapter", "M6", "through", 4, 10.0, engage_max=8.0)]
    lines = {ln["item"]: ln for ln in fz.bom_lines(joints)}
    assert lines["insert_m2"]["quantity"] == 6 and "ruthex" in lines["insert_m2"]["specification"]
    m2 = [ln for k, ln in lines.items() if k.startswith("screw_m2x")]
    assert sum(ln["quantity"] for ln in m2) == 6
    assert lines["screw_m6x16"]["quantity"] == 4
    assert "insert_m6" not in lines


def test_bad_table_rows_are_one_line():
    head = (fz.TABLE.read_text().splitlines())
    rows = [ln for ln in head if not ln.startswith("#")]
    broken = rows[0] + "\n" + rows[1].replace(",2.2,2.4,2.6,", ",2.6,2.4,2.2,") + "\n"
    with pytest.raises(fz.FastenerError) as e:
        fz.parse_table(broken, "t.csv")
    assert "\n" not in str(e.value) and "M2" in str(e.value) and "clearance" in str(e.value)
