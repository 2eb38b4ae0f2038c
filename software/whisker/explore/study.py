"""The design explorer (``whisker explore``): every design of a grid, its predicted grasp, force, heat
and resolution, run as independent tasks on joblib (local cores) or Dask (a LocalCluster or an
existing cluster). docs/explore.md.

Flow: the grid (whisker.explore.grid) -> one design task per distinct design (predictions + CAD
checks) -> for every design that builds, one grasp task per object x whisker set x attempt chunk
(whisker.explore.tasks) -> one row per grid point (:func:`table`) -> results.csv, Pareto plots and the
Pareto designs as design files (whisker.explore.report). Finished tasks are cached under the design
digest, so an interrupted run resumes; the table depends on neither the engine, nor the number of
workers, nor the order tasks finish.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Iterable

from whisker.explore.grid import Point
from whisker.explore.tasks import Task, TaskCache, design_task, grasp_task, guarded, scene_key, scene_objects

#: column labels of the paper's configurations (whisker.sim.experiments.paper.configurations): all whiskers,
#: every second one, one opposite pair (8 / 4 / 2 for the paper's sensor)
CONFIG_LABELS = {1: ("all",), 2: ("all", "pair"), 3: ("all", "half", "pair")}


def _tagged(tag: int, fn, *args) -> dict:
    return {"tag": tag, **guarded(fn, *args)}


class JoblibEngine:
    """Every local core (or ``n_jobs``) through joblib's loky processes; ``n_jobs=1`` runs in this process."""

    def __init__(self, n_jobs: int = -1):
        from joblib import cpu_count

        self.n_jobs = n_jobs
        self.workers = cpu_count() if n_jobs < 0 else n_jobs
        self.name = f"joblib, {self.workers} process{'es' if self.workers != 1 else ''}"

    def run(self, calls: list[tuple[Callable, tuple]]) -> Iterable[dict]:
        from joblib import Parallel, delayed

        par = Parallel(n_jobs=self.n_jobs, return_as="generator_unordered")
        return par(delayed(_tagged)(i, fn, *args) for i, (fn, args) in enumerate(calls))

    def running(self, left: int) -> int:
        return min(self.workers, left)      # joblib keeps every worker busy while tasks are left

    def close(self) -> None:
        pass


class DaskEngine:
    """A dask.distributed Client: on a LocalCluster it starts (``workers``) or at ``address``."""

    def __init__(self, workers: int | None = None, address: str | None = None, connect_timeout_s: float = 5.0):
        import logging

        from dask.distributed import Client, LocalCluster

        self.cluster = None
        if address is not None:
            self.client = Client(address, timeout=f"{connect_timeout_s}s")
            self.name = f"Dask scheduler {address}"
        else:
            # real processes (not threads): MuJoCo and the CAD kernel hold the GIL for long stretches.
            # The workers ignore Ctrl-C (inherited): this process catches it and closes the cluster,
            # instead of every worker printing its own traceback.
            import signal

            old = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                            dashboard_address=None, silence_logs=logging.ERROR)
            finally:
                signal.signal(signal.SIGINT, old)
            self.client = Client(self.cluster)
            self.name = f"Dask LocalCluster, {workers} worker process{'es' if workers != 1 else ''}"
        self.workers = max(1, sum(self.client.nthreads().values()))

    def run(self, calls: list[tuple[Callable, tuple]]) -> Iterable[dict]:
        from dask.distributed import as_completed

        futs = {self.client.submit(_tagged, i, fn, *args, pure=False): i for i, (fn, args) in enumerate(calls)}
        try:
            for fut in as_completed(futs):
                try:
                    yield fut.result()
                except Exception as err:  # noqa: BLE001 - a lost worker fails its task, not the study
                    yield {"tag": futs[fut], "ok": False, "error": f"{type(err).__name__}: {err}"}
                fut.release()
        finally:
            self.client.cancel([f for f in futs if not f.done()])

    def running(self, left: int) -> int:
        return min(left, sum(len(v) for v in self.client.processing().values()))

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


@dataclass
class Progress:
    """What the progress bar shows: tasks done (from the cache too), running, failed."""
    total: int = 0
    done: int = 0
    cached: int = 0
    failed: int = 0
    running: int = 0
    failures: list[str] = field(default_factory=list)


@dataclass
class Study:
    points: list[Point]
    scene: object
    attempts: int
    chunk: int
    cad: bool
    designs: dict = field(default_factory=dict)      # digest -> design task value (or {"error": ...})
    grasps: dict = field(default_factory=dict)       # (digest, obj, active, start) -> grasp value / {"error"}


def configurations(scene, design) -> list[tuple[int, ...]]:
    from whisker.sim.experiments.paper import configurations as paper_configurations

    return [tuple(c) for c in paper_configurations(scene, design)]


def _chunks(attempts: int, chunk: int) -> list[tuple[int, int]]:
    return [(a, min(a + chunk, attempts)) for a in range(0, attempts, chunk)]


def grasp_tasks(study: Study, point: Point) -> list[Task]:
    """One task per object x distinct whisker set x attempt chunk of a design."""
    d = point.design
    sets = dict.fromkeys(configurations(study.scene, d))         # 4 whiskers: half == pair, run once
    return [Task("grasp", point.index, point.digest, k, ws, a, b)
            for k in range(len(scene_objects(study.scene))) for ws in sets
            for a, b in _chunks(study.attempts, study.chunk)]


def run(study: Study, engine, cache: TaskCache, on_progress: Callable[[Progress], None] | None = None) -> Progress:
    """Run every task not in the cache (design tasks first, then the grasp tasks of the designs that
    build); fills ``study.designs`` and ``study.grasps``. KeyboardInterrupt leaves the cache resumable."""
    seed, skey, cad = study.scene.scene.seed, scene_key(study.scene), study.cad
    firsts = {}
    for p in study.points:
        if p.design is not None:
            firsts.setdefault(p.digest, p)
    gtasks = {dg: grasp_tasks(study, p) for dg, p in firsts.items()}
    prog = Progress(total=len(firsts) + sum(map(len, gtasks.values())))
    say = on_progress or (lambda _p: None)

    def phase(tasks: list[Task], call, store):
        todo = []
        for t in tasks:
            hit = cache.get(t.digest, t.name(seed, skey, cad))
            if hit is None:
                todo.append(t)
            else:
                store(t, hit)
                prog.done += 1
                prog.cached += 1
        say(prog)
        if not todo:
            return
        last, finished = 0.0, 0
        for r in engine.run([call(t) for t in todo]):
            finished += 1
            t = todo[r["tag"]]
            if r["ok"]:
                cache.put(t.digest, t.name(seed, skey, cad), r["value"])
                store(t, r["value"])
            else:
                prog.failed += 1
                prog.failures.append(f"design {t.point} ({t.digest}) {describe(study, t)}: {r['error']}")
                store(t, {"error": r["error"]})
            prog.done += 1
            now = time.monotonic()
            if now - last > 0.3 or prog.done == prog.total:
                last = now
                prog.running = engine.running(len(todo) - finished)
            say(prog)

    def keep_design(t, v):
        study.designs[t.digest] = v
        if v.get("refusal") or "error" in v:           # no grasp tasks for a design that does not build
            prog.total -= len(gtasks.pop(t.digest, []))

    phase([Task("design", p.index, dg) for dg, p in firsts.items()],
          lambda t: (design_task, (firsts[t.digest].design, cad)), keep_design)
    phase([t for ts in gtasks.values() for t in ts],
          lambda t: (grasp_task, (firsts[t.digest].design, study.scene, t.obj, t.active, t.start, t.stop)),
          lambda t, v: study.grasps.__setitem__((t.digest, t.obj, t.active, t.start), v))
    prog.running = 0
    say(prog)
    return prog


def describe(study: Study, t: Task) -> str:
    if t.kind == "design":
        return "design task"
    name = scene_objects(study.scene)[t.obj].name
    return f"grasp {name!r}, whiskers {list(t.active)}, attempts {t.start}..{t.stop - 1}"


# ---- the table ---------------------------------------------------------------------------------

def slug(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def table(study: Study) -> list[dict]:
    """One row per grid point, in grid order: the varied values, the verdict, the predictions and
    the grasp success per configuration (Wilson 95 % interval over every object's attempts pooled)
    and the attempts held per object and configuration."""
    from whisker.sim.experiments.paper import wilson_interval

    objs = scene_objects(study.scene)
    n = study.attempts
    rows = []
    for p in study.points:
        row = {"point": p.index, "status": "ok", "reason": "", "design_digest": p.digest,
               **{k: v for k, v in p.assignment}}
        rows.append(row)
        if p.design is None:
            row.update(status="refused", reason=p.refusal)
            continue
        row.update(whiskers=p.design.whiskers.count, ring_radius_mm=p.design.whiskers.ring_radius)
        dv = study.designs.get(p.digest)
        if dv is None or "error" in dv:
            row.update(status="failed" if dv else "not run", reason=f"design task: {dv['error']}" if dv else "")
            continue
        if dv["refusal"]:
            row.update(status="refused", reason=dv["refusal"])
            continue
        row.update(dv["predictions"], cad=dv["cad"], attempts=n)
        cfgs = configurations(study.scene, p.design)
        labels = CONFIG_LABELS.get(len(cfgs)) if not study.scene.experiment.configurations else None
        labels = labels or tuple(f"c{i}" for i in range(len(cfgs)))
        errors = []
        for label, ws in zip(labels, cfgs):
            total = 0
            complete = True
            for k, o in enumerate(objs):
                held = []
                for a, _b in _chunks(n, study.chunk):
                    g = study.grasps.get((p.digest, k, ws, a))
                    if g is None or "error" in g:
                        complete = False
                        if g is not None:
                            errors.append(f"grasp {o.name!r} whiskers {list(ws)}: {g['error']}")
                        continue
                    held += g["held"]
                row[f"held_{slug(o.name)}_{label}"] = sum(held) if complete else ""
                total += sum(held)
            row[f"n_{label}"] = len(ws)
            if complete:
                lo, hi = wilson_interval(total, n * len(objs))
                row.update({f"grasp_{label}_pct": 100.0 * total / (n * len(objs)),
                            f"grasp_{label}_lo": lo, f"grasp_{label}_hi": hi})
        if errors or any(f"grasp_{lab}_pct" not in row for lab in labels):
            row.update(status="failed" if errors else "not run", reason="; ".join(errors[:1]))
    return rows
