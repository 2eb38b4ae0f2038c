"""The membrane's rotational stiffness from the device itself: the paper's Fig. 4 protocol.

Protocol (``measure_tilts``): every coil at the same voltage, steps of increasing magnitude in both
polarities (``steps_volts``), each step held ``settle_s`` and followed by rest; the markers are tracked
and each whisker's tilt read with the exact ray/sphere geometry (whisker.vision.geometry, sign from the
radial direction of the marker's motion: outward = retraction = +).

Model (whisker.coil, the one the simulator and `whisker coil` use): at equilibrium
k_rot theta = I k_F(gap0 - lever sin theta) lever cos theta, I = V / R (whisker.drive.guard.coil_current_A).
For a given rest gap gap0 the least-squares k_rot through the measured points is closed-form
(``whisker.coil.fit_stiffness``: sum(tau theta) / sum(theta^2)). The rest gap changes how the torque
grows with tilt, which differs between retraction (gap closes) and extension (gap opens), so with both
polarities it can be identifiable: ``fit`` scans gap0, takes the least residual, and calls the gap
identified only when the residual's 2-sigma interval (delta chi^2 = 4) is narrower than
``GAP_IDENTIFIED`` x gap0 and the stiffness fitted at the interval's ends differs by less than
``K_SPREAD``; otherwise the design's gap is kept and the stiffness fitted with it.
"""

from __future__ import annotations

import math

import numpy as np

from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad

STOP_MARGIN_DEG = 0.5  # tilts within this of whiskers.max_deflection_deg are taken as resting on the stop
K_SPREAD = 0.03        # ... and the stiffness changes by less than this fraction over that interval
GAP_IDENTIFIED = 0.4    # 2-sigma interval width / gap below which the fitted rest gap is reported as identified


class StiffnessError(ValueError):
    """The tilts cannot fix the stiffness (no motion, wrong signs ...); one line."""


def steps_volts(design, count: int = 5, max_volts: float | None = None) -> np.ndarray:
    """[+v1, -v1, +v2, -v2, ...] volts at the coil, v_k evenly up to max_volts (default actuation.voltage)."""
    vmax = design.actuation.voltage if max_volts is None else float(max_volts)
    mags = np.linspace(vmax / count, vmax, count)
    return np.ravel(np.column_stack([mags, -mags]))


def signed_tilts_deg(tracker, result) -> np.ndarray:
    """(N,) tilt per whisker, deg, + = retraction (marker moved outward in the image); NaN if lost."""
    import numpy as np

    g = tracker.deflection(result, model="exact")
    base = tracker.baseline.out_xy
    out_dir = base - base.mean(axis=0)
    radial = result.dx_px * out_dir[:, 0] + result.dy_px * out_dir[:, 1]
    return np.where(np.asarray(result.valid), np.sign(radial) * np.asarray(g.theta_deg), np.nan)


def cool_down(actuator, sleep, above_ambient_C: float = 10.0, step_s: float = 0.5, max_s: float = 600.0) -> float:
    """Wait (coils off) until the thermal guard's estimate of every coil is within `above_ambient_C` of
    ambient, so a step is not derated or cut by heat from the previous ones. Returns seconds waited."""
    guard = getattr(actuator, "guard", None)
    waited = 0.0
    while guard is not None and waited < max_s:
        actuator.tick()
        if float(np.max(guard.temperatures)) <= guard.ambient_C + above_ambient_C:
            break
        sleep(step_s)
        waited += step_s
    return waited


def measure_tilts(actuator, grab, tracker, volts, *, settle_s: float, sleep, frames: int = 3,
                  rest_frames: int = 5, progress=None, temperatures: list | None = None) -> np.ndarray:
    """(S, N) signed tilts (deg) of every whisker at each voltage step (all coils driven together).

    `temperatures`, if a list, receives the thermal guard's (N,) coil temperature estimate (C) at each
    step: a warm coil draws less current, which `fit` can take into account."""
    from whisker.drive.guard import volts_to_levels
    from whisker.bringup.wiring import rest_baseline, settled_results

    n = actuator.n
    rest_baseline(actuator, grab, tracker, settle_s=settle_s, sleep=sleep, frames=rest_frames)
    out = np.full((len(volts), n), np.nan)
    for s, v in enumerate(volts):
        cool_down(actuator, sleep)
        want = np.full(n, float(volts_to_levels(actuator.design, float(v))))
        actuator.apply(want, f"stiffness {v:+.2f} V")
        sleep(settle_s)
        applied = actuator.tick()
        if temperatures is not None and getattr(actuator, "guard", None) is not None:
            temperatures.append(np.array(actuator.guard.temperatures, dtype=float))
        t = [signed_tilts_deg(tracker, r) for r in settled_results(tracker, grab, frames)]
        with np.errstate(all="ignore"):
            out[s] = np.nanmean(np.array(t), axis=0)
        out[s, np.abs(applied - want) > 1e-9] = np.nan   # the thermal guard derated or cut this coil
        actuator.neutral()
        sleep(settle_s)
        tracker.reset()
        if progress:
            progress(s)
    return out


def _with_gap(design, gap_mm: float):
    from whisker.design import design_from_dict

    data = design.to_dict()
    data["actuation"]["gap"] = float(gap_mm)
    return design_from_dict(data)


def _k_and_ssr(design, cur, theta):
    """Closed-form k_rot (N*mm/rad) for one gap, and the residual sum of squares in rad."""
    from whisker.coil import torque_per_ampere_Nmm

    tau = cur * torque_per_ampere_Nmm(design, theta)
    k = float(np.sum(tau * theta) / np.sum(theta * theta))
    return k, float(np.sum((tau / k - theta) ** 2))


def fit(design, volts, tilts_deg, fit_gap: bool = True, temperatures_C=None) -> dict:
    """Rotational stiffness (and the rest gap if the data fix it) from (S,) volts and (S, N) tilts.

    temperatures_C: (S, N) coil temperatures (C) at the steps (from `measure_tilts`); default 20 C,
    the temperature at which the coil's resistance is given (and at which the simulator drives)."""
    from whisker.drive.guard import coil_current_A

    v = np.asarray(volts, dtype=float)
    th = np.radians(np.asarray(tilts_deg, dtype=float))
    if th.ndim == 1:
        th = th[:, None]
    vv = np.broadcast_to(v[:, None], th.shape)
    ok = np.isfinite(th) & (np.abs(th) > math.radians(0.2))   # a step that did not move says nothing of k
    if ok.sum() < 3:
        raise StiffnessError(f"only {int(ok.sum())} step(s) moved a whisker by > 0.2 deg; the coils do not move "
                             "the whiskers (supply off, dead coils or wrong wiring: run `whisker calibrate wiring`)")
    wrong = ok & (np.sign(th) != np.sign(vv))
    if wrong.sum() > 0.2 * ok.sum():
        raise StiffnessError(f"{int(wrong.sum())} of {int(ok.sum())} tilts have the opposite sign of their voltage "
                             "(reversed coils): run `whisker calibrate wiring` first")
    ok &= ~wrong
    temp = np.broadcast_to(20.0 if temperatures_C is None else np.asarray(temperatures_C, dtype=float), th.shape)
    # a whisker at its hard stop (or snapped onto its magnet) is not in spring equilibrium
    stop = np.radians(design.whiskers.max_deflection_deg - STOP_MARGIN_DEG)
    ok &= np.abs(th) < stop
    if ok.sum() < 3:
        raise StiffnessError("fewer than 3 tilts below the hard stop; lower --max-volts")
    cur = np.asarray(coil_current_A(design, vv[ok], temp[ok]), dtype=float)
    t = th[ok]
    gap0 = design.actuation.gap
    result = {"points": int(ok.sum()), "design_gap_mm": gap0, "design_stiffness_Nmm_per_rad":
              design_stiffness_Nmm_per_rad(design)}
    gaps = np.linspace(0.5 * gap0, 1.5 * gap0, 81)
    lever = _lever(design)
    gaps = gaps[gaps > lever * np.sin(np.max(t)) + 0.05]    # the coil must not reach the magnet at any point
    ssr = []
    for g in gaps:
        try:
            ssr.append(_k_and_ssr(_with_gap(design, g), cur, t)[1])
        except ValueError:
            ssr.append(math.inf)
    ssr = np.array(ssr)
    best = gaps[int(np.argmin(ssr))]
    if 0 < int(np.argmin(ssr)) < len(gaps) - 1:   # refine between the grid's neighbours
        from scipy.optimize import minimize_scalar

        step = gaps[1] - gaps[0]
        r = minimize_scalar(lambda g: _k_and_ssr(_with_gap(design, g), cur, t)[1],
                            bounds=(best - step, best + step), method="bounded", options={"xatol": 1e-4})
        if r.success and r.fun <= np.min(ssr):
            best = float(r.x)
    sigma2 = float(np.min(ssr)) / max(len(t) - 2, 1)
    inside = gaps[ssr <= np.min(ssr) + 4.0 * sigma2]
    width = float(inside.max() - inside.min()) if inside.size else math.inf
    identified = bool(fit_gap and len(gaps) > 2 and width < GAP_IDENTIFIED * best and gaps[0] < best < gaps[-1])
    if identified:   # the gap counts only if its uncertainty leaves the stiffness fixed to K_SPREAD
        ks = [_k_and_ssr(_with_gap(design, g), cur, t)[0] for g in (inside.min(), best, inside.max())]
        identified = (max(ks) - min(ks)) < K_SPREAD * ks[1]
    gap = float(best) if identified else gap0
    d = _with_gap(design, gap)
    k, s = _k_and_ssr(d, cur, t)
    per = []
    for w in range(th.shape[1]):
        m = ok[:, w]
        per.append(_k_and_ssr(d, np.asarray(coil_current_A(design, vv[m, w], temp[m, w])), th[m, w])[0]
                   if m.sum() >= 2 else None)
    result.update(rotational_stiffness_Nmm_per_rad=k, gap_mm=gap, gap_identified=bool(identified),
                  gap_best_mm=float(best), gap_interval_mm=[float(inside.min()), float(inside.max())],
                  rms_residual_deg=float(np.degrees(math.sqrt(s / len(t)))), per_whisker_Nmm_per_rad=per)
    return result


def _lever(design) -> float:
    from whisker.coil import lever_mm

    return float(lever_mm(design))


def curve_deg(design, stiffness, gap_mm, volts) -> np.ndarray:
    """Model tilt (deg) at each voltage for a stiffness and rest gap (NaN beyond pull-in)."""
    from whisker.coil import equilibrium
    from whisker.drive.guard import coil_current_A

    d = _with_gap(design, gap_mm)
    out = []
    for v in np.asarray(volts, dtype=float):
        eq = equilibrium(d, float(coil_current_A(design, v)), stiffness_Nmm_per_rad=stiffness)
        out.append(eq.theta_deg if eq.stable else np.nan)
    return np.array(out)


def plot_png(design, volts, tilts_deg, result: dict) -> bytes:
    """PNG bytes: measured tilts (points, every whisker) and the fitted and design curves over voltage."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    v = np.asarray(volts, dtype=float)
    t = np.asarray(tilts_deg, dtype=float)
    grid = np.linspace(min(v.min(), 0), max(v.max(), 0), 121)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for w in range(t.shape[1]):
        ax.plot(v, t[:, w], "o", ms=3.5, alpha=0.7, label="measured (each whisker)" if w == 0 else None)
    ax.plot(grid, curve_deg(design, result["rotational_stiffness_Nmm_per_rad"], result["gap_mm"], grid), "k-",
            label=f"fit: k = {result['rotational_stiffness_Nmm_per_rad']:.3g} N mm/rad, gap {result['gap_mm']:.2f} mm")
    ax.plot(grid, curve_deg(design, design_stiffness_Nmm_per_rad(design), design.actuation.gap, grid), "k--",
            alpha=0.5, label=f"design: k = {design_stiffness_Nmm_per_rad(design):.3g}, gap {design.actuation.gap:g} mm")
    ax.set_xlabel("coil voltage (V)")
    ax.set_ylabel("tilt (deg, + = retraction)")
    ax.set_title("Whisker tilt against coil voltage (paper Fig. 4 protocol)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    return buf.getvalue()


def bringup_levels(design, per_whisker_k) -> dict:
    """Each whisker's measured safe level and grasp level from its fitted stiffness (N*mm/rad).

    Levels are PWM duties (whisker.drive.guard: level x full-scale volts = mean volts at the coil); a
    level's current is taken with the cold (20 C) coil, the largest current a level gives.
    - Without an end stop: safe level = the current 20 % below this whisker's pull-in current
      (whisker.coil.tilt.pull_in with its stiffness; issue 27's margin); grasp level = actuation.voltage's
      level, lowered to the safe level where that is smaller.
    - With an end stop pull-in lands on the stop, so the safe level is the rating; grasp level = the
      level that reaches this whisker's stop (whisker.coil.tilt.stop_reach_current_A) with the hottest coil
      of hw/tolerances.csv and whisker.coil.tolerance.BRINGUP_MARGIN, never below actuation.voltage's
      level, never above the rating (the study's "bringup" drive).
    Whiskers without a fit (None) get the rating and actuation.voltage's level. ``short``: whiskers
    whose stop needs more than the rating.
    """
    from whisker.coil import tolerance
    from whisker.coil.tilt import pull_in, stop_reach_current_A
    from whisker.coil.tolerance_table import load_tolerances
    from whisker.design.wire import temperature_factor
    from whisker.drive.guard import full_scale_voltage, max_level

    r20 = float(design.coil.resistance)
    i_fs = full_scale_voltage(design) / r20            # A at level 1, cold coil
    top = max_level(design)
    base = min(top, design.actuation.voltage / full_scale_voltage(design))
    tol = load_tolerances()
    hot = float(temperature_factor(tol["coil_temperature"].hi) / temperature_factor(20.0))
    safe, grasp, short = [], [], []
    for i, k in enumerate(per_whisker_k):
        if k is None or not (k > 0 and math.isfinite(k)):
            safe.append(top)
            grasp.append(base)
            continue
        reach = stop_reach_current_A(design, k)
        if reach is None:
            s = min(top, pull_in(design, k)[0] / (1.0 + tolerance.PULL_IN_MARGIN) / i_fs)
            safe.append(s)
            grasp.append(min(base, s))
        else:
            need = reach * hot * (1.0 + tolerance.BRINGUP_MARGIN) / i_fs
            if need > top:
                short.append(i)
            safe.append(top)
            grasp.append(min(top, max(base, need)))
    return {"safe_levels": [round(x, 4) for x in safe], "grasp_levels": [round(x, 4) for x in grasp],
            "short_of_stop": short}
