"""Reading the packages' own source, for the tests that check it (layers, vocabulary, planner
names, the team's seat): every module by name, its syntax tree and nodes (parsed once per test
process, shared by those tests: a parse of both packages is about a second), and the
docstrings a rule about literals leaves aside."""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("benchmark_adapter", "cocobench_agents")


@cache
def modules() -> dict[str, Path]:
    """Every module of both packages by dotted name (a package by its own name)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


@cache
def syntax(module: str) -> ast.Module:
    """The syntax tree of `module` (a dotted name of `modules()`); read-only, shared."""
    path = modules()[module]
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


@cache
def nodes(module: str) -> tuple[ast.AST, ...]:
    """Every node of `module`'s tree, in `ast.walk`'s order."""
    return tuple(ast.walk(syntax(module)))


def docstrings(tree: ast.Module) -> list[ast.Constant]:
    """The docstring constants of a module and of its classes and functions."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.body[0] if node.body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.append(first.value)
    return out


@cache
def docstring_ids(module: str) -> frozenset[int]:
    """The `id`s of `module`'s docstring constants (nodes of its shared `syntax` tree)."""
    return frozenset(id(node) for node in docstrings(syntax(module)))
