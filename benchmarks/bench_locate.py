"""Contact distance by active whisking (whisker.sensing.locate), validated in simulation (issue 31).

The simulator: whisker.sim.experiments.locate_sweep (quasi-static membrane + Euler-Bernoulli rod +
rigid or Hertz-compliant object with Coulomb friction on the bare rod; its docstring says why not the
MuJoCo scene). The camera: the tracker's real errors on rendered frames, as a bank of 200 rest frames
resampled per sweep, and section 4 renders and tracks every frame of a few sweeps.

1. Accuracy at the defaults: rigid objects touching the rod 10-60 mm from the pivot, approach angles
   0-40 deg (stick below atan(mu), shakedown and cyclic slip above: whisker.sensing.contact_slip), 5
   seeds; compliant objects (materials of sim/scenes/materials.toml) beside them, with the object's
   compliance unknown to the estimator (an upper bound, no distance) and with its Hertz compliance known.
2. Accuracy against the sweep's amplitude, duration and the camera's frame rate, and the heat the
   sweep costs (whisker.coil.thermal via whisker.sensing.locate.sweep_heat).
3. Ablation: the same frames without the sweep.
4. Full pipeline: every frame rendered and tracked, three distances.

Writes benchmarks/results/locate.md, locate.csv, locate_tradeoff.csv and locate.png.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402
from whisker.design import default_design  # noqa: E402
from whisker.sensing import locate as L  # noqa: E402
from whisker.sim.experiments import locate_sweep as S  # noqa: E402

DISTANCES = np.arange(10, 61, 5.0)
SEEDS = range(5)
APPROACH = (0.0, 10.0, 20.0, 30.0, 40.0)
CONE_APPROACH = (30.0, 40.0)          # the cyclic-slip angles, with the opt-in cone-edge estimate
COMPLIANT = ("polyolefin foam", "acrylic pile", "pine cone scale")
FPS = 120.0


def stats(results, truths):
    """median / p90 |error| (mm) over the answered sweeps, the fraction answered, force error (%), the
    contact regimes of the answered sweeps, and for "upper bound" answers how often the bound holds
    (bound >= truth) and its median excess over the truth (mm)."""
    err = [abs(r.distance_mm - t["r_mm"]) for r, t in zip(results, truths) if r.status == "ok"]
    ferr = [abs(r.force_mN - t["force_mN"]) / t["force_mN"] for r, t in zip(results, truths) if r.status == "ok"]
    statuses, regimes = {}, {}
    for r in results:
        statuses[r.status] = statuses.get(r.status, 0) + 1
        if r.status == "ok":
            regimes[r.details["regime"]] = regimes.get(r.details["regime"], 0) + 1
    excess = [r.details["upper_bound_mm"] - t["r_mm"] for r, t in zip(results, truths) if r.status == "upper bound"]
    return {"bound_holds_pct": 100.0 * float(np.mean(np.array(excess) >= 0)) if excess else float("nan"),
            "bound_excess_mm": float(np.median(excess)) if excess else float("nan"),
            "regimes": ", ".join(f"{k} {v}" for k, v in sorted(regimes.items())),
            "median_mm": float(np.median(err)) if err else float("nan"),
            "p90_mm": float(np.percentile(err, 90)) if err else float("nan"),
            "answered_pct": 100.0 * len(err) / len(results),
            "force_median_pct": 100.0 * float(np.median(ferr)) if ferr else float("nan"),
            "statuses": ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())), "sweeps": len(results)}


def batch(design, cases, noise, **kw):
    res, tru = [], []
    for i, (c, seed) in enumerate(cases):
        r, t = S.run_case(design, c, noise=noise, seed=1000 * seed + i, **{"fps": FPS, **kw})
        res.append(r)
        tru.append(t)
    return res, tru


def main() -> int:
    design = default_design()
    t0 = time.perf_counter()
    print("tracker noise bank: rendering and tracking 200 rest frames ...", flush=True)
    noise = S.tracker_noise_bank(design, 200)
    noise = noise[np.isfinite(noise).all(axis=1)]
    noise = noise - noise.mean(axis=0)
    sig = noise.std(axis=0)
    rows, error_curves = [], {}
    # 1. accuracy at the defaults
    by_angle = {}
    models = {"rigid": "rigid (asserted)", "unknown": "compliance unknown", "known": "compliance known",
              "cone": "rigid, cone edge (opt-in: mu given, absolute tilt exact)"}
    mu = S.rod_friction()
    for mat in (None,) + COMPLIANT:
        for model in (("rigid", "cone", "unknown") if mat is None else ("unknown", "known")):
            angles = APPROACH if model == "rigid" else CONE_APPROACH if model == "cone" else (0.0,)
            for ang in angles:
                cases = [(S.Case(r, mat, ang), s) for r in DISTANCES for s in SEEDS]
                res, tru = batch(design, cases, noise, known_compliance=model == "known",
                                 rigid_object=model != "unknown", mu=mu if model == "cone" else None)
                st = stats(res, tru)
                rows.append({"object": mat or "rigid", "approach_deg": ang, "estimator": models[model], **st})
                if mat is None and model == "rigid":
                    by_angle[ang] = (res, tru)
                if model != "unknown" and (ang in (0.0, 20.0, 30.0, 40.0)) and not (model == "rigid" and ang in CONE_APPROACH):
                    label = (f"{mat or 'rigid'}{' (compliance known)' if model == 'known' else ''}"
                             f"{' cone edge (opt-in)' if model == 'cone' else ''}, {ang:g} deg")
                    error_curves[label] = [
                        (t["r_mm"], r.distance_mm - t["r_mm"] if r.status == "ok" else np.nan) for r, t in zip(res, tru)]
                print(rows[-1], flush=True)
    # headlines: rigid, all approach angles; and the angles at which the contact sticks (tan(angle) <= mu)
    stick = [a for a in APPROACH if np.tan(np.radians(a)) <= mu]
    head = stats(sum((by_angle[a][0] for a in APPROACH), []), sum((by_angle[a][1] for a in APPROACH), []))
    head_stick = stats(sum((by_angle[a][0] for a in stick), []), sum((by_angle[a][1] for a in stick), []))
    # 2. trade-off
    trade = []
    grid = ([("amplitude", a, 2.0, FPS) for a in (0.25, 0.5, 0.75, 1.0)]
            + [("duration", 1.0, d, FPS) for d in (0.5, 1.0, 1.5, 2.0, 2.5)]
            + [("fps", 1.0, 2.0, f) for f in (30.0, 60.0, 120.0, 240.0)])
    for what, amp, dur, fps in grid:
        heat = L.sweep_heat(design, amp, dur)
        cases = [(S.Case(r), s) for r in np.arange(10, 61, 10.0) for s in range(4)]
        st = stats(*batch(design, cases, noise, amplitude=amp, duration_s=dur, fps=fps))
        trade.append({"varied": what, "amplitude": amp, "duration_s": dur, "fps": fps, "frames": int(dur * fps),
                      "coil_rise_K": heat["rise_K"], "energy_J": heat["energy_J"],
                      "over_limit": heat["peak_C"] > heat["cut_C"], **st})
        print(trade[-1], flush=True)
    # 3. ablation
    cases = [(S.Case(r), s) for r in DISTANCES for s in SEEDS]
    nosweep = batch(design, cases, noise, sweep=False)[0]
    refused = sum(r.status == "refused" for r in nosweep)
    guess = np.array([abs(35.0 - c.r_mm) for c, _ in cases])
    ablation = [{"estimator": "sweep (defaults)", "median_mm": rows[0]["median_mm"], "p90_mm": rows[0]["p90_mm"],
                 "answered_pct": rows[0]["answered_pct"], "note": "rigid, approach 0 deg"},
                {"estimator": "same frames, coil off", "median_mm": float("nan"), "p90_mm": float("nan"),
                 "answered_pct": 100.0 * (len(nosweep) - refused) / len(nosweep),
                 "note": f"{refused}/{len(nosweep)} refused: " + nosweep[0].message},
                {"estimator": "no sweep, best constant guess (35 mm)", "median_mm": float(np.median(guess)),
                 "p90_mm": float(np.percentile(guess, 90)), "answered_pct": 100.0,
                 "note": "what any estimator without the sweep's information can do at best on a uniform 10-60 mm"}]
    # 4. full pipeline
    full = []
    for r, ang, cone in ((15.0, 0.0, False), (35.0, 0.0, False), (55.0, 0.0, False), (35.0, 20.0, False),
                         (35.0, 30.0, False), (15.0, 30.0, True), (35.0, 30.0, True), (55.0, 30.0, True)):
        res, tru = S.run_case(design, S.Case(r, None, ang), frames=True, seed=int(r), fps=FPS, mu=mu if cone else None)
        full.append({"r_mm": r, "approach_deg": ang, "estimator": "cone edge (opt-in)" if cone else "default",
                     "regime": res.details.get("regime"), "status": res.status, "estimate_mm": res.distance_mm, "sigma_mm": res.distance_sigma_mm,
                     "error_mm": None if res.distance_mm is None else res.distance_mm - r,
                     "force_mN": res.force_mN, "true_force_mN": tru["force_mN"]})
        full[-1] = {key: float("nan") if v is None else v for key, v in full[-1].items() if key != "_"}
        print(full[-1], flush=True)
    write_csv("locate.csv", rows)
    write_csv("locate_tradeoff.csv", trade)
    plot(error_curves, trade)
    k, k_src = L.membrane_stiffness_Nmm_per_rad(design)
    heat0 = L.sweep_heat(design, L.DEFAULT_AMPLITUDE, L.DEFAULT_DURATION_S)
    f = {"median_mm": ".2f", "p90_mm": ".2f", "answered_pct": ".0f", "force_median_pct": ".1f", "coil_rise_K": ".1f",
         "energy_J": ".2f", "approach_deg": ".0f", "estimate_mm": ".2f", "sigma_mm": ".2f", "error_mm": ".2f",
         "force_mN": ".3f", "true_force_mN": ".3f", "bound_holds_pct": ".0f", "bound_excess_mm": ".2f", "amplitude": ".2f", "duration_s": ".2f", "fps": ".0f"}
    text = f"""# Contact distance by active whisking (whisker.sensing.locate), in simulation

Machine: {machine_line()}; whole run {time.perf_counter() - t0:.0f} s. Generated by `benchmarks/bench_locate.py`.
Simulator: whisker.sim.experiments.locate_sweep (membrane k = {k:.3g} N*mm/rad from {k_src}; rod EI =
{L.bending_stiffness_Nmm2(design):.0f} N*mm^2 from mechanics.rod_modulus {design.mechanics.rod_modulus:g} GPa and a
{design.whiskers.rod_diameter:g} mm rod; rod friction mu = {mu:g}, contact.rod_friction). Camera: the real tracker
on rendered frames (method `{S.METHOD}`), noise sigma 2, blur 0.8 px: its tilt error is {1e6 * sig[0]:.0f} / {1e6 * sig[1]:.0f} urad
(radial / tangential) per frame, resampled from 200 rendered rest frames; section 4 renders every frame.
Object preload: the object pushed the whisker to 2 deg before the sweep.

Defaults (whisker.sensing.locate): level {L.DEFAULT_AMPLITUDE:g}, {L.DEFAULT_DURATION_S:g} s square wave of
{L.DEFAULT_PERIOD_S:g} s period, camera {FPS:g} fps: the coil warms {heat0['rise_K']:.1f} K ({heat0['energy_J']:.2f} J).

## Headline: rigid objects, 10-60 mm, approach angles {', '.join(f'{a:g}' for a in APPROACH)} deg (default estimator)

median error **{head['median_mm']:.2f} mm**, 90th percentile **{head['p90_mm']:.2f} mm**, {head['answered_pct']:.0f} % of
{head['sweeps']} sweeps answered ({head['statuses']}; regimes of the answered: {head['regimes']}); contact force
median error {head['force_median_pct']:.1f} %. At the angles at which the contact sticks ({', '.join(f'{a:g}' for a in stick)} deg;
tan(angle) <= mu): median **{head_stick['median_mm']:.2f} mm**, p90 **{head_stick['p90_mm']:.2f} mm** ({head_stick['statuses']}).

## 1. Accuracy at the defaults ({len(DISTANCES)} distances 10-60 mm x {len(SEEDS)} seeds per row)

Errors over the answered sweeps (status "ok"); the rest got a status without a number. `regimes`: how
the answered contacts behaved under the sweep, as the estimator classified them (whisker.sensing.contact_slip:
stick; shakedown = slid in the first loading, stuck after, located on the later cycles; cyclic slip =
slides every cycle: refused ("slip") by default, located at the friction cone's edges by the opt-in
rows (mu = {mu:g} given; with the tracker's noise on the exact tilt: section 4 shows what the rendered
frames' absolute-tilt errors do to it). `compliance unknown`: the estimator is told the object may be
soft; it answers "upper bound" (a soft object only looks farther), never a distance: `bound_holds_pct`
how often the bound is at or beyond the true contact, `bound_excess_mm` its median excess.

{markdown_table(rows, ["object", "approach_deg", "estimator", "median_mm", "p90_mm", "answered_pct", "force_median_pct", "statuses", "regimes", "bound_holds_pct", "bound_excess_mm"], f)}

## 2. Accuracy against sweep amplitude, duration and frame rate, and the heat it costs

Rigid object, approach 0 deg, 6 distances x 4 seeds. `coil_rise_K`: the coil's temperature rise over
the sweep from ambient; `over_limit`: past the temperature where the thermal guard starts derating (`whisker locate` refuses it).

{markdown_table(trade, ["varied", "amplitude", "duration_s", "fps", "frames", "coil_rise_K", "energy_J", "over_limit", "median_mm", "p90_mm", "answered_pct"], f)}

## 3. Ablation: the sweep carries the information

{markdown_table(ablation, ["estimator", "median_mm", "p90_mm", "answered_pct", "note"], f)}

## 4. Full pipeline: every frame rendered and tracked (defaults, rigid)

The tracked tilt is zeroed on 30 rest frames tracked the same way (the free whisker's rest) and read
with the camera's exact ray model. The cone-edge estimate reads the ABSOLUTE tilt: 1e-5 rad of error
moves it by ~0.7 mm (0.1 % of tracker gain by ~0.75 mm), where the stick estimate reads only the
in-axis change.

{markdown_table(full, ["r_mm", "approach_deg", "estimator", "regime", "status", "estimate_mm", "sigma_mm", "error_mm", "force_mN", "true_force_mN"], f)}

![error vs distance, accuracy vs heat](locate.png)
"""
    write_text("locate.md", text)
    print(text)
    return 0


def plot(curves, trade):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.6))
    for label, pts in curves.items():
        pts = np.array(pts, dtype=float)
        rs = np.unique(pts[:, 0])
        med = [np.nanmedian(np.abs(pts[pts[:, 0] == r, 1])) if np.isfinite(pts[pts[:, 0] == r, 1]).any() else np.nan
               for r in rs]
        a.plot(rs, med, "o-" if label.startswith("rigid") else ".--", label=label)
    a.axhline(2.0, color="k", lw=0.8, ls=":")
    a.set_yscale("log")
    a.set_xlabel("true contact distance from the pivot (mm)")
    a.set_ylabel("median |error| (mm), answered sweeps")
    a.set_title("defaults; rigid at 0-40 deg approach, compliant at 0 deg (gaps: no answer)", fontsize=9)
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
    for what, m in (("amplitude", "o"), ("duration", "s"), ("fps", "^")):
        pts = [t for t in trade if t["varied"] == what]
        b.plot([t["coil_rise_K"] for t in pts], [t["median_mm"] for t in pts], m + "-", label=f"median, {what} varied")
        b.plot([t["coil_rise_K"] for t in pts], [t["p90_mm"] for t in pts], m + ":", alpha=0.6, label=f"p90, {what} varied")
    b.axhline(2.0, color="k", lw=0.8, ls=":")
    b.axhline(5.0, color="k", lw=0.8, ls="--")
    b.set_xlabel("coil temperature rise over the sweep (K)")
    b.set_ylabel("distance error (mm)")
    b.set_title("accuracy vs heat (rigid, 10-60 mm)", fontsize=9)
    b.legend(fontsize=6)
    b.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, "locate.png")
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
