"""Coil winding calculator and the whisker's steady deflection, from the design.

Everything reads a :class:`whisker.design.Design`: the former ([coil] inner/outer diameter, length),
the wire ([coil] wire_diameter, [winding] enamel_grade), the turns ([coil] turns) and the fill
([winding] fill_factor), the measured resistance ([coil] resistance), the magnet and gap, and the
membrane's rotational stiffness ([mechanics]).

Material constants (copper, enamel build) and their sources: :mod:`whisker.design.wire`.
Formula sources:
- Wheeler's multilayer inductance formula: L = 31.6 N^2 r^2 / (6 r + 9 l + 10 c) uH with r the mean
  radius, l the length and c the winding depth in metres (Wheeler, Proc. IRE 16, 1928).

Resistance: the design carries the authors' MEASURED resistance ([coil] resistance). The electrical
and thermal functions use it by default (``source="measured"``); ``source="winding"`` uses the
resistance the winding geometry predicts. :func:`winding` reports both and warns when they disagree.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from whisker.coil import magnetics
from whisker.design.stop import stop_tilt_rad
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad
from whisker.design.wire import (ALPHA20_PER_K, COPPER_DENSITY_G_CM3, COPPER_SPECIFIC_HEAT, ENAMEL_DENSITY_G_CM3,  # noqa: F401
                                 ENAMEL_SPECIFIC_HEAT, ORTHOCYCLIC_PACKING, RHO20_OHM_MM2_PER_M, CoilError, _build,
                                 _positive, enamel_overall_diameter_mm, ohm_per_m, temperature_factor, turns_per_layer,
                                 wire_length_mm)

class SnapThrough(CoilError):
    """No stable whisker equilibrium: the coil is pulled in until it meets the magnet (or its stop)."""


@dataclass(frozen=True)
class Winding:
    """What a winding request gives (mm, ohm, g, H, s). ``fits`` is False when the turns need more
    copper fill than [winding] fill_factor or the wire's orthocyclic limit allows."""

    turns: int
    fits: bool
    fill_factor: float                 # assumed copper fill (design)
    fill_required: float               # copper fill the requested turns need in the window
    fill_limit_orthocyclic: float      # perfect orthocyclic winding with this enamel
    max_turns_at_fill: int             # turns that fit at fill_factor
    max_turns_orthocyclic: int
    wire_overall_diameter_mm: float
    turns_per_layer: int
    layers: int
    window_mm2: float
    build_mm: float                    # radial winding depth of the requested turns at fill_factor
    wound_outer_diameter_mm: float
    mean_turn_length_mm: float
    wire_length_mm: float
    resistance_ohm: float              # predicted by the geometry at 20 C
    measured_resistance_ohm: float     # the design's [coil] resistance
    turns_for_measured_resistance: int  # turns whose wire gives the measured resistance (filling from the bore)
    copper_mass_g: float               # of the requested turns' wire
    copper_mass_from_resistance_g: float  # of the wire the measured resistance implies (the thermal model's)
    enamel_mass_g: float
    inductance_wheeler_H: float
    inductance_numeric_H: float
    time_constant_s: float             # L / R (numeric L, measured R)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)


def winding(design) -> Winding:
    """Turns that fit, layers, wire length, resistance, mass, inductance of the design's coil."""
    from whisker.design.former import window

    c, w = design.coil, design.winding
    a1, a2, L = window(design)
    d = c.wire_diameter
    do = enamel_overall_diameter_mm(d, w.enamel_grade)
    a_cu = math.pi * d * d / 4.0
    window = (a2 - a1) * L
    fill_req = c.turns * a_cu / window
    fill_ortho = ORTHOCYCLIC_PACKING * (d / do) ** 2
    max_fill = int(math.floor(w.fill_factor * window / a_cu + 1e-9))
    max_ortho = int(math.floor(fill_ortho * window / a_cu + 1e-9))
    tpl = turns_per_layer(L, do)
    layers = int(math.ceil(c.turns / tpl))
    build = _build(c.turns, d, w.fill_factor, L)
    mean_r = a1 + build / 2.0
    mlt = 2.0 * math.pi * mean_r
    length_mm = wire_length_mm(a1, c.turns, d, w.fill_factor, L)
    r20 = ohm_per_m(d) * length_mm / 1000.0
    # turns whose wire has the measured resistance, wound from the bore outwards at fill_factor:
    # R = n * 2 pi (a1 + n k / 2) * ohm/mm with k = a_cu/(fill L)  ->  quadratic in n
    k = a_cu / (w.fill_factor * L)
    target_len = c.resistance / ohm_per_m(d) * 1000.0
    n_meas = (-a1 + math.sqrt(a1 * a1 + k * target_len / math.pi)) / k
    vol_cu = length_mm * a_cu  # mm^3
    vol_en = length_mm * math.pi * (do * do - d * d) / 4.0
    l_w = wheeler_inductance_H(c.turns, mean_r, L, build)
    l_n = inductance_numeric_H(c.turns, a1, a1 + build, L)
    warnings = []
    fits = fill_req <= w.fill_factor + 1e-12
    if not fits:
        need = (f"more than even a perfect orthocyclic winding reaches ({fill_ortho:.2f})" if fill_req > fill_ortho
                else f"more than winding.fill_factor ({w.fill_factor:.2f}) assumes")
        warnings.append(
            f"{c.turns} turns of {d} mm wire (overall {do:.3f} mm) need a copper fill of {fill_req:.2f} in "
            f"the {window:.2f} mm^2 window, {need}; {max_fill} turns fit at fill {w.fill_factor:.2f} "
            f"({max_ortho} orthocyclic), and {c.turns} would reach {2 * (a1 + build):.2f} mm outer diameter")
    if abs(r20 - c.resistance) > 0.25 * c.resistance:
        warnings.append(
            f"the winding predicts {r20:.1f} ohm but the design's measured coil.resistance is "
            f"{c.resistance:g} ohm; {n_meas:.0f} turns at fill {w.fill_factor:.2f} would give it")
    return Winding(
        turns=c.turns, fits=fits, fill_factor=w.fill_factor, fill_required=fill_req,
        fill_limit_orthocyclic=fill_ortho, max_turns_at_fill=max_fill, max_turns_orthocyclic=max_ortho,
        wire_overall_diameter_mm=do, turns_per_layer=tpl, layers=layers, window_mm2=window,
        build_mm=build, wound_outer_diameter_mm=2.0 * (a1 + build), mean_turn_length_mm=mlt,
        wire_length_mm=length_mm, resistance_ohm=r20, measured_resistance_ohm=c.resistance,
        turns_for_measured_resistance=int(round(n_meas)),
        copper_mass_g=vol_cu * COPPER_DENSITY_G_CM3 / 1000.0,
        copper_mass_from_resistance_g=target_len * a_cu * COPPER_DENSITY_G_CM3 / 1000.0,
        enamel_mass_g=vol_en * ENAMEL_DENSITY_G_CM3 / 1000.0,
        inductance_wheeler_H=l_w, inductance_numeric_H=l_n, time_constant_s=l_n / c.resistance,
        warnings=warnings)


def resistance_range_vs_fill(design, fills=(0.4, 0.5, 0.55, 0.6, 0.7)) -> list[dict]:
    """Turns and 20 C resistance when the whole window is wound at each copper fill."""
    from whisker.design.former import window

    a1, a2, L = window(design)
    d = design.coil.wire_diameter
    a_cu = math.pi * d * d / 4.0
    rows = []
    for f in fills:
        n = int(math.floor(f * (a2 - a1) * L / a_cu))
        length = n * math.pi * (a1 + a2)
        rows.append({"fill": float(f), "turns": n, "wire_length_m": length / 1000.0,
                     "resistance_ohm": ohm_per_m(d) * length / 1000.0})
    return rows


# ---- inductance ------------------------------------------------------------------------------

def wheeler_inductance_H(turns: float, mean_radius_mm: float, length_mm: float, depth_mm: float) -> float:
    """Wheeler (1928) multilayer air-core inductance, H (about 1 % for 6r+9l+10c-type coils)."""
    r, l, c = mean_radius_mm * 1e-3, length_mm * 1e-3, depth_mm * 1e-3
    return 31.6 * turns ** 2 * r * r / (6 * r + 9 * l + 10 * c) * 1e-6


def inductance_numeric_H(turns: float, inner_radius_mm: float, outer_radius_mm: float,
                         length_mm: float, cells: int = 24) -> float:
    """Self-inductance of a uniform rectangular-section coil by Maxwell's cell method, H.

    The cross-section is cut into about cells x cells near-square cells (more along the longer
    side); ring pairs couple through the exact elliptic-integral mutual inductance M = 2 pi r A_phi,
    each ring's self term is the ring formula with the geometric mean distance of its rectangular
    section (mu0 r (ln(8 r / GMD) - 2), GMD = 0.2235 (dr + dz), Rosa & Grover, Bull. Bur. Stand. 8,
    1912). Converges as 1/cells^2 (24 cells: ~0.1 %).
    """
    a1, a2, L = inner_radius_mm * 1e-3, outer_radius_mm * 1e-3, length_mm * 1e-3
    for name, v in (("inner_radius", a1), ("outer_radius - inner_radius", a2 - a1), ("length", L)):
        if not (math.isfinite(v) and v > 0 or (name == "inner_radius" and v == 0)):
            raise CoilError(f"inductance: {name} must be positive (got {v * 1e3!r} mm)")
    aspect = math.sqrt(L / (a2 - a1))
    nr = max(1, int(round(cells / aspect)))
    nz = max(1, int(round(cells * aspect)))
    scale = min(1.0, math.sqrt(2500.0 / (nr * nz)))
    nr, nz = max(1, int(nr * scale)), max(1, int(nz * scale))
    dr, dz = (a2 - a1) / nr, L / nz
    r = a1 + dr * (np.arange(nr) + 0.5)
    z = dz * (np.arange(nz) + 0.5)
    R, Z = np.meshgrid(r, z, indexing="ij")
    R, Z = R.ravel(), Z.ravel()
    M = 2.0 * math.pi * R[None, :] * magnetics.loop_vector_potential(R[:, None], R[None, :], Z[None, :] - Z[:, None])
    gmd = 0.2235 * (dr + dz)
    self_l = magnetics.MU0 * R * (np.log(8.0 * R / gmd) - 2.0)
    np.fill_diagonal(M, self_l)
    per_cell = turns / (nr * nz)
    return float(M.sum() * per_cell ** 2)


# ---- electrical -------------------------------------------------------------------------------

def resistance_ohm(design, temperature_C=20.0, source: str = "measured"):
    """Coil resistance at temperature, ohm (vectorised over temperature_C).

    ``source="measured"`` scales the design's [coil] resistance (taken as measured at 20 C);
    ``source="winding"`` uses the resistance the winding geometry predicts.
    """
    if source == "measured":
        r20 = design.coil.resistance
    elif source == "winding":
        r20 = winding(design).resistance_ohm
    else:
        raise CoilError(f"resistance source must be 'measured' or 'winding' (got {source!r})")
    out = r20 * temperature_factor(temperature_C)
    return out if np.ndim(out) else float(out)


def current_A(design, volts_at_coil, temperature_C=20.0, source: str = "measured"):
    """Coil current for a voltage across the coil, A (vectorised). Steady state: L/R ~ 50 us."""
    v = np.asarray(volts_at_coil, dtype=float)
    if not np.all(np.isfinite(v)):
        raise CoilError(f"volts_at_coil must be finite (got {volts_at_coil!r})")
    out = v / resistance_ohm(design, temperature_C, source=source)
    return out if np.ndim(out) else float(out)


def magnetic_moment_Am2(design, current) -> float:
    """Coil dipole moment, A*m^2 (uniform winding over the design's window)."""
    return magnetics.geometry(design).coil_moment_per_ampere * float(current)


def current_density_A_mm2(design, current) -> float:
    """Current density in the copper, A/mm^2."""
    d = design.coil.wire_diameter
    return float(current) / (math.pi * d * d / 4.0)


# ---- deflection ------------------------------------------------------------------------------

def lever_mm(design) -> float:
    """Pivot to coil axis, mm (the coil force's lever about the whisker pivot)."""
    return design.pivot_z - design.coil_axis_z


def gap_at_mm(design, theta_rad):
    """Coil-magnet gap when the whisker is tilted by theta (retraction positive), mm.

    The coil's centre swings on the lever about the pivot: its radial position grows by
    lever*sin(theta), so the gap shrinks by that much (coil tilt and the small vertical offset
    lever*(1 - cos theta) are ignored in the force: Principle 3, < 1.5 % of the lever at 15 deg).
    """
    g = design.actuation.gap - lever_mm(design) * np.sin(theta_rad)
    return np.where((g < 0) & (g > -1e-9), 0.0, g)  # rounding at contact (theta = asin(gap/lever))


def torque_per_ampere_Nmm(design, theta_rad, model: str = "table"):
    """Torque about the pivot per ampere at tilt theta, N*mm/A: k(gap(theta)) * lever * cos(theta)."""
    th = np.asarray(theta_rad, dtype=float)
    return magnetics.force_per_ampere_N(design, gap_at_mm(design, th), model=model) * lever_mm(design) * np.cos(th)


@dataclass(frozen=True)
class Equilibrium:
    current_A: float
    theta_deg: float                 # steady tilt (retraction positive); at snap-through: the contact tilt
    gap_mm: float
    stable: bool                     # a stable equilibrium exists (False = snap-through)
    pull_in_current_A: float | None  # largest retracting current with a stable equilibrium (None: no pull-in,
    pull_in_theta_deg: float | None  # the coil cannot reach the magnet); tilt just before pull-in
    exceeds_max_deflection: bool     # beyond whiskers.max_deflection_deg
    message: str
    at_stop: bool = False            # resting on the end stop (actuation.end_stop; whisker.design.stop)
    holding_torque_Nmm: float | None = None  # at the stop: magnetic minus membrane torque pressing it on

    def to_dict(self) -> dict:
        return asdict(self)


def _theta_contact(design) -> float:
    gap0, lev = design.actuation.gap, lever_mm(design)
    return math.asin(gap0 / lev) if gap0 < lev else math.pi / 2.0


def pull_in(design, stiffness_Nmm_per_rad: float | None = None, model: str = "table") -> tuple[float, float]:
    """(current A, tilt rad) at which the retracting equilibrium disappears (snap-through).

    Equilibrium needs I = k_rot theta / tau(theta); the largest such current over the reachable tilts
    [0, contact] is the pull-in current. If the maximum is at contact there is no snap: the coil just
    reaches the magnet at that current. Returns (math.inf, pi/2) when the gap is at least the lever:
    the coil cannot reach the magnet, and every current has a stable tilt.
    """
    k_rot = design_stiffness_Nmm_per_rad(design) if stiffness_Nmm_per_rad is None else stiffness_Nmm_per_rad
    th_c = _theta_contact(design)
    if design.actuation.gap >= lever_mm(design):
        return math.inf, math.pi / 2.0
    th = np.linspace(0.0, th_c, 4001)[1:]
    g = k_rot * th / torque_per_ampere_Nmm(design, th, model=model)
    i = int(np.argmax(g))
    return float(g[i]), float(th[i])


def equilibrium(design, current_A: float, model: str = "table",
                stiffness_Nmm_per_rad: float | None = None) -> Equilibrium:
    """Steady whisker tilt for a coil current: solves k_rot*theta = I*k(gap(theta))*lever*cos(theta).

    Retracting current (I > 0) shrinks the gap, so the magnetic 'spring' softens the membrane: the
    first root from theta = 0 is the stable equilibrium; if none exists before the coil meets the
    magnet, the whisker snaps through (``stable=False``, never NaN). Pushing current (I < 0) always
    has one stable root.
    """
    from scipy.optimize import brentq

    I = float(current_A)
    if not math.isfinite(I):
        raise CoilError(f"current_A must be finite (got {current_A!r})")
    k_rot = design_stiffness_Nmm_per_rad(design) if stiffness_Nmm_per_rad is None else stiffness_Nmm_per_rad
    _positive("rotational_stiffness", k_rot)
    max_dev = design.whiskers.max_deflection_deg
    i_pull, th_pull = pull_in(design, k_rot, model)
    th_c = _theta_contact(design)
    th_s = stop_tilt_rad(design)
    th_end = th_c if th_s is None else min(th_c, th_s)
    at_stop, hold = False, None

    def h(th):
        return I * torque_per_ampere_Nmm(design, th, model=model) - k_rot * th

    if I == 0.0:
        th, stable, msg = 0.0, True, "no current: rest"
    elif I > 0:
        grid = np.linspace(0.0, th_end, 2001)
        hv = h(grid)
        neg = np.nonzero(hv[1:] <= 0.0)[0]
        if len(neg):
            j = neg[0] + 1
            th = brentq(h, grid[j - 1], grid[j], xtol=1e-12) if hv[j] < 0 else float(grid[j])
            stable, msg = True, "stable"
        elif th_s is not None:
            th, stable, at_stop, hold = th_end, True, True, float(h(th_end))
            msg = (f"on the end stop at {math.degrees(th_end):.1f} deg, holding torque {hold:.3g} N*mm"
                   + (f" (pulled in: {I:.3g} A > {i_pull:.3g} A)" if I > i_pull and th_pull < th_s else ""))
        else:
            th, stable = th_c, False
            msg = (f"snap-through: {I:.3g} A exceeds the pull-in current {i_pull:.3g} A; the coil is "
                   f"pulled onto the magnet (gap 0 at {math.degrees(th_c):.1f} deg)")
    else:
        lo = -math.pi / 2.0
        th = brentq(h, lo, 0.0, xtol=1e-12)
        stable, msg = True, "stable (pushing)"
    th_deg = math.degrees(th)
    exceeds = abs(th_deg) > max_dev + 1e-9
    if stable and exceeds:
        msg += f"; beyond whiskers.max_deflection_deg ({max_dev:g} deg)"
    reach = math.isfinite(i_pull)
    return Equilibrium(I, th_deg, float(gap_at_mm(design, th)), stable, i_pull if reach else None,
                       math.degrees(th_pull) if reach else None, exceeds, msg, at_stop, hold)


def stop_reach_current_A(design, stiffness_Nmm_per_rad: float | None = None, model: str = "table") -> float | None:
    """Smallest retracting current that brings the whisker onto its end stop, A (None without a stop).

    max of k_rot theta / tau(theta) over (0, theta_stop]: every smaller current has a stable tilt before it.
    """
    th_s = stop_tilt_rad(design)
    if th_s is None:
        return None
    k_rot = design_stiffness_Nmm_per_rad(design) if stiffness_Nmm_per_rad is None else stiffness_Nmm_per_rad
    th = np.linspace(0.0, min(th_s, _theta_contact(design)), 2001)[1:]
    return float(np.max(k_rot * th / torque_per_ampere_Nmm(design, th, model=model)))


def holding_at_stop(design, current_A: float, stiffness_Nmm_per_rad: float | None = None,
                    model: str = "table") -> dict | None:
    """What the end stop holds at a current: net torque (N*mm), the force on the post (mN) and the tip
    force that lifts the whisker off the stop (mN, on the pivot-to-tip lever l_u). None without a stop;
    a negative torque means the current does not reach the stop."""
    from whisker.design.stop import end_stop

    s = end_stop(design)
    if s is None:
        return None
    k_rot = design_stiffness_Nmm_per_rad(design) if stiffness_Nmm_per_rad is None else stiffness_Nmm_per_rad
    th = math.radians(s.tilt_deg)
    tau = float(current_A) * float(torque_per_ampere_Nmm(design, th, model=model)) - k_rot * th
    return {"tilt_deg": s.tilt_deg, "stop_gap_mm": s.gap_mm, "holding_torque_Nmm": tau,
            "post_force_mN": tau / s.contact_arm_mm * 1e3, "tip_force_mN": tau / design.l_u * 1e3}


def deflection_deg(design, current_A, model: str = "table"):
    """Steady whisker tilt (deg, retraction positive) for a coil current (scalar or array).

    Raises :class:`SnapThrough` (one line, with the pull-in current) when a retracting current has
    no stable equilibrium; use :func:`equilibrium` for a flag instead of an error.
    """
    cur = np.asarray(current_A, dtype=float)
    out = np.empty(cur.shape)
    for idx, i in np.ndenumerate(cur):
        eq = equilibrium(design, float(i), model=model)
        if not eq.stable:
            raise SnapThrough(eq.message)
        out[idx] = eq.theta_deg
    return out if out.ndim else float(out)


def fit_stiffness(design, points, by: str = "volts", temperature_C: float = 20.0,
                  model: str = "table") -> dict:
    """Fit [mechanics] rotational_stiffness (N*mm/rad) to measured (drive, tilt_deg) points.

    At a measured tilt theta the magnetic torque is known exactly: tau = I k(gap(theta)) lever
    cos(theta); equilibrium says k_rot = tau/theta, so the least-squares stiffness through the
    origin is sum(tau theta)/sum(theta^2). ``by="volts"`` converts volts at the coil to current with
    the measured resistance at `temperature_C`; ``by="amps"`` takes currents.
    """
    pts = [(float(a), float(b)) for a, b in points]
    if not pts:
        raise CoilError("fit_stiffness needs at least one (drive, angle_deg) point")
    drive = np.array([p[0] for p in pts])
    theta = np.radians([p[1] for p in pts])
    if not (np.all(np.isfinite(drive)) and np.all(np.isfinite(theta))):
        raise CoilError("fit_stiffness: points must be finite numbers")
    if np.all(np.abs(theta) < 1e-9):
        raise CoilError("fit_stiffness: every angle is zero; the stiffness is undetermined")
    if by == "volts":
        cur = np.asarray(current_A(design, drive, temperature_C))
    elif by == "amps":
        cur = drive
    else:
        raise CoilError(f"by must be 'volts' or 'amps' (got {by!r})")
    if np.any(np.sign(cur) * np.sign(theta) < 0):
        raise CoilError("fit_stiffness: a point's angle has the opposite sign of its drive "
                        "(retraction is positive for positive drive)")
    tau = cur * torque_per_ampere_Nmm(design, theta, model=model)
    k = float(np.sum(tau * theta) / np.sum(theta * theta))
    resid = tau / k - theta
    return {"rotational_stiffness_Nmm_per_rad": k, "points": len(pts),
            "rms_residual_deg": float(np.degrees(np.sqrt(np.mean(resid ** 2)))),
            "set": f"mechanics.rotational_stiffness={k:.4g}"}
