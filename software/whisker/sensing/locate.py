"""Where along a whisker the object touches it: contact distance by active whisking (issue 31).

Method (Kaneko's active antenna: Kaneko, Kanayama & Tsuji, IEEE Trans. Robot. Autom. 14(2), 1998,
"Active antenna for contact sensing"; the same beam relation underlies Solomon & Hartmann, Nature 443,
2006, "Robotic whiskers used to sense features"). While the whisker touches an object at distance r
from its pivot, the coil drives it through a small, known square-wave sweep of torque into the
contact. The object holds the contact point, so the base can turn only as far as the rod bends
between the pivot and the contact; the rod is an Euler-Bernoulli beam loaded by a moment at the pivot
and held at r, whose end rotation is M r / (3 EI). With the membrane (rotational stiffness k) in
parallel, the base's stiffness against the commanded torque is

    K = d tau / d theta = k + 3 EI / r          ->          r = 3 EI / (K - k)

K is the least-squares slope of the commanded torque (whisker.coil.kinematics.magnetic_torque at the
tracked tilt) against the tracked radial tilt over the sweep's frames. The contact moment is what the
membrane holds at rest, M = k theta_0 (theta_0: the tilt the object pushed the whisker to), and the
contact force F = M / r. EI = E pi d^4 / 64 from ``mechanics.rod_modulus`` and ``whiskers.rod_diameter``;
k from the membrane model (whisker.mechanics.membrane) when that module is installed, else
``mechanics.rotational_stiffness``; either can be replaced by a per-whisker calibration (`calibrate_EI`:
one press at a known distance).

What the estimator handles, and what it does not:
- rod bending: it is the measurement (linear beam, small angles);
- membrane compliance: k in parallel (known or calibrated);
- a compliant object: its contact compliance c = d(indentation)/dF adds c / r^2 to 1 / (K - k). If the
  object's indentation law is given (`estimate(..., contact_indentation_mm=...)`), r is solved with
  it; if not, a soft object reads farther out than it is (docs/locate.md gives the bias);
- slip (whisker.sensing.contact_slip): a stuck contact is elastic, so path independent and moving the
  base only along the torque axis. A contact that slid in the first loading and stuck after
  (shakedown: the rest tilt before the sweep differs from the later rest tilt) is located on the
  later cycles; one that slides every cycle (the base moves across the sweep) is located at its
  friction cone's edges when the rod's Coulomb coefficient ``mu`` is given (checked against the two
  levels' force directions), else gets "slip"; a base more compliant than a rod held at its tip gets
  "slip or soft contact";
- an object of unknown compliance (``rigid_object=False``): its compliance only adds to the rod's, so
  the rigid-object distance is an upper bound: status "upper bound", no distance;
- no contact / no information: a whisker that follows the sweep like a free one is "no contact"; a
  sweep whose response is below the tracker's noise gets "not observable", never a number;
- serially correlated tracker noise (camera, light, vibration): the 1-sigma comes from a standard error
  that is cluster-robust over the sweep's cycles (`_fit`), and the torque is taken at the run-mean tilt
  (`sweep_torque_Nmm`), so the noise neither shrinks sigma nor biases K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: defaults of the sweep, at the knee of benchmarks/results/locate.md (accuracy vs heat and time)
DEFAULT_AMPLITUDE = 1.0          # level (signed PWM duty, whisker.drive.actuation)
DEFAULT_DURATION_S = 2.0         # s
DEFAULT_PERIOD_S = 0.2           # s, one on/off cycle of the square wave
MIN_FRAMES = 8
#: a distance whose 1-sigma uncertainty is above this fraction of the rod's protrusion is not reported
NOT_OBSERVABLE_FRACTION = 0.25
#: slip: motion across the torque axis (or a ratchet of the rest tilt, contact_slip.ratchet) above this many
#: standard errors of the frame noise; and across-axis above this fraction of the in-axis response: the
#: stuck contact's own cross-talk allowed for a coil torque axis or camera axes misaligned by up to
#: atan(0.2) = 11 deg (a stuck isotropic rod moves the base only along the torque)
SLIP_SIGMAS, SLIP_FRACTION = 4.0, 0.2


class LocateError(ValueError):
    """Input the estimator refuses (one line naming what is wrong)."""


def bending_stiffness_Nmm2(design) -> float:
    """EI of the rod, N*mm^2: E (``mechanics.rod_modulus``, GPa -> N/mm^2) x pi d^4 / 64
    (whisker.mechanics.membrane.rod_bending_stiffness_Nmm2)."""
    from whisker.mechanics.membrane import rod_bending_stiffness_Nmm2

    return rod_bending_stiffness_Nmm2(design)


def membrane_stiffness_Nmm_per_rad(design) -> tuple[float, str]:
    """(k, source): ``mechanics.rotational_stiffness`` resolved - the number in the design (a
    calibration) or, for "auto", the membrane model's (whisker.mechanics.membrane)."""
    from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad, stiffness_source

    return design_stiffness_Nmm_per_rad(design), stiffness_source(design)


def coil_torque_Nmm(design, levels, theta_r) -> np.ndarray:
    """Commanded coil torque about the pivot, N*mm (+ retracts), at signed levels and radial tilts (rad):
    the driver's current for level x full-scale voltage (cold coil) times the coil model's torque."""
    from whisker.coil.kinematics import magnetic_torque, whisker_body
    from whisker.drive.guard import coil_current_A, full_scale_voltage

    levels = np.asarray(levels, dtype=float)
    volts = np.abs(levels) * full_scale_voltage(design)
    current = np.sign(levels) * coil_current_A(design, volts)
    return 1e3 * magnetic_torque(design, whisker_body(design), theta_r, current)


def sweep_torque_Nmm(design, levels, theta_r) -> np.ndarray:
    """`coil_torque_Nmm` of a tracked sweep, at the radial tilt averaged over each run of one level.

    The torque depends on the tilt (the coil gap) by g = d tau / d theta. Taken at each frame's tracked
    tilt, its noise e enters the regressor too, correlated with the tilt's own (errors in variables):
    the slope gains g var(e) / var(tau), with the authors' real jitter at level 0.25 about +6.5e-4
    rad/(N*mm), ~12 mm of r, the same for any sweep length. The mean over a run of n frames leaves
    1 / n of it; a stuck contact does not move within a run, so noiseless input is unchanged."""
    levels = np.asarray(levels, dtype=float)
    theta_r = np.asarray(theta_r, dtype=float)
    run = np.cumsum(np.r_[True, levels[1:] != levels[:-1]]) - 1
    mean = np.bincount(run, theta_r) / np.bincount(run)
    return coil_torque_Nmm(design, levels, mean[run])


def sweep_levels(amplitude: float, duration_s: float, fps: float, period_s: float = DEFAULT_PERIOD_S
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(t_s, level) per camera frame of the square-wave sweep: off for the first half period, then
    ``amplitude`` (signed) for half a period, and so on; frames at 1/fps."""
    if not (duration_s > 0 and fps > 0 and period_s > 0):
        raise LocateError(f"sweep needs duration, fps and period > 0 (got {duration_s}, {fps}, {period_s})")
    t = np.arange(int(math.floor(duration_s * fps + 1e-9))) / fps
    on = np.floor(t / (period_s / 2.0)).astype(int) % 2 == 1
    return t, np.where(on, float(amplitude), 0.0)


def sweep_heat(design, amplitude: float, duration_s: float, start_C: float | None = None) -> dict:
    """Heat the sweep costs in the coil (the thermal network whisker.coil.thermal_network, one coil
    driven 50 % of the time): peak winding temperature (C), rise (K), electrical energy (J), and the limit
    (C): where the thermal guard (whisker.drive.guard) starts derating on the materials at the winding
    (its enamel and the bobbin resin), so the whole sweep runs at the commanded level."""
    from whisker.coil.thermal_network import ThermalNetwork
    from whisker.drive.guard import full_scale_voltage

    net = ThermalNetwork(design)
    T0 = net.ambient_C if start_C is None else float(start_C)
    x = net.initial_state(T0)
    volts = abs(float(amplitude)) * full_scale_voltage(design)
    v = np.zeros(net.n)
    v[0] = volts * math.sqrt(0.5)                  # mean power of a 50 % square: half of V^2/R
    steps = max(10, int(duration_s / 0.01))
    energy = 0.0
    for _ in range(steps):
        r = float(net.r20_ohm * (1.0 + net.alpha * (net.winding_C(x)[0] - 20.0)))
        energy += 0.5 * volts ** 2 / r * duration_s / steps
        x = net.step_state(x, None, duration_s / steps, volts=v)
    T = float(net.winding_C(x)[0])
    # the guard starts derating drive.guard_derate_band below its cut-off: past that the applied torque
    # would no longer be the commanded one, so that is the sweep's limit
    cut = net.winding_limit_C - float(design.drive.guard_margin) - float(design.drive.guard_derate_band)
    return {"start_C": T0, "peak_C": T, "rise_K": T - T0, "energy_J": float(energy), "cut_C": cut}


def check_sweep(design, amplitude: float, duration_s: float, start_C: float | None = None) -> dict:
    """`sweep_heat` if the sweep is allowed; LocateError if its level is beyond the drive's ratings or
    it would heat the coil to where the thermal guard derates."""
    from whisker.drive.guard import max_level

    if not math.isfinite(amplitude) or abs(amplitude) > max_level(design) + 1e-12:
        raise LocateError(f"sweep amplitude {amplitude:g} is beyond the drive's largest level "
                          f"{max_level(design):.3g} (coil rating)")
    heat = sweep_heat(design, amplitude, duration_s, start_C)
    if heat["peak_C"] > heat["cut_C"]:
        raise LocateError(f"sweep of level {amplitude:g} for {duration_s:g} s would heat the coil from "
                          f"{heat['start_C']:.1f} C to {heat['peak_C']:.1f} C, past {heat['cut_C']:.1f} C where the thermal guard "
                          "starts derating (the torque would no longer be the commanded one); "
                          "shorten it or lower the amplitude")
    return heat


def tilt_from_tip_mm(design, whisker: int, tip_xy_mm) -> np.ndarray:
    """(F, 2) [radial, tangential] tilt (rad) of one whisker from its tracked tip displacement (F, 2),
    sensor x, y in mm: the exact inverse of whisker.coil.kinematics.tip_positions_mm (a universal joint:
    the tip's displacement along the whisker's radial and tangential directions is
    l_u (-sin(tr) cos(tt), sin(tt))). The small-angle Jacobian is off by theta^2 / 6 (6e-4 at 0.06 rad),
    as much as the rod's bending signal next to a sliding contact's slide (whisker.sensing.contact_slip)."""
    ang = math.radians(float(np.asarray(design.whisker_angles_deg)[whisker]))
    cx, cy = math.cos(ang), math.sin(ang)
    lever = float(design.l_u)                          # mm, pivot to tip (kinematics._point_mm)
    d = np.atleast_2d(np.asarray(tip_xy_mm, dtype=float))
    a = (d[:, 0] * cx + d[:, 1] * cy) / lever          # -sin(tr) cos(tt)
    b = (-d[:, 0] * cy + d[:, 1] * cx) / lever         # sin(tt)
    tt = np.arcsin(np.clip(b, -1.0, 1.0))
    tr = -np.arcsin(np.clip(a / np.cos(tt), -1.0, 1.0))
    return np.stack([tr, tt], axis=1)


@dataclass
class Sweep:
    """One whisker's sweep: frame times (s), commanded level per frame, tracked [radial, tangential]
    tilt (rad) per frame, and the tracker's valid flags."""

    t_s: np.ndarray
    level: np.ndarray
    tilt_rad: np.ndarray
    valid: np.ndarray | None = None


@dataclass
class LocateResult:
    status: str     # "ok", "no contact", "slip", "slip or soft contact", "not observable", "ambiguous", "upper bound"
    message: str
    distance_mm: float | None = None
    distance_sigma_mm: float | None = None
    force_mN: float | None = None
    moment_Nmm: float | None = None
    stiffness_Nmm_per_rad: float | None = None
    frames: int = 0
    details: dict = field(default_factory=dict)

    def row(self) -> dict:
        r = lambda v, n: None if v is None else round(float(v), n)  # noqa: E731
        return {"status": self.status, "distance_mm": r(self.distance_mm, 2),
                "distance_sigma_mm": r(self.distance_sigma_mm, 2), "force_mN": r(self.force_mN, 3),
                "moment_Nmm": r(self.moment_Nmm, 4), "stiffness_Nmm_per_rad": r(self.stiffness_Nmm_per_rad, 2),
                "frames": self.frames, "message": self.message}


def calibrate_EI(design, sweep: Sweep, distance_mm: float, k: float | None = None) -> float:
    """Per-whisker calibration: EI (N*mm^2) from a sweep against a rigid object at a known distance."""
    b = _slopes(design, sweep)[0]
    k = membrane_stiffness_Nmm_per_rad(design)[0] if k is None else k
    if b <= 0 or 1.0 / b <= k:
        raise LocateError("calibration sweep shows no contact stiffness; press a rigid object against the rod")
    return (1.0 / b - k) * distance_mm / 3.0


def _frames(design, sweep: Sweep):
    """(tau N*mm, tilt rad (F, 2), level) of the sweep's tracked frames, or LocateError."""
    t = np.asarray(sweep.t_s, dtype=float)
    lev = np.asarray(sweep.level, dtype=float)
    tilt = np.asarray(sweep.tilt_rad, dtype=float)
    if tilt.ndim != 2 or tilt.shape[1] != 2 or len(lev) != len(tilt) or len(t) != len(tilt):
        raise LocateError(f"sweep arrays disagree: {len(t)} times, {len(lev)} levels, tilt {tilt.shape} "
                          "(need one [radial, tangential] tilt per frame)")
    ok = np.isfinite(tilt).all(axis=1) & np.isfinite(lev)
    if sweep.valid is not None:
        ok &= np.asarray(sweep.valid, bool)
    if ok.sum() < MIN_FRAMES:
        raise LocateError(f"{int(ok.sum())} tracked frames in the sweep, need at least {MIN_FRAMES}")
    lev, tilt = lev[ok], tilt[ok]
    if np.ptp(lev) < 1e-3:
        raise LocateError("recording without actuation: the coil level does not change during it; "
                          "locate needs a sweep (a recording made with one, or whisker locate --simulate)")
    return sweep_torque_Nmm(design, lev, tilt[:, 0]), tilt, lev


def sweep_cycles(lev) -> np.ndarray:
    """Cycle index per frame: a new cycle at each rise of the level into its upper half; the rest frames
    before the first rise join the first cycle, and a last cycle without both levels joins the one
    before it (each cycle then holds both levels, so its own slope is defined)."""
    lev = np.asarray(lev, dtype=float)
    high = lev > 0.5 * (lev.min() + lev.max())
    ids = np.maximum(np.cumsum(np.r_[False, high[1:] & ~high[:-1]]), 1) - 1
    if ids[-1] > 0 and not (high[ids == ids[-1]].any() and (~high[ids == ids[-1]]).any()):
        ids[ids == ids[-1]] -= 1
    return ids


def _fit(tau, tilt, cycles=None):
    """Least squares tilt = a + b tau on both axes: (a (2,), b (2,), standard error of b (2,), residual
    std per frame (2,), white-noise standard error of b (2,)).

    The standard error is cluster-robust over the sweep's cycles (``cycles``: `sweep_cycles`): the
    sandwich Var(b) = sum_g (sum_{t in g} x_t e_t)^2 / Sxx^2 (x = tau - mean, e the residual) with the
    CR1 small-sample factor G/(G-1) (N-1)/(N-2) (Liang & Zeger, Biometrika 73, 1986; Cameron & Miller,
    "A practitioner's guide to cluster-robust inference", J. Human Resources 50(2), 2015). It is the
    batch-means error of one slope per on/off cycle and, unlike the ordinary s / sqrt(Sxx), stays valid
    when the tracker's noise is serially correlated (camera, light, vibration) as long as the
    correlation dies out within about a cycle. Chosen over Newey-West HAC (no lag window to pick: the
    sweep's own cycles are the blocks); the coverage of both is measured in
    benchmarks/results/locate_noise.md (section 4). The white-noise error is its floor: from ~10 cycles
    the cluster estimate scatters by ~25 %, and a draw below the truth would pass the observability
    test on luck; the noise that limits a camera (vibration, flicker, sway) is positively correlated,
    which the floor never hides."""
    A = np.stack([np.ones_like(tau), tau], axis=1)
    coef, *_ = np.linalg.lstsq(A, tilt, rcond=None)
    resid = tilt - A @ coef
    n = len(tau)
    s = np.sqrt((resid ** 2).sum(axis=0) / max(1, n - 2))
    x = tau - tau.mean()
    sxx = max(float((x ** 2).sum()), 1e-300)
    se_white = s / math.sqrt(sxx)
    if cycles is None:
        return coef[0], coef[1], se_white, s, se_white
    ids = np.unique(cycles, return_inverse=True)[1]
    g = int(ids.max()) + 1
    score = np.zeros((g, 2))
    np.add.at(score, ids, x[:, None] * resid)
    se = np.sqrt(max(g / max(g - 1, 1), 1.0) * (n - 1) / max(1, n - 2) * (score ** 2).sum(axis=0)) / sxx
    return coef[0], coef[1], np.maximum(se, se_white), s, se_white


def _slopes(design, sweep: Sweep):
    """(K, sigma_K, across-axis slope, its standard error, tau, tilt, level, residual rad) over all frames."""
    tau, tilt, lev = _frames(design, sweep)
    _, b, se_b, s, _ = _fit(tau, tilt, sweep_cycles(lev))
    return b[0], se_b[0], b[1], se_b[1], tau, tilt, lev, s


def estimate(design, sweep: Sweep, *, k: float | None = None, EI: float | None = None,
             contact_indentation_mm=None, rigid_object: bool = True, mu: float | None = None,
             standard_error: str = "cycles") -> LocateResult:
    """Contact distance (mm), its 1-sigma, contact force (mN) and moment (N*mm) from one sweep.

    ``k`` (N*mm/rad) and ``EI`` (N*mm^2) default to the design's (`membrane_stiffness_Nmm_per_rad`,
    `bending_stiffness_Nmm2`) or come from a calibration. ``contact_indentation_mm(F_N)``: the
    object's indentation under the rod when known (e.g. Hertz from its material); without it the object
    is taken as rigid (``rigid_object`` True) or, ``rigid_object`` False, of unknown compliance: an object's
    compliance only adds to the rod's, so the rigid-object distance is then an upper bound (status
    "upper bound", the bound in details["upper_bound_mm"], no distance). ``mu``: the Coulomb
    coefficient of the rod on the object; with it a contact that slides every cycle is located at the
    friction cone's edge (whisker.sensing.contact_slip), without it such a sweep gets "slip".
    Stick, shakedown (slid in the first loading, stuck after) and cyclic slip are told apart on
    physical grounds (contact_slip's docstring). Refusals raise LocateError; the other outcomes are
    statuses without a number. ``standard_error``: "cycles" (cluster-robust over the sweep's cycles,
    `_fit`) or "white" (the ordinary least-squares error, valid for white noise only: the benchmarks'
    comparison row).
    """
    if standard_error not in ("cycles", "white"):
        raise LocateError(f"standard_error must be 'cycles' or 'white', not {standard_error!r}")
    from whisker.sensing import contact_slip as CS

    k = membrane_stiffness_Nmm_per_rad(design)[0] if k is None else float(k)
    EI = bending_stiffness_Nmm2(design) if EI is None else float(EI)
    tau, tilt, lev = _frames(design, sweep)
    L = float(design.whiskers.protrusion)
    pre = CS.pre_sweep(lev)
    steady = ~pre
    cyc = (lambda m: sweep_cycles(lev[m])) if standard_error == "cycles" else (lambda m: None)
    if steady.sum() > 2:
        _, _, se_s, s_steady, sew_s = _fit(tau[steady], tilt[steady], cyc(steady))
        s_steady = s_steady * _inflation(se_s, sew_s)
    else:
        s_steady = np.full(2, np.inf)
    ratchet = CS.ratchet(tilt, lev, s_steady)
    # a stuck contact is path independent: the frames before the sweep belong to the same line; a
    # contact that slid in the first loading left them behind (shakedown): fit the later cycles only
    shaken = ratchet["sigmas"] > SLIP_SIGMAS
    use = steady if shaken else np.ones(len(tau), bool)
    _, bb, se, noise, se_white = _fit(tau[use], tilt[use], cyc(use))
    # per-frame noise as the means over runs of frames see it (the slip tests): white x the cycles' inflation
    noise_eff = noise * _inflation(se, se_white)
    b, b_t, se_b, se_bt = bb[0], bb[1], se[0], se[1]
    theta0 = np.median(tilt[pre], axis=0) if pre.any() else tilt[lev == 0].mean(axis=0) if (lev == 0).any() \
        else tilt.mean(axis=0) - bb * tau.mean()
    n = len(tau)
    details = {"compliance_rad_per_Nmm": float(b), "compliance_se": float(se_b), "across_axis": float(b_t),
               "compliance_se_white": float(se_white[0]), "standard_error": standard_error,
               "noise_rad": noise.tolist(), "noise_eff_rad": noise_eff.tolist(), "k_Nmm_per_rad": k, "EI_Nmm2": EI,
               "sweep_torque_Nmm": float(np.ptp(tau)), "preload_rad": theta0.tolist(), "ratchet": ratchet,
               "regime": "shakedown" if shaken else "stick"}
    free = 1.0 / k
    if b > 0.5 * free:
        return LocateResult("no contact", f"the whisker followed the sweep like a free one (compliance "
                            f"{b:.3g} rad/(N*mm), free {free:.3g}): nothing holds it", frames=n, details=details)
    across = abs(b_t) > SLIP_SIGMAS * se_bt and abs(b_t) > SLIP_FRACTION * abs(b)
    if not across and (b <= 0 or b < 2 * se_b):
        return LocateResult("not observable", f"the sweep moved the base by {abs(b) * np.ptp(tau):.2g} rad, "
                            f"within the tracker's noise ({noise[0]:.2g} rad per frame x {n} frames): use a "
                            "longer or stronger sweep or a faster camera", frames=n, details=details)
    moment = k * float(np.hypot(*theta0))          # |r f| at rest: the membrane holds the contact's moment
    if across:
        details["regime"] = "cyclic slip"
        if contact_indentation_mm is not None or mu is None:
            why = "a soft object's compliance model" if contact_indentation_mm is not None else "no friction coefficient (mu)"
            return LocateResult("slip", f"the base moved across the sweep ({b_t / b:.2f} of the in-axis motion): the "
                                f"contact slides along the object every cycle, and with {why} it is not located",
                                frames=n, details=details)
        return _cyclic_slip(CS, tau[steady], tilt[steady], lev[steady], noise_eff, k, EI, mu, L, moment, rigid_object,
                            n, details)
    K = 1.0 / b
    Kc = K - k
    span = float(np.ptp(tau))
    Kc_min = 1.0 / (L / (3 * EI) + _secant(contact_indentation_mm, moment, span, L) / L ** 2)
    # a contact cannot lie beyond the rod: within 2 standard errors of the tip's stiffness the
    # constrained estimate is the tip; farther out the base is too compliant for any held contact
    at_tip = contact_indentation_mm is None and Kc < Kc_min and b - 1.0 / (Kc_min + k) < 2 * se_b
    if at_tip:
        Kc = Kc_min
    elif Kc < Kc_min and contact_indentation_mm is None:
        return LocateResult("slip or soft contact", f"the base is more compliant ({1 / Kc:.3g} rad/(N*mm)) than "
                            f"a rod held at its tip ({1 / Kc_min:.3g}): the contact slides or the object is soft",
                            stiffness_Nmm_per_rad=K, frames=n, details=details)
    roots = _solve_r(Kc, EI, L, moment, span, contact_indentation_mm)
    if not roots:
        return LocateResult("slip or soft contact", f"no distance on the rod explains the stiffness {K:.3g} "
                            "N*mm/rad with this object's compliance", stiffness_Nmm_per_rad=K, frames=n, details=details)
    if len(roots) > 1:
        details["candidates_mm"] = roots
        return LocateResult("ambiguous", "with this object's compliance " + " and ".join(f"{x:.1f}" for x in roots)
                            + " mm fit the sweep alike", stiffness_Nmm_per_rad=K, frames=n, details=details)
    r = roots[0]
    near = _solve_r(Kc * 1.001, EI, L, moment, span, contact_indentation_mm)
    dr_dKc = abs(min(near, key=lambda x: abs(x - r)) - r) / (Kc * 0.001) if near else float("inf")
    # dK = db / b^2 at the stiffness the distance stands on: the tip's when clamped there (the measured b
    # is then up to 2 se_b above it, and its smaller 1/b^2 would shrink sigma by that factor squared)
    sigma_r = dr_dKc * se_b * (Kc + k) ** 2
    details["distance_sigma_white_mm"] = float(sigma_r * se_white[0] / se_b) if se_b > 0 else 0.0
    details["at_tip"] = bool(at_tip)
    return _answer(r, sigma_r, moment, K, L, rigid_object or contact_indentation_mm is not None, n, details)


def _answer(r, sigma_r, moment, K, L, located, n, details) -> LocateResult:
    """The located contact, or "not observable" / "upper bound" without a distance."""
    if sigma_r > NOT_OBSERVABLE_FRACTION * L:
        return LocateResult("not observable", f"distance {r:.0f} mm would be uncertain by {sigma_r:.0f} mm "
                            f"(1 sigma): the sweep's response is too close to the noise", frames=n, details=details)
    if not located:
        details["upper_bound_mm"] = float(r + 2 * sigma_r)
        return LocateResult("upper bound", f"contact at most {r + 2 * sigma_r:.1f} mm from the pivot (2 sigma; nearer "
                            "if the object is soft: the sweep measures the rod's and the object's compliance "
                            "together, and the object's is unknown)", stiffness_Nmm_per_rad=None if K is None else float(K), frames=n,
                            details=details)
    force = moment / r
    return LocateResult("ok", f"contact at {r:.1f} +- {sigma_r:.1f} mm from the pivot, {1e3 * force:.2f} mN "
                        f"({details['regime']})", distance_mm=float(r), distance_sigma_mm=float(sigma_r),
                        force_mN=1e3 * force, moment_Nmm=float(moment), stiffness_Nmm_per_rad=None if K is None else float(K), frames=n,
                        details=details)


def _cyclic_slip(CS, tau, tilt, lev, noise, k, EI, mu, L, moment, rigid_object, n, details) -> LocateResult:
    """A contact that slides every cycle: located at the friction cone's edges (contact_slip)."""
    out = CS.cone_edge_estimate(tau, tilt, lev, noise, k, EI, mu)
    details["cone_edge"] = {key: v for key, v in out.items() if key != "ok"}
    if not out["ok"]:
        return LocateResult("slip", "the contact slides along the object every cycle, and " + out["reason"],
                            frames=n, details=details)
    r, sigma_r = float(out["r_mm"]), float(out["sigma_mm"])
    if r > L:
        if r - 2 * sigma_r > L:
            return LocateResult("slip", f"the sliding contact's normal response puts it at {r:.0f} mm, beyond the "
                                f"rod's {L:g} mm: the slide is not at the cone's edges", frames=n, details=details)
        r = L
    details["at_tip"] = r == L
    return _answer(r, sigma_r, moment, None, L, rigid_object, n, details)


def _inflation(se, se_white) -> np.ndarray:
    """Per axis: how much the cycles' standard error exceeds the white-noise one (1 for white noise)."""
    return np.where(se_white > 0, se / np.maximum(se_white, 1e-300), 1.0)


def _secant(indentation, moment: float, span: float, r: float) -> float:
    """Contact compliance (mm/N) between the sweep's two contact forces at distance r: off F0 = M/r,
    on F0 + span/r (nearly all the sweep's torque goes into the contact); 0 for a rigid object."""
    if indentation is None:
        return 0.0
    F0 = max(moment / r, 1e-6)
    F1 = F0 + max(span, 1e-9) / r
    return (float(indentation(F1)) - float(indentation(F0))) / (F1 - F0)


def _solve_r(Kc: float, EI: float, L: float, moment: float, span: float, indentation) -> list[float]:
    """Every r in (0.5, L] with 1/Kc = r/(3 EI) + c(r)/r^2, c the object's secant compliance over the
    sweep. Rigid object (c = 0): the one root r = 3 EI / Kc. With a compliance the right side has a
    minimum, so two distances can fit the same stiffness."""
    if indentation is None:
        return [3.0 * EI / Kc]
    target = 1.0 / Kc
    r = np.linspace(0.5, L, 2000)
    g = np.array([x / (3 * EI) + _secant(indentation, moment, span, x) / x ** 2 - target for x in r])
    return [float(r[i] - g[i] * (r[i + 1] - r[i]) / (g[i + 1] - g[i]))
            for i in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:]))]
