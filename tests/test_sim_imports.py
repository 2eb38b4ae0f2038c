"""The simulator package's data flows one way: scene -> plan -> build -> step -> experiments.

The import graph of ``whisker.sim`` is read with ``ast`` (every import, at the top of a module or
inside a function: a lazy import is still a dependency) and must have no cycle; each module may import
only modules of its own layer or of layers below it (docs/sim.md, "Package layout").
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import whisker.sim

SIM = Path(whisker.sim.__file__).parent

#: lowest first; a module may import from its own layer and the layers before it
LAYERS = {
    "base": {"contract", "graph", "kinematics", "airflow", "contact_law", "result", "run"},
    "scene": {"scene", "materials", "meshes", "timeline", "protocol"},
    "plan": {"effects", "compliant"},
    "build": {"drive", "mj", "camera", "validate", "backend"},
    "step": {"simulate"},
    "experiments": {"experiments", "paper", "grasp_closed", "closed_loop", "state_sequences"},
    "app": {"runner", "__init__"},
}
RANK = {m: i for i, (_, mods) in enumerate(LAYERS.items()) for m in mods}


def _module_imports(path: Path) -> set[str]:
    """Names of the whisker.sim modules `path` imports (anywhere in the file)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module == "whisker.sim":
                out |= {a.name for a in node.names if (SIM / f"{a.name}.py").exists()}
                if not any((SIM / f"{a.name}.py").exists() for a in node.names):
                    out.add("__init__")
            elif node.module.startswith("whisker.sim."):
                out.add(node.module.split(".")[2])
        elif isinstance(node, ast.Import):
            out |= {a.name.split(".")[2] for a in node.names if a.name.startswith("whisker.sim.")}
    return out


def import_graph() -> dict[str, set[str]]:
    return {p.stem: _module_imports(p) - {p.stem} for p in sorted(SIM.glob("*.py"))}


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


def test_the_cycle_finder_finds_a_planted_cycle():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycle(g) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_whisker_sim_has_no_import_cycle():
    graph = import_graph()
    assert {"effects", "mj", "simulate", "paper"} <= set(graph)
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle in whisker.sim: " + " -> ".join(cycle)


def test_every_module_has_a_layer():
    missing = sorted(set(import_graph()) - set(RANK))
    assert not missing, f"whisker.sim modules without a layer in this test (add them to LAYERS): {missing}"


@pytest.mark.parametrize("module", sorted(RANK))
def test_imports_only_its_own_layer_or_below(module):
    if not (SIM / f"{module}.py").exists():
        pytest.skip(f"whisker/sim/{module}.py is not in this checkout")
    up = {n: next(k for k, v in LAYERS.items() if n in v) for n in import_graph()[module] if RANK[n] > RANK[module]}
    assert not up, f"{module} imports from layers above it: {up}"


def test_experiments_are_imported_by_nothing_below_them():
    graph = import_graph()
    top = LAYERS["experiments"]
    users = {m for m, deps in graph.items() if deps & top and RANK[m] < RANK["paper"]}
    assert not users, f"modules below the experiments import them: {sorted(users)}"
