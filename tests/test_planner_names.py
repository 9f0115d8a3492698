"""No built-in planner's name is written outside `cocobench_agents/graphs/`: the rest of the
package reads what a planner is from its `PlannerSpec` (its loop, prompt, broadcast, whether
it calls a model) or names it through the registry's constants (`DEFAULT_PLANNER`, `ORACLE`,
`NO_MODEL`), never by a literal of its own.

The rule, read from the source with `ast`: in every module of `cocobench_agents` outside
`graphs/`, no string constant equals a built-in planner's name (`PLANNERS`). Not counted:
docstrings (the first statement of a module, class or function) and comments, which explain;
the command line's help text (a `help=` argument under `cli/`), which lists the names for
people; and the few literals below that name something else that happens to share the word.
A name inside a longer string ("the oracle's plan") is prose, not a name, and is not counted.
`benchmark_adapter` is not read: it has no planners, and its "oracle" is the benchmark's
reference plan.
"""

from __future__ import annotations

import ast
from collections.abc import Set

from cocobench_agents.graphs import PLANNERS
from tests.source import ROOT, docstring_ids, docstrings, modules, syntax

PACKAGE = ROOT / "cocobench_agents"
GRAPHS = PACKAGE / "graphs"
NAMES = frozenset(PLANNERS)

#: (module, literal) pairs that name something other than a planner, and what.
OTHER_MEANINGS = {
    ("cocobench_agents/prompts/fields.py", "centralized"):
        "the team prompt's template in a prompt suite (a suite's file name)",
    ("cocobench_agents/prompts/render.py", "centralized"):
        "the team prompt's template in a prompt suite (a suite's file name)",
    ("cocobench_agents/models/builtin.py", "centralized"):
        "a script file's key for the team's replies (a file format users write)",
    ("cocobench_agents/reports/arms.py", "oracle"):
        "the oracle rows' model label (`graphs.NO_MODEL`): reports import run folders only",
}


def test_the_rule_counts_names_and_skips_docstrings_comments_and_help():
    source = '''"""The centralized planner's module docstring: "centralized"."""
import click
PLANNER = "leader-worker"  # a name of its own: counted
OPTION = click.option("--planner", help="oracle")  # help text, under cli/ only
def f():
    """oracle"""
    return "the oracle's plan"  # prose
'''
    tree = ast.parse(source)
    skipped = {id(node) for node in docstrings(tree)}
    assert names_in(tree, skipped, cli=False) == [(3, "leader-worker"), (4, "oracle")]
    assert names_in(tree, skipped, cli=True) == [(3, "leader-worker")]


def test_no_built_in_planner_is_named_outside_the_graphs():
    assert {"centralized", "decentralized", "decentralized-broadcast", "leader-worker",
            "oracle"} <= NAMES
    found, allowed = [], set()
    for dotted, path in modules().items():
        if PACKAGE not in path.parents or GRAPHS in path.parents:
            continue
        module = path.relative_to(ROOT).as_posix()
        cli = (PACKAGE / "cli") in path.parents
        for line, name in names_in(syntax(dotted), docstring_ids(dotted), cli=cli):
            if (module, name) in OTHER_MEANINGS:
                allowed.add((module, name))
            else:
                found.append(f"{module}:{line}: {name!r}")
    assert not found, ("built-in planner names outside graphs/ (read the PlannerSpec, or "
                       "import DEFAULT_PLANNER / ORACLE / NO_MODEL from cocobench_agents."
                       "graphs):\n" + "\n".join(found))
    assert allowed == set(OTHER_MEANINGS), "an exception no longer needed: remove it"


def names_in(tree: ast.Module, docstring_nodes: Set[int], *, cli: bool
             ) -> list[tuple[int, str]]:
    """(line, name) of every string constant of `tree` that is a built-in planner's name,
    its docstrings (the `id`s of their nodes) and (with `cli`) `help=` arguments left out."""
    skipped = set(docstring_nodes)
    if cli:
        skipped |= {id(node) for node in _help_text(tree)}
    return sorted((node.lineno, node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Constant) and isinstance(node.value, str)
                  and node.value in NAMES and id(node) not in skipped)


def _help_text(tree: ast.Module) -> list[ast.AST]:
    """Every node inside a `help=` keyword argument (click's help text, however built)."""
    return [inner for node in ast.walk(tree) if isinstance(node, ast.keyword)
            and node.arg == "help" for inner in ast.walk(node.value)]
