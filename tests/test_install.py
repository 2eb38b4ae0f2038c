"""The package as a user gets it: the wheel, installed into fresh venvs, run from outside the checkout.

- core: the wheel with only its core requirements (what a Raspberry Pi needs), installed by pip from
  wheel files at the versions of constraints.txt (downloaded once into .ci-wheels/, then offline).
  No CAD, simulator or netlist library is importable there; the sensor commands run; the others end
  with one line naming the extra to install.
- all: the same wheel in a venv whose libraries are those of the test run (the [all] install of
  `make`, pinned by constraints.txt) - it builds the default design exactly like `make stl`.

About a minute on 2 cores (venv creation, two pip installs, one CAD build); marked `install`,
part of `make test` (deselect locally with -m "not install").
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from conftest import ROOT, load_manifest, run_cli
from test_dataset import synthetic

pytestmark = pytest.mark.install

CONSTRAINTS = ROOT / "constraints.txt"
WHEELHOUSE = ROOT / ".ci-wheels"  # gitignored (.ci-*/): the core's wheel files, kept between runs
HEAVY = ("cadquery", "OCP", "mujoco", "skidl", "kinparse", "magpylib", "trimesh", "manifold3d", "rtree", "skfem", "SALib",
         "triangle")


def run(cmd, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=900, **kw)


def doctor(stdout: str) -> dict[str, tuple[str, str]]:
    """`whisker doctor`'s lines -> {item: (status, detail)} (the last line is the count)."""
    found = [re.fullmatch(r"(ok|FIX)\s+(\S+(?: \S+)?)\s{2,}(.*)", line) for line in stdout.splitlines()[:-1]]
    assert all(found), stdout
    return {m[2]: (m[1], m[3]) for m in found}


def ok(res: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert res.returncode == 0, f"{res.args}\n{res.stdout[-2000:]}\n{res.stderr[-3000:]}"
    return res


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built from a copy of the checkout (no build/ or egg-info left in the repository)."""
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"
    skip = shutil.ignore_patterns(".git", ".venv*", ".ci-*", "exports*", "dist", "runs", "*.egg-info", "__pycache__",
                                  ".pytest_cache", ".hypothesis", "benchmarks")

    def ignore(folder, names):   # build/ only at the root: software/whisker/commands/build is a package
        return set(skip(folder, names)) | ({"build"} if Path(folder) == ROOT else set())
    shutil.copytree(ROOT, src, ignore=ignore)
    ok(run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", base / "dist", src]))
    (whl,) = (base / "dist").glob("whisker_array-*.whl")
    return whl


def test_wheel_ships_every_data_file(wheel):
    """Everything that is not Python under hw/ and docs/sequences/ (whatever is added later), and the
    sim scenes, at the paths whisker.resources looks in; no CAD source twice."""
    import zipfile

    names = set(zipfile.ZipFile(wheel).namelist())

    def data(folder):
        # __pycache__ holds compiled caches (CPython's .pyc, numba's .nbi/.nbc for the HAT router), not data
        return {p.relative_to(ROOT / folder).as_posix() for p in (ROOT / folder).rglob("*")
                if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts}

    for folder, package in (("hw", "whisker/hw"), ("docs/sequences", "whisker/sequences"),
                            ("software/whisker/sim/scenes", "whisker/sim/scenes")):
        expected = {f"{package}/{name}" for name in data(folder)}
        assert expected and expected <= names, sorted(expected - names)
    assert not [n for n in names if n.startswith("whisker/hw/") and n.endswith(".py") and n != "whisker/hw/__init__.py"]
    assert {"whisker/cad/build.py", "whisker/pcb/netlist.py", "whisker/commands/sensor/doctor.py"} <= names


def make_venv(path: Path) -> Path:
    venv.EnvBuilder(with_pip=True, clear=True).create(path)
    return path / "bin" / "python"


def user_env(home: Path) -> dict:
    """A user's environment: no PYTHONPATH into the checkout, own cache (coil state), mock GPIO pins."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"), GPIOZERO_PIN_FACTORY="mock", MPLBACKEND="Agg")
    return env


@pytest.fixture(scope="module")
def core(wheel, tmp_path_factory):
    """(whisker executable, run folder outside the checkout, env) of a core-only install."""
    base = tmp_path_factory.mktemp("core")
    pip = [sys.executable, "-m", "pip", "download", "-q", "-d", WHEELHOUSE, "-c", CONSTRAINTS, wheel]
    for stale in WHEELHOUSE.glob("whisker_array-*.whl"):  # pip would reuse an older build of the same name
        stale.unlink()
    if run([*pip[:5], "--no-index", "--find-links", WHEELHOUSE, *pip[5:]]).returncode != 0:
        ok(run(pip))  # first run on this machine, or new requirements: fetch the missing files once
    for copy in WHEELHOUSE.glob("whisker_array-*.whl"):
        copy.unlink()
    python = make_venv(base / "venv")
    ok(run([python, "-m", "pip", "install", "-q", "--no-index", "--find-links", WHEELHOUSE,
            "-c", CONSTRAINTS, wheel]))
    home = base / "home"
    home.mkdir()
    yield base / "venv" / "bin" / "whisker", home, user_env(home)
    shutil.rmtree(base / "venv")  # ~0.5 GB; pytest keeps its last temporary folders


def test_core_install_has_no_heavy_library_and_every_module_imports(core):
    whisker, home, env = core
    probe = """
import importlib, importlib.util, json, pkgutil, sys, whisker
heavy = %r
present = [m for m in heavy if importlib.util.find_spec(m) is not None]
failed = {}
for m in pkgutil.walk_packages(whisker.__path__, "whisker.", onerror=lambda name: None):
    if m.name.startswith(("whisker.cad", "whisker.pcb", "whisker.hw", "whisker.sequences", "whisker.ros.node",
                          "whisker.ros.coil_commands")):
        continue  # [cad] / [hw] / [ros] code, and the data packages
    try:
        importlib.import_module(m.name)
    except Exception as err:
        failed[m.name] = repr(err)
from whisker import resources
from whisker.design import printer
from whisker.design import load_design
data = [resources.default_design_path(), printer.resolve(load_design().print.profile),
        resources.example("voltage_sweep", resources.sequences_dir()),
        resources.example("grasp", resources.scenes_dir()), resources.scenes_dir() / "paper_objects.toml"]
print(json.dumps({"present": present, "failed": failed, "loaded": [m for m in heavy if m in sys.modules],
                  "file": whisker.__file__, "data": [str(p) for p in data if p.is_file()]}))
""" % (HEAVY,)
    res = ok(run([whisker.parent / "python", "-c", probe], cwd=home, env=env))
    out = json.loads(res.stdout)
    assert out["present"] == [], "the core install pulled in an extra's library"
    assert out["failed"] == {}, "a module the core install ships does not import without the extras"
    assert out["loaded"] == []
    venv_dir = whisker.parents[1]
    assert Path(out["file"]).is_relative_to(venv_dir), "whisker came from the checkout, not the wheel"
    assert len(out["data"]) == 5 and all(Path(p).is_relative_to(venv_dir) for p in out["data"]), out["data"]


def test_core_runs_the_sensor_commands_from_outside_the_checkout(core, tmp_path):
    whisker, home, env = core
    from whisker.design import load_design

    res = ok(run([whisker, "design", "show", "--json"], cwd=home, env=env))
    shown = json.loads(res.stdout)
    assert shown["derived"]["digest"] == load_design().digest(), "the wheel's sensor.toml is not hw/sensor.toml"

    tracks = tmp_path / "tracks.csv"
    res = ok(run([whisker, "track", "--source", "synthetic:12", "--out", tracks], cwd=home, env=env))
    rows = tracks.read_text().splitlines()
    assert len(rows) == 1 + 12 * 8 and all(r.split(",")[7] == "1" for r in rows[1:])

    res = ok(run([whisker, "actuate", "retract", "--backend", "mock", "--duration", "0.2", "-q"], cwd=home, env=env))
    assert res.stderr.startswith("done: peak coil temperature") and "guard trips [0, 0, 0, 0, 0, 0, 0, 0]" in res.stderr

    ds = synthetic(n_obj=3, trials=3, poses=6, R=8, W=8, scale_px=5.0)  # inside the 11 deg stop's marker travel
    from whisker.data.dataset_files import write_csv_folder

    write_csv_folder(ds, tmp_path / "data")
    model = tmp_path / "m.joblib"
    ok(run_cli("classify", "train", "--data", str(tmp_path / "data"), "--protocol", "random", "--epochs", "30",
               "--out", str(model)))
    rows = (tmp_path / "data" / "obj2.csv").read_text().splitlines()[:3]
    (tmp_path / "in.csv").write_text("\n".join(rows) + "\n")
    res = ok(run([whisker, "classify", "predict", "--model", model, "--input", tmp_path / "in.csv"], cwd=home, env=env))
    assert [line.split("\t")[1] for line in res.stdout.splitlines()[1:]] == ["obj2"] * 3

    res = run([whisker, "doctor"], cwd=home, env=env)
    items = doctor(res.stdout)
    status = {item: st for item, (st, _) in items.items()}
    lines = {item: detail for item, (_, detail) in items.items()}
    kicad = status.pop("kicad", None)   # information only (the HAT's board tools), never a reason to fix
    assert status == {"design": "ok", "extras": "ok", "camera": "FIX", "gpio": "ok", "coil state": "ok"}, res.stdout
    assert kicad in (None, "ok", "info"), res.stdout
    assert res.returncode == 1, "no camera on the test machine: doctor must not say all is well"
    assert str(whisker.parents[1]) in lines["design"], "doctor's design is not the wheel's"
    assert "core only; not installed: " in lines["extras"] and "pip install 'whisker-array[cad]'" in lines["extras"]
    assert "MockFactory opens all 16 coil pins" in lines["gpio"]


@pytest.mark.parametrize("args, extra", [
    (["cad", "build", "--out", "exports"], "cad"),
    (["sim", "grasp", "--out", "runs", "--trials", "1", "--attempts", "1", "-q"], "sim"),
    (["hw", "pcb", "--out", "pcb"], "hw"),
    (["coil", "force", "--model", "magpylib"], "magnetics"),
    (["explore", "--vary", "whiskers.count=8", "--cad", "skip", "--out", "runs"], "sim"),
])
def test_core_names_the_missing_extra(core, args, extra, tmp_path):
    whisker, home, env = core
    res = run([whisker, *args], cwd=tmp_path, env=env)
    assert res.returncode == 1 and "Traceback" not in res.stdout
    assert res.stderr.count("\n") == 1 and "Traceback" not in res.stderr, res.stderr
    assert f"[{extra}] extra: pip install 'whisker-array[{extra}]'" in res.stderr
    assert not any(tmp_path.iterdir()), "a refused command left files behind"


@pytest.fixture(scope="module")
def full(wheel, tmp_path_factory):
    """The wheel in a fresh venv that sees this test run's libraries (the [all] install at the
    constraints' versions) through a path entry: no downloads, and the checkout is not on the path."""
    base = tmp_path_factory.mktemp("all")
    python = make_venv(base / "venv")
    site = Path(run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    here = {Path(sysconfig.get_paths()[k]) for k in ("purelib", "platlib")}
    # a path entry, not a site dir: its .pth files (the checkout's editable install) are not run
    (site / "zz_libraries_of_the_test_run.pth").write_text("\n".join(map(str, sorted(here))) + "\n")
    ok(run([python, "-m", "pip", "install", "-q", "--no-deps", "--no-index", wheel]))
    home = base / "home"
    home.mkdir()
    yield base / "venv" / "bin" / "whisker", home, user_env(home)
    shutil.rmtree(base / "venv")


def test_all_install_builds_the_default_design_like_make_stl(full, default_build):
    whisker, home, env = full
    extras = doctor(run([whisker, "doctor"], cwd=home, env=env).stdout)["extras"][1]
    # [ros] (not part of [all]) is there when the test run has it: make installs it on x86-64 Linux
    ros = "ros, " if importlib.util.find_spec("rclpy") is not None else ""
    assert f"core + cad, explore, fem, hw, magnetics, {ros}sim, tolerance" in extras, extras
    assert ("not installed" not in extras) if ros else extras.endswith("; not installed: ros (pip install "
                                                                        "'whisker-array[ros]')"), extras
    ok(run([whisker, "cad", "build", "--out", "exports", "-q"], cwd=home, env=env))
    wheel_m, repo_m = load_manifest(home / "exports"), load_manifest(default_build)
    assert wheel_m["build_key"] == repo_m["build_key"], "another design or other CAD sources in the wheel"
    assert wheel_m["all_checks_passed"] and sorted(wheel_m["parts"]) == sorted(repo_m["parts"])
    volumes = 0
    for name, part in repo_m["parts"].items():
        got = wheel_m["parts"][name]
        assert set(got) == set(part), name
        if "volume_mm3" in part:  # the solids (not the reference parts without a mesh)
            assert got["volume_mm3"] == pytest.approx(part["volume_mm3"], rel=1e-9, abs=1e-6), name
            volumes += 1
        assert got.get("bbox_mm") == part.get("bbox_mm") and got["checks"] == part["checks"], name
    assert volumes >= 4, "too few measured parts to call the geometry identical"
