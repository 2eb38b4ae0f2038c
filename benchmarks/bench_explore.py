"""Design explorer benchmark: what one task costs, how the engines scale, what a large study costs.

1. Cost of the pieces, in this process: one simulated grasp attempt (the grasp scene's five objects,
   every whisker of the paper's sensor), a design's predictions (coil report, thermal, camera), the
   CAD checks `whisker explore --cad evaluate` runs (``whisker.cad.build.evaluate``, what `make sweep`
   runs) and, for comparison, the full build `make stl` runs (every part exported and checked).
2. Scheduler overhead: 1000 empty tasks through each engine (joblib with 2 processes, a Dask
   LocalCluster of 2 worker processes), per task.
3. Throughput: the same small study (4 designs x 5 objects x their configurations x 2 attempts, CAD
   skipped, one attempt per task) on a Dask LocalCluster of 1 and of 2 worker processes (cluster start
   not counted, reported apart), and on joblib with 2 processes: simulated attempts per second,
   design points per second, and the scaling efficiency rate(2) / (2 rate(1)), measured in one run.
4. From 1-3: the cost of a 1,000-design x 100-attempt study on 1, 16 and 256 cores.

Writes benchmarks/results/explore.md.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import machine_line, markdown_table, write_text  # noqa: E402
from whisker.design import default_design  # noqa: E402
from whisker.explore.study import DaskEngine, JoblibEngine, Study, run  # noqa: E402
from whisker.explore.grid import grid  # noqa: E402
from whisker.explore.tasks import TaskCache, design_task, grasp_task, scene_objects  # noqa: E402
from whisker.resources import scenes_dir  # noqa: E402
from whisker.sim.scene import load_scene  # noqa: E402

VARY = ["whiskers.count=8,6", "whiskers.ring_radius=12,14"]
ATTEMPTS = 2
NOOPS = 1000


def noop(i: int) -> int:
    return i


def scene(attempts: int):
    s = load_scene(scenes_dir() / "grasp.toml")
    return s.with_(experiment={**s.experiment.model_dump(), "attempts": attempts})


def piece_costs() -> dict:
    d = default_design()
    sc = scene(5)
    grasp_task(d, sc, 0, tuple(range(8)), 0, 1)                           # imports, MuJoCo warm-up
    t0, c0 = time.perf_counter(), time.process_time()
    n = 0
    for k in range(len(scene_objects(sc))):
        n += len(grasp_task(d, sc, k, tuple(range(8)), 0, 4)["held"])
    attempt = {"wall": (time.perf_counter() - t0) / n, "cpu": (time.process_time() - c0) / n}
    design_task(d, False)
    c0 = time.process_time()
    for _ in range(5):
        design_task(d, False)
    pred = (time.process_time() - c0) / 5
    design_task(default_design("whiskers.count=6", "whiskers.ring_radius=7"), True)   # CadQuery imports
    t0, c0 = time.perf_counter(), time.process_time()
    v = design_task(d, True)
    cad, cad_cpu = time.perf_counter() - t0, time.process_time() - c0
    assert v["cad"] == "ok", v
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run([str(Path(sys.executable).with_name("whisker")), "cad", "build", "--force", "-q", "--out",
                        str(Path(tmp) / "x")], check=True, capture_output=True)
        full = time.perf_counter() - t0
    return {"attempt_s": attempt["wall"], "attempt_cpu_s": attempt["cpu"], "predictions_cpu_s": pred,
            "cad_evaluate_s": cad, "cad_evaluate_cpu_s": cad_cpu, "cad_build_s": full}


def overhead(engine) -> float:
    list(engine.run([(noop, (i,)) for i in range(50)]))                  # warm the workers
    t0 = time.perf_counter()
    out = list(engine.run([(noop, (i,)) for i in range(NOOPS)]))
    assert len(out) == NOOPS and all(r["ok"] for r in out)
    return (time.perf_counter() - t0) / NOOPS


def study_rate(engine, points, attempts: int) -> dict:
    st = Study(points, scene(attempts), attempts, 1, cad=False)
    list(engine.run([(noop, (i,)) for i in range(20)]))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        prog = run(st, engine, TaskCache(Path(tmp) / "cache"))
        wall = time.perf_counter() - t0
    assert prog.failed == 0
    n_att = sum(len(v["held"]) for v in st.grasps.values())
    return {"engine": engine.name, "wall_s": wall, "attempts": n_att, "tasks": prog.done,
            "attempts_per_s": n_att / wall, "designs_per_s": len(points) / wall}


def dask_engine(workers: int):
    t0 = time.perf_counter()
    e = DaskEngine(workers=workers)
    return e, time.perf_counter() - t0


def study_cost(c: dict, sched_s: float, cores: int, chunk: int, designs=1000, attempts=100, objects=5,
               configs=3) -> dict:
    """Wall time of a study from the measured pieces: the CPU work (attempts, predictions, CAD checks)
    spread over `cores`, plus the scheduler's cost per task, which is serial (one scheduler) and taken
    in full (not overlapped with the work: an upper bound). One core runs in-process (joblib
    ``--jobs 1``): no scheduler."""
    n_att = designs * objects * configs * attempts
    tasks = designs * (1 + objects * configs * math.ceil(attempts / chunk))
    cpu = n_att * c["attempt_cpu_s"] + designs * (c["predictions_cpu_s"] + c["cad_evaluate_cpu_s"])
    work = cpu / cores
    sched = tasks * sched_s if cores > 1 else 0.0
    return {"cores": cores, "chunk": chunk, "tasks": tasks, "cpu_h": cpu / 3600, "work_h": work / 3600,
            "scheduler_h": sched / 3600, "wall_h": (work + sched) / 3600, "efficiency": work / (work + sched)}


def main() -> None:
    load = os.getloadavg()
    c = piece_costs()
    points = grid(None, (), VARY)
    ej = JoblibEngine(2)
    rj_over = overhead(ej)
    rows = []
    e1, start1 = dask_engine(1)
    try:
        r1 = study_rate(e1, points, ATTEMPTS)
    finally:
        e1.close()
    e2, start2 = dask_engine(2)
    try:
        d_over = overhead(e2)
        r2 = study_rate(e2, points, ATTEMPTS)
    finally:
        e2.close()
    rj = study_rate(ej, points, ATTEMPTS)
    for r, w in ((r1, 1), (r2, 2), (rj, 2)):
        rows.append({**r, "workers": w})
    eff = r2["attempts_per_s"] / (2 * r1["attempts_per_s"])
    load_after = os.getloadavg()
    busy = load[0] > 1.0  # before the bench's own workers start: other jobs share the 2 cores
    costs = [study_cost(c, d_over, n, ch) for n in (1, 16, 256) for ch in (5, 25)]
    lines = [
        "# Design explorer: cost per task, scaling, and the cost of a large study (benchmarks/bench_explore.py)", "",
        f"Machine: {machine_line()}. Load average {load[0]:.2f} before, {load_after[0]:.2f} after"
        + (": **this machine was shared with other jobs while this ran**, so the rates and the efficiency below "
           "are lower bounds; re-run `make bench-explore` on a quiet machine." if busy else
           " (a quiet machine: the bench's own workers are the load)."), "",
        "## Cost of the pieces (one process)", "",
        "| piece | s |", "|---|---|",
        f"| one simulated grasp attempt (mean of the five objects, 8 whiskers), wall | {c['attempt_s']:.4f} |",
        f"| the same, CPU time of this process | {c['attempt_cpu_s']:.4f} |",
        f"| a design's predictions (coil report, thermal, camera resolution), CPU | {c['predictions_cpu_s']:.4f} |",
        f"| CAD checks per design, `--cad evaluate` (solids + collision/fit + mesh checks, = `make sweep`), wall | "
        f"{c['cad_evaluate_s']:.2f} |",
        f"| the same, CPU | {c['cad_evaluate_cpu_s']:.2f} |",
        f"| the full build `make stl` runs (export, wall, assembly-sequence checks; a subprocess), wall | "
        f"{c['cad_build_s']:.2f} |",
        "",
        f"CPU / wall of one attempt: {c['attempt_cpu_s'] / c['attempt_s']:.2f} (1.00 on a quiet machine): the share "
        "of a core this process got. The study costs below use CPU times.", "",
        "Per design, the explorer runs the CAD checks `make sweep` runs, not the full build: every refusal of "
        "the 330-cell sweep (docs/sweep.md) is a check `evaluate` runs, the full build takes "
        f"{c['cad_build_s'] / c['cad_evaluate_s']:.1f}x as long and adds file export, wall thickness and the "
        "assembly sequence. Against the grasp simulation the checks are small: at 100 attempts x 5 objects x 3 "
        f"configurations a design's attempts cost {1500 * c['attempt_cpu_s']:.0f} s of CPU, its CAD checks "
        f"{c['cad_evaluate_cpu_s']:.1f} s ({100 * c['cad_evaluate_cpu_s'] / (1500 * c['attempt_cpu_s']):.1f} %). Build a "
        "Pareto design with `make stl DESIGN=...` before printing it.", "",
        "## Scheduler overhead", "",
        f"{NOOPS} empty tasks, per task: joblib (2 loky processes; it batches short tasks) {1e3 * rj_over:.2f} ms, "
        "Dask LocalCluster "
        f"(2 worker processes) {1e3 * d_over:.2f} ms. Starting the LocalCluster: {start1:.1f} s (1 worker), "
        f"{start2:.1f} s (2 workers).", "",
        f"## Throughput: {len(points)} designs ({', '.join(VARY)}), {ATTEMPTS} attempts per cell, one attempt per task", "",
        markdown_table(rows, ["engine", "workers", "tasks", "attempts", "wall_s", "attempts_per_s", "designs_per_s"],
                       {"wall_s": ".2f", "attempts_per_s": ".2f", "designs_per_s": ".3f"}), "",
        f"Scaling efficiency, Dask 1 -> 2 workers: **{eff:.2f}** (rate(2) / (2 rate(1)); target >= 0.8 on a quiet "
        f"2-core machine)." + (f" With a load average of {load[0]:.1f} on 2 cores the second worker had no free "
        "core to run on, so this run does not measure the engine's scaling." if busy else
        " What is lost is the scheduler's and the workers' own share of the 2 cores.")
        + " The tables of all three runs are the same (tests/test_explore.py checks it).", "",
        "## A 1,000-design x 100-attempt study", "",
        "5 objects x 3 configurations (the paper's all / every second / opposite pair) x 100 attempts per design "
        "= 1.5 million attempts, plus the predictions and CAD checks of every design, from the CPU times "
        "above. Wall time = CPU work / cores + tasks x the Dask overhead per task measured above (the "
        "scheduler is one process, so its share does not shrink with more cores; counted in full, not "
        "overlapped with the work). efficiency = work / wall. The overhead was measured with the scheduler sharing 2 cores with its workers; a "
        "scheduler on its own core is faster, so the 16- and 256-core rows are upper bounds.", "",
        markdown_table(costs, ["cores", "chunk", "tasks", "cpu_h", "work_h", "scheduler_h", "wall_h", "efficiency"],
                       {"cpu_h": ".1f", "work_h": ".2f", "scheduler_h": ".3f", "wall_h": ".2f", "efficiency": ".2f"}), "",
        "chunk: attempts per task (`--chunk`). On 256 cores with chunks of 5 the scheduler, not the simulation, sets the pace: use chunks of 25 or more there; "
        "the table does not depend on the chunk.", ""]
    write_text("explore.md", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
