"""What simulation accuracy costs in time, per scene type (issue 8).

Writes benchmarks/results/sim.md, sim.csv and sim.png (atomically). For every scene type, each
cheaper variant (time step, integrator, contact settings, coil-force lookup, tracker and geometry
model) is run beside a fine reference and reported as error against it and time. Times are the
process's CPU time (time.process_time: one core, independent of other jobs on a shared machine),
best of several repeats. Targets (issue 8): grasp scene >= 20x faster than real time, static deflection
scene <= 1 ms.

Run: .venv/bin/python benchmarks/bench_sim.py   (or `make bench`, `make sim-bench`)
"""

from __future__ import annotations

import csv
import io
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
QUICK = os.environ.get("SIM_BENCH_QUICK") == "1"
GRASP_DT = float("nan")      # the grasp scene's time step, set by bench_grasp


def _best(fn, repeat=5):
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.process_time()          # CPU time of this process: one core, whatever the load
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def bench_static(design, rows):
    from whisker.sim import plan, scene_from_dict, simulate
    from whisker.sim.contract import current_A
    from whisker.coil.kinematics import static_equilibrium, whisker_body

    design = _full_scale(design, 1.0)                     # level 1 = 1 V at the coil
    body = whisker_body(design)
    s = scene_from_dict({"actuation": {"schedule": [{"t": 0.0, "level": 1.0}]},
                         "sensor": {"facing": "down"}})
    p = plan(s, design)
    I = current_A(design, np.array([1.0]))
    ref = static_equilibrium(design, body, I, facing="down", model="filament", grid=400, iters=200).theta_rad[0]
    for label, kw in [("grid 48 + Illinois, table", dict(model="table")),
                      ("grid 16 + at most 20 Illinois steps, table", dict(model="table", grid=16, iters=20)),
                      ("grid 48 + Illinois, filament", dict(model="filament")),
                      ("grid 48 + Illinois, dipole", dict(model="dipole"))]:
        t, eq = _best(lambda: static_equilibrium(design, body, I, facing="down", **kw), 20)
        rows.append(("static deflection (1 whisker, 1 V)", label, abs(np.degrees(eq.theta_rad[0] - ref)), "deg", t * 1e3, ""))
    t, r = _best(lambda: simulate(s, design, p, body=body), 20)
    rows.append(("static deflection scene", "simulate(): static solve, 8 whiskers", abs(r.theta_deg[0, 0, 0] - np.degrees(ref)),
                 "deg", t * 1e3, "target <= 1 ms"))
    t2, _ = _best(lambda: simulate(s, design, plan(s, design)), 5)
    rows.append(("static deflection scene", "plan() + simulate()", abs(r.theta_deg[0, 0, 0] - np.degrees(ref)), "deg", t2 * 1e3, ""))
    sd = scene_from_dict({**s.model_dump(), "scene": {"duration": 2.0, "timestep": 1e-3},
                          "fidelity": {"solver": "dynamic", "heating": "off"}})
    t3, r3 = _best(lambda: simulate(sd, design, body=body), 1)
    rows.append(("static deflection scene", "time stepping 2 s to settle (what the static solve saves)",
                 abs(r3.theta_deg[-1, 0, 0] - np.degrees(ref)), "deg", t3 * 1e3, ""))


def _full_scale(design, volts):
    """The design with level 1 = `volts` at the coil (whisker.drive.guard.full_scale_voltage reads it)."""
    from whisker.design import design_from_dict

    data = design.model_dump()
    data["drive"]["full_scale_voltage"] = volts
    return design_from_dict(data)


def bench_free(design, rows, curves):
    from whisker.sim import scene_from_dict, simulate
    from whisker.coil.kinematics import whisker_body

    design = _full_scale(design, 1.0)                     # level 1 = 1 V at the coil
    body = whisker_body(design)
    base = {"scene": {"duration": 0.6}, "sensor": {"facing": "down"},
            "actuation": {"schedule": [{"t": 0.05, "level": 1.0}, {"t": 0.35, "level": -0.5}]},
            "fidelity": {"heating": "off"}}

    def run(dt, integ, lut=256):
        s = scene_from_dict({**base, "scene": {"duration": 0.6, "timestep": dt},
                             "fidelity": {"heating": "off", "integrator": integ, "magnetics_lookup": lut}})
        return simulate(s, design, body=body, record_hz=1000)

    ref = run(2e-5, "implicit", 0)
    tr = ref.t_s
    for dt in [5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4]:
        for integ in ["implicit", "euler"]:
            try:
                t, r = _best(lambda: run(dt, integ), 2)
            except Exception as err:  # the explicit step refuses beyond its limit
                rows.append(("free whiskers (step response)", f"{integ}, dt {dt:g} s", float("nan"), "deg", float("nan"), f"refused: {err}"))
                continue
            err = np.abs(np.interp(tr, r.t_s, r.theta_deg[:, 0, 0]) - ref.theta_deg[:, 0, 0]).max()
            rows.append(("free whiskers (step response)", f"{integ}, dt {dt:g} s", err, "deg max",
                         t * 1e3, f"{0.6 / t:.0f}x real time"))
            curves.setdefault(f"free {integ}", []).append((t / 0.6, err))
    t, r = _best(lambda: run(1e-3, "implicit", 0), 2)
    err = np.abs(np.interp(tr, r.t_s, r.theta_deg[:, 0, 0]) - ref.theta_deg[:, 0, 0]).max()
    rows.append(("free whiskers (step response)", "implicit, dt 0.001 s, magnetics model every step (no lookup)", err,
                 "deg max", t * 1e3, f"{0.6 / t:.0f}x real time"))


def bench_grasp(design, rows, curves):
    from whisker.sim import load_scene, plan, simulate
    from whisker.sim.experiments import paper
    from whisker.coil.kinematics import whisker_body

    body = whisker_body(design)
    s0 = load_scene(ROOT / "software" / "whisker" / "sim" / "scenes" / "grasp.toml")
    objs = [o for o in s0.objects if o.name in ("foam ball", "mini pinecone")]
    cases = []
    for o in objs:
        for cfg in paper.configurations(s0, design)[:2]:
            cases.append((o, cfg))

    def variant(dt, chunk, cone="elliptic", condim=4, patch=None, impratio=None):
        out = []
        wall = 0.0
        simt = 0.0
        for o, cfg in cases:
            s = paper.grasp_scene(s0, o, cfg, level=paper.grasp_level(design))
            s = s.with_(scene={**s.scene.model_dump(), "timestep": dt},
                        contact={**s.contact.model_dump(), "chunk": chunk, "cone": cone, "condim": condim,
                                 **({} if patch is None else {"patch_radius": patch}),
                                 **({} if impratio is None else {"impratio": impratio})})
            p = plan(s, design)
            t0 = time.process_time()
            r = simulate(s, design, p, body=body, record_hz=100)
            wall += time.process_time() - t0
            simt += r.t_s[-1]
            out.append(r)
        return wall, simt, out

    # the reference: the finest step, the coil torque every step and the hardest friction (impratio 10)
    _, _, ref = variant(2.5e-4, 1, impratio=10.0)
    variants = [(2e-3, 5), (2e-3, 1), (1e-3, 5), (1e-3, 1), (5e-4, 5), (4e-3, 5), (2e-3, 20)]
    if QUICK:
        variants = variants[:2]
    def add_row(label, run) -> float:
        """One table row for a variant's (cpu s, simulated s, results): mean RMS of the object height
        against the reference, and in how many attempts held / dropped agrees with it."""
        wall, simt, res = run
        err = float(np.mean([np.sqrt(np.mean((np.interp(rr.t_s, r.t_s, r.objects_mm[:, 0, 2])
                                                - rr.objects_mm[:, 0, 2]) ** 2)) for r, rr in zip(res, ref)]))
        agree = sum(int((r.objects_mm[-1, 0, 2] > 10) == (rr.objects_mm[-1, 0, 2] > 10)) for r, rr in zip(res, ref))
        rows.append(("grasp (MuJoCo)", label, err, "mm RMS object height", wall / simt * 1e3,
                     f"{simt / wall:.1f}x real time; outcome agrees {agree}/{len(res)}"))
        return err

    for dt, chunk in variants:
        run = variant(dt, chunk)
        err = add_row(f"dt {dt:g} s, chunk {chunk}", run)
        curves.setdefault("grasp", []).append((run[0] / run[1], err, f"{dt * 1e3:g} ms/{chunk}"))
    for cone, condim in [("pyramidal", 3), ("elliptic", 3)]:
        add_row(f"dt 0.002 s, chunk 5, {cone} cone, condim {condim}", variant(2e-3, 5, cone, condim))
    # friction-to-normal impedance ratio: MuJoCo's soft friction lets a held object creep; a larger
    # ratio makes friction harder (less creep) but costs Newton iterations
    for imp in (1.0, 2.0, 3.0, 5.0, 10.0):
        add_row(f"dt {s0.scene.timestep:g} s, chunk 5, impratio {imp:g}", variant(s0.scene.timestep, 5, impratio=imp))
    # the torsional-friction patch (a model choice, not a numerical one): how far it moves the answer
    for patch in (2.5, 7.5):
        add_row(f"dt 0.002 s, chunk 5, torsional patch {patch:g} mm (default 0.6)", variant(2e-3, 5, patch=patch))
    # one 8-whisker attempt of each object of the default grasp scene, timed alone
    global GRASP_DT
    GRASP_DT = s0.scene.timestep
    tot_cpu = tot_sim = 0.0
    for o in s0.objects:
        s = paper.grasp_scene(s0, o, list(range(design.whiskers.count)), level=paper.grasp_level(design))
        p = plan(s, design)
        t, r = _best(lambda: simulate(s, design, p, body=body), 5)   # best of 5: the machine is shared
        tot_cpu += t
        tot_sim += r.t_s[-1]
        rows.append(("grasp scene (default settings)", f"one 8-whisker attempt, {o.name} ({len(o.parts) + 1} geoms), "
                     f"dt {GRASP_DT:g} s", 0.0, "-", t * 1e3, f"{r.t_s[-1] / t:.1f}x real time"))
    rows.append(("grasp scene (default settings)", "the five objects together", 0.0, "-", tot_cpu * 1e3,
                 f"{tot_sim / tot_cpu:.1f}x real time (target >= 20x)"))
    return tot_sim / tot_cpu


def bench_camera(design, rows):
    try:
        import whisker.vision.render  # noqa: F401
        import whisker.vision.tracking  # noqa: F401
    except ImportError as err:
        rows.append(("camera end to end", "skipped", float("nan"), "", float("nan"), str(err)))
        return
    from whisker.sim import scene_from_dict, simulate
    from whisker.sim.camera import camera_run
    from whisker.vision.tracking import CalibrationError

    design = _full_scale(design, 3.0)                     # level 1 = the paper's 3 V at the coil
    base = {"scene": {"duration": 1.0, "timestep": 1e-3, "seed": 2}, "sensor": {"facing": "up"},
            "actuation": {"schedule": [{"t": 0.1, "level": 0.4, "whiskers": [0, 2, 4, 6]},
                                                       {"t": 0.1, "level": -0.8, "whiskers": [1, 3, 5, 7]},
                                                       {"t": 0.6, "level": 1.0}]},
            "fidelity": {"heating": "off"}}
    r = None
    for method in ["paper", "contour", "blob", "roi"]:
        for geom in ["paper", "exact"]:
            s = scene_from_dict({**base, "camera": {"enabled": True, "fps": 30, "method": method, "geometry": geom}})
            if r is None:
                r = simulate(s, design)
            t0 = time.process_time()
            try:
                cr = camera_run(s, design, r)
            except CalibrationError as err:     # the paper's erosion can lose every small marker
                rows.append(("camera end to end (render + track + geometry)", f"tracker {method}, geometry {geom}",
                             float("nan"), "mm RMS tip", float("nan"), f"refused: {str(err)[:120]}"))
                continue
            dt = (time.process_time() - t0) / len(cr.t_s)
            rows.append(("camera end to end (render + track + geometry)", f"tracker {method}, geometry {geom}",
                         cr.tip_rms_mm, "mm RMS tip", dt * 1e3,
                         f"max {cr.tip_max_mm:.3f} mm, valid {100 * cr.valid.mean():.0f} %, marker {cr.px_rms:.3f} px RMS"))


def main() -> int:
    sys.path.insert(0, str(ROOT / "software"))
    from whisker.design import default_design
    from whisker.files import atomic_write_bytes, atomic_write_text

    design = default_design()
    rows: list[tuple] = []
    curves: dict = {}
    print("static ...", flush=True)
    bench_static(design, rows)
    print("free ...", flush=True)
    bench_free(design, rows, curves)
    print("grasp ...", flush=True)
    xrt = bench_grasp(design, rows, curves)
    print("camera ...", flush=True)
    bench_camera(design, rows)

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["scene_type", "variant", "error", "error_unit", "ms_per_run_or_per_sim_s", "note"])
    for r in rows:
        w.writerow([r[0], r[1], f"{r[2]:.6g}", r[3], f"{r[4]:.6g}", r[5]])
    atomic_write_text(OUT / "sim.csv", buf.getvalue())

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    md = ["# Simulator: accuracy against cost (benchmarks/bench_sim.py)", "",
          f"CPU time of one process (one core; load average {load:.1f} on {os.cpu_count()} cores during the "
          "run, so wall-clock times were longer). Errors are against a fine "
          "reference of the same scene type: static: filament magnetics, 400-point grid + Illinois to 1e-13 rad; "
          "free: implicit integrator at dt = 20 us with the magnetics model called every step; grasp: "
          "MuJoCo at dt = 0.25 ms with the coil torque refreshed every step (chunk 1), 4 attempts "
          "(foam ball and mini pinecone, 8 and 4 whiskers); camera: the simulator's ground-truth tips.", "",
          "Time column: ms per call (static), ms per simulated second (free, grasp), ms per frame (camera).", "",
          "| scene type | variant | error | unit | time (ms) | note |", "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        md.append(f"| {r[0]} | {r[1]} | {r[2]:.3g} | {r[3]} | {r[4]:.3g} | {r[5]} |")
    static_ms = next(r[4] for r in rows if r[0] == "static deflection scene")
    md += ["", "## Targets", "",
           f"- static deflection scene: {static_ms:.3f} ms per run (target <= 1 ms): "
           f"{'met' if static_ms <= 1 else 'NOT met'}",
           f"- grasp scene at the default settings (grasp.toml: dt {GRASP_DT * 1e3:g} ms, chunk 5), one 8-whisker "
           f"attempt per object: {xrt:.1f}x "
           "faster than real time "
           f"(target >= 20x): {'met' if xrt >= 20 else 'NOT met'}", ""]
    atomic_write_text(OUT / "sim.md", "\n".join(md) + "\n")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    for name, pts in curves.items():
        pts = sorted(p for p in pts if np.isfinite(p[1]))
        if not pts:
            continue
        if len(pts[0]) == 3:        # labelled variants of different kinds (dt / chunk): points, not a curve
            ax.loglog([p[0] for p in pts], [max(p[1], 1e-6) for p in pts], "s", label=f"{name} (dt / chunk)")
            for x, y, lab in pts:
                ax.annotate(lab, (x, max(y, 1e-6)), textcoords="offset points", xytext=(4, 3), fontsize=7)
        else:
            ax.loglog([p[0] for p in pts], [max(p[1], 1e-6) for p in pts], "o-", label=name)
    ax.axvline(1 / 20, color="r", ls="--", lw=0.8, label="20x real time")
    ax.set_xlabel("CPU seconds per simulated second (one core)")
    ax.set_ylabel("error vs reference (deg max / mm RMS)")
    ax.set_title("Simulator: error against cost")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    tmp = OUT / ".sim.png.tmp.png"
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    atomic_write_bytes(OUT / "sim.png", tmp.read_bytes())
    tmp.unlink()
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
