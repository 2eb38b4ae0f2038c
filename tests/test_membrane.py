"""The membrane's stiffness from material data (whisker.mechanics): closed-form check, the model's
symmetry and scaling, the cache, the design's "auto", and bad input (one line, outputs untouched)."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.design import DesignError, default_design
from whisker.mechanics import membrane as M
from whisker.mechanics.materials import MaterialError, load_silicone, material_path, neo_hookean_shear_modulus
from whisker.mechanics.plate import flexural_rigidity, hub_tilt_stiffness

pytest.importorskip("skfem", reason="the membrane model needs the [fem] extra (installed by make)")


# ---- the closed form ------------------------------------------------------------------------

def test_fem_matches_the_clamped_plate_with_a_rigid_hub_within_5_percent():
    """A thin plate (span / thickness 30) clamped at r = 10 mm with a rigid hub 2.5 mm in radius (10
    thicknesses) tilted about a diameter: the 3D model against Kirchhoff's closed form."""
    from whisker.mechanics.fem import Inclusion, Plate, solve

    a, b, t, E, nu = 10.0, 2.5, 0.25, 1.0, 0.3
    outline = tuple((a * math.cos(x), a * math.sin(x)) for x in np.linspace(0, 2 * np.pi, 96, endpoint=False))
    mu, K = E / (2 * (1 + nu)), E / (3 * (1 - 2 * nu))
    sol = solve(Plate(outline, t, (Inclusion(0.0, 0.0, b),), None), mu, K, 1.5, 0.5, 1, axes=[(0.0, 1.0, 0.0)])
    k = hub_tilt_stiffness(a, b, t, E, nu)
    assert sol.stiffness.shape == (1, 1)
    assert abs(sol.stiffness[0, 0] / k - 1) < 0.05


@settings(max_examples=40, deadline=None)
@given(a=st.floats(2.0, 100.0), ratio=st.floats(0.05, 0.8), t=st.floats(0.01, 5.0), E=st.floats(0.01, 1e3),
       nu=st.floats(0.0, 0.499), s=st.floats(0.1, 10.0))
def test_property_closed_form_scales_as_plate_theory(a, ratio, t, E, nu, s):
    """k = D_p f(b/a): proportional to E t^3 / (1 - nu^2), unchanged when a and b scale together, and
    growing with the hub."""
    b = ratio * a
    k = hub_tilt_stiffness(a, b, t, E, nu)
    assert k > 0 and math.isfinite(k)
    assert hub_tilt_stiffness(s * a, s * b, t, E, nu) == pytest.approx(k, rel=1e-6)
    assert hub_tilt_stiffness(a, b, s * t, s * E, nu) == pytest.approx(k * s ** 4, rel=1e-6)
    assert k / flexural_rigidity(E, t, nu) == pytest.approx(hub_tilt_stiffness(a, b, 1.0, 1.0, 0.0) * 12, rel=1e-6)
    assert hub_tilt_stiffness(a, min(0.95 * a, 1.1 * b), t, E, nu) > k


def test_closed_form_refuses_a_hub_outside_the_plate():
    with pytest.raises(ValueError, match="hub radius"):
        hub_tilt_stiffness(5.0, 6.0, 1.0, 1.0, 0.3)


@settings(max_examples=30, deadline=None)
@given(p=st.floats(1e-4, 10.0), lam=st.floats(1.05, 10.0))
def test_property_neo_hookean_one_point_fit_reproduces_its_point(p, lam):
    mu = neo_hookean_shear_modulus(p, lam)
    assert mu * (lam - lam ** -2) == pytest.approx(p, rel=1e-12)


# ---- the default design's membrane ----------------------------------------------------------

def test_default_design_stiffness_is_the_model_and_not_a_fit():
    d = default_design()
    assert d.mechanics.rotational_stiffness == "auto"
    k = M.design_stiffness_Nmm_per_rad(d)
    assert k == M.rotational_stiffness_Nmm_per_rad(d)
    # the model's per-whisker value lies inside the first-principles bracket for 3 mm Ecoflex
    assert 0.3 < k < 3.0
    # a number in the file overrides the model
    assert M.design_stiffness_Nmm_per_rad(default_design("mechanics.rotational_stiffness=1.7")) == 1.7


def test_stiffness_matrix_has_the_ring_symmetry():
    d = default_design()
    K = M.stiffness_matrix(d)
    n = d.whiskers.count
    assert K.shape == (n, n)
    assert np.allclose(K, K.T, rtol=0, atol=1e-9 * K[0, 0])
    # 8 rods on an octagon, each facing a flat: every whisker sees the same membrane (circulant K)
    for i in range(n):
        assert np.allclose(np.roll(K[0], i), K[i], rtol=2e-3, atol=1e-4 * K[0, 0])
    # positive definite; a neighbour driven the same way helps (negative off-diagonal)
    assert np.all(np.linalg.eigvalsh(K) > 0)
    assert K[0, 1] < 0
    C = M.coupling(d)
    assert np.allclose(np.diag(C), 1.0) and np.all(C[1:, 0] > 0) and np.all(C[1:, 0] < 0.5)
    # every whisker driven together is softer than one alone: the inner membrane turns with them
    assert M.rotational_stiffness_Nmm_per_rad(d) < M.single_whisker_stiffness_Nmm_per_rad(d)
    assert M.driven_stiffness_Nmm_per_rad(d, [0]) == pytest.approx(1 / np.linalg.inv(K)[0, 0])


def test_model_is_linear_in_the_modulus_and_stiffens_with_thickness():
    d = default_design()
    g = M.MembraneGeometry.from_design(d)
    mu, K = 0.04, 1000.0
    k1 = M.tilt_stiffness(g, mu, K, 4.0)
    k2 = M.tilt_stiffness(g, 2 * mu, 2 * K, 4.0)
    assert np.allclose(k2.K, 2 * k1.K, rtol=1e-6)
    k3 = M.tilt_stiffness(g, 2 * mu, K, 4.0)          # K >> mu: k follows mu
    assert k3.all_driven_Nmm_per_rad == pytest.approx(2 * k1.all_driven_Nmm_per_rad, rel=2e-3)
    thick = M.MembraneGeometry(**{**g.__dict__, "thickness": 4.0})
    assert M.tilt_stiffness(thick, mu, K, 4.0).all_driven_Nmm_per_rad > k1.all_driven_Nmm_per_rad


def test_shipped_table_holds_the_default_design(tmp_path, monkeypatch):
    """The core install resolves the default design without the FEM: its entry ships in hw/."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    M._MEMO.clear()
    d = default_design()
    key = M.membrane_key(M.model_inputs(d))
    assert key in json.loads(M.shipped_path().read_text())
    e = M.lookup(d, compute=False)
    assert e["key"] == key and not list(tmp_path.rglob("*.json"))


def test_cache_is_written_once_and_read_back(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    d = default_design("membrane.thickness=3.5")
    e = M.lookup(d)
    path = M.cache_dir() / f"{e['key']}.json"
    assert path.is_file()
    stamp = path.stat().st_mtime_ns
    assert M.lookup(d) == json.loads(path.read_text())
    assert path.stat().st_mtime_ns == stamp
    # a value the membrane does not read leaves the key
    assert M.membrane_key(M.model_inputs(default_design("membrane.thickness=3.5", "drive.guard_margin=4"))) == e["key"]


# ---- bad input: one line, outputs untouched ---------------------------------------------------

def test_membrane_too_thin_to_mesh_is_one_line_and_caches_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    d = default_design("membrane.thickness=0.01", "mechanics.rotational_stiffness=1.0")
    with pytest.raises(M.MembraneError, match="too thin to mesh") as err:
        M.lookup(d)
    assert "\n" not in str(err.value) and "membrane.thickness" in str(err.value)
    assert not list(tmp_path.rglob("*.json"))


def test_missing_material_field_is_one_line(tmp_path):
    src = material_path("Ecoflex 00-30").read_text()
    bad = tmp_path / "ecoflex_00_30.toml"
    bad.write_text(src.replace("modulus_100 = 0.0689", "# modulus_100 removed"))
    with pytest.raises(MaterialError, match=r"missing field datasheet\.modulus_100") as err:
        load_silicone(bad)
    assert "\n" not in str(err.value)
    bad.write_text(src.replace("bulk_modulus = 1000.0", ""))
    with pytest.raises(MaterialError, match=r"hyperelastic\.bulk_modulus"):
        load_silicone(bad)


def test_missing_material_field_leaves_the_cache_and_the_design_refuses(tmp_path, monkeypatch):
    """A material file without a field: the design's stiffness is refused in one line; no cache file."""
    hw = tmp_path / "hw"
    shutil.copytree(material_path("Ecoflex 00-30").parent.parent, hw, ignore=shutil.ignore_patterns("cad", "pcb"))
    mat = hw / "materials" / "ecoflex_00_30.toml"
    mat.write_text(mat.read_text().replace("fit_stretch = 2.0", ""))
    monkeypatch.setattr("whisker.resources.hw_dir", lambda: hw)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    M._MEMO.clear()
    with pytest.raises(M.MembraneError, match=r"missing field hyperelastic\.fit_stretch") as err:
        M.design_stiffness_Nmm_per_rad(default_design())
    assert "\n" not in str(err.value)
    assert not (tmp_path / "cache").exists()
    M._MEMO.clear()


def test_unknown_material_names_the_known_ones():
    with pytest.raises(M.MembraneError, match="known: ecoflex_00_30"):
        M.lookup(default_design('membrane.material="Dragon Skin 10"'))


def test_rods_on_the_glued_rim_are_refused():
    g = M.MembraneGeometry.from_design(default_design())
    bad = M.MembraneGeometry(**{**g.__dict__, "ring_radius": g.clamp_radius - 0.2})
    with pytest.raises(M.MembraneError, match="seat's opening"):
        M.tilt_stiffness(bad, 0.04, 1000.0)


def test_stiffness_value_in_the_file_is_validated():
    with pytest.raises(DesignError, match="rotational_stiffness"):
        default_design("mechanics.rotational_stiffness=-1")
    with pytest.raises(DesignError, match="rotational_stiffness"):
        default_design('mechanics.rotational_stiffness="soft"')


# ---- the docs' numbers come from the model ----------------------------------------------------

def test_docs_state_the_models_numbers():
    """docs/coil.md and docs/membrane.md quote the default design's stiffness and pull-in: they must be
    the model's (to the digits written), so a model change that leaves the docs behind fails here."""
    import re
    from pathlib import Path

    from whisker.coil import pull_in, resistance_ohm

    root = Path(__file__).resolve().parents[1]
    d = default_design()
    k_all, k_one = M.rotational_stiffness_Nmm_per_rad(d), M.single_whisker_stiffness_Nmm_per_rad(d)
    v_pull = pull_in(d)[0] * resistance_ohm(d)
    coil_md = re.sub(r"\s+", " ", (root / "docs" / "coil.md").read_text())
    m = re.search(r"\*\*([\d.]+) N mm/rad\*\* per whisker with every whisker driven together \(([\d.]+) for one", coil_md)
    assert m and float(m[1]) == round(k_all, 3) and float(m[2]) == round(k_one, 3)
    from whisker.coil.tilt import stop_reach_current_A
    i_stop = stop_reach_current_A(d)
    m = re.search(r"\(([\d.]+) N mm/rad, every whisker driven\) \| on the end stop at ([\d.]+) deg, reached from "
                  r"([\d.]+) A = ([\d.]+) V \(without the stop: pull-in above ([\d.]+) V\)", coil_md)
    assert m and float(m[1]) == round(k_all, 3) and float(m[2]) == d.whiskers.max_deflection_deg
    assert float(m[3]) == round(i_stop, 3) and float(m[4]) == round(i_stop * resistance_ohm(d), 2)
    assert float(m[5]) == round(v_pull, 2)
    m = re.search(r"the paper's 3 V is past pull-in \(([\d.]+) V\)", coil_md)
    assert m and float(m[1]) == round(v_pull, 2)
    mem_md = re.sub(r"\s+", " ", (root / "docs" / "membrane.md").read_text())
    m = re.search(r"every whisker driven together: \*\*([\d.]+) N mm/rad\*\*, one whisker alone \*\*([\d.]+) N mm/rad\*\*",
                  mem_md)
    assert m and float(m[1]) == round(k_all, 3) and float(m[2]) == round(k_one, 3)
    m = re.search(r"two opposite whiskers driven / four \(every other one\) \| ([\d.]+) / ([\d.]+) N mm/rad", mem_md)
    assert m and float(m[1]) == round(M.driven_stiffness_Nmm_per_rad(d, [0, 4]), 3)
    assert float(m[2]) == round(M.driven_stiffness_Nmm_per_rad(d, [0, 2, 4, 6]), 3)
    m = re.search(r"pull-in of the default coil \(370 turns, 5.87 ohm\), every whisker driven \| ([\d.]+) V", mem_md)
    assert m and float(m[1]) == round(v_pull, 2)
    C = M.coupling(d)
    m = re.search(r"tilts its neighbours by ([\d.]+), ([\d.]+), ([\d.]+) and ([\d.]+) of its own tilt", mem_md)
    assert m and [float(x) for x in m.groups()] == [round(float(C[j, 0]), 3) for j in range(1, 5)]


def test_docs_convergence_table_is_the_benchmarks():
    """docs/membrane.md's convergence rows are benchmarks/results/membrane.csv's (regenerated by
    `make bench-membrane`), and that run converged: < 2 % change at the last refinement."""
    import csv
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    rows = list(csv.DictReader((root / "benchmarks" / "results" / "membrane.csv").open()))
    k = [float(r["k_all_Nmm_per_rad"]) for r in rows]
    assert abs(k[-1] / k[-2] - 1) < 0.02
    assert float(rows[-1]["mesh_mm"]) < M.DEFAULT_MESH_SIZE_MM < float(rows[0]["mesh_mm"])
    doc = (root / "docs" / "membrane.md").read_text()
    for r in rows:
        h = float(r["mesh_mm"])
        m = re.search(rf"\| (?:\*\*)?{h:.1f}(?: \(default\)\*\*)? \| (\d+) \| ([\d ]+) \| ([\d.]+) \|", doc)
        assert m, f"no row for the {h} mm mesh"
        assert int(m[1]) == int(r["layers"]) and int(m[2].replace(" ", "")) == int(r["unknowns"])
        assert float(m[3]) == round(float(r["k_all_Nmm_per_rad"]), 4)
    assert re.search(rf"\*\*{M.DEFAULT_MESH_SIZE_MM:.1f} \(default\)\*\*", doc)


def test_cli_refuses_a_membrane_too_thin_to_mesh_in_one_line_and_writes_nothing(tmp_path):
    from conftest import run_cli

    out = tmp_path / "coil"
    out.mkdir()
    (out / "report.txt").write_text("the previous report")
    res = run_cli("coil", "report", "--set", "membrane.thickness=0.01", "--out", str(out))
    assert res.returncode == 2, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "too thin to mesh" in res.stderr
    assert [p.name for p in out.iterdir()] == ["report.txt"] and (out / "report.txt").read_text() == "the previous report"


def test_core_install_without_the_fem_extra_says_what_to_install(tmp_path, monkeypatch):
    """The Pi's core install: the default design resolves from the shipped table; another membrane
    geometry says in one line which extra computes it (or to give the number)."""
    import sys

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setitem(sys.modules, "skfem", None)      # import skfem -> ModuleNotFoundError
    M._MEMO.clear()
    assert M.design_stiffness_Nmm_per_rad(default_design()) > 0
    with pytest.raises(M.MembraneError, match=r"pip install 'whisker-array\[fem\]'") as err:
        M.design_stiffness_Nmm_per_rad(default_design("membrane.thickness=3.3"))
    assert "\n" not in str(err.value) and "as a number" in str(err.value)
    assert M.design_stiffness_Nmm_per_rad(default_design("membrane.thickness=3.3", "mechanics.rotational_stiffness=0.9")) == 0.9
    M._MEMO.clear()


def test_docs_paper_comparison_is_the_benchmarks():
    """docs/membrane.md's comparison with the authors' ~15 deg quotes benchmarks/results/membrane.md."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    bench = (root / "benchmarks" / "results" / "membrane.md").read_text()
    doc = (root / "docs" / "membrane.md").read_text()
    section = doc[doc.index("## The paper's sensor"):]
    rows = re.findall(r"^\| ([^|]+) \| ([^|]+) \| ([\d.]+) \| ([^|]+) \| ~15 deg \|$", section, flags=re.M)
    assert len(rows) == 6
    for _, _, k, tilt in rows:
        assert f"| {k} |" in bench
        for volts in re.findall(r"pull-in ([\d.]+ V)", tilt):
            assert f"pull-in {volts}" in bench
