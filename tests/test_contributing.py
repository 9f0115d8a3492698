"""docs/contributing.md stays true: every file it names exists, and every definition it
points a contributor to is where it says."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "contributing.md"

#: (module, name) for each definition the guide sends a contributor to.
DEFINITIONS = [
    ("benchmark_adapter.vocabulary", "ObservationMode"),
    ("benchmark_adapter.vocabulary", "OBSERVATION_MODES"),
    ("benchmark_adapter.vocabulary", "Dimension"),
    ("benchmark_adapter.vocabulary", "DIMENSIONS"),
    ("benchmark_adapter.vocabulary", "PRODUCER_CONSUMER"),
    ("benchmark_adapter.metrics.constructs", "_DIMS"),
    ("benchmark_adapter.metrics.constructs", "_MECHANISMS"),
    ("cocobench_agents.prompts.fields", "view_template"),
    ("cocobench_agents.viewer.signals", "TITLES"),
    ("cocobench_agents.viewer.signals", "EVENT_COUNTERS"),
    ("cocobench_agents.viewer.signals", "_DRAW"),
    ("cocobench_agents.viewer.pages", "FORMULAS"),
    ("cocobench_agents.graphs.registry", "PLANNERS"),
    ("cocobench_agents.graphs.registry", "PlannerSpec"),
    ("cocobench_agents.harness.executor", "Executor"),
    ("cocobench_agents.harness.executors", "EXECUTORS"),
    ("cocobench_agents.harness.execution_settings", "ExecutorName"),
    ("cocobench_agents.harness.execution_settings", "ExecutionSettings"),
    ("cocobench_agents.models.remote", "RemoteClient"),
    ("cocobench_agents.models.settings", "TRANSPORTS"),
    ("cocobench_agents.models.settings", "ENDPOINT_TRANSPORTS"),
    ("cocobench_agents.models.settings", "ModelSettings"),
    ("cocobench_agents.models.pool", "_REMOTE_CLIENTS"),
    ("cocobench_agents.setting_kinds", "shaping"),
    ("cocobench_agents.setting_kinds", "run_setting"),
    ("cocobench_agents.engine.request", "RunRequest"),
    ("cocobench_agents.engine.request", "Limits"),
    ("cocobench_agents.cli.request_options", "request_option"),
    ("cocobench_agents.episode_runner", "EpisodeSpec"),
]


def _named_paths() -> list[str]:
    """Every `path` in backticks that names a file or folder of the repository (one with a
    slash, no placeholder)."""
    found = re.findall(r"`([A-Za-z0-9_./-]+/[A-Za-z0-9_./-]*)`", GUIDE.read_text())
    return sorted({p for p in found if "<" not in p})


@pytest.mark.parametrize("path", _named_paths())
def test_every_named_file_exists(path):
    assert (ROOT / path).exists() or (ROOT / "cocobench_agents" / path).exists(), path


@pytest.mark.parametrize(("module", "name"), DEFINITIONS)
def test_every_definition_is_where_the_guide_says(module, name):
    text = GUIDE.read_text()
    assert f"`{name}`" in text or name in text, f"the guide no longer names {name}"
    assert hasattr(importlib.import_module(module), name), f"{module} has no {name}"


def test_the_guide_names_a_path_for_each_definition_module():
    text = GUIDE.read_text()
    for module, _ in DEFINITIONS:
        assert module.replace(".", "/") + ".py" in text or \
            module.split(".", 1)[1].replace(".", "/") + ".py" in text, module
