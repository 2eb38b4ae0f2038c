"""whisker.coil.magnetics: every fidelity level against the converged reference and magpylib; hard cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from whisker.coil import magnetics as M
from whisker.design import default_design

D = default_design()
G = M.geometry(D)


def test_filament_matches_magpylib_field_to_1e6():
    # magpylib's own closed-form cylinder field (getB), integrated over the same coil nodes
    gaps = np.array([0.2, 2.5, 10.0])
    ref = M.k_magpylib(G, gaps, nodes=16, method="getB")
    fil = M.k_filament(G, gaps, nodes=16)
    assert np.allclose(fil, ref, rtol=1e-6)


def test_filament_matches_magpylib_getFT():
    # the independent force path: Collection of Circle loops, getFT with segment meshing
    ref = M.k_magpylib(G, [1.0], nodes=8, meshing=256, method="getFT")
    fil = M.k_filament(G, [1.0], nodes=8)
    assert abs(ref[0] / fil[0] - 1) < 1e-4


def test_filament_converges_with_nodes():
    gaps = np.array([0.0, 0.2, 1.0, 5.0])
    ref = M.k_filament(G, gaps, nodes=64)
    errs = [np.max(np.abs(M.k_filament(G, gaps, nodes=n) / ref - 1)) for n in (1, 2, 4, 8)]
    assert errs[0] > errs[1] > errs[2] > errs[3] or errs[3] < 1e-9
    assert errs[3] < 1e-5


def test_table_within_half_percent_of_reference_over_range():
    gaps = np.geomspace(0.2, 10.0, 301)
    ref = M.k_filament(G, gaps, nodes=M.REFERENCE_NODES)
    tab = M.force_per_ampere_N(D, gaps, model="table")
    assert np.max(np.abs(tab / ref - 1)) < 0.005
    assert np.max(np.abs(tab / ref - 1)) < 1e-4  # in fact far better than the target


def test_point_dipole_overestimates_at_millimetre_gaps():
    gaps = np.array([0.5, 2.0, 5.0])
    ref = M.k_filament(G, gaps, nodes=32)
    assert np.all(M.k_dipole(G, gaps) > ref * 1.05)
    assert np.all(M.k_dipole_field(G, gaps) > ref * 1.05)
    # ... and all models meet in the far field (d^-4 law)
    far = M.k_filament(G, [200.0], nodes=16)[0]
    assert abs(M.k_dipole(G, 200.0) / far - 1) < 1e-3
    assert abs(M.k_dipole_field(G, 200.0) / far - 1) < 1e-3


def test_gap_zero_and_tiny_gaps_finite():
    for model in ("dipole", "dipole_field", "filament", "table"):
        k = np.asarray(M.force_per_ampere_N(D, [0.0, 1e-12, 1e-6, 1e-3], model=model))
        assert np.all(np.isfinite(k)) and np.all(k > 0), model
    # continuous at contact
    k0, k1 = M.force_per_ampere_N(D, [0.0, 1e-9], model="filament")
    assert abs(k0 / k1 - 1) < 1e-6


def test_magnet_entering_the_bore_changes_sign_at_centre():
    g = M.CoilMagnet(1.0, 2.0, 4.0, 300, 0.4, 1.0, 1.3)   # small magnet fits the 2 mm bore
    centre = -(g.coil_length + g.magnet_height) / 2.0     # gap where the centres coincide
    k = M.k_per_ampere(g, [centre - 0.5, centre, centre + 0.5, 0.5], model="filament", nodes=24)
    assert abs(k[1]) < 1e-9 * abs(k[2])
    assert k[0] < 0 < k[2] and k[3] > 0
    assert abs(k[0] + k[2]) < 1e-9 * abs(k[2])           # antisymmetric about the centre
    kd = M.k_per_ampere(g, [centre - 0.5, centre, centre + 0.5], model="dipole_field")
    assert kd[0] < 0 < kd[2] and abs(kd[1]) < 1e-12
    with pytest.raises(M.MagneticsError, match="centre"):
        M.k_per_ampere(g, centre, model="dipole")


def test_magnet_that_cannot_enter_refuses_negative_gap():
    with pytest.raises(M.MagneticsError, match="cannot enter the coil bore"):
        M.force_per_ampere_N(D, -0.1)
    for bad in (np.nan, np.inf):
        with pytest.raises(M.MagneticsError, match="finite"):
            M.force_per_ampere_N(D, bad)
    with pytest.raises(M.MagneticsError, match="unknown model"):
        M.force_per_ampere_N(D, 1.0, model="fem")


@pytest.mark.parametrize("radius", ["outer", "inner"])
def test_coil_radius_equal_to_magnet_radius(radius):
    R = 2.0 if radius == "outer" else 0.5
    g = M.CoilMagnet(0.5, 2.0, 4.0, 600, R, 1.59, 1.32)
    for gap in (0.0, 1e-9, 0.05):
        k = [M.k_filament(g, gap, nodes=n)[()] for n in (32, 64, 128)]
        assert all(math.isfinite(x) and x > 0 for x in k)
        # the log singularity at the shared edge slows convergence but it still converges
        assert abs(k[2] / k[1] - 1) < abs(k[1] / k[0] - 1) + 1e-12
        assert abs(k[2] / k[1] - 1) < 2e-3


def test_vector_potential_near_m_equal_1_matches_thin_wire_limit():
    a = 2e-3
    for rho in (1e-4, 1e-6, 1e-9):
        A = M.loop_vector_potential(a, a + rho, 0.0)
        # close to the wire: A -> mu0/(2 pi) (ln(8a/rho) - 2) (Smythe; Landau-Lifshitz ECM 33)
        approx = M.MU0 / (2 * math.pi) * (math.log(8 * a / rho) - 2)
        assert abs(A / approx - 1) < 5 * rho / a * math.log(8 * a / rho) + 1e-6
    on_wire = M.loop_vector_potential(a, a, 0.0)
    assert np.isfinite(on_wire) and on_wire > M.loop_vector_potential(a, a + 1e-9, 0.0)


def test_vector_potential_small_m_branch_is_continuous_and_dipolar():
    a = 1e-3
    z = np.array([10, 50, 500, 5000]) * a  # m from ~1e-2 down to ~1e-8
    r = 0.5 * a
    A = M.loop_vector_potential(a, r, z)
    dip = M.MU0 * a * a * r / (4 * (a * a + r * r + z * z) ** 1.5)
    assert np.allclose(A[1:], dip[1:], rtol=2e-3)
    # both sides of the series switch (m = 1e-3) agree
    s = (a + r) ** 2
    z_switch = math.sqrt(4 * a * r / 1e-3 - s)
    lo, hi = M.loop_vector_potential(a, r, [z_switch * (1 - 1e-9), z_switch * (1 + 1e-9)])
    assert abs(lo / hi - 1) < 1e-7
    assert M.loop_vector_potential(a, 0.0, 0.0) == 0.0


@pytest.mark.parametrize("bad", [
    dict(coil_inner_radius=-0.1), dict(coil_outer_radius=0.0), dict(coil_length=-4.0), dict(turns=0),
    dict(magnet_radius=0.0), dict(magnet_height=-1.0), dict(remanence=float("nan")),
    dict(coil_inner_radius=2.5),
])
def test_bad_geometry_refused_with_name(bad):
    args = dict(coil_inner_radius=0.5, coil_outer_radius=2.0, coil_length=4.0, turns=600,
                magnet_radius=2.38, magnet_height=1.59, remanence=1.32)
    args.update(bad)
    with pytest.raises(M.MagneticsError, match=list(bad)[0]):
        M.CoilMagnet(**args)


def test_nodes_must_be_positive():
    with pytest.raises(M.MagneticsError, match="nodes"):
        M.k_filament(G, 1.0, nodes=0)


@settings(max_examples=40, deadline=None)
@given(a1=st.floats(0.0, 3.0), t=st.floats(0.05, 3.0), L=st.floats(0.2, 8.0), R=st.floats(0.2, 5.0),
       h=st.floats(0.1, 5.0), gap=st.floats(0.0, 30.0))
def test_property_all_models_finite_and_attractive(a1, t, L, R, h, gap):
    g = M.CoilMagnet(a1, a1 + t, L, 100, R, h, 1.2)
    if g.magnet_fits_bore and gap < 0:
        return
    ks = {m: float(M.k_per_ampere(g, gap, model=m)) for m in ("dipole", "dipole_field", "filament")}
    for m, k in ks.items():
        assert math.isfinite(k) and k > 0, (m, k)
    # no iron: linear in the ampere-turns and in the magnet's polarisation
    g2 = M.CoilMagnet(a1, a1 + t, L, 300, R, h, 0.6)
    assert abs(float(M.k_per_ampere(g2, gap, model="filament")) / ks["filament"] - 1.5) < 1e-9


@settings(max_examples=30, deadline=None)
@given(gap=st.floats(0.2, 10.0))
def test_property_table_matches_reference(gap):
    ref = float(M.k_filament(G, gap, nodes=M.REFERENCE_NODES))
    assert abs(float(M.force_per_ampere_N(D, gap)) / ref - 1) < 0.005


def test_table_falls_back_outside_its_range():
    far = M.TABLE_MAX_GAP_MM * 2
    k = M.force_per_ampere_N(D, np.array([1.0, far]))
    assert abs(k[1] / M.k_filament(G, far, nodes=M.REFERENCE_NODES) - 1) < 1e-9


def test_vectorised_shapes():
    g2 = np.linspace(0.5, 3, 6).reshape(2, 3)
    for m in ("dipole", "dipole_field", "filament", "table"):
        assert np.shape(M.force_per_ampere_N(D, g2, model=m)) == (2, 3)
    assert np.ndim(M.force_per_ampere_N(D, 1.0)) == 0
