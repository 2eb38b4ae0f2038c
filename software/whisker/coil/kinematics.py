"""Whisker kinematics: rigid rods tilting about the membrane pivot (pure functions, SI inside).

Each whisker is one rigid body (carbon rod + coil) on a universal joint at the pivot
(``design.pivot_z``): tilt ``theta_r`` in the radial plane (+ = retraction, tip toward the centre)
and ``theta_t`` in the tangential plane (+ = tip toward +tangent, counter-clockwise). The membrane is
a torsional spring-damper about each axis: stiffness ``[mechanics] rotational_stiffness``, damping
``c = 2 zeta sqrt(k J)`` (critical-damping fraction ``[mechanics] damping_ratio``), J the moment of
inertia about the pivot. The paper assumes the same rigid rods and pivot at the membrane centre.

Units: inputs from the Design in mm, g; everything returned here is SI (m, kg, s, N, N*m, rad)
unless the name says otherwise (``_mm``, ``_g``, ``_deg``).

Sources: rod inertia about an end-offset axis, parallel-axis theorem (J = m (L^2/12 + d^2) +
m r^2/4); the coil as a solid cylinder with its axis radial (J_c = m_c (3 a^2 + h^2)/12 about a
transverse diameter) at the coil axis height; gravity torque m g h sin(theta) from the potential
-m g h cos(theta) of the centre of mass h above the pivot along the rod.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad

G = 9.81  # m/s^2


@dataclass(frozen=True)
class WhiskerBody:
    """One whisker as a rigid body about its pivot (SI)."""
    mass_kg: float
    inertia_kgm2: float        # about a transverse axis through the pivot
    com_m: float               # centre of mass along the rod, + toward the tip, from the pivot
    stiffness: float           # N*m/rad, per tilt axis
    damping: float             # N*m*s/rad, per tilt axis
    lever_m: float             # pivot to the coil axis (the magnetic force's lever arm)
    gap0_mm: float             # coil face to magnet face at theta = 0
    stop_rad: float            # hard stop: coil face touches the magnet (or the design's limit)
    tip_m: float               # pivot to tip (l_u)
    rod_radius_m: float
    rod_bottom_m: float        # pivot to the rod's lower end (positive, below the pivot)
    rod_top_m: float           # pivot to the rod's upper end (= tip)
    coil_mass_kg: float
    rod_mass_kg: float

    @property
    def omega_n(self) -> float:
        """Undamped natural frequency about one axis, rad/s (gravity neglected)."""
        return math.sqrt(self.stiffness / self.inertia_kgm2)


_BODY_CACHE: dict[str, "WhiskerBody"] = {}


def whisker_body(design, coil_mass_g: float | None = None) -> WhiskerBody:
    """The rigid-body data of one whisker from the design (cached per design digest).

    ``coil_mass_g`` defaults to the copper mass of the winding (whisker.coil.winding).
    """
    if coil_mass_g is None:
        key = design.digest()
        if key not in _BODY_CACHE:
            from whisker.coil.tilt import winding
            _BODY_CACHE[key] = whisker_body(design, float(winding(design).copper_mass_g))
        return _BODY_CACHE[key]
    if not (coil_mass_g >= 0 and math.isfinite(coil_mass_g)):
        raise ValueError(f"coil mass must be a finite number >= 0 g (got {coil_mass_g})")
    w, mech = design.whiskers, design.mechanics
    mm = 1e-3
    r = w.rod_diameter / 2 * mm
    L = w.rod_length * mm
    top = design.l_u * mm                                  # pivot -> tip
    bottom = (design.pivot_z + design.rod_below_membrane) * mm  # pivot -> lower end
    rod_m = mech.rod_density * 1e-3 * math.pi * (w.rod_diameter / 2) ** 2 * w.rod_length * 1e-3  # kg
    rod_com = (top - bottom) / 2
    j_rod = rod_m * (L ** 2 / 12 + rod_com ** 2) + rod_m * r ** 2 / 4
    coil_m = coil_mass_g * 1e-3
    lever = (design.pivot_z - design.coil_axis_z) * mm
    a = design.coil.outer_diameter / 2 * mm
    h = design.coil.length * mm
    j_coil = coil_m * (3 * a ** 2 + h ** 2) / 12 + coil_m * lever ** 2
    m = rod_m + coil_m
    com = (rod_m * rod_com - coil_m * lever) / m
    J = j_rod + j_coil
    k = design_stiffness_Nmm_per_rad(design) * 1e-3       # N*mm/rad -> N*m/rad
    c = 2 * mech.damping_ratio * math.sqrt(k * J)
    gap0 = design.actuation.gap
    lever_mm = lever / mm
    stop_gap = math.asin(min(1.0, gap0 / lever_mm)) if lever_mm > 0 else math.pi / 2
    # the coil meets the magnet, or the design's limit: with actuation.end_stop the bobbin's post meets the
    # magnet exactly there (whisker.design.stop), so pull-in lands on the stop as in whisker.coil.tilt
    stop = min(stop_gap, math.radians(w.max_deflection_deg))
    return WhiskerBody(mass_kg=m, inertia_kgm2=J, com_m=com, stiffness=k, damping=c, lever_m=lever,
                       gap0_mm=gap0, stop_rad=stop, tip_m=top, rod_radius_m=r, rod_bottom_m=bottom,
                       rod_top_m=top, coil_mass_kg=coil_m, rod_mass_kg=rod_m)


def gravity_sign(facing: str) -> float:
    """+1 when the whiskers hang (facing down: gravity restores), -1 when they stand up."""
    return 1.0 if facing == "down" else -1.0


def gravity_torque(body: WhiskerBody, theta, facing: str = "down") -> np.ndarray:
    """Torque of the whisker's weight about the pivot, N*m (restoring when hanging)."""
    return -gravity_sign(facing) * body.mass_kg * G * body.com_m * np.sin(theta)


def gap_mm(body: WhiskerBody, theta_r) -> np.ndarray:
    """Coil face to magnet face at radial tilt theta_r (rad), mm: the coil base swings outward."""
    return body.gap0_mm - body.lever_m * 1e3 * np.sin(theta_r)


def magnetic_torque(design, body: WhiskerBody, theta_r, current_A, model: str = "table") -> np.ndarray:
    """Torque of the coil force about the pivot, N*m (+ retracts).

    F = I k(gap) (force linear in current, no iron; k from whisker.coil.magnetics), acting radially at the
    coil axis, lever ``body.lever_m`` below the pivot: tau = F * lever * cos(theta_r).
    """
    from whisker.coil.magnetics import force_per_ampere_N

    theta_r = np.asarray(theta_r, dtype=float)
    g = np.maximum(gap_mm(body, theta_r), 1e-3)
    k = np.asarray(force_per_ampere_N(design, np.asarray(g, dtype=float), model=model), dtype=float)
    return np.asarray(current_A, dtype=float) * k * body.lever_m * np.cos(theta_r)


@dataclass(frozen=True)
class Equilibrium:
    theta_rad: np.ndarray      # equilibrium radial tilt per input current
    at_stop: np.ndarray        # bool: pinned at the hard stop (no interior equilibrium)
    residual_Nm: np.ndarray    # torque balance left over


def static_equilibrium(design, body: WhiskerBody, current_A, *, facing: str = "down",
                       model: str = "table", grid: int = 48, iters: int = 40) -> Equilibrium:
    """Radial tilt where k*theta = tau_magnetic + tau_gravity, the first one met from rest.

    Quasi-static loading from theta = 0 stops at the first sign change of the residual in the
    direction the torque pushes (a `grid`-point scan); that cell is solved by Illinois regula falsi
    (at most `iters` evaluations, stopping below 1e-13 rad). Vectorised over `current_A`; with no sign change up to the stop the
    whisker rests on the stop (``at_stop``).
    """
    I = np.atleast_1d(np.asarray(current_A, dtype=float))
    if not np.all(np.isfinite(I)):
        raise ValueError("current_A must be finite")

    def resid(th, cur):
        return (magnetic_torque(design, body, th, cur, model) + gravity_torque(body, th, facing)
                - body.stiffness * th)

    r0 = resid(np.zeros_like(I), I)
    direction = np.where(r0 >= 0, 1.0, -1.0)
    s = np.linspace(0.0, body.stop_rad, grid + 1)                       # (G,)
    th = direction[:, None] * s[None, :]                                 # (n, G)
    r = resid(th, I[:, None]) * direction[:, None]                       # >0 while still pushed
    neg = r <= 0
    neg[:, 0] = False
    has = neg.any(axis=1)
    j = np.where(has, neg.argmax(axis=1), grid)
    rows = np.arange(len(I))
    jj = np.minimum(j, grid)
    lo = s[np.maximum(jj - 1, 0)]
    hi = s[jj]
    flo = r[rows, np.maximum(jj - 1, 0)]
    fhi = r[rows, jj]
    # Illinois regula falsi inside the bracketing cell (superlinear; the bracket is kept, so it
    # cannot escape): `iters` is an upper bound, it stops when the cell is below 1e-13 rad.
    side = np.zeros(len(I))
    for _ in range(iters):
        den = flo - fhi
        x = np.where(np.abs(den) > 0, (lo * (-fhi) + hi * flo) / np.where(den == 0, 1, den), 0.5 * (lo + hi))
        x = np.clip(x, np.minimum(lo, hi), np.maximum(lo, hi))
        fx = resid(direction * x, I) * direction
        pos = fx > 0
        lo = np.where(pos, x, lo)
        flo = np.where(pos, fx, np.where(side == -1, flo * 0.5, flo))
        hi = np.where(pos, hi, x)
        fhi = np.where(pos, np.where(side == 1, fhi * 0.5, fhi), fx)
        side = np.where(pos, 1, -1)
        if np.all((np.abs(hi - lo) < 1e-13) | (fx == 0) | ~has):
            break
    mid = np.where(np.abs(flo) < np.abs(fhi), lo, hi)
    theta = direction * np.where(has, mid, body.stop_rad)
    theta = np.where(r0 == 0, 0.0, theta)
    return Equilibrium(theta_rad=theta, at_stop=~has & (r0 != 0), residual_Nm=resid(theta, I))


def step_free(body: WhiskerBody, theta, omega, torque_ext, dt: float, method: str = "implicit"):
    """Advance the spring-damper whiskers by dt without contact. Returns (theta, omega).

    ``implicit``: the linear spring and damper implicit (unconditionally stable, first order),
    external torque explicit: omega' = (J omega + dt (tau - k theta)) / (J + c dt + k dt^2).
    ``euler``: semi-implicit (symplectic) Euler, stable only for dt < 2/omega_n.
    Tilts are clamped at the hard stop, where the velocity into the stop is removed (inelastic).
    """
    J, k, c = body.inertia_kgm2, body.stiffness, body.damping
    if method == "implicit":
        omega = (J * omega + dt * (torque_ext - k * theta)) / (J + c * dt + k * dt * dt)
    elif method == "euler":
        omega = omega + dt * (torque_ext - k * theta - c * omega) / J
    else:
        raise ValueError(f"integrator {method!r}: use 'implicit' or 'euler'")
    theta = theta + dt * omega
    lim = body.stop_rad
    hit = np.abs(theta) >= lim
    if np.any(hit):
        theta = np.clip(theta, -lim, lim)
        omega = np.where(hit & (np.sign(omega) == np.sign(theta)), 0.0, omega)
    return theta, omega


def energy_J(body: WhiskerBody, theta, omega, facing: str = "down") -> np.ndarray:
    """Mechanical energy per whisker (kinetic + membrane spring + weight), J; axes summed."""
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    kin = 0.5 * body.inertia_kgm2 * omega ** 2
    spring = 0.5 * body.stiffness * theta ** 2
    grav = gravity_sign(facing) * body.mass_kg * G * body.com_m * (1 - np.cos(theta))
    return (kin + spring + grav).sum(axis=-1) if theta.ndim > 1 else kin + spring + grav  # (..., N)


def tip_positions_mm(design, theta) -> np.ndarray:
    """Tip xyz in the sensor frame (mm) for tilts theta (N, 2) = (radial, tangential) rad."""
    return _point_mm(design, np.asarray(theta, dtype=float), design.l_u)


def marker_positions_mm(design, theta) -> np.ndarray:
    """Marker (coil lower face centre) xyz in the sensor frame, mm, for tilts (N, 2) rad."""
    return _point_mm(design, np.asarray(theta, dtype=float), -design.l_l)


def _point_mm(design, theta, s: float) -> np.ndarray:
    """A point at signed distance s (mm) along the rod from the pivot, rod tilted by theta.

    Rotation: first the radial tilt about -t (tip toward -r for +theta_r), then the tangential tilt
    about -r (tip toward +t), composed as a universal joint: direction =
    (-sin(tr) cos(tt)) r + (sin(tt)) t + (cos(tr) cos(tt)) z.
    """
    ang = np.radians(np.asarray(design.whisker_angles_deg))
    R = design.whiskers.ring_radius
    tr, tt = theta[..., 0], theta[..., 1]
    d_r = -np.sin(tr) * np.cos(tt)
    d_t = np.sin(tt)
    d_z = np.cos(tr) * np.cos(tt)
    cx, cy = np.cos(ang), np.sin(ang)
    x = R * cx + s * (d_r * cx - d_t * cy)
    y = R * cy + s * (d_r * cy + d_t * cx)
    z = design.pivot_z + s * d_z
    return np.stack([x, y, z], axis=-1)
