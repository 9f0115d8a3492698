"""Configs built in Python (not through the loader's checks) still end cleanly: an empty menu
is the `no_actions` terminal, not a crash; a missing budget ends on the largest budget."""

from __future__ import annotations

import asyncio

import pytest

from benchmark_adapter.tasks import TaskConfig, load_tasks
from benchmark_adapter.tasks.checks import MAX_STEP_BUDGET
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.models import ModelPool


def _config(**changes) -> TaskConfig:
    data = load_tasks("demo")[1].model_dump()
    for agent in data["agents"]:
        agent.update(changes)
    return TaskConfig.model_validate(data)


@pytest.mark.parametrize("planner", ["centralized", "decentralized", "leader-worker"])
def test_an_empty_menu_ends_the_episode_as_no_actions(planner):
    config = _config(allowed_skills=["NoSuchSkill"])
    _document, result = asyncio.run(run_episode(EpisodeSpec(config, planner=planner,
                                                           max_steps=3), ModelPool()))
    assert result.terminal_reason == "no_actions"
    assert result.num_steps == 0


def test_a_config_without_a_budget_gets_the_largest_one():
    data = load_tasks("demo")[1].model_dump()
    data["difficulty"] = {k: v for k, v in (data.get("difficulty") or {}).items()
                          if k != "step_budget"}
    data["step_budget"] = None
    spec = EpisodeSpec(TaskConfig.model_validate(data))
    assert spec.budget == MAX_STEP_BUDGET
