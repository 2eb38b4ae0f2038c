"""What every generated figure and table under docs/ and benchmarks/results/ was made from.

`docs/generated.json` holds one entry per generated file (path relative to the repository):

    {"command": "whisker cad sweep --radii 4..25:3 ...", "design_args": ["--set", "..."],
     "digest": "cafd80df421f42f0", "model": {"coil_turns": 370, "coil_resistance_ohm": 5.872, ...},
     "reduced": "radii every 3 mm instead of 1 mm" or null, "sha256": "..."}

`make docs` regenerates the files and stamps them (`python -m whisker.data.provenance stamp`); the
test tests/test_docs_current.py fails, naming the file and what differs, when a stamped file was
made from another design digest or other model numbers than today's, when a file changed after
it was stamped, or when a generated file has no stamp. The model numbers are the ones the
figures depend on, computed by the code that uses them (so a change of a model's code shows up,
not only a change of hw/sensor.toml).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

from whisker.files import atomic_write_text

ROOT = Path(__file__).resolve().parents[3]
MANIFEST = ROOT / "docs" / "generated.json"


#: the generated files (globs relative to the repository): every one must carry a current stamp
GENERATED = ("docs/images/**/*.png", "docs/images/**/*.jpg", "docs/images/**/*.csv", "docs/images/*.json", "docs/*_table.md",
             "docs/tracking_real.md",
             "benchmarks/results/*.md", "benchmarks/results/*.csv", "benchmarks/results/*.png",
             "benchmarks/results/*.json")


#: files matching GENERATED that no generator makes (photos, hand drawings), each with the reason: the
#: check lists them apart instead of asking for a stamp. Empty today -- every picture under docs/images is
#: rendered from the design (`make docs` names the generator of each; tests/test_docs_current.py checks that)
NOT_GENERATED: dict[str, str] = {}


def generated_files(root: Path = ROOT) -> list[str]:
    """The repository's generated figures and tables that exist now (relative paths, sorted), without
    the hand-made files of NOT_GENERATED."""
    out = set()
    for g in GENERATED:
        out |= {str(p.relative_to(root)) for p in root.glob(g) if p.is_file()}
    return sorted(out - set(NOT_GENERATED))


def model_numbers(design) -> dict:
    """The model numbers the docs' figures and tables depend on, for `design` (units in the names)."""
    from whisker.coil.driver import series_resistance_ohm
    from whisker.drive.guard import ThermalGuard, full_scale_voltage
    from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad

    guard = ThermalGuard(design)
    return {
        "whiskers": design.whiskers.count,
        "ring_radius_mm": design.whiskers.ring_radius,
        "coil_turns": design.coil.turns,
        "coil_resistance_ohm": round(float(design.coil.resistance), 4),
        "series_resistance_ohm": round(float(series_resistance_ohm(design)), 4),
        "full_scale_V": round(float(full_scale_voltage(design)), 4),
        "rotational_stiffness_Nmm_per_rad": round(design_stiffness_Nmm_per_rad(design), 4),   # "auto" resolved
        "guard_derate_from_C": round(float(guard.derate_from_C), 3),
        "guard_cut_C": round(float(guard.cut_C), 3),
        "mm_per_px": round(float(design.mm_per_px), 6),
    }


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _rel(path) -> str:
    p = Path(path).resolve()
    try:
        return str(p.relative_to(ROOT))
    except ValueError:
        raise ValueError(f"{path} is not inside the repository {ROOT}") from None


def load(manifest: Path = MANIFEST) -> dict:
    if not manifest.exists():
        return {}
    return json.loads(manifest.read_text())


def stamp(paths, command: str, design_args=(), reduced: str | None = None, manifest: Path = MANIFEST) -> dict:
    """Record that `paths` were just made by `command` from the design of `design_args`."""
    from whisker.design import load_design

    design_file, overrides = _split_args(design_args)
    d = load_design(design_file, overrides)
    data = load(manifest)
    entry = {"command": command, "design_args": list(design_args), "digest": d.digest(), "model": model_numbers(d),
             "reduced": reduced}
    for p in paths:
        p = Path(p)
        if not p.is_file():
            raise FileNotFoundError(f"provenance: {p} was not made (no such file)")
        data[_rel(p)] = {**entry, "sha256": sha256(p)}
    atomic_write_text(manifest, json.dumps(dict(sorted(data.items())), indent=1) + "\n")
    return data


def _split_args(args) -> tuple[str | None, tuple[str, ...]]:
    args = list(args)
    design_file, overrides = None, []
    i = 0
    while i < len(args):
        if args[i] == "--design":
            design_file = args[i + 1]
            i += 2
        elif args[i] == "--set":
            overrides.append(args[i + 1])
            i += 2
        else:
            raise ValueError(f"provenance: design arguments are --design FILE and --set K=V, got {args[i]!r}")
    return design_file, tuple(overrides)


def problems(manifest: Path = MANIFEST, expected=()) -> list[str]:
    """One line per generated file that is not current: missing stamp, changed after stamping,
    made from another design digest or other model numbers than today's (naming each number)."""
    from whisker.design import DesignError, load_design

    data = load(manifest)
    out = []
    for rel in expected:
        if rel not in data:
            out.append(f"{rel}: no provenance stamp (not made by `make docs`); regenerate it with `make docs`")
    today = {}
    for rel, e in sorted(data.items()):
        path = ROOT / rel
        if not path.is_file():
            out.append(f"{rel}: stamped in docs/generated.json but missing; regenerate it with `make docs`")
            continue
        if sha256(path) != e["sha256"]:
            out.append(f"{rel}: changed after it was stamped (sha256 differs): regenerate it with `make docs` "
                       f"rather than editing it")
        key = tuple(e.get("design_args", ()))
        if key not in today:
            try:
                design_file, overrides = _split_args(key)
                d = load_design(design_file, overrides)
                today[key] = (d.digest(), model_numbers(d))
            except (DesignError, ValueError, OSError) as err:
                today[key] = (None, {"error": str(err)})
        digest, model = today[key]
        if digest != e["digest"] or model != e["model"]:
            diff = [f"{k} {e['model'].get(k)} -> {model.get(k)}" for k in sorted(set(model) | set(e["model"]))
                    if e["model"].get(k) != model.get(k)]
            out.append(f"{rel}: made from design {e['digest']}, today's is {digest}"
                       + (f" ({'; '.join(diff)})" if diff else " (same model numbers: another design value changed)")
                       + f"; regenerate: {e['command']}")
    return out


def main(argv=None) -> int:
    """python -m whisker.data.provenance stamp --command CMD [--reduced TEXT] [--design F] [--set K=V] -- FILES
    python -m whisker.data.provenance check"""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m whisker.data.provenance")
    sub = ap.add_subparsers(dest="what", required=True)
    s = sub.add_parser("stamp", help="record how FILES were made")
    s.add_argument("--command", required=True, help="the command that made them")
    s.add_argument("--reduced", default=None, help="how the setting was reduced from the full one (if it was)")
    s.add_argument("--design", default=None, help="design TOML file the command used")
    s.add_argument("--set", action="append", default=[], help="design override the command used")
    s.add_argument("files", nargs="+")
    sub.add_parser("check", help="list the generated files that are not current")
    a = ap.parse_args(argv)
    if a.what == "stamp":
        args = (["--design", a.design] if a.design else []) + [x for kv in a.set for x in ("--set", kv)]
        try:
            stamp(a.files, a.command, args, a.reduced)
        except (FileNotFoundError, ValueError) as err:
            print(err, file=sys.stderr)
            return 2
        print(f"stamped {len(a.files)} file(s): {a.command}", file=sys.stderr)
        return 0
    bad = problems(expected=generated_files())
    for line in bad:
        print(line)
    for rel, why in sorted(NOT_GENERATED.items()):
        print(f"{rel}: not generated ({why}); no stamp needed", file=sys.stderr)
    print(f"{len(generated_files())} generated file(s), {len(bad)} problem(s), {len(NOT_GENERATED)} hand-made file(s)",
          file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
