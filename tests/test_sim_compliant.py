"""Compliant contact (whisker.sim.effects.contact_law, materials, compliant): Hertz, its MuJoCo mapping checked
on a single sphere-plane contact, the materials data, the plan and the build."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whisker.sim import load_scene, plan, scene_design
from whisker.sim.effects import compliant
from whisker.sim.effects.contact_law import (contact_radius_m, effective_modulus_Pa, effective_radius_m, hertz_force_N,
                                     hertz_indentation_m, hertz_stiffness_N_m, mujoco_contact, mujoco_force_N)
from whisker.coil.kinematics import whisker_body
from whisker.sim.materials import Material
from whisker.sim.protocol import Placement, grasp_level, grasp_scene
from whisker.sim.scene import SceneError, scene_with_overrides

SCENES = Path(__file__).resolve().parents[1] / "software" / "whisker" / "sim" / "scenes"
LOADS_N = (1e-3, 2e-3, 5e-3, 10e-3, 20e-3)          # the range a whisker tip presses


# --- Hertz ------------------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(F=st.floats(1e-5, 1.0), E=st.floats(1e2, 1e11), R=st.floats(1e-5, 1e-1))
def test_hertz_indentation_inverts_the_force_and_stiffness_is_1_5_F_over_delta(F, E, R):
    d = float(hertz_indentation_m(F, E, R))
    assert math.isclose(float(hertz_force_N(d, E, R)), F, rel_tol=1e-9)
    assert math.isclose(hertz_stiffness_N_m(F, E, R), 1.5 * F / d, rel_tol=1e-9)
    assert math.isclose(contact_radius_m(F, E, R) ** 2, R * d, rel_tol=1e-9)


@given(E1=st.floats(1e3, 1e11), E2=st.floats(1e3, 1e11), nu1=st.floats(0, 0.5), nu2=st.floats(0, 0.5))
def test_effective_modulus_is_symmetric_and_below_the_softer_plane_strain_modulus(E1, E2, nu1, nu2):
    e = effective_modulus_Pa(E1, nu1, E2, nu2)
    assert math.isclose(e, effective_modulus_Pa(E2, nu2, E1, nu1), rel_tol=1e-12)
    assert e <= min(E1 / (1 - nu1 ** 2), E2 / (1 - nu2 ** 2)) * (1 + 1e-12)


def test_hertz_known_value_and_rigid_limits():
    # steel ball (R 10 mm) on steel at 10 N: E* = 115 GPa; delta in the other closed form,
    # (9 F^2 / (16 E*^2 R))^(1/3) (Johnson eq. 4.23): 0.75 um
    es = effective_modulus_Pa(210e9, 0.3, 210e9, 0.3)
    assert es == pytest.approx(115.4e9, rel=1e-3)
    assert float(hertz_indentation_m(10.0, es, 10e-3)) == pytest.approx((9 * 100 / (16 * es ** 2 * 10e-3)) ** (1 / 3), rel=1e-9)
    assert float(hertz_indentation_m(10.0, es, 10e-3)) == pytest.approx(0.750e-6, rel=1e-2)
    assert effective_modulus_Pa(5e6, 0.3, math.inf, 0.0) == pytest.approx(5e6 / 0.91)
    assert effective_radius_m(1e-3) == 1e-3 and effective_radius_m(2e-3, 2e-3) == pytest.approx(1e-3)
    with pytest.raises(ValueError, match="both bodies are rigid"):
        effective_modulus_Pa(math.inf, 0.3, math.inf, 0.3)
    with pytest.raises(ValueError, match="load range"):
        mujoco_contact(1e6, 1e-3, 100.0, load_range_N=(2e-3, 1e-3))


@settings(max_examples=40, deadline=None)
@given(E=st.floats(1e3, 1e9), R=st.floats(1e-4, 1e-2), A=st.floats(1.0, 1e5))
def test_the_mapping_follows_hertz_over_the_load_range_at_rest(E, R, A):
    """MuJoCo's static force law K d^2/(1-d) r / A with the chosen solref/solimp against Hertz:
    the indentation under each load within 5 % (the fit's worst force error is ~6.4 %)."""
    c = mujoco_contact(E, R, A)
    r = np.geomspace(float(hertz_indentation_m(1e-3, E, R)), float(hertz_indentation_m(20e-3, E, R)), 40)
    F = mujoco_force_N(r, c.solref, c.solimp, A)
    assert np.all(np.diff(F) > 0)
    # the indentation MuJoCo settles at under F, against Hertz's under the same F
    d_hertz = hertz_indentation_m(F, E, R)
    assert np.max(np.abs(r / d_hertz - 1)) < 0.05
    assert c.solref[0] < 0 and c.solref[1] < 0 and 0.9 <= c.solimp[0] < c.solimp[1] < 1


# --- a single sphere on a plane in MuJoCo ------------------------------------------------------

def _sphere_on_plane(E, nu, R, mass_kg, loss, dt):
    import mujoco

    xml = (f'<mujoco><option timestep="{dt}" gravity="0 0 0"/><worldbody>'
           '<geom type="plane" size="1 1 0.1" priority="0"/>'
           f'<body name="ball" pos="0 0 {R}"><freejoint/><geom name="s" type="sphere" size="{R}" '
           f'mass="{mass_kg}" priority="1"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    A = float(m.body_invweight0[1, 0])            # MuJoCo's diagApprox of the ball-plane pair
    c = mujoco_contact(effective_modulus_Pa(E, nu, math.inf, 0.0), R, A, loss_factor=loss)
    m.geom_solref[1] = c.solref
    m.geom_solimp[1] = c.solimp
    return mujoco, m, d


@pytest.mark.parametrize("E, nu, R_mm, mass_g", [(2e4, 0.1, 7.5, 0.33),      # a pom-pom-like pile
                                                  (4e6, 0.33, 7.0, 0.15)])    # the foam ball
def test_sphere_plane_indentation_within_10_percent_of_hertz_over_1_to_20_mN(E, nu, R_mm, mass_g):
    R = R_mm * 1e-3
    mujoco, m, d = _sphere_on_plane(E, nu, R, mass_g * 1e-3, loss=1.0, dt=1e-4)
    E_star = effective_modulus_Pa(E, nu, math.inf, 0.0)
    for F in LOADS_N:
        mujoco.mj_resetData(m, d)
        d.qpos[2] = R
        d.xfrc_applied[1, 2] = -F                     # press the ball onto the plane with F
        mujoco.mj_step(m, d, 6000)
        assert d.ncon == 1 and abs(d.qvel[2]) < 1e-6, "not settled"
        pen = -float(d.contact[0].dist)
        hertz = float(hertz_indentation_m(F, E_star, R))
        assert pen == pytest.approx(hertz, rel=0.10), (F, pen, hertz)


# --- materials, plan, build --------------------------------------------------------------------

def test_materials_file_values_sit_in_their_ranges_with_sources():
    s = load_scene(SCENES / "grasp.toml")
    assert {"sand cap", "polyolefin foam", "acrylic pile", "paper petal", "popcorn", "pine cone scale"} <= set(s.materials)
    for name, m in s.materials.items():
        lo, hi = m.youngs_modulus_range_Pa
        assert lo <= m.youngs_modulus_Pa <= hi and len(m.source) > 20, name
    assert all(o.material in s.materials for o in s.objects) and s.contact.tip_material == "sand cap"


def test_a_value_outside_its_published_range_or_an_unknown_material_is_refused_in_one_line():
    s = load_scene(SCENES / "grasp.toml")
    with pytest.raises(SceneError, match="outside its published range") as e:
        scene_with_overrides(s, ["materials.polyolefin foam.youngs_modulus_Pa=1e9"])
    assert "\n" not in str(e.value)
    with pytest.raises(SceneError, match="no material named"):
        scene_with_overrides(s, ["materials.steel.poisson=0.3"])
    with pytest.raises(SceneError, match="not in the scene's materials"):
        scene_with_overrides(s, ["objects.pom-pom.material=\"felt\""])
    with pytest.raises(ValueError, match="friction needs friction_range"):
        Material(youngs_modulus_Pa=1e6, youngs_modulus_range_Pa=(1e5, 1e7), poisson=0.3, poisson_range=(0.2, 0.4),
                 loss_factor=0.1, loss_factor_range=(0.05, 0.2), friction=0.5, source="a handbook")


def _attempt_scene(s, name, n=8):
    d = scene_design(s)
    o = next(o for o in s.objects if o.name == name)
    return grasp_scene(s, o, list(range(n)), level=grasp_level(d)), d


def test_explain_lists_compliance_only_when_materials_call_for_it():
    s = load_scene(SCENES / "grasp.toml")
    a, d = _attempt_scene(s, "pom-pom")
    p = plan(a, d)
    assert p.built("compliance") and "pom-pom (E* 20" in p.effect("compliance").reason
    assert "compliance" in p.explain() and p.names.index("contact") < p.names.index("compliance")
    off = plan(scene_with_overrides(a, ["fidelity.compliance=off"]), d)
    assert not off.built("compliance") and "'off'" in off.effect("compliance").reason
    bare = a.with_(contact={**a.contact.model_dump(), "tip_material": None},
                   objects=[{**a.objects[0].model_dump(), "material": None}])
    assert not plan(bare, d).built("compliance") and "no object or tip names a material" in plan(bare, d).effect("compliance").reason
    # a stiff pair at a coarse step stays rigid, and the reason names the step it would need
    # a pair stiffer than MuJoCo's rigid contact stays rigid (the step resolves nothing stiffer)
    pine, _ = _attempt_scene(s, "mini pinecone")
    q = plan(pine, d)
    assert not q.built("compliance") and "mini pinecone (E* 2" in q.effect("compliance").reason
    assert "stiffer than the rigid contact" in q.effect("compliance").reason
    # a soft pair whose ringing the step cannot follow stays rigid, and the reason names the step it needs
    coarse = scene_with_overrides(a, ["materials.acrylic pile.youngs_modulus_Pa=5e5", "scene.timestep=0.004"])
    q = plan(coarse, d)
    assert not q.built("compliance") and "needs dt <=" in q.effect("compliance").reason
    # no objects: no contact, so no compliance either
    empty = a.with_(objects=[])
    assert not plan(empty, d).built("compliance")


def test_build_sets_the_pairs_with_the_compiled_inverse_masses():
    from whisker.sim.mj import MjScene

    s = load_scene(SCENES / "grasp.toml")
    a, d = _attempt_scene(s, "pom-pom")
    body = whisker_body(d)
    sim = MjScene(a, d, plan(a, d), body)
    mj, m = sim.mujoco, sim.model
    # the plan's estimate of MuJoCo's body_invweight0 (whisker and object) matches the compiled model
    w0 = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, "w0")
    assert float(m.body_invweight0[w0, 0]) == pytest.approx(compliant.whisker_inv_mass(body), rel=0.01)
    (p,) = compliant.pairs(a, d, body)
    g = mj.mj_name2id(m, mj.mjtObj.mjOBJ_GEOM, "obj:pom-pom:0")
    assert np.allclose(m.geom_solref[g], p.solref, rtol=0.01) and np.allclose(m.geom_solimp[g], p.solimp, rtol=0.01)
    assert m.geom_friction[g, 1] == pytest.approx(2 / 3 * 1.2 * p.patch_m, rel=0.01)
    # the tips and rods keep MuJoCo's rigid default
    t = mj.mj_name2id(m, mj.mjtObj.mjOBJ_GEOM, "tip0")
    assert m.geom_solref[t][0] > 0


def test_a_centred_compliant_grasp_holds_the_pom_pom_with_eight_whiskers():
    from whisker.sim.experiments import paper

    s = load_scene(SCENES / "grasp.toml")
    d = scene_design(s)
    o = next(o for o in s.objects if o.name == "pom-pom")
    at = paper.grasp_attempt(s, d, o, list(range(8)), placement=Placement(), keep=True)
    assert at.result.plan.built("compliance")
    assert at.success and at.lift_mm > 25.0
    assert np.all(np.isfinite(at.result.objects_mm))


def test_compliant_grasp_table_keeps_the_order_of_the_totals():
    """The committed grasp scene with compliant contact, 20 common placements per object (CI size;
    100 per cell in benchmarks/results/sim_compliant.md): the totals fall 8 > 4 > 2, and no placement
    is held by fewer whiskers and dropped by more except at most one."""
    from whisker.sim.experiments import paper

    s = load_scene(SCENES / "grasp.toml")
    s = s.with_(experiment={**s.experiment.model_dump(), "attempts": 20})
    tab = paper.grasp_table(s, scene_design(s))
    t = tab["totals"]
    assert t[0] > t[1] > t[2], t
    assert sum(c["losses"] for p in tab["paired"].values() for c in p) <= 1
    for name, order in tab["order"].items():
        assert order["weak"], (name, tab["rates"][name])
