"""Build scatter of the coil actuator: tilt at the grasp level, pull-in, build yield, Sobol indices.

Inputs: ``hw/tolerances.csv`` (one row per tolerance, its range, whether a built sensor draws it once
or each whisker draws its own, and its source; read and checked by whisker.coil.tolerance_table).
Every value is drawn uniformly in its range (the sources give ranges, not distributions).

Physics per whisker (the same as whisker.coil.tilt, vectorised over whiskers and tilts):
- force per ampere k(gap) from the converged filament table (whisker.coil.magnetics.force_table) of
  the design's coil-magnet pair, built at three magnet heights and interpolated linearly in height;
  it scales exactly with the remanence and with the ampere-turns (the filament model is linear in
  the magnet's surface current Br/mu0 and in the coil's current density N I / (L (a2 - a1)));
- torque I k(gap0 - lever sin t) lever cos t against the membrane's k_rot t. k_rot scales linearly
  with the Ecoflex modulus and with the cube of the membrane's thickness (a plate in bending, D ~ E t^3:
  Roark's formulas, plates) from the design's nominal stiffness (whisker.coil.tolerance.nominal_stiffness);
- the end stop (whisker.design.stop): the post's tip meets the magnet's face at the tilt where
  a cos t + h sin t = gap0 + winding offset, so the stop tilt moves with the gap and the lever; the
  stop gap is set by the resin post (+-0.05 mm);
- the drive (whisker.coil.driver, L298N model): a PWM level x (Vs - V0)/(Rc(T) + Rs + r), the drop's
  V0 and r between the datasheet's corners; or a regulated current; or a level set per whisker at
  bring-up from that whisker's measured reach current.

Outputs (:class:`StudyResult`): the tilt distribution at the grasp level, P(pull-in) (the current is
above the whisker's pull-in current: without a stop the coil snaps onto the magnet, with one it lands
on the stop), the build yield (share of built sensors in which every whisker reaches the grasp tilt,
or the stop, and none lands coil-on-magnet) and, from :func:`sobol`, Sobol' indices (SALib: Saltelli
sampling and Jansen/Saltelli estimators) of the log drive margin.

Why SALib: it carries the Sobol' sampler and estimators with bootstrap confidence intervals and
Latin hypercube sampling, all on plain NumPy arrays (the model here is a vectorised NumPy function);
chaospy's polynomial chaos would be cheaper per sample but needs a smooth output, and pull-in makes
the tilt jump.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from whisker.coil import driver as drv
from whisker.coil import magnetics
from whisker.coil.tilt import lever_mm
from whisker.coil.tolerance_table import FACTORS, Tolerance, ToleranceError, load_tolerances, to_values
from whisker.design.wire import temperature_factor

#: tilt grid per whisker (points from 0 to its stop or contact tilt): the tilt's grid error is
#: (stop tilt)/GRID ~ 0.06 deg at 15 deg, far below the scatter (benchmarks/results/tolerance.md)
GRID = 256
#: whiskers per block of the vectorised evaluation (memory: block x GRID doubles per array)
BLOCK = 8192
#: margin of the pull-in current over the grasp current a design without a stop must keep (issue 27 (a))
PULL_IN_MARGIN = 0.20
#: without a stop, a whisker reaches the grasp tilt when it tilts at least this share of the nominal tilt
TILT_FRACTION = 0.8
#: bring-up level: the measured reach level x (hot coil's resistance ratio) x (1 + this)
BRINGUP_MARGIN = 0.05
DRIVES = ("voltage", "current", "bringup")


def nominal_stiffness(design) -> tuple[float, str]:
    """(k_rot N*mm/rad, source) of the nominal design: ``mechanics.rotational_stiffness`` resolved by
    whisker.mechanics.membrane (the membrane model for "auto", else the design's number)."""
    from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad, stiffness_source

    return float(design_stiffness_Nmm_per_rad(design)), stiffness_source(design)


# ---- the vectorised physics --------------------------------------------------------------------

class _Forces:
    """k(gap) per ampere for the design's coil at three magnet heights; scaled by Br and turns."""

    def __init__(self, design, dh: tuple[float, float]):
        g = magnetics.geometry(design)
        self.h0, self.br0, self.n0 = g.magnet_height, g.remanence, g.turns
        lo, hi = dh
        self.heights = np.array(sorted({g.magnet_height + lo, g.magnet_height, g.magnet_height + hi}))
        self.tables = []
        for h in self.heights:
            gh = magnetics.CoilMagnet(g.coil_inner_radius, g.coil_outer_radius, g.coil_length, g.turns,
                                      g.magnet_radius, float(h), g.remanence)
            self.tables.append(magnetics.force_table(gh))

    def __call__(self, gap, height, remanence, turns):
        """N/A, arrays broadcast; gaps below 0 are clipped (contact). Linear in height between tables."""
        gap = np.maximum(gap, 0.0)
        hs = self.heights
        ks = [t(gap) for t in self.tables]
        if len(hs) == 1:
            k = ks[0]
        else:
            k = None
            for j in range(len(hs) - 1):
                w = (height - hs[j]) / (hs[j + 1] - hs[j])
                kj = (1 - w) * ks[j] + w * ks[j + 1]
                sel = (height < hs[j + 1]) if j < len(hs) - 2 else np.ones_like(np.asarray(height, bool))
                k = kj if k is None else np.where(done, k, kj)
                done = sel if j == 0 else (done | sel)
        return k * (remanence / self.br0) * (turns / self.n0)


@dataclass
class Whiskers:
    """Per-whisker physical values (arrays of shape (M,)), mm, T, N*mm/rad, ohm, C."""

    remanence: np.ndarray
    magnet_height: np.ndarray
    gap: np.ndarray
    stiffness: np.ndarray
    lever: np.ndarray
    turns: np.ndarray
    r20: np.ndarray
    drop_u: np.ndarray
    temperature: np.ndarray
    post: np.ndarray
    sense: np.ndarray
    calibration: np.ndarray


def physical(design, tol: dict[str, Tolerance], u: dict[str, np.ndarray], k_nom: float) -> Whiskers:
    """Unit draws per factor (each (M,)) -> the whiskers' physical values."""
    v = {k: to_values(tol[k], u[k]) for k in FACTORS}
    t0 = design.membrane.thickness
    return Whiskers(
        remanence=v["remanence"], magnet_height=design.magnet.height + v["magnet_height"],
        gap=design.actuation.gap + v["gap_print"] + v["glue_layer"],
        stiffness=k_nom * v["ecoflex_modulus"] * ((t0 + v["membrane_thickness"]) / t0) ** 3,
        lever=lever_mm(design) + v["rod_glue_height"], turns=float(design.coil.turns) * v["turns"],
        r20=float(design.coil.resistance) * v["resistance"] * v["turns"], drop_u=v["driver_drop"],
        temperature=v["coil_temperature"], post=v["stop_post"],
        sense=v["current_sense"], calibration=v["calibration"])


def _contact_and_stop(design, w: Whiskers):
    """(contact tilt, stop tilt or None) per whisker, rad."""
    from whisker.design.former import outer_offset, winding_face_offset
    from whisker.design.stop import contact_tilt_rad, end_stop

    th_c = np.arcsin(np.clip(w.gap / w.lever, 0.0, 1.0))
    s = end_stop(design)
    if s is None:
        return th_c, None
    x_face = winding_face_offset(design) + w.gap
    post = contact_tilt_rad(outer_offset(design) + s.post_length_mm + w.post, w.lever + s.post_diameter_mm / 2,
                            x_face)
    # a short gap can bring the flange's lower rim onto the magnet first: then the rim is the stop
    rim = contact_tilt_rad(outer_offset(design), w.lever + design.coil.outer_diameter / 2, x_face)
    return th_c, np.clip(np.minimum(post, rim), 1e-6, th_c)


def _needed(forces: _Forces, w: Whiskers, theta_end):
    """max over (0, theta_end] of k_rot t / tau(t) per ampere: the largest current with a stable tilt
    before theta_end (pull-in current when theta_end is the contact tilt), A; and the tilt of that max."""
    s = np.linspace(0.0, 1.0, GRID + 1)[1:]
    out, at = np.empty(len(w.gap)), np.empty(len(w.gap))
    for b in range(0, len(w.gap), BLOCK):
        sl = slice(b, b + BLOCK)
        th = theta_end[sl, None] * s[None, :]
        lev = w.lever[sl, None]
        tau = forces(w.gap[sl, None] - lev * np.sin(th), w.magnet_height[sl, None], w.remanence[sl, None],
                     w.turns[sl, None]) * lev * np.cos(th)
        g = w.stiffness[sl, None] * th / tau
        j = np.argmax(g, axis=1)
        out[sl] = g[np.arange(len(j)), j]
        at[sl] = th[np.arange(len(j)), j]
    return out, at


def _tilt(forces: _Forces, w: Whiskers, current, theta_end):
    """First stable tilt from rest, rad; NaN where there is none before theta_end."""
    s = np.linspace(0.0, 1.0, GRID + 1)
    out = np.full(len(w.gap), np.nan)
    for b in range(0, len(w.gap), BLOCK):
        sl = slice(b, b + BLOCK)
        th = theta_end[sl, None] * s[None, :]
        lev = w.lever[sl, None]
        h = current[sl, None] * forces(w.gap[sl, None] - lev * np.sin(th), w.magnet_height[sl, None],
                                       w.remanence[sl, None], w.turns[sl, None]) * lev * np.cos(th) \
            - w.stiffness[sl, None] * th
        h[:, 0] = np.where(current[sl] > 0, 1.0, -1.0)   # tilt 0 is not a root for a retracting current
        neg = h[:, 1:] <= 0
        has = neg.any(axis=1)
        j = np.argmax(neg, axis=1) + 1
        r = np.arange(len(j))
        h0, h1 = h[r, j - 1], h[r, j]
        t0, t1 = th[r, j - 1], th[r, j]
        root = t0 + (t1 - t0) * h0 / np.where(h0 - h1 != 0, h0 - h1, 1.0)
        out[sl] = np.where(has & (current[sl] > 0), root, np.where(current[sl] <= 0, 0.0, np.nan))
    return out


def _bridge_current(design, w: Whiskers, level, temperature):
    """Mean coil current at a PWM level from the bridge, A: level (Vs - V0)/(Rc(T) + Rs + r)."""
    br = drv.bridge(design.driver.type)
    v0 = br.v0_typ + w.drop_u * (br.v0_max - br.v0_typ)
    r = br.r_typ + w.drop_u * (br.r_max - br.r_typ)
    rs = drv.series_resistance_ohm(design)
    rc = w.r20 * temperature_factor(temperature)
    return level * np.maximum(0.0, float(design.driver.supply_voltage) - v0) / (rc + rs + r)


def full_scale_voltage(design) -> float:
    """Volts at a cold (20 C) nominal coil at 100 % duty (whisker.drive.guard.full_scale_voltage's model)."""
    if design.drive.full_scale_voltage > 0:
        return float(design.drive.full_scale_voltage)
    br = drv.bridge(design.driver.type)
    r = float(design.coil.resistance)
    return drv.coil_current_A(br, float(design.driver.supply_voltage), r, drv.series_resistance_ohm(design)) * r


@dataclass(frozen=True)
class Drive:
    """How the grasp level is set: ``voltage`` (one PWM level for every whisker: actuation.voltage /
    full scale), ``current`` (a regulated current, amps; default the nominal coil's current at
    actuation.voltage, 20 C) or ``bringup`` (each whisker's level from its measured reach current)."""

    mode: str = "voltage"
    amps: float | None = None

    def __post_init__(self):
        if self.mode not in DRIVES:
            raise ToleranceError(f"drive must be one of {', '.join(DRIVES)} (got {self.mode!r})")


def currents(design, w: Whiskers, drive: Drive, need_A, tol: dict[str, Tolerance], stop: bool = False):
    """(grasp current A, level) per whisker for a drive."""
    vfs = full_scale_voltage(design)
    lvl_max = design.drive.max_coil_voltage / vfs
    if drive.mode == "voltage":
        lvl = np.full(len(w.gap), design.actuation.voltage / vfs)
        return _bridge_current(design, w, lvl, w.temperature), lvl
    if drive.mode == "current":
        amps = drive.amps if drive.amps is not None else design.actuation.voltage / float(design.coil.resistance)
        return np.full(len(w.gap), amps) * w.sense, np.full(len(w.gap), np.nan)
    # bringup: the level at which this whisker just reaches its target at 20 C on its own channel,
    # as measured (calibration error), raised for the hottest coil and a margin. With an end stop
    # the grasp level is the floor (more current only presses harder on the stop); without one the
    # measured level is the whisker's own (it must stay below its pull-in). Never above the rating.
    per_level = _bridge_current(design, w, np.ones(len(w.gap)), np.full(len(w.gap), 20.0))
    hot = float(temperature_factor(tol["coil_temperature"].hi) / temperature_factor(20.0))
    lvl = need_A / per_level * w.calibration * hot * (1.0 + BRINGUP_MARGIN)
    if stop:
        lvl = np.maximum(lvl, design.actuation.voltage / vfs)
    lvl = np.minimum(lvl, lvl_max)
    return _bridge_current(design, w, lvl, w.temperature), lvl


@dataclass
class StudyResult:
    design_digest: str
    drive: str
    end_stop: bool
    sensors: int
    whiskers_per_sensor: int
    stiffness_Nmm_per_rad: float
    stiffness_source: str
    grasp_current_nominal_A: float
    pull_in_current_nominal_A: float | None  # None: the coil cannot reach the magnet
    pull_in_margin_nominal: float | None     # I_pull / I_grasp - 1 at nominal values (no stop)
    stop_reach_current_nominal_A: float | None
    holding: dict | None                     # at the nominal stop and grasp current
    target_tilt_deg: float                   # what "reaches the grasp tilt" means (the stop, or a share of nominal)
    p_pull_in: float                         # per whisker: current above its pull-in current
    p_coil_on_magnet: float                  # per whisker: snapped onto the magnet (0 with a stop)
    p_short: float                           # per whisker: stable below the target tilt
    share_at_stop: float
    yield_: float
    yield_ci95: tuple[float, float]          # Wilson interval
    tilt_percentiles_deg: dict               # 1, 5, 50, 95, 99 % of the stable/stopped tilts
    tilt_hist: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["yield"] = d.pop("yield_")
        return d


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion k/n."""
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (max(0.0, c - h), min(1.0, c + h))


def _problem(tol: dict[str, Tolerance], names) -> dict:
    return {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}


def draws(tol: dict[str, Tolerance], sensors: int, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Unit draws (sensors x n whiskers, flattened sensor-major): sensor-level factors by a Latin
    hypercube over sensors, repeated for their whiskers; whisker-level ones by a Latin hypercube over
    all whiskers (SALib.sample.latin)."""
    from SALib.sample import latin

    if sensors < 1 or n < 1:
        raise ToleranceError(f"sensors and whiskers per sensor must be >= 1 (got {sensors}, {n})")
    s_names = [f for f in FACTORS if tol[f].level == "sensor"]
    w_names = [f for f in FACTORS if tol[f].level == "whisker"]
    out = {}
    if s_names:
        us = latin.sample(_problem(tol, s_names), sensors, seed=seed)
        for j, f in enumerate(s_names):
            out[f] = np.repeat(us[:, j], n)
    if w_names:
        uw = latin.sample(_problem(tol, w_names), sensors * n, seed=seed + 1)
        for j, f in enumerate(w_names):
            out[f] = uw[:, j]
    return out


def nominal_draws(tol: dict[str, Tolerance], design) -> dict[str, np.ndarray]:
    """Unit draws that give the design's nominal values (offsets 0, factors 1, absolute = the design's)."""
    nominal = {"remanence": design.magnet.remanence, "coil_temperature": 20.0, "driver_drop": 0.0}
    u = {}
    for f in FACTORS:
        t = tol[f]
        x = nominal.get(f, 1.0 if t.kind == "factor" else 0.0)
        u[f] = np.array([0.5 if t.hi == t.lo else min(1.0, max(0.0, (x - t.lo) / (t.hi - t.lo)))])
    return u


def evaluate(design, tol, u, drive: Drive, k_nom: float, target_deg: float | None = None) -> dict:
    """Per-whisker arrays for unit draws u: current, pull-in and reach currents, tilt, flags."""
    forces = _Forces(design, (tol["magnet_height"].lo, tol["magnet_height"].hi))
    w = physical(design, tol, u, k_nom)
    th_c, th_s = _contact_and_stop(design, w)
    i_pull, _ = _needed(forces, w, th_c)
    i_reach = _needed(forces, w, th_s)[0] if th_s is not None else None
    need = i_reach if i_reach is not None else i_pull / (1.0 + PULL_IN_MARGIN)
    cur, lvl = currents(design, w, drive, need, tol, th_s is not None)
    theta_end = th_s if th_s is not None else th_c
    tilt = _tilt(forces, w, cur, theta_end)
    pulled = cur > i_pull
    if th_s is not None:
        at_stop = np.isnan(tilt)
        tilt = np.where(at_stop, theta_end, tilt)
        on_magnet = np.zeros(len(cur), bool)
        reached = at_stop
    else:
        at_stop = np.zeros(len(cur), bool)
        on_magnet = np.isnan(tilt)
        reached = ~on_magnet & (np.degrees(np.nan_to_num(tilt)) >= (target_deg or 0.0))
    return {"current_A": cur, "level": lvl, "pull_in_A": i_pull, "reach_A": i_reach, "tilt_rad": tilt,
            "pulled_in": pulled, "on_magnet": on_magnet, "at_stop": at_stop, "reached": reached, "whiskers": w}


def study(design, sensors: int = 2000, drive: Drive | None = None, seed: int = 0,
          tolerances: str | Path | None = None, stiffness_Nmm_per_rad: float | None = None) -> StudyResult:
    """The Monte Carlo build study of a design: `sensors` built sensors of design.whiskers.count whiskers."""
    from whisker.coil.tilt import equilibrium, holding_at_stop, pull_in, stop_reach_current_A

    drive = drive or Drive()
    tol = load_tolerances(tolerances)
    if stiffness_Nmm_per_rad is None:
        k_nom, k_src = nominal_stiffness(design)
    else:
        k_nom, k_src = float(stiffness_Nmm_per_rad), "given"
    n = design.whiskers.count
    # nominal values (no scatter): grasp current, pull-in margin, reach and holding
    nom = evaluate(design, tol, nominal_draws(tol, design), drive, k_nom, None)
    i_nom = float(nom["current_A"][0])
    i_pull_nom, _ = pull_in(design, k_nom)
    i_reach_nom = stop_reach_current_A(design, k_nom)
    hold = holding_at_stop(design, i_nom, k_nom)
    if i_reach_nom is not None:
        target = design.whiskers.max_deflection_deg
    else:
        eq = equilibrium(design, i_nom, stiffness_Nmm_per_rad=k_nom)
        target = TILT_FRACTION * eq.theta_deg if eq.stable else design.whiskers.max_deflection_deg
    r = evaluate(design, tol, draws(tol, sensors, n, seed), drive, k_nom, target)
    ok = r["reached"] & ~r["on_magnet"]
    good = ok.reshape(sensors, n).all(axis=1)
    k = int(good.sum())
    tilts = np.degrees(r["tilt_rad"][~r["on_magnet"]])
    pct = {f"p{q}": float(np.percentile(tilts, q)) for q in (1, 5, 50, 95, 99)} if len(tilts) else {}
    hist, edges = np.histogram(tilts, bins=30) if len(tilts) else (np.zeros(0), np.zeros(0))
    return StudyResult(
        design_digest=design.digest(), drive=drive.mode, end_stop=i_reach_nom is not None, sensors=sensors,
        whiskers_per_sensor=n, stiffness_Nmm_per_rad=k_nom, stiffness_source=k_src,
        grasp_current_nominal_A=i_nom,
        pull_in_current_nominal_A=float(i_pull_nom) if math.isfinite(i_pull_nom) else None,
        pull_in_margin_nominal=float(i_pull_nom / i_nom - 1.0) if i_nom > 0 and math.isfinite(i_pull_nom) else None,
        stop_reach_current_nominal_A=i_reach_nom, holding=hold, target_tilt_deg=float(target),
        p_pull_in=float(r["pulled_in"].mean()), p_coil_on_magnet=float(r["on_magnet"].mean()),
        p_short=float((~r["reached"] & ~r["on_magnet"]).mean()), share_at_stop=float(r["at_stop"].mean()),
        yield_=k / sensors, yield_ci95=wilson(k, sensors), tilt_percentiles_deg=pct,
        tilt_hist={"counts": hist.tolist(), "edges_deg": edges.tolist()})


def sobol(design, base: int = 256, drive: Drive | None = None, seed: int = 0,
          tolerances: str | Path | None = None, stiffness_Nmm_per_rad: float | None = None) -> dict:
    """First-order and total Sobol' indices (SALib) of the whisker's log drive margin.

    Output: ln(I / I_reach) with an end stop (how far the grasp current is above what the stop
    needs), ln(I_pull / I) without one (how far it stays below pull-in). Every factor is drawn per
    whisker here (the indices say which tolerance moves one whisker; sensor-level sharing matters for
    the yield, not for the attribution). base x (D + 2) model runs (Saltelli, no second order).
    """
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    drive = drive or Drive()
    tol = load_tolerances(tolerances)
    k_nom = nominal_stiffness(design)[0] if stiffness_Nmm_per_rad is None else float(stiffness_Nmm_per_rad)
    names = [f for f in FACTORS if tol[f].hi > tol[f].lo and _used(f, design, drive)]
    prob = _problem(tol, names)
    X = sobol_sample.sample(prob, base, calc_second_order=False, seed=seed)
    u = {f: X[:, j] for j, f in enumerate(names)}
    nominal = nominal_draws(tol, design)
    for f in FACTORS:
        if f not in u:
            u[f] = np.full(len(X), nominal[f][0])
    r = evaluate(design, tol, u, drive, k_nom, None)
    if r["reach_A"] is not None:
        y, what = np.log(r["current_A"] / r["reach_A"]), "ln(I / I_reach_stop)"
    else:
        y, what = np.log(r["pull_in_A"] / r["current_A"]), "ln(I_pull / I)"
    si = sobol_analyze.analyze(prob, y, calc_second_order=False, seed=seed)
    rows = sorted(({"factor": f, "S1": float(si["S1"][j]), "S1_conf": float(si["S1_conf"][j]),
                    "ST": float(si["ST"][j]), "ST_conf": float(si["ST_conf"][j])} for j, f in enumerate(names)),
                  key=lambda d: -d["ST"])
    return {"output": what, "runs": int(len(X)), "indices": rows}


def _used(f: str, design, drive: Drive) -> bool:
    """Whether a factor can change the output for this design and drive."""
    from whisker.design.stop import end_stop

    if f == "stop_post":
        return end_stop(design) is not None
    if f == "current_sense":
        return drive.mode == "current"
    if f in ("resistance", "driver_drop", "coil_temperature"):
        return drive.mode != "current"
    if f == "calibration":
        return drive.mode == "bringup"
    return True
