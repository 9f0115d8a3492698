"""Both packages are layered one way (the design map, §1): no import cycles; `benchmark_adapter`
never imports `cocobench_agents` (nor an LLM library); every module imports only its own unit
and the layers below it; no module reaches into another subpackage's private names.

The import graph is read statically with `ast`, so every import counts: at module level,
inside functions, under `TYPE_CHECKING`, and in the lazy export tables (`_EXPORTS`) that a
package's `__init__` imports from on first use (PEP 562).
"""

from __future__ import annotations

import ast
import importlib.util
import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache

import pytest

from tests.source import PACKAGES, modules, nodes, syntax

# The layer tables: each row is a layer, the top one first; each entry a unit (a module or
# subpackage, named relative to its package; `__init__` is the package's own `__init__`). A
# module imports its own unit and the units of the rows below its own: never a row above, nor
# another unit of its own row.
LAYERS: dict[str, tuple[tuple[str, ...], ...]] = {
    "benchmark_adapter": (
        ("__init__",),
        ("generator",),  # scenes and templates → suites, through the gates
        ("validation", "invariants"),  # the placement, oracle and metric gates; the embedded
        # world's invariants checked over random play (it plays Episodes)
        ("oracles",),  # reference plans, run through an Episode
        ("episode",),
        ("scene_setup", "menu_bound"),  # menu_bound: Γ's longest in the embedded world
        ("skills", "goals", "menu", "trajectory", "metrics"),
        ("sim",),  # simulators ground task configs
        ("tasks",),
        ("vocabulary",),  # words several layers share: skills, observation modes, dimensions, …
    ),
    "cocobench_agents": (
        ("__init__", "cli"),  # the Python API's name list, the command: nothing imports them
        ("play",),  # the play page of human seats, served on the viewer's local server
        ("inspect_eval",),  # the Inspect task: the Python API's request, run by Inspect
        ("leaderboard",),  # verified runs as a static site, linking to the viewer's pages
        ("api", "viewer", "episode_graph", "export", "envs"),  # the other doors: none opens
        # onto another
        ("verify",),  # replays recorded runs and bundles in the embedded simulator
        ("reports",),  # reads run folders, and what their requests' settings are
        ("engine",),  # RunRequest → plan → run; imports no door
        ("harness",),
        ("runfolder",),  # the run folder's format: every reader of a run imports it
        ("episode_runner",),
        ("graphs",),  # planners never import the harness or the runner
        ("tools",),
        ("models", "prompts"),  # never import the graphs
        ("setting_kinds", "version", "lazy", "conditions", "partial_output", "rewards"),
        # conditions: `C0_image` names; partial_output: a new folder taken back on failure;
        # rewards: the training reward, for the environments and the export
    ),
}
#: Units that may import only some of the units below them (besides benchmark_adapter).
ONLY: dict[str, tuple[str, ...]] = {
    # the request's settings (engine.request), their kinds and the built-in models, the
    # condition codes; never the harness or the planners
    "cocobench_agents.reports": ("engine", "runfolder", "models", "setting_kinds",
                                 "conditions"),
}
#: What a part must never import, and why.
FORBIDDEN: dict[str, tuple[str, ...]] = {
    # the benchmark alone scores trajectories: no agents, no LLM, no LangGraph
    "benchmark_adapter": ("cocobench_agents", "langgraph", "langchain", "litellm", "openai"),
    # the engine emits events; only the doors draw them
    "cocobench_agents.engine": ("cocobench_agents.cli", "click", "rich"),
}


@dataclass(frozen=True)
class Import:
    importer: str  # a module of the packages
    line: int
    target: str  # a module of the packages, or the dotted name of an outside one
    name: str | None = None  # the attribute imported from `target` (`from target import name`)

    def __str__(self) -> str:
        what = f"{self.target}.{self.name}" if self.name else self.target
        return f"{self.importer} (line {self.line}) imports {what}"


# -- reading the packages --------------------------------------------------------------------



def is_package(module: str) -> bool:
    return modules()[module].name == "__init__.py"


def subpackage(module: str) -> str:
    return module if is_package(module) else module.rpartition(".")[0]


def ours(dotted: str) -> str | None:
    """The most specific module of the packages that `dotted` names, if any."""
    while dotted and dotted not in modules():
        dotted = dotted.rpartition(".")[0]
    return dotted or None


@cache
def imports() -> tuple[Import, ...]:
    return tuple(i for module in modules() for i in imports_of(module))


def imports_of(module: str) -> Iterator[Import]:
    for node in nodes(module):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield Import(module, node.lineno, ours(alias.name) or alias.name)
        elif isinstance(node, ast.ImportFrom):
            source = from_source(module, node)
            for alias in node.names:
                yield from_import(module, node.lineno, source, alias.name)
    yield from lazy_exports(module, syntax(module))


def from_source(module: str, node: ast.ImportFrom) -> str:
    """The absolute name of the module a `from … import` in `module` reads."""
    return importlib.util.resolve_name("." * node.level + (node.module or ""), subpackage(module))


def from_import(module: str, line: int, source: str, name: str) -> Import:
    submodule = f"{source}.{name}"
    if submodule in modules():
        return Import(module, line, submodule)
    return Import(module, line, ours(source) or source, name)


def lazy_exports(module: str, tree: ast.Module) -> Iterator[Import]:
    """The modules a package's `_EXPORTS` table (name → module) loads names from."""
    for node in tree.body:
        if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Dict)
                and any(isinstance(t, ast.Name) and t.id == "_EXPORTS" for t in node.targets)):
            for value in node.value.values:
                if isinstance(value, ast.Constant) and isinstance(value.value, str):
                    yield Import(module, value.lineno, export_module(module, value.value))


def export_module(package: str, text: str) -> str:
    if text.startswith("."):
        return importlib.util.resolve_name(text, package)
    return text if text in modules() else f"{package}.{text}"


def graph(package: str) -> dict[str, dict[str, Import]]:
    """Module → the modules of `package` it imports (with the first import of each)."""
    edges: dict[str, dict[str, Import]] = {m: {} for m in modules() if in_part(m, package)}
    for i in imports():
        if i.importer in edges and i.target in edges and i.target != i.importer:
            edges[i.importer].setdefault(i.target, i)
    return edges


def in_part(module: str, part: str) -> bool:
    return module == part or module.startswith(part + ".")


# -- (a) no cycles -----------------------------------------------------------------------------


def cycles(edges: dict[str, dict[str, Import]]) -> list[list[str]]:
    """One cycle (the modules around it) through each set of modules that import one another."""
    return [shortest_cycle(edges, group) for group in strongly_connected(edges) if len(group) > 1]


def strongly_connected(edges: dict[str, dict[str, Import]]) -> list[set[str]]:
    """Tarjan's algorithm: the sets of modules each reachable from every other."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[set[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for target in edges[module]:
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:  # the root of a group: pop the group off the stack
            group = {stack.pop()}
            while module not in group:
                group.add(stack.pop())
            groups.append(group)

    for module in sorted(edges):
        if module not in index:
            visit(module)
    return groups


def shortest_cycle(edges: dict[str, dict[str, Import]], group: set[str]) -> list[str]:
    start = min(group)
    paths = {start: [start]}
    frontier = [start]
    while frontier:
        module = frontier.pop(0)
        for target in sorted(edges[module]):
            if target == start:
                return [*paths[module], start]
            if target in group and target not in paths:
                paths[target] = [*paths[module], target]
                frontier.append(target)
    raise AssertionError(f"no cycle through {start}")  # a strongly connected group has one


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycles(package: str) -> None:
    edges = graph(package)
    found = ["\n  ".join(str(edges[a][b]) for a, b in itertools.pairwise(cycle))
             for cycle in cycles(edges)]
    assert not found, "import cycles:\n  " + "\n\n  ".join(found)


# -- (b) forbidden imports -----------------------------------------------------------------------


def test_no_part_imports_what_it_must_not() -> None:
    found = [f"{i}: {part} must not import {banned}"
             for part, banned_list in FORBIDDEN.items() for banned in banned_list
             for i in imports() if in_part(i.importer, part) and in_part(i.target, banned)]
    assert not found, "\n".join(found)


# -- (c) layers ------------------------------------------------------------------------------------


def unit(module: str) -> str:
    """The unit of the layer table `module` belongs to (fails for a module in no layer)."""
    package, _, relative = module.partition(".")
    relative = relative or "__init__"
    names = [u for row in LAYERS[package] for u in row if in_part(relative, u)]
    assert names, f"{module} is in no layer of {package}: add it to LAYERS"
    return max(names, key=len)


def row(package: str, name: str) -> int:
    return next(i for i, r in enumerate(LAYERS[package]) if name in r)


def layer_violation(i: Import) -> str | None:
    package = i.importer.partition(".")[0]
    if not in_part(i.target, package):
        return None  # across packages: test_no_part_imports_what_it_must_not
    here, there = unit(i.importer), unit(i.target)
    if here == there:
        return None
    allowed = ONLY.get(f"{package}.{here}")
    if allowed is not None and there not in allowed:
        return f"{i}: {here} may import only {', '.join(allowed)} of {package}"
    above = row(package, there) - row(package, here)
    if above > 0:
        return None
    where = "beside it" if above == 0 else "above it"
    return f"{i}: {here} may not import {there}, which is {where} in {package}'s layers"


def test_every_module_imports_only_the_layers_below_its_own() -> None:
    found = [v for i in imports() if i.target in modules() and (v := layer_violation(i))]
    assert not found, "\n".join(found)


def test_the_layer_tables_cover_every_module_and_name_no_other() -> None:
    for module in modules():
        unit(module)
    for package, rows in LAYERS.items():
        for name in (u for r in rows for u in r if u != "__init__"):
            assert ours(f"{package}.{name}") == f"{package}.{name}", f"no module {package}.{name}"


# -- (d) private names ---------------------------------------------------------------------------


def is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_uses(module: str) -> Iterator[str]:
    """`from M import _x`, and `m._x` on a module `m` bound by an import, where M (m) is a
    module of another subpackage than `module`'s."""
    found = tuple(imports_of(module))
    foreign = {i.target for i in found
               if i.target in modules() and subpackage(i.target) != subpackage(module)}
    for i in found:
        if i.target in foreign and i.name and is_private(i.name):
            yield f"{i} (private)"
    bound = {name: target for name, target in module_bindings(module) if target in foreign}
    for node in nodes(module):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in bound and is_private(node.attr)):
            yield (f"{module} (line {node.lineno}) uses {bound[node.value.id]}.{node.attr} "
                   "(private)")


def module_bindings(module: str) -> Iterator[tuple[str, str]]:
    """(local name, module) for each module of the packages an import binds to a name."""
    for node in nodes(module):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname and alias.name in modules():
                    yield alias.asname, alias.name
        elif isinstance(node, ast.ImportFrom):
            source = from_source(module, node)
            for alias in node.names:
                if f"{source}.{alias.name}" in modules():
                    yield alias.asname or alias.name, f"{source}.{alias.name}"


def test_no_module_uses_another_subpackages_private_names() -> None:
    found = [use for module in modules() for use in private_uses(module)]
    assert not found, "\n".join(found)
