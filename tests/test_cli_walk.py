"""Every `whisker` subcommand and option, found in click's own command tree, through hostile values.

A command added later is walked without being listed here. Each invocation gives ONE hostile value
to ONE parameter, the other parameters minimal and valid (BASE below; a command not in BASE gets
generic fillers), through click's CliRunner in a worker process that is killed and replaced when an invocation
runs past the time limit. Asserted
for every invocation:

- no Python traceback, no "internal error" (an unexpected exception reached the CLI's error path),
  no RuntimeWarning (overflow, invalid value) printed;
- garbage (NaN, +-inf, +-1e308, text or an empty value for a number; an inverted range, a zero step,
  NaN or text for a range option (a..b:step); a folder where a file is expected, a path under a
  regular file, a non-UTF-8 input file, an unwritable output under /proc) never exits 0 and never
  runs to the time limit (the command accepted it and started working);
- a 0-byte file and a folder for every file argument may be valid, but never crash;
- every failure's own message is one line on stderr.

Budget: in the test suite each command gets WHISKER_WALK_COMMAND_S (3 s) of cases, garbage first, in
a fixed pseudo-random order, at most 10 s per invocation; WHISKER_WALK_BUDGET=full (`make fuzz`) runs
every case with 60 s each and writes benchmarks/results/fuzz_walk.md (WHISKER_FUZZ_REPORT).
"""

from __future__ import annotations

import hashlib
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import click
import pytest

from test_dataset import synthetic
from test_recording_plot import make_trial
from whisker.cli import main
from whisker.errors import is_internal

ROOT = Path(__file__).resolve().parents[1]
#: "full" (make fuzz): every (parameter, value) pair, 60 s per invocation. Otherwise (the test suite)
#: each command gets COMMAND_S seconds of cases, garbage first, in a fixed pseudo-random order.
FULL = os.environ.get("WHISKER_WALK_BUDGET", "ci") == "full"
TIME_LIMIT_S = float(os.environ.get("WHISKER_WALK_TIME_LIMIT_S", "60" if FULL else "10"))
COMMAND_S = float(os.environ.get("WHISKER_WALK_COMMAND_S", "3"))
NUMBER_TYPES = (click.types.FloatParamType, click.types.IntParamType)

#: names of path parameters that are written, not read (generic: any name starting with "out")
OUTPUT_NAMES = {"report", "record", "images", "print_report"}


@dataclass
class Case:
    command: tuple[str, ...]
    param: str
    label: str
    args: list[str]
    garbage: bool


@dataclass
class Outcome:
    case: Case
    code: int | None
    output: str
    seconds: float
    problems: list[str] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# the tree
# ---------------------------------------------------------------------------------------------

def leaf_commands(cmd=main, path=()):
    """(path, command) for every runnable command under `cmd`, from click's own tree."""
    ctx = click.Context(main)
    if isinstance(cmd, click.Group):
        for name in cmd.list_commands(ctx):
            sub = cmd.get_command(ctx, name)
            if sub is not None and not getattr(sub, "hidden", False):
                yield from leaf_commands(sub, path + (name,))
    else:
        yield path, cmd


def is_output(param: click.Parameter) -> bool:
    return param.name.startswith("out") or param.name in OUTPUT_NAMES


def param_flag(param: click.Parameter) -> str | None:
    """The option's long name (None for an argument)."""
    if isinstance(param, click.Argument):
        return None
    longs = [o for o in param.opts if o.startswith("--")]
    return (longs or param.opts)[0]


# ---------------------------------------------------------------------------------------------
# fixtures: minimal valid arguments for the commands that need inputs
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """Valid inputs (dataset, model, session, scene) and hostile files, made once."""
    from whisker.data.classify import fit_quiet, make_classifier, save_model
    from whisker.data.dataset_files import write_csv_folder
    from whisker.design import default_design

    base = tmp_path_factory.mktemp("walk")
    ds = synthetic(n_obj=3, trials=3, poses=6, R=2, W=8)
    write_csv_folder(ds, base / "data")
    model = base / "model.joblib"
    save_model(model, fit_quiet(make_classifier(seed=0, epochs=3), ds.features(), ds.y), ds, {"protocol": "random"})
    rows = (base / "data" / "obj0.csv").read_text().splitlines()[:2]
    (base / "input.csv").write_text("\n".join(rows) + "\n")
    make_trial(base / "session", default_design(), offset_s=0.2, amplitude=2.0)
    (base / "a_file").write_text("x\n")
    (base / "empty.dat").write_bytes(b"")
    (base / "binary.bin").write_bytes(b"\xff\xfe\x00\x81garbage\xc3\x28" * 8)
    (base / "a_dir").mkdir()
    return base


def base_args(path: tuple[str, ...], w: Path, fresh: Path) -> list[str]:
    """Minimal valid arguments that exercise `path` cheaply; `fresh` is a new, empty folder."""
    scene = str(ROOT / "software/whisker/sim/scenes/angle_vs_voltage.toml")
    table = {
        ("classify", "train"): ["--data", str(w / "data"), "--protocol", "random", "--epochs", "1",
                                "--out", str(fresh / "m.joblib")],
        ("classify", "evaluate"): ["--data", str(w / "data"), "--protocol", "random", "--seeds", "1", "--epochs", "1"],
        ("classify", "predict"): ["--model", str(w / "model.joblib"), "--input", str(w / "input.csv")],
        ("recplot",): [str(w / "session"), "--out", str(fresh / "fig.png")],
        ("record",): ["--source", "synthetic:3", "--frames", "3", "--rest-frames", "1", "-q", "--out",
                      str(fresh / "session")],
        ("track",): ["--source", "synthetic:3", "--rest-frames", "1"],
        ("ros",): ["--source", "sim", "--backend", "sim", "--duration", "1"],
        ("sim",): [scene, "--explain"],
        ("cad", "build"): ["--out", str(fresh / "exports")],
        ("cad", "sweep"): ["--counts", "8", "--radii", "12", "--out", str(fresh / "sweep")],
        ("explore",): ["--vary", "whiskers.count=2", "--attempts", "1", "--cad", "skip", "--jobs", "1", "-q",
                       "--out", str(fresh / "explore")],
    }
    return list(table.get(path, []))


def filler(param: click.Parameter, w: Path, fresh: Path) -> list[str]:
    """A valid-looking value for a required parameter of a command not in the BASE table."""
    t = param.type
    if isinstance(t, click.Choice):
        v = str(t.choices[0])
    elif isinstance(t, click.Path):
        v = str(fresh / "out") if is_output(param) else str(w / "a_file" if not t.dir_okay else w / "a_dir")
    elif isinstance(t, NUMBER_TYPES):
        v = "1"
    else:
        v = "x"
    flag = param_flag(param)
    return [v] if flag is None else [flag, v]


def hostile_values(param: click.Parameter, w: Path, fresh: Path) -> list[tuple[str, str, bool]]:
    """(label, value, is garbage) for `param`'s type."""
    t = param.type
    if isinstance(t, click.Choice):
        return [("unknown choice", "bogus-choice", True), ("empty", "", True)]
    if isinstance(t, click.Path):
        out = is_output(param)
        vals = [("under a file", str(w / "a_file" / "sub" / "x"), True),
                ("empty", "", True),
                ("missing", str(fresh / "missing" / "nothing.toml"), not out)]
        if not t.dir_okay:
            vals.append(("a folder", str(w / "a_dir"), True))
        elif not out and t.file_okay:
            vals.append(("a folder", str(w / "a_dir"), False))      # may be valid (a session folder): no crash
        if not out:
            vals.append(("non-UTF-8 file", str(w / "binary.bin"), True))
            if t.file_okay:
                vals.append(("0-byte file", str(w / "empty.dat"), False))   # may be valid (an empty TOML)
        if out:
            vals.append(("in /proc", "/proc/whisker-walk/x", True))
        return vals
    if isinstance(t, NUMBER_TYPES):
        return [("nan", "nan", True), ("inf", "inf", True), ("-inf", "-inf", True), ("1e308", "1e308", True),
                ("-1e308", "-1e308", True), ("empty", "", True), ("text", "abc", True), ("zero", "0", False),
                ("negative", "-1", False)]
    if ".." in str(param.default or ""):
        # a range option (a..b or a..b:step): inverted and zero-step ranges, NaN and text are garbage
        return [("inverted range", "16..2", True), ("zero step", "4..25:0", True), ("nan", "nan", True),
                ("text", "abc", True), ("empty", "", True), ("nan in range", "4..nan", True)]
    # free text: only no traceback (a title may be "nan"); numbers given as text are tried too
    return [("empty", "", False), ("nan", "nan", False), ("1e308", "1e308", False), ("-1", "-1", False),
            ("non-UTF-8", os.fsdecode(b"\xff\xfe\x81"), False), ("a folder", str(w / "a_dir"), False)]


def _rank(key: str) -> int:
    return int(hashlib.sha256(key.encode()).hexdigest()[:8], 16)


def cases(w: Path) -> dict[tuple[str, ...], list[Case]]:
    """Per command: its cases, garbage first, each group in a fixed pseudo-random order."""
    out = {}
    for path, cmd in leaf_commands():
        mine = []
        for param in cmd.params:
            if isinstance(param, click.Option) and (param.is_flag or param.count or param.hidden):
                continue
            if param.name in ("help",):
                continue
            for label, value, garbage in hostile_values(param, w, Path("/FRESH")):
                mine.append(Case(path, param.name, label, [value], garbage))
        mine.sort(key=lambda c: (not c.garbage, _rank(f"{' '.join(c.command)}|{c.param}|{c.label}")))
        out[path] = mine
    return out


def build_args(case: Case, cmd: click.Command, w: Path, fresh: Path) -> list[str]:
    """The command line: BASE (or fillers) with the hostile value replacing the parameter's own."""
    args = base_args(case.command, w, fresh)
    target = next(p for p in cmd.params if p.name == case.param)
    value = case.args[0].replace("/FRESH", str(fresh))
    flag = param_flag(target)
    if flag is not None:
        # drop the base's value for this option, then append the hostile one
        cleaned, skip = [], False
        for a in args:
            if skip:
                skip = False
                continue
            if a in target.opts:
                skip = True
                continue
            cleaned.append(a)
        args = cleaned + [flag, value]
    else:
        args_given = [p for p in cmd.params if isinstance(p, click.Argument)]
        if case.command in {("recplot",), ("sim",)}:
            args = [value] + args[1:]  # the base's first token is this (only) argument
        else:
            args = args + [value]
        del args_given
    for p in cmd.params:
        if p.required and p.name != case.param and not _given(p, args):
            args = filler(p, w, fresh) + args if isinstance(p, click.Argument) else args + filler(p, w, fresh)
    return list(case.command) + args


def _given(param: click.Parameter, args: list[str]) -> bool:
    if isinstance(param, click.Argument):
        return bool(args) and not args[0].startswith("-")
    return any(a in param.opts for a in args)


WORKER = r"""
import json, os, sys
os.environ.setdefault("MPLBACKEND", "Agg")
from click.testing import CliRunner
from whisker.cli import main
for line in sys.stdin:
    argv = json.loads(line)
    res = CliRunner().invoke(main, argv, env={"WHISKER_DEBUG": ""}, catch_exceptions=True)
    exc = res.exception
    escaped = None if exc is None or isinstance(exc, SystemExit) else f"{type(exc).__name__}: {exc}"
    sys.stdout.write(json.dumps({"code": res.exit_code, "output": res.output, "escaped": escaped}) + "\n")
    sys.stdout.flush()
"""


class Worker:
    """A `whisker` process that runs invocations in turn; one that overruns is killed and replaced."""

    def __init__(self, cwd: Path):
        self.proc = None
        self.cwd = cwd              # a scratch folder: a command defaulting to ./ must not write into the repo

    def _start(self):
        import subprocess
        import sys

        self.proc = subprocess.Popen([sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True, cwd=self.cwd, start_new_session=True)

    def run(self, argv: list[str]) -> dict | None:
        """The invocation's result, or None when it ran past TIME_LIMIT_S."""
        import json
        import selectors

        if self.proc is None or self.proc.poll() is not None:
            self._start()
        self.proc.stdin.write(json.dumps(argv) + "\n")
        self.proc.stdin.flush()
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stdout, selectors.EVENT_READ)
        ready = sel.select(TIME_LIMIT_S + 30.0 * (self.first is None))  # the first call also imports
        sel.close()
        self.first = False
        if not ready:
            self.kill()
            return None
        line = self.proc.stdout.readline()
        if not line:                       # the worker died (a crash is a failure too)
            self.kill()
            return {"code": None, "output": "", "escaped": "the worker process died"}
        return json.loads(line)

    first = None

    def kill(self):
        import signal as sig

        if self.proc is not None:
            try:
                os.killpg(self.proc.pid, sig.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait()
            self.proc = None
            self.first = None


def run_case(case: Case, w: Path, fresh: Path, worker: Worker) -> Outcome:
    cmd = dict(leaf_commands())[case.command]
    argv = build_args(case, cmd, w, fresh)
    t0 = time.perf_counter()
    r = worker.run(argv)
    timed_out = r is None
    r = r or {"code": None, "output": "", "escaped": None}
    code, text = r["code"], r["output"]
    o = Outcome(case, code, text, time.perf_counter() - t0)
    if r["escaped"]:
        o.problems.append(f"exception escaped: {r['escaped']}")
    if "Traceback (most recent call last)" in text:
        o.problems.append("traceback printed")
    if any(is_internal(line) for line in text.splitlines()):
        o.problems.append("internal error: " + next(line for line in text.splitlines() if is_internal(line)))
    if "RuntimeWarning" in text:
        o.problems.append("RuntimeWarning printed")
    if case.garbage and code == 0:
        o.problems.append("garbage accepted (exit 0)")
    if case.garbage and timed_out:
        o.problems.append(f"garbage accepted (still running after {TIME_LIMIT_S:g} s)")
    return o


def describe(o: Outcome, argv: list[str]) -> str:
    tail = " | ".join(o.output.strip().splitlines()[-2:])[:300]
    return f"whisker {' '.join(argv)}  [{o.case.label}] -> exit {o.code}: {'; '.join(o.problems)}  <{tail}>"


def test_the_walk_finds_every_command():
    """The tree is read from click: every module in whisker/commands is in it, and groups expand."""
    from whisker import commands

    found = {p[0] for p, _ in leaf_commands()}
    modules = set(commands.command_modules())
    assert found == modules
    assert ("classify", "train") in dict(leaf_commands()) and ("coil", "report") in dict(leaf_commands())


def test_hostile_walk(world, tmp_path):
    """0 tracebacks, 0 internal errors, 0 exit-0 on garbage over the walked (command, option, value) table."""
    table = cases(world)
    assert sum(map(len, table.values())) > 1000  # every option of every command has its hostile values
    outcomes, bad = [], []
    scratch = tmp_path / "cwd"
    scratch.mkdir()
    worker = Worker(scratch)
    i = 0
    try:
        for path, mine in table.items():
            t0 = time.perf_counter()
            for case in mine:
                if not FULL and time.perf_counter() - t0 > COMMAND_S:
                    break
                i += 1
                fresh = tmp_path / f"c{i}"
                fresh.mkdir()
                cmd = dict(leaf_commands())[case.command]
                o = run_case(case, world, fresh, worker)
                outcomes.append(o)
                if o.problems:
                    bad.append(describe(o, build_args(case, cmd, world, fresh)))
                    print(bad[-1], flush=True)
    finally:
        worker.kill()
    report = os.environ.get("WHISKER_FUZZ_REPORT")
    if report:
        write_report(Path(report), outcomes, table)
    walked = {o.case.command for o in outcomes}
    assert walked == set(table)                       # every command was walked
    assert sum(o.case.garbage for o in outcomes) >= len(table)
    assert not bad, f"{len(bad)} of {len(outcomes)} hostile invocations misbehaved:\n" + "\n".join(bad)


def write_report(path: Path, outcomes: list[Outcome], table) -> None:
    from collections import Counter

    from whisker.files import atomic_write_text

    by_cmd = Counter(" ".join(o.case.command) for o in outcomes)
    codes = Counter(o.code for o in outcomes)
    slow = sorted(outcomes, key=lambda o: -o.seconds)[:5]
    lines = [f"# CLI walk: {len(outcomes)} of {sum(map(len, table.values()))} hostile invocations "
             f"({'full' if FULL else f'{COMMAND_S:g} s per command'}; limit {TIME_LIMIT_S:g} s each)", "",
             "Written by tests/test_cli_walk.py: " + ("`make fuzz` (every case)." if FULL else
                 f"a reduced budget of {COMMAND_S:g} s of cases per command, garbage first (`make docs-fuzz`; "
                 "`make fuzz` runs every case)."), "",
             f"exit status: " + ", ".join(f"{k}: {v}" for k, v in sorted(codes.items(), key=str)),
             f"problems: {sum(bool(o.problems) for o in outcomes)}", "",
             "| command | invocations | of | problems |", "|---|---|---|---|"]
    probs = Counter(" ".join(o.case.command) for o in outcomes if o.problems)
    lines += [f"| {c} | {by_cmd[c]} | {len(table[tuple(c.split())])} | {probs[c]} |" for c in sorted(by_cmd)]
    lines += ["", "slowest:", ""] + [f"- {' '.join(o.case.command)} {o.case.param} [{o.case.label}]: "
                                      f"{o.seconds:.2f} s" for o in slow]
    atomic_write_text(path, "\n".join(lines) + "\n")
    plot_report(path.with_suffix(".png"), outcomes)


def plot_report(path: Path, outcomes: list[Outcome]) -> None:
    """Exit statuses per command (stacked bars): 2 = refused as bad input, 1 = environment, 0 = ran."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from whisker.files import atomic_write_bytes

    cmds = sorted({" ".join(o.case.command) for o in outcomes})
    statuses = [(2, "exit 2 (bad input)"), (1, "exit 1 (environment)"), (0, "exit 0 (not garbage)"),
                (None, "time limit (not garbage)")]
    fig, ax = plt.subplots(figsize=(7, 0.28 * len(cmds) + 1.2))
    left = [0] * len(cmds)
    for code, label in statuses:
        n = [sum(1 for o in outcomes if " ".join(o.case.command) == c and o.code == code) for c in cmds]
        ax.barh(cmds, n, left=left, label=label)
        left = [a + b for a, b in zip(left, n)]
    other = [sum(1 for o in outcomes if " ".join(o.case.command) == c and o.code not in (0, 1, 2, None)) for c in cmds]
    ax.barh(cmds, other, left=left, label="other exit")
    ax.set_xlabel("hostile invocations")
    ax.invert_yaxis()
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
