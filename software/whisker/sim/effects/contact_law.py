"""Hertz contact of two elastic bodies, and its mapping onto MuJoCo's soft-contact parameters.

Pure functions, SI units (Pa, m, N, kg, s).

Hertz (Hertz 1882; Johnson, Contact Mechanics, 1985, sec. 4.2, eqs. 4.22-4.23), two bodies of
Young's moduli E1, E2, Poisson ratios nu1, nu2 and radii of curvature R1, R2 at the contact:

    1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2        1/R = 1/R1 + 1/R2
    F = (4/3) E* sqrt(R) delta^(3/2)              a = sqrt(R delta)        dF/ddelta = 2 E* a

MuJoCo's soft contact (MuJoCo documentation, Computation > Soft constraints and Modeling > Solver
parameters; engine_core_constraint.c, mj_makeImpedance). A contact of penetration r > 0 and impedance
d(r) (``solimp``) with direct reference parameters ``solref = (-k, -b)`` has K = k / dmax^2,
B = b / dmax, regulariser R = (1 - d)/d A, where A = ``efc_diagApprox``, the sum of the two bodies'
translational ``body_invweight0`` (1/kg). Its constraint-space dynamics are

    a = (1 - d) a0 + d (-B v - K d r)           (a0: the acceleration without the contact)

so at rest the contact carries F = K d^2 / (1 - d) r / A, and it rings at omega^2 = d^2 K with
damping ratio zeta = B / (2 sqrt(K)). B is also the friction rows' reference damping (see
:func:`mujoco_contact`, ``min_damping``). :func:`mujoco_contact` picks solimp (d rising from 0.9 with a
cubic sigmoid, as MuJoCo's default starts at 0.9) and K so that F(r) follows Hertz over a load range
(least squares on log F), and B from the material's loss factor eta: zeta = eta / 2 (the viscous
damping ratio of a loss factor at resonance; Nashif, Jones & Henderson, Vibration Damping, 1985,
sec. 2.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

#: MuJoCo's impedance bounds (mjMINIMP, mjMAXIMP)
D_MIN, D_MAX = 0.0001, 0.9999
#: MuJoCo's default solimp, which the rigid contacts use
RIGID_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
#: impedance at first touch (MuJoCo's default solimp starts at 0.9: the friction of a just-touching
#: contact is as hard as in the rigid model), the sigmoid's midpoint and power
SHAPE_DMIN, SHAPE_MID, SHAPE_POWER = 0.9, 0.05, 3.0


def effective_modulus_Pa(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """E* of two bodies (Johnson eq. 4.22); E = inf is a rigid body."""
    for name, v in (("E1", E1), ("E2", E2)):
        if not v > 0:
            raise ValueError(f"effective_modulus_Pa: {name} must be > 0 Pa (got {v})")
    for name, v in (("nu1", nu1), ("nu2", nu2)):
        if not -1.0 < v <= 0.5:
            raise ValueError(f"effective_modulus_Pa: {name} must be in (-1, 0.5] (got {v})")
    c = (1 - nu1 * nu1) / E1 + (1 - nu2 * nu2) / E2
    if c <= 0:
        raise ValueError("effective_modulus_Pa: both bodies are rigid")
    return 1.0 / c


def effective_radius_m(R1: float, R2: float = math.inf) -> float:
    """R of two curvatures (R = inf: flat)."""
    if not (R1 > 0 and R2 > 0):
        raise ValueError(f"effective_radius_m: radii must be > 0 m (got {R1}, {R2})")
    c = 1.0 / R1 + 1.0 / R2
    if c <= 0:
        raise ValueError("effective_radius_m: two flat surfaces have no Hertz contact")
    return 1.0 / c


def hertz_force_N(delta_m, E_star: float, R: float):
    """Normal force F = (4/3) E* sqrt(R) delta^1.5 at indentation delta (m)."""
    d = np.maximum(np.asarray(delta_m, dtype=float), 0.0)
    return 4.0 / 3.0 * E_star * math.sqrt(R) * d ** 1.5


def hertz_indentation_m(F_N, E_star: float, R: float):
    """Indentation delta = (3 F / (4 E* sqrt(R)))^(2/3) under force F (N)."""
    F = np.maximum(np.asarray(F_N, dtype=float), 0.0)
    return (3.0 * F / (4.0 * E_star * math.sqrt(R))) ** (2.0 / 3.0)


def contact_radius_m(F_N: float, E_star: float, R: float) -> float:
    """Radius a = (3 F R / (4 E*))^(1/3) of the contact patch under force F."""
    return (3.0 * F_N * R / (4.0 * E_star)) ** (1.0 / 3.0)


def hertz_stiffness_N_m(F_N: float, E_star: float, R: float) -> float:
    """Tangent stiffness dF/ddelta = 2 E* a = 1.5 F / delta at force F."""
    return 2.0 * E_star * contact_radius_m(F_N, E_star, R)


def impedance(r_m, solimp) -> np.ndarray:
    """MuJoCo's impedance d(r) for penetration r >= 0 (its polynomial sigmoid, engine_core_constraint.c)."""
    dmin, dmax, width, mid, p = solimp
    x = np.clip(np.asarray(r_m, dtype=float) / width, 0.0, 1.0)
    a = 1.0 / mid ** (p - 1)
    b = 1.0 / (1.0 - mid) ** (p - 1)
    y = np.where(x <= mid, a * x ** p, 1.0 - b * (1.0 - x) ** p)
    return dmin + y * (dmax - dmin)


def mujoco_force_N(r_m, solref, solimp, diag_approx: float):
    """Force MuJoCo's contact carries at rest at penetration r: K d^2 / (1 - d) r / A (module doc)."""
    K = -solref[0] / solimp[1] ** 2
    d = impedance(r_m, solimp)
    return K * d * d / (1.0 - d) * np.asarray(r_m, dtype=float) / diag_approx


@lru_cache(maxsize=16)
def _shape(load_ratio: float) -> tuple[float, float, float, float]:
    """(dmax, width / r_hi, c, worst relative force error) of the impedance shape whose static force
    follows r^1.5 between r_hi * load_ratio^(-2/3) and r_hi: F(r) / F(r_hi) = c g(x) x with
    g = d^2 / (1 - d), x = r / r_hi (least squares on log F; the shape is scale-free)."""
    from scipy.optimize import least_squares

    xs = np.geomspace(load_ratio ** (-2.0 / 3.0), 1.0, 48)

    def res(q):
        dmax, w, logc = q
        d = impedance(xs, (SHAPE_DMIN, dmax, w, SHAPE_MID, SHAPE_POWER))
        return logc + np.log(d * d / (1.0 - d) * xs) - 1.5 * np.log(xs)

    best = None
    for x0 in ([0.96, 1.1, -3.2], [0.99, 1.5, -3.0], [0.93, 0.8, -2.5]):
        r = least_squares(res, x0, bounds=([SHAPE_DMIN + 1e-3, 0.05, -30.0], [D_MAX, 50.0, 30.0]))
        if best is None or r.cost < best.cost:
            best = r
    dmax, w, logc = best.x
    return float(dmax), float(w), float(math.exp(logc)), float(np.expm1(np.abs(res(best.x))).max())


@dataclass(frozen=True)
class MjContact:
    """MuJoCo parameters of one compliant contact pair, and what they stand for."""
    solref: tuple[float, float]          # (-k, -b): direct stiffness and damping
    solimp: tuple[float, float, float, float, float]
    omega_rad_s: float                   # contact ringing frequency at the top of the load range
    stiffness_N_m: float                 # Hertz tangent stiffness at the nominal load
    patch_radius_m: float                # Hertz contact radius at the nominal load
    indentation_m: float                 # Hertz indentation at the nominal load
    indentation_hi_m: float              # Hertz indentation at the top of the load range
    fit_error: float                     # worst relative force error of the fit over the load range


def mujoco_contact(E_star: float, R: float, diag_approx: float, *, load_range_N=(1e-3, 20e-3),
                   nominal_N: float = 2e-3, loss_factor: float = 0.1, min_damping: float = 0.0) -> MjContact:
    """solref/solimp making MuJoCo's contact follow Hertz over `load_range_N` (module doc).

    diag_approx: the pair's ``efc_diagApprox`` in the normal direction, 1/kg (the sum of the two
    bodies' translational ``body_invweight0``); loss_factor: eta of the softer material (zeta = eta / 2);
    min_damping: the least B (1/s). MuJoCo reuses B as the reference damping of the friction rows
    (a geom has no separate solreffriction), and a held object creeps at a speed ~ 1/B under a
    tangential load: a B below the rigid contact's, 2 / (dmax timeconst), would let grasped objects
    slide out by a numerical artifact, so callers pass that as the floor.
    """
    lo, hi = (float(v) for v in load_range_N)
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ValueError(f"mujoco_contact: load range must be 0 < low < high N (got {load_range_N})")
    if not (E_star > 0 and R > 0 and diag_approx > 0 and math.isfinite(E_star * R * diag_approx)):
        raise ValueError(f"mujoco_contact: E*, R and the inverse mass must be finite and > 0 "
                         f"(got {E_star}, {R}, {diag_approx})")
    if not 0 <= loss_factor <= 4:
        raise ValueError(f"mujoco_contact: loss factor must be in [0, 4] (got {loss_factor})")
    dmax, w, c, err = _shape(round(hi / lo, 6))
    r_hi = float(hertz_indentation_m(hi, E_star, R))
    K = diag_approx * c * hi / r_hi             # F(r) = K g(r) r / A = hi c g(x) x
    zeta = loss_factor / 2.0
    B = max(2.0 * zeta * math.sqrt(K), float(min_damping))
    solimp = (SHAPE_DMIN, dmax, w * r_hi, SHAPE_MID, SHAPE_POWER)
    d_hi = float(impedance(r_hi, solimp))
    return MjContact(solref=(-K * dmax * dmax, -B * dmax), solimp=solimp, omega_rad_s=d_hi * math.sqrt(K),
                     stiffness_N_m=hertz_stiffness_N_m(nominal_N, E_star, R),
                     patch_radius_m=contact_radius_m(nominal_N, E_star, R),
                     indentation_m=float(hertz_indentation_m(nominal_N, E_star, R)), indentation_hi_m=r_hi,
                     fit_error=err)


def rigid_indentation_m(F_N: float, diag_approx: float, timeconst_s: float, dampratio: float = 1.0,
                        solimp=RIGID_SOLIMP) -> float:
    """Penetration at which MuJoCo's default ("rigid") contact, ``solref = (timeconst, dampratio)`` and
    MuJoCo's default solimp, carries F at rest: K d^2 / (1 - d) r / A = F with K = 1 / (dmax^2
    timeconst^2 dampratio^2) (bisection; the force rises with r)."""
    K = 1.0 / (solimp[1] ** 2 * timeconst_s ** 2 * dampratio ** 2)
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        d = float(impedance(mid, solimp))
        if K * d * d / (1.0 - d) * mid / diag_approx < F_N:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
