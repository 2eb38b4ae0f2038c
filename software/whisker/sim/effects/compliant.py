"""The compliance effect: Hertz contact between the tips' cap and the objects, from their materials.

A contact model is a module with ``NAME``, ``effect(scene, design, contact, body) -> Effect`` (the
plan's decision and its reason) and ``apply(effect, sim)`` (called by whisker.sim.mj on the compiled
MuJoCo model); whisker.sim.effects.plan lists the modules in ``CONTACT_MODELS``.

For each object geom a tip can touch: E* from the cap's and the object's materials (either may be
absent = rigid), R from the tip capsule's radius and the geom's smallest radius of curvature,
the pair's inverse mass from the two bodies (MuJoCo's ``body_invweight0``: 1/m for a free object,
2 c^2 / (3 J) + 1/M_arm for a whisker, c its centre of mass from the pivot), then
whisker.sim.effects.contact_law.mujoco_contact: solref/solimp following Hertz over ``contact.load_range_mN``,
damping from the softer material's loss factor (at least the rigid contact's, which sets how
hard friction holds: contact_law.mujoco_contact), and the torsional friction of the Hertz patch at
``contact.nominal_load_mN`` ((2/3) mu a). The pair is built only when it is softer than MuJoCo's
rigid contact (solref ``contact.solref_timeconst``, default solimp) at the top of the load range, and
its ringing frequency omega there satisfies omega * 2 dt <= 1 (MuJoCo's own rule for its
time-constant form, timeconst >= 2 dt). A stiffer pair stays rigid: the rigid contact is already as
stiff as the scene's step resolves (a stiffer contact at 1 ms moved the popcorn's 4-whisker rate from
36 % at 0.5 ms to 21 %: a step artefact, docs/sim.md), and the reason says why. Contacts of the rods, the table and the membrane stay rigid.

The objects own the tip pair's parameters (priority 1 over the tips' 0, as for friction:
whisker.sim.mj), so setting them on the object geoms changes only the tip-object contacts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from whisker.sim.effects.contact_law import effective_modulus_Pa, effective_radius_m, mujoco_contact, rigid_indentation_m
from whisker.sim.graph import Effect

NAME = "compliance"
#: kg, the arm body carrying the sensor in the MuJoCo model (whisker.sim.mj; its slides are driven)
ARM_MASS_KG = 100.0
RIGID_E = math.inf
#: dmax of MuJoCo's default solimp, which the rigid contacts use
RIGID_DMAX = 0.95


@dataclass(frozen=True)
class Pair:
    obj: str
    geom: int                      # index of the geom in the object's geoms() (core first)
    E_star_Pa: float
    R_m: float
    loss_factor: float
    inv_mass: float                # 1/kg, MuJoCo's diagApprox of the pair
    solref: tuple[float, float]
    solimp: tuple[float, ...]
    omega: float
    patch_m: float
    indentation_m: float
    indentation_hi_m: float        # Hertz, at the top of the load range
    rigid_hi_m: float              # MuJoCo's rigid contact, at the top of the load range
    fit_error: float


def curvature_radius_m(shape: str, size_mm) -> float:
    """Smallest radius of curvature of a primitive (the sharpest place a tip can press), m; flat = inf.

    sphere r; capsule/cylinder r (the rim of a cylinder is sharper, its side is r); ellipsoid with
    semi-axes a >= b >= c: c^2 / a, the smallest radius of curvature (at the ends of the long axis
    in the plane of a and c); box and mesh: flat faces (inf).
    """
    s = [float(v) * 1e-3 for v in size_mm]
    if shape in ("sphere", "capsule", "cylinder"):
        return s[0]
    if shape == "ellipsoid":
        a, c = max(s), min(s)
        return c * c / a
    return math.inf


def whisker_inv_mass(body) -> float:
    """MuJoCo's translational body_invweight0 of a whisker (1/kg): the mean over x, y, z of the mobility
    of its centre of mass at rest, 2 c^2 / (3 J) on its two hinges, plus the driven arm's 1/M."""
    return 2.0 * body.com_m ** 2 / (3.0 * body.inertia_kgm2) + 1.0 / ARM_MASS_KG


def pairs(scene, design, body, inv_mass=None) -> list[Pair]:
    """The compliant tip-object pairs of `scene` (resolvable or not); `inv_mass(obj_name, whisker)` gives
    the pair's inverse mass when the compiled model is at hand (default: :func:`whisker_inv_mass` + 1/m)."""
    c = scene.contact
    cap = scene.materials.get(c.tip_material) if c.tip_material else None
    E_tip, nu_tip, eta_tip = (cap.youngs_modulus_Pa, cap.poisson, cap.loss_factor) if cap else (RIGID_E, 0.0, 0.0)
    r_tip = body.rod_radius_m * c.tip_radius_factor
    lo, hi = (v * 1e-3 for v in c.load_range_mN)
    b_rigid = 2.0 / (RIGID_DMAX * c.solref_timeconst)      # the rigid contact's B (friction hardness)
    out = []
    for o in scene.objects:
        mat = scene.materials.get(o.material) if o.material else None
        if mat is None and cap is None:
            continue
        E_o, nu_o, eta_o = (mat.youngs_modulus_Pa, mat.poisson, mat.loss_factor) if mat else (RIGID_E, 0.0, 0.0)
        E_star = effective_modulus_Pa(E_tip, nu_tip, E_o, nu_o)
        eta = eta_o if E_o <= E_tip else eta_tip        # the softer side deforms, and dissipates
        A = inv_mass(o.name) if inv_mass else whisker_inv_mass(body) + (0.0 if o.fixed else 1.0 / (o.mass * 1e-3))
        geoms = [(o.shape, o.size)] if o.shape == "mesh" else [(sh, sz) for sh, sz, _, _ in o.geoms()]
        for k, (sh, sz) in enumerate(geoms):
            R = effective_radius_m(r_tip, curvature_radius_m(sh, sz))
            m = mujoco_contact(E_star, R, A, load_range_N=(lo, hi), nominal_N=c.nominal_load_mN * 1e-3,
                               loss_factor=eta, min_damping=b_rigid)
            out.append(Pair(o.name, k, E_star, R, eta, A, m.solref, m.solimp, m.omega_rad_s, m.patch_radius_m,
                            m.indentation_m, m.indentation_hi_m, rigid_indentation_m(hi, A, c.solref_timeconst),
                            m.fit_error))
    return out


def _pa(v: float) -> str:
    return f"{v / 1e6:.3g} MPa" if v >= 1e6 else f"{v / 1e3:.3g} kPa"


def resolvable(p: Pair, dt: float) -> bool:
    """The pair is softer than the rigid contact at the top of the load range (it dents deeper), and
    MuJoCo steps it stably: omega * 2 dt <= 1 (module doc)."""
    return p.indentation_hi_m >= p.rigid_hi_m and p.omega * 2.0 * dt <= 1.0


def effect(scene, design, contact: bool, body) -> Effect:
    """Built when contact is, compliance is not off, and some tip-object pair is soft enough for the step."""
    c = scene.contact
    if not contact:
        return Effect(NAME, False, "no contact model", needs=("contact",))
    if scene.fidelity.compliance == "off":
        return Effect(NAME, False, "fidelity.compliance = 'off': every contact rigid", needs=("contact",))
    if body is None:
        return Effect(NAME, False, "whisker inertia unknown: contacts rigid", needs=("contact",))
    ps = pairs(scene, design, body)
    if not ps:
        return Effect(NAME, False, "no object or tip names a material: contacts rigid", needs=("contact",))
    dt = scene.scene.timestep
    soft, stiff = {}, {}
    for p in ps:
        (soft if resolvable(p, dt) else stiff).setdefault(p.obj, []).append(p)
    notes = []
    for name, pp in soft.items():
        p = pp[0]
        notes.append(f"{name} (E* {_pa(p.E_star_Pa)}: {p.indentation_m * 1e3:.2g} mm dent, "
                     f"{p.patch_m * 1e3:.2g} mm patch at {c.nominal_load_mN:g} mN, "
                     f"Hertz within {100 * max(q.fit_error for q in pp):.0f} %)")
    rigid = []
    hi = c.load_range_mN[1]
    for name, pp in stiff.items():
        if name in soft:
            continue
        p = min(pp, key=lambda q: q.indentation_hi_m)
        if p.indentation_hi_m < p.rigid_hi_m:
            rigid.append(f"{name} (E* {_pa(p.E_star_Pa)}: {p.indentation_hi_m * 1e3:.2g} mm at {hi:g} mN, stiffer than "
                         f"the rigid contact's {p.rigid_hi_m * 1e3:.2g} mm)")
        else:
            w = max(q.omega for q in pp)
            rigid.append(f"{name} (E* {_pa(p.E_star_Pa)} needs dt <= {1e3 / (2 * w):.2g} ms)")
    cap = f"tips: {c.tip_material}; " if c.tip_material else "tips rigid; "
    if not soft:
        return Effect(NAME, False, f"{cap}every pair kept rigid at dt = {dt * 1e3:g} ms: "
                                   + ", ".join(rigid), needs=("contact",))
    why = f"{cap}Hertz contact for " + ", ".join(notes)
    if rigid:
        why += "; rigid: " + ", ".join(rigid)
    return Effect(NAME, True, why, needs=("contact",),
                  detail={"objects": sorted(soft)})


def apply(eff: Effect, sim) -> None:
    """Set the compliant pairs' solref/solimp and torsional friction on the compiled model of `sim`
    (an whisker.sim.mj.MjScene), with the inverse masses MuJoCo computed."""
    mj, m = sim.mujoco, sim.model
    w0 = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, "w0")
    iw_w = float(m.body_invweight0[w0, 0])

    def inv_mass(name: str) -> float:
        b = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"obj:{name}")
        return iw_w + float(m.body_invweight0[b, 0])

    dt = float(m.opt.timestep)
    for p in pairs(sim.scene, sim.design, sim.body, inv_mass):
        if p.obj not in eff.detail.get("objects", ()) or not resolvable(p, dt):
            continue
        g = mj.mj_name2id(m, mj.mjtObj.mjOBJ_GEOM, f"obj:{p.obj}:{p.geom}")
        m.geom_solref[g] = p.solref
        m.geom_solimp[g] = p.solimp
        m.geom_friction[g, 1] = 2.0 / 3.0 * m.geom_friction[g, 0] * p.patch_m
