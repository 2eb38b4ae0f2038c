"""The bobbin (resin coil former) and the winding jig, measured on their meshes."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from shapely.geometry import Point, Polygon

from whisker import coil as coil_calc
from whisker.cad.solids import bobbin, reference
from whisker.cad.verify import walls
from whisker.cad.solids import winding_jig as wj
from whisker.cad.verify.checks import describe_circles, holes, section, to_mesh
from whisker.design import default_design


@pytest.fixture(scope="module")
def d():
    return default_design()


@pytest.fixture(scope="module")
def mesh(d):
    return to_mesh(bobbin.bobbin(d), 0.005, 0.1)


def _x_section(mesh: trimesh.Trimesh, x: float):
    path = mesh.section(plane_origin=[x, 0, 0], plane_normal=[1, 0, 0])
    planar, _ = path.to_2D()
    return list(planar.polygons_full)


def test_core_bore_and_flange_on_the_coil_axis(d, mesh):
    L = bobbin.layout(d)
    core = _x_section(mesh, sum(L["core"]) / 2)
    assert len(core) == 1
    outer = 2 * math.sqrt(core[0].exterior.convex_hull.area / math.pi)
    assert outer == pytest.approx(d.coil.inner_diameter, abs=0.01)
    assert len(core[0].interiors) == 1
    bore = 2 * math.sqrt(Polygon(core[0].interiors[0]).area / math.pi)
    assert bore == pytest.approx(L["bore"], abs=0.01)
    flange = _x_section(mesh, sum(L["flange"]) / 2)
    assert 2 * math.sqrt(flange[0].exterior.convex_hull.area / math.pi) == pytest.approx(d.coil.outer_diameter, abs=0.01)


def test_rod_sits_in_the_tab_outside_the_winding(d, mesh):
    L = bobbin.layout(d)
    def first_hit(x):
        hits, _, _ = mesh.ray.intersects_location([[x, 0, 10.0]], [[0, 0, -1]], multiple_hits=True)
        return max(np.asarray(hits)[:, 2])

    R = d.whiskers.ring_radius
    assert first_hit(R) == pytest.approx(-d.rod_below_membrane, abs=1e-3)   # the socket's floor: the rod's end
    assert first_hit(R + L["socket_diameter"] / 2 + 0.1) == pytest.approx(L["tab_top"], abs=1e-3)
    rod, wound = reference.rod(d), bobbin.winding_envelope(d)
    assert rod.intersect(wound).Volume() < 1e-6 and rod.distance(wound) > 0.1
    assert rod.intersect(bobbin.bobbin(d)).Volume() < 1e-6


def test_lead_holes_beside_the_rod_and_marker_face_below(d, mesh):
    L = bobbin.layout(d)
    leads = [c for c in describe_circles(holes(section(mesh, (L["tab_top"] + L["tab_bottom"]) / 2)))
             if abs(c[2] - L["settings"].lead_hole) < 0.03]
    assert len(leads) == 2
    assert mesh.bounds[0, 2] == pytest.approx(d.marker_z, abs=1e-3)   # the face the camera sees
    face = section(mesh, d.marker_z + 0.01)
    marker = Point(d.whiskers.ring_radius, 0).buffer(d.coil.marker_diameter / 2)
    assert any(p.contains(marker) for p in face)


def test_turns_are_what_fits_the_window(d):
    """coil.turns = "auto": the turns that fit the former's window (whisker.design.former) at the fill
    factor, and the resistance is theirs: one source for the force model, the driver and the BOM."""
    from whisker.design import former

    w = coil_calc.winding(d)
    a1, a2, length = former.window(d)
    a_cu = math.pi * d.coil.wire_diameter ** 2 / 4
    assert w.turns == d.coil.turns == w.max_turns_at_fill == math.floor(d.winding.fill_factor * (a2 - a1) * length / a_cu)
    assert w.fits is True
    assert d.coil.resistance == pytest.approx(w.resistance_ohm, abs=1e-4)
    assert w.resistance_ohm == pytest.approx(
        coil_calc.ohm_per_m(d.coil.wire_diameter) * w.wire_length_mm / 1000, rel=1e-9)
    paper = coil_calc.winding(default_design("coil.turns=600"))
    assert paper.fits is False                     # the paper's 600 do not fit (issue 21)


def test_bobbin_walls_for_resin(d, mesh):
    c = walls.wall_check("bobbin", mesh, {**bobbin.bobbin_tools(d), **bobbin.edges(d)},
                         bobbin.layout(d)["settings"].min_wall)
    assert c.ok, c.line()


def test_jig_pocket_keys_the_bobbin_on_the_axis_and_one_flag_per_turn(d):
    L = wj.layout(d)
    m = to_mesh(wj.winding_jig(d), 0.01, 0.2)
    z1 = L["disc"][1]
    pocket = holes(section(m, z1 - L["pocket_depth"] / 2))
    assert len(pocket) == 1
    x0, y0, x1, y1 = pocket[0].bounds
    w, ty0, ty1 = L["tab"]
    c = d.print.clearance
    assert (x0, x1) == pytest.approx((-w / 2 - c, w / 2 + c), abs=0.01)
    assert (y0, y1) == pytest.approx((ty0 - c, ty1 + c), abs=0.01)   # the coil axis is the arbor's axis
    outline = np.asarray(section(m, (L["disc"][0] + z1) / 2)[0].exterior.coords)
    r = np.hypot(outline[:, 0], outline[:, 1])
    far = outline[r > L["settings"].disc_diameter / 2 + 0.5]
    assert len(far) and np.ptp(np.degrees(np.arctan2(far[:, 1], far[:, 0]))) < 30   # one flag
    assert r.max() == pytest.approx(math.hypot(L["settings"].disc_diameter / 2 + L["settings"].flag_length,
                                               L["settings"].flag_width / 2), abs=0.01)
    cw = walls.wall_check("winding_jig", m, {**wj.jig_tools(d), **wj.edges(d)}, d.print.min_wall)
    assert cw.ok, cw.line()


def test_bom_orders_the_wire_the_bobbin_takes_and_every_printed_part(d):
    from whisker import bom

    rows = {r.item: r for r in bom.make_bom(d)}
    w = coil_calc.winding(d)
    n, b = d.whiskers.count, d.bom
    want = n * (w.wire_length_mm + 2 * b.coil_lead_length) * (1 + b.wire_waste) / 1000
    assert rows["magnet_wire"].value == pytest.approx(want, abs=0.05)
    assert rows["coil"].specification.startswith(f"{w.turns} turns")
    assert all(f"print_{p}" in rows for p in bom.PRINTED_PARTS) and rows["bobbin"].value == n
    assert rows["insert_m3"].value == d.mount.mounting_hole_count + d.adapter.coupling_count and "ruthex" in rows["insert_m3"].specification


def test_wound_coil_is_bobbin_and_full_annulus_with_the_rod_outside(d):
    """The winding's cross-section, measured on its solid, is a full annulus - core to the turns'
    build - all along its length; the rod stays outside it, in the tab."""
    from whisker.cad.solids import reference

    L = bobbin.layout(d)
    wound = coil_calc.winding(d).wound_outer_diameter_mm
    mesh = to_mesh(reference.winding(d), 0.005, 0.1)
    for x in np.linspace(L["core"][0] + 0.05, L["core"][1] - 0.05, 7):
        polys = _x_section(mesh, x)
        assert len(polys) == 1 and len(polys[0].interiors) == 1
        outer = 2 * math.sqrt(Polygon(polys[0].exterior).area / math.pi)
        inner = 2 * math.sqrt(Polygon(polys[0].interiors[0]).area / math.pi)
        assert outer == pytest.approx(min(wound, L["winding_od"]), abs=0.01)
        assert inner == pytest.approx(d.coil.inner_diameter, abs=0.01)
        assert Point(0, 0).distance(polys[0].exterior) > 0  # concentric: the ring goes all the way round
    coil = reference.coil(d)
    assert coil.Volume() == pytest.approx(bobbin.bobbin(d).Volume() + reference.winding(d).Volume(), rel=1e-3)
    assert reference.rod(d).intersect(reference.winding(d)).Volume() < 1e-6
