"""One vocabulary (issue 27): the words several layers share — observation modes, coordination
dimensions, backend names, built-in suite names — are spelled in one module,
`benchmark_adapter/vocabulary.py`, and every other module imports them; condition names
(`C0_image`) are written and read by `cocobench_agents/conditions.py` alone. So adding an
observation mode or a dimension is a change of that definition plus the code that gives it a
meaning (a template, a metric), which the last tests here name.

The rules the source test applies, read with `ast` over every module of both packages (not
bench/ or examples/: they use the packages as a user does, and bench/harness.py must also run
against an older tree):

* Every string constant in code counts, the literal parts of f-strings included; docstrings
  (the first statement of a module, class or function) and comments do not.
* A constant spells a word when it *is* the word (``"image"``, ``"D1"``, ``"ai2thor"``,
  ``"cocobench-240"``). An observation mode is also spelled by a name-like constant (no
  whitespace) that ends in ``_<mode>``: a condition name ``C0_image``, or its suffix
  ``_image``. Other names that contain the letters are words of their own: a task type's
  code ``K_D3``, OpenAI's ``image_url`` field.
* Prose (a constant with whitespace: help text, error messages) is for people and is not
  read; where it lists the words, the code builds it from the tuples so that it stays true.
* `ALLOWED` lists the other spellings, each with its reason: the same letters with another
  meaning (a record's field, a package's name). An entry that no longer matches fails too.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from functools import cache

import pytest

from benchmark_adapter.vocabulary import (
    BACKEND_NAMES,
    BUILTIN_SUITES,
    DIMENSIONS,
    OBSERVATION_MODES,
)
from tests.source import docstring_ids, modules, nodes

HOME = "benchmark_adapter.vocabulary"
WORDS = (*OBSERVATION_MODES, *DIMENSIONS, *BACKEND_NAMES, *BUILTIN_SUITES)

#: (module, word) → why that module may spell it.
ALLOWED: dict[tuple[str, str], str] = {
    # "D1" is also the condition code of decentralized-broadcast, which its PlannerSpec
    # declares (the one definition of the planners' codes).
    ("cocobench_agents.graphs.registry", "D1"):
        "the decentralized-broadcast planner's own condition code",
    # The trajectory's per-step `image` field (a saved frame), not the observation mode.
    ("benchmark_adapter.episode", "image"): "writes the trajectory item's `image` field",
    ("cocobench_agents.viewer.export", "image"): "reads the trajectory item's `image` field",
    ("cocobench_agents.viewer.timeline", "image"): "reads the trajectory item's `image` field",
    ("cocobench_agents.export.decisions", "image"): "reads the trajectory item's `image` field",
    ("cocobench_agents.export.columns", "image"): "names the dataset's `image` column",
    # `ai2thor` as the name of the Python package (imported, its version looked up), not the
    # backend.
    ("benchmark_adapter.sim.thor.loader", "ai2thor"): "imports the ai2thor package",
    ("benchmark_adapter.generator.thor", "ai2thor"): "imports the ai2thor package",
    ("cocobench_agents.engine.records", "ai2thor"): "records the ai2thor package's version",
    ("cocobench_agents.cli.doctor_cmd", "ai2thor"): "checks the ai2thor package's install",
}


def spelled(text: str) -> Iterator[str]:
    """The vocabulary words a string constant spells (the module docstring's rules)."""
    if text in WORDS:
        yield text
    elif not any(c.isspace() for c in text):
        yield from (mode for mode in OBSERVATION_MODES if text.endswith(f"_{mode}"))


@cache
def spellings() -> dict[tuple[str, str], tuple[int, ...]]:
    """(module, word) → the lines where a module other than the vocabulary spells the word."""
    found: dict[tuple[str, str], list[int]] = {}
    for module in modules():
        if module == HOME:
            continue
        skip = docstring_ids(module)
        for node in nodes(module):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and id(node) not in skip:
                for word in spelled(node.value):
                    found.setdefault((module, word), []).append(node.lineno)
    return {key: tuple(lines) for key, lines in found.items()}


def test_each_word_is_spelled_in_the_vocabulary_only():
    found = spellings()
    stray = [f"{module}:{lines[0]} spells {word!r}: import it from {HOME}"
             for (module, word), lines in sorted(found.items()) if (module, word) not in ALLOWED]
    assert not stray, "\n".join(stray)


def test_every_exemption_is_still_needed():
    stale = sorted(set(ALLOWED) - set(spellings()))
    assert not stale, f"remove these ALLOWED entries, they match nothing now: {stale}"


@pytest.mark.parametrize("text, words", [
    ("image", ["image"]), ("C0_image", ["image"]), ("_blind", ["blind"]),
    ("leader-worker_blind", ["blind"]), ("D1", ["D1"]), ("K_D3", []), ("ai2thor", ["ai2thor"]),
    ("image_url", []), ("save_image_per_frame", []),
    ("data:image/png;base64,", []), ("an image, for a text-only model", []),
    ("accepts_images", []), ("cocobench-240", ["cocobench-240"]),
])
def test_the_rules_read_constants_as_documented(text, words):
    assert list(spelled(text)) == words


# -- what gives each word its meaning: adding one is the definition plus these ---------------


def test_the_built_in_suites_are_the_shipped_folders():
    from benchmark_adapter.tasks import available_suites

    assert sorted(BUILTIN_SUITES) == sorted(available_suites())


def test_every_observation_mode_has_its_view_templates():
    from cocobench_agents.prompts import load_prompt_suite
    from cocobench_agents.prompts.fields import TEMPLATE_FIELDS, view_template

    suite = load_prompt_suite()
    for mode in OBSERVATION_MODES:
        for prompt in ("centralized", "distributed"):
            assert view_template(mode, prompt) in TEMPLATE_FIELDS
            assert view_template(mode, prompt) in suite.templates


def test_every_dimension_has_its_construct_and_views():
    from benchmark_adapter.metrics import cross_construct_scores
    from cocobench_agents.viewer.pages import FORMULAS
    from cocobench_agents.viewer.signals import TITLES

    assert list(FORMULAS) == list(TITLES) == list(DIMENSIONS)
    traj = {"task_config": {"coordination_dim": DIMENSIONS[0]}, "trajectory": []}
    assert list(cross_construct_scores(traj)) == list(DIMENSIONS)


def test_every_backend_has_its_controller():
    from benchmark_adapter.sim.backends import BACKENDS

    assert list(BACKENDS) == list(BACKEND_NAMES)
