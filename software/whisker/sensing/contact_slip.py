"""Stick, shakedown and cyclic slip of a whisker's contact under an active sweep (issue 31).

The active-antenna estimator (whisker.sensing.locate) reads the rod's bending between the pivot and a
contact point that the object HOLDS. A contact on a surface inclined to the sweep (approach angle phi
between the surface normal and the sweep axis) holds only while the contact force stays inside the
Coulomb friction cone |T| <= mu N. Under a periodic (square-wave) sweep a frictional contact does one
of three things, by the shakedown theorem for elastic bodies in Coulomb contact (Klarbring, Ciavarella
& Barber, "Shakedown in elastic contact problems with Coulomb friction", Int. J. Solids Struct. 44,
2007; the frictional analogue of Melan's theorem): if a stuck state exists whose contact forces lie in
the cone at every level of the cycle, the contact slides at most during the first cycles and then
sticks for good (shakedown); if none exists, it slides back and forth every cycle (cyclic slip). For
one point contact with the sweep's normal and tangential force swing dN, dT (stick values) on a preload
N0, a stuck state exists iff dT - mu dN <= 2 mu N0 (the tangential swing fits in the cone's width at
both ends).

What each regime leaves in the tracked base tilt theta (2 axes, rad), and how it is tested here; the
tests are significance tests against the tracker's own frame-to-frame noise, no tuned thresholds:

- stick: the response is elastic, so PATH INDEPENDENT (the same torque gives the same tilt, before the
  sweep and after it) and, for an isotropic rod and membrane held at a point, ALONG THE TORQUE AXIS
  only (the held point lets the base turn only where the torque turns it);
- shakedown: the first loading slides the contact to the cone's edge and it sticks from then on: the
  rest tilt before the sweep differs from the rest tilt of the later cycles (a "ratchet" of the base,
  `ratchet`), while the later cycles are a clean stick. The stick estimator is run on the cycles after
  the first loading;
- cyclic slip: the contact slides along the object's surface every half cycle: the base moves ACROSS
  the torque axis between the levels (`across_axis` in locate). Both levels then sit on the cone's
  edges, one on each side: the contact force directions of the two levels (moment balance:
  r f = k theta - tau e) make the angle 2 atan(mu) and their bisector is the surface normal n. The
  object still holds the contact point's NORMAL position, so the rod's bending is still measurable
  along n: with u = r theta + f r^3 / (3 EI) (membrane + Euler-Bernoulli beam) and n.u the same at both
  levels,

      r = 3 EI (n . d theta) / (d tau (n . e) - k (n . d theta))        (`cone_edge_distance`)

  (for n along the sweep axis this is locate's r = 3 EI / (K - k)). The bisector needs no mu; the
  half angle is an estimate of mu, checked against the rod's friction coefficient (the cone of the
  contact table, `contact.rod_friction`) within its stated spread: a pair of forces that is not on
  both edges (partial slip, a soft object, a misread torque) fails it and gets no number.

Limits (docs/locate.md): the cone-edge estimate needs the absolute rest tilt and the ratio of the coil
torque to k theta right to about 1e-3 (the slide across the axis is 10-100 x the bending signal); the
simulator has them exactly, hardware needs the per-whisker calibration.
"""

from __future__ import annotations

import math

import numpy as np

#: relative spread of a Coulomb coefficient for one material pair (tables give ranges of about +-50 %:
#: Rabinowicz, Friction and Wear of Materials, 2nd ed., 1995, ch. 4); the cone-edge estimate's mu must
#: fall within it of the contact table's value
MU_SPREAD = 0.5
#: rad, least frame noise assumed in the significance tests: noiseless (simulated) input would otherwise
#: turn round-off into "significant" motion; any camera's tilt noise is >= 1e-6 rad
NOISE_FLOOR_RAD = 1e-9


def levels_split(lev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(off, on) frame masks of a two-level sweep: level 0 and the sweep's level (the larger half)."""
    lev = np.asarray(lev, dtype=float)
    off = np.abs(lev) < 1e-6
    top = np.abs(lev).max()
    return off, np.abs(lev) > 0.5 * top


def pre_sweep(lev: np.ndarray) -> np.ndarray:
    """Mask of the rest frames before the sweep's first loading (level 0 until the first nonzero level)."""
    lev = np.asarray(lev, dtype=float)
    nz = np.flatnonzero(np.abs(lev) > 1e-6)
    mask = np.zeros(len(lev), bool)
    if len(nz):
        mask[:nz[0]] = True
    return mask


def ratchet(tilt: np.ndarray, lev: np.ndarray, noise_rad: np.ndarray) -> dict:
    """How far the rest tilt moved between before the sweep and the rest frames after its first loading
    (rad, 2 axes), with its standard error from the frame noise. A stuck (elastic) contact returns to
    where it started; a contact that slid during the first loading does not."""
    pre = pre_sweep(lev)
    off, _ = levels_split(lev)
    later = off & ~pre
    if pre.sum() < 2 or later.sum() < 2:
        return {"shift_rad": [0.0, 0.0], "se_rad": [math.inf, math.inf], "sigmas": 0.0}
    shift = tilt[pre].mean(axis=0) - tilt[later].mean(axis=0)
    se = np.maximum(np.asarray(noise_rad, dtype=float), NOISE_FLOOR_RAD) * math.sqrt(1.0 / pre.sum() + 1.0 / later.sum())
    return {"shift_rad": shift.tolist(), "se_rad": se.tolist(),
            "sigmas": float(np.max(np.abs(shift) / np.maximum(se, 1e-300)))}


def cone_edge_distance(theta_off, theta_on, tau_off: float, tau_on: float, k: float, EI: float) -> dict:
    """Contact distance r (mm) of a contact that slides between the two edges of its friction cone.

    theta_*: mean base tilt (rad, [radial, tangential]) at the two levels; tau_*: the coil torque
    (N*mm, about the radial axis e); k: membrane N*mm/rad; EI: rod N*mm^2. The contact moment r f at
    each level is k theta - tau e (moment balance); the surface normal n is the bisector of the two
    force directions, mu_hat = tan(half the angle between them), and r = 3 EI (n.dtheta) /
    (dtau (n.e) - k (n.dtheta)) from the contact point's normal position (module docstring)."""
    e = np.array([1.0, 0.0])
    w_off = k * np.asarray(theta_off, dtype=float) - tau_off * e
    w_on = k * np.asarray(theta_on, dtype=float) - tau_on * e
    u_off, u_on = w_off / np.linalg.norm(w_off), w_on / np.linalg.norm(w_on)
    n = u_off + u_on
    n = n / np.linalg.norm(n)
    half = 0.5 * math.acos(float(np.clip(u_off @ u_on, -1.0, 1.0)))
    dth = np.asarray(theta_on, dtype=float) - np.asarray(theta_off, dtype=float)
    num = float(n @ dth)
    den = float((tau_on - tau_off) * (n @ e) - k * num)
    r = 3.0 * EI * num / den if den != 0 else math.inf
    return {"r_mm": r, "mu_hat": math.tan(half), "normal": n.tolist(),
            "approach_deg": math.degrees(math.atan2(-n[1], -n[0]))}


def cone_edge_estimate(tau: np.ndarray, tilt: np.ndarray, lev: np.ndarray, noise_rad, k: float, EI: float,
                       mu: float) -> dict:
    """`cone_edge_distance` on the steady cycles (after the first loading) of a sweep, with its 1-sigma
    (mm) by first-order propagation of the level means' standard errors (frame noise / sqrt(frames)),
    and the friction check: ``ok`` False with a reason when the two levels are not on the cone's edges
    (mu_hat outside mu x (1 -+ MU_SPREAD)) or the distance is not positive."""
    steady = ~pre_sweep(lev)
    off, on = levels_split(lev)
    off, on = off & steady, on & steady
    if off.sum() < 2 or on.sum() < 2:
        return {"ok": False, "reason": "too few frames at each level after the first loading"}
    th_off, th_on = tilt[off].mean(axis=0), tilt[on].mean(axis=0)
    t_off, t_on = float(tau[off].mean()), float(tau[on].mean())
    out = cone_edge_distance(th_off, th_on, t_off, t_on, k, EI)
    noise = np.asarray(noise_rad, dtype=float)
    var = 0.0
    for which, n_frames in ((0, off.sum()), (1, on.sum())):
        for axis in range(2):
            h = 1e-7
            a, b = th_off.copy(), th_on.copy()
            (a if which == 0 else b)[axis] += h
            d = (cone_edge_distance(a, b, t_off, t_on, k, EI)["r_mm"] - out["r_mm"]) / h
            var += (d * noise[axis]) ** 2 / n_frames
    out["sigma_mm"] = math.sqrt(var)
    lo, hi = mu * (1.0 - MU_SPREAD), mu * (1.0 + MU_SPREAD)
    if not lo <= out["mu_hat"] <= hi:
        out.update(ok=False, reason=f"the contact forces of the two levels span a cone of mu {out['mu_hat']:.2f}, "
                                    f"not the rod's {mu:g} (+-{100 * MU_SPREAD:.0f} %): they are not on the edges of the rod's "
                                    "friction cone (another friction, partial slip, or a soft object)")
    elif not (math.isfinite(out["r_mm"]) and out["r_mm"] > 0):
        out.update(ok=False, reason="the sliding contact's normal response gives no distance on the rod")
    else:
        out["ok"] = True
    return out
