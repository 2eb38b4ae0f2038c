"""The package's data flows one way: its import graph, read from the code, has no cycle, and no module
imports a layer above its own (README, "Layout").

The graph is read with ``ast`` from every module of ``whisker`` (software/whisker), ``whisker.cad``
(hw/cad) and ``whisker.pcb`` (hw/pcb): every import, at the top of a module or inside a function (a lazy
import is still a dependency), and the module names that ``importlib.import_module`` is called with
(the simulator's contract loads its helpers that way). Imports under ``if TYPE_CHECKING:`` are type
hints only, never executed, and are left out. ``from pkg import name`` counts as an import of the
submodule ``pkg.name`` when there is one, else of the package ``pkg`` (its ``__init__``).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import whisker
import whisker.cad
import whisker.pcb

ROOTS = {"whisker": Path(whisker.__file__).parent, "whisker.cad": Path(whisker.cad.__file__).parent,
         "whisker.pcb": Path(whisker.pcb.__file__).parent}

#: Lowest first. A module may import modules of its own layer and of the layers below it. A layer is
#: named by module prefixes; the longest prefix that matches a module decides its layer.
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("base: errors, atomic files, shipped data, extras", ("whisker", "whisker.errors", "whisker.files",
                                                         "whisker.resources", "whisker.extras")),
    ("design: the design model and what sizes it", ("whisker.design",)),
    ("mechanics: the membrane from material data", ("whisker.mechanics",)),
    ("coil: winding, tilt, magnetics, heat, driver, kinematics", ("whisker.coil",)),
    ("drive: pins, backends, guard, actuator, sequences", ("whisker.drive",)),
    ("vision: sources, lens, render, tracking, geometry", ("whisker.vision",)),
    ("sensing: states, contact force, live, grasp control", ("whisker.sensing",)),
    ("sim: the scene simulator", ("whisker.sim",)),
    ("bringup: calibrations on the device", ("whisker.bringup",)),
    ("data: recordings, datasets, classification", ("whisker.data",)),
    ("cad: the printed and reference parts", ("whisker.cad",)),
    ("hardware: the driver board, the bill of materials", ("whisker.pcb", "whisker.bom", "whisker.part_measures",
                                                           "whisker.part_numbers")),
    ("explore: the design explorer", ("whisker.explore",)),
    ("interfaces: robot middleware", ("whisker.ros",)),
    ("cli: the command line", ("whisker.cli", "whisker.cliutil", "whisker.commands")),
]

#: Inside the simulator, lowest first (docs/sim.md, "Package layout").
SIM_LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("base", ("whisker.sim.contract", "whisker.sim.graph", "whisker.sim.effects.airflow",
              "whisker.sim.effects.contact_law", "whisker.sim.result", "whisker.sim.run")),
    ("scene", ("whisker.sim.scene", "whisker.sim.materials", "whisker.sim.meshes", "whisker.sim.protocol")),
    ("drive", ("whisker.sim.drive",)),
    ("plan", ("whisker.sim.effects",)),
    ("build", ("whisker.sim.mj", "whisker.sim.camera", "whisker.sim.validate")),
    ("step", ("whisker.sim.simulate",)),
    ("experiments", ("whisker.sim.experiments",)),
    ("app", ("whisker.sim", "whisker.sim.runner")),
]


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg, root in ROOTS.items():
        for p in root.rglob("*.py"):
            parts = list(p.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join([pkg, *parts])] = p
    return mods


MODULES = _modules()


def _resolve(current: str, node: ast.AST) -> set[str]:
    if isinstance(node, ast.Import):
        return {a.name for a in node.names if a.name in MODULES}
    if node.level:
        base = current.split(".")
        if MODULES[current].name != "__init__.py":
            base = base[:-1]
        base = base[:len(base) - (node.level - 1)]
        module = ".".join(base + ([node.module] if node.module else []))
    else:
        module = node.module or ""
    out = set()
    for a in node.names:
        if f"{module}.{a.name}" in MODULES:
            out.add(f"{module}.{a.name}")
        elif module in MODULES:
            out.add(module)
    return out


def _imports(name: str) -> set[str]:
    tree = ast.parse(MODULES[name].read_text(), str(MODULES[name]))
    type_only = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.If) and "TYPE_CHECKING" in ast.unparse(n.test):
            type_only |= {id(m) for m in ast.walk(n)}
    out = set()
    for n in ast.walk(tree):
        if id(n) in type_only:
            continue
        if isinstance(n, (ast.Import, ast.ImportFrom)):
            out |= _resolve(name, n)
        elif isinstance(n, ast.Constant) and isinstance(n.value, str) and re.fullmatch(r"whisker(\.\w+)+", n.value):
            if n.value in MODULES:  # importlib.import_module("whisker.x.y") and the like
                out.add(n.value)
    return out - {name}


def import_graph() -> dict[str, set[str]]:
    return {m: _imports(m) for m in sorted(MODULES)}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of `graph` as a list of modules (first == last), or None (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (c := visit(n)):
                return c
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (c := visit(m)):
            return c
    return None


def layer_of(module: str, layers=LAYERS) -> int | None:
    best = None
    for i, (_, prefixes) in enumerate(layers):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and (best is None or len(p) > best[1]):
                best = (i, len(p))
    return None if best is None else best[0]


def upward_imports(graph, layers=LAYERS) -> list[str]:
    out = []
    for a, deps in graph.items():
        la = layer_of(a, layers)
        if la is None:
            continue
        for b in sorted(deps):
            lb = layer_of(b, layers)
            if lb is not None and lb > la:
                out.append(f"{a} ({layers[la][0].split(':')[0]}) imports {b} ({layers[lb][0].split(':')[0]})")
    return out


GRAPH = import_graph()


def test_the_cycle_finder_finds_a_planted_cycle():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycle(g) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_the_layer_check_finds_a_planted_upward_import():
    g = {"whisker.design.model": {"whisker.sim.scene"}, "whisker.sim.scene": {"whisker.design.model"}}
    assert upward_imports(g) == ["whisker.design.model (design) imports whisker.sim.scene (sim)"]


def test_the_graph_sees_lazy_type_only_and_string_imports():
    # a lazy import inside a function counts, a TYPE_CHECKING import does not, a module named in a string does
    assert "whisker.design.sizing" in GRAPH["whisker.design.model"]
    assert "whisker.design.model" not in GRAPH["whisker.design.sizing"]
    assert "whisker.coil.magnetics" in GRAPH["whisker.sim.contract"]


def test_the_package_has_no_import_cycle():
    assert len(GRAPH) > 100
    cycle = find_cycle(GRAPH)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_every_module_has_a_layer():
    missing = sorted(m for m in GRAPH if layer_of(m) is None)
    assert not missing, f"modules without a layer in this test (add them to LAYERS): {missing}"


def test_no_module_imports_a_layer_above_its_own():
    up = upward_imports(GRAPH)
    assert not up, "upward imports:\n" + "\n".join(up)


def test_inside_the_simulator_data_flows_one_way():
    sim = {m: {d for d in deps if d.startswith("whisker.sim")} for m, deps in GRAPH.items() if m.startswith("whisker.sim")}
    missing = sorted(m for m in sim if layer_of(m, SIM_LAYERS) is None)
    assert not missing, f"whisker.sim modules without a layer in SIM_LAYERS: {missing}"
    up = upward_imports(sim, SIM_LAYERS)
    assert not up, "upward imports inside whisker.sim:\n" + "\n".join(up)


@pytest.mark.parametrize("folder", sorted({p.parent for root in ROOTS.values() for p in root.rglob("*.py")}),
                         ids=lambda p: str(p.relative_to(ROOTS["whisker"].parents[2])))
def test_no_folder_holds_more_than_about_fifteen_modules(folder):
    n = len(list(folder.glob("*.py")))
    assert n <= 16, f"{folder} holds {n} modules: split it into subpackages by what they hold"
