"""Closed form: a rigid central hub tilted in a clamped circular plate (Kirchhoff plate theory).

The limiting case the membrane model is checked against (tests/test_membrane.py): an annular plate,
outer edge r = a clamped, inner edge r = b bonded to a rigid hub that is tilted by theta about a
diameter. The case is the "annular plate with a rigid central hub under a tilting moment" of
Roark's Formulas (Young & Budynas, Roark's Formulas for Stress and Strain, 7th ed., ch. 11, annular
plates with unsymmetric loading); it is solved here from its governing equation rather than read off
a coefficient table, so it holds for every b/a:

Kirchhoff plate, del^4 w = 0, the n = 1 (cos phi) solution (Timoshenko & Woinowsky-Krieger, Theory of
Plates and Shells, 2nd ed., 1959, sec. 31, unsymmetrical bending of circular plates):

    w = f(r) cos(phi),   f = A r + B / r + C r^3 + D r ln r,

with f(a) = f'(a) = 0 (clamped) and f(b) = theta b, f'(b) = theta (the hub turns rigidly). The strain
energy is U = (D_p / 2) int (del^2 w)^2 dA (the Gaussian-curvature term integrates to zero: the
slope is constant along both edges), del^2 w = (8 C r + 2 D / r) cos(phi), so

    k = 2 U / theta^2 = pi D_p [16 C^2 (a^4 - b^4) + 16 C D (a^2 - b^2) + 4 D^2 ln(a / b)] / theta^2,

D_p = E t^3 / (12 (1 - nu^2)). Valid for a thin plate (t << a - b) and a hub several thicknesses
wide; units: mm, MPa -> N mm/rad.
"""

from __future__ import annotations

import math

import numpy as np


def flexural_rigidity(youngs_modulus: float, thickness: float, poisson_ratio: float) -> float:
    """D_p = E t^3 / (12 (1 - nu^2)), N mm (E in MPa, t in mm)."""
    return youngs_modulus * thickness ** 3 / (12.0 * (1.0 - poisson_ratio ** 2))


def hub_tilt_stiffness(outer_radius: float, hub_radius: float, thickness: float, youngs_modulus: float,
                       poisson_ratio: float) -> float:
    """Moment per radian to tilt a rigid hub of radius b in a plate clamped at radius a, N mm/rad."""
    a, b = float(outer_radius), float(hub_radius)
    if not (0 < b < a) or thickness <= 0 or youngs_modulus <= 0 or not (-1 < poisson_ratio < 0.5):
        raise ValueError("hub_tilt_stiffness needs 0 < hub radius < outer radius, t > 0, E > 0, -1 < nu < 0.5")
    # rows: f(a), f'(a), f(b), f'(b) for the basis r, 1/r, r^3, r ln r
    def rows(r):
        return [[r, 1 / r, r ** 3, r * math.log(r)], [1.0, -1 / r ** 2, 3 * r ** 2, math.log(r) + 1.0]]

    M = np.array(rows(a) + rows(b))
    _, _, C, D = np.linalg.solve(M, [0.0, 0.0, b, 1.0])  # theta = 1
    Dp = flexural_rigidity(youngs_modulus, thickness, poisson_ratio)
    return float(math.pi * Dp * (16 * C * C * (a ** 4 - b ** 4) + 16 * C * D * (a * a - b * b)
                                 + 4 * D * D * math.log(a / b)))
