"""The paper's contact experiments in simulation: grasp table, displacement vs time, classification.

Each attempt is an ordinary scene (whisker.sim.scene) built from the experiment scene's objects and
parameters, simulated with MuJoCo (the plan builds contact because the object is within reach).

Grasp protocol (paper Section III-B): the sensor starts above the object, descends until the tips are
``experiment.tip_height`` mm above the table, drives the configuration's coils at the design's
``actuation.voltage`` (the paper's 3 V) as a level of the full-scale coil voltage
(:func:`grasp_level`, whisker.drive.guard), waits for the whiskers to close, lifts ``experiment.lift`` mm, holds;
success if the object's centre ends more than ``experiment.hold_height`` mm above its resting height.
Placement noise: the object's (x, y) ~ N(0, placement_noise^2) per axis, yaw uniform in
+-yaw_noise; the sensor's yaw uniform over one whisker spacing.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass

import numpy as np

from whisker.sim.experiments.repeat import PAPER_GRASP, PAPER_GRASP_TOTAL
from whisker.sim.protocol import (START_HEIGHT, T_CLOSE, T_DOWN, T_HOLD, T_LIFT, T_RELEASE,  # noqa: F401 (public here)
                                  Placement, draw_placement, grasp_level, grasp_scene)
from whisker.sim.scene import Scene, SceneError

def experiment_objects(scene: Scene) -> list:
    """The objects an experiment uses: ``experiment.objects`` in that order, else all of the scene's."""
    names = scene.experiment.objects
    if not names:
        return list(scene.objects)
    by_name = {o.name: o for o in scene.objects}
    return [by_name[n] for n in names]          # the scene validator checked every name


def configurations(scene: Scene, design) -> list[list[int]]:
    """Whisker index sets: the scene's, else the paper's all / every second / opposite pair."""
    if scene.experiment.configurations:
        return [list(c) for c in scene.experiment.configurations]
    n = design.whiskers.count
    out = [list(range(n))]
    if n % 2 == 0 and n >= 4:
        out.append(list(range(0, n, 2)))
    if n % 2 == 0:
        out.append([0, n // 2])
    return out


@dataclass
class Attempt:
    obj: str
    config: int
    success: bool
    lift_mm: float
    result: object = None


def grasp_attempt(scene, design, obj, active, rng=None, *, keep=False, release=False, body=None,
                  placement: Placement | None = None) -> Attempt:
    """One attempt at `placement` (default: drawn from `rng`, see :func:`draw_placement`)."""
    from whisker.sim.effects.plan import plan
    from whisker.sim.simulate import simulate

    e = scene.experiment
    pl = placement if placement is not None else draw_placement(scene, design, rng)
    s = grasp_scene(scene, obj, active, dx=pl.dx, dy=pl.dy, obj_yaw=pl.obj_yaw, sensor_yaw=pl.sensor_yaw,
                    release=release, level=grasp_level(design))
    p = plan(s, design)
    if not p.built("contact"):
        raise SceneError(f"grasp: object {obj.name!r} is out of reach of the whiskers")
    res = simulate(s, design, p, body=body)
    z = res.objects_mm[:, 0, 2]
    t_end = T_DOWN + T_CLOSE + T_LIFT + T_HOLD
    k_end = int(np.searchsorted(res.t_s, t_end - 1e-9))
    k_end = min(k_end, len(z) - 1)
    lift = float(z[k_end] - z[0])
    ok = bool(lift > e.hold_height and np.all(np.isfinite(z)))
    return Attempt(obj.name, len(active), ok, lift, res if keep else None)


def _attempt_outcome(scene, design, obj, cfg, body, placement) -> tuple[bool, float]:
    a = grasp_attempt(scene, design, obj, cfg, body=body, placement=placement)
    return a.success, a.lift_mm


def grasp_table(scene: Scene, design, progress=None, n_jobs: int = 1) -> dict:
    """Success rate (%) per object and configuration, with the paper's numbers beside them.

    Every configuration of an object sees the same placements (common random numbers), so the
    differences between the columns come from the configurations, not from different draws. The
    placements are drawn first (seeded per object), then the attempts run over `n_jobs` joblib
    worker processes (each attempt is its own MuJoCo model): the table is the same for any `n_jobs`.
    """
    from joblib import Parallel, delayed

    from whisker.coil.kinematics import whisker_body

    e = scene.experiment
    objs = experiment_objects(scene)
    if not objs:
        raise SceneError("grasp experiment: the scene has no objects")
    if n_jobs < 1:
        raise ValueError(f"grasp table: n_jobs must be >= 1 (got {n_jobs})")
    cfgs = configurations(scene, design)
    body = whisker_body(design)
    jobs = []
    for oi, o in enumerate(objs):
        rng = np.random.default_rng([scene.scene.seed, oi])
        places = [draw_placement(scene, design, rng) for _ in range(e.attempts)]
        jobs += [(oi, ci, o, cfg, pl) for ci, cfg in enumerate(cfgs) for pl in places]
    total = len(jobs)
    out = []
    run = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_attempt_outcome)(scene, design, o, cfg, body, pl) for _, _, o, cfg, pl in jobs)
    for k, res in enumerate(run):
        out.append(res)
        if progress:
            progress((k + 1) / total)
    rates: dict[str, list[float]] = {o.name: [] for o in objs}
    lifts: dict[str, list[list[float]]] = {o.name: [] for o in objs}
    held: dict[str, list[list[bool]]] = {o.name: [] for o in objs}
    for oi, o in enumerate(objs):
        for ci in range(len(cfgs)):
            rows = [r for (a, c, *_), r in zip(jobs, out) if a == oi and c == ci]
            ok = [r[0] for r in rows]
            rates[o.name].append(100.0 * float(np.mean(ok)))
            lifts[o.name].append([r[1] for r in rows])
            held[o.name].append(ok)
    totals = [float(np.mean([rates[o.name][c] for o in objs])) for c in range(len(cfgs))]
    n = e.attempts
    ci95 = {name: [wilson_interval(round(v / 100 * n), n) for v in r] for name, r in rates.items()}
    paired = {name: paired_comparisons(h) for name, h in held.items()}
    return {"configurations": cfgs, "rates": rates, "ci95": ci95, "totals": totals, "attempts": n,
            "tip_force": tip_pressing_mN(design),
            "objects": {o.name: o.mass for o in objs}, "lifts_mm": lifts, "paired": paired,
            "order": {name: grasp_order(r, ci95[name], paired[name]) for name, r in rates.items()}}


def tip_pressing_mN(design, tilts_deg=(0.0, 4.0, 8.0), facing: str = "down") -> dict:
    """The force (mN) with which a tip blocked at each tilt (deg, radial) presses the object at the
    grasp level (coil at 20 C): the net closing torque, the coil's pull at that tilt's gap minus the
    membrane spring (and the whisker's weight), tau = tau_mag(I, theta) + tau_grav(theta) - k theta
    (whisker.coil.kinematics), over the pivot-to-tip lever. Also the free tilt (deg) and whether it
    is the end stop (the whisker pulled in onto it: there the net torque loads the stop, not an object)."""
    from whisker.coil.kinematics import gravity_torque, magnetic_torque, static_equilibrium, whisker_body
    from whisker.sim.contract import current_A, full_scale_voltage

    body = whisker_body(design)
    I = float(current_A(design, grasp_level(design) * full_scale_voltage(design)))
    eq = static_equilibrium(design, body, np.array([I]), facing=facing)
    out = {}
    for deg in tilts_deg:
        th = math.radians(deg)
        tau = float(magnetic_torque(design, body, th, I)) + float(gravity_torque(body, th, facing)) - body.stiffness * th
        out[float(deg)] = 1e3 * tau / body.tip_m                     # N m / m -> mN
    return {"force_mN": out, "free_tilt_deg": float(np.degrees(eq.theta_rad[0])),
            "at_stop": bool(eq.at_stop[0]), "stop_deg": float(np.degrees(body.stop_rad)),
            "at_stop_mN": 1e3 * (float(magnetic_torque(design, body, body.stop_rad, I))
                                 + float(gravity_torque(body, body.stop_rad, facing))
                                 - body.stiffness * body.stop_rad) / body.tip_m}


def paired_comparisons(held: list[list[bool]]) -> list[dict]:
    """For each neighbouring pair of configurations (more whiskers first) over the same placements:
    ``wins`` (the larger one holds, the smaller drops), ``losses`` (the reverse) and the exact one-sided
    McNemar p-value, P(wins >= observed | wins ~ Binomial(wins + losses, 1/2)) (McNemar 1947; the
    exact binomial form, e.g. Agresti, Categorical Data Analysis, sec. 10.1)."""
    from scipy.stats import binomtest

    out = []
    for a, b in zip(held, held[1:]):
        wins = sum(1 for x, y in zip(a, b) if x and not y)
        losses = sum(1 for x, y in zip(a, b) if y and not x)
        p = binomtest(wins, wins + losses, 0.5, alternative="greater").pvalue if wins + losses else 1.0
        out.append({"wins": wins, "losses": losses, "p": float(p)})
    return out


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Binomial 95 % confidence interval of a success rate, % (Wilson score interval; Wilson 1927,
    recommended over the normal approximation near 0 and 100 % by Brown, Cai & DasGupta 2001)."""
    if n <= 0:
        raise ValueError("wilson_interval: n must be > 0 attempts")
    if not 0 <= successes <= n:
        raise ValueError(f"wilson_interval: successes {successes} not in 0..{n}")
    p = successes / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    lo = 0.0 if successes == 0 else 100 * max(0.0, mid - half)        # exact ends (no rounding below 100 %)
    hi = 100.0 if successes == n else 100 * min(1.0, mid + half)
    return (min(lo, 100 * p), max(hi, 100 * p))


def grasp_order(rates: list[float], ci95: list[tuple[float, float]], paired: list[dict] | None = None) -> dict:
    """Does the success rate fall strictly with fewer whiskers (configurations in the given order)?
    ``strict``: every neighbouring pair strictly ordered; ``weak``: >=; ``resolved``: strictly, and each
    pair's difference is significant: the exact McNemar p < 0.05 on the paired attempts when `paired` is
    given (:func:`paired_comparisons`), else disjoint 95 % intervals."""
    pairs = list(zip(rates, rates[1:]))
    if paired is not None:
        sig = [c["p"] < 0.05 for c in paired]
    else:
        sig = [ca[0] > cb[1] for ca, cb in zip(ci95, ci95[1:])]
    return {"strict": all(a > b for a, b in pairs), "weak": all(a >= b for a, b in pairs),
            "resolved": all(a > b and ok for (a, b), ok in zip(pairs, sig))}


def grasp_markdown(tab: dict) -> str:
    cfgs = tab["configurations"]
    head = " | ".join(f"{len(c)} whiskers sim [95 % CI] / paper" for c in cfgs)
    pair_head = " | ".join(f"{len(a)} vs {len(b)}: wins-losses (p)" for a, b in zip(cfgs, cfgs[1:]))
    lines = [f"| object (mass) | {head} | {pair_head} | order |",
             "| --- |" + " --- |" * (2 * len(cfgs))]
    for name, r in tab["rates"].items():
        paper = PAPER_GRASP.get(name)
        cells = []
        for ci, v in enumerate(r):
            p = f"{paper[ci]}" if paper and ci < 3 and len(cfgs) == 3 else "-"
            lo, hi = tab["ci95"][name][ci]
            cells.append(f"{v:.0f} [{lo:.0f}-{hi:.0f}] / {p}")
        cells += [f"{c['wins']}-{c['losses']} ({c['p']:.2g})" for c in tab["paired"][name]]
        o = tab["order"][name]
        verdict = ("-" if len(r) < 2 else "strict, resolved" if o["resolved"] else "strict" if o["strict"]
                   else "tie" if o["weak"] else "no")
        lines.append(f"| {name} ({tab['objects'][name]:g} g) | " + " | ".join(cells) + f" | {verdict} |")
    tot = [f"{v:.0f} / {PAPER_GRASP_TOTAL[ci] if len(cfgs) == 3 else '-'}" for ci, v in enumerate(tab["totals"])]
    lines.append("| total | " + " | ".join(tot) + " |" + " |" * len(cfgs))
    return "\n".join(lines) + (
        f"\n\n{tab['attempts']} simulated attempts per cell (sim %, Wilson 95 % interval) beside the paper's 20 "
        "(paper %). Every configuration sees the same placements; 'wins-losses': attempts the larger "
        "configuration holds and the smaller drops, and the reverse; p: exact one-sided McNemar test. "
        "'resolved': strictly ordered and every p < 0.05." + _force_line(tab) + "\n")


def _force_line(tab: dict) -> str:
    f = tab.get("tip_force")
    if not f:
        return ""
    at = ", ".join(f"{v:.2f} mN at {k:g} deg" for k, v in f["force_mN"].items())
    free = (f"the free whisker pulls in onto the {f['stop_deg']:g} deg end stop (pressing it with {f['at_stop_mN']:.2f} mN "
            "at the tip's lever)" if f["at_stop"] else f"the free whisker closes to {f['free_tilt_deg']:.1f} deg")
    return (f" Each tip that meets an object presses it with {at} of tilt (the coil's pull at that gap minus "
            f"the membrane spring, over the pivot-to-tip lever, coil at 20 C); {free}.")


def grasp_csv(tab: dict) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["object", "mass_g", "active_whiskers", "success_pct_sim", "ci95_low_pct", "ci95_high_pct",
                "success_pct_paper", "attempts"])
    for name, r in tab["rates"].items():
        for ci, v in enumerate(r):
            paper = PAPER_GRASP.get(name)
            p = paper[ci] if paper and len(tab["configurations"]) == 3 else ""
            lo, hi = tab["ci95"][name][ci]
            w.writerow([name, tab["objects"][name], len(tab["configurations"][ci]), f"{v:.1f}", f"{lo:.1f}",
                        f"{hi:.1f}", p, tab["attempts"]])
    return buf.getvalue()


# --- displacement vs time (Fig. 8) -------------------------------------------------------------

def displacement_runs(scene: Scene, design, progress=None) -> dict:
    """Per object: marker displacement magnitude (px) of each whisker against time over trials."""
    from whisker.coil.kinematics import whisker_body

    e = scene.experiment
    objs = experiment_objects(scene)
    n = design.whiskers.count
    body = whisker_body(design)
    out = {}
    total = len(objs) * e.trials
    done = 0
    for oi, o in enumerate(objs):
        rng = np.random.default_rng([scene.scene.seed, 100 + oi])
        series = []
        succ = []
        for _ in range(e.trials):
            a = grasp_attempt(scene, design, o, list(range(n)), rng, keep=True, release=True, body=body)
            r = a.result
            dm = r.markers_mm[:, :, :2] - r.markers_mm[:1, :, :2]
            series.append(np.hypot(dm[..., 0], dm[..., 1]) / design.mm_per_px)
            succ.append(a.success)
            done += 1
            if progress:
                progress(done / total)
        arr = np.array(series)                                   # (trials, T, N) px
        out[o.name] = {"t_s": r.t_s, "disp_px": arr, "mean": arr.mean(axis=0), "std": arr.std(axis=0),
                       "success": succ}
    phases = {"retract": T_DOWN, "lift": T_DOWN + T_CLOSE, "release": T_DOWN + T_CLOSE + T_LIFT + T_HOLD}
    return {"objects": out, "phases": phases}


def plot_displacement(d: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objs = d["objects"]
    fig, axes = plt.subplots(1, len(objs), figsize=(5.5 * len(objs), 3.6), squeeze=False, sharey=True)
    for ax, (name, r) in zip(axes[0], objs.items()):
        t = r["t_s"]
        for i in range(r["mean"].shape[1]):
            ax.plot(t, r["mean"][:, i], lw=1, label=f"w{i}")
            ax.fill_between(t, r["mean"][:, i] - r["std"][:, i], r["mean"][:, i] + r["std"][:, i], alpha=0.2)
        for k, (ph, tt) in enumerate(d["phases"].items(), 1):
            ax.axvline(tt, color="k", ls="--", lw=0.7)
            ax.text(tt, ax.get_ylim()[1] * 0.95 if ax.get_ylim()[1] > 0 else 1, f" ({k})", fontsize=8)
        ax.set_title(f"{name}: mean and +-1 sd over {r['disp_px'].shape[0]} trials")
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("marker displacement (px)")
    axes[0][-1].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# --- classification dataset ----------------------------------------------------------------

def classification_sample(scene: Scene, design, obj, rotation_deg: float, rng, body=None) -> np.ndarray:
    """One sample: for each approach direction and distance, the N markers' (dx, dy) in px.

    The sensor (whiskers down, tips ``tip_height`` above the table) starts with its front tip 60 mm
    from the object's centre on the approach line, moves horizontally until the front tip is at each
    recording distance (far first), settles 0.15 s, and the markers' pixel displacements are read. Layout: directions x distances x whiskers x (dx, dy)
    = 4 x 2 x 8 x 2 = 128 values for the paper's sensor, rounded to integers like the authors' data.
    """
    from whisker.sim.effects.plan import plan
    from whisker.sim.scene import scene_from_dict
    from whisker.sim.simulate import simulate

    e = scene.experiment
    vals = []
    speed = 100.0  # mm/s approach
    start = 60.0
    for k in range(e.directions):
        ang = math.radians(360.0 * k / e.directions)
        ux, uy = math.cos(ang), math.sin(ang)
        dx, dy = rng.normal(0.0, e.placement_noise, 2) if e.placement_noise > 0 else (0.0, 0.0)
        ox, oy = obj.pos[0] + dx, obj.pos[1] + dy
        ring = design.whiskers.ring_radius
        path = [[0.0, ox - (start + ring) * ux, oy - (start + ring) * uy, e.tip_height, rotation_deg]]
        times = []
        t = 0.0
        prev = start
        for dist in e.distances:
            t += abs(prev - dist) / speed
            path.append([t, ox - (dist + ring) * ux, oy - (dist + ring) * uy, e.tip_height, rotation_deg])
            t += 0.15                                    # settle, then record
            path.append([t, ox - (dist + ring) * ux, oy - (dist + ring) * uy, e.tip_height, rotation_deg])
            times.append(t)
            prev = dist
        o = obj.model_dump()
        o["pos"] = [ox, oy]
        o["yaw"] = obj.yaw + rng.uniform(-e.yaw_noise, e.yaw_noise)
        data = scene.model_dump()
        data.update(objects=[o], sensor={"facing": "down", "path": path},
                    actuation={"schedule": []}, experiment={"kind": "none"},
                    scene={**data["scene"], "duration": t},
                    fidelity={**data["fidelity"], "contact": "on"})
        s = scene_from_dict(data)
        res = simulate(s, design, plan(s, design), body=body, record_hz=100.0)
        from whisker.sim.contract import marker_pixels
        rest = marker_pixels(design, res.markers_mm[0])
        for tt in times:
            j = min(int(np.searchsorted(res.t_s, tt - 1e-9)), len(res.t_s) - 1)
            px = marker_pixels(design, res.markers_mm[j]) - rest
            vals.append(px.reshape(-1))
    return np.rint(np.concatenate(vals)).astype(int)


def classification_dataset(scene: Scene, design, progress=None) -> dict[str, np.ndarray]:
    """{object: (rotations x trials, 8 * N * 2 * ...) int array} in the authors' layout."""
    from whisker.coil.kinematics import whisker_body

    e = scene.experiment
    objs = experiment_objects(scene)
    if not objs:
        raise SceneError("classification experiment: the scene has no objects")
    body = whisker_body(design)
    out = {}
    total = len(objs) * len(e.rotations) * e.trials
    done = 0
    for oi, o in enumerate(objs):
        rng = np.random.default_rng([scene.scene.seed, 200 + oi])
        rows = []
        for rot in e.rotations:
            for _ in range(e.trials):
                rows.append(classification_sample(scene, design, o, rot, rng, body=body))
                done += 1
                if progress:
                    progress(done / total)
        out[o.name] = np.array(rows)
    return out


def dataset_info(scene: Scene, design) -> dict:
    """The folder's ``dataset.json`` for ``whisker.data.dataset_files.load_csv_folder``: whisker count, the sense
    of the whisker numbering in the camera image (``whisker.data.dataset_files.design_sense``) and the row order:
    pose-major, ``trials_per_pose`` rows per sensor rotation (row = trials * rotation + trial), so each
    row's trial id and pose (rotation index) are known."""
    from whisker.sim.contract import design_sense

    e = scene.experiment
    return {"n_whiskers": design.whiskers.count, "sense": design_sense(design), "trials_per_pose": e.trials,
            "rotations_deg": list(e.rotations), "records": e.directions * len(e.distances),
            "source": f"whisker sim ({scene.scene.name}, design {design.digest()})"}


def dataset_csv(rows: np.ndarray) -> str:
    return "".join(",".join(str(int(v)) for v in r) + "\n" for r in rows)


def run(kind: str, scene: Scene, design, files: dict, progress=None, jobs: int = 1) -> dict:
    """Run a contact experiment, add its files to `files`, return summary entries (`jobs`: joblib
    worker processes for the grasp table)."""
    from whisker.sim.run import png_bytes

    if kind == "grasp":
        tab = grasp_table(scene, design, progress, n_jobs=jobs)
        files["grasp_table.md"] = grasp_markdown(tab)
        files["grasp_table.csv"] = grasp_csv(tab)
        order = {n: bool(o["strict"]) for n, o in tab["order"].items()}
        return {"grasp": {k: v for k, v in tab.items() if k != "lifts_mm"}, "order_strict": order,
                "headline": grasp_markdown(tab)}
    if kind == "displacement":
        d = displacement_runs(scene, design, progress)
        files["displacement.png"] = png_bytes(lambda p: plot_displacement(d, p))
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        n = design.whiskers.count
        w.writerow(["object", "t_s", *[f"mean_w{i}_px" for i in range(n)], *[f"sd_w{i}_px" for i in range(n)]])
        spread = {}
        for name, r in d["objects"].items():
            for k, t in enumerate(r["t_s"]):
                w.writerow([name, f"{t:.4f}", *(f"{v:.4g}" for v in r["mean"][k]), *(f"{v:.4g}" for v in r["std"][k])])
            spread[name] = float(r["std"].mean())
        files["displacement.csv"] = buf.getvalue()
        head = ", ".join(f"{k}: mean sd {v:.2f} px" for k, v in spread.items())
        return {"displacement_mean_sd_px": spread, "phases_s": d["phases"], "headline": f"displacement spread: {head}"}
    if kind == "classification":
        ds = classification_dataset(scene, design, progress)
        for name, rows in ds.items():
            files[f"dataset/{name}.csv"] = dataset_csv(rows)
        files["dataset/dataset.json"] = json.dumps(dataset_info(scene, design), indent=2) + "\n"
        shape = {k: list(v.shape) for k, v in ds.items()}
        return {"dataset": shape, "headline": f"dataset/: {', '.join(f'{k} {v[0]}x{v[1]}' for k, v in shape.items())}"}
    raise SceneError(f"experiment.kind {kind!r} is not known")
