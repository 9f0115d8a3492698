"""Prompt suites: versioned sets of text templates, plus named ablation variants.

A suite is a folder of `.txt` templates with `{named}` fields and a `suite.json`. A suite spec
names a suite and, optionally, variants joined with `+`: `cocobench-v1+no-hint+no-history`.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

DEFAULT_SUITE = "cocobench-v1"

# Each variant switches one prompt section off (an ablation of what the planner is told).
VARIANTS = {
    "no-progress": "drop the live GOAL PROGRESS block",
    "no-hint": "drop the coordination hint (RESOURCE / RELAY CONSTRAINT)",
    "no-history": "drop the recent-actions history",
}


class PromptSuiteError(ValueError):
    """An unknown suite or variant name."""


@dataclass(frozen=True)
class PromptSuite:
    """Loaded templates of one suite and the variants applied to it."""

    name: str
    version: str
    templates: dict[str, str]
    variants: frozenset[str] = frozenset()
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def spec(self) -> str:
        """The spec string that reloads exactly this suite (recorded in run metadata)."""
        return "+".join([self.name, *sorted(self.variants)])

    def template(self, key: str) -> str:
        """One template's text."""
        return self.templates[key]

    def setting(self, key: str, default: int) -> int:
        """A numeric setting from suite.json (history window, etc.)."""
        return int(self.settings.get(key, default))


def available_suites() -> list[str]:
    """Names of the prompt suites shipped with the package."""
    root = resources.files(__package__) / "templates"
    return sorted(p.name for p in root.iterdir() if p.is_dir() and (p / "suite.json").is_file())


def load_prompt_suite(spec: str = DEFAULT_SUITE) -> PromptSuite:
    """Load `name[+variant…]`; unknown names raise `PromptSuiteError` listing the known ones."""
    name, *variants = spec.split("+")
    if name not in available_suites():
        raise PromptSuiteError(f"unknown prompt suite {name!r} (available: "
                               f"{', '.join(available_suites())})")
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise PromptSuiteError(f"unknown prompt variant {unknown[0]!r} (available: "
                               f"{', '.join(VARIANTS)})")
    meta, templates = _read_suite(name)
    return PromptSuite(name=name, version=str(meta.get("version", "")),
                       templates=dict(templates), variants=frozenset(variants),
                       settings=dict(meta))


@functools.cache
def _read_suite(name: str) -> tuple[dict[str, Any], dict[str, str]]:
    """suite.json and the templates of a shipped suite, read once per process (every
    episode loads its suite)."""
    folder = resources.files(__package__) / "templates" / name
    meta = json.loads((folder / "suite.json").read_text(encoding="utf-8"))
    templates = {p.name.removesuffix(".txt"): p.read_text(encoding="utf-8")
                 for p in folder.iterdir() if p.name.endswith(".txt")}
    return meta, templates
